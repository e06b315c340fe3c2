"""``<text>`` is drawn as glyph outlines (repulsionpak.io.svg_text through the SVG reader):
laid out as browsers lay out a line — compared pixel by pixel with resvg, an independent
renderer, given the same font files — and packed and written like the rest of the art."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest
import shapely

from render_checks import differs_only_along_edges, our_mask, pack_copies, resvg_mask
from repulsionpak.art_area import art_area
from repulsionpak.io import load_element, load_elements

# fonts matplotlib ships (DejaVu Sans and Serif, STIX), so the test does not depend on the
# system's; positions, anchors, a tspan that moves the pen, units, the font shorthand in a
# style sheet, inheritance from a group, and preserved spaces
TEXT = """<svg xmlns="http://www.w3.org/2000/svg" width="200" height="120" viewBox="0 0 200 120">
  <style>.big { font: bold 40px 'DejaVu Serif'; }</style>
  <g font-family="DejaVu Sans" fill="#c33">
    <text x="100" y="40" text-anchor="middle" class="big">Ab<tspan fill="#36c" dy="-8">ç</tspan> &amp;</text>
    <text x="195" y="70" font-size="1.5em" text-anchor="end">End<tspan x="195" y="90" font-size="50%">second line</tspan></text>
    <text x="10" y="112" font-size="16" font-style="italic" stroke="#000" stroke-width="0.5">Hello,
      world</text>
    <text x="150" y="112" font-family="DejaVu Sans Mono" font-size="14" xml:space="preserve">a  b</text>
  </g>
