"""Curve-level data of SVG shapes, read beside their flattened outlines.

The simulation works on flattened polylines (:func:`.svg_read.flatten_shape`); the
renderer needs more: every shape's exact segments (lines, quadratic and cubic Béziers,
arcs as cubics) to map them through the deformation and fit smooth curves again, the
shape's own markup (tag, geometry and presentation attributes, composed transform) so the
container is written as drawn, and the gradients and patterns it is painted with.

``shape_source(path, shape) -> ShapeSource | None`` and
``paint_servers(path, xml_root, arts) -> {id: markup}`` are called by the readers.
"""

from __future__ import annotations

import copy
import math
import re
import xml.etree.ElementTree as ET

import numpy as np

from ..geometry.curves import path_data
from ..types import CurveSubpath, ShapeSource

__all__ = ["arc_to_cubics", "curves_bbox", "paint_servers", "segments_to_curves", "shape_source"]

SVG_NS = "http://www.w3.org/2000/svg"
XLINK_NS = "http://www.w3.org/1999/xlink"

#: geometry attributes of each basic shape, written back as they were
GEOMETRY_ATTRS = {
    "circle": ("cx", "cy", "r"),
    "ellipse": ("cx", "cy", "rx", "ry"),
    "rect": ("x", "y", "width", "height", "rx", "ry"),
    "line": ("x1", "y1", "x2", "y2"),
    "polygon": ("points",),
    "polyline": ("points",),
    "path": ("d",),
}
#: presentation properties taken from the resolved (inherited, CSS) values
PRESENTATION = (
    "fill", "fill-opacity", "fill-rule", "stroke", "stroke-width", "stroke-opacity",
    "stroke-linecap", "stroke-linejoin", "stroke-miterlimit", "stroke-dasharray",
    "stroke-dashoffset", "vector-effect", "paint-order",
)
_PAINT_TAGS = {"linearGradient", "radialGradient", "pattern"}
_URL = re.compile(r"url\(\s*['\"]?#([^)'\"]+)['\"]?\s*\)")


# --------------------------------------------------------------------------- segments


def arc_to_cubics(center, u, v, theta0: float, sweep: float) -> np.ndarray:
    """Cubic Béziers (k, 4, 2) of the elliptical arc c + u cos θ + v sin θ for θ from
    ``theta0`` over ``sweep`` radians, in pieces of at most 45° (radial error below
    1e-5 of the radius)."""
    c, u, v = (np.asarray(a, dtype=float) for a in (center, u, v))
    n = max(1, math.ceil(abs(sweep) / (math.pi / 4) - 1e-9))
    th = theta0 + sweep * np.linspace(0.0, 1.0, n + 1)
    a, b = th[:-1, None], th[1:, None]
    k = 4.0 / 3.0 * np.tan((b - a) / 4.0)
    p0 = c + np.cos(a) * u + np.sin(a) * v
    p3 = c + np.cos(b) * u + np.sin(b) * v
    d0 = -np.sin(a) * u + np.cos(a) * v
    d3 = -np.sin(b) * u + np.cos(b) * v
    return np.stack([p0, p0 + k * d0, p3 - k * d3, p3], axis=1)


def _pt(p) -> np.ndarray:
    return np.array([float(p[0]), float(p[1])])


def _xy(p) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))


