"""A suite of test scenes made from plain shapes and font glyphs (issue 10's yardstick).

Everything here is generated from parameters, as plain SVG text: elements (squares,
discs, triangles, hexagons, 5- and 8-pointed stars, bars, crosses, crescents, rings and
letters of the DejaVu Sans font that matplotlib ships) and containers (circle, square,
sharp star, curved band, holed square, two regions). A :class:`Scene` names one packing
problem — container, elements, gap, count, seed, drawing scale — and
:meth:`Scene.write` turns it into files :func:`repulsionpak.pack` / ``repulsionpak pack``
read. :func:`suite` is the full matrix, :func:`fast_suite` a few small scenes for the
tests.

Units: a scene is drawn in a frame whose container's larger side is ``1000 × scale``
user units; elements are drawn about ``100 × scale`` units wide (their drawn size does
not matter to the packing, which scales them to fit, but their coordinates carry the
scale). The gap is given as a fraction of the container's larger side.

Fonts: the glyphs come from DejaVu Sans (Bitstream Vera licence with public-domain
changes, a permissive licence) through :class:`matplotlib.textpath.TextPath`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from repulsionpak.errors import ParameterError
from repulsionpak.io.files import atomic_write_bytes

__all__ = [
    "ELEMENT_KINDS",
    "CONTAINER_KINDS",
    "DISTORTION_LIMITS",
    "element_category",
    "element_svg",
    "glyph_svg",
    "container_svg",
    "Scene",
    "SceneFiles",
    "suite",
    "fast_suite",
    "holdout_suite",
    "write_suite",
]

#: element kind -> category (the distortion promise depends on it)
ELEMENT_KINDS: dict[str, str] = {
    "square": "convex",
    "disc": "convex",
    "triangle": "convex",
    "hexagon": "convex",
    "star5": "spiky",
    "star8": "spiky",
    "bar": "thin",
    "cross": "thin",
    "crescent": "thin",
    "ring": "holed",
    # holdout kinds (scenes.holdout_suite); concave smooth shapes take the 0.15 limit ("spiky")
    "heart": "spiky",
    "bean": "spiky",
    "gear": "spiky",
    "arrow": "thin",
    "ell": "thin",
    "keyhole": "thin",
    "thinring": "holed",
    "pentagon": "convex",
    "ellipse": "convex",
    # probe kinds (benchmarks/probe.py draws from every kind; no suite uses these): shapes
    # that found bugs no suite scene had (a bullseye's island, November 27)
    "bullseye": "holed",
    "dots": "spiky",
    "spiral": "thin",
    "comb": "thin",
    "zigzag": "spiky",
    "lineart": "thin",
}
#: glyphs whose outline has a counter (a hole)
_HOLED_GLYPHS = set("ABDOPQRabdegopq&0689")
CONTAINER_KINDS = ("circle", "square", "star", "band", "holed", "two",
                   # holdout containers (scenes.holdout_suite)
                   "triangle", "ellipse", "annulus", "ell", "glyph", "hexagon",
                   # probe containers (benchmarks/probe.py)
                   "crescent", "cross", "target")
#: the letter the ``glyph`` container is drawn as
GLYPH_CONTAINER_CHAR = "C"
#: issue 10: p95 of the distortion per element category
DISTORTION_LIMITS = {"convex": 0.08, "spiky": 0.15, "thin": 0.15, "holed": 0.15, "letter": 0.15}

_COLOURS = {
    "square": "#4e79a7", "disc": "#f28e2b", "triangle": "#e15759", "hexagon": "#76b7b2",
    "star5": "#edc948", "star8": "#b07aa1", "bar": "#59a14f", "cross": "#9c755f",
    "crescent": "#ff9da7", "ring": "#17becf", "glyph": "#333333",
    "heart": "#d62728", "bean": "#8c564b", "gear": "#7f7f7f", "arrow": "#2ca02c", "ell": "#1f77b4",
    "keyhole": "#bcbd22", "thinring": "#9467bd", "pentagon": "#e377c2", "ellipse": "#ff7f0e",
    "bullseye": "#c33c8a", "dots": "#cc3333", "spiral": "#3366cc", "comb": "#339933",
    "zigzag": "#ee9900", "lineart": "#222222",
}
_GLYPH_PREFIX = "glyph-"


def element_category(name: str) -> str:
    """Category of an element kind or file stem (``"square"``, ``"glyph-A"``, ``"ring.svg"``)."""
    stem = Path(name).stem
    if stem.startswith(_GLYPH_PREFIX):
        return "letter"
    kind = stem.split("@")[0]
    if kind not in ELEMENT_KINDS:
        raise ParameterError(f"unknown element kind {stem!r}; known: {', '.join(ELEMENT_KINDS)} or glyph-X")
    return ELEMENT_KINDS[kind]


# --------------------------------------------------------------------------- SVG text


def _num(x: float) -> str:
    """A coordinate with 9 significant digits (exact enough from 0.01× to 100× scales)."""
    s = f"{float(x):.9g}"
    return "0" if s in ("-0", "0") else s


def _pts(points) -> str:
    return " ".join(f"{_num(x)},{_num(y)}" for x, y in points)


def _svg(width: float, height: float, body: str) -> str:
    w, h = _num(width), _num(height)
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}">\n'
            f"{body}\n</svg>\n")


def _star(cx: float, cy: float, r_out: float, r_in: float, n: int, phase: float = -math.pi / 2) -> np.ndarray:
    """Vertices of an n-pointed star (tips at ``r_out``, notches at ``r_in``), first tip up."""
    t = phase + np.arange(2 * n) * math.pi / n
    r = np.where(np.arange(2 * n) % 2 == 0, r_out, r_in)
    return np.stack([cx + r * np.cos(t), cy + r * np.sin(t)], axis=1)


def _regular(cx: float, cy: float, r: float, n: int, phase: float = -math.pi / 2) -> np.ndarray:
    t = phase + np.arange(n) * 2 * math.pi / n
    return np.stack([cx + r * np.cos(t), cy + r * np.sin(t)], axis=1)


def _circle_d(cx: float, cy: float, r: float, sweep: int = 1) -> str:
    """A full circle as two SVG arcs (usable inside a compound path)."""
    return (f"M {_num(cx - r)} {_num(cy)} A {_num(r)} {_num(r)} 0 1 {sweep} {_num(cx + r)} {_num(cy)} "
            f"A {_num(r)} {_num(r)} 0 1 {sweep} {_num(cx - r)} {_num(cy)} Z")


def _check_scale(scale: float, what: str = "scale") -> float:
    scale = float(scale)
    if not (math.isfinite(scale) and scale > 0):
        raise ParameterError(f"{what} must be a positive number, got {scale!r}")
    return scale


def element_svg(kind: str, size: float = 100.0, scale: float = 1.0, fill: str | None = None) -> str:
    """SVG text of one plain-shape element, about ``size × scale`` units across.

    ``kind``: one of :data:`ELEMENT_KINDS` — ``square`` (``<rect>``), ``disc``
    (``<circle>``), ``triangle`` / ``hexagon`` (regular ``<polygon>``), ``star5`` /
    ``star8`` (sharp stars, inner radius 0.4 / 0.45 of the outer), ``bar`` (a 5:1
    rectangle), ``cross`` (a plus sign with arms 0.28 wide), ``crescent`` (a disc minus
    an offset disc, two arcs), ``ring`` (two concentric circles, ``fill-rule="evenodd"``,
    inner radius 0.6).
    """
    if kind.startswith(_GLYPH_PREFIX):
        return glyph_svg(kind[len(_GLYPH_PREFIX):], size, scale, fill)
    if kind not in ELEMENT_KINDS:
        raise ParameterError(f"unknown element kind {kind!r}; known: {', '.join(ELEMENT_KINDS)} or glyph-X")
    s = float(size) * _check_scale(scale)
    if not s > 0:
        raise ParameterError(f"size must be positive, got {size!r}")
    colour = fill or _COLOURS[kind]
    c = 0.5 * s
    r = 0.5 * s
    paint = f'fill="{colour}"'
    w = h = s
    if kind == "square":
        body = f'  <rect x="0" y="0" width="{_num(s)}" height="{_num(s)}" {paint}/>'
    elif kind == "disc":
        body = f'  <circle cx="{_num(c)}" cy="{_num(c)}" r="{_num(r)}" {paint}/>'
    elif kind == "triangle":
        tri = _regular(c, c, r, 3)  # tip up at y = 0, base at y = 0.75 s
        body = f'  <polygon points="{_pts(tri)}" {paint}/>'
        h = float(tri[:, 1].max())
    elif kind == "hexagon":
        body = f'  <polygon points="{_pts(_regular(c, c, r, 6))}" {paint}/>'
    elif kind in ("star5", "star8"):
        n, ratio = (5, 0.4) if kind == "star5" else (8, 0.45)
        body = f'  <polygon points="{_pts(_star(c, c, r, ratio * r, n))}" {paint}/>'
    elif kind == "bar":
        h = 0.2 * s
        body = f'  <rect x="0" y="0" width="{_num(s)}" height="{_num(h)}" {paint}/>'
    elif kind == "cross":
        a, b = (0.5 - 0.14) * s, (0.5 + 0.14) * s
        pts = [(a, 0), (b, 0), (b, a), (s, a), (s, b), (b, b), (b, s), (a, s), (a, b), (0, b), (0, a), (a, a)]
        body = f'  <path d="M {_pts(pts).replace(",", " ")} Z" {paint}/>'
    elif kind == "crescent":
        # outer disc radius r at (c, c) minus a disc of radius ri centred d to the right
        ri, d = 0.8 * r, 0.45 * r
        x = (r * r - ri * ri + d * d) / (2 * d)  # intersection abscissa, relative to the centre
        y = math.sqrt(max(r * r - x * x, 0.0))
        top, bot = (c + x, c - y), (c + x, c + y)
        # outer arc top -> bottom through the left; inner arc back through the inner circle's left
        large_out = 1 if x > 0 else 0
        large_in = 1 if x > d else 0
        body = (f'  <path d="M {_num(top[0])} {_num(top[1])} '
                f'A {_num(r)} {_num(r)} 0 {large_out} 0 {_num(bot[0])} {_num(bot[1])} '
                f'A {_num(ri)} {_num(ri)} 0 {large_in} 1 {_num(top[0])} {_num(top[1])} Z" {paint}/>')
    elif kind == "heart":
        # two lobes (cubic Béziers) meeting in a notch at the top and a point at the bottom
        h = 0.9 * s
        body = (f'  <path d="M {_num(0.5 * s)} {_num(0.22 * s)} '
                f'C {_num(0.5 * s)} {_num(0.0)} {_num(0.0)} {_num(-0.02 * s)} {_num(0.02 * s)} {_num(0.3 * s)} '
                f'C {_num(0.04 * s)} {_num(0.55 * s)} {_num(0.35 * s)} {_num(0.7 * s)} {_num(0.5 * s)} {_num(h)} '
                f'C {_num(0.65 * s)} {_num(0.7 * s)} {_num(0.96 * s)} {_num(0.55 * s)} {_num(0.98 * s)} {_num(0.3 * s)} '
                f'C {_num(s)} {_num(-0.02 * s)} {_num(0.5 * s)} {_num(0.0)} {_num(0.5 * s)} {_num(0.22 * s)} Z" '
                f'{paint}/>')
    elif kind == "bean":
        # a kidney: two round ends joined by a convex back and a concave (dented) front
        h = 0.6 * s
        body = (f'  <path d="M {_num(0.25 * s)} {_num(0.0)} '
                f'C {_num(0.45 * s)} {_num(0.0)} {_num(0.45 * s)} {_num(0.14 * s)} {_num(0.5 * s)} {_num(0.14 * s)} '
                f'C {_num(0.55 * s)} {_num(0.14 * s)} {_num(0.55 * s)} {_num(0.0)} {_num(0.75 * s)} {_num(0.0)} '
                f'C {_num(0.92 * s)} {_num(0.0)} {_num(s)} {_num(0.14 * s)} {_num(s)} {_num(0.3 * s)} '
                f'C {_num(s)} {_num(0.5 * s)} {_num(0.8 * s)} {_num(h)} {_num(0.5 * s)} {_num(h)} '
                f'C {_num(0.2 * s)} {_num(h)} {_num(0.0)} {_num(0.5 * s)} {_num(0.0)} {_num(0.3 * s)} '
                f'C {_num(0.0)} {_num(0.14 * s)} {_num(0.08 * s)} {_num(0.0)} {_num(0.25 * s)} {_num(0.0)} Z" '
                f'{paint}/>')
    elif kind == "gear":
        # 10 trapezoidal teeth: root radius 0.78 r, tip radius r
        n, pts = 10, []
        for i in range(n):
            t0 = -math.pi / 2 + i * 2 * math.pi / n
            for dt, rad in ((-0.5, 0.78), (-0.3, 1.0), (0.0, 1.0), (0.2, 0.78)):
                t = t0 + dt * 2 * math.pi / n
                pts.append((c + rad * r * math.cos(t), c + rad * r * math.sin(t)))
        body = f'  <polygon points="{_pts(pts)}" {paint}/>'
    elif kind == "arrow":
        # a shaft 0.16 wide and a triangular head 0.5 wide, 0.35 long, pointing right
        h = 0.5 * s
        a, b = 0.25 * s - 0.08 * s, 0.25 * s + 0.08 * s
        pts = [(0, a), (0.65 * s, a), (0.65 * s, 0), (s, 0.25 * s), (0.65 * s, h), (0.65 * s, b), (0, b)]
        body = f'  <polygon points="{_pts(pts)}" {paint}/>'
    elif kind == "ell":
        # an L: two arms 0.25 wide
        t = 0.25 * s
        pts = [(0, 0), (t, 0), (t, s - t), (s, s - t), (s, s), (0, s)]
        body = f'  <polygon points="{_pts(pts)}" {paint}/>'
    elif kind == "keyhole":
        # a disc (radius 0.3) on a neck 0.12 wide, on a foot 0.6 wide: one outline
        rr, cy, hw = 0.3 * s, 0.3 * s, 0.06 * s
        yj = cy + math.sqrt(rr * rr - hw * hw)  # where the neck leaves the disc
        body = (f'  <path d="M {_num(c - hw)} {_num(yj)} A {_num(rr)} {_num(rr)} 0 1 1 {_num(c + hw)} {_num(yj)} '
                f'L {_num(c + hw)} {_num(0.72 * s)} L {_num(0.8 * s)} {_num(0.72 * s)} L {_num(0.8 * s)} {_num(s)} '
                f'L {_num(0.2 * s)} {_num(s)} L {_num(0.2 * s)} {_num(0.72 * s)} L {_num(c - hw)} {_num(0.72 * s)} Z" '
                f'{paint}/>')
    elif kind == "thinring":
        body = (f'  <path fill-rule="evenodd" d="{_circle_d(c, c, r)} {_circle_d(c, c, 0.85 * r)}" {paint}/>')
    elif kind == "pentagon":
        pts = _regular(c, c, r, 5)
        body = f'  <polygon points="{_pts(pts)}" {paint}/>'
        h = float(pts[:, 1].max())
    elif kind == "ellipse":
        h = s / 3
        body = f'  <ellipse cx="{_num(c)}" cy="{_num(h / 2)}" rx="{_num(r)}" ry="{_num(h / 2)}" {paint}/>'
    elif kind == "bullseye":
        # a ring (inner radius 0.7) with a disc (radius 0.35) in its hole: one element
        body = (f'  <path fill-rule="evenodd" d="{_circle_d(c, c, r)} {_circle_d(c, c, 0.7 * r)} '
                f'{_circle_d(c, c, 0.35 * r)}" {paint}/>')
    elif kind == "dots":
        # three separate discs
        body = "\n".join(f'  <circle cx="{_num(x * s)}" cy="{_num(y * s)}" r="{_num(q * s)}" {paint}/>'
                         for x, y, q in ((0.2, 0.2, 0.18), (0.8, 0.25, 0.15), (0.48, 0.78, 0.2)))
    elif kind == "spiral":
        # a band 0.09 wide winding 1.6 turns out from the centre
        t = np.linspace(0.0, 1.0, 120)
        a, rad = 2 * math.pi * 1.6 * t, (0.1 + 0.34 * t) * s
        out = np.column_stack([c + (rad + 0.045 * s) * np.cos(a), c + (rad + 0.045 * s) * np.sin(a)])
        inn = np.column_stack([c + (rad - 0.045 * s) * np.cos(a), c + (rad - 0.045 * s) * np.sin(a)])
        body = f'  <polygon points="{_pts(np.vstack([out, inn[::-1]]))}" {paint}/>'
    elif kind == "comb":
        # a back 0.3 deep and four teeth 0.1 wide
        pts = [(0, s), (s, s), (s, 0), (0.9 * s, 0), (0.9 * s, 0.7 * s)]
        for x in (0.675, 0.45, 0.225):
            pts += [((x + 0.05) * s, 0.7 * s), ((x + 0.05) * s, 0), ((x - 0.05) * s, 0), ((x - 0.05) * s, 0.7 * s)]
        pts += [(0.1 * s, 0.7 * s), (0.1 * s, 0), (0, 0)]
        body = f'  <polygon points="{_pts(pts)}" {paint}/>'
    elif kind == "zigzag":
        # a lightning bolt
        pts = [(0.35, 0), (0.75, 0), (0.55, 0.4), (0.8, 0.4), (0.25, 1.0), (0.4, 0.55), (0.15, 0.55)]
        body = f'  <polygon points="{_pts([(x * s, y * s) for x, y in pts])}" {paint}/>'
    elif kind == "lineart":
        # an open quadratic stroked 0.06 wide with round caps (no fill)
        body = (f'  <path d="M {_num(0.1 * s)} {_num(0.9 * s)} Q {_num(c)} {_num(-0.3 * s)} {_num(0.9 * s)} '
                f'{_num(0.9 * s)}" fill="none" stroke="{colour}" stroke-width="{_num(0.06 * s)}" '
                f'stroke-linecap="round"/>')
    else:  # ring
        body = (f'  <path fill-rule="evenodd" d="{_circle_d(c, c, r)} {_circle_d(c, c, 0.6 * r)}" {paint}/>')
    return _svg(w, h, body)


def _glyph_path(char: str, size: float):
    from matplotlib.font_manager import FontProperties, findfont
    from matplotlib.textpath import TextPath

    if len(char) != 1 or char.isspace():
        raise ParameterError(f"a glyph element is one visible character, got {char!r}")
    prop = FontProperties(family="DejaVu Sans")
    findfont(prop, fallback_to_default=False)  # raises if matplotlib's DejaVu is missing
    return TextPath((0, 0), char, size=size, prop=prop)


def glyph_svg(char: str, size: float = 100.0, scale: float = 1.0, fill: str | None = None) -> str:
    """SVG text of one DejaVu Sans glyph as a compound path (``fill-rule="evenodd"``,
    so counters are holes), curves kept as quadratic / cubic Béziers, ``size × scale``
    the font size in user units. The glyph's box starts at (0, 0), y down."""
    s = float(size) * _check_scale(scale)
    path = _glyph_path(char, s)
    v = np.asarray(path.vertices, dtype=float)
    if len(v) == 0:
        raise ParameterError(f"glyph {char!r} has no outline in DejaVu Sans")
    x0, y1 = float(v[:, 0].min()), float(v[:, 1].max())
    y0 = float(v[:, 1].min())
    x1 = float(v[:, 0].max())

    def tr(x, y):
        return f"{_num(x - x0)} {_num(y1 - y)}"  # y up -> y down, box at the origin

    parts = []
    for verts, code in path.iter_segments(curves=True, simplify=False):
        p = np.asarray(verts, dtype=float).reshape(-1, 2)
        if code == 1:
            parts.append("M " + tr(*p[0]))
        elif code == 2:
            parts.append("L " + tr(*p[0]))
        elif code == 3:
            parts.append("Q " + tr(*p[0]) + " " + tr(*p[1]))
        elif code == 4:
            parts.append("C " + " ".join(tr(*q) for q in p))
        elif code == 79:
            parts.append("Z")
    colour = fill or _COLOURS["glyph"]
    body = f'  <path fill-rule="evenodd" fill="{colour}" d="{" ".join(parts)}"/>'
    return _svg(x1 - x0, y1 - y0, body)


