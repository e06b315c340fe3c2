"""Tests of repulsionpak.io readers: SVG and .path elements and containers."""

from __future__ import annotations

import math
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from repulsionpak.errors import InputError, ParameterError
from repulsionpak.art_area import art_area
from repulsionpak.io import (
    load_container,
    load_element,
    load_elements,
    parse_pathfile,
    rings_to_region,
)
from repulsionpak.io import files as io_files
from repulsionpak.io import svg_element

FIX = Path(__file__).parent / "fixtures"
DATA = Path("/work/shared/data")
ANIMALS = ["bear", "bird", "bunny", "cat", "dog", "fox", "mouse", "penguin", "snake"]

needs_data = pytest.mark.skipif(
    not (DATA / "animals").is_dir(), reason="shared data set not available"
)


def _svg(body: str, root: str = 'viewBox="0 0 100 100"') -> str:
    return f'<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" {root}>{body}</svg>'


def _write(tmp_path: Path, name: str, content: str | bytes) -> Path:
    p = tmp_path / name
    p.write_bytes(content.encode() if isinstance(content, str) else content)
    return p


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args, **kwargs)


def _region(art) -> shapely.Geometry:
    return rings_to_region(list(art.subpaths), art.style.fill_rule)


def _seg_dist(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance of each point (N,2) to the open polyline poly (K,2)."""
    a, b = poly[:-1], poly[1:]
    ab = b - a
    ap = points[:, None, :] - a[None]
    t = np.clip(
        (ap * ab[None]).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-300)[None], 0, 1
    )
    closest = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(points[:, None, :] - closest, axis=-1).min(axis=1)


# --------------------------------------------------------------------------- coordinates and units


def test_rect_transforms_and_units_give_user_units():
    el = load_element(FIX / "rect_scaled.svg")
    assert el.name == "rect_scaled" and el.source == "rect_scaled.svg"
    assert len(el.paths) == 1
    art = el.paths[0]
    assert art.closed == (True,)
    # rect (1,2,10,20) scaled by 2 then translated by (5,7); width="10cm" is NOT applied
    np.testing.assert_allclose(
        art.subpaths[0], [[7, 11], [27, 11], [27, 51], [7, 51]], atol=1e-12
    )
    assert art.style.fill == "#ff0000" and art.style.stroke == "#0000ff"
    assert art.style.stroke_width == pytest.approx(6.0)  # 3 x scale(2)


def test_container_area_with_scale_transform():
    c = load_container(FIX / "rect_scaled.svg")
    assert c.area == pytest.approx(800.0)  # 10 x 20 with scale(2)
    assert c.svg_root == {"width": "10cm", "height": "5cm", "viewBox": "0 0 200 100"}
    assert c.source == "rect_scaled.svg"
    assert c.region.is_valid


def test_viewbox_offset_and_non_uniform_viewport_not_applied():
    el = load_element(FIX / "viewbox_offset.svg")
    np.testing.assert_allclose(
        el.paths[0].subpaths[0], [[55, 22], [59, 22], [59, 24], [55, 24]], atol=1e-9
    )
    assert el.paths[0].style.stroke_width == pytest.approx(0.5)


def test_root_transform_and_nested_svg(tmp_path):
    body = '<svg x="10" y="20" width="20" height="20" viewBox="0 0 10 10"><rect width="10" height="10"/></svg>'
    p = _write(
        tmp_path,
        "nested.svg",
        _svg(body, 'width="5in" height="5in" viewBox="0 0 100 100"'),
    )
    el = load_element(p)
    # nested viewport scales its content by 2 and moves it to (10, 20): part of user space
    np.testing.assert_allclose(
        el.paths[0].subpaths[0], [[10, 20], [30, 20], [30, 40], [10, 40]], atol=1e-9
    )


@pytest.mark.parametrize("use, bounds", [
    ('x="5" y="5" width="40" height="80"', (5, 5, 45, 85)),  # the viewBox scaled ×4
    ('x="5" y="5" width="40" height="40"', (15, 5, 35, 45)),  # meet: ×2, centred
    ('x="5" y="5" width="40" height="40" transform="translate(50 0)"', (65, 5, 85, 45)),
    ('', (25, 0, 75, 100)),  # width/height 100 % of the viewport: ×5, centred
])
def test_use_of_a_symbol_fits_its_viewbox_into_the_use_viewport(tmp_path, use, bounds):
    """Illustrator and Inkscape write symbols this way; browsers scale the symbol's viewBox
    into the <use>'s x, y, width, height (svgelements alone only translated it)."""
    body = (f'<defs><symbol id="s" viewBox="0 0 10 20"><rect width="10" height="20"/></symbol></defs>'
            f'<use href="#s" {use}/>')
    el = load_element(_write(tmp_path, "sym.svg", _svg(body)))
    pts = np.vstack([s for p in el.paths for s in p.subpaths])
    np.testing.assert_allclose([*pts.min(axis=0), *pts.max(axis=0)], bounds, atol=1e-9)


def _bounds(el) -> list[float]:
    pts = np.vstack([s for p in el.paths for s in p.subpaths])
    return [*pts.min(axis=0), *pts.max(axis=0)]


@pytest.mark.parametrize("overflow, bounds", [
    ("", (10, 10, 30, 30)),  # the default: the viewport clips (x 30 is the viewport's edge)
    ('overflow="hidden"', (10, 10, 30, 30)),
    ('style="overflow: visible"', (10, 10, 40, 30)),
])
def test_nested_svg_and_symbol_viewports_clip_their_content(tmp_path, overflow, bounds):
    """Browsers clip a nested <svg> or a <symbol> to its viewport (overflow hidden by
    default): what sticks out is neither packed nor written."""
    nested = (f'<svg x="10" y="10" width="20" height="20" viewBox="0 0 10 10" {overflow}>'
              '<rect width="15" height="10"/></svg>')
    el = load_element(_write(tmp_path, "nested.svg", _svg(nested)))
    np.testing.assert_allclose(_bounds(el), bounds, atol=1e-9)
    symbol = (f'<symbol id="s" viewBox="0 0 10 10" {overflow}><rect width="15" height="10"/></symbol>'
              '<use href="#s" x="5" y="5" width="20" height="20" transform="translate(5 5)"/>')
    el = load_element(_write(tmp_path, "symbol.svg", _svg(symbol)))
    np.testing.assert_allclose(_bounds(el), bounds, atol=1e-9)


@pytest.mark.parametrize("root, size", [
    ('width="200" height="100" viewBox="0 0 100 100" preserveAspectRatio="none"', (2 ** 0.5, 2 ** -0.5)),
    ('viewBox="0 0 100 100" transform="scale(3 1)"', (3 ** 0.5, 3 ** -0.5)),
    ('viewBox="0 0 100 100" transform="rotate(90)"', (1, 1)),
    ('width="300" height="300" viewBox="0 0 100 100"', (1, 1)),  # uniform: user units, as before
])
def test_an_element_is_read_as_drawn_by_its_root(tmp_path, root, size):
    """A root transform or a non-uniform viewBox mapping stretches or turns the art in a
    browser: the element keeps that shape (a stretched circle packed as a circle, a turned
    one upright with --rotation fixed), at its user-unit size (its area is kept)."""
    body = '<rect x="10" y="20" width="40" height="20"/>'
    el = load_element(_write(tmp_path, "e.svg", _svg(body, root)))
    x0, y0, x1, y1 = _bounds(el)
    if "rotate" in root:
        assert (x1 - x0, y1 - y0) == (pytest.approx(20), pytest.approx(40))
    else:
        assert (x1 - x0, y1 - y0) == (pytest.approx(40 * size[0]), pytest.approx(20 * size[1]))


def test_shapes_inside_elements_browsers_do_not_draw_are_left_out(tmp_path):
    """Inkscape's flowed text (<flowRoot>: its <flowRegion> rect is a frame, not art),
    <metadata>, gradients, unknown elements and other namespaces draw nothing in browsers;
    their ids stay referable by <use>."""
    body = ('<circle cx="50" cy="50" r="20"/>'
            '<flowRoot><flowRegion><rect id="frame" width="90" height="90"/></flowRegion>'
            '<flowPara>hello</flowPara></flowRoot>'
            '<metadata><rect width="5" height="5"/></metadata>'
            '<linearGradient id="lg"><rect width="5" height="5"/></linearGradient>'
            '<foo><rect width="5" height="5"/></foo>'
            '<ink:layer xmlns:ink="http://example.com/ink"><rect width="5" height="5"/></ink:layer>'
            '<g><foo><rect width="5" height="5"/></foo></g>'
            '<use href="#frame" x="200"/>')
    with pytest.warns(UserWarning, match=r"flowRoot.*not drawn") as rec:
        el = load_element(_write(tmp_path, "inkscape.svg", _svg(body)))
    assert any("<foo>" in str(w.message) and "<metadata>" in str(w.message) for w in rec)
    regions = sorted(tuple(round(v, 6) for v in _region(p).bounds) for p in el.paths)
    assert regions == [(30, 30, 70, 70), (200, 0, 290, 90)]  # the circle and the <use> of the frame


def test_a_line_is_never_filled(tmp_path):
    """<line> has no inside: without a stroke it draws nothing (it was written as a filled
    open path, which the deformation turned into a visible sliver)."""
    body = ('<rect width="10" height="10"/><line x1="20" y1="0" x2="60" y2="40"/>'
            '<line x1="20" y1="50" x2="60" y2="90" stroke="red" stroke-width="4"/>')
    el = _quiet(load_element, _write(tmp_path, "lines.svg", _svg(body)))
    styles = [(p.style.fill, p.style.stroke) for p in el.paths]
    assert styles == [("#000000", None), (None, "#ff0000")]


@pytest.mark.parametrize("attrs", ['rx="20"', 'ry="20"', 'rx="20" ry="auto"', 'rx="auto" ry="20"',
                                   'rx="20" style="fill:red"'])
def test_an_ellipse_with_one_radius_is_a_circle(tmp_path, attrs):
    """SVG 2: an ellipse's missing (or ``auto``) radius takes the other's value, as browsers
    draw it; svgelements made it 1 and ``<ellipse rx="20"/>`` packed as a 40 × 2 sliver."""
    body = f'<ellipse cx="50" cy="50" {attrs}/>'
    el = _quiet(load_element, _write(tmp_path, "e.svg", _svg(body)))
    (path,) = el.paths
    b = _region(path).bounds
    assert b == pytest.approx((30, 30, 70, 70), abs=1e-6)
    assert _region(path).area == pytest.approx(math.pi * 400, rel=5e-3)  # flattened


@pytest.mark.parametrize("root, body, centre, radius", [
    ('viewBox="0 0 200 100"', '<circle cx="50%" cy="50%" r="40%"/>', (100, 50), 0.4 * math.sqrt(25000)),
    ('width="200" height="100"', '<circle cx="100" cy="50" r="10%"/>', (100, 50), 0.1 * math.sqrt(25000)),
    # a nested viewport: its own viewBox is what the percentage refers to
    ('viewBox="0 0 200 100"', '<svg width="200" height="100" viewBox="0 0 20 20"><circle cx="10" cy="10" '
     'r="25%"/></svg>', (100, 50), 0.25 * 20 * 5),
])
def test_a_circle_radius_in_percent_is_a_share_of_the_normalized_diagonal(tmp_path, root, body, centre, radius):
    """SVG 2: ``r="40%"`` is 40 % of sqrt((w² + h²)/2) of the viewport, a circle; it was
    read as 40 % of the width along x and of the height along y (an ellipse)."""
    cont = _quiet(load_container, _write(tmp_path, "c.svg", _svg(body, root)))
    b = cont.region.bounds
    assert ((b[0] + b[2]) / 2, (b[1] + b[3]) / 2) == pytest.approx(centre, abs=1e-6)
    assert (b[2] - b[0], b[3] - b[1]) == pytest.approx((2 * radius, 2 * radius), rel=1e-6)


@pytest.mark.parametrize("radii", ['rx="10"', 'ry="10"', 'rx="auto" ry="10"', 'rx="10" ry="auto"'])
def test_a_rect_corner_radius_left_out_or_auto_takes_the_other(tmp_path, radii):
    """Browsers round the corners of ``<rect rx="auto" ry="10">`` by 10 both ways; the
    "auto" was read as 0 (square corners)."""
    body = f'<rect x="10" y="10" width="50" height="50" {radii}/>'
    el = _quiet(load_element, _write(tmp_path, "r.svg", _svg(body)))
    (path,) = el.paths
    assert _region(path).area == pytest.approx(2500 - (4 - math.pi) * 100, rel=2e-3)


def test_shapes_without_a_size_are_not_drawn(tmp_path):
    """A circle without ``r``, an ellipse without radii, a rect without ``height``: not
    drawn in a browser (size 0), drawn 1 unit across by svgelements; alone in an element,
    the file is refused as having nothing visible."""
    none = '<circle cx="50" cy="50"/><ellipse cx="20" cy="20"/><rect x="5" y="5" width="30"/>'
    el = _quiet(load_element, _write(tmp_path, "some.svg", _svg(none + '<rect x="60" y="60" width="9" height="9"/>')))
    assert [tuple(round(v, 6) for v in _region(p).bounds) for p in el.paths] == [(60, 60, 69, 69)]
    with pytest.raises(InputError, match="no visible geometry"):
        _quiet(load_element, _write(tmp_path, "none.svg", _svg(none)))


def test_css_custom_properties(tmp_path):
    """var(--x, fallback) as browsers resolve it: inherited, overridden, nested, in style
    sheets and style attributes; an undefined one is ignored with a note (was black)."""
    body = ('<style>circle { fill: var(--c, #27a); --c: #a27 }</style>'
            '<g style="--main: #00ff00"><rect width="9" height="9" style="fill: var(--main)"/>'
            '<rect x="10" width="9" height="9" style="fill: var(--nope, var(--acc))"/></g>'
            '<rect x="20" width="9" height="9" style="fill: var(--main); stroke: var(--undefined)"/>'
            '<circle cx="50" cy="50" r="5"/>')
    with pytest.warns(UserWarning, match=r"stroke: var\(--undefined\) with an undefined variable"):
        el = load_element(_write(tmp_path, "vars.svg", _svg(body, 'viewBox="0 0 100 100" '
                                                           'style="--main: #123456; --acc: var(--main)"')))
    assert [(p.style.fill, p.style.stroke) for p in el.paths] == [
        ("#00ff00", None), ("#123456", None), ("#123456", None), ("#aa2277", None)]


def test_use_of_a_symbol_without_viewbox_is_only_moved(tmp_path):
    body = '<symbol id="s"><rect width="10" height="20"/></symbol><use xlink:href="#s" x="7" y="3" width="99" height="99"/>'
    el = load_element(_write(tmp_path, "sym.svg", _svg(body)))
    pts = np.vstack([s for p in el.paths for s in p.subpaths])
    np.testing.assert_allclose([*pts.min(axis=0), *pts.max(axis=0)], (7, 3, 17, 23), atol=1e-9)


def test_use_of_another_file_is_not_drawn_and_says_so(tmp_path):
    body = '<use xlink:href="other.svg#r"/><circle cx="5" cy="5" r="4"/>'
    with pytest.warns(UserWarning, match=r"ext.svg: skipped unsupported content: <use> of another file"):
        el = load_element(_write(tmp_path, "ext.svg", _svg(body)))
    assert len(el.paths) == 1


def test_markers_are_drawn_once_where_they_are_used(tmp_path):
    """The marker's content is drawn at the line's end (test_io_markers.py has the rest),
    not on its own where it is defined."""
    body = ('<defs><marker id="a" viewBox="0 0 10 10" refX="5" refY="5"><path d="M0 0 L10 5 L0 10 z"/></marker></defs>'
            '<path d="M10 50 L90 50" stroke="#000" stroke-width="4" marker-end="url(#a)"/>')
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        el = load_element(_write(tmp_path, "m.svg", _svg(body)))
    assert len(el.paths) == 2
    head = art_area(el.paths[1:])
    assert head.bounds == pytest.approx((84, 44, 96, 56), abs=1e-6)  # 3 × 4 units square at (90, 50)


def test_no_viewbox_means_px_user_units(tmp_path):
    p = _write(
        tmp_path,
        "px.svg",
        _svg('<rect x="1" y="1" width="3" height="4"/>', 'width="200" height="100"'),
    )
    c = load_container(p)
    assert c.area == pytest.approx(12.0)
    assert c.svg_root == {"width": "200", "height": "100"}


def test_doctype_public_is_allowed():
    el = load_element(FIX / "doctype.svg")
    np.testing.assert_allclose(
        el.paths[0].subpaths[0], [[0, 0], [4, 0], [4, 3], [0, 3]]
    )


# --------------------------------------------------------------------------- fill rules, holes


def test_fill_rules_make_holes():
    el = load_element(FIX / "holes.svg")
    assert [a.style.fill_rule for a in el.paths] == ["nonzero", "evenodd", "nonzero"]
    areas = [_region(a).area for a in el.paths]
    assert areas[0] == pytest.approx(
        1600.0
    )  # same orientation + nonzero: inner square filled
    assert areas[1] == pytest.approx(1200.0)  # evenodd: hole
    assert areas[2] == pytest.approx(
        1200.0
    )  # opposite orientation: hole under nonzero too
    c = load_container(FIX / "holes.svg")
    assert c.area == pytest.approx(1600 + 1200 + 1200)


def test_rings_to_region_self_intersecting():
    bowtie = np.array([[0, 0], [2, 2], [2, 0], [0, 2]], float)
    assert rings_to_region([bowtie], "nonzero").area == pytest.approx(2.0)
    # a pentagram: the centre has winding 2 -> filled by nonzero, empty by evenodd
    ang = np.pi / 2 + np.arange(5) * 4 * np.pi / 5
    star = np.c_[np.cos(ang), np.sin(ang)]
    nz, eo = rings_to_region([star], "nonzero"), rings_to_region([star], "evenodd")
    assert nz.area > eo.area > 0
    assert nz.contains(shapely.Point(0, 0)) and not eo.contains(shapely.Point(0, 0))


def test_container_holes_multipolygon_and_open_path_warning():
    with pytest.warns(UserWarning, match="container_holes.svg.*open subpath"):
        c = load_container(FIX / "container_holes.svg")
    # 100x50 - evenodd hole 10x10 - class="hole" rect 20x20, plus a disjoint 30x30 square
    assert c.area == pytest.approx(5000 - 100 - 400 + 900)
    assert c.region.geom_type == "MultiPolygon" and len(c.region.geoms) == 2
    assert c.region.is_valid
    assert not c.region.contains(shapely.Point(50, 20))  # inside the hole shape
    assert not c.region.contains(shapely.Point(15, 15))  # inside the evenodd hole
    assert c.region.contains(shapely.Point(135, 15))
    assert len(c.paths) == 3 and all(all(a.closed) for a in c.paths)
    assert c.svg_root["viewBox"] == "-10 -10 200 100"


def test_hole_by_id_and_nearly_closed_path(tmp_path):
    body = (
        '<path d="M0 0 L100 0 L100 100 L0 100 L0 0.00001"/>'  # open but ends meet within tolerance
        '<rect id="hole-1" x="10" y="10" width="10" height="10"/>'
    )
    c = load_container(_write(tmp_path, "c.svg", _svg(body)))
    assert c.area == pytest.approx(10000 - 100, rel=1e-6)


def test_container_errors(tmp_path):
    line = _write(tmp_path, "line.svg", _svg('<path d="M0 0 L10 10" stroke="black"/>'))
    with (
        pytest.raises(InputError, match="line.svg.*no closed path"),
        warnings.catch_warnings(),
    ):
        warnings.simplefilter("ignore")
        load_container(line)
    flat = _write(tmp_path, "flat.svg", _svg('<path d="M0 0 L10 0 L20 0 Z"/>'))
    with pytest.raises(InputError, match="flat.svg"):
        _quiet(load_container, flat)


# --------------------------------------------------------------------------- styles


def test_styles_inherited_and_invisible_dropped():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the text is drawn (tests/test_io_text.py), not skipped
        el = load_element(FIX / "styles.svg")
    assert (
        len(el.paths) == 5
    )  # fill+stroke none, display:none, hidden, opacity 0 dropped; the text's glyphs last
    s0, s1, s2, s3, s4 = (a.style for a in el.paths)
    assert s4.fill == "#000000" and art_area(el.paths[4:]).bounds[0] >= 50  # "hello" at x = 50
    assert (s0.fill, s0.stroke, s0.stroke_width, s0.opacity, s0.stroke_linejoin) == (
        "#00ff00",
        "#112233",
        2.0,
        0.5,
        "round",
    )
    assert (
        s1.fill is None
        and s1.stroke_opacity == pytest.approx(0.25)
        and s1.stroke_linecap == "square"
    )
    assert s2.fill == "#0000ff"  # CSS class
    assert s2.opacity == pytest.approx(0.25)  # group 0.5 x own 0.5
    assert s2.fill_opacity == pytest.approx(0.3)
    assert s3.stroke_width == pytest.approx(6.0)  # inherited 2 x scale(3)
    np.testing.assert_allclose(
        np.linalg.norm(el.paths[3].subpaths[0] - [60, 60], axis=1), 6.0, atol=1e-9
    )


@pytest.mark.parametrize("attrs, dashes, offset, limit", [
    ('stroke-dasharray="6 3" stroke-dashoffset="2" stroke-miterlimit="9"', (12, 6), 4, 9),
    ('stroke-dasharray="1,2,3"', (2, 4, 6, 2, 4, 6), 0, 4),  # an odd list repeats
    ('style="stroke-dasharray:5px 1px;stroke-miterlimit:0.5"', (10, 2), 0, 4),  # limit < 1: invalid
    ('stroke-dasharray="none" stroke-dashoffset="3"', (), 0, 4),
    ('stroke-dasharray="10%"', (20, 20), 0, 4),  # a share of the viewport's diagonal (100)
    ('stroke-dasharray="5" stroke-dashoffset="15px"', (10, 10), 30, 4),  # a unit on the offset
    ('stroke-dasharray="3 -1"', (), 0, 4),  # invalid: solid, as SVG draws it
    ('stroke-dasharray="0 0"', (), 0, 4),
])
def test_stroke_dashes_and_miter_limit_are_kept_and_scaled(tmp_path, attrs, dashes, offset, limit):
    body = f'<g transform="scale(2)"><path d="M0 0 L10 0 L5 8" fill="none" stroke="red" {attrs}/></g>'
    st = load_element(_write(tmp_path, "d.svg", _svg(body))).paths[0].style
    assert st.stroke_dasharray == pytest.approx(dashes) and st.stroke_dashoffset == pytest.approx(offset)
    assert st.stroke_miterlimit == limit and st.stroke_width == pytest.approx(2.0)


@pytest.mark.parametrize("sheet, shape, fill", [
    (".x.y { fill: #0000ff }", '<path class="y x" d="M0 0h9v9z"/>', "#0000ff"),  # compound
    ("g .c { fill: #ff00ff }", '<g><g><path class="c" d="M0 0h9v9z"/></g></g>', "#ff00ff"),  # descendant
    ("svg > .c { fill: #ff00ff }", '<g><path class="c" d="M0 0h9v9z"/></g>', "#000000"),  # not a child
    ("[data-k='1'] { fill: #00ffff }", '<path data-k="1" d="M0 0h9v9z"/>', "#00ffff"),  # attribute
    (".d { fill: #abcdef !important }", '<rect class="d" width="9" height="9" fill="red"/>', "#abcdef"),
    (".d { fill: #abcdef }", '<rect class="d" width="9" height="9" style="fill:#111111"/>', "#111111"),
    (".d { fill: #abcdef !important }", '<rect class="d" width="9" height="9" style="fill:#111111"/>', "#abcdef"),
    ("", '<rect width="9" height="9" style="fill:#333333 !important"/>', "#333333"),
    ("#i { fill: #222222 } .d { fill: #abcdef }", '<rect id="i" class="d" width="9" height="9"/>', "#222222"),
    (".d { fill: #222222 } .d { fill: #abcdef }", '<rect class="d" width="9" height="9"/>', "#abcdef"),
    ("@media print { .d { fill: #ff0000 } } .d:hover { fill: #ff0000 }",
     '<rect class="d" width="9" height="9" fill="#00ff00"/>', "#00ff00"),
])
def test_css_cascade_as_browsers_apply_it(tmp_path, sheet, shape, fill):
    el = load_element(_write(tmp_path, "css.svg", _svg(f"<style>{sheet}</style>{shape}")))
    assert [a.style.fill for a in el.paths] == [fill]


@pytest.mark.parametrize("colour, fill, alpha", [
    ("transparent", None, 1.0),  # paints nothing (svgelements made it black)
    ("rgb(255 0 0 / 50%)", "#ff0000", 0.5),  # CSS Color 4: spaces and a slash
    ("rgb(100% 0% 0% / .25)", "#ff0000", 0.25),
    ("hsl(120deg 100% 50%)", "#00ff00", 1.0),
    ("hsla(0, 100%, 50%, 0.25)", "#ff0000", 0.25),
    ("#11223344", "#112233", 0x44 / 255),
])
def test_fill_colours_css_writes(tmp_path, colour, fill, alpha):
    body = f'<rect width="5" height="5" fill="{colour}" stroke="#0000ff"/>'
    st = load_element(_write(tmp_path, "c.svg", _svg(body))).paths[0].style
    assert st.fill == fill and st.fill_opacity == pytest.approx(alpha, abs=2 / 255)


@pytest.mark.parametrize("given, kept", [
    ("stroke", "stroke fill markers"), ("stroke fill", "stroke fill markers"),
    ("markers", "markers fill stroke"), ("fill stroke", "normal"), ("normal", "normal"), ("bogus", "normal"),
])
def test_paint_order_is_kept(tmp_path, given, kept):
    body = f'<rect width="5" height="5" fill="#f00" stroke="#000" style="paint-order: {given}"/>'
    assert load_element(_write(tmp_path, "p.svg", _svg(body))).paths[0].style.paint_order == kept


def test_default_fill_black_and_colours_as_hex(tmp_path):
    body = '<rect width="1" height="1"/><rect width="1" height="1" fill="rgb(255,0,0)" stroke="currentColor" color="teal"/>'
    el = load_element(_write(tmp_path, "c.svg", _svg(body)))
    assert el.paths[0].style.fill == "#000000" and el.paths[0].style.stroke is None
    assert el.paths[1].style.fill == "#ff0000" and el.paths[1].style.stroke == "#008080"


# --------------------------------------------------------------------------- shapes and flattening


def test_all_shape_kinds():
    el = load_element(FIX / "shapes.svg", tolerance=0.01)
    assert len(el.paths) == 8
    rr, circle, ellipse, poly, pline, line, path, use = el.paths
    # rounded rect: area of a 40x20 rect minus (4 - pi) r^2
    assert _region(rr).area == pytest.approx(800 - (4 - math.pi) * 25, abs=0.01 * 120)
    # circle: vertices on the circle, chords within tolerance
    c = circle.subpaths[0]
    np.testing.assert_allclose(np.linalg.norm(c - [100, 100], axis=1), 30, atol=1e-9)
    mids = (c + np.roll(c, -1, axis=0)) / 2
    assert (30 - np.linalg.norm(mids - [100, 100], axis=1)).max() <= 0.01
    # rotated ellipse: points satisfy the ellipse equation in the rotated frame
    q = ellipse.subpaths[0] - [200, 100]
    th = math.radians(-30)
    r = q @ np.array([[math.cos(th), math.sin(th)], [-math.sin(th), math.cos(th)]])
    np.testing.assert_allclose(
        (r[:, 0] / 40) ** 2 + (r[:, 1] / 10) ** 2, 1.0, atol=1e-9
    )
    np.testing.assert_allclose(poly.subpaths[0], [[0, 200], [50, 200], [25, 240]])
    assert (
        poly.closed == (True,) and pline.closed == (False,) and line.closed == (False,)
    )
    np.testing.assert_allclose(line.subpaths[0], [[200, 200], [250, 260]])
    assert len(path.subpaths) == 2 and path.closed == (
        True,
        True,
    )  # relative commands, 2 subpaths
    np.testing.assert_allclose(path.subpaths[1], [[360, 300], [370, 300], [370, 310]])
    assert path.subpaths[0].max(axis=0)[1] == pytest.approx(
        352.5, abs=0.01
    )  # arc radii scaled up
    np.testing.assert_allclose(use.subpaths[0], [[50, 300], [60, 300], [55, 308]])


@pytest.mark.parametrize("tol", [1.0, 0.1, 0.01, 0.001])
def test_cubic_flattening_error_within_tolerance(tol):
    el = load_element(FIX / "bezier.svg", tolerance=tol)
    poly = el.paths[0].subpaths[0]
    P = np.array([[10, 80], [40, 10], [65, 10], [95, 80]], float)
    t = np.linspace(0, 1, 6001)[:, None]
    curve = (
        (1 - t) ** 3 * P[0]
        + 3 * (1 - t) ** 2 * t * P[1]
        + 3 * (1 - t) * t**2 * P[2]
        + t**3 * P[3]
    )
    assert _seg_dist(curve, poly).max() <= tol * (1 + 1e-9)
    np.testing.assert_allclose(poly[[0, -1]], P[[0, 3]])
    if tol >= 0.01:
        assert len(poly) < 200  # adaptive, not absurdly dense


def test_quadratic_and_arc_flattening_under_transform(tmp_path):
    body = '<g transform="matrix(2 0.5 -0.3 1.5 10 20)"><path d="M0 0 Q 50 80 100 0 A 30 20 15 1 1 40 -30" fill="none" stroke="black"/></g>'
    tol = 0.05
    el = load_element(
        _write(tmp_path, "q.svg", _svg(body, 'viewBox="0 0 400 400"')), tolerance=tol
    )
    poly = el.paths[0].subpaths[0]
    A = np.array([[2, -0.3], [0.5, 1.5]])
    t = np.linspace(0, 1, 5001)[:, None]
    Q = np.array([[0, 0], [50, 80], [100, 0]], float)
    quad = ((1 - t) ** 2 * Q[0] + 2 * (1 - t) * t * Q[1] + t**2 * Q[2]) @ A.T + [10, 20]
    assert _seg_dist(quad, poly).max() <= tol * (1 + 1e-9)
    # arc end point transformed exactly; every arc vertex lies on the transformed ellipse
    np.testing.assert_allclose(
        poly[-1], np.array([40, -30]) @ A.T + [10, 20], atol=1e-9
    )


def test_default_tolerance_is_relative_to_size(tmp_path):
    small = load_element(
        _write(tmp_path, "s.svg", _svg('<circle cx="0" cy="0" r="1"/>'))
    )
    big = load_element(
        _write(tmp_path, "b.svg", _svg('<circle cx="0" cy="0" r="1000"/>'))
    )
    assert len(small.paths[0].subpaths[0]) == len(
        big.paths[0].subpaths[0]
    )  # scale invariant
    c = big.paths[0].subpaths[0]
    mids = (c + np.roll(c, -1, axis=0)) / 2
    diag = 2000 * math.sqrt(2)
    assert (1000 - np.linalg.norm(mids, axis=1)).max() <= 1e-3 * diag


def test_duplicate_points_and_degenerate_subpaths_removed(tmp_path):
    body = (
        '<path d="M0 0 L0 0 L10 0 L10 0 L10 10 L0 0 Z M50 50 L50 50 Z M20 20 L 30 30"/>'
    )
    el = load_element(_write(tmp_path, "d.svg", _svg(body)))
    art = el.paths[0]
    assert len(art.subpaths) == 2
    np.testing.assert_allclose(art.subpaths[0], [[0, 0], [10, 0], [10, 10]])
    assert art.closed == (True, False)


def test_tolerance_parameter_validated():
    for bad in (0, -1, float("nan"), float("inf"), "x"):
        with pytest.raises(ParameterError):
            load_element(FIX / "bezier.svg", tolerance=bad)


# --------------------------------------------------------------------------- .path format


def test_pathfile_element_styles_and_reverse_order():
    el = load_element(FIX / "mini.path")
    assert el.name == "mini" and el.source == "mini.path"
    assert len(el.paths) == 2  # the type-1 detail path is ignored
    open_path, square = el.paths  # reverse file order
    assert square.closed == (True,) and open_path.closed == (False,)
    np.testing.assert_allclose(square.subpaths[0], [[0, 0], [10, 0], [10, 10], [0, 10]])
    assert (square.style.fill, square.style.stroke) == ("#f06465", None)
    assert (
        open_path.style.fill,
        open_path.style.stroke,
        open_path.style.stroke_width,
    ) == (None, "#ff0000", 0.5)


def test_pathfile_container_regions_and_holes():
    c = load_container(FIX / "holes.path")
    assert c.area == pytest.approx(100 * 100 - 50 * 50 + 50 * 50)
    assert c.region.geom_type == "MultiPolygon"
    assert not c.region.contains(shapely.Point(50, 50))
    assert (
        c.paths[0].style.stroke == "#000000" and c.paths[0].style.fill == "#ffffff"
    )  # defaults
    assert all(
        len(a.subpaths[0]) == 4 for a in c.paths
    )  # repeated closing point dropped


def test_pathfile_palette_lines(tmp_path):
    p = _write(
        tmp_path,
        "pal.path",
        "1\nforeground_color 0 3 -1\nbackground_color 0 8 0\n0 1 0 0 0 1 0 1 1\n0 1 0 5 5 6 5 6 6\n",
    )
    el = load_element(p)
    assert [(a.style.stroke, a.style.fill) for a in el.paths] == [
        (None, "#beddf4"),
        ("#ff0000", "#ffffff"),
    ]


@pytest.mark.parametrize(
    "content, line",
    [
        ("1\n0 1 0 0 0 1 1 2\n", "line 2"),
        ("1\n\n0 1 0 0 0 1 1 2 2\n0 1 q 0 0 1 1\n", "line 4"),
        ("1\n0 2 0 0 0 1 1\n", "line 2"),
        ("1\n0 1 9 0 0 1 1\n", "line 2"),
        ("1\nbackground_color_rgb 0 300,0,0\n", "line 2"),
        ("1\n0 1\n", "line 2"),
        ("1 2\n", "line 1"),
        ("0\n", "line 1"),
        ("1\n0 1 0 0 0 nan 1\n", "line 2"),
    ],
)
def test_pathfile_malformed_lines(tmp_path, content, line):
    p = _write(tmp_path, "bad.path", content)
    with pytest.raises(InputError, match=rf"bad\.path: {line}"):
        load_element(p)


def test_pathfile_parse_keeps_raw_records():
    pf = parse_pathfile("mini.path", (FIX / "mini.path").read_bytes())
    assert pf.num_regions == 1 and len(pf.records) == 3
    assert [r.path_type for r in pf.records] == [0, 0, 1]
    assert pf.records[0].line == 4


# --------------------------------------------------------------------------- shared data


@needs_data
@pytest.mark.parametrize("animal", ANIMALS)
def test_svg_and_path_elements_are_equivalent(animal):
    a = load_element(DATA / "animals" / f"{animal}.svg")
    b = load_element(DATA / "repulsionpak_format" / "animals" / f"{animal}.path")
    assert len(a.paths) == len(b.paths)
    for pa, pb in zip(a.paths, b.paths):  # both in reverse file order
        assert pa.closed == pb.closed
        assert pa.style.fill == pb.style.fill
        assert len(pa.subpaths[0]) == len(pb.subpaths[0])
        np.testing.assert_allclose(pa.subpaths[0], pb.subpaths[0], atol=1e-3)


@needs_data
def test_svg_and_path_containers_are_equivalent():
    a = load_container(DATA / "containers" / "heart.svg")
    b = load_container(DATA / "repulsionpak_format" / "containers" / "heart.path")
    assert a.area == pytest.approx(b.area, rel=1e-6)
    assert a.area == pytest.approx(122440, rel=1e-3)
    assert a.region.symmetric_difference(b.region).area < 1e-3 * a.area
    assert a.svg_root == {"width": "500", "height": "500", "viewBox": "0 0 500 500"}
    np.testing.assert_allclose(a.bounds, (6.06, 66.19, 493.99, 474.0), atol=0.01)


@needs_data
def test_load_elements_on_directories():
    els = load_elements(
        [DATA / "animals", DATA / "animals" / "cat.svg", DATA / "secondary"]
    )
    assert [e.name for e in els] == ANIMALS + [
        "small_cat"
    ]  # sorted, duplicate cat dropped
    paths = load_elements([DATA / "repulsionpak_format" / "animals"])
    assert [e.source for e in paths] == [f"{a}.path" for a in ANIMALS]


# --------------------------------------------------------------------------- directories, sniffing


def test_load_elements_directory_rules(tmp_path):
    d = tmp_path / "lib"
    d.mkdir()
    shutil.copy(FIX / "rect_scaled.svg", d / "b.svg")
    shutil.copy(FIX / "mini.path", d / "a.path")
    (d / "notes.txt").write_text("x")
    (d / "sub").mkdir()
    shutil.copy(FIX / "bezier.svg", d / "sub" / "c.svg")  # not recursive
    els = load_elements([d, d / "b.svg", str(d)])
    assert [e.source for e in els] == ["a.path", "b.svg"]
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "readme.txt").write_text("x")
    with pytest.raises(InputError, match="empty"):
        load_elements([empty])


