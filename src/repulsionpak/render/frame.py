"""The frame of a written packing: the input's viewBox, grown where the drawing reaches past it.

The SVG, the PDF (converted from the SVG) and the PNG preview all show this frame, so
the preview and the delivered file hold the same picture.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np
import shapely

from ..io.svg_viewports import ROOT_VIEW_ATTRS
from ..types import Container, PlacedArt
from .numbers import format_number

__all__ = ["Frame", "drawing_bounds", "packing_frame"]

#: share of the drawing's larger side added around it when the input gives no viewport
FREE_MARGIN = 0.02

_LENGTH = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([a-zA-Z]*)\s*$")
_PX = {"": 1.0, "px": 1.0, "in": 96.0, "cm": 96.0 / 2.54, "mm": 96.0 / 25.4, "pt": 4.0 / 3.0,
       "pc": 16.0, "q": 96.0 / 101.6}


@dataclass(frozen=True)
class Frame:
    """What the output shows: ``view`` (x, y, w, h) in container user units, and the root
    attributes that put it on the page (``width``/``height``/``viewBox``/...), in order."""

    view: tuple[float, float, float, float]
    root_attrs: tuple[tuple[str, str], ...]


def drawing_bounds(container: Container, placed: list[PlacedArt], paint: str,
                   outline_width: float) -> tuple[float, float, float, float]:
    """(x0, y0, x1, y1) of everything the output draws, strokes included.

    The container counts by its region (plus half the outline's width with ``outline``,
    plus its shapes' strokes with ``as-drawn``). Each copy counts by the area its art
    covers (fills and stroked outlines).
    """
    x0, y0, x1, y1 = container.bounds
    half = 0.5 * outline_width if paint == "outline" else 0.0
    b = [x0 - half, y0 - half, x1 + half, y1 + half]
    if paint == "as-drawn":
        for art in container.paths:
            pts = [np.asarray(p, float).reshape(-1, 2) for p in art.subpaths if len(p)]
            if not pts:
                continue
            pts = np.concatenate(pts)
            st = art.style
            w = 0.5 * st.stroke_width if st.stroke is not None else 0.0
            if st.stroke is not None and st.stroke_linejoin == "miter":
                w *= math.sqrt(2.0)  # a right-angled corner's miter; sharper ones are rare
            lo, hi = pts.min(axis=0) - w, pts.max(axis=0) + w
            b = [min(b[0], lo[0]), min(b[1], lo[1]), max(b[2], hi[0]), max(b[3], hi[1])]
    for pa in placed:
        geom = pa.art
        if geom is None or geom.is_empty:
            continue
        g0, g1, g2, g3 = shapely.bounds(geom)
        b = [min(b[0], g0), min(b[1], g1), max(b[2], g2), max(b[3], g3)]
    return tuple(float(v) for v in b)  # type: ignore[return-value]


def _number(text: str) -> tuple[float, str] | None:
    """(value, unit) of an absolute SVG length such as ``"4in"`` or ``"448"``; None for
    percentages, ``em`` and anything unreadable."""
    m = _LENGTH.match(str(text))
    if not m or m.group(2).lower() not in _PX:
        return None
    v = float(m.group(1))
    return (v, m.group(2)) if math.isfinite(v) and v > 0 else None


def _viewbox(text) -> tuple[float, float, float, float] | None:
    try:
        vals = [float(v) for v in re.split(r"[\s,]+", str(text).strip()) if v]
    except ValueError:
        return None
    if len(vals) != 4 or not all(math.isfinite(v) for v in vals) or min(vals[2:]) <= 0:
        return None
    return tuple(vals)  # type: ignore[return-value]


def packing_frame(container: Container, placed: list[PlacedArt], paint: str = "outline",
                  outline_width: float = 0.0) -> Frame:
    """The output's frame: the input's viewBox, grown where the drawing reaches past it.

    Parameters
    ----------
    container, placed
        The packing.
    paint
        ``"outline"``, ``"as-drawn"`` or ``"none"`` (how the container is drawn).
    outline_width
        Stroke width of the container's outline (container units); also the margin kept
        between the drawing and a grown edge of the frame.

    Returns
    -------
    Frame
        An input with a viewBox (or an absolute ``width``/``height``, which set one of
        ``0 0 width height`` px) keeps it where everything fits; where the drawing reaches
        past an edge, that edge moves out to the drawing plus ``outline_width`` (at least
        0.2 % of the drawing's size), and ``width``/``height`` grow by the same factors, so
        a user unit keeps its size on the page. An input without either is framed to the
        drawing plus 2 % of its larger side. A root ``transform`` (rare) keeps the input's
        frame as it is.

    Notes
    -----
    Icons often reach past their own viewBox (Font Awesome's tree runs from y = -32 to
    544 in ``0 0 448 512``); keeping the input's viewBox there made browsers clip the
    copies packed in the overflow while the PNG preview showed them.
    """
    root = dict(container.svg_root or {})
    d = drawing_bounds(container, placed, paint, outline_width)
    size = max(d[2] - d[0], d[3] - d[1], 1e-12)
    vb = _viewbox(root["viewBox"]) if root.get("viewBox") is not None else None
    width = _number(root["width"]) if root.get("width") is not None else None
    height = _number(root["height"]) if root.get("height") is not None else None
    if vb is None and (width is None or height is None):
        if root.get("viewBox") is None and root.get("width") is None and root.get("height") is None:
            d = drawing_bounds(container, placed, paint, 0.0)  # the 2 % holds the outline
            m = FREE_MARGIN * max(d[2] - d[0], d[3] - d[1], 1e-12)
            view = (d[0] - m, d[1] - m, d[2] - d[0] + 2 * m, d[3] - d[1] + 2 * m)
            return Frame(view, (("width", format_number(view[2])), ("height", format_number(view[3])),
                                ("viewBox", " ".join(format_number(v) for v in view))))
        # relative sizes without a viewBox: the page decides; keep the input's mapping
        return Frame(_fallback_view(root, d), _as_given(root))
    if vb is None:  # absolute width and height: user units are px from (0, 0)
        vb = (0.0, 0.0, width[0] * _PX[width[1].lower()], height[0] * _PX[height[1].lower()])
    x, y, w, h = vb
    if root.get("transform") is not None:
        return Frame(vb, _as_given(root))
    m = max(outline_width, 2e-3 * size)
    eps = 1e-9 * max(size, w, h)  # (a flattened curve on the edge is not past it)
    nx0 = min(x, d[0] - m) if d[0] < x - eps else x
    ny0 = min(y, d[1] - m) if d[1] < y - eps else y
    nx1 = max(x + w, d[2] + m) if d[2] > x + w + eps else x + w
    ny1 = max(y + h, d[3] + m) if d[3] > y + h + eps else y + h
    if (nx0, ny0, nx1, ny1) == (x, y, x + w, y + h):
        return Frame(vb, _as_given(root))
    view = (nx0, ny0, nx1 - nx0, ny1 - ny0)
    fx, fy = view[2] / w, view[3] / h
    attrs = []
    for k, v in _as_given(root):
        if k == "viewBox" or (k == "width" and width is None) or (k == "height" and height is None):
            if k != "viewBox":
                attrs.append((k, str(v)))
            continue
        if k == "width":
            attrs.append((k, format_number(width[0] * fx) + width[1]))
        elif k == "height":
            attrs.append((k, format_number(height[0] * fy) + height[1]))
        else:
            attrs.append((k, str(v)))
    attrs.append(("viewBox", " ".join(format_number(v) for v in view)))
    order = {"width": 0, "height": 1, "viewBox": 2}
    attrs.sort(key=lambda kv: order.get(kv[0], 3))
    return Frame(view, tuple(attrs))


def _as_given(root: dict) -> tuple[tuple[str, str], ...]:
    """The input's page attributes, in the order the output writes them."""
    return tuple((k, str(root[k])) for k in ROOT_VIEW_ATTRS if root.get(k) is not None)


def _fallback_view(root: dict, d) -> tuple[float, float, float, float]:
    """The view of an input whose page size is relative (``width="100%"`` without a viewBox):
    the drawing plus 2 %, for the PNG."""
    m = FREE_MARGIN * max(d[2] - d[0], d[3] - d[1], 1e-12)
    return (d[0] - m, d[1] - m, d[2] - d[0] + 2 * m, d[3] - d[1] + 2 * m)
