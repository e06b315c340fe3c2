"""CSS lengths and ``transform-origin`` resolved to user units before svgelements reads a tree.

svgelements knows px, pt, pc, mm, cm, in and percentages along one axis. Browsers also read
the font-relative units ``em``, ``ex``, ``ch``, ``rem``, the viewport units ``vw``, ``vh``,
``vmin``, ``vmax`` and ``Q``; a ``stroke-width``, dash length or dash offset in percent is
a share of the viewport's normalized diagonal ``sqrt((w² + h²) / 2)``; a rect's or an
ellipse's ``rx`` in percent is a share of the viewport's width and ``ry`` of its height,
also when it stands in for the other radius left out. svgelements read such values as px,
as 0, refused the file (``em`` on a ``<rect>``), or took the missing radius as a share of
the wrong axis. :func:`resolve_lengths` rewrites them as plain numbers (user units) with
the viewport of the nearest ``<svg>`` and the element's computed font size (a browser's
16 px at the root); :func:`resolve_transform_origin` folds ``transform-origin`` into the
``transform`` it moves.

Notes
-----
``ch`` is taken as half an ``em`` and ``ex`` as half an ``em``, CSS's fallback when the
font's own metrics are not looked up; the viewport units refer to the outermost viewport
(the root's viewBox, else its size), which is what a standalone SVG has.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET

from .svg_xml import inline_declarations
from .svg_xml import local_name as _local

__all__ = ["resolve_lengths", "resolve_transform_origin"]

_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_LENGTH = re.compile(rf"\s*({_NUMBER})\s*([a-zA-Z%]*)\s*")
_ABSOLUTE = {"": 1.0, "px": 1.0, "pt": 4.0 / 3.0, "pc": 16.0, "mm": 96.0 / 25.4, "cm": 96.0 / 2.54,
             "in": 96.0, "q": 96.0 / 101.6}
#: CSS font-size keywords in px (the text module shares them)
FONT_SIZE_KEYWORDS = _SIZE_KEYWORDS = {"xx-small": 9.0, "x-small": 10.0, "small": 13.0, "medium": 16.0, "large": 18.0,
                  "x-large": 24.0, "xx-large": 32.0, "xxx-large": 48.0}
_DEFAULT_FONT_SIZE = 16.0
#: geometry attributes whose lengths are rewritten when they use a unit svgelements lacks
_GEOMETRY = ("x", "y", "width", "height", "r", "cx", "cy", "x1", "y1", "x2", "y2", "refX", "refY",
             "markerWidth", "markerHeight")
#: painting properties (attribute or style) rewritten whatever their unit: percentages of
#: the diagonal, and dash lists svgelements reads as numbers only
_PAINT_LENGTHS = ("stroke-width", "stroke-dashoffset", "stroke-dasharray")
#: percentages svgelements resolves against the root viewport: rewritten inside a nested
#: one (attribute, 0 for the viewport's width, 1 for its height)
_PERCENT_GEOMETRY = {
    "rect": (("x", 0), ("y", 1), ("width", 0), ("height", 1)),
    "circle": (("cx", 0), ("cy", 1)),
    "ellipse": (("cx", 0), ("cy", 1)),
    "line": (("x1", 0), ("y1", 1), ("x2", 0), ("y2", 1)),
    "use": (("x", 0), ("y", 1)),
    "image": (("x", 0), ("y", 1), ("width", 0), ("height", 1)),
}
_SVG_UNITS = {"", "px", "pt", "pc", "mm", "cm", "in", "%"}


class _Context:
    """What a length refers to: the viewport (w, h), the root viewport, font sizes."""

    def __init__(self, vp: tuple[float, float], root_vp: tuple[float, float], font: float, root_font: float):
        self.vp, self.root_vp, self.font, self.root_font = vp, root_vp, font, root_font

    @property
    def diagonal(self) -> float:
        return math.sqrt((self.vp[0] ** 2 + self.vp[1] ** 2) / 2.0)


def _px(value: str, ctx: _Context, percent_of: float) -> float | None:
    """One CSS length in user units (None when it is not a length)."""
    m = _LENGTH.fullmatch(value)
    if not m:
        return None
    num, unit = float(m.group(1)), m.group(2).lower()
    if unit in _ABSOLUTE:
        return num * _ABSOLUTE[unit]
    if unit == "%":
        return num / 100.0 * percent_of
    if unit == "em":
        return num * ctx.font
    if unit in ("ex", "ch"):
        return num * ctx.font / 2.0
    if unit == "rem":
        return num * ctx.root_font
    w, h = ctx.root_vp
    scale = {"vw": w, "vh": h, "vmin": min(w, h), "vmax": max(w, h)}.get(unit)
    return None if scale is None else num * scale / 100.0


def _font_size(el: ET.Element, parent: float) -> float:
    value = el.get("font-size")
    for name, v, _ in inline_declarations(el.get("style")):
        if name == "font-size":
            value = v
        elif name == "font":  # the shorthand: the first token that is a size
            for tok in v.split():
                tok = tok.split("/", 1)[0]
                if _LENGTH.fullmatch(tok) or tok.lower() in _SIZE_KEYWORDS:
                    value = tok
                    break
    return parent if value is None else font_size_value(value, parent)


def font_size_value(value: str, parent: float) -> float:
    """A CSS ``font-size`` value in user units.

    Parameters
    ----------
    value : str
        A keyword (``medium``, ``larger`` ...), a length or a percentage.
    parent : float
        The inherited font size (user units): what ``%``, ``em``, ``ex`` and ``ch`` refer to.

    Returns
    -------
    float
        The size; ``parent`` for a value that does not parse or is negative.
    """
    v = value.strip().lower()
    if v in _SIZE_KEYWORDS:
        return _SIZE_KEYWORDS[v]
    if v == "larger":
        return parent * 1.2
    if v == "smaller":
        return parent / 1.2
    m = _LENGTH.fullmatch(v)
    if not m:
        return parent
    num, unit = float(m.group(1)), m.group(2)
    if unit == "%":
        size = parent * num / 100.0
    elif unit == "em":
        size = parent * num
    elif unit in ("ex", "ch"):
        size = parent * num / 2.0
    elif unit in _ABSOLUTE:
        size = num * _ABSOLUTE[unit]
    else:
        return parent
    return size if math.isfinite(size) and size >= 0 else parent


def _viewport(el: ET.Element, outer: tuple[float, float]) -> tuple[float, float]:
    vb = (el.get("viewBox") or "").replace(",", " ").split()
    try:
        if len(vb) == 4 and float(vb[2]) > 0 and float(vb[3]) > 0:
            return float(vb[2]), float(vb[3])
    except ValueError:
        pass
    ctx = _Context(outer, outer, _DEFAULT_FONT_SIZE, _DEFAULT_FONT_SIZE)
    w = _px(el.get("width", "100%"), ctx, outer[0])
    h = _px(el.get("height", "100%"), ctx, outer[1])
    if w is None or h is None or not (w > 0 and h > 0):
        return outer
    return w, h


def _fmt(v: float) -> str:
    return repr(float(v))


def _rewrite_paint(name: str, value: str, ctx: _Context) -> str | None:
    """The user-unit form of a painting length (list), or None to leave it as it is."""
    text = value.strip()
    if name == "stroke-dasharray":
        parts = [p for p in re.split(r"[\s,]+", text) if p]
        if not parts or text.lower() in ("none", "inherit"):
            return None
        if all(_LENGTH.fullmatch(p) and not _LENGTH.fullmatch(p).group(2) for p in parts):
            return None
        vals = [_px(p, ctx, ctx.diagonal) for p in parts]
        return None if any(v is None for v in vals) else " ".join(_fmt(v) for v in vals)
    m = _LENGTH.fullmatch(text)
    if not m or not m.group(2):
        return None
    v = _px(text, ctx, ctx.diagonal)
    return None if v is None else _fmt(v)


def _radii(el: ET.Element, ctx: _Context) -> None:
    """A rect's or ellipse's ``rx``/``ry``: percentages of the viewport's width / height,
    a missing (or ``auto``) radius taking the other's length."""
    rx, ry = el.get("rx"), el.get("ry")
    auto = lambda v: v is None or v.strip().lower() in ("", "auto")  # noqa: E731
    if not any(v is not None and re.search(r"[a-zA-Z%]\s*$", v) and not auto(v) for v in (rx, ry)):
        return
    x = None if auto(rx) else _px(rx, ctx, ctx.vp[0])
    y = None if auto(ry) else _px(ry, ctx, ctx.vp[1])
    if x is None and y is None:
        return
    el.set("rx", _fmt(x if x is not None else y))
    el.set("ry", _fmt(y if y is not None else x))