def test_unknown_suffix_is_sniffed(tmp_path):
    a = _write(tmp_path, "art.dat", (FIX / "rect_scaled.svg").read_bytes())
    b = _write(tmp_path, "art2.txt", (FIX / "mini.path").read_bytes())
    assert len(load_element(a).paths) == 1
    assert len(load_element(b).paths) == 2
    with pytest.raises(InputError, match="art3.bin"):
        load_element(_write(tmp_path, "art3.bin", b"\x89PNG\r\n\x1a\n\x00\x00"))


def test_svgz_is_read(tmp_path):
    import gzip

    p = _write(
        tmp_path, "z.svgz", gzip.compress((FIX / "rect_scaled.svg").read_bytes())
    )
    assert load_container(p).area == pytest.approx(800)


# --------------------------------------------------------------------------- bad input


def _bad_inputs(tmp_path: Path) -> dict[str, Path]:
    S = _svg
    cases = {
        "empty.svg": b"",
        "blank.svg": b"  \n\t",
        "notxml.svg": b"this is not xml",
        "truncated.svg": S('<rect width="3" height="3"/>').encode()[:60],
        "binary.svg": bytes(range(256)) * 4,
        "html.svg": b"<html><body/></html>",
        "bomb.svg": (
            b'<?xml version="1.0"?><!DOCTYPE svg [<!ENTITY a "aaaaaaaaaa">'
            b'<!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;"><!ENTITY c "&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;">]>'
            b'<svg xmlns="http://www.w3.org/2000/svg">&c;</svg>'
        ),
        "external.svg": (
            b'<?xml version="1.0"?><!DOCTYPE svg [<!ENTITY x SYSTEM "file:///etc/passwd">]>'
            b'<svg xmlns="http://www.w3.org/2000/svg"><text>&x;</text></svg>'
        ),
        "nogeometry.svg": S('<image href="x.png" width="5" height="5"/><text x="1" y="1"> </text>').encode(),
        "infinite.svg": S('<path d="M0 0 L1e400 0 L1 1 Z"/>').encode(),
        "overflow.svg": S(
            '<path d="M0 0 L1 0 L1 1 Z" transform="scale(1e200) scale(1e200)"/>'
        ).encode(),
        "usecycle.svg": S('<g id="a"><use href="#a"/></g>').encode(),
        "usebomb.svg": S(
            '<defs><rect id="r0" width="1" height="1"/>'
            + "".join(
                f'<g id="r{i}">' + f'<use href="#r{i - 1}"/>' * 10 + "</g>"
                for i in range(1, 8)
            )
            + '</defs><use href="#r7"/>'
        ).encode(),
        "deep.svg": S(
            "<g>" * 400 + '<rect width="1" height="1"/>' + "</g>" * 400
        ).encode(),
        "zerosize.svg": S(
            '<rect width="3" height="3"/>', 'width="0" height="10" viewBox="0 0 10 10"'
        ).encode(),
        "wrongns.svg": b'<svg xmlns="http://example.com/ns"><rect width="3" height="3"/></svg>',
        "empty.path": b"\n",
        "binary.path": b"1\n\x00\x01\x02",
    }
    out = {name: _write(tmp_path, name, data) for name, data in cases.items()}
    out["missing.svg"] = tmp_path / "missing.svg"
    (tmp_path / "folder.svg").mkdir()
    out["folder.svg"] = tmp_path / "folder.svg"
    return out


