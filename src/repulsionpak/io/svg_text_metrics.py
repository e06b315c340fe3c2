"""Where a text run sits on its line: baselines, ``baseline-shift`` and text decorations.

Browsers place a run of ``<text>`` by its font's metrics: ``dominant-baseline`` and
``alignment-baseline`` move the run so that the named baseline, not the alphabetic one,
lies at ``y``; ``baseline-shift`` raises or lowers it (``sub``/``super`` by the font's
subscript/superscript offsets, a length, or a percentage of the font size, summed over
the nested ``<tspan>``s); ``text-decoration`` draws an underline, overline or line-through
as a bar across the run. The baseline table is Chrome's (which does not read a font's
``BASE`` table either): text-before-edge at the ascent, middle at half the x-height,
central halfway between ascent and descent, hanging at 0.8 of the ascent, mathematical at
half of it, ideographic and text-after-edge at the descent.

Metrics come from the FreeType face matplotlib draws the run with: ``hhea`` ascent and
descent, OS/2's x-height (else 45 % of ascent - descent, as Firefox), sub/superscript and
strikeout offsets, and ``post``'s underline position and thickness.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

__all__ = ["BASELINES", "FontMetrics", "baseline_offset", "decoration_bars", "metrics_of", "shift_item"]

#: the baselines ``dominant-baseline`` / ``alignment-baseline`` name
BASELINES = {"auto", "baseline", "alphabetic", "ideographic", "hanging", "mathematical", "central", "middle",
             "text-after-edge", "text-before-edge", "after-edge", "before-edge", "no-change", "use-script",
             "reset-size", "inherit"}
_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:e[+-]?\d+)?"
_UNITS = {"": 1.0, "px": 1.0, "pt": 4.0 / 3.0, "pc": 16.0, "mm": 96.0 / 25.4, "cm": 96.0 / 2.54,
          "in": 96.0, "q": 96.0 / 101.6}


@dataclass(frozen=True)
class FontMetrics:
    """A face's metrics per em (y up, as fonts have them)."""

    ascent: float
    descent: float  # negative below the baseline
    x_height: float
    subscript: float
    superscript: float
    strikeout: float
    underline: float  # negative below the baseline
    thickness: float  # of every decoration bar (the underline's, as browsers draw them)


def metrics_of(font) -> FontMetrics:
    """The :class:`FontMetrics` of a matplotlib ``FT2Font``."""
    em = float(font.units_per_EM or 1000)
    asc, desc = font.ascender / em, font.descender / em
    os2 = None
    try:
        os2 = font.get_sfnt_table("OS/2")
    except Exception:  # noqa: BLE001  (a face without the table: the fallbacks below)
        pass
    os2 = os2 or {}
    xh = os2.get("sxHeight", 0) / em if os2.get("sxHeight") else 0.45 * (asc - desc)
    thick = (font.underline_thickness / em) if font.underline_thickness else 1.0 / 12.0
    # FreeType gives the centre of the underline (post's position minus half the thickness);
    # browsers and resvg centre the bar on post's own value
    under = ((font.underline_position + font.underline_thickness / 2.0) / em) if font.underline_position \
        else -1.0 / 9.0
    return FontMetrics(
        ascent=asc, descent=desc, x_height=xh,
        subscript=os2.get("ySubscriptYOffset", em * 0.2) / em,
        superscript=os2.get("ySuperscriptYOffset", em * 0.4) / em,
        strikeout=(os2["yStrikeoutPosition"] / em) if os2.get("yStrikeoutPosition") else xh / 2.0,
        underline=under, thickness=thick,
    )


def shift_item(value: str | None, font_size: float):
    """One element's ``baseline-shift``: ``"sub"``, ``"super"``, a number of user units
    (up positive), or None (``baseline``, unset, unreadable)."""
    if value is None:
        return None
    v = value.strip().lower()
    if v in ("sub", "super"):
        return v
    m = re.fullmatch(rf"({_NUMBER})\s*([a-z%]*)", v)
    if not m:
        return None
    num, unit = float(m.group(1)), m.group(2)
    if unit == "%":
        return num / 100.0 * font_size
    if unit == "em":
        return num * font_size
    if unit == "ex":
        return num * font_size / 2.0
    return num * _UNITS[unit] if unit in _UNITS else None


def baseline_offset(m: FontMetrics, size: float, dominant: str, alignment: str, shifts: tuple) -> float:
    """How far down (y down, user units) a run moves from its ``y``: its alignment
    baseline (``alignment-baseline``, else ``dominant-baseline``) brought to ``y``, then
    its ``baseline-shift`` items (innermost last) applied."""
    name = alignment if alignment not in ("auto", "baseline", "inherit") else dominant
    down = {
        "text-before-edge": m.ascent, "before-edge": m.ascent,
        "middle": m.x_height / 2.0,
        "central": m.ascent - (m.ascent - m.descent) / 2.0,
        "text-after-edge": m.descent, "after-edge": m.descent, "ideographic": m.descent,
        "hanging": 0.8 * m.ascent, "mathematical": 0.5 * m.ascent,
    }.get(name, 0.0) * size
    up = 0.0
    for item in shifts:
        if item == "sub":
            up -= m.subscript * size
        elif item == "super":
            up += m.superscript * size
        elif item is not None:
            up += item
    return down - up


def decoration_bars(m: FontMetrics, size: float, kinds: tuple[str, ...], x0: float, x1: float,
                    y: float) -> tuple[np.ndarray, np.ndarray]:
    """Rectangles (path vertices and matplotlib codes, y down) of the decorations
    ``kinds`` across ``x0``..``x1`` of a run whose baseline is at ``y``."""
    verts, codes = [], []
    for kind in kinds:
        if kind == "underline":
            centre, t = m.underline * size, m.thickness * size
        elif kind == "overline":
            centre, t = m.ascent * size, m.thickness * size
        elif kind == "line-through":
            centre, t = m.strikeout * size, m.thickness * size
        else:
            continue
        top, bottom = y - centre - t / 2.0, y - centre + t / 2.0
        verts += [(x0, top), (x1, top), (x1, bottom), (x0, bottom), (x0, top)]
        codes += [1, 2, 2, 2, 79]
    return np.asarray(verts, dtype=float).reshape(-1, 2), np.asarray(codes, dtype=np.uint8)