def _size_and_d(svg_text: str) -> tuple[float, float, str]:
    """Width, height and the (first) path data of an SVG text written by this module."""
    m = re.search(r'width="([^"]+)" height="([^"]+)"', svg_text)
    return float(m.group(1)), float(m.group(2)), re.search(r' d="([^"]+)"', svg_text).group(1)


def container_svg(kind: str, size: float = 1000.0, scale: float = 1.0) -> str:
    """SVG text of a container whose larger side is ``size × scale`` user units.

    ``kind``: ``circle`` (a ``<circle>``), ``square`` (a ``<rect>``), ``star`` (a sharp
    5-pointed star polygon, inner radius 0.45 of the outer), ``band`` (a curved band: an
    annular sector of 240° with radii 0.55 and 1 of the outer, drawn with arcs),
    ``holed`` (a square with a round hole of 0.35 of its side, ``fill-rule="evenodd"``),
    ``two`` (two regions: a disc and a square side by side, one file).
    """
    s = float(size) * _check_scale(scale)
    if not s > 0:
        raise ParameterError(f"size must be positive, got {size!r}")
    style = 'fill="none" stroke="#000000" stroke-width="' + _num(s / 500) + '"'
    c, r = 0.5 * s, 0.5 * s
    w = h = s
    if kind == "circle":
        body = f'  <circle cx="{_num(c)}" cy="{_num(c)}" r="{_num(r)}" {style}/>'
    elif kind == "square":
        body = f'  <rect x="0" y="0" width="{_num(s)}" height="{_num(s)}" {style}/>'
    elif kind == "star":
        pts = _star(0.0, 0.0, 1.0, 0.45, 5)
        pts -= pts.min(axis=0)
        pts *= s / pts.max()  # the wider side (tip to tip) is s
        w, h = float(pts[:, 0].max()), float(pts[:, 1].max())
        body = f'  <polygon points="{_pts(pts)}" {style}/>'
    elif kind == "band":
        r_in = 0.55 * r
        t0, t1 = math.radians(150.0), math.radians(390.0)  # 240°, opening downwards (y down)
        cy = r  # circle centre; the band's top is at y = 0
        p = lambda rad, t: (c + rad * math.cos(t), cy + rad * math.sin(t))  # noqa: E731
        a, b = p(r, t0), p(r, t1)
        e, f = p(r_in, t1), p(r_in, t0)
        body = (f'  <path d="M {_num(a[0])} {_num(a[1])} A {_num(r)} {_num(r)} 0 1 1 {_num(b[0])} {_num(b[1])} '
                f'L {_num(e[0])} {_num(e[1])} A {_num(r_in)} {_num(r_in)} 0 1 0 {_num(f[0])} {_num(f[1])} Z" '
                f'{style}/>')
        h = cy + r * math.sin(math.radians(30.0))  # the band's lowest points are its two ends
    elif kind == "holed":
        hole = 0.35 * 0.5 * s
        body = (f'  <path fill-rule="evenodd" d="M 0 0 H {_num(s)} V {_num(s)} H 0 Z '
                f'{_circle_d(c, c, hole)}" {style}/>')
    elif kind == "two":
        h = 0.46 * s
        rr = 0.23 * s
        q0 = 0.52 * s
        body = (f'  <circle cx="{_num(rr)}" cy="{_num(rr)}" r="{_num(rr)}" {style}/>\n'
                f'  <rect x="{_num(q0)}" y="0" width="{_num(s - q0)}" height="{_num(h)}" {style}/>')
    elif kind == "triangle":
        h = s * math.sqrt(3) / 2
        body = f'  <polygon points="{_pts([(c, 0.0), (s, h), (0.0, h)])}" {style}/>'
    elif kind == "ellipse":
        h = 0.5 * s
        body = f'  <ellipse cx="{_num(c)}" cy="{_num(h / 2)}" rx="{_num(r)}" ry="{_num(h / 2)}" {style}/>'
    elif kind == "annulus":
        body = f'  <path fill-rule="evenodd" d="{_circle_d(c, c, r)} {_circle_d(c, c, 0.45 * r)}" {style}/>'
    elif kind == "ell":
        t = 0.45 * s
        body = f'  <polygon points="{_pts([(0, 0), (t, 0), (t, s - t), (s, s - t), (s, s), (0, s)])}" {style}/>'
    elif kind == "hexagon":
        pts = _regular(0.0, 0.0, 1.0, 6, phase=0.0)  # flat top and bottom, corners left and right
        pts -= pts.min(axis=0)
        pts *= s / pts.max()
        w, h = float(pts[:, 0].max()), float(pts[:, 1].max())
        body = f'  <polygon points="{_pts(pts)}" {style}/>'
    elif kind == "glyph":
        w, h, _ = _size_and_d(glyph_svg(GLYPH_CONTAINER_CHAR, 100.0))
        w, h, d = _size_and_d(glyph_svg(GLYPH_CONTAINER_CHAR, 100.0 * s / max(w, h)))  # larger side s
        body = f'  <path fill-rule="evenodd" d="{d}" {style}/>'
    elif kind == "crescent":
        # the crescent element's outline (two arcs; horns tapering to points)
        w, h, d = _size_and_d(element_svg("crescent", s))
        body = f'  <path d="{d}" {style}/>'
    elif kind == "cross":
        a, b = 0.35 * s, 0.65 * s
        pts = [(a, 0), (b, 0), (b, a), (s, a), (s, b), (b, b), (b, s), (a, s), (a, b), (0, b), (0, a), (a, a)]
        body = f'  <polygon points="{_pts(pts)}" {style}/>'
    elif kind == "target":
        # a ring (inner radius 0.66) and a disc (0.36) in its hole: two regions, one inside the other
        body = (f'  <path fill-rule="evenodd" d="{_circle_d(c, c, r)} {_circle_d(c, c, 0.66 * r)} '
                f'{_circle_d(c, c, 0.36 * r)}" {style}/>')
    else:
        raise ParameterError(f"unknown container kind {kind!r}; known: {', '.join(CONTAINER_KINDS)}")
    return _svg(w, h, body)


