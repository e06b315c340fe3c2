"""Markers (arrowheads, vertex dots) are drawn as the art they put on a path
(repulsionpak.io.svg_markers through the SVG reader): placed, turned and scaled as
browsers do, compared pixel by pixel with resvg, an independent renderer, when it is
installed; and packed and written like the rest of the element's art."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import shapely

from render_checks import differs_only_along_edges, our_mask, pack_copies, resvg_mask
from repulsionpak.art_area import art_area
from repulsionpak.io import load_element

ARROW = """<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">
  <defs>
    <marker id="head" viewBox="0 0 10 10" refX="5" refY="5" markerWidth="6" markerHeight="6"
            orient="auto-start-reverse">
      <path d="M 0 0 L 10 5 L 0 10 z" fill="#c00"/>
    </marker>
    <marker id="dot" viewBox="0 0 10 10" refX="5" refY="5" markerWidth="4" markerHeight="4">
      <circle cx="5" cy="5" r="5" fill="context-stroke"/>
    </marker>
  </defs>
  <path d="M 15,80 L 40,30 Q 60,0 85,25" fill="none" stroke="#036" stroke-width="3"
        marker-start="url(#head)" marker-end="url(#head)" marker-mid="url(#dot)"/>
</svg>"""

# as Inkscape writes its arrows: no viewBox, the content turned and moved by its own
# transform, paints from the line (context-stroke), in a transformed group
INKSCAPE = """<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">
  <defs>
    <marker style="overflow:visible" id="Arrow1Lend" refX="0" refY="0" orient="auto">
      <path transform="scale(0.8) rotate(180) translate(12.5,0)"
            style="fill-rule:evenodd;fill:context-stroke;stroke:context-stroke;stroke-width:1"
            d="M 0,0 5,-5 -12.5,0 5,5 z"/>
    </marker>
  </defs>
  <g transform="translate(5,5) scale(0.9)">
    <polyline points="10,90 50,20 90,60" fill="none" style="stroke:#080;stroke-width:1.5"
              marker-end="url(#Arrow1Lend)"/>
    <line x1="10" y1="10" x2="60" y2="10" stroke="#008" stroke-width="2"
          marker-start="url(#Arrow1Lend)" marker-end="url(#Arrow1Lend)"/>
  </g>
</svg>"""


def _load(tmp_path: Path, name: str, text: str):
    p = tmp_path / name
    p.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # markers are drawn: no "skipped" warning
        return p, load_element(p)


def test_markers_are_drawn_where_and_how_browsers_draw_them(tmp_path):
    p, e = _load(tmp_path, "arrow.svg", ARROW)
    # the line, the start head, the dot on the one middle vertex, the end head
    assert [(a.style.fill, a.style.stroke) for a in e.paths] == [
        (None, "#003366"), ("#cc0000", None), ("#003366", None), ("#cc0000", None)]
    start, dot, end = (art_area([a]) for a in e.paths[1:])
    # 6 stroke widths (3) across: the head's tip points back along the line at the start
    # (auto-start-reverse) and forward at the end
    assert start.area == pytest.approx(0.5 * 18 * 18, rel=1e-3)
    assert end.area == pytest.approx(0.5 * 18 * 18, rel=1e-3)
    assert shapely.Point(15, 80).distance(start.centroid) < 4 and shapely.Point(85, 25).distance(end.centroid) < 4
    tip_start = max(np.asarray(start.exterior.coords), key=lambda q: math.dist(q, (40, 30)))
    assert tip_start[1] > 80  # beyond the start, away from the line
    assert dot.area == pytest.approx(math.pi * 6 ** 2, rel=3e-2) and dot.centroid.distance(shapely.Point(40, 30)) < 1e-6


@pytest.mark.parametrize("name", ["ARROW", "INKSCAPE"])
def test_markers_match_an_independent_renderer(name, tmp_path):
    pytest.importorskip("resvg_py")
    p, e = _load(tmp_path, f"{name}.svg", globals()[name])
    n = 400
    ref = resvg_mask(p, n, n)
    ours = our_mask(e.paths, n, n, n / 100)
    lines = [e.paths[i] for i in ((0,) if name == "ARROW" else (0, 2))]  # the marked shapes
    without = our_mask(lines, n, n, n / 100)
    assert ours.sum() > without.sum() + 0.05 * ref.sum()  # the markers are a good part of the art
    ok, diff, edge = differs_only_along_edges(ref, ours)
    assert ok, (diff, edge)


def test_a_marker_naming_nothing_warns_and_the_line_is_kept(tmp_path):
    p = tmp_path / "m.svg"
    p.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
                 '<path d="M 10,50 L 90,50" stroke="#000" stroke-width="4" marker-end="url(#gone)"/></svg>')
    with pytest.warns(UserWarning, match=r"marker-end naming no <marker> \(gone\)"):
        e = load_element(p)
    assert len(e.paths) == 1


def test_packed_copies_carry_their_arrowheads(tmp_path):
    """``repulsionpak pack`` with an arrow element: every written copy has the line and
    both heads, and the heads take part in the gap (they are art)."""
    p, _ = _load(tmp_path, "arrow.svg", ARROW)
    placed = pack_copies(p, tmp_path / "o.svg", 5)
    assert len(placed) == 5
    for pa in placed:
        assert [a.style.fill for a in pa.paths] == [None, "#cc0000", "#003366", "#cc0000"]