@pytest.mark.parametrize("loader", [load_element, load_container])
def test_bad_inputs_raise_input_error_naming_the_file(tmp_path, loader):
    for name, path in _bad_inputs(tmp_path).items():
        with pytest.raises(InputError) as info, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            loader(path)
        assert name in str(info.value), (name, str(info.value))
        assert info.value.path is not None and info.value.path.endswith(name)


def test_entity_declarations_message(tmp_path):
    cases = _bad_inputs(tmp_path)
    for name in ("bomb.svg", "external.svg"):
        with pytest.raises(
            InputError, match="declares XML entities, which are not allowed"
        ):
            load_element(cases[name])


ILLUSTRATOR = b"""<?xml version="1.0" encoding="utf-8"?>
<!-- Generator: Adobe Illustrator 27.0.0, SVG Export Plug-In . SVG Version: 6.00 Build 0)  -->
<!DOCTYPE svg PUBLIC "-//W3C//DTD SVG 1.1//EN" "http://www.w3.org/Graphics/SVG/1.1/DTD/svg11.dtd" [
\t<!ENTITY ns_extend "http://ns.adobe.com/Extensibility/1.0/">
\t<!ENTITY ns_ai "http://ns.adobe.com/AdobeIllustrator/10.0/">
\t<!ENTITY ns_vars "http://ns.adobe.com/Variables/1.0/">
]>
<svg version="1.1" xmlns:x="&ns_extend;" xmlns:i="&ns_ai;" xmlns="http://www.w3.org/2000/svg"
\t x="0px" y="0px" viewBox="0 0 100 100" style="enable-background:new 0 0 100 100;" xml:space="preserve">
<style type="text/css">.st0{fill:#E94E1B;} .st1{fill:#FFFFFF;stroke:#1D1D1B;stroke-width:2;}</style>
<switch>
\t<foreignObject requiredExtensions="&ns_ai;" x="0" y="0" width="1" height="1"><i:pgfRef xlink:href="#x"/></foreignObject>
\t<g i:extraneous="self">
\t\t<polygon class="st0" points="50,5 61,38 95,38 68,59 79,92 50,72 21,92 32,59 5,38 39,38 "/>
\t\t<circle class="st1" cx="50" cy="52" r="10"/>
\t</g>
\t<g><rect width="100" height="100"/></g>
</switch>
</svg>
"""