# --------------------------------------------------------------------------- scenes


@dataclass(frozen=True)
class SceneFiles:
    """A scene written to disk: the files and the absolute gap to pass to ``pack``."""

    scene: "Scene"
    container: Path
    elements: tuple[Path, ...]
    gap: float  # container user units

    def categories(self) -> dict[str, str]:
        """``data-source`` file name -> element category."""
        return {p.name: element_category(p.name) for p in self.elements}


@dataclass(frozen=True)
class Scene:
    """One packing problem of the suite.

    ``container``: one of :data:`CONTAINER_KINDS`; ``elements``: element kinds
    (:data:`ELEMENT_KINDS`, or ``"glyph-X"`` for the letter X); ``gap``: the gap as a
    fraction of the container's larger side (0.005 = 0.5 %); ``count``: number of
    primary elements; ``scale``: the drawing scale of the whole scene (container and
    elements, 1 = a 1000-unit container); ``tags``: the categories it exercises
    (convex / spiky / thin / holed / letter, derived from the elements).
    """

    name: str
    container: str
    elements: tuple[str, ...]
    gap: float = 0.01
    count: int = 30
    seed: int = 1
    scale: float = 1.0
    tags: tuple[str, ...] = field(default=())

    def __post_init__(self):
        if not self.name or any(ch in self.name for ch in "/\\ "):
            raise ParameterError(f"scene name {self.name!r} must be a non-empty word (no spaces or slashes)")
        if self.container not in CONTAINER_KINDS:
            raise ParameterError(f"scene {self.name}: unknown container {self.container!r}")
        if not self.elements:
            raise ParameterError(f"scene {self.name}: no elements")
        cats = tuple(sorted({element_category(e) for e in self.elements}))
        if not self.tags:
            object.__setattr__(self, "tags", cats)
        if not (0 < self.gap < 0.25):
            raise ParameterError(f"scene {self.name}: gap must be a fraction of the container in (0, 0.25)")
        if self.count < 1:
            raise ParameterError(f"scene {self.name}: count must be >= 1")
        _check_scale(self.scale, f"scene {self.name}: scale")

    @property
    def size(self) -> float:
        """The container's larger side in user units."""
        return 1000.0 * self.scale

    @property
    def gap_units(self) -> float:
        """The gap in the container's user units."""
        return float(f"{self.gap * self.size:.6g}")

    @property
    def category(self) -> str:
        """A short label: the single category, or ``mixed``."""
        return self.tags[0] if len(self.tags) == 1 else "mixed"

    def write(self, root: str | Path) -> SceneFiles:
        """Write the container and element SVGs under ``root/<name>/`` (atomically)."""
        base = Path(root) / self.name
        (base / "elements").mkdir(parents=True, exist_ok=True)
        cont = base / f"container-{self.container}.svg"
        atomic_write_bytes(cont, container_svg(self.container, scale=self.scale).encode())
        files = []
        for kind in dict.fromkeys(self.elements):  # unique, in order
            f = base / "elements" / f"{kind}.svg"
            atomic_write_bytes(f, element_svg(kind, scale=self.scale).encode())
            files.append(f)
        return SceneFiles(self, cont, tuple(files), self.gap_units)


