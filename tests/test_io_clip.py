"""``clip-path`` on element art and containers: the clipped geometry is what is loaded,
packed and written (repulsionpak.io.svg_clip through the SVG readers).

Analytic cases check areas and bounds; the fixtures in ``fixtures/clip/`` (transforms on
the clipPath, the element and its groups, nested clipped groups, ``clip-rule``, ``<use>``
in a clipPath, a clipped clipPath, ``objectBoundingBox``) are also compared pixel by
pixel with resvg, an independent SVG renderer, when it is installed.
"""

from __future__ import annotations

import io
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import shapely

from repulsionpak.errors import InputError
from repulsionpak.art_area import art_area
from repulsionpak.io import load_container, load_element, read_packing_svg
from repulsionpak.render.svg import write_packing_svg
from repulsionpak.io.svg_clip import clip_art
from repulsionpak.types import ArtPath, PlacedArt, Style

CLIP = Path(__file__).parent / "fixtures" / "clip"


def _svg(body: str, root: str = 'viewBox="0 0 100 100"') -> str:
    return (f'<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" '
            f"{root}>{body}</svg>")


def _write(tmp_path: Path, name: str, body: str, root: str = 'viewBox="0 0 100 100"') -> Path:
    p = tmp_path / name
    p.write_text(_svg(body, root))
    return p


def _area(path: Path) -> shapely.Geometry:
    return art_area(load_element(path).paths)


# --------------------------------------------------------------------------- analytic cases


def test_square_clipped_by_a_disc_loads_as_the_disc():
    el = load_element(CLIP / "square_disc.svg")
    g = art_area(el.paths)
    # the disc r = 40 flattened to 1e-3 of the diagonal: a little less than pi r^2
    assert g.area == pytest.approx(math.pi * 40**2, rel=5e-3)
    assert g.area < math.pi * 40**2
    np.testing.assert_allclose(g.bounds, (10, 10, 90, 90), atol=0.05)
    assert shapely.Point(50, 50).buffer(39.8).within(g)
    # the square's stroke lies outside the disc: clipped away entirely
    assert [(a.style.fill, a.style.stroke) for a in el.paths] == [("#22aa77", None)]


def test_partly_clipped_stroke_becomes_a_filled_band(tmp_path):
    body = ('<clipPath id="left"><rect x="0" y="0" width="50" height="100"/></clipPath>'
            '<rect x="20" y="20" width="60" height="60" fill="#ff0000" fill-opacity="0.5" '
            'stroke="#0000ff" stroke-width="4" stroke-opacity="0.25" clip-path="url(#left)"/>')
    el = load_element(_write(tmp_path, "band.svg", body))
    fill, stroke = el.paths
    assert fill.style.fill == "#ff0000" and fill.style.stroke is None
    assert fill.style.fill_opacity == pytest.approx(0.5)
    assert stroke.style.fill == "#0000ff" and stroke.style.stroke is None
    assert stroke.style.fill_opacity == pytest.approx(0.25)
    assert all(fill.closed) and all(stroke.closed)
    assert art_area([fill]).area == pytest.approx(30 * 60)
    # the stroke ring 18..82 minus 22..78 (miter corners), left of x = 50
    assert art_area([stroke]).area == pytest.approx(32 * 64 - 28 * 56)
    assert art_area(el.paths).bounds == pytest.approx((18, 18, 50, 82))


def test_unclipped_parts_are_left_untouched(tmp_path):
    """A shape inside its clip region keeps its subpaths, stroke and open ends."""
    body = ('<clipPath id="big"><rect width="100" height="100"/></clipPath>'
            '<path d="M10,10 L40,30 L70,10" fill="none" stroke="#000" stroke-width="2" '
            'clip-path="url(#big)"/>')
    el = load_element(_write(tmp_path, "inside.svg", body))
    (art,) = el.paths
    assert art.closed == (False,) and art.style.stroke == "#000000"
    np.testing.assert_allclose(art.subpaths[0], [[10, 10], [40, 30], [70, 10]])


def test_clip_path_transform_and_element_transform(tmp_path):
    """userSpaceOnUse: the clip is in the element's user space (its transform applies),
    after the clipPath's own transform."""
    body = ('<clipPath id="c" transform="translate(10 20)"><rect width="30" height="40"/></clipPath>'
            '<rect width="100" height="100" fill="#123" transform="scale(2)" clip-path="url(#c)"/>')
    g = _area(_write(tmp_path, "tf.svg", body, 'viewBox="0 0 200 200"'))
    assert g.area == pytest.approx(60 * 80)
    assert g.bounds == pytest.approx((20, 40, 80, 120))


