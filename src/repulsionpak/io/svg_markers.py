"""Markers (``marker-start``, ``marker-mid``, ``marker-end``: arrowheads, dots on the
vertices of a line) drawn as the art they put on a path, as browsers draw them.

A ``<marker>``'s content is placed at a vertex of the path, line, polyline or polygon
that refers to it: its reference point (``refX``, ``refY`` in its ``viewBox``) on the
vertex, turned to the path's direction there (``orient="auto"``: the tangent at the start
and the end, the bisector of the two tangents at a middle vertex; ``auto-start-reverse``;
a fixed angle), scaled by the stroke width (``markerUnits="strokeWidth"``, the default)
and by its ``viewBox`` into ``markerWidth`` × ``markerHeight`` (``preserveAspectRatio``).
``context-fill`` and ``context-stroke`` take the referring shape's paint. The content is
clipped to the marker's box (``overflow`` is ``hidden`` by default): :func:`clip_box` is
that box in the content's coordinates, the ``viewBox`` (or ``0 0 markerWidth
markerHeight`` without one), as resvg and Chrome clip it.

:func:`marker_ids` tells which markers a shape uses, :func:`placements` where their
copies go, and :func:`marker_svg` writes a marker's content as a small SVG document whose
shapes the reader parses like any others.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET

import numpy as np

from .svg_clip import url_id

__all__ = ["MARKABLE", "clip_box", "drop_marker_attribute", "marker_ids", "placements", "marker_svg",
           "resolve_marker_lengths", "resolve_overflow_inherit"]

#: the shapes markers are drawn on (SVG 2: every basic shape; a circle or an ellipse from
#: its rightmost point through the bottom, a rect from its top-left corner clockwise)
MARKABLE = ("Path", "SimpleLine", "Polyline", "Polygon", "Circle", "Ellipse", "Rect")
_ANGLE_UNITS = {"deg": 1.0, "grad": 0.9, "rad": 180.0 / math.pi, "turn": 360.0}
_ABSOLUTE = {"": 1.0, "px": 1.0, "pt": 4.0 / 3.0, "pc": 16.0, "mm": 96.0 / 25.4, "cm": 96.0 / 2.54,
             "in": 96.0}
_KINDS = ("marker-start", "marker-mid", "marker-end")
#: attributes of <marker> itself that are not presentation attributes its content inherits
_OWN = {"id", "refX", "refY", "markerWidth", "markerHeight", "markerUnits", "orient", "viewBox",
        "preserveAspectRatio", "overflow", "class"}


def drop_marker_attribute(root: ET.Element) -> None:
    """Remove ``marker="..."`` attributes: ``marker`` is a CSS shorthand only (in ``style``
    or a style sheet), not a presentation attribute, and browsers ignore it there."""
    for el in root.iter():
        if isinstance(el.tag, str) and "marker" in el.attrib:
            del el.attrib["marker"]


def resolve_overflow_inherit(root: ET.Element) -> None:
    """Give each ``<marker overflow="inherit">`` its parent's ``overflow`` (``visible``,
    CSS's initial value, when no ancestor sets one), in place."""
    def walk(el, inherited: str):
        own = _overflow(el, None)
        value = inherited if own in (None, "inherit") else own
        if own == "inherit" and _local_tag(el) == "marker":
            el.set("overflow", value)
            if "style" in el.attrib:
                el.set("style", ";".join(d for d in el.get("style").split(";")
                                         if d.split(":")[0].strip().lower() != "overflow"))
        for c in el:
            if isinstance(c.tag, str):
                walk(c, value)

    walk(root, "visible")


def _local_tag(el) -> str:
    return el.tag.rsplit("}", 1)[-1]


def resolve_marker_lengths(marker: ET.Element, viewport: tuple[float, float]) -> None:
    """Rewrite ``refX``, ``refY``, ``markerWidth``, ``markerHeight`` given with a unit or
    in percent (of the viewport's width for x and width, its height for y and height)
    as plain numbers, in place."""
    for name, ref in (("refX", viewport[0]), ("markerWidth", viewport[0]),
                      ("refY", viewport[1]), ("markerHeight", viewport[1])):
        m = re.fullmatch(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([a-zA-Z%]*)\s*",
                         str(marker.get(name, "")))
        if m is None:
            continue
        unit = m.group(2).lower()
        if unit == "%":
            marker.set(name, repr(float(m.group(1)) * ref / 100.0))
        elif unit in _ABSOLUTE:
            marker.set(name, repr(float(m.group(1)) * _ABSOLUTE[unit]))


