"""Write (and read back) the packing SVG.

Structure (see DESIGN.md, "Contracts")::

    <svg xmlns=... width=.. height=.. viewBox=.. data-gap="5.2" [data-partial="true"] data-*=...>
      <metadata>{"partial": false, ...}</metadata>
      <g id="container" data-source="heart.svg">
        container outlines (original styles) ...
        <path class="container-region" fill="none" stroke="none" fill-rule="evenodd" d="..."/>
      </g>
      <g id="elements">
        <g class="element primary" data-source="cat.svg" data-deformation="0.0123"> <path .../> ... </g>
        <g class="element secondary" ...> ... </g>
      </g>
      <g id="debug-NAME" style="display:none"> ... </g>
    </svg>

The invisible ``container-region`` path stores the exact region (holes included) so
:func:`read_packing_svg` gets the container back even when its outlines were drawn as
separate shapes. Output is deterministic and written atomically.
"""

from __future__ import annotations

import json
import math
import os
import re
import tempfile
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import numpy as np
import shapely

from ..errors import InputError, OutputError
from ..types import ArtPath, Container, PlacedArt, Style
from . import svg_read
from .svg_read import (
    PointBudget,
    container_from_shapes,
    default_tolerance,
    finalize_region,
    flatten_shape,
    guard,
    parse_svg_shapes,
    read_input_bytes,
    rings_to_region,
    shape_bounds,
)

__all__ = [
    "atomic_write_bytes",
    "format_number",
    "packing_svg_string",
    "read_packing_svg",
    "write_packing_svg",
]

SVG_NS = "http://www.w3.org/2000/svg"
_DEFAULT_STYLE = Style()
_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_.-]*$")


# --------------------------------------------------------------------------- files