def test_illustrator_export_with_entities_and_switch(tmp_path):
    """Illustrator declares its namespaces as plain XML entities and wraps the art in a
    <switch> after its private data: read like a browser draws it, without warnings."""
    p = _write(tmp_path, "ai.svg", ILLUSTRATOR.replace(b"<svg version", b'<svg xmlns:xlink="http://www.w3.org/1999/xlink" version'))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        el = load_element(p)
    assert [(a.style.fill, a.style.stroke) for a in el.paths] == [("#e94e1b", None), ("#ffffff", "#1d1d1b")]
    pts = np.vstack([s for a in el.paths for s in a.subpaths])
    np.testing.assert_allclose([*pts.min(axis=0), *pts.max(axis=0)], (5, 5, 95, 92), atol=1e-9)  # not the rect


@pytest.mark.parametrize("doctype", [
    b'<!DOCTYPE svg [<!ENTITY a "x"><!ENTITY b "&a;&a;">]>',  # nested
    b'<!DOCTYPE svg [<!ENTITY % p "x">]>',  # parameter entity
    b'<!DOCTYPE svg [<!ENTITY a "x"><!ELEMENT svg ANY>]>',  # more than plain entities
    b'<!DOCTYPE svg [<!ENTITY a "' + b"y" * 4000 + b'">]>',  # expands past 4x the file
])
def test_other_entities_stay_refused(tmp_path, doctype):
    body = b"".join([b'<svg xmlns="http://www.w3.org/2000/svg"><rect width="1" height="1"/>',
                     b'<desc>' + b"&a;" * 40 + b"</desc>" if b'"y' in doctype else b"", b"</svg>"])
    p = _write(tmp_path, "e.svg", b'<?xml version="1.0"?>' + doctype + body)
    with pytest.raises(InputError, match="e.svg.*entities"):
        load_element(p)