def _moved(a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Whether points ``a`` and ``b`` differ (False when a coordinate is NaN, as
    ``np.abs(b - a).max() > 0`` says)."""
    dx, dy = abs(b[0] - a[0]), abs(b[1] - a[1])
    return (dx > 0 or dy > 0) and dx == dx and dy == dy


def segments_to_curves(segments, matrix: np.ndarray | None = None) -> tuple[CurveSubpath, ...]:
    """svgelements segments (local coordinates) -> curve subpaths under ``matrix``.

    Zero-length lines are dropped, ``Z`` adds an explicit closing line when the pen is
    away from the start, subpaths without a segment are dropped. Non-finite input gives
    an empty tuple (the flattened outline reports the error).

    Notes
    -----
    A traced drawing has thousands of segments: each is kept as a row of 8 Python floats
    (its 4 control points) and a subpath becomes an array once, at its end.
    """
    import svgelements as se

    out: list[CurveSubpath] = []
    order: list[int] = []
    rows: list[tuple[float, ...]] = []
    start = cur = None

    def flush(closed: bool):
        nonlocal order, rows
        if order:
            c = np.array(rows, dtype=float).reshape(-1, 4, 2)
            if matrix is not None:
                c = c @ matrix[:2, :2].T + matrix[:2, 2]
            if np.all(np.isfinite(c)):
                out.append(CurveSubpath(np.array(order), c, closed))
        order, rows = [], []

    def add(o: int, *pts: tuple[float, float]):
        nonlocal cur
        end = pts[-1]
        rows.append((*pts[0], *(pts[1] if o > 1 else end), *(pts[2] if o > 2 else end), *end))
        order.append(o)
        cur = end

    for seg in segments:
        if isinstance(seg, se.Move):
            flush(False)
            start = cur = None if seg.end is None else _xy(seg.end)
            continue
        if isinstance(seg, se.Close):
            if start is not None and cur is not None and _moved(cur, start):
                add(1, cur, start)
            flush(True)
            cur = start
            continue
        if getattr(seg, "start", None) is None or seg.end is None:
            continue
        p0 = _xy(seg.start) if cur is None else cur
        if start is None:
            start = p0
        end = _xy(seg.end)
        if isinstance(seg, se.Linear):
            if _moved(p0, end):
                add(1, p0, end)
        elif isinstance(seg, se.QuadraticBezier):
            add(2, p0, _xy(seg.control), end)
        elif isinstance(seg, se.CubicBezier):
            add(3, p0, _xy(seg.control1), _xy(seg.control2), end)
        elif isinstance(seg, se.Arc):
            if seg.center is None or seg.prx is None or seg.pry is None or not seg.sweep:
                if _moved(p0, end):
                    add(1, p0, end)
                continue
            c = _pt(seg.center)
            cubics = arc_to_cubics(c, _pt(seg.prx) - c, _pt(seg.pry) - c,
                                   float(seg.get_start_t()), float(seg.sweep))
            cubics[0, 0], cubics[-1, -1] = p0, end
            for cb in cubics.tolist():
                add(3, *map(tuple, cb))
        elif _moved(p0, end):
            add(1, p0, end)
    flush(False)
    return tuple(out)


def _bezier_extrema(ctrl: np.ndarray, order: int) -> np.ndarray:
    """Points of one segment where x or y is extreme (end points included)."""
    p = ctrl[: order + 1]
    ts = [0.0, 1.0]
    if order == 2:
        d = p[0] - 2 * p[1] + p[2]
        for k in range(2):
            if abs(d[k]) > 1e-300:
                ts.append((p[0, k] - p[1, k]) / d[k])
    elif order == 3:
        for k in range(2):
            a = -p[0, k] + 3 * p[1, k] - 3 * p[2, k] + p[3, k]
            b = 2 * (p[0, k] - 2 * p[1, k] + p[2, k])
            c = p[1, k] - p[0, k]
            if abs(a) > 1e-12 * (abs(b) + abs(c) + 1e-300):
                disc = b * b - 4 * a * c
                if disc >= 0:
                    r = math.sqrt(disc)
                    ts += [(-b + r) / (2 * a), (-b - r) / (2 * a)]
            elif abs(b) > 1e-300:
                ts.append(-c / b)
    t = np.clip(np.array([x for x in ts if -1e-12 <= x <= 1 + 1e-12]), 0.0, 1.0)[:, None]
    s = 1 - t
    if order == 1:
        return s * p[0] + t * p[1]
    if order == 2:
        return s * s * p[0] + 2 * s * t * p[1] + t * t * p[2]
    return s**3 * p[0] + 3 * s * s * t * p[1] + 3 * s * t * t * p[2] + t**3 * p[3]


def _line_ends(ctrl: np.ndarray) -> np.ndarray:
    """(n, 2, 2): :func:`_bezier_extrema` of n line segments at once (their end points,
    computed as it computes them, so the same numbers to the bit)."""
    t = np.array([[0.0], [1.0]])
    s = 1 - t
    return s * ctrl[:, None, 0] + t * ctrl[:, None, 1]


def curves_bbox(curves) -> tuple[float, float, float, float] | None:
    """Exact bounding box (x0, y0, x1, y1) of curve subpaths, None when empty.

    Notes
    -----
    Drawings are mostly lines (a traced animal: ~1,700 of them): their end points are
    taken a subpath at a time (:func:`_line_ends`), the curves' extrema one by one; the
    points are gathered in segment order either way.
    """
    pts = []
    for sp in curves:
        order = np.asarray(sp.order)
        ctrl = np.asarray(sp.ctrl, dtype=float)
        line = order == 1
        ends = _line_ends(ctrl[line]) if line.any() else None
        if line.all():
            pts.append(ends.reshape(-1, 2))
            continue
        at = np.cumsum(line) - 1  # each line's row in ends
        pts += [ends[at[k]] if o == 1 else _bezier_extrema(ctrl[k], o) for k, o in enumerate(order.tolist())]
    if not pts:
        return None
    a = np.concatenate(pts)
    return (float(a[:, 0].min()), float(a[:, 1].min()), float(a[:, 0].max()), float(a[:, 1].max()))


# --------------------------------------------------------------------------- shapes


def _tag(sh) -> str:
    tag = str(sh.attrs.get("tag") or "")
    if tag in GEOMETRY_ATTRS:
        return tag
    import svgelements as se

    for cls, name in ((se.Circle, "circle"), (se.Ellipse, "ellipse"), (se.Rect, "rect"),
                      (se.SimpleLine, "line"), (se.Polygon, "polygon"), (se.Polyline, "polyline")):
        if isinstance(sh.node, cls):
            return name
    return "path"


def _paint_id(value) -> str | None:
    m = _URL.search(str(value or ""))
    return m.group(1) if m else None


def shape_source(path, sh) -> ShapeSource | None:
    """Curves (user units), markup and paint references of one parsed shape."""
    local = segments_to_curves(sh.segments)
    if not local:
        return None
    matrix = np.asarray(sh.matrix, dtype=float)
    curves = tuple(c.transformed(matrix) for c in local)
    tag = _tag(sh)
    own = sh.attrs
    values = getattr(sh.node, "values", None) or {}
    attrs: list[tuple[str, str]] = []
    if all(own.get(k) is not None for k in GEOMETRY_ATTRS[tag] if k not in ("rx", "ry")):
        attrs += [(k, str(own[k])) for k in GEOMETRY_ATTRS[tag] if own.get(k) is not None]
    else:  # geometry we cannot restate (e.g. a shape svgelements made): its path data
        tag = "path"
        attrs.append(("d", path_data(local, decimals=6)))
    for k in PRESENTATION:
        v = values.get(k)
        if v is not None and str(v).strip() and k != "stroke-width":
            attrs.append((k, str(v).strip()))
    sw = values.get("stroke-width")
    if sw is not None and str(values.get("stroke", "none")).strip() != "none":
        attrs.append(("stroke-width", str(sw).strip()))
    if sh.style.opacity != 1.0:
        attrs.append(("opacity", format(sh.style.opacity, ".6g")))
    return ShapeSource(
        curves=curves,
        tag=tag,
        attrs=tuple(attrs),
        matrix=matrix,
        fill_paint=_paint_id(values.get("fill")),
        stroke_paint=_paint_id(values.get("stroke")),
        local_bbox=curves_bbox(local),
        id=str(own["id"]) if own.get("id") else None,
    )


# --------------------------------------------------------------------------- paint servers


def _local(tag) -> str:
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) and tag.startswith("{") else str(tag)


def _href(el) -> str | None:
    ref = el.get(f"{{{XLINK_NS}}}href") or el.get("href")
    return ref[1:] if ref and ref.startswith("#") else None


def _strip_ns(el: ET.Element) -> ET.Element:
    """Deep copy of ``el`` with plain tag and attribute names (SVG/xlink namespaces dropped)."""
    out = copy.deepcopy(el)
    for e in out.iter():
        e.tag = _local(e.tag)
        for k in list(e.attrib):
            if k.startswith("{"):
                v = e.attrib.pop(k)
                name = _local(k)
                if name == "href" or k.startswith(f"{{{SVG_NS}}}"):
                    e.set(name, v)
    return out


def _resolved_server(el: ET.Element, ids: dict) -> ET.Element:
    """A paint server with its ``href`` template chain merged in (own attributes win;
    children from the first element of the chain that has any). No ``href`` left."""
    chain, seen = [el], {id(el)}
    while True:
        ref = _href(chain[-1])
        nxt = ids.get(ref) if ref else None
        if nxt is None or id(nxt) in seen or _local(nxt.tag) not in _PAINT_TAGS:
            break
        chain.append(nxt)
        seen.add(id(nxt))
    out = _strip_ns(el)
    out.attrib.pop("href", None)
    for tmpl in chain[1:]:
        t = _strip_ns(tmpl)
        for k, v in t.attrib.items():
            if k not in out.attrib and k not in ("id", "href"):
                out.set(k, v)
    if not len(out):
        for tmpl in chain[1:]:
            if len(tmpl):
                for child in _strip_ns(tmpl):
                    out.append(child)
                break
    return out


def _inline_uses(el: ET.Element, ids: dict, depth: int = 0) -> None:
    """Replace every ``<use>`` below ``el`` by a group holding a copy of its target."""
    for parent in list(el.iter()):
        for i, child in enumerate(list(parent)):
            if child.tag != "use":
                continue
            target = ids.get(_href(child) or "")
            g = ET.Element("g")
            tf = child.get("transform", "")
            x, y = child.get("x", "0"), child.get("y", "0")
            g.set("transform", f"{tf} translate({x} {y})".strip())
            for k, v in child.attrib.items():
                if k not in ("x", "y", "width", "height", "href", "transform", "id"):
                    g.set(k, v)
            if target is not None and depth < 8 and _local(target.tag) not in _PAINT_TAGS:
                t = _strip_ns(target)
                t.attrib.pop("id", None)
                g.append(t)
                _inline_uses(g, ids, depth + 1)
            parent.remove(child)
            parent.insert(i, g)


def paint_servers(path, xml, arts) -> dict:
    """``{id: markup}`` of every gradient or pattern ``arts`` refer to, self-contained
    (templates merged, ``<use>`` inlined), plus the servers those refer to in turn."""
    if xml is None:
        return {}
    ids = {el.get("id"): el for el in xml.iter() if el.get("id")}
    want = []
    for a in arts:
        s = a.source
        if s is not None:
            want += [s.fill_paint, s.stroke_paint]
    out: dict[str, str] = {}
    todo = [w for w in want if w]
    while todo:
        key = todo.pop()
        el = ids.get(key)
        if key in out or el is None or _local(el.tag) not in _PAINT_TAGS:
            continue
        server = _resolved_server(el, ids)
        _inline_uses(server, ids)
        for e in server.iter():
            for k, v in e.attrib.items():
                todo += [m for m in _URL.findall(v) if m not in out]
            style = e.get("style") or ""
            todo += [m for m in _URL.findall(style) if m not in out]
        out[key] = ET.tostring(server, encoding="unicode")
    return out