def test_object_bounding_box_units_on_a_group(tmp_path):
    """objectBoundingBox: fractions of the group's box (its shapes, strokes excluded);
    the clipPath's transform applies in user units after the box mapping, as in
    Gecko and Blink."""
    shapes = ('<rect x="10" y="20" width="40" height="40" fill="#111"/>'
              '<rect x="50" y="20" width="40" height="40" fill="#222" stroke="#000" stroke-width="6"/>')
    for shift, x0 in ((None, 30.0), ("translate(3 0)", 33.0)):
        tf = f' transform="{shift}"' if shift else ""
        body = (f'<clipPath id="mid" clipPathUnits="objectBoundingBox"{tf}>'
                '<rect x="0.25" y="0" width="0.5" height="1"/></clipPath>'
                f'<g clip-path="url(#mid)">{shapes}</g>')
        g = _area(_write(tmp_path, "obb.svg", body))
        assert g.bounds == pytest.approx((x0, 20, x0 + 40, 60))
        assert g.area == pytest.approx(40 * 40)


def test_nested_clipped_groups_intersect(tmp_path):
    body = ('<clipPath id="a"><rect width="60" height="100"/></clipPath>'
            '<clipPath id="b"><rect x="20" width="80" height="100"/></clipPath>'
            '<clipPath id="c" clip-rule="evenodd"><path d="M0,0 H100 V100 H0 Z M30,30 H50 V50 H30 Z"/></clipPath>'
            '<g clip-path="url(#a)"><g clip-path="url(#b)">'
            '<rect width="100" height="100" fill="#333" clip-path="url(#c)"/></g></g>')
    g = _area(_write(tmp_path, "nest.svg", body))
    assert g.bounds == pytest.approx((20, 0, 60, 100))
    assert g.area == pytest.approx(40 * 100 - 20 * 20)  # evenodd: the inner square is a hole


def test_clip_path_in_a_css_rule_and_in_a_hidden_group(tmp_path):
    body = ('<style>.c { clip-path: url(#d) }</style>'
            '<g style="display:none"><clipPath id="d"><rect x="5" y="5" width="10" height="10"/></clipPath></g>'
            '<rect class="c" width="50" height="50" fill="#777"/>')
    g = _area(_write(tmp_path, "css.svg", body))
    assert g.bounds == pytest.approx((5, 5, 15, 15))


def test_clip_path_on_the_root_and_on_a_used_element(tmp_path):
    body = ('<clipPath id="c"><rect width="30" height="30"/></clipPath><g><rect width="50" height="50"/></g>')
    p = tmp_path / "root.svg"
    p.write_text(_svg(body, 'viewBox="0 0 100 100" clip-path="url(#c)"'))
    assert _area(p).bounds == pytest.approx((0, 0, 30, 30))
    # the clip moves with the <use> (it is in the used element's user space)
    body = ('<defs><rect id="r" width="40" height="40" clip-path="url(#d)"/></defs>'
            '<clipPath id="d"><circle cx="20" cy="20" r="20"/></clipPath>'
            '<use xlink:href="#r" x="50" y="50"/>')
    g = _area(_write(tmp_path, "use.svg", body))
    assert g.area == pytest.approx(math.pi * 20**2, rel=5e-3)
    np.testing.assert_allclose(g.bounds, (50, 50, 90, 90), atol=0.05)


def test_missing_clip_path_warns_and_draws_unclipped(tmp_path):
    """As browsers do (CSS Masking: an invalid reference is as if none were given)."""
    body = ('<rect id="notaclip" width="5" height="5"/>'
            '<rect x="10" y="10" width="50" height="50" fill="#000" clip-path="url(#nope)"/>'
            '<rect x="70" y="70" width="10" height="10" fill="#000" clip-path="url(#notaclip)"/>')
    p = _write(tmp_path, "missing.svg", body)
    with pytest.warns(UserWarning) as rec:
        g = _area(p)
    texts = [str(w.message) for w in rec]
    assert any("missing.svg: clip-path url(#nope) does not name a <clipPath>" in t for t in texts)
    assert any("url(#notaclip)" in t for t in texts)
    assert g.area == pytest.approx(50 * 50 + 5 * 5 + 10 * 10)


def test_unsupported_clip_path_value_warns(tmp_path):
    body = '<rect width="50" height="50" fill="#000" style="clip-path: circle(50%)"/>'
    with pytest.warns(UserWarning, match=r"shape\.svg: skipped unsupported content: clip-path 'circle"):
        g = _area(_write(tmp_path, "shape.svg", body))
    assert g.area == pytest.approx(2500)