_CONVEX = ("square", "disc", "triangle", "hexagon")
_SPIKY = ("star5", "star8")
_THIN = ("bar", "cross", "crescent")
_HOLED = ("ring", "glyph-O", "glyph-A")
_LETTERS = tuple(f"glyph-{c}" for c in "ABORSg&")
_MIXED = ("square", "disc", "star5", "bar", "crescent", "ring", "glyph-R")


def suite() -> list[Scene]:
    """The full matrix (26 scenes): convex, spiky, thin, holed, letter and mixed
    elements in circle, square, sharp star, curved band, holed and two-region
    containers; gaps 0.5–3 % of the container; drawing scales 0.01× to 100×; 5 to 300
    elements."""
    S = Scene
    return [
        # convex
        S("convex-circle", "circle", _CONVEX, gap=0.01, count=40, seed=1),
        S("squares-square", "square", ("square",), gap=0.01, count=36, seed=2),
        S("discs-star", "star", ("disc",), gap=0.008, count=40, seed=3),
        S("hexagons-holed", "holed", ("hexagon",), gap=0.015, count=30, seed=4),
        S("triangles-band", "band", ("triangle",), gap=0.01, count=40, seed=5),
        S("convex-two-300", "two", _CONVEX, gap=0.005, count=300, seed=6),
        S("convex-circle-5", "circle", ("square", "disc"), gap=0.03, count=5, seed=7),
        # spiky
        S("stars-circle", "circle", _SPIKY, gap=0.01, count=40, seed=11),
        S("stars-square-x100", "square", ("star5",), gap=0.01, count=30, seed=12, scale=100.0),
        S("stars-band", "band", _SPIKY, gap=0.02, count=25, seed=13),
        # thin
        S("thin-circle", "circle", _THIN, gap=0.01, count=40, seed=21),
        S("bars-square", "square", ("bar",), gap=0.005, count=60, seed=22),
        S("crosses-star", "star", ("cross",), gap=0.01, count=30, seed=23),
        S("crescents-holed-x0.01", "holed", ("crescent",), gap=0.02, count=25, seed=24, scale=0.01),
        S("thin-two", "two", _THIN, gap=0.01, count=40, seed=25),
        # holed
        S("rings-circle", "circle", ("ring",), gap=0.01, count=30, seed=31),
        S("rings-square-x10", "square", ("ring",), gap=0.03, count=12, seed=32, scale=10.0),
        S("holed-band", "band", _HOLED, gap=0.01, count=35, seed=33),
        # letters
        S("letters-circle", "circle", _LETTERS, gap=0.01, count=40, seed=41),
        S("letters-square-x0.1", "square", _LETTERS, gap=0.01, count=40, seed=42, scale=0.1),
        S("letters-holed", "holed", _LETTERS, gap=0.015, count=30, seed=43),
        S("letters-star", "star", ("glyph-A", "glyph-S", "glyph-g"), gap=0.008, count=40, seed=44),
        S("letters-two-x100", "two", _LETTERS, gap=0.01, count=40, seed=45, scale=100.0),
        # mixed
        S("mixed-circle-120", "circle", _MIXED, gap=0.006, count=120, seed=51),
        S("mixed-band-x0.01", "band", _MIXED, gap=0.01, count=40, seed=52, scale=0.01),
        S("mixed-square-300", "square", _MIXED, gap=0.005, count=300, seed=53),
    ]