</svg>"""


def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_text_is_drawn_as_glyph_outlines_with_its_colours(tmp_path):
    p = _write(tmp_path, "t.svg", TEXT)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # every family is installed: nothing to warn about
        e = load_element(p)
    fills = [a.style.fill for a in e.paths]
    assert fills.count("#3366cc") == 1 and "#cc3333" in fills  # the tspan keeps its own fill
    strokes = {a.style.stroke for a in e.paths}
    assert "#000000" in strokes
    area = art_area(e.paths)
    big = area.intersection(shapely.box(0, 0, 200, 45))
    # anchored in the middle: the line's ink is centred on x = 100 (within a side bearing)
    x0, _, x1, _ = big.bounds
    assert abs(0.5 * (x0 + x1) - 100) < 3
    # anchored at the end: "End" and "second line" end at x = 195 (the last glyph's side bearing)
    end_ink = area.intersection(shapely.box(100, 45, 200, 92))
    assert 190 < end_ink.bounds[2] < 195.01


def test_text_matches_an_independent_renderer_with_the_same_fonts(tmp_path):
    pytest.importorskip("resvg_py")
    import matplotlib

    p = _write(tmp_path, "t.svg", TEXT)
    e = load_element(p)
    k = 4
    fonts = str(Path(matplotlib.get_data_path()) / "fonts" / "ttf")
    ref = resvg_mask(p, 200 * k, 120 * k, skip_system_fonts=True, font_dirs=[fonts])
    ours = our_mask(e.paths, 200 * k, 120 * k, k)
    assert ref.sum() > 0.05 * ref.size  # resvg drew the text
    ok, diff, edge = differs_only_along_edges(ref, ours)
    assert ok, (diff, edge)


def test_font_sizes_in_css_units(tmp_path):
    """12pt is 16px (as Chrome draws it; resvg ignores the unit), 1.5em of a 20px parent is 30px."""
    def ink(size, parent=""):
        p = _write(tmp_path, "s.svg", f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 60">'
                   f'<g {parent}><text x="5" y="40" font-family="DejaVu Sans" font-size="{size}">H</text></g></svg>')
        return art_area(load_element(p).paths).bounds[3] - art_area(load_element(p).paths).bounds[1]

    assert ink("12pt") == pytest.approx(ink("16"), rel=1e-6)
    assert ink("1.5em", 'font-size="20"') == pytest.approx(ink("30px"), rel=1e-6)
    assert ink("50%", 'font-size="20"') == pytest.approx(ink("10"), rel=1e-6)
    assert ink("16") == pytest.approx(0.729 * 16, rel=0.01)  # DejaVu Sans' cap height


def test_a_missing_font_falls_back_to_serif_with_a_warning_naming_it(tmp_path):
    p = _write(tmp_path, "t.svg", '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 40">'
               '<text x="5" y="30" font-family="No Such Font" font-size="20">Ab</text></svg>')
    with pytest.warns(UserWarning, match=r"not installed \(No Such Font\) is drawn in the default serif"):
        e = load_element(p)
    q = _write(tmp_path, "q.svg", '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 40">'
               '<text x="5" y="30" font-family="DejaVu Serif" font-size="20">Ab</text></svg>')
    same = load_element(q)
    assert art_area(e.paths).symmetric_difference(art_area(same.paths)).area < 1e-6


def test_unsupported_layout_is_named(tmp_path):
    p = _write(tmp_path, "t.svg", '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 40">'
               '<text x="5 20 35" y="30" font-family="DejaVu Sans" letter-spacing="3">Abc</text></svg>')
    with pytest.warns(UserWarning, match=r"position per character.*|letter-spacing"):
        e = load_element(p)
    assert art_area(e.paths).area > 50


def test_a_text_element_packs_and_its_copies_are_written_as_curves(tmp_path):
    """A text-only element was refused ("no visible geometry"); now its lettering packs."""
    p = _write(tmp_path, "amp.svg", '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
               '<text x="50" y="80" font-family="DejaVu Sans" font-size="90" text-anchor="middle" '
               'fill="#c33">&amp;</text></svg>')
    source = art_area(load_elements([p])[0].paths)
    out = tmp_path / "o.svg"
    placed = pack_copies(p, out, 6)
    assert len(placed) == 6
    for pa in placed:
        assert all(a.style.fill == "#cc3333" for a in pa.paths)
        copy = art_area(pa.paths)
        # the ampersand's counter survives as a hole
        holes = sum(len(g.interiors) for g in shapely.get_parts(copy))
        assert holes == sum(len(g.interiors) for g in shapely.get_parts(source)) >= 1
    assert "<text" not in out.read_text()


def test_malformed_values_and_missing_glyphs(tmp_path):
    """A malformed size or position is ignored (the inherited one used), and characters the
    font lacks are named in a warning (matplotlib's own warning named no file)."""
    p = _write(tmp_path, "t.svg", '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 40">'
               '<text x="1.2.3" y="30" font-size="1.2.3px" font-family="DejaVu Sans">A</text></svg>')
    x0, y0, _, y1 = art_area(load_element(p).paths).bounds
    assert 0 <= x0 < 1 and y1 == pytest.approx(30, abs=0.01)  # x 0, on the baseline at 30
    assert 30 - y0 == pytest.approx(0.729 * 16, rel=0.01)  # the default 16px
    q = _write(tmp_path, "q.svg", '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 40">'
               '<text x="5" y="30" font-family="DejaVu Sans">A\u65e5</text></svg>')
    with pytest.warns(UserWarning, match="q.svg: characters the font lacks \\(\u65e5\\) are drawn as empty boxes"):
        load_element(q)


def test_a_run_the_font_machinery_cannot_draw_is_left_out_with_a_note(tmp_path, monkeypatch):
    from repulsionpak.io import svg_text

    real = svg_text._Fonts.run

    def run(self, s, props):
        if s == "B":
            raise RuntimeError("FreeType could not load the glyph")
        return real(self, s, props)

    monkeypatch.setattr(svg_text._Fonts, "run", run)
    p = _write(tmp_path, "t.svg", '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 40">'
               '<text x="5" y="30" font-family="DejaVu Sans">A<tspan>B</tspan></text></svg>')
    with pytest.warns(UserWarning, match="text the font machinery could not draw"):
        e = load_element(p)
    assert art_area(e.paths).area > 20  # the A is drawn