FIGMA = """<svg width="120" height="120" viewBox="0 0 120 120" fill="none" xmlns="http://www.w3.org/2000/svg">
<g clip-path="url(#clip0_1_2)">
<path d="M60 10C87.6 10 110 32.4 110 60C110 87.6 87.6 110 60 110C32.4 110 10 87.6 10 60C10 32.4 32.4 10 60 10Z" fill="#F24E1E"/>
<path fill-rule="evenodd" clip-rule="evenodd" d="M40 40H80V80H40V40ZM50 50V70H70V50H50Z" fill="white"/>
</g>
<defs><clipPath id="clip0_1_2"><rect width="120" height="120" fill="white"/></clipPath></defs>
</svg>"""
COREL = """<?xml version="1.0" encoding="UTF-8" standalone="no"?>
<svg xmlns="http://www.w3.org/2000/svg" xml:space="preserve" width="30mm" height="30mm" version="1.1"
 style="shape-rendering:geometricPrecision; fill-rule:evenodd; clip-rule:evenodd" viewBox="0 0 3000 3000">
 <defs><style type="text/css"><![CDATA[
    .fil0 {fill:#2B2A29}
    .fil1 {fill:#E31E24}
 ]]></style></defs>
 <g id="Layer_x0020_1">
  <polygon class="fil0" points="1500,100 2900,1500 1500,2900 100,1500 "/>
  <circle class="fil1" cx="1500" cy="1500" r="600"/>
 </g>
</svg>"""
SKETCH = """<?xml version="1.0" encoding="UTF-8"?>
<svg width="48px" height="48px" viewBox="0 0 48 48" version="1.1" xmlns="http://www.w3.org/2000/svg">
    <title>icon</title>
    <g id="Page-1" stroke="none" stroke-width="1" fill="none" fill-rule="evenodd">
        <g id="Artboard" transform="translate(-20.000000, -20.000000)" fill="#4A90E2">
            <path d="M44,20 L68,44 L44,68 L20,44 Z M44,32 L32,44 L44,56 L56,44 Z"></path>
        </g>
    </g>
</svg>"""