def fast_suite() -> list[Scene]:
    """Four small scenes (5–12 elements) that pack in a few seconds each: convex, spiky
    and thin, holed (and at 10× scale), letters in a holed container."""
    S = Scene
    return [
        S("fast-convex", "circle", ("square", "disc", "hexagon"), gap=0.02, count=10, seed=101),
        S("fast-spiky-thin", "square", ("star5", "bar", "crescent"), gap=0.02, count=10, seed=102),
        S("fast-rings-x10", "circle", ("ring",), gap=0.03, count=6, seed=103, scale=10.0),
        S("fast-letters", "holed", ("glyph-A", "glyph-g", "glyph-R"), gap=0.02, count=10, seed=104),
    ]


_H_CONVEX = ("pentagon", "ellipse")
_H_SMOOTH = ("heart", "bean")
_H_THIN = ("arrow", "ell", "keyhole")
_H_LETTERS = tuple(f"glyph-{c}" for c in "KMWx%@3y")
_H_MIXED = ("heart", "gear", "arrow", "thinring", "ellipse", "glyph-K", "glyph-@", "disc", "cross")


def holdout_suite() -> list[Scene]:
    """A held-out suite (27 scenes) never used to tune the packing: new element kinds
    (heart, bean, gear, arrow, L, keyhole, thin ring, pentagon, 3:1 ellipse; glyphs
    K M W x % @ 3 y) and new containers (triangle, 2:1 ellipse, wide annulus, L shape,
    a big letter C, hexagon) mixed with the old ones; gaps 0.5–3 %, scales 0.01×–100×,
    5 to 200 elements; seeds from 201. The last seven ("ho-stress-*") push the ranges
    corners (0.5 % gaps with thin parts or letters, 5–6 elements at a 3 % gap)."""
    S = Scene
    return [
        # convex, elongated
        S("ho-ellipses-triangle", "triangle", ("ellipse",), gap=0.01, count=40, seed=201),
        S("ho-pentagons-annulus", "annulus", ("pentagon",), gap=0.015, count=35, seed=202),
        S("ho-convex-ell-x100", "ell", _H_CONVEX + ("square",), gap=0.01, count=40, seed=203, scale=100.0),
        # smooth concave and spiky
        S("ho-hearts-ellipse", "ellipse", ("heart",), gap=0.01, count=40, seed=204),
        S("ho-beans-hexagon", "hexagon", ("bean",), gap=0.02, count=25, seed=205),
        S("ho-gears-circle", "circle", ("gear",), gap=0.008, count=40, seed=206),
        S("ho-gears-glyph", "glyph", ("gear", "star5"), gap=0.01, count=30, seed=207),
        # thin
        S("ho-arrows-square", "square", ("arrow",), gap=0.006, count=50, seed=208),
        S("ho-ells-triangle-x0.01", "triangle", ("ell",), gap=0.02, count=25, seed=209, scale=0.01),
        S("ho-keyholes-annulus", "annulus", ("keyhole",), gap=0.01, count=40, seed=210),
        S("ho-thin-glyph", "glyph", _H_THIN + ("bar",), gap=0.008, count=45, seed=211),
        # holed
        S("ho-thinrings-hexagon", "hexagon", ("thinring",), gap=0.01, count=30, seed=212),
        S("ho-thinrings-ell-x10", "ell", ("thinring", "ring"), gap=0.03, count=8, seed=213, scale=10.0),
        # letters
        S("ho-letters-circle", "circle", _H_LETTERS, gap=0.01, count=40, seed=214),
        S("ho-letters-triangle-x0.1", "triangle", _H_LETTERS, gap=0.012, count=35, seed=215, scale=0.1),
        S("ho-letters-annulus", "annulus", _H_LETTERS, gap=0.008, count=50, seed=216),
        S("ho-letters-glyph-x100", "glyph", ("glyph-x", "glyph-y", "glyph-3", "glyph-%"), gap=0.01, count=40,
          seed=217, scale=100.0),
        # mixed, and the two large ones
        S("ho-mixed-ellipse-5", "ellipse", ("heart", "glyph-W"), gap=0.03, count=5, seed=218),
        S("ho-mixed-hexagon-150", "hexagon", _H_MIXED, gap=0.005, count=150, seed=219),
        S("ho-mixed-star-200-x0.01", "star", _H_MIXED, gap=0.005, count=200, seed=220, scale=0.01),
        # stress: the corners of the ranges where the first 20 came closest to a limit
        S("ho-stress-thin-ell", "ell", ("arrow", "ell", "bar"), gap=0.005, count=60, seed=221),
        S("ho-stress-few-triangle", "triangle", ("gear", "glyph-%"), gap=0.03, count=5, seed=222),
        S("ho-stress-letters-glyph", "glyph", tuple(f"glyph-{c}" for c in "%@MW"), gap=0.005, count=60,
          seed=223),
        S("ho-stress-keyholes-star-x0.01", "star", ("keyhole", "thinring"), gap=0.005, count=50, seed=224,
          scale=0.01),
        S("ho-stress-few-annulus", "annulus", ("heart", "bean"), gap=0.03, count=6, seed=225),
        S("ho-stress-at-hexagon", "hexagon", ("glyph-@",), gap=0.005, count=60, seed=226),
        S("ho-stress-discs-glyph", "glyph", ("disc", "ellipse"), gap=0.005, count=60, seed=227),
    ]