def _orient_angle(orient: str) -> float:
    """A fixed ``orient`` angle in radians (``deg``, ``grad``, ``rad``, ``turn`` or a
    plain number of degrees; 0 when invalid, as browsers do)."""
    m = re.fullmatch(r"([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)([a-z]*)", orient.strip().lower())
    if m is None or (m.group(2) and m.group(2) not in _ANGLE_UNITS):
        return 0.0
    deg = float(m.group(1)) * _ANGLE_UNITS.get(m.group(2) or "deg", 1.0)
    return math.radians(deg) if math.isfinite(deg) else 0.0


def marker_ids(values) -> dict[str, str]:
    """``{"marker-start" | "marker-mid" | "marker-end": id}`` of a shape's resolved
    presentation values (the ``marker`` shorthand sets all three)."""
    both = url_id(values.get("marker"))
    out = {}
    for k in _KINDS:
        v = url_id(values.get(k)) or both
        if v:
            out[k] = v
    return out


def _xy(p) -> np.ndarray:
    return np.array([float(p.x), float(p.y)])


def _tangents(seg) -> tuple[np.ndarray, np.ndarray]:
    """Directions of an svgelements segment at its start and its end (zero vectors when
    it has no length)."""
    a, b = _xy(seg.start), _xy(seg.end)
    name = type(seg).__name__
    if name == "CubicBezier":
        c1, c2 = _xy(seg.control1), _xy(seg.control2)
        d0 = next((v for v in (c1 - a, c2 - a, b - a) if np.hypot(*v) > 0), b - a)
        d1 = next((v for v in (b - c2, b - c1, b - a) if np.hypot(*v) > 0), b - a)
        return d0, d1
    if name == "QuadraticBezier":
        c = _xy(seg.control)
        d0 = c - a if np.hypot(*(c - a)) > 0 else b - a
        d1 = b - c if np.hypot(*(b - c)) > 0 else b - a
        return d0, d1
    if name == "Arc":
        e = 1e-4
        return _xy(seg.point(e)) - a, b - _xy(seg.point(1.0 - e))
    return b - a, b - a  # Line, Close


def _angle(v) -> float | None:
    return math.atan2(v[1], v[0]) if v is not None and np.hypot(*v) > 0 else None


def _vertices(segs) -> list[tuple[np.ndarray, float | None, float | None]]:
    """The path's vertices ``(point, angle in, angle out)`` in order (radians; None where
    no segment arrives or leaves)."""
    verts: list[list] = []
    for seg in segs:
        name = type(seg).__name__
        if name == "Move":
            if seg.end is not None:
                verts.append([_xy(seg.end), None, None])
            continue
        if seg.start is None or seg.end is None:
            continue
        d0, d1 = _tangents(seg)
        if verts and verts[-1][2] is None:
            verts[-1][2] = d0
        verts.append([_xy(seg.end), d1, None])
    return [(p, _angle(i), _angle(o)) for p, i, o in verts]


def _number(el, name, default: float) -> float:
    try:
        v = float(str(el.get(name, default)).strip().rstrip("px") or default)
    except ValueError:
        return default
    return v if math.isfinite(v) else default


def _viewbox(el) -> np.ndarray:
    """(3, 3) map from the marker's content coordinates to its viewport (``viewBox`` and
    ``preserveAspectRatio`` into ``markerWidth`` × ``markerHeight``)."""
    import svgelements as se

    w, h = _number(el, "markerWidth", 3.0), _number(el, "markerHeight", 3.0)
    vb = [float(x) for x in re.split(r"[\s,]+", (el.get("viewBox") or "").strip()) if x] \
        if el.get("viewBox") else []
    if len(vb) != 4 or not (vb[2] > 0 and vb[3] > 0):
        return np.eye(3)
    m = se.Matrix(se.Viewbox.viewbox_transform(0.0, 0.0, w, h, *vb, el.get("preserveAspectRatio")))
    return np.array([[m.a, m.c, m.e], [m.b, m.d, m.f], [0.0, 0.0, 1.0]])


def _overflow(el, default: str | None = "hidden") -> str | None:
    value = el.get("overflow")
    for decl in str(el.get("style") or "").split(";"):
        k, _, v = decl.partition(":")
        if k.strip().lower() == "overflow":
            value = v
    return str(value).strip().lower() if value else default


def clip_box(marker: ET.Element) -> tuple[float, float, float, float] | None:
    """``(x0, y0, x1, y1)``: the box ``marker``'s content is clipped to, in the content's
    coordinates (those of :func:`placements`' matrices); None when ``overflow`` is
    ``visible`` or ``auto``.

    Notes
    -----
    ``overflow`` is ``hidden`` on a marker by default (UA style sheet), so an arrowhead
    drawn past its box is cut there. With a ``viewBox`` the box is the ``viewBox``
    rectangle (where ``preserveAspectRatio`` leaves room around it, Chrome and resvg
    still cut at the ``viewBox``); without one it is ``markerWidth`` × ``markerHeight``
    from the content's origin.
    """
    if _overflow(marker) in ("visible", "auto"):
        return None
    try:
        vb = [float(x) for x in re.split(r"[\s,]+", (marker.get("viewBox") or "").strip()) if x]
    except ValueError:
        vb = []
    if len(vb) == 4 and vb[2] > 0 and vb[3] > 0:
        return vb[0], vb[1], vb[0] + vb[2], vb[1] + vb[3]
    return 0.0, 0.0, _number(marker, "markerWidth", 3.0), _number(marker, "markerHeight", 3.0)