def test_empty_clip_path_and_singular_transform_clip_everything(tmp_path):
    body = ('<clipPath id="e"/><clipPath id="z" transform="scale(0)"><rect width="90" height="90"/></clipPath>'
            '<rect width="20" height="20" clip-path="url(#e)"/>'
            '<rect x="30" width="20" height="20" clip-path="url(#z)"/>'
            '<rect x="60" y="60" width="10" height="10"/>')
    g = _area(_write(tmp_path, "empty.svg", body))
    assert g.bounds == pytest.approx((60, 60, 70, 70))


def test_clip_cycle_drops_only_the_link_that_closes_it(tmp_path):
    # browsers (and resvg) ignore the recursive reference: the rect is clipped by #a's 30 x 60 rect
    body = ('<clipPath id="a"><rect width="30" height="60" clip-path="url(#a)"/></clipPath>'
            '<rect width="50" height="50" clip-path="url(#a)"/>')
    with pytest.warns(UserWarning, match=r"self\.svg: clip-path url\(#a\) refers back to itself"):
        g = _area(_write(tmp_path, "self.svg", body))
    assert g.bounds == pytest.approx((0, 0, 30, 50))


def test_clipped_container(tmp_path):
    body = ('<clipPath id="disc"><circle cx="50" cy="50" r="40"/></clipPath>'
            '<rect width="100" height="100" fill="none" stroke="#000" clip-path="url(#disc)"/>')
    c = load_container(_write(tmp_path, "cont.svg", body))
    assert c.area == pytest.approx(math.pi * 40**2, rel=5e-3)
    np.testing.assert_allclose(c.bounds, (10, 10, 90, 90), atol=0.05)
    # drawn as browsers draw it: the rectangle's stroke lies outside the disc, nothing shows
    assert c.paths == ()


def test_a_clipped_container_is_drawn_without_a_stroke_along_the_cut(tmp_path):
    """A stroked disc clipped to its upper part: the fill is cut, the stroke is the arc's
    stroke only (the clipped outline, stroked, drew a line along the cut)."""
    body = ('<clipPath id="top"><rect width="100" height="50"/></clipPath>'
            '<circle cx="50" cy="50" r="40" fill="#def" stroke="#000" stroke-width="2" clip-path="url(#top)"/>')
    c = load_container(_write(tmp_path, "cont.svg", body))
    assert c.area == pytest.approx(math.pi * 40**2 / 2, rel=5e-3)
    fill, stroke = c.paths
    assert (fill.style.fill, fill.style.stroke, stroke.style.fill, stroke.style.stroke) == ("#ddeeff", None, "#000000", None)
    ring = art_area([stroke])
    assert ring.area == pytest.approx(math.pi * 40 * 2, rel=0.02)  # half the ring (length pi r), width 2
    assert ring.intersection(shapely.box(12, 45, 88, 50)).area < 1e-9  # nothing along y = 50


def test_clip_art_unit():
    art = ArtPath((np.array([[0.0, 0], [10, 0], [10, 10], [0, 10]]),), (True,),
                  Style(fill="#abcdef", stroke=None))
    assert clip_art(art, shapely.box(-1, -1, 11, 11)) == [art]
    assert clip_art(art, shapely.box(20, 20, 30, 30)) == []
    assert clip_art(art, shapely.Polygon()) == []
    (half,) = clip_art(art, shapely.box(5, -5, 20, 20))
    assert art_area([half]).area == pytest.approx(50)
    assert half.style.fill == "#abcdef" and half.style.fill_rule == "evenodd"


def test_written_art_is_the_clipped_geometry(tmp_path):
    """What the packing SVG holds for a clipped element is the clipped shape."""
    el = load_element(CLIP / "square_disc.svg")
    cont = load_container(CLIP / "square_disc.svg")
    out = tmp_path / "packing.svg"
    write_packing_svg(out, cont, [PlacedArt(el.source, "primary", el.paths)], 1.0)
    _, placed, _ = read_packing_svg(out)
    g = art_area(placed[0].paths)
    assert g.area == pytest.approx(math.pi * 40**2, rel=5e-3)
    np.testing.assert_allclose(g.bounds, (10, 10, 90, 90), atol=0.05)