def resolve_lengths(root: ET.Element, reference: tuple[float, float]) -> None:
    """Rewrite, in place, the lengths under ``root`` that svgelements would misread (see
    the module docstring) as user-unit numbers. ``reference``: the root viewport's width
    and height (what its percentages refer to)."""
    root_font = _font_size(root, _DEFAULT_FONT_SIZE)

    def walk(el: ET.Element, vp: tuple[float, float], parent_font: float) -> None:
        if not isinstance(el.tag, str):
            return
        name = _local(el.tag)
        font = _font_size(el, parent_font)
        ctx = _Context(vp, reference, font, root_font)
        for attr in _GEOMETRY:
            v = el.get(attr)
            if v is None:
                continue
            m = _LENGTH.fullmatch(v)
            if m and m.group(2).lower() not in _SVG_UNITS:
                px = _px(v, ctx, 0.0)
                if px is not None:
                    el.set(attr, _fmt(px))
        if name in ("text", "tspan"):  # position lists: the text layout reads plain numbers
            for attr, axis in (("x", 0), ("dx", 0), ("y", 1), ("dy", 1)):
                v = el.get(attr)
                if v is not None and "%" in v:
                    items = [p for p in re.split(r"[\s,]+", v.strip()) if p]
                    out = []
                    for item in items:
                        m = _LENGTH.fullmatch(item)
                        out.append(_fmt(float(m.group(1)) / 100.0 * vp[axis])
                                   if m and m.group(2) == "%" else item)
                    el.set(attr, " ".join(out))
        if vp != reference and name in _PERCENT_GEOMETRY:  # svgelements takes the root's
            for attr, axis in _PERCENT_GEOMETRY[name]:
                v = el.get(attr)
                m = _LENGTH.fullmatch(v) if v is not None else None
                if m and m.group(2) == "%":
                    el.set(attr, _fmt(float(m.group(1)) / 100.0 * vp[axis]))
        if name in ("rect", "ellipse"):
            _radii(el, ctx)
        for attr in _PAINT_LENGTHS:
            v = el.get(attr)
            if v is not None:
                new = _rewrite_paint(attr, v, ctx)
                if new is not None:
                    el.set(attr, new)
        style = el.get("style")
        if style and any(p in style for p in _PAINT_LENGTHS):
            decls = []
            for prop, v, important in inline_declarations(style):
                new = _rewrite_paint(prop, v, ctx) if prop in _PAINT_LENGTHS else None
                decls.append(f"{prop}:{new if new is not None else v}{' !important' if important else ''}")
            el.set("style", ";".join(decls))
        inner = _viewport(el, vp) if name == "svg" and el is not root else vp
        for child in el:
            walk(child, inner, font)

    walk(root, reference, _DEFAULT_FONT_SIZE)


