"""Read back a packing SVG: the container and the placed copies, as written.

The writer is :func:`repulsionpak.render.svg.write_packing_svg`. Structure (the output
contract)::

    <svg xmlns=... width=.. height=.. viewBox=.. data-gap="5.2" [data-partial="true"] data-*=...>
      <metadata>{"partial": false, ...}</metadata>
      <g id="container" data-source="heart.svg">
        the container as ``container_paint`` draws it: its region's outline
        (``<path class="container-outline" fill="none" stroke=...>``, the default), its own
        shapes in their original styles (``as-drawn``), or nothing (``none``)
        <path class="container-region" fill="none" stroke="none" fill-rule="evenodd" d="..."/>
      </g>
      <g id="elements">
        <g class="element primary" data-source="cat.svg" data-deformation="0.0123"> <path .../> ... </g>
        <g class="element secondary" ...> ... </g>
      </g>
      <g id="debug-NAME" style="display:none"> ... </g>
    </svg>

The invisible ``container-region`` path stores the exact region (holes included) so
:func:`read_packing_svg` gets the container back however it was drawn (a
``container-outline`` is not read as the container's own drawing). Output is
deterministic and written atomically.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..types import ArtPath, Container, PlacedArt
from .files import MAX_POINTS, PointBudget, guard, read_input_bytes
from .regions import finalize_region, rings_to_region
from .svg_container import container_from_shapes
from .svg_flatten import default_tolerance, flatten_shape, shape_bounds
from .svg_shapes import parse_svg_shapes
from .svg_xml import local_name

__all__ = ["read_packing_svg"]


def _art_paths(path, shapes, tol: float, budget) -> list[ArtPath]:
    """Each shape flattened within ``tol`` as one :class:`ArtPath` (shapes that flatten to
    nothing are left out)."""
    arts = []
    for sh in shapes:
        subs = flatten_shape(path, sh, tol, budget)
        if subs:
            arts.append(ArtPath(tuple(q for q, _ in subs), tuple(c for _, c in subs), sh.style))
    return arts


def _classes(attrs: dict) -> set[str]:
    return set(str(attrs.get("class") or "").split())


def read_packing_svg(path: str | Path) -> tuple[Container, list[PlacedArt], dict]:
    """Read a packing SVG written by :func:`write_packing_svg`.

    Returns ``(container, placed, info)``; ``info`` holds the root ``data-*``
    attributes without the prefix (``gap`` as float or None, ``partial`` as bool, the
    others as strings) and ``metadata`` (the parsed ``<metadata>`` JSON, or None).
    Element groups are the ``<g>`` with class ``element`` and ``primary`` or
    ``secondary``. Raises InputError for unusable files.
    """
    p = Path(path)
    with guard(p, "packing SVG"):
        data = read_input_bytes(p, "packing SVG")
        doc = parse_svg_shapes(p, data)
        info: dict = {}
        for k, v in doc.root_attrs.items():
            if isinstance(k, str) and k.startswith("data-"):
                info[k[5:]] = v
        if "gap" in info:
            try:
                info["gap"] = float(info["gap"])
            except ValueError:
                raise InputError(
                    p,
                    f"data-gap={info['gap']!r} is not a number; fix it or pass the gap explicitly",
                ) from None
        else:
            info["gap"] = None
        meta = None
        if doc.metadata_text:
            try:
                meta = json.loads(doc.metadata_text)
            except ValueError:
                meta = None
        info["metadata"] = meta
        if "partial" in info:
            info["partial"] = str(info["partial"]).strip().lower() == "true"
        else:
            info["partial"] = (
                bool(meta.get("partial", False)) if isinstance(meta, dict) else False
            )

        container_shapes, region_shapes = [], []
        container_attrs = None
        groups: dict[int, tuple[dict, list]] = {}
        for sh in doc.shapes:
            cont = next((g for g in sh.groups if g.get("id") == "container"), None)
            if cont is not None:
                container_attrs = cont
                classes = _classes(sh.attrs)
                if "container-region" in classes:
                    region_shapes.append(sh)
                elif sh.style.visible and "container-outline" not in classes:
                    container_shapes.append(sh)
                continue
            grp = next(
                (
                    g
                    for g in reversed(sh.groups)
                    if "element" in _classes(g)
                    and _classes(g) & {"primary", "secondary"}
                ),
                None,
            )
            if grp is None or not sh.style.visible:
                continue
            groups.setdefault(id(grp), (grp, []))[1].append(sh)
        if container_attrs is None:
            there = doc.xml is not None and any(
                local_name(el.tag) == "g" and el.get("id") == "container"
                for el in doc.xml.iter())
            raise InputError(
                p,
                'its <g id="container"> draws nothing; the container outline is needed to measure the packing'
                if there else ('has no <g id="container">; it is not a packing written by repulsionpak (an '
                             'element file? `evaluate --elements` takes one file: repeat it for more)'),
            )

        everything = (
            container_shapes
            + region_shapes
            + [s for _, shs in groups.values() for s in shs]
        )
        # the art is written as curves: flatten them 10× finer than an input file, so the
        # metrics of a packing read back agree with those of the placed art (< 1e-4)
        tol = 0.1 * default_tolerance(shape_bounds(everything))
        budget = PointBudget(p, limit=10 * MAX_POINTS)
        source = container_attrs.get("data-source") or p.name
        if region_shapes:
            rings = []
            for sh in region_shapes:
                rings.extend(
                    pts for pts, _ in flatten_shape(p, sh, tol, budget) if len(pts) >= 3
                )
            region = finalize_region(p, rings_to_region(rings, "evenodd", p))
            container = Container(
                source=source,
                region=region,
                paths=tuple(_art_paths(p, container_shapes, tol, budget)),
                svg_root=dict(doc.svg_root),
            )
        else:
            c = container_from_shapes(p, container_shapes, tol, budget, doc.svg_root)
            container = Container(
                source=source, region=c.region, paths=c.paths, svg_root=c.svg_root
            )

        placed = []
        for grp, shapes in groups.values():
            cls = _classes(grp)
            kind = "primary" if "primary" in cls else "secondary"
            # small copies (pocket fillers) are flattened relative to their own size too
            b = shape_bounds(shapes)
            size = float(np.hypot(b[2] - b[0], b[3] - b[1])) if b is not None else 0.0
            el_tol = min(tol, 1e-4 * size) if size > 0 else tol
            arts = _art_paths(p, shapes, el_tol, budget)
            deformation = grp.get("data-deformation")
            try:
                deformation = float(deformation) if deformation is not None else None
            except ValueError:
                deformation = None
            placed.append(
                PlacedArt(
                    source=str(grp.get("data-source") or ""),
                    kind=kind,
                    paths=tuple(arts),
                    stroke_scale=1.0,
                    deformation=deformation,
                    pinned=grp.get("data-pinned") == "true",
                )
            )
        return container, placed, info