def write_suite(scenes, root: str | Path) -> list[SceneFiles]:
    """Write every scene under ``root`` (one folder per scene)."""
    names = [s.name for s in scenes]
    if len(set(names)) != len(names):
        raise ParameterError("scene names must be unique")
    return [s.write(root) for s in scenes]


# --------------------------------------------------------------------------- running


def scp_grid(scene: Scene, pixels_per_gap: int = 10, low: int = 1000, high: int = 2400) -> int:
    """SCP raster size for a scene: at least ``pixels_per_gap`` pixels across the gap."""
    return int(min(high, max(low, math.ceil(pixels_per_gap / scene.gap))))


def measure(files: SceneFiles, packing_svg: str | Path, grid: int | None = None) -> dict:
    """Issue 10's metrics of a packing of ``files`` read back from its output SVG.

    The container is re-read from the scene's own file with a fine flattening tolerance
    (gap/2000, finer than the gap/1000 the packing used), so distances and 'outside' are
    measured against the true curved outline, not the polygon the simulation used; the
    sources are the scene's element files.
    Returns the :func:`repulsionpak.measure.evaluate` result plus ``promises``
    (:func:`repulsionpak.measure.check_promises`) and ``sources`` (each element's
    ``data-source``).
    """
    from repulsionpak.measure import evaluate
    from repulsionpak.io import load_container, load_elements, read_packing_svg
    from repulsionpak.measure import check_promises, source_geometries

    container = load_container(files.container, tolerance=files.gap / 2000)
    _, placed, _ = read_packing_svg(packing_svg)
    sources = source_geometries(load_elements(files.elements))
    res = evaluate(container, placed, files.gap, grid=grid or scp_grid(files.scene), sources=sources)
    names = [p.source for p in placed]
    res["sources"] = names
    res["promises"] = check_promises(res, files.categories(), sources=names)
    return res