_ORIGIN_KEYWORDS = {"left": ("x", 0.0), "right": ("x", 1.0), "top": ("y", 0.0), "bottom": ("y", 1.0),
                    "center": (None, 0.5)}


def _origin(value: str, vp: tuple[float, float]) -> tuple[float, float] | None:
    """``transform-origin`` (keywords, lengths, percentages of the view box) -> (x, y)."""
    parts = [p.lower() for p in value.strip().split()[:2]]
    if not parts:
        return None
    if len(parts) == 1:
        parts = ["center", parts[0]] if parts[0] in ("top", "bottom") else [parts[0], "center"]
    elif parts[0] in ("top", "bottom") or parts[1] in ("left", "right"):
        parts = [parts[1], parts[0]]  # "top left": the vertical keyword first
    ctx = _Context(vp, vp, _DEFAULT_FONT_SIZE, _DEFAULT_FONT_SIZE)
    out = []
    for axis, p in enumerate(parts):
        k = _ORIGIN_KEYWORDS.get(p)
        if k is not None:
            if k[0] is not None and k[0] != "xy"[axis]:
                return None
            out.append(k[1] * vp[axis])
            continue
        v = _px(p, ctx, vp[axis])
        if v is None:
            return None
        out.append(v)
    return out[0], out[1]


def resolve_transform_origin(root: ET.Element, reference: tuple[float, float]) -> None:
    """Fold ``transform-origin`` (attribute or style) into the element's ``transform``:
    ``translate(o) transform translate(-o)``, the origin's percentages and keywords
    referring to the nearest viewport (``transform-box: view-box``, SVG's default)."""

    def walk(el: ET.Element, vp: tuple[float, float]) -> None:
        if not isinstance(el.tag, str):
            return
        value = el.get("transform-origin")
        for prop, v, _ in inline_declarations(el.get("style")):
            if prop == "transform-origin":
                value = v
        tf = el.get("transform")
        if value and tf and tf.strip() and _local(el.tag) not in ("pattern", "linearGradient", "radialGradient"):
            o = _origin(value, vp)
            if o is not None and all(math.isfinite(c) for c in o) and o != (0.0, 0.0):
                el.set("transform", f"translate({_fmt(o[0])} {_fmt(o[1])}) {tf} "
                                    f"translate({_fmt(-o[0])} {_fmt(-o[1])})")
        el.attrib.pop("transform-origin", None)
        inner = _viewport(el, vp) if _local(el.tag) == "svg" and el is not root else vp
        for child in el:
            walk(child, inner)

    walk(root, reference)
