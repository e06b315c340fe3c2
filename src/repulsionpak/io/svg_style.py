"""Paint and style: an svgelements shape's presentation values as a :class:`~repulsionpak.types.Style`.

Owns :func:`style_of` (fill and stroke colours with their alphas, stroke width in user
units -- ``non-scaling-stroke`` included --, dashes, caps, joins, miter limit, fill rule,
visibility and ``paint-order``), the colour of gradients and patterns the packing sees
(:func:`gradient_colours`: first stop; translucent stops and patterns noted as
approximated), CSS Color 4's space-separated ``rgb()``/``hsl()``, and
``context-fill``/``context-stroke``.

Notes
-----
Paint servers are written back as they are; only the packing's geometry and the
container outline's colour use the solid colour chosen here.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET

from ..types import Style
from .svg_xml import href
from .svg_xml import inline_declarations as _inline_declarations
from .svg_xml import local_name as _local

__all__ = ["clamp01", "context_paint", "float_attr", "gradient_colours", "shape_stroke_width", "style_of"]


class _Servers(dict):
    """id -> the colour a paint server's outline is drawn with (``dict``), and in
    ``approx`` id -> what the packing approximates of that server's paint."""

    approx: dict


def gradient_colours(root: ET.Element) -> dict[str, str]:
    """id -> colour of the first stop of each gradient (following href templates).

    Patterns and gradients with translucent stops are listed in the result's ``approx``:
    they are written back as they are, but the packing sees the painted shape as solid."""
    grads = {
        el.get("id"): el
        for el in root.iter()
        if _local(el.tag) in ("linearGradient", "radialGradient") and el.get("id")
    }
    out = _Servers()
    out.approx = {}
    for gid, start in grads.items():
        el, seen = start, set()
        while el is not None and id(el) not in seen:
            seen.add(id(el))
            stops = [s for s in el if _local(s.tag) == "stop"]
            if stops:
                if any(_translucent_stop(st) for st in stops):
                    out.approx[gid] = "gradient with translucent stops (kept; packed as a solid shape)"
                s = stops[0]
                colour = s.get("stop-color")
                m = re.search(r"stop-color\s*:\s*([^;]+)", s.get("style") or "")
                if m:
                    colour = m.group(1).strip()
                out[gid] = colour or "black"
                break
            ref = href(el)
            el = grads.get(ref[1:]) if ref and ref.startswith("#") else None
    for el in root.iter():  # patterns: the first plain fill of their content, else grey
        if _local(el.tag) == "pattern" and el.get("id") and el.get("id") not in out:
            colour = "#808080"
            for c in el.iter():
                f = c.get("fill")
                if c is not el and f and not f.strip().startswith("url(") and f.strip() != "none":
                    colour = f.strip()
                    break
            out[el.get("id")] = colour
            out.approx[el.get("id")] = "pattern paint (kept; packed as a solid shape)"
    return out


def _translucent_stop(stop: ET.Element) -> bool:
    """Whether a gradient ``<stop>`` paints with an alpha below 1."""
    decls = {k: v for k, v, _ in _inline_declarations(stop.get("style"))}
    op = decls.get("stop-opacity", stop.get("stop-opacity"))
    colour = str(decls.get("stop-color", stop.get("stop-color")) or "").strip().lower()
    if op is not None and float_attr(op.strip().rstrip("%"), 1.0) * (0.01 if op.strip().endswith("%") else 1) < 1:
        return True
    return colour == "transparent" or colour.startswith(("rgba", "hsla")) or "/" in colour


def float_attr(value, default: float) -> float:
    if value is None:
        return default
    s = str(value).strip()
    try:
        v = float(s[:-1]) / 100.0 if s.endswith("%") else float(s)
    except ValueError:
        return default
    return v if math.isfinite(v) else default


def clamp01(v: float) -> float:
    return min(1.0, max(0.0, v))


def _paint(raw, gradients: dict[str, str], notes: set[str]) -> tuple[str | None, float]:
    """SVG paint string -> ('#rrggbb' | None, alpha)."""
    from svgelements import Color

    if raw is None:
        return None, 1.0
    s = str(raw).strip()
    if not s or s.lower() == "none":
        return None, 1.0
    if s.lower().startswith("url("):
        m = re.match(r"url\(\s*['\"]?\s*#([^)'\"\s]+)\s*['\"]?\s*\)\s*(.*)$", s, re.IGNORECASE)
        fallback = m.group(2).strip() if m else ""
        if m and m.group(1) in gradients:  # kept in the output; the outline uses a colour
            s = gradients[m.group(1)]
            approx = getattr(gradients, "approx", {}).get(m.group(1))
            if approx:
                notes.add(approx)
        elif fallback:
            s = fallback
        else:
            notes.add("pattern or unresolved paint server (not painted)")
            return None, 1.0
        if s.lower() == "none":
            return None, 1.0
    if s.lower() == "transparent":  # paints nothing, like none
        return None, 1.0
    c = Color(_comma_colour(s))
    if c.value is None:
        return None, 1.0
    return c.hexrgb.lower(), c.alpha / 255.0


_SPACE_COLOUR = re.compile(
    r"(rgb|hsl)a?\(\s*([^\s,()/]+)\s+([^\s,()/]+)\s+([^\s,()/]+)\s*(?:/\s*([^\s,()/]+)\s*)?\)",
    re.IGNORECASE)


