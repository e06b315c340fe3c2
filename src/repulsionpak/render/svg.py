"""Write the packing SVG: the container (an outline by default), every copy's art as smooth curves.

Structure (the output contract; docs/evaluation.md describes how it is read)::

    <svg xmlns=... width=.. height=.. viewBox=.. data-gap="5.2" [data-partial="true"] data-*=...>
      <metadata>{"partial": false, ...}</metadata>
      <g id="container" data-source="heart.svg">
        container_paint "outline" (default): the region's exact outline, stroke only
          <path class="container-outline" fill="none" stroke=.. stroke-width=.. d="..."/>
        container_paint "as-drawn": [<defs> its gradients and patterns </defs>] the
          container's own shapes (<circle>, <path> ...) with their attributes and composed
          transforms, exactly as drawn
        container_paint "none": nothing drawn
        <path class="container-region" fill="none" stroke="none" fill-rule="evenodd" d="..."/>
      </g>
      <g id="elements">
        <g class="element primary" data-source="cat.svg" data-deformation="0.0123">
          [<defs> this copy's gradients and patterns, ids suffixed -eK </defs>]
          <path d="m..c..q..l..z" fill=... /> ...
        </g>
        <g class="element secondary" ...> ... </g>
      </g>
      <g id="debug-NAME" style="display:none"> ... </g>
    </svg>

The invisible ``container-region`` path stores the exact region (holes included) so
:func:`~repulsionpak.io.svg_packing.read_packing_svg` gets the container back however it is
drawn. The root's page attributes are the container file's, its viewBox grown where the
drawing reaches past it (:func:`~repulsionpak.render.frame.packing_frame`). Placed art with curves (``ArtPath.source``) is
written as those curves (compact relative path data); art without them as polylines.
Output is deterministic and written atomically.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path

import numpy as np
import shapely

from ..errors import OutputError
from ..geometry.curves import decimals_for, path_data
from ..io.files import atomic_write_bytes
from ..types import ArtPath, Container, PlacedArt, Style
from .container_paint import check_paint, outline_colour, outline_width
from .frame import packing_frame
from .numbers import format_number
from .paint import CopyPaint, matrix_attr

__all__ = ["container_lines", "packing_svg_string", "write_packing_svg"]

SVG_NS = "http://www.w3.org/2000/svg"
_DEFAULT_STYLE = Style()
_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_.-]*$")
_RESERVED_IDS = {"container", "elements"}


def escape(data: str) -> str:
    """``xml.sax.saxutils.escape(data)``: ``&``, ``>`` and ``<`` as entities.

    Notes
    -----
    The same replacements, in the same order, as the standard library's; written here
    because importing ``xml.sax.saxutils`` imports ``urllib.request`` and with it
    ``http.client`` and ``email`` (~15 ms of every run's start-up) for two string
    functions (``tests/test_render_output.py`` checks they agree).
    """
    return data.replace("&", "&amp;").replace(">", "&gt;").replace("<", "&lt;")


def quoteattr(data: str) -> str:
    """``xml.sax.saxutils.quoteattr(data)``: ``data`` escaped (:func:`escape`, and
    newline, carriage return and tab as character references) and quoted, with ``"``
    when it holds none, else ``'`` when it holds none of those, else ``"`` with ``"`` as
    ``&quot;``."""
    data = escape(data).replace("\n", "&#10;").replace("\r", "&#13;").replace("\t", "&#9;")
    if '"' in data:
        if "'" in data:
            return '"%s"' % data.replace('"', "&quot;")
        return "'%s'" % data
    return '"%s"' % data


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


def _style_attrs(style: Style, stroke_scale: float = 1.0, fill_url: str | None = None,
                 stroke_url: str | None = None) -> list[tuple[str, str]]:
    """Presentation attributes differing from the SVG defaults (``fill_url``/``stroke_url``:
    a paint server replacing the fallback colour)."""
    out: list[tuple[str, str]] = []
    if fill_url is not None and style.fill is not None:
        out.append(("fill", fill_url))
    elif style.fill != _DEFAULT_STYLE.fill:
        out.append(("fill", style.fill if style.fill is not None else "none"))
    if style.stroke is not None:
        out.append(("stroke", stroke_url if stroke_url is not None else style.stroke))
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
    if style.stroke is not None and style.stroke_miterlimit != 4.0:
        out.append(("stroke-miterlimit", _fmt_g(style.stroke_miterlimit)))
    if style.stroke is not None and style.stroke_dasharray:
        k = float(stroke_scale)
        out.append(("stroke-dasharray", " ".join(_fmt_g(d * k) for d in style.stroke_dasharray)))
        if style.stroke_dashoffset != 0.0:
            out.append(("stroke-dashoffset", _fmt_g(style.stroke_dashoffset * k)))
    if style.stroke is not None and style.fill is not None and style.paint_order != "normal":
        out.append(("paint-order", style.paint_order))
    return out


def _attrs(pairs) -> str:
    return "".join(f" {k}={quoteattr(str(v))}" for k, v in pairs)


def _unique(ident: str, ids: set | None) -> str | None:
    """``ident`` the first time the document uses it, else None (the shapes a ``<use>``
    clones carry the id of what they clone: written once, XML ids stay unique)."""
    if ids is None:
        return ident
    if ident in ids:
        return None
    ids.add(ident)
    return ident


def _art_path_xml(art: ArtPath, stroke_scale: float, indent: str,
                  paint: CopyPaint | None = None, suffix: str = "", decimals: int = 6,
                  ids: set | None = None) -> str | None:
    """One ``<path>``: the art's curves when it has them, else its polylines. ``ids``: the
    ids written so far (a repeated one is left out)."""
    src = art.source
    if src is not None and src.curves:
        d = path_data(src.curves, decimals=decimals)
    else:
        d = _path_d(art.subpaths, art.closed)
    if not d:
        return None
    fill_url = stroke_url = None
    if paint is not None and src is not None:
        fill_url = paint.paint(src.fill_paint, src.matrix, src.local_bbox)
        stroke_url = paint.paint(src.stroke_paint, src.matrix, src.local_bbox)
    attrs = []
    if src is not None and src.id and suffix and _unique(src.id + suffix, ids):
        attrs.append(("id", src.id + suffix))
    style = art.style
    if style.layers:  # the enclosing <g opacity> carry the groups' share (see _layered)
        groups = math.prod(op for _, op in style.layers)
        style = dataclasses.replace(style, opacity=style.opacity / groups if groups > 0 else 0.0)
    attrs += _style_attrs(style, stroke_scale, fill_url, stroke_url)
    return f"{indent}<path{_attrs(attrs)} d={quoteattr(d)}/>"


def _layered(items: list[tuple[tuple, str]], indent: str) -> list[str]:
    """Lines of ``(layers, path line)`` items (in drawing order) with each run of paths
    that share a translucent group wrapped in ``<g opacity>``, nested as in the source:
    shapes overlapping inside it then compose as one layer."""
    out, open_ = [], ()
    for layers, line in items:
        common = 0
        while common < min(len(open_), len(layers)) and open_[common] == layers[common]:
            common += 1
        for depth in range(len(open_), common, -1):
            out.append(indent + "  " * (depth - 1) + "</g>")
        for depth in range(common, len(layers)):
            out.append(indent + "  " * depth + f'<g opacity="{_fmt_g(layers[depth][1])}">')
        out.append("  " * len(layers) + line)
        open_ = layers
    for depth in range(len(open_), 0, -1):
        out.append(indent + "  " * (depth - 1) + "</g>")
    return out


def _container_shape_xml(art: ArtPath, indent: str, ids: set | None = None) -> str | None:
    """A container shape as drawn: its own tag, attributes and composed transform."""
    src = art.source
    if src is None or not src.tag:
        return _art_path_xml(art, 1.0, indent)
    attrs = []
    if (src.id and src.id not in _RESERVED_IDS and not src.id.startswith("debug-")
            and _unique(src.id, ids)):
        attrs.append(("id", src.id))
    attrs += list(src.attrs)
    m = np.asarray(src.matrix, dtype=float)
    if not np.allclose(m, np.eye(3), rtol=0, atol=1e-12):
        if not np.all(np.isfinite(m)):
            return _art_path_xml(art, 1.0, indent)
        attrs.append(("transform", matrix_attr(m)))
    return f"{indent}<{src.tag}{_attrs(attrs)}/>"


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


def container_lines(container: Container, container_paint: str, stroke_width: float,
                    ids: set | None = None, rings=None, indent: str = "  ") -> list[str]:
    """The ``<g id="container">`` of the output, as lines.

    ``container_paint``: ``"outline"`` (the region's outline, ``stroke_width`` wide, in
    :func:`~repulsionpak.render.container_paint.outline_colour`), ``"as-drawn"`` (the
    container's own shapes and paint servers; a container without shapes gets a black
    outline of 1/1000 of its diagonal) or ``"none"``; always followed by the invisible
    ``container-region`` path. ``ids``: the ids written so far (updated).
    """
    rings, closed = rings if rings is not None else _region_rings(container.region)
    region_d = _path_d(rings, closed)
    inner = indent + "  "
    lines = [f'{indent}<g id="container"{_attrs([("data-source", container.source)])}>']
    if container_paint == "as-drawn":
        servers = getattr(container, "paint_servers", None) or {}
        if servers:
            lines.append(f"{inner}<defs>" + "".join(servers[k] for k in sorted(servers)) + "</defs>")
        for art in container.paths:
            line = _container_shape_xml(art, inner, ids)
            if line:
                lines.append(line)
        if not container.paths and region_d:
            x0, y0, x1, y1 = container.bounds
            diag = math.hypot(x1 - x0, y1 - y0) or 1.0
            lines.append(
                f'{inner}<path class="container-outline" fill="none" stroke="#000000" stroke-width="{_fmt_g(diag / 1000)}" fill-rule="evenodd" d={quoteattr(region_d)}/>'
            )
    elif container_paint == "outline" and region_d:
        lines.append(
            f'{inner}<path class="container-outline" fill="none" stroke="{outline_colour(container)}" '
            f'stroke-width="{_fmt_g(stroke_width)}" stroke-linejoin="round" fill-rule="evenodd" d={quoteattr(region_d)}/>'
        )
    if region_d:
        lines.append(
            f'{inner}<path class="container-region" fill="none" stroke="none" fill-rule="evenodd" d={quoteattr(region_d)}/>'
        )
    lines.append(f"{indent}</g>")
    return lines


def packing_svg_string(
    container: Container,
    placed: list[PlacedArt],
    gap: float,
    attrs: dict[str, str] | None = None,
    debug_layers: dict[str, list[np.ndarray]] | None = None,
    partial: bool = False,
    metadata: dict | None = None,
    path: str | Path = "<output>",
    container_paint: str = "outline",
) -> str:
    """The packing SVG as a string (see module docstring); deterministic.

    ``container_paint``: ``"outline"`` (the container's region as a thin stroke, no
    fill), ``"as-drawn"`` (its own shapes and paint) or ``"none"`` (only the invisible
    region). ``path`` only names the output in error messages.
    """
    gap = float(gap)
    check_paint(container_paint)
    for pa in placed:  # before anything measures the art
        for art in pa.paths:
            _check_finite(path, art.subpaths, f"element {pa.source}")
            if art.source is not None:
                _check_finite(path, [c.ctrl.reshape(-1, 2) for c in art.source.curves],
                              f"element {pa.source}")
    for art in container.paths:
        _check_finite(path, art.subpaths, "the container")
    rings, closed = _region_rings(container.region)
    _check_finite(path, rings, "the container region")
    stroke_w = outline_width(container, gap)
    frame = packing_frame(container, placed, container_paint, stroke_w)
    root_attrs = [("xmlns", SVG_NS), *frame.root_attrs, ("data-gap", repr(gap))]
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

    # container: drawn as container_paint says, then its exact region (invisible)
    ids: set[str] = set()  # the shapes' ids written so far
    lines.extend(container_lines(container, container_paint, stroke_w, ids, rings=(rings, closed)))
    x0, y0, x1, y1 = container.bounds
    diag = math.hypot(x1 - x0, y1 - y0) or 1.0

    # elements
    lines.append('  <g id="elements">')
    for index, pa in enumerate(placed):
        kind = str(pa.kind)
        if kind not in ("primary", "secondary"):
            raise ValueError(
                f"PlacedArt.kind must be 'primary' or 'secondary', got {kind!r}"
            )
        g = [("class", f"element {kind}"), ("data-source", pa.source)]
        if pa.deformation is not None:
            g.append(("data-deformation", repr(float(pa.deformation))))
        if getattr(pa, "pinned", False):
            g.append(("data-pinned", "true"))
        lines.append(f"    <g{_attrs(g)}>")
        suffix = f"-e{index + 1}"
        paint = CopyPaint(getattr(pa, "paint_servers", None) or {}, suffix)
        tol = getattr(pa, "tolerance", None)
        decimals = decimals_for(tol) if tol else 6
        body = []
        for art in pa.paths:
            line = _art_path_xml(art, pa.stroke_scale, "      ", paint, suffix, decimals, ids)
            if line:
                body.append((art.style.layers, line))
        defs = paint.defs()
        if defs:
            lines.append("      <defs>" + "".join(defs) + "</defs>")
        lines.extend(_layered(body, "      "))
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
    container_paint: str = "outline",
) -> None:
    """Write the packing as SVG in the container's coordinate system (atomic, deterministic).

    ``gap`` goes to ``data-gap``; ``attrs`` become further root ``data-*`` attributes;
    ``debug_layers`` maps a layer name to polygons ((K, 2) arrays) drawn in hidden
    groups; ``partial`` marks an interrupted run (``data-partial="true"``);
    ``metadata`` is stored as JSON in ``<metadata>``; ``container_paint`` is
    ``"outline"``, ``"as-drawn"`` or ``"none"`` (see :func:`packing_svg_string`). Raises
    OutputError if the directory does not exist or the file cannot be written.
    """
    text = packing_svg_string(
        container, placed, gap, attrs, debug_layers, partial, metadata, path=path,
        container_paint=container_paint,
    )
    atomic_write_bytes(path, text.encode("utf-8"))