def _file_mode(path: Path) -> int:
    """The mode a new file would get (0666 & ~umask), or the mode of the file replaced."""
    try:
        return path.stat().st_mode & 0o777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically: temp file in the same directory, fsync,
    ``os.replace``. OutputError if the directory is missing or not writable."""
    p = Path(path)
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise OutputError(
            f"{p}: the output directory {parent} does not exist; create it first"
        )
    if p.is_dir():
        raise OutputError(f"{p}: is a directory; give a file name for the output")
    tmp_name = None
    try:
        fd, tmp_name = tempfile.mkstemp(dir=parent, prefix=f".{p.name}.", suffix=".tmp")
        os.chmod(tmp_name, _file_mode(p))  # mkstemp makes 0600; outputs get the usual mode
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp_name, p)
        tmp_name = None
    except OSError as exc:
        raise OutputError(
            f"{p}: cannot write the output ({exc.strerror or exc}); check the directory permissions"
        ) from None
    finally:
        if tmp_name is not None:
            try:
                os.unlink(tmp_name)
            except OSError:
                pass
    try:  # make the rename durable; not possible everywhere (e.g. Windows)
        dfd = os.open(parent, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)
    except OSError:
        pass


# --------------------------------------------------------------------------- formatting


def format_number(x: float, decimals: int = 4) -> str:
    """Fixed-point with up to ``decimals`` decimals, no trailing zeros, no ``-0``."""
    s = f"{float(x):.{decimals}f}"
    if "." in s:
        s = s.rstrip("0").rstrip(".")
    if s in ("-0", "", "-"):
        s = "0"
    return s


def _fmt_g(x: float) -> str:
    s = format(float(x), ".6g")
    return "0" if s == "-0" else s


def _path_d(subpaths, closed) -> str:
    parts = []
    for pts, cl in zip(subpaths, closed):
        pts = np.asarray(pts, dtype=float)
        if len(pts) == 0:
            continue
        coords = [f"{format_number(x)} {format_number(y)}" for x, y in pts]
        s = "M " + coords[0]
        if len(coords) > 1:
            s += " L " + " L ".join(coords[1:])
        if cl:
            s += " Z"
        parts.append(s)
    return " ".join(parts)


def _check_finite(path, subpaths, what: str) -> None:
    for pts in subpaths:
        if not np.all(np.isfinite(np.asarray(pts, dtype=float))):
            raise OutputError(
                f"{path}: {what} has non-finite coordinates (NaN or infinity); nothing was written"
            )


def _style_attrs(style: Style, stroke_scale: float = 1.0) -> list[tuple[str, str]]:
    """Presentation attributes differing from the SVG defaults."""
    out: list[tuple[str, str]] = []
    if style.fill != _DEFAULT_STYLE.fill:
        out.append(("fill", style.fill if style.fill is not None else "none"))
    if style.stroke is not None:
        out.append(("stroke", style.stroke))
        sw = float(style.stroke_width) * float(stroke_scale)
        if sw != 1.0:
            out.append(("stroke-width", _fmt_g(sw)))
    if style.opacity != 1.0:
        out.append(("opacity", _fmt_g(style.opacity)))
    if style.fill is not None and style.fill_opacity != 1.0:
        out.append(("fill-opacity", _fmt_g(style.fill_opacity)))
    if style.stroke is not None and style.stroke_opacity != 1.0:
        out.append(("stroke-opacity", _fmt_g(style.stroke_opacity)))
    if style.fill_rule != "nonzero":
        out.append(("fill-rule", style.fill_rule))
    if style.stroke is not None and style.stroke_linecap != "butt":
        out.append(("stroke-linecap", style.stroke_linecap))
    if style.stroke is not None and style.stroke_linejoin != "miter":
        out.append(("stroke-linejoin", style.stroke_linejoin))
    return out


def _attrs(pairs) -> str:
    return "".join(f" {k}={quoteattr(str(v))}" for k, v in pairs)


def _art_path_xml(art: ArtPath, stroke_scale: float, indent: str) -> str | None:
    d = _path_d(art.subpaths, art.closed)
    if not d:
        return None
    return f"{indent}<path{_attrs(_style_attrs(art.style, stroke_scale))} d={quoteattr(d)}/>"


def _region_rings(region) -> tuple[list[np.ndarray], list[bool]]:
    rings = []
    for poly in shapely.get_parts(region):
        if not isinstance(poly, shapely.Polygon) or poly.is_empty:
            continue
        for ring in [poly.exterior, *poly.interiors]:
            pts = np.asarray(ring.coords, dtype=float)[:-1]
            if len(pts) >= 3:
                rings.append(pts)
    return rings, [True] * len(rings)


def _json_safe(obj):
    if isinstance(obj, dict):
        return {str(k): _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _json_safe(obj.tolist())
    if isinstance(obj, np.generic):
        return _json_safe(obj.item())
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if obj is None or isinstance(obj, (bool, int, str)):
        return obj
    if isinstance(obj, Path):
        return str(obj)
    return str(obj)


def _view(container: Container) -> list[tuple[str, str]]:
    root = dict(container.svg_root or {})
    out = []
    if (
        root.get("viewBox") is None
        and root.get("width") is None
        and root.get("height") is None
    ):
        x0, y0, x1, y1 = container.bounds
        w, h = x1 - x0, y1 - y0
        m = 0.02 * max(w, h) if max(w, h) > 0 else 1.0
        vb = [x0 - m, y0 - m, w + 2 * m, h + 2 * m]
        out.append(("width", format_number(vb[2])))
        out.append(("height", format_number(vb[3])))
        out.append(("viewBox", " ".join(format_number(v) for v in vb)))
        return out
    for key in ("width", "height", "viewBox"):
        if root.get(key) is not None:
            out.append((key, str(root[key])))
    return out


def packing_svg_string(
    container: Container,
    placed: list[PlacedArt],
    gap: float,
    attrs: dict[str, str] | None = None,
    debug_layers: dict[str, list[np.ndarray]] | None = None,
    partial: bool = False,
    metadata: dict | None = None,
    path: str | Path = "<output>",
) -> str:
    """The packing SVG as a string (see module docstring); deterministic."""
    gap = float(gap)
    root_attrs = [("xmlns", SVG_NS), *_view(container), ("data-gap", repr(gap))]
    if partial:
        root_attrs.append(("data-partial", "true"))
    for key, value in (attrs or {}).items():
        name = str(key)
        name = name if name.startswith("data-") else f"data-{name}"
        if not _NAME_RE.match(name) or name in ("data-gap", "data-partial"):
            raise ValueError(
                f"attrs key {key!r} cannot be written as an SVG data-* attribute"
            )
        root_attrs.append((name, str(value)))
    lines = ['<?xml version="1.0" encoding="UTF-8"?>', f"<svg{_attrs(root_attrs)}>"]

    meta = {"partial": bool(partial)}
    meta.update(_json_safe(dict(metadata or {})))
    meta["partial"] = bool(partial)
    lines.append(
        f"  <metadata>{escape(json.dumps(meta, sort_keys=True, separators=(', ', ': ')))}</metadata>"
    )

    # container
    lines.append(f'  <g id="container"{_attrs([("data-source", container.source)])}>')
    x0, y0, x1, y1 = container.bounds
    diag = math.hypot(x1 - x0, y1 - y0) or 1.0
    for art in container.paths:
        _check_finite(path, art.subpaths, "the container")
        line = _art_path_xml(art, 1.0, "    ")
        if line:
            lines.append(line)
    rings, closed = _region_rings(container.region)
    _check_finite(path, rings, "the container region")
    region_d = _path_d(rings, closed)
    if not container.paths and region_d:
        lines.append(
            f'    <path class="container-outline" fill="none" stroke="#000000" stroke-width="{_fmt_g(diag / 1000)}" fill-rule="evenodd" d={quoteattr(region_d)}/>'
        )
    if region_d:
        lines.append(
            f'    <path class="container-region" fill="none" stroke="none" fill-rule="evenodd" d={quoteattr(region_d)}/>'
        )
    lines.append("  </g>")

    # elements
    lines.append('  <g id="elements">')
    for pa in placed:
        kind = str(pa.kind)
        if kind not in ("primary", "secondary"):
            raise ValueError(
                f"PlacedArt.kind must be 'primary' or 'secondary', got {kind!r}"
            )
        g = [("class", f"element {kind}"), ("data-source", pa.source)]
        if pa.deformation is not None:
            g.append(("data-deformation", repr(float(pa.deformation))))
        lines.append(f"    <g{_attrs(g)}>")
        for art in pa.paths:
            _check_finite(path, art.subpaths, f"element {pa.source}")
            line = _art_path_xml(art, pa.stroke_scale, "      ")
            if line:
                lines.append(line)
        lines.append("    </g>")
    lines.append("  </g>")

    # debug layers
    for name, polys in (debug_layers or {}).items():
        safe = re.sub(r"[^A-Za-z0-9_.-]", "_", str(name))
        lines.append(f'  <g id={quoteattr("debug-" + safe)} style="display:none">')
        arrays = [np.asarray(p, dtype=float).reshape(-1, 2) for p in polys]
        arrays = [a for a in arrays if len(a) >= 2 and np.all(np.isfinite(a))]
        if arrays:
            d = _path_d(arrays, [len(a) >= 3 for a in arrays])
            lines.append(
                f'    <path fill="none" stroke="#0077ff" stroke-width="{_fmt_g(diag / 2000)}" d={quoteattr(d)}/>'
            )
        lines.append("  </g>")
    lines.append("</svg>")
    return "\n".join(lines) + "\n"


def write_packing_svg(
    path: str | Path,
    container: Container,
    placed: list[PlacedArt],
    gap: float,
    attrs: dict[str, str] | None = None,
    debug_layers: dict[str, list[np.ndarray]] | None = None,
    partial: bool = False,
    metadata: dict | None = None,
) -> None:
    """Write the packing as SVG in the container's coordinate system (atomic, deterministic).

    ``gap`` goes to ``data-gap``; ``attrs`` become further root ``data-*`` attributes;
    ``debug_layers`` maps a layer name to polygons ((K, 2) arrays) drawn in hidden
    groups; ``partial`` marks an interrupted run (``data-partial="true"``);
    ``metadata`` is stored as JSON in ``<metadata>``. Raises OutputError if the
    directory does not exist or the file cannot be written.
    """
    text = packing_svg_string(
        container, placed, gap, attrs, debug_layers, partial, metadata, path=path
    )
    atomic_write_bytes(path, text.encode("utf-8"))


# --------------------------------------------------------------------------- reading back


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
            raise InputError(
                p,
                'has no <g id="container">; it is not a packing written by repulsionpak',
            )

        everything = (
            container_shapes
            + region_shapes
            + [s for _, shs in groups.values() for s in shs]
        )
        tol = default_tolerance(shape_bounds(everything))
        budget = PointBudget(p, limit=10 * svg_read.MAX_POINTS)
        source = container_attrs.get("data-source") or p.name
        if region_shapes:
            rings = []
            for sh in region_shapes:
                rings.extend(
                    pts for pts, _ in flatten_shape(p, sh, tol, budget) if len(pts) >= 3
                )
            region = finalize_region(p, rings_to_region(rings, "evenodd", p))
            arts = []
            for sh in container_shapes:
                subs = flatten_shape(p, sh, tol, budget)
                if subs:
                    arts.append(
                        ArtPath(
                            tuple(q for q, _ in subs),
                            tuple(c for _, c in subs),
                            sh.style,
                        )
                    )
            container = Container(
                source=source,
                region=region,
                paths=tuple(arts),
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
            arts = []
            for sh in shapes:
                subs = flatten_shape(p, sh, tol, budget)
                if subs:
                    arts.append(
                        ArtPath(
                            tuple(q for q, _ in subs),
                            tuple(c for _, c in subs),
                            sh.style,
                        )
                    )
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
                )
            )
        return container, placed, info