INKSCAPE = """<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink"
 xmlns:sodipodi="http://sodipodi.sourceforge.net/DTD/sodipodi-0.dtd" xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
 width="100mm" height="50mm" viewBox="0 0 100 50">
  <sodipodi:namedview id="nv" pagecolor="#ffffff"/>
  <g inkscape:label="sketch" inkscape:groupmode="layer" id="layer0" style="display:none">
    <rect width="100" height="50" style="fill:#ff0000"/>
  </g>
  <g inkscape:label="Layer 1" inkscape:groupmode="layer" id="layer1" transform="translate(-10,-20)">
    <path style="fill:#ff6600;fill-opacity:1;stroke:#000000;stroke-width:0.5;stroke-dasharray:none"
          d="m 20,30 h 20 v 20 h -20 z" id="rect1" sodipodi:nodetypes="ccccc"/>
    <use x="0" y="0" xlink:href="#rect1" id="use1" transform="translate(40,0)" width="100%" height="100%"/>
  </g>
</svg>"""


@pytest.mark.parametrize("text, fills, bounds, area", [
    (FIGMA, ["#f24e1e", "#ffffff"], (10, 10, 110, 110), math.pi * 50 ** 2),  # the clip frame: no effect
    (COREL, ["#2b2a29", "#e31e24"], (100, 100, 2900, 2900), 2 * 1400 ** 2),  # CSS in CDATA
    (SKETCH, ["#4a90e2"], (0, 0, 48, 48), 2 * 24 ** 2 - 2 * 12 ** 2),  # inherited evenodd: a hole
    (INKSCAPE, ["#ff6600", "#ff6600"], (9.75, 9.75, 70.25, 30.25), 2 * 20.5 ** 2),  # a clone; hidden layer
])
def test_design_tool_exports_read_as_drawn(tmp_path, text, fills, bounds, area):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        el = load_element(_write(tmp_path, "x.svg", text))
    assert [a.style.fill for a in el.paths] == fills
    from repulsionpak.art_area import art_area

    geom = art_area(el.paths)
    np.testing.assert_allclose(geom.bounds, bounds, atol=1e-6)
    assert geom.area == pytest.approx(area, rel=5e-3)  # Figma's circle: four cubics