def run_scene(scene: Scene, workdir: str | Path, grid: int | None = None, png: bool = False, *,
              config: Path | None = None, estimate_count: bool = False) -> dict:
    """Write ``scene`` under ``workdir``, pack it through the library
    (:func:`repulsionpak.pack` on the files, :meth:`repulsionpak.Packing.save`), and
    :func:`measure` the output SVG.

    Parameters
    ----------
    scene : Scene
        The packing problem.
    workdir : path
        Where the scene's files and the packing go (``<workdir>/<scene.name>/``).
    grid : int, optional
        SCP raster size (default: :func:`scp_grid`).
    png : bool
        Also save the packing as ``packing.png``.
    config : path, optional
        A TOML parameter file for the packing (as ``--config``); the scene's gap, seed and
        count go on top.
    estimate_count : bool
        Leave the number of primaries to the default estimate instead of the scene's count.

    Returns
    -------
    dict
        ``{"scene", "files", "svg", "png", "report", "metrics", "seconds"}``: ``report`` is
        :meth:`repulsionpak.Packing.report` (what ``--report`` holds, its ``seconds`` with
        ``render`` and ``total`` as the command counts them); ``seconds`` is the wall time
        of the packing, reading the inputs to writing the SVG and PNG.

    Notes
    -----
    The library gives the bytes ``repulsionpak pack`` gives for the same files, seed and
    parameters, so these measurements are those of the command.
    """
    import time

    from repulsionpak import pack
    from repulsionpak.params import Params, load_config

    files = scene.write(workdir)
    base = files.container.parent
    out = base / "packing.svg"
    png_path = base / "packing.png" if png else None
    t0 = time.perf_counter()
    params = (load_config(config) if config else Params()).with_(gap=files.gap, seed=scene.seed)
    if not estimate_count:
        params = params.with_(placement__count=scene.count)
    packing = pack(files.container, list(files.elements), params)
    t_out = time.perf_counter()
    packing.save(out)
    if png_path is not None:
        packing.save(png_path)
    times = dict(packing.seconds)
    times["render"] = times.get("render", 0.0) + (time.perf_counter() - t_out)
    times["total"] = time.perf_counter() - t0
    rep = packing.report(seconds=times)
    seconds = time.perf_counter() - t0
    return {"scene": scene, "files": files, "svg": out, "png": png_path, "report": rep,
            "metrics": measure(files, out, grid), "seconds": seconds}