def placements(segs, marker: ET.Element, kind: str, stroke_width: float) -> list[np.ndarray]:
    """(3, 3) matrices from ``marker``'s content coordinates to the shape's local ones,
    one per vertex it is drawn on (``kind``: marker-start, -mid or -end)."""
    verts = _vertices(segs)
    if not verts:
        return []
    if kind == "marker-start":
        chosen = [(verts[0], "start")]
    elif kind == "marker-end":
        chosen = [(verts[-1], "end")]
    else:
        chosen = [(v, "mid") for v in verts[1:-1]]
    units = (marker.get("markerUnits") or "strokeWidth").strip()
    k = stroke_width if units == "strokeWidth" else 1.0
    vb = _viewbox(marker)
    ref = vb @ np.array([_number(marker, "refX", 0.0), _number(marker, "refY", 0.0), 1.0])
    orient = (marker.get("orient") or "0").strip()
    out = []
    for (p, a_in, a_out), where in chosen:
        if orient in ("auto", "auto-start-reverse"):
            if where == "start":
                a = a_out if a_out is not None else 0.0
                if orient == "auto-start-reverse":
                    a += math.pi
            elif where == "end":
                a = a_in if a_in is not None else 0.0
            elif a_in is None or a_out is None:
                a = a_in if a_out is None else a_out
                a = a or 0.0
            else:  # the bisector of the two directions
                a = math.atan2(math.sin(a_in) + math.sin(a_out), math.cos(a_in) + math.cos(a_out))
        else:
            a = _orient_angle(orient)
        c, s = math.cos(a), math.sin(a)
        place = np.array([[c * k, -s * k, p[0]], [s * k, c * k, p[1]], [0.0, 0.0, 1.0]])
        shift = np.array([[1.0, 0.0, -ref[0]], [0.0, 1.0, -ref[1]], [0.0, 0.0, 1.0]])
        out.append(place @ shift @ vb)
    return out


def _svg_matrix(m: np.ndarray) -> str:
    return "matrix(" + " ".join(repr(float(v)) for v in (m[0, 0], m[1, 0], m[0, 1], m[1, 1], m[0, 2], m[1, 2])) + ")"


def marker_svg(marker: ET.Element, matrices: list[np.ndarray], context_fill: str, context_stroke: str,
               by_id: dict | None = None) -> bytes:
    """A small SVG document drawing ``marker``'s content once per matrix (content ->
    the file's user units), its own presentation attributes inherited, ``context-fill``
    and ``context-stroke`` replaced by the referring shape's paints. ``by_id``: the
    file's elements by id, so that a ``<use>`` in the marker finds what it draws."""
    ns = "http://www.w3.org/2000/svg"
    inherited = {k: v for k, v in marker.attrib.items() if k not in _OWN and not k.startswith("{")}
    body = "".join(ET.tostring(c, encoding="unicode") for c in marker if isinstance(c.tag, str))
    if by_id:  # what a <use> inside the marker draws lives elsewhere in the file
        own = {e.get("id") for e in marker.iter() if isinstance(e.tag, str)}
        wanted, seen, defs = [marker], set(), []
        while wanted:
            for e in wanted.pop().iter():
                href = e.get("{http://www.w3.org/1999/xlink}href") or e.get("href") if isinstance(e.tag, str) else None
                key = href[1:] if href and href.startswith("#") else None
                if key and key not in own and key not in seen and key in by_id:
                    seen.add(key)
                    defs.append(by_id[key])
                    wanted.append(by_id[key])
        if defs:
            body += "<defs>" + "".join(ET.tostring(d, encoding="unicode") for d in defs) + "</defs>"
    body = body.replace("context-stroke", context_stroke).replace("context-fill", context_fill)
    attrs = "".join(f' {k}="{_escape(v)}"' for k, v in inherited.items())
    attrs = attrs.replace("context-stroke", context_stroke).replace("context-fill", context_fill)
    groups = "".join(f'<g transform="{_svg_matrix(m)}"><g{attrs}>{body}</g></g>' for m in matrices)
    return (f'<svg xmlns="{ns}" xmlns:xlink="http://www.w3.org/1999/xlink">{groups}</svg>').encode()


def _escape(v: str) -> str:
    return str(v).replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")
