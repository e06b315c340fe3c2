"""How the container is drawn under the art, and whether its own paint would hide the art.

``outline`` (the default) draws the container's exact region as a thin stroke with no
fill, as the paper's figures do: it never hides the art. ``as-drawn`` writes the
container's own shapes, fill and stroke under the art; ``none`` leaves it out. Every
output (SVG, PDF, PNG, the live view, batch's contact sheet) draws the same choice.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import shapely

from ..errors import ParameterError
from ..types import ArtPath, Container, PlacedArt

__all__ = ["CONTAINER_PAINTS", "check_paint", "hidden_art", "hiding_warning", "outline_colour",
           "outline_width"]

CONTAINER_PAINTS = ("outline", "as-drawn", "none")

#: the outline's width: this share of the container's bounding-box diagonal ...
OUTLINE_SHARE = 1 / 700
#: ... but at most this share of the gap (the art keeps gap/2 from the edge)
OUTLINE_GAP_SHARE = 1 / 3
#: CIE76 colour difference below which art and container paint read as one colour
SAME_COLOUR = 20.0
#: share of the art's area hidden that makes ``as-drawn`` warn
HIDDEN_SHARE = 0.2


def check_paint(paint: str) -> str:
    """``paint`` if it is one of :data:`CONTAINER_PAINTS`, else ParameterError."""
    if paint not in CONTAINER_PAINTS:
        raise ParameterError(f"container paint must be one of {', '.join(CONTAINER_PAINTS)}, got {paint!r}")
    return paint


def outline_width(container: Container, gap: float | None) -> float:
    """Stroke width of the outline (container units): 1/700 of the container's diagonal,
    at most a third of the gap, so it never reaches the art (kept gap/2 from the edge)."""
    x0, y0, x1, y1 = container.bounds
    w = OUTLINE_SHARE * (math.hypot(x1 - x0, y1 - y0) or 1.0)
    if gap is not None and math.isfinite(gap) and gap > 0:
        w = min(w, OUTLINE_GAP_SHARE * float(gap))
    return float(w)


def _rgb(colour: str | None) -> np.ndarray | None:
    if colour is None:
        return None
    if str(colour).strip().lower() == "currentcolor":
        return np.zeros(3)
    # svgelements' parser: the reader's own dependency (matplotlib's costs 0.3 s of imports,
    # and neither it nor Pillow is in the build environment that packs the demo)
    from svgelements import Color  # noqa: PLC0415

    text = str(colour).strip()
    if text.lower().startswith("url(") or text.lower() in ("none", "transparent"):
        return None  # a paint server reference: no colour of its own
    c = Color(text)
    if c.value is None:
        return None
    return np.array([c.red, c.green, c.blue], float) / 255.0


def _linear(rgb: np.ndarray) -> np.ndarray:
    return np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)


def _lab(rgb: np.ndarray) -> np.ndarray:
    """CIE L*a*b* (D65) of an sRGB colour in [0, 1]."""
    xyz = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722],
                    [0.0193, 0.1192, 0.9505]]) @ _linear(rgb)
    t = xyz / np.array([0.95047, 1.0, 1.08883])
    f = np.where(t > (6 / 29) ** 3, np.cbrt(t), t / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def _hex(rgb: np.ndarray) -> str:
    return "#" + "".join(f"{int(round(255 * min(max(c, 0.0), 1.0))):02x}" for c in rgb)


def _rings(art: ArtPath) -> list[np.ndarray]:
    return [np.asarray(p, float) for p in art.subpaths if len(p) >= 3]


def _ring_area(art: ArtPath) -> float:
    total = 0.0
    for r in _rings(art):
        x, y = r[:, 0], r[:, 1]
        total += abs(0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
    return total


def outline_colour(container: Container) -> str:
    """The outline's colour: that of the container's largest visible shape (its stroke,
    else its fill), darkened until it shows on white (relative luminance at most 0.4);
    black when the container has no colour of its own.

    Notes
    -----
    A red circle keeps a red edge and a black icon a black one, so the outline still
    reads as the container the designer chose; a white or pale shape would vanish on the
    page, so it is darkened, keeping its hue.
    """
    best, best_area = None, -1.0
    for art in container.paths:
        st = art.style
        if not st.visible:
            continue
        colour = st.stroke if st.stroke is not None and st.stroke_width > 0 else st.fill
        rgb = _rgb(colour)
        if rgb is None:
            continue
        area = _ring_area(art)
        if area > best_area:
            best, best_area = rgb, area
    if best is None:
        return "#000000"
    lum = float(np.dot([0.2126, 0.7152, 0.0722], _linear(best)))
    if lum > 0.4:
        best = best * (0.4 / lum) ** (1 / 2.2)  # about the luminance 0.4, hue kept
    return _hex(best)


def _region(art: ArtPath) -> shapely.Geometry | None:
    from ..io.regions import RegionTooComplex, rings_to_region  # noqa: PLC0415

    rings = _rings(art)
    if not rings:
        return None
    try:
        return rings_to_region(rings, art.style.fill_rule)
    except (RegionTooComplex, ValueError, shapely.errors.GEOSException):
        return None


def _stroke_band(art: ArtPath, stroke_scale: float) -> shapely.Geometry | None:
    w = art.style.stroke_width * stroke_scale
    if not w > 0:
        return None
    lines = []
    for pts, closed in zip(art.subpaths, art.closed):
        pts = np.asarray(pts, float)
        if len(pts) >= 2:
            lines.append(shapely.LineString(np.vstack([pts, pts[:1]]) if closed else pts))
    if not lines:
        return None
    return shapely.union_all(shapely.buffer(lines, w / 2))


def _painted(art: ArtPath, stroke_scale: float = 1.0) -> list[tuple[shapely.Geometry, np.ndarray]]:
    """(area, colour) layers an opaque-enough shape paints, bottom first (fill, stroke)."""
    st = art.style
    out = []
    if st.fill is not None and st.opacity * st.fill_opacity >= 0.5:
        rgb, g = _rgb(st.fill), _region(art)
        if rgb is not None and g is not None and not g.is_empty:
            out.append((g, rgb))
    if st.stroke is not None and st.opacity * st.stroke_opacity >= 0.5:
        rgb, g = _rgb(st.stroke), _stroke_band(art, stroke_scale)
        if rgb is not None and g is not None and not g.is_empty:
            out.append((g, rgb))
    if st.paint_order.split()[:1] == ["stroke"]:
        out.reverse()
    return out


def _topmost(layers: list[tuple[shapely.Geometry, np.ndarray]]) -> list[tuple[shapely.Geometry, np.ndarray]]:
    """The part of each layer (bottom first) no later layer covers."""
    out, above = [], None
    for g, rgb in reversed(layers):
        seen = g if above is None else shapely.difference(g, above)
        above = g if above is None else shapely.union(above, g)
        if not seen.is_empty:
            out.append((seen, rgb))
    return out


def hidden_art(container: Container, placed: Sequence[PlacedArt]) -> tuple[float, str] | None:
    """How much of the art the container, drawn as it is, would hide.

    Returns
    -------
    (share, colour) or None
        ``share``: the area of the art whose visible paint is within :data:`SAME_COLOUR`
        (CIE76) of the container's visible fill where they overlap, over the area of all
        the art; ``colour``: that container fill (the one hiding the most). None when the
        container paints no solid fill or there is no art.

    Notes
    -----
    Only what shows counts: the topmost container fill at each place, and each copy's
    topmost paint (a black outline drawn over a black body hides nothing more than the
    body). Icon sets draw container and elements in ``currentColor`` alike; a designer
    sees a silhouette, not a packing.
    """
    cont_layers = []
    for art in container.paths:
        st = art.style
        if st.fill is not None and st.opacity * st.fill_opacity >= 0.5:
            rgb, g = _rgb(st.fill), _region(art)
            if rgb is not None and g is not None and not g.is_empty:
                cont_layers.append((g, rgb))
    cont_layers = _topmost(cont_layers)
    if not cont_layers:
        return None
    total, hidden = 0.0, {}
    for pa in placed:
        layers = _topmost([layer for art in pa.paths for layer in _painted(art, pa.stroke_scale)])
        for g, rgb in layers:
            total += g.area
            lab = _lab(rgb)
            for cg, crgb in cont_layers:
                if float(np.linalg.norm(_lab(crgb) - lab)) < SAME_COLOUR:
                    a = shapely.intersection(g, cg).area
                    key = _hex(crgb)
                    hidden[key] = hidden.get(key, 0.0) + a
    if total <= 0 or not hidden:
        return None
    colour = max(hidden, key=hidden.get)
    return sum(hidden.values()) / total, colour


def hiding_warning(container: Container, placed: Sequence[PlacedArt], paint: str) -> str | None:
    """The warning to give when ``paint`` is ``as-drawn`` and the container's fill would
    hide at least :data:`HIDDEN_SHARE` of the art (see :func:`hidden_art`); else None."""
    if paint != "as-drawn":
        return None
    found = hidden_art(container, placed)
    if found is None or found[0] < HIDDEN_SHARE:
        return None
    share, colour = found
    return (f"{container.source}: the container drawn as-drawn hides the art: {share:.0%} of the art is "
            f"painted in colours close to the container's fill {colour} where they overlap. Draw the "
            "container as an outline (--container-paint outline, the default; in a config file "
            "[output] container_paint = \"outline\") or leave it out (--container-paint none), or give "
            "the container another fill")