def _comma_colour(s: str) -> str:
    """CSS Color 4's ``rgb(255 0 0 / 50%)`` (and ``hsl``) in the comma form svgelements
    reads (``rgba(255,0,0,0.5)``); any other string unchanged."""
    m = _SPACE_COLOUR.fullmatch(s.strip())
    if m is None:
        return s
    fn, a, b, c, alpha = m.groups()
    a = a[:-3] if fn.lower() == "hsl" and a.lower().endswith("deg") else a
    if alpha is None:
        return f"{fn.lower()}({a},{b},{c})"
    if alpha.endswith("%"):
        try:
            alpha = repr(float(alpha[:-1]) / 100.0)
        except ValueError:
            return s
    return f"{fn.lower()}a({a},{b},{c},{alpha})"


def shape_stroke_width(shape) -> float:
    """A shape's ``stroke-width`` in its own coordinates (1 when unset or unreadable, 0
    when negative or not finite)."""
    sw = shape.stroke_width if shape.stroke_width is not None else 1.0
    try:
        sw = float(sw)
    except (TypeError, ValueError):
        return 1.0
    return sw if math.isfinite(sw) and sw >= 0 else 0.0


def context_paint(raw, context: tuple) -> str | None:
    """``raw`` with ``context-fill``/``context-stroke`` replaced by the context element's
    paint (``context``: its resolved fill and stroke strings; ``none`` without one, as
    browsers paint it)."""
    key = str(raw).strip().lower() if raw is not None else ""
    if key == "context-fill":
        return context[0] or "none"
    if key == "context-stroke":
        return context[1] or "none"
    return raw


def style_of(
    shape, opacity: float, det_scale: float, vp_scale: float, gradients, notes, context: tuple = (None, None)
) -> Style:
    """The :class:`Style` of an svgelements shape; ``context``: the fill and stroke (paint
    strings) ``context-fill`` and ``context-stroke`` stand for (of the ``<use>`` the shape
    is drawn by)."""
    values = shape.values
    fill, fill_alpha = _paint(context_paint(values.get("fill", "black"), context), gradients, notes)
    stroke, stroke_alpha = _paint(context_paint(values.get("stroke", "none"), context), gradients, notes)
    sw = shape_stroke_width(shape)
    if "non-scaling-stroke" in str(values.get("vector-effect", "")):  # lengths in the viewport's units
        to_user = (lambda v: v / vp_scale) if vp_scale > 0 else (lambda v: v)
    else:
        to_user = lambda v: v * det_scale  # noqa: E731
    sw = to_user(sw)
    dashes = tuple(to_user(d) for d in _dasharray(values.get("stroke-dasharray")))
    offset = to_user(float_attr(values.get("stroke-dashoffset"), 0.0)) if dashes else 0.0
    limit = float_attr(values.get("stroke-miterlimit"), 4.0)
    cap = str(values.get("stroke-linecap", "butt")).strip().lower()
    join = str(values.get("stroke-linejoin", "miter")).strip().lower()
    rule = str(values.get("fill-rule", "nonzero")).strip().lower()
    vis = str(values.get("visibility", "visible")).strip().lower()
    if vis in ("hidden", "collapse"):
        opacity = 0.0
    return Style(
        fill=fill,
        stroke=stroke,
        stroke_width=sw,
        opacity=clamp01(opacity),
        fill_opacity=clamp01(
            float_attr(values.get("fill-opacity"), 1.0) * fill_alpha
        ),
        stroke_opacity=clamp01(
            float_attr(values.get("stroke-opacity"), 1.0) * stroke_alpha
        ),
        fill_rule="evenodd" if rule == "evenodd" else "nonzero",
        stroke_linecap=cap if cap in ("butt", "round", "square") else "butt",
        stroke_linejoin=join if join in ("miter", "round", "bevel") else "miter",
        stroke_miterlimit=limit if math.isfinite(limit) and limit >= 1.0 else 4.0,
        stroke_dasharray=dashes,
        stroke_dashoffset=offset if math.isfinite(offset) else 0.0,
        paint_order=_paint_order(values.get("paint-order")),
    )


def _paint_order(raw) -> str:
    """``paint-order`` normalised: "normal", or the order of fill, stroke and markers as
    given (the missing ones follow in their normal order), e.g. "stroke fill markers"."""
    words = [w for w in str(raw or "").strip().lower().split() if w in ("fill", "stroke", "markers")]
    if not words:
        return "normal"
    seen = list(dict.fromkeys(words))
    order = seen + [w for w in ("fill", "stroke", "markers") if w not in seen]
    return "normal" if order == ["fill", "stroke", "markers"] else " ".join(order)


def _dasharray(raw) -> tuple[float, ...]:
    """``stroke-dasharray`` as lengths (an odd list repeated, as SVG does); () for
    ``none``, percentages, and invalid lists (negative or non-finite values, all zero),
    which SVG draws solid."""
    if raw is None:
        return ()
    text = str(raw).strip().lower()
    if text in ("", "none", "inherit") or "%" in text:
        return ()
    try:
        vals = [float(re.sub(r"(px)$", "", v)) for v in re.split(r"[\s,]+", text) if v]
    except ValueError:
        return ()
    if not vals or any(not math.isfinite(v) or v < 0 for v in vals) or sum(vals) <= 0:
        return ()
    return tuple(vals * 2 if len(vals) % 2 else vals)
