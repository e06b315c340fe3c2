"""The SVG reader draws what browsers draw: lengths, transform-origin, text runs, paint.

Each case is a tiny SVG written here, asserting the geometry a browser gives it.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import shapely

from repulsionpak.io import load_element
from repulsionpak.types import Element


def _svg(body: str, root: str = 'viewBox="0 0 200 100"') -> str:
    return (f'<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" '
            f'{root}>{body}</svg>')


def _load(tmp_path: Path, body: str, root: str = 'viewBox="0 0 200 100"', name: str = "e.svg") -> Element:
    p = tmp_path / name
    p.write_text(_svg(body, root))
    return load_element(p)


def _bounds(el: Element, i: int | None = None) -> np.ndarray:
    arts = el.paths if i is None else [el.paths[i]]
    pts = np.concatenate([p for a in arts for p in a.subpaths])
    return np.concatenate([pts.min(0), pts.max(0)])


def _area(el: Element, i: int = 0) -> float:
    a = el.paths[i]
    return shapely.union_all([shapely.Polygon(p) for p in a.subpaths]).area


# ----------------------------------------------------------------------------- lengths


@pytest.mark.parametrize("attrs, box", [
    ('x="1em" y="1em" width="4em" height="2em"', (10, 10, 50, 30)),  # font-size 10 on the group
    ('x="2ex" y="2ex" width="4ex" height="2ex"', (10, 10, 30, 20)),  # ex: half an em
    ('x="1rem" y="1rem" width="1rem" height="1rem"', (16, 16, 32, 32)),  # the root's 16 px
    ('x="5vw" y="10vh" width="10vw" height="20vh"', (10, 10, 30, 30)),  # of the 200 x 100 viewport
    ('x="0" y="0" width="10vmax" height="10vmin"', (0, 0, 20, 10)),
    ('x="40Q" y="0" width="40Q" height="40Q"', (96 / 2.54, 0, 2 * 96 / 2.54, 96 / 2.54)),  # 40Q = 1 cm
])
def test_css_units_on_a_rect_are_browser_lengths(tmp_path, attrs, box):
    el = _load(tmp_path, f'<g font-size="10"><rect {attrs}/></g>')
    np.testing.assert_allclose(_bounds(el), box, atol=1e-6)


def test_rem_refers_to_the_root_font_size_not_the_element(tmp_path):
    el = _load(tmp_path, '<rect font-size="64" x="0" y="0" width="2rem" height="1rem"/>',
               root='viewBox="0 0 200 100" font-size="20"')
    np.testing.assert_allclose(_bounds(el), (0, 0, 40, 20), atol=1e-6)


def test_stroke_width_percent_is_a_share_of_the_normalized_diagonal(tmp_path):
    el = _load(tmp_path, '<path d="M10 50 H190" stroke="black" stroke-width="10%" fill="none"/>',
               root='viewBox="0 0 200 200"')
    assert el.paths[0].style.stroke_width == pytest.approx(20.0)  # was 28.3 (the plain diagonal)


@pytest.mark.parametrize("attrs, dashes, offset", [
    ('stroke-dasharray="5mm 10px"', (5 * 96 / 25.4, 10), 0.0),
    ('style="stroke-dasharray: 2em 1em; stroke-dashoffset: 1em"', (20, 10), 10.0),
    ('stroke-dasharray="10" stroke-dashoffset="10%"', (10, 10), 0.1 * (25000 ** 0.5)),  # of sqrt((200² + 100²) / 2)
])
def test_dash_lengths_with_units(tmp_path, attrs, dashes, offset):
    el = _load(tmp_path, f'<path d="M10 50 H190" stroke="black" font-size="10" fill="none" {attrs}/>')
    st = el.paths[0].style
    assert st.stroke_dasharray == pytest.approx(dashes)
    assert st.stroke_dashoffset == pytest.approx(offset)


def test_rect_ry_percent_without_rx_is_a_rounded_rect_not_an_ellipse(tmp_path):
    # ry = 10% of the viewport height (10), rx takes the same length: corners of radius 10
    el = _load(tmp_path, '<rect x="0" y="0" width="100" height="50" ry="10%"/>')
    np.testing.assert_allclose(_bounds(el), (0, 0, 100, 50), atol=1e-6)
    assert _area(el) == pytest.approx(100 * 50 - (4 - np.pi) * 10 ** 2, rel=2e-3)


def test_ellipse_rx_percent_without_ry_is_a_circle(tmp_path):
    el = _load(tmp_path, '<ellipse cx="100" cy="50" rx="10%"/>')  # 10% of the width 200 = 20
    np.testing.assert_allclose(_bounds(el), (80, 30, 120, 70), atol=1e-3)


# ----------------------------------------------------------------------------- transform-origin


@pytest.mark.parametrize("origin, centre", [
    ('transform-origin="center"', (100, 50)),  # the viewport's centre (transform-box: view-box)
    ('transform-origin="50% 50%"', (100, 50)),
    ('style="transform-origin: 20px 30px"', (20, 30)),
    ('transform-origin="right bottom"', (200, 100)),
    ('transform-origin="bottom right"', (200, 100)),
    ('transform-origin="left"', (0, 50)),
])
def test_transform_origin_moves_the_transform(tmp_path, origin, centre):
    # rotate(180) about the origin maps (x, y) to 2 * origin - (x, y)
    el = _load(tmp_path, f'<rect x="10" y="10" width="20" height="10" transform="rotate(180)" {origin}/>')
    cx, cy = centre
    np.testing.assert_allclose(_bounds(el), (2 * cx - 30, 2 * cy - 20, 2 * cx - 10, 2 * cy - 10), atol=1e-6)


def test_transform_origin_on_a_group(tmp_path):
    el = _load(tmp_path, '<g transform="scale(2)" transform-origin="100 50"><rect x="90" y="40" width="20" '
                         'height="20"/></g>')
    np.testing.assert_allclose(_bounds(el), (80, 30, 120, 70), atol=1e-6)


# ----------------------------------------------------------------------------- text runs


def test_space_between_tspans_moves_the_next_word(tmp_path):
    body = ('<text x="10" y="50" font-family="DejaVu Sans" font-size="20"><tspan>ab</tspan>{sep}'
            '<tspan fill="red">cd</tspan></text>')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        spaced = _load(tmp_path, body.format(sep=" "), name="spaced.svg")
    joined = _load(tmp_path, body.format(sep=""), name="joined.svg")
    assert not [w for w in caught if "could not draw" in str(w.message)]
    shift = _bounds(spaced, -1)[0] - _bounds(joined, -1)[0]
    assert shift == pytest.approx(20 * 0.318, abs=0.3)  # DejaVu Sans' space: 0.318 em


def test_spaces_collapse_across_tspans(tmp_path):
    one = _load(tmp_path, '<text x="0" y="50" font-family="DejaVu Sans" font-size="20">ab <tspan>cd</tspan>'
                          '</text>', name="one.svg")
    two = _load(tmp_path, '<text x="0" y="50" font-family="DejaVu Sans" font-size="20">ab <tspan> cd</tspan>'
                          '</text>', name="two.svg")
    np.testing.assert_allclose(_bounds(one), _bounds(two), atol=1e-6)


def test_font_weight_bolder_is_relative_to_the_parent_weight(tmp_path):
    body = '<g font-weight="{}"><text x="0" y="50" font-family="DejaVu Sans" font-size="40" font-weight="{}">H</text></g>'
    light_bolder = _load(tmp_path, body.format(300, "bolder"), name="l.svg")  # 300 -> 400: regular
    regular = _load(tmp_path, body.format(400, "normal"), name="r.svg")
    bold = _load(tmp_path, body.format(400, 650), name="b.svg")  # the bold face, as a browser picks it
    assert _area(light_bolder) == pytest.approx(_area(regular), rel=1e-6)
    assert _area(bold) > 1.2 * _area(regular)


def test_font_variation_settings_is_said_to_be_ignored(tmp_path):
    with pytest.warns(UserWarning, match="font-variation-settings"):
        _load(tmp_path, '<text x="0" y="50" font-size="20" font-variation-settings="\'wght\' 700">Hi</text>')


# ----------------------------------------------------------------------------- paint


def test_pattern_paint_is_said_to_be_packed_as_a_solid_shape(tmp_path):
    body = ('<pattern id="p" width="10" height="10" patternUnits="userSpaceOnUse"><rect width="5" height="5" '
            'fill="green"/></pattern><rect width="100" height="100" fill="url(#p)"/>')
    with pytest.warns(UserWarning, match="pattern paint"):
        _load(tmp_path, body)


# ----------------------------------------------------------------------------- baselines, decorations


def _dejavu_metrics():
    from matplotlib.font_manager import FontProperties, findfont
    from matplotlib.ft2font import FT2Font

    f = FT2Font(findfont(FontProperties(family="DejaVu Sans")))
    return f.ascender / f.units_per_EM, f.descender / f.units_per_EM


_TEXT = '<text x="10" y="60" font-family="DejaVu Sans" font-size="20" {}>Hx</text>'


@pytest.mark.parametrize("attrs, down", [
    ('dominant-baseline="hanging"', lambda a, d: 0.8 * a * 20),
    ('dominant-baseline="central"', lambda a, d: (a + d) / 2 * 20),
    ('style="dominant-baseline: text-before-edge"', lambda a, d: a * 20),
    ('dominant-baseline="hanging" alignment-baseline="text-after-edge"', lambda a, d: d * 20),
    ('dominant-baseline="mathematical"', lambda a, d: 0.5 * a * 20),
])
def test_baselines_move_the_run(tmp_path, attrs, down):
    plain = _load(tmp_path, _TEXT.format(""), name="plain.svg")
    moved = _load(tmp_path, _TEXT.format(attrs), name="moved.svg")
    a, d = _dejavu_metrics()
    np.testing.assert_allclose(_bounds(moved) - _bounds(plain), [0, down(a, d), 0, down(a, d)], atol=1e-3)  # (path data has 6 digits)


@pytest.mark.parametrize("shift, up", [("10", 10.0), ("-50%", -10.0), ("2mm", 2 * 96 / 25.4)])
def test_baseline_shift_on_a_tspan(tmp_path, shift, up):
    body = ('<text x="10" y="60" font-family="DejaVu Sans" font-size="20">H<tspan baseline-shift="{}">'
            '<tspan>H</tspan></tspan></text>')
    plain = _load(tmp_path, body.format("baseline"), name="plain.svg")
    moved = _load(tmp_path, body.format(shift), name="moved.svg")
    def by_x(el):  # [first H, second H]
        return sorted((_bounds(el, i) for i in range(len(el.paths))), key=lambda b: b[0])

    (p1, p2), (m1, m2) = by_x(plain), by_x(moved)
    assert m2[1] - p2[1] == pytest.approx(-up, abs=1e-3)
    assert m1[1] == pytest.approx(p1[1], abs=1e-9)  # the first H stays


def test_underline_and_line_through_are_bars_across_the_run(tmp_path):
    plain = _load(tmp_path, _TEXT.format(""), name="plain.svg")
    under = _load(tmp_path, _TEXT.format('text-decoration="underline line-through"'), name="u.svg")
    pb, ub = _bounds(plain), _bounds(under)
    assert ub[3] > 60 + 1.0 and pb[3] <= 60 + 1e-6  # the underline reaches below the baseline
    geom = shapely.union_all([shapely.Polygon(p) for a in under.paths for p in a.subpaths if len(p) >= 3])
    probe = shapely.LineString([(ub[0] + 0.5, 0), (ub[0] + 0.5, 100)])  # left of the H's stem
    assert geom.intersection(probe).length > 0.5  # the bars start where the run starts


# ----------------------------------------------------------------------------- single bugs


def test_s_after_t_starts_at_the_current_point(tmp_path):
    # the S's first control is the current point (80, 30), not the T's reflected control
    el = _load(tmp_path, '<path d="M 30 100 T 80 30 S 120 100 170 100" fill="none" stroke="black"/>',
               root='viewBox="0 0 200 200"')
    np.testing.assert_allclose(_bounds(el), (30, 30, 170, 100), atol=1e-6)


def test_rgb_with_fractional_channels_paints_the_shape(tmp_path):
    el = _load(tmp_path, '<rect width="50" height="50" fill="rgb(0.8, 127.5, 14.2)"/>')
    assert el.paths[0].style.fill == "#01800e"


def test_display_none_on_the_root_is_said_plainly(tmp_path):
    from repulsionpak.errors import InputError

    with pytest.raises(InputError, match='display="none"'):
        _load(tmp_path, '<rect width="50" height="50"/>', root='viewBox="0 0 200 100" display="none"')


def test_use_cycle_skips_only_the_use(tmp_path):
    body = '<g id="g1"><use href="#g1" x="20"/><rect x="20" y="20" width="60" height="60"/></g>'
    with pytest.warns(UserWarning, match="drawing itself"):
        el = _load(tmp_path, body)
    np.testing.assert_allclose(_bounds(el), (20, 20, 80, 80), atol=1e-9)


# ----------------------------------------------------------------------------- markers


def test_marker_content_is_clipped_to_its_box(tmp_path):
    # a 40 x 40 square in a 10 x 10 marker box: browsers show only the box's quarter square
    el = _load(tmp_path, '<marker id="m" markerWidth="10" markerHeight="10" markerUnits="userSpaceOnUse">'
                         '<rect x="-20" y="-20" width="40" height="40" fill="red"/></marker>'
                         '<path d="M20 50 H180" stroke="black" stroke-width="2" fill="none" '
                         'marker-end="url(#m)"/>')
    red = [i for i, a in enumerate(el.paths) if a.style.fill == "#ff0000"]
    assert len(red) == 1
    np.testing.assert_allclose(_bounds(el, red[0]), (180, 50, 190, 60), atol=1e-6)


def test_marker_clipped_to_its_viewbox_and_visible_overflow_is_not(tmp_path):
    body = ('<marker id="m" markerWidth="4" markerHeight="4" viewBox="0 0 10 10" refX="5" refY="5" {o}>'
            '<circle cx="5" cy="5" r="8" fill="blue"/></marker>'
            '<path d="M20 50 H100" stroke="black" stroke-width="5" fill="none" marker-start="url(#m)"/>')
    el = _load(tmp_path, body.format(o=""), name="hidden.svg")
    blue = [i for i, a in enumerate(el.paths) if a.style.fill == "#0000ff"][0]
    # the 10 x 10 viewBox fills 4 x 4 stroke widths (20 px), centred on the start
    np.testing.assert_allclose(_bounds(el, blue), (10, 40, 30, 60), atol=1e-6)
    el = _load(tmp_path, body.format(o='overflow="visible"'), name="visible.svg")
    blue = [i for i, a in enumerate(el.paths) if a.style.fill == "#0000ff"][0]
    np.testing.assert_allclose(_bounds(el, blue), (4, 34, 36, 66), atol=0.05)  # r 8 * 2 = 16


_DOT = ('<marker id="m" markerWidth="4" markerHeight="4" refX="2" refY="2" markerUnits="userSpaceOnUse" '
        'overflow="visible" {a}><rect width="4" height="4" fill="red"/></marker>')


def _red_centres(el: Element) -> list[tuple[float, float]]:
    out = []
    for a in el.paths:
        if a.style.fill == "#ff0000":
            for p in a.subpaths:
                out.append(tuple(np.round((p.min(0) + p.max(0)) / 2, 6)))
    return sorted(set(out))


def test_markers_on_a_circle_and_a_rect(tmp_path):
    el = _load(tmp_path, _DOT.format(a="") + '<circle cx="100" cy="50" r="40" fill="none" stroke="black" '
                                             'marker-mid="url(#m)"/>')
    assert _red_centres(el) == [(60, 50), (100, 10), (100, 90), (140, 50)]
    el = _load(tmp_path, _DOT.format(a="") + '<rect x="10" y="20" width="50" height="30" fill="none" '
                                             'stroke="black" marker-start="url(#m)"/>', name="r.svg")
    assert _red_centres(el) == [(10, 20)]


def test_marker_orient_in_turns_and_the_marker_attribute_ignored(tmp_path):
    body = ('<marker id="m" markerWidth="10" markerHeight="10" markerUnits="userSpaceOnUse" orient="0.25turn">'
            '<rect width="10" height="2" fill="red"/></marker>')
    el = _load(tmp_path, body + '<path d="M50 50 H150" stroke="black" fill="none" marker-start="url(#m)"/>')
    red = [i for i, a in enumerate(el.paths) if a.style.fill == "#ff0000"][0]
    np.testing.assert_allclose(_bounds(el, red), (48, 50, 50, 60), atol=1e-6)  # turned a quarter
    el = _load(tmp_path, body + '<path d="M50 50 H150" stroke="black" fill="none" marker="url(#m)"/>',
               name="attr.svg")
    assert not [a for a in el.paths if a.style.fill == "#ff0000"]  # a CSS shorthand only


def test_marker_percent_sizes_and_use_of_outside_content(tmp_path):
    el = _load(tmp_path, '<defs><rect id="sq" width="100" height="100" fill="red"/></defs>'
                         '<marker id="m" markerWidth="10%" markerHeight="20%" markerUnits="userSpaceOnUse">'
                         '<use href="#sq"/></marker>'
                         '<path d="M50 50 H150" stroke="black" fill="none" marker-start="url(#m)"/>')
    red = [i for i, a in enumerate(el.paths) if a.style.fill == "#ff0000"]
    assert len(red) == 1  # the use finds #sq; the box is 10 % of 200 by 20 % of 100
    np.testing.assert_allclose(_bounds(el, red[0]), (50, 50, 70, 70), atol=1e-6)


# ----------------------------------------------------------------------------- viewports


def test_use_size_replaces_the_nested_svg_size_and_clips(tmp_path):
    # the svg is 80 x 80 at (40, 40); the use makes it 100 x 150: the circle is cut there
    el = _load(tmp_path, '<defs><svg id="s" x="40" y="40" width="80" height="80">'
                         '<circle cx="100" cy="100" r="120" fill="green"/></svg></defs>'
                         '<use href="#s" width="100" height="150"/>', root='viewBox="0 0 200 200"')
    np.testing.assert_allclose(_bounds(el), (40, 40, 140, 190), atol=1e-6)


def test_symbol_without_viewbox_is_clipped_to_the_use_size(tmp_path):
    el = _load(tmp_path, '<symbol id="s"><rect x="20" y="20" width="160" height="160"/></symbol>'
                         '<use href="#s" x="10" width="100" height="100"/>', root='viewBox="0 0 200 200"')
    np.testing.assert_allclose(_bounds(el), (30, 20, 110, 100), atol=1e-6)


def test_percentages_inside_a_nested_svg_refer_to_it(tmp_path):
    el = _load(tmp_path, '<svg x="50" y="50" width="100" height="100">'
                         '<rect x="10%" y="20%" width="50%" height="50%"/></svg>', root='viewBox="0 0 200 200"')
    np.testing.assert_allclose(_bounds(el), (60, 70, 110, 120), atol=1e-6)


# ----------------------------------------------------------------------------- context paint


def test_context_fill_in_use_takes_the_use_paint(tmp_path):
    el = _load(tmp_path, '<defs><rect id="r" width="50" height="50" fill="context-fill" stroke="context-stroke"/>'
                         '</defs><use href="#r" fill="#00ff00" stroke="#0000ff"/>'
                         '<rect x="100" width="10" height="10" fill="context-fill" stroke="#ff0000"/>')
    assert (el.paths[0].style.fill, el.paths[0].style.stroke) == ("#00ff00", "#0000ff")
    # no context element: context-fill paints nothing (the rect is only stroked)
    assert el.paths[1].style.fill is None and el.paths[1].style.stroke == "#ff0000"


def test_context_fill_with_a_pattern_is_said_to_be_approximated(tmp_path):
    with pytest.warns(UserWarning, match="pattern paint"):
        _load(tmp_path, '<pattern id="p" width="10" height="10" patternUnits="userSpaceOnUse">'
                        '<rect width="5" height="5" fill="red"/></pattern>'
                        '<defs><rect id="r" width="50" height="50" fill="context-fill"/></defs>'
                        '<use href="#r" fill="url(#p)"/>')


# ----------------------------------------------------------------------------- refused before, drawn by browsers


def test_negative_ellipse_radius_falls_back_to_auto(tmp_path):
    el = _load(tmp_path, '<ellipse cx="100" cy="50" rx="-30" ry="40"/>')
    np.testing.assert_allclose(_bounds(el), (60, 10, 140, 90), atol=0.1)  # rx auto = ry


def test_funciri_with_spaces_finds_the_gradient(tmp_path):
    el = _load(tmp_path, '<linearGradient id="g"><stop offset="0" stop-color="#00ff00"/></linearGradient>'
                         '<rect width="50" height="50" fill="  url(  #g   )  "/>')
    assert el.paths[0].style.fill == "#00ff00"


def test_switch_skips_an_unknown_child(tmp_path):
    el = _load(tmp_path, '<switch><random/><rect width="50" height="50" fill="#00ff00"/>'
                         '<rect width="60" height="60" fill="#ff0000"/></switch>')
    assert [a.style.fill for a in el.paths] == ["#00ff00"]


def test_tref_draws_the_referenced_characters_and_display_none_does_not_advance(tmp_path):
    fam = 'font-family="DejaVu Sans" font-size="20"'
    ref = _load(tmp_path, f'<text {fam} x="10" y="50">AB</text>', name="ref.svg")
    el = _load(tmp_path, f'<defs><text id="t">AB</text></defs><text {fam} x="10" y="50">'
                         '<tref href="#t"/><tspan display="none">WWW</tspan></text>', name="tref.svg")
    np.testing.assert_allclose(_bounds(el), _bounds(ref), atol=1e-6)
    el = _load(tmp_path, f'<text {fam} x="10" y="50">A<tspan display="none">WWW</tspan>B</text>',
               name="none.svg")
    np.testing.assert_allclose(_bounds(el), _bounds(ref), atol=0.01)  # (two runs: no kerning pair)


def test_root_background_colour_is_named_not_packed(tmp_path):
    with pytest.warns(UserWarning, match="background-color of the root"):
        el = _load(tmp_path, '<rect x="20" y="20" width="50" height="50"/>',
                   root='viewBox="0 0 200 100" style="background-color: #0000ff80"')
    np.testing.assert_allclose(_bounds(el), (20, 20, 70, 70))


def test_text_position_in_percent_of_the_viewport(tmp_path):
    fam = 'font-family="DejaVu Sans" font-size="20"'
    ref = _load(tmp_path, f'<text {fam} x="50" y="50">A</text>', name="ref.svg")
    el = _load(tmp_path, f'<text {fam} x="20%" y="40%" dx="5%" dy="10%">A</text>', name="pc.svg")
    np.testing.assert_allclose(_bounds(el), _bounds(ref), atol=1e-6)  # 40 + 10, 40 + 10 of 200 x 100


# ----------------------------------------------------------------------------- clip paths, odd attributes


_STAR = "M 100 15 l 50 160 l -130 -100 l 160 0 l -130 100 z"


def test_clip_rule_is_inherited_where_the_clip_path_stands(tmp_path):
    body = (f'<g clip-rule="evenodd"><clipPath id="c"><path d="{_STAR}"/></clipPath></g>'
            '<rect width="200" height="200" clip-path="url(#c)"/>')
    el = _load(tmp_path, body, root='viewBox="0 0 200 200"')
    region = shapely.union_all([shapely.Polygon(p) for p in el.paths[0].subpaths])
    if len(el.paths[0].subpaths) > 1:  # outer ring and the pentagon hole
        region = shapely.symmetric_difference_all([shapely.Polygon(p) for p in el.paths[0].subpaths])
    assert region.contains(shapely.Point(100, 30))  # a tip of the star
    assert not region.contains(shapely.Point(100, 105))  # the centre: a hole with evenodd


def test_a_group_inside_a_clip_path_is_ignored_but_text_is_not(tmp_path):
    el = _load(tmp_path, '<clipPath id="c"><rect width="50" height="50"/><g><rect x="100" width="50" '
                         'height="50"/></g></clipPath><rect width="200" height="100" clip-path="url(#c)"/>')
    np.testing.assert_allclose(_bounds(el), (0, 0, 50, 50), atol=1e-6)
    el = _load(tmp_path, '<clipPath id="c"><text x="10" y="50" font-family="DejaVu Sans" font-size="40">'
                         'I</text></clipPath><rect width="200" height="100" clip-path="url(#c)"/>', name="t.svg")
    b = _bounds(el)
    assert 10 < b[0] < b[2] < 30 and b[1] > 10 and b[3] <= 50 + 1e-6  # the glyph clips


def test_text_in_another_namespace_is_not_drawn(tmp_path):
    fam = 'font-family="DejaVu Sans" font-size="20"'
    ref = _load(tmp_path, f'<text {fam} x="10" y="50">A</text>', name="ref.svg")
    el = _load(tmp_path, f'<text {fam} x="10" y="50">A<a xmlns="http://example.org/x">WWW</a></text>',
               name="ns.svg")
    np.testing.assert_allclose(_bounds(el), _bounds(ref), atol=1e-6)


def test_inherit_on_a_geometry_attribute_is_invalid(tmp_path):
    el = _load(tmp_path, '<g x="20"><rect x="inherit" width="50" height="50"/></g>')
    np.testing.assert_allclose(_bounds(el), (0, 0, 50, 50), atol=1e-6)


def test_a_skewed_stroke_and_a_root_filter_are_said_to_be_approximated(tmp_path):
    with pytest.warns(UserWarning, match="skewing or uneven scaling"):
        _load(tmp_path, '<line x1="60" y1="90" x2="140" y2="10" stroke="black" stroke-width="20" '
                        'transform="skewX(-45)"/>')
    with pytest.warns(UserWarning, match="filter"):
        _load(tmp_path, '<filter id="f"><feGaussianBlur stdDeviation="4"/></filter>'
                        '<rect width="50" height="50"/>', root='viewBox="0 0 200 100" filter="url(#f)"',
              name="f.svg")


# ----------------------------------------------------------------------------- images


def _png_uri(tmp_path) -> str:
    import base64
    import io

    from PIL import Image

    img = Image.new("RGBA", (10, 10), (0, 0, 0, 0))
    for x in range(2, 8):  # a red 6 x 4 block in a transparent 10 x 10 picture
        for y in range(3, 7):
            img.putpixel((x, y), (255, 0, 0, 255))
    buf = io.BytesIO()
    img.save(buf, "PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def test_raster_image_is_the_rectangle_of_its_visible_pixels(tmp_path):
    with pytest.warns(UserWarning, match="raster <image>"):
        el = _load(tmp_path, f'<image x="10" y="10" width="100" height="50" href="{_png_uri(tmp_path)}"/>')
    # the 10 x 10 picture meets the 100 x 50 viewport at scale 5, centred: x from 35
    np.testing.assert_allclose(_bounds(el), (35 + 10, 10 + 15, 35 + 40, 10 + 35), atol=1e-6)
    assert el.paths[0].style.fill == "#ff0000"


def test_svg_image_is_drawn_as_its_shapes(tmp_path):
    (tmp_path / "pic.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 10 10">'
                                      '<circle id="c" cx="5" cy="5" r="5" fill="#00ff00"/></svg>')
    el = _load(tmp_path, '<image x="20" y="0" width="40" height="40" href="pic.svg"/>'
                         '<circle id="c" cx="150" cy="50" r="10"/>')
    np.testing.assert_allclose(_bounds(el, 0), (20, 0, 60, 40), atol=1e-6)
    assert el.paths[0].style.fill == "#00ff00"


def test_image_that_cannot_be_read_is_not_drawn(tmp_path):
    with pytest.warns(UserWarning, match="could not be read"):
        el = _load(tmp_path, '<image width="40" height="40" href="https://example.org/a.png"/>'
                             '<rect x="100" width="10" height="10"/>')
    np.testing.assert_allclose(_bounds(el), (100, 0, 110, 10), atol=1e-6)


def test_trailing_space_after_a_tspan_does_not_move_a_centred_text(tmp_path):
    fam = 'font-family="DejaVu Sans" font-size="20" text-anchor="middle"'
    ref = _load(tmp_path, f'<text {fam} x="100" y="50">ab</text>', name="ref.svg")
    el = _load(tmp_path, f'<text {fam} x="100" y="50">\n  <tspan>ab</tspan>\n  </text>', name="sp.svg")
    np.testing.assert_allclose(_bounds(el), _bounds(ref), atol=1e-6)


def test_a_chunk_takes_the_text_anchor_of_its_first_glyphs(tmp_path):
    fam = 'font-family="DejaVu Sans" font-size="20"'
    ref = _load(tmp_path, f'<text {fam} x="100" y="50" text-anchor="end">ab</text>', name="ref.svg")
    el = _load(tmp_path, f'<text {fam} x="100" y="50">\n  <tspan text-anchor="end">ab</tspan></text>',
               name="tspan.svg")
    np.testing.assert_allclose(_bounds(el), _bounds(ref), atol=1e-6)  # ends at x = 100


def test_tspan_transform_has_no_effect_and_inherit_takes_the_parent_alignment(tmp_path):
    fam = 'font-family="DejaVu Sans" font-size="20"'
    ref = _load(tmp_path, f'<text {fam} x="10" y="50">ab</text>', name="ref.svg")
    el = _load(tmp_path, f'<text {fam} x="10" y="50"><tspan transform="skewX(30)">ab</tspan></text>',
               name="tf.svg")
    np.testing.assert_allclose(_bounds(el), _bounds(ref), atol=1e-6)
    hang = _load(tmp_path, f'<text {fam} x="10" y="50" alignment-baseline="hanging">ab</text>', name="h.svg")
    el = _load(tmp_path, f'<g alignment-baseline="hanging"><text {fam} x="10" y="50" '
                         'alignment-baseline="inherit">ab</text></g>', name="inh.svg")
    np.testing.assert_allclose(_bounds(el), _bounds(hang), atol=1e-6)
    assert _bounds(hang)[1] > _bounds(ref)[1] + 5  # (hanging moves the text down)


def test_writing_mode_on_a_group_is_said_to_be_ignored(tmp_path):
    with pytest.warns(UserWarning, match="vertical writing"):
        _load(tmp_path, '<g writing-mode="tb"><text x="10" y="50" font-family="DejaVu Sans">ab</text></g>')


def test_decorations_take_the_declaring_element_paint_and_skip_the_trailing_space(tmp_path):
    fam = 'font-family="DejaVu Sans" font-size="20"'
    el = _load(tmp_path, f'<text {fam} x="10" y="50" fill="#ffff00" text-decoration="line-through">'
                         '<tspan fill="#0000ff">ab</tspan> </text>')
    glyphs = [a for a in el.paths if a.style.fill == "#0000ff"]
    bars = [a for a in el.paths if a.style.fill == "#ffff00"]
    assert glyphs and len(bars) == 1  # one bar, in the text's yellow, across "ab" only
    np.testing.assert_allclose(_bounds(el, el.paths.index(bars[0]))[[0, 2]],
                               _bounds(_load(tmp_path, f'<text {fam} x="10" y="50">ab</text>', name="r.svg"))[[0, 2]],
                               atol=2.5)