def test_point_budget(tmp_path, monkeypatch):
    pts = " ".join(f"L{i} {(i % 2) * 6}" for i in range(1, 3000))  # every point a corner: none thinned
    p = _write(
        tmp_path,
        "many.svg",
        _svg(
            f'<path d="M0 0 {pts}" fill="none" stroke="black"/>',
            'viewBox="0 0 3000 10"',
        ),
    )
    assert load_element(p).paths[0].n_points == 3000
    monkeypatch.setattr(io_files, "MAX_POINTS", 1000)
    with pytest.raises(InputError, match="many.svg.*more than 1000 points"):
        load_element(p)
    big = _write(
        tmp_path, "bigcurve.svg", _svg('<path d="M0 0 C 1e9 0 1e9 1e9 0 1e9"/>')
    )
    with pytest.raises(InputError, match="bigcurve.svg.*points"):
        load_element(big, tolerance=1e-6)


def test_unsupported_content_warns_and_is_skipped(tmp_path):
    body = (
        '<image href="x.png" width="5" height="5"/>'
        '<rect width="5" height="5" filter="url(#f)"/>'
        '<symbol id="s"><rect width="50" height="50"/></symbol>'
        '<mask id="m"><rect width="70" height="70" fill="white"/></mask>'
    )
    with pytest.warns(UserWarning, match="warn.svg.*<image> that could not be read.*filter"):
        el = load_element(_write(tmp_path, "warn.svg", _svg(body)))
    assert len(el.paths) == 1  # symbol and mask content are not drawn
    np.testing.assert_allclose(el.paths[0].subpaths[0].max(axis=0), [5, 5])


def test_use_of_symbol_is_drawn(tmp_path):
    body = '<defs><symbol id="s"><rect width="5" height="5"/></symbol></defs><use href="#s" x="10" y="10"/>'
    el = load_element(_write(tmp_path, "sym.svg", _svg(body)))
    np.testing.assert_allclose(
        el.paths[0].subpaths[0], [[10, 10], [15, 10], [15, 15], [10, 15]]
    )


# --------------------------------------------------------------------------- fuzzing


_SVG_PIECES = [
    "<svg",
    "</svg>",
    ' xmlns="http://www.w3.org/2000/svg"',
    ' viewBox="0 0 10 10"',
    ' width="1e400"',
    ">",
    '<path d="',
    "M 0 0",
    "L 5 5",
    "C 1 2 3 4 5 6",
    "A 5 5 0 1 1 9 9",
    "Z",
    "nan",
    "1e308",
    "-",
    ".",
    '"/>',
    '<rect width="3" height="3"',
    ' transform="scale(0)"',
    ' transform="rotate(45)"',
    ' fill-rule="evenodd"',
    '<g id="a">',
    "</g>",
    '<use href="#a"/>',
    "<!ENTITY x 'y'>",
    "<!DOCTYPE svg>",
    "&x;",
    '<circle r="-1"/>',
    '<polygon points="0,0 1"/>',
    ' class="hole"',
    ' style="fill:url(#q);stroke-width:1e309"',
    "<text>t</text>",
    '<ellipse rx="2" ry="0"/>',
    "\x00",
    "\xff",
    " ",
]


_NUM = st.one_of(
    st.integers(-5, 120).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(
        ["1e308", "-1e308", "1e-320", "0", "nan", "inf", "", "5%", "2mm", "x"]
    ),
)
_TF = st.one_of(
    st.just(""),
    st.builds(
        lambda f, a, b: f' transform="{f}({a} {b})"',
        st.sampled_from(["translate", "scale", "rotate", "skewX", "matrix", "bogus"]),
        _NUM,
        _NUM,
    ),
)
_STYLE = st.sampled_from(
    [
        "",
        ' fill="none" stroke="red"',
        ' fill-rule="evenodd"',
        ' class="hole"',
        ' opacity="0"',
        ' style="display:none"',
        ' stroke-width="1e309" stroke="blue"',
        ' fill="url(#nope) red"',
        ' visibility="hidden"',
    ]
)
_D = st.lists(
    st.tuples(st.sampled_from("MLHVCSQTAZmlhvcsqtaz"), st.lists(_NUM, max_size=7)),
    max_size=8,
).map(lambda d: " ".join(c + " " + " ".join(v) for c, v in d))
_SHAPE = st.one_of(
    st.builds(lambda d, t, s: f'<path d="{d}"{t}{s}/>', _D, _TF, _STYLE),
    st.builds(
        lambda a, b, c, d, t, s: (
            f'<rect x="{a}" y="{b}" width="{c}" height="{d}" rx="{a}"{t}{s}/>'
        ),
        _NUM,
        _NUM,
        _NUM,
        _NUM,
        _TF,
        _STYLE,
    ),
    st.builds(
        lambda a, b, c, t, s: f'<circle cx="{a}" cy="{b}" r="{c}"{t}{s}/>',
        _NUM,
        _NUM,
        _NUM,
        _TF,
        _STYLE,
    ),
    st.builds(
        lambda p, t, s: f'<polygon points="{p}"{t}{s}/>',
        st.lists(_NUM, max_size=8).map(" ".join),
        _TF,
        _STYLE,
    ),
    st.builds(lambda i, t: f'<use href="#g{i}"{t}/>', st.integers(0, 2), _TF),
    st.just("<text>x</text>"),
)
_BODY = st.recursive(
    st.lists(_SHAPE, max_size=4).map("".join),
    lambda inner: st.builds(
        lambda ch, t, s, i: f'<g id="g{i}"{t}{s}>' + "".join(ch) + "</g>",
        st.lists(inner, max_size=3),
        _TF,
        _STYLE,
        st.integers(0, 2),
    ),
    max_leaves=8,
)
_STRUCTURED = st.builds(
    lambda w, h, vb, b: (
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="{vb}">{b}</svg>'.encode()
    ),
    _NUM,
    _NUM,
    st.lists(_NUM, max_size=5).map(" ".join),
    _BODY,
)
_SEEDS = [
    (FIX / n).read_bytes() for n in ("shapes.svg", "mini.path", "container_holes.svg")
]
_MUTATED = st.builds(
    lambda k, i, b: (
        _SEEDS[k][: i % len(_SEEDS[k])]
        + bytes([b])
        + _SEEDS[k][i % len(_SEEDS[k]) + 1 :]
    ),
    st.integers(0, len(_SEEDS) - 1),
    st.integers(0, 10_000),
    st.integers(0, 255),
)
_ALMOST = st.lists(st.sampled_from(_SVG_PIECES), max_size=30).map(
    lambda x: "".join(x).encode("utf-8", "surrogatepass")
)


