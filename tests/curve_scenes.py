"""Small scenes for the output-curve tests and ``benchmarks/output_curves.py``.

Every scene is written as SVG files into a folder: an 800-unit artboard with a circular
container drawn as ``<circle>``, and elements drawn with curves: a disc (``<circle>``), a
square (``<rect>``), letters (quadratic Béziers from the DejaVu Sans outlines that
matplotlib ships), and a styled badge (linear and radial gradients, a pattern, a stroke,
``<use>``, ids).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

CONTAINER = """<?xml version="1.0" encoding="UTF-8"?>
<svg xmlns="http://www.w3.org/2000/svg" width="800" height="800" viewBox="0 0 800 800">
  <g transform="translate(400 400)">
    <circle id="frame" cx="0" cy="0" r="380" fill="none" stroke="#222222" stroke-width="3"/>
  </g>
</svg>
"""

DISC = """<svg xmlns="http://www.w3.org/2000/svg" width="100" height="100" viewBox="0 0 100 100">
  <circle cx="50" cy="50" r="45" fill="#e76f51"/>
</svg>
"""

SQUARE = """<svg xmlns="http://www.w3.org/2000/svg" width="100" height="100" viewBox="0 0 100 100">
  <rect x="5" y="5" width="90" height="90" fill="#2a9d8f"/>
</svg>
"""

BADGE = """<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink"
     width="100" height="100" viewBox="0 0 100 100">
  <defs>
    <linearGradient id="sky" x1="0" y1="0" x2="1" y2="1">
      <stop offset="0" stop-color="#264653"/><stop offset="1" stop-color="#e9c46a"/>
    </linearGradient>
    <radialGradient id="sun" cx="50" cy="40" r="30" gradientUnits="userSpaceOnUse">
      <stop offset="0" stop-color="#ffffff"/><stop offset="1" stop-color="#f4a261"/>
    </radialGradient>
    <pattern id="dots" width="10" height="10" patternUnits="userSpaceOnUse">
      <circle cx="5" cy="5" r="2.5" fill="#e76f51"/>
    </pattern>
    <path id="leaf" d="M0,0 C6,-8 14,-8 20,0 C14,8 6,8 0,0 Z"/>
  </defs>
  <path id="body" d="M10,50 C10,20 30,8 50,8 C70,8 90,20 90,50 C90,80 70,92 50,92 C30,92 10,80 10,50 Z"
        fill="url(#sky)" stroke="#1d3557" stroke-width="3"/>
  <circle cx="50" cy="40" r="18" fill="url(#sun)"/>
  <rect x="25" y="62" width="50" height="16" rx="4" fill="url(#dots)" stroke="#1d3557" stroke-width="1.5"/>
  <use xlink:href="#leaf" x="28" y="28" fill="#8ab17d"/>
</svg>
"""

LETTERS = "aegRS&"


def letter_svg(ch: str, size: float = 100.0) -> str:
    """One glyph of DejaVu Sans as an SVG path (quadratic Béziers and lines, 2 decimals)."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.path import Path as MPath
    from matplotlib.textpath import TextPath

    tp = TextPath((0, 0), ch, size=size, prop=FontProperties(family="DejaVu Sans"))
    v = tp.vertices.copy()
    x0 = v[:, 0].min()
    h = v[:, 1].max()
    v[:, 0] -= x0 - 5
    v[:, 1] = h - v[:, 1] + 5  # y down
    parts = []
    i = 0
    codes = tp.codes

    def f(p):
        return f"{p[0]:.2f} {p[1]:.2f}".replace(".00", "")

    while i < len(codes):
        c = codes[i]
        if c == MPath.MOVETO:
            parts.append("M" + f(v[i]))
            i += 1
        elif c == MPath.LINETO:
            parts.append("L" + f(v[i]))
            i += 1
        elif c == MPath.CURVE3:
            parts.append("Q" + f(v[i]) + " " + f(v[i + 1]))
            i += 2
        elif c == MPath.CURVE4:
            parts.append("C" + f(v[i]) + " " + f(v[i + 1]) + " " + f(v[i + 2]))
            i += 3
        elif c == MPath.CLOSEPOLY:
            parts.append("Z")
            i += 1
        else:
            i += 1
    w = float(np.ceil(v[:, 0].max() + 5))
    hh = float(np.ceil(v[:, 1].max() + 5))
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{w:g}" height="{hh:g}" viewBox="0 0 {w:g} {hh:g}">\n'
            f'  <path fill="#1d3557" d="{"".join(parts)}"/>\n</svg>\n')


def write_scene(folder: Path, name: str) -> tuple[Path, list[Path]]:
    """Write scene ``name`` ("discs", "squares", "letters", "badges", "mixed") into
    ``folder``; returns (container file, element files)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    cont = folder / "container.svg"
    cont.write_text(CONTAINER)
    files = []
    if name in ("discs", "mixed"):
        files.append(folder / "disc.svg")
        files[-1].write_text(DISC)
    if name in ("squares", "mixed"):
        files.append(folder / "square.svg")
        files[-1].write_text(SQUARE)
    if name in ("badges", "mixed"):
        files.append(folder / "badge.svg")
        files[-1].write_text(BADGE)
    if name in ("letters", "mixed"):
        for ch in LETTERS if name == "letters" else "gS":
            stem = {"&": "amp"}.get(ch, ch + ("_upper" if ch.isupper() else ""))
            files.append(folder / f"letter_{stem}.svg")
            files[-1].write_text(letter_svg(ch))
    if not files:
        raise ValueError(f"unknown scene {name!r}")
    return cont, files