def test_clipped_gradient_keeps_its_paint(tmp_path):
    """A shape painted with a gradient and clipped keeps the gradient (it came out in the
    gradient's first colour), mapped on the unclipped shape's box as renderers do."""
    resvg_py = pytest.importorskip("resvg_py")
    import matplotlib.image as mpimg

    src = _write(tmp_path, "g.svg", (
        '<defs><linearGradient id="g1"><stop offset="0" stop-color="#f00"/>'
        '<stop offset="1" stop-color="#00f"/></linearGradient>'
        '<clipPath id="c1"><circle cx="50" cy="50" r="45"/></clipPath></defs>'
        '<rect x="0" y="0" width="100" height="100" fill="url(#g1)" stroke="url(#g1)" '
        'stroke-width="20" clip-path="url(#c1)"/>'))
    el = load_element(src)
    assert len(el.paths) == 2 and list(el.paint_servers) == ["g1"]
    out = tmp_path / "packing.svg"
    write_packing_svg(out, load_container(src), [PlacedArt(el.source, "primary", el.paths,
                                                           paint_servers=el.paint_servers)], 1.0)
    text = out.read_text()
    written = out.with_name("written.svg")  # the copy alone, without the container's outline
    written.write_text(text.replace('class="container-region"', 'class="container-region" display="none"'))

    def rgb(path):
        png = bytes(resvg_py.svg_to_bytes(svg_path=str(path), width=100, height=100))
        return mpimg.imread(io.BytesIO(png), format="png")[..., :3]

    a, b = rgb(src), rgb(written)
    assert a[50, 90, 2] > 0.8 and a[50, 10, 0] > 0.8  # the source: red on the left, blue on the right
    assert np.abs(a[20:80, 20:80] - b[20:80, 20:80]).mean() < 0.02


# --------------------------------------------------------------------------- against resvg


def _coverage_resvg(path: Path, n: int) -> np.ndarray:
    resvg_py = pytest.importorskip("resvg_py")
    import matplotlib.image as mpimg

    png = bytes(resvg_py.svg_to_bytes(svg_path=str(path), width=n, height=n))
    return mpimg.imread(io.BytesIO(png), format="png")[..., 3] > 0.5


def _coverage_ours(path: Path, n: int, box=(0.0, 0.0, 100.0, 100.0)) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        g = art_area(load_element(path).paths)
    x0, y0, w, h = box
    X, Y = np.meshgrid(x0 + (np.arange(n) + 0.5) * w / n, y0 + (np.arange(n) + 0.5) * h / n)
    return shapely.contains_xy(g, X, Y)


@pytest.mark.parametrize("name", ["square_disc", "transforms", "nested_groups", "bbox_units"])
def test_clipped_art_matches_an_independent_renderer(name, tmp_path):
    """Pixels covered by resvg's rendering vs by our clipped art area (400 x 400 px over
    the 100-unit viewBox): they differ only along edges (anti-aliasing, flattening)."""
    path = CLIP / f"{name}.svg"
    n = 400
    ref = _coverage_resvg(path, n)
    ours = _coverage_ours(path, n)
    assert ref.sum() > 0.1 * n * n
    # the clip removes a substantial part of the art (the fixture tests something)
    unclipped = tmp_path / "unclipped.svg"
    unclipped.write_text(path.read_text().replace("clip-path=", "data-no-clip="))
    assert _coverage_ours(unclipped, n).sum() > 1.15 * ours.sum()
    diff = np.count_nonzero(ref ^ ours)
    edge = np.count_nonzero(ref ^ np.roll(ref, 1, 0)) + np.count_nonzero(ref ^ np.roll(ref, 1, 1))
    assert diff <= 0.5 * edge, (diff, edge)


# --------------------------------------------------------------------------- end to end


def test_packing_a_clipped_element_places_discs(tmp_path):
    """``repulsionpak pack`` with the square-clipped-to-a-disc element: every placed copy
    is a disc (area / bounding box ~ pi/4; the unclipped square would give 1)."""
    from typer.testing import CliRunner

    from repulsionpak.cli import app

    circle = Path(__file__).resolve().parents[1] / "src" / "repulsionpak" / "examples" / "containers" / "circle.svg"
    out = tmp_path / "o.svg"
    res = CliRunner().invoke(app, ["pack", str(circle), str(CLIP / "square_disc.svg"), "-o", str(out),
                                   "--count", "4", "--max-iterations", "200", "--gap", "10",
                                   "--seed", "1", "-q", "--no-pocket-fill"])
    assert res.exit_code == 0, res.stderr
    _, placed, _ = read_packing_svg(out)
    assert len(placed) == 4
    for pa in placed:
        assert [a.style.fill for a in pa.paths] == ["#22aa77"]
        g = art_area(pa.paths)
        x0, y0, x1, y1 = g.bounds
        assert 0.72 < g.area / ((x1 - x0) * (y1 - y0)) < 0.84
        assert 0.9 < (x1 - x0) / (y1 - y0) < 1.1