@settings(
    max_examples=200,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(data=st.one_of(st.binary(max_size=300), _ALMOST, _STRUCTURED, _MUTATED))
def test_fuzz_only_input_errors_escape(tmp_path, data):
    for suffix in (".svg", ".path", ".dat"):
        p = tmp_path / f"fuzz{suffix}"
        p.write_bytes(data)
        for loader in (load_element, load_container):
            try:
                res = _quiet(loader, p)
            except InputError as exc:
                assert "fuzz" in str(exc)
                continue
            if loader is load_container:
                assert res.region.is_valid and res.area > 0
            else:
                assert res.paths and all(
                    np.all(np.isfinite(s)) for a in res.paths for s in a.subpaths
                )


@settings(
    max_examples=80,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    d=st.lists(
        st.tuples(
            st.sampled_from("MLHVCSQTAZmlhvcsqtaz"),
            st.lists(
                st.floats(allow_nan=True, allow_infinity=True, width=32), max_size=7
            ),
        ),
        max_size=12,
    ),
    rule=st.sampled_from(["nonzero", "evenodd"]),
)
def test_fuzz_path_data(tmp_path, d, rule):
    dstr = " ".join(
        cmd + " " + " ".join(repr(float(v)) for v in vals) for cmd, vals in d
    )
    p = tmp_path / "fuzzpath.svg"
    p.write_text(_svg(f'<path fill-rule="{rule}" d="{dstr}"/>'))
    for loader in (load_element, load_container):
        try:
            res = _quiet(loader, p)
        except InputError as exc:
            assert "fuzzpath.svg" in str(exc)
            continue
        if loader is load_container:
            assert res.region.is_valid and res.area > 0
        else:
            for art in res.paths:
                assert all(len(s) >= 2 and np.all(np.isfinite(s)) for s in art.subpaths)


# --------------------------------------------------------------------------- dense drawings


def _dense_polygon(n: int) -> str:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    r = 40 + 4 * np.sin(5 * t) + 2 * np.cos(11 * t)
    return " ".join(f"{50 + x:.5f},{50 + y:.5f}" for x, y in zip(r * np.cos(t), r * np.sin(t)))


def test_a_dense_drawing_is_thinned_within_a_quarter_of_the_curve_tolerance(tmp_path):
    """A traced or digitized outline (6,000 points): its runs of lines keep what
    Douglas-Peucker keeps within 2.5e-4 of the element's size, a quarter of what every copy
    is written to; curves stay as drawn. (20,000 points took ~10 minutes to pack.)"""
    body = (f'<polygon points="{_dense_polygon(6000)}" fill="#369"/>'
            '<path d="M 45 45 C 48 40 52 40 55 45 Z" fill="#fff"/>')
    el = load_element(_write(tmp_path, "dense.svg", _svg(body)))
    poly, curve = el.paths
    assert 50 < len(poly.subpaths[0]) < 600 and (poly.source.curves[0].order == 1).all()
    assert list(curve.source.curves[0].order) == [3, 1]  # the cubic and its closing line, untouched
    exact = shapely.Polygon(np.array([p.split(",") for p in _dense_polygon(6000).split()], float))
    thin = shapely.Polygon(poly.subpaths[0])
    size = np.hypot(*np.ptp(np.asarray(exact.exterior.coords), axis=0))
    assert exact.hausdorff_distance(thin) <= svg_element.DENSE_TOLERANCE * size * (1 + 1e-6)
    np.testing.assert_allclose(poly.source.curves[0].ctrl[:, 0], poly.subpaths[0])  # curves = outline


def test_a_drawing_under_the_limit_is_kept_as_drawn(tmp_path):
    n = svg_element.MAX_LINE_SEGMENTS // 2
    el = load_element(_write(tmp_path, "d.svg", _svg(f'<polygon points="{_dense_polygon(n)}"/>')))
    assert len(el.paths[0].subpaths[0]) == n


def test_a_stretched_container_says_so(tmp_path):
    """A container drawn stretched by its root (preserveAspectRatio="none", a root
    scale(2 1)) is packed in its user units, and its output, drawn the same way, shows the
    copies stretched: a warning says so (a uniform mapping, a turn or a mirror says nothing)."""
    body = '<circle cx="50" cy="50" r="40"/>'
    for root in ('width="200" height="100" viewBox="0 0 100 100" preserveAspectRatio="none"',
                 'viewBox="0 0 100 100" transform="scale(2 1)"'):
        with pytest.warns(UserWarning, match=r"stretches the drawing \(2:1\)"):
            load_container(_write(tmp_path, "c.svg", _svg(body, root)))
    for root in ('width="300" height="300" viewBox="0 0 100 100"', 'viewBox="0 0 100 100" transform="rotate(30) scale(-1 1)"'):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            load_container(_write(tmp_path, "c.svg", _svg(body, root)))


@pytest.mark.parametrize("cap, area", [("round", math.pi), ("square", 4.0), ("butt", 0.0)])
def test_zero_length_subpaths_are_dots_with_round_and_square_caps(tmp_path, cap, area):
    # browsers paint `M18 3 L18 3` and `M4 3 z` stroked with round (square) caps as a disc
    # (a square) of the stroke's width, and nothing for a lone moveto or butt caps
    body = (f'<g fill="none" stroke="#000" stroke-width="2" stroke-linecap="{cap}">'
            '<path d="M50 50 h20"/><path d="M18 3 L18 3"/><path d="M4 3 z"/><path d="M80 80"/></g>')
    el = _quiet(load_element, _write(tmp_path, "dots.svg", _svg(body)))
    dots = [p for p in el.paths if np.ptp(np.concatenate(p.subpaths)[:, 0]) < 1]
    assert len(dots) == (2 if area else 0)
    for p in dots:
        assert art_area([p]).area == pytest.approx(area, rel=0.03)
    # the line keeps its own caps: 20 x 2, plus a disc (a square) of diameter 2 at its ends
    line = [p for p in el.paths if np.ptp(np.concatenate(p.subpaths)[:, 0]) > 10]
    assert art_area(line).area == pytest.approx(40 + area, rel=0.03)


def test_container_outline_whose_ends_miss_by_a_rounding_counts_as_closed(tmp_path):
    """Icon sets draw outlines without ``z`` whose last point misses the first by a rounding
    (Tabler's heart: 0.006 in 24 units); at a fine gap's tolerance that refused the file.
    Ends within 1e-3 of the outline's size close it; farther apart it stays open."""
    from repulsionpak.errors import InputError
    from repulsionpak.io import load_container

    near = tmp_path / "near.svg"
    near.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 24 24"><path fill="none" '
                    'stroke="black" d="M12 4 L20 12 L12 20 L4 12 L11.994 4.002"/></svg>')
    c = load_container(near, tolerance=2e-4)
    assert c.region.area == pytest.approx(128.0, rel=1e-3)
    far = tmp_path / "far.svg"
    far.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 24 24"><path fill="none" '
                   'stroke="black" d="M12 4 L20 12 L12 20 L4 12 L11.5 4.5"/></svg>')
    with pytest.raises(InputError, match="closed"):
        load_container(far, tolerance=2e-4)
