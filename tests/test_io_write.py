"""Tests of repulsionpak.io writers: packing SVG (write + read back) and PNG preview."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import shapely

from repulsionpak.errors import InputError, OutputError, ParameterError
from repulsionpak.io import load_container, load_element, read_packing_svg
from repulsionpak.render.png import render_png
from repulsionpak.render.svg import write_packing_svg
from repulsionpak.render.numbers import format_number
from repulsionpak.types import ArtPath, Container, PlacedArt, Style

FIX = Path(__file__).parent / "fixtures"
DATA = Path("/work/shared/data")
NS = "{http://www.w3.org/2000/svg}"


def _square(x, y, s):
    return np.array([[x, y], [x + s, y], [x + s, y + s], [x, y + s]], float)


def _placed() -> list[PlacedArt]:
    rng = np.random.default_rng(7)
    blob = np.c_[
        np.cos(np.linspace(0, 2 * np.pi, 40, endpoint=False)),
        np.sin(np.linspace(0, 2 * np.pi, 40, endpoint=False)),
    ]
    blob = blob * (8 + rng.random((40, 1))) + [30, 25]
    a = PlacedArt(
        source="cat.svg",
        kind="primary",
        paths=(
            ArtPath((blob,), (True,), Style(fill="#f06465")),
            ArtPath(
                (_square(25, 20, 4), _square(26, 21, 1)),
                (True, True),
                Style(
                    fill="#ffffff",
                    stroke="#112233",
                    stroke_width=0.5,
                    fill_rule="evenodd",
                    opacity=0.8,
                    stroke_linejoin="round",
                    stroke_miterlimit=10.0,
                    paint_order="stroke fill markers",
                ),
            ),
            ArtPath(
                (np.array([[22.123456, 30.0], [38.5, 31.25], [40.0, 35.0]]),),
                (False,),
                Style(
                    fill=None,
                    stroke="#000000",
                    stroke_width=2.0,
                    stroke_linecap="round",
                    stroke_opacity=0.5,
                    stroke_dasharray=(4.0, 2.0),
                    stroke_dashoffset=1.0,
                ),
            ),
        ),
        stroke_scale=0.25,
        deformation=0.0123,
    )
    b = PlacedArt(
        source="small_cat.svg",
        kind="secondary",
        paths=(
            ArtPath(
                (_square(125, 5, 10) + rng.random((4, 2)) * 0.1,),
                (True,),
                Style(fill="#00ff00", fill_opacity=0.5),
            ),
        ),
        stroke_scale=1.0,
        deformation=None,
    )
    return [a, b]


@pytest.fixture
def container():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_container(FIX / "container_holes.svg")


# --------------------------------------------------------------------------- SVG structure


def test_output_structure(tmp_path, container):
    out = tmp_path / "out.svg"
    layers = {
        "skins": [_square(0, 0, 5), _square(10, 10, 3)],
        "mesh": [np.array([[0, 0], [1, 0], [0, 1]])],
    }
    write_packing_svg(
        out,
        container,
        _placed(),
        5.2,
        attrs={"seed": "42", "data-n_iter": 17},
        debug_layers=layers,
        metadata={"seed": 42, "arr": np.arange(3), "bad": float("nan")},
    )
    root = ET.parse(out).getroot()
    assert root.tag == NS + "svg"
    assert (
        root.get("width") == "4in"
        and root.get("height") == "2in"
        and root.get("viewBox") == "-10 -10 200 100"
    )
    assert (
        root.get("data-gap") == "5.2"
        and root.get("data-seed") == "42"
        and root.get("data-n_iter") == "17"
    )
    assert root.get("data-partial") is None
    meta = json.loads(root.find(NS + "metadata").text)
    assert meta == {"seed": 42, "arr": [0, 1, 2], "bad": None, "partial": False}
    children = [c for c in root if c.tag != NS + "metadata"]
    assert [c.get("id") for c in children] == [
        "container",
        "elements",
        "debug-skins",
        "debug-mesh",
    ]
    cont = children[0]
    assert cont.get("data-source") == "container_holes.svg"
    drawn = [p for p in cont if p.get("class") != "container-region"]
    # by default the container is its region's outline, stroke only (it never hides the art)
    assert [p.get("class") for p in drawn] == ["container-outline"]
    assert drawn[0].get("fill") == "none" and drawn[0].get("stroke") not in (None, "none")
    assert drawn[0].get("d") == next(p for p in cont if p.get("class") == "container-region").get("d")
    as_drawn = tmp_path / "as_drawn.svg"
    write_packing_svg(as_drawn, container, _placed(), 5.2, container_paint="as-drawn")
    cont2 = next(c for c in ET.parse(as_drawn).getroot() if c.get("id") == "container")
    assert len([p for p in cont2 if p.get("class") != "container-region"]) == 3  # its own shapes
    groups = list(children[1])
    assert [g.get("class") for g in groups] == ["element primary", "element secondary"]
    assert (
        groups[0].get("data-source") == "cat.svg"
        and groups[0].get("data-deformation") == "0.0123"
    )
    assert groups[1].get("data-deformation") is None
    p0, p1, p2 = list(groups[0])
    assert (
        p0.get("fill") == "#f06465"
        and p0.get("stroke") is None
        and p0.get("stroke-width") is None
    )
    assert (
        p1.get("fill-rule") == "evenodd"
        and p1.get("stroke-width") == "0.125"
        and p1.get("opacity") == "0.8"
    )
    assert p1.get("stroke-miterlimit") == "10" and p1.get("stroke-dasharray") is None
    assert p1.get("paint-order") == "stroke fill markers" and p2.get("paint-order") is None
    assert (p2.get("stroke-dasharray"), p2.get("stroke-dashoffset")) == ("1 0.5", "0.25")  # × stroke_scale
    assert (
        p1.get("stroke-linejoin") == "round"
        and p1.get("d").count("M") == 2
        and p1.get("d").count("Z") == 2
    )
    assert (
        p2.get("fill") == "none"
        and p2.get("stroke-width") == "0.5"
        and p2.get("stroke-linecap") == "round"
    )
    assert "Z" not in p2.get("d") and "22.1235 30 L 38.5 31.25" in p2.get("d")
    for layer in children[2:]:
        assert layer.get("style") == "display:none"


def test_partial_flag_and_gap_repr(tmp_path, container):
    out = tmp_path / "partial.svg"
    write_packing_svg(out, container, [], 0.1 + 0.2, partial=True)
    root = ET.parse(out).getroot()
    assert root.get("data-partial") == "true"
    assert float(root.get("data-gap")) == 0.1 + 0.2  # shortest round-trip repr
    assert json.loads(root.find(NS + "metadata").text) == {"partial": True}
    _, placed, info = read_packing_svg(out)
    assert placed == [] and info["partial"] is True and info["gap"] == 0.1 + 0.2


def test_format_number():
    assert format_number(1.23456789) == "1.2346"
    assert format_number(2.0) == "2"
    assert format_number(-0.00001) == "0"
    assert format_number(-12.5) == "-12.5"
    assert format_number(1e6) == "1000000"


def test_bad_attr_key_rejected(tmp_path, container):
    with pytest.raises(ValueError):
        write_packing_svg(
            tmp_path / "x.svg", container, [], 1.0, attrs={"bad key": "1"}
        )


def test_nonfinite_coordinates_refused(tmp_path, container):
    bad = PlacedArt(
        "a.svg",
        "primary",
        (ArtPath((np.array([[0, 0], [np.nan, 1], [1, 1]]),), (True,)),),
    )
    with pytest.raises(OutputError):
        write_packing_svg(tmp_path / "x.svg", container, [bad], 1.0)
    assert not list(tmp_path.iterdir())


# --------------------------------------------------------------------------- round trip


def test_round_trip(tmp_path, container):
    placed = _placed()
    out = tmp_path / "rt.svg"
    write_packing_svg(out, container, placed, 5.25, attrs={"seed": 3})
    c2, p2, info = read_packing_svg(out)
    assert info["gap"] == 5.25 and info["seed"] == "3" and info["partial"] is False
    assert c2.source == container.source and c2.svg_root == container.svg_root
    assert c2.area == pytest.approx(container.area, rel=1e-6)
    assert c2.region.symmetric_difference(container.region).area < 1e-3
    assert c2.paths == ()  # the default outline is not the container's own drawing
    drawn = tmp_path / "rt_as_drawn.svg"
    write_packing_svg(drawn, container, placed, 5.25, container_paint="as-drawn")
    c3, _, _ = read_packing_svg(drawn)
    assert len(c3.paths) == len(container.paths)  # as-drawn: its own shapes come back
    assert c3.region.symmetric_difference(container.region).area < 1e-3
    assert [p.kind for p in p2] == ["primary", "secondary"]
    assert [p.source for p in p2] == ["cat.svg", "small_cat.svg"]
    assert p2[0].deformation == pytest.approx(0.0123) and p2[1].deformation is None
    for a, b in zip(placed, p2):
        assert len(a.paths) == len(b.paths)
        for pa, pb in zip(a.paths, b.paths):
            assert pa.closed == pb.closed
            for sa, sb in zip(pa.subpaths, pb.subpaths):
                assert sa.shape == sb.shape
                np.testing.assert_allclose(sa, sb, atol=1e-4)
            sa_, sb_ = pa.style, pb.style
            assert (
                sa_.fill,
                sa_.stroke,
                sa_.fill_rule,
                sa_.stroke_linecap,
                sa_.stroke_linejoin,
            ) == (
                sb_.fill,
                sb_.stroke,
                sb_.fill_rule,
                sb_.stroke_linecap,
                sb_.stroke_linejoin,
            )
            assert (sb_.opacity, sb_.fill_opacity, sb_.stroke_opacity) == pytest.approx(
                (sa_.opacity, sa_.fill_opacity, sa_.stroke_opacity)
            )
            if sa_.stroke is not None:
                assert sb_.stroke_width == pytest.approx(
                    sa_.stroke_width * a.stroke_scale
                )
                assert sb_.stroke_miterlimit == sa_.stroke_miterlimit
                assert sb_.paint_order == sa_.paint_order
                assert sb_.stroke_dasharray == pytest.approx(tuple(d * a.stroke_scale for d in sa_.stroke_dasharray))
                assert sb_.stroke_dashoffset == pytest.approx(sa_.stroke_dashoffset * a.stroke_scale)


def test_output_reloads_as_container_in_same_coordinates(tmp_path, container):
    out = tmp_path / "rt.svg"
    write_packing_svg(out, container, _placed(), 1.0)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        again = load_element(out)  # any SVG reader sees the same user units
    pts = np.concatenate([s for a in again.paths for s in a.subpaths])
    assert pts.min(axis=0)[0] == pytest.approx(
        0, abs=1e-3
    )  # container outline starts at x=0


def test_write_without_svg_root_and_without_outline(tmp_path):
    region = shapely.Polygon(
        [(100, 50), (300, 50), (300, 150), (100, 150)],
        [[(150, 75), (160, 75), (160, 85)]],
    )
    c = Container(source="box.path", region=region)
    out = tmp_path / "o.svg"
    write_packing_svg(out, c, [], 2.0)
    root = ET.parse(out).getroot()
    x, y, w, h = map(float, root.get("viewBox").split())
    assert x < 100 and y < 50 and x + w > 300 and y + h > 150
    assert float(root.get("width")) == pytest.approx(w, abs=1e-3)
    cont = root.find(NS + "g")
    drawn = [p for p in cont if p.get("class") != "container-region"]
    assert (
        len(drawn) == 1
        and drawn[0].get("stroke") == "#000000"
        and drawn[0].get("fill") == "none"
    )
    assert drawn[0].get("class") == "container-outline"
    c2, _, _ = read_packing_svg(out)
    assert c2.area == pytest.approx(region.area, rel=1e-9)
    assert c2.paths == ()  # the fallback outline is not an input outline


@pytest.mark.skipif(
    not (DATA / "containers").is_dir(), reason="shared data set not available"
)
def test_round_trip_with_shared_data(tmp_path):
    heart = load_container(DATA / "containers" / "heart.svg")
    cat = load_element(DATA / "animals" / "cat.svg")
    placed = [
        PlacedArt(
            "cat.svg",
            "primary",
            tuple(a.transformed(lambda p: p * 0.2 + 150) for a in cat.paths),
            stroke_scale=0.2,
        )
    ]
    out = tmp_path / "heart_out.svg"
    write_packing_svg(out, heart, placed, 3.0)
    c2, p2, _ = read_packing_svg(out)
    assert c2.area == pytest.approx(heart.area, rel=1e-6)
    for pa, pb in zip(placed[0].paths, p2[0].paths):
        np.testing.assert_allclose(pa.subpaths[0], pb.subpaths[0], atol=1e-4)


# --------------------------------------------------------------------------- files


def test_deterministic_and_atomic(tmp_path, container):
    a, b = tmp_path / "a.svg", tmp_path / "b.svg"
    write_packing_svg(a, container, _placed(), 5.2, metadata={"z": 1, "a": [1.5]})
    write_packing_svg(b, container, _placed(), 5.2, metadata={"a": [1.5], "z": 1})
    assert a.read_bytes() == b.read_bytes()
    a.write_text("old content")
    write_packing_svg(
        a, container, _placed(), 5.2, metadata={"z": 1, "a": [1.5]}
    )  # replaces
    assert a.read_bytes() == b.read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "a.svg",
        "b.svg",
    ]  # no temp files left


def test_missing_directory_and_directory_target(tmp_path, container):
    with pytest.raises(OutputError, match="does not exist"):
        write_packing_svg(tmp_path / "nope" / "o.svg", container, [], 1.0)
    (tmp_path / "d.svg").mkdir()
    with pytest.raises(OutputError):
        write_packing_svg(tmp_path / "d.svg", container, [], 1.0)
    with pytest.raises(OutputError, match="does not exist"):
        render_png(tmp_path / "nope" / "o.png", container, [])
    assert [p.name for p in tmp_path.iterdir()] == ["d.svg"]


def test_read_packing_svg_errors(tmp_path):
    with pytest.raises(InputError, match="rect_scaled.svg.*container"):
        read_packing_svg(FIX / "rect_scaled.svg")
    bomb = tmp_path / "bomb.svg"
    bomb.write_text(
        '<?xml version="1.0"?><!DOCTYPE svg [<!ENTITY a "aaaa"><!ENTITY b "&a;&a;">]><svg xmlns="http://www.w3.org/2000/svg">&b;</svg>'
    )
    with pytest.raises(InputError, match="bomb.svg.*entities"):
        read_packing_svg(bomb)
    with pytest.raises(InputError, match="missing.svg"):
        read_packing_svg(tmp_path / "missing.svg")
    bad_gap = tmp_path / "gap.svg"
    bad_gap.write_text(
        '<svg xmlns="http://www.w3.org/2000/svg" data-gap="x"><g id="container"><rect width="1" height="1"/></g></svg>'
    )
    with pytest.raises(InputError, match="gap.svg.*data-gap"):
        read_packing_svg(bad_gap)


# --------------------------------------------------------------------------- PNG


def _png(path: Path) -> np.ndarray:
    from matplotlib.image import imread

    return imread(path)  # float RGBA in [0, 1]


def _simple_container():
    region = shapely.box(0, 0, 200, 100)
    return Container(
        source="box.svg",
        region=region,
        paths=(
            ArtPath(
                (np.asarray(region.exterior.coords)[:-1],),
                (True,),
                Style(fill=None, stroke="#000000", stroke_width=1.0),
            ),
        ),
    )


def _px(x, y, W, container, margin=0.02):
    """Pixel (row, col) of data point (x, y) for a container rendered W pixels wide."""
    x0, y0, x1, y1 = container.bounds
    m = margin * max(x1 - x0, y1 - y0)
    scale = W / (x1 - x0 + 2 * m)
    return int((y - y0 + m) * scale), int((x - x0 + m) * scale)


def test_png_size_colours_and_fill_rules(tmp_path):
    c = _simple_container()
    red = ArtPath((_square(20, 20, 40),), (True,), Style(fill="#ff0000"))
    ring_eo = ArtPath(
        (_square(100, 20, 40), _square(110, 30, 20)),
        (True, True),
        Style(fill="#0000ff", fill_rule="evenodd"),
    )
    ring_nz = ArtPath(
        (_square(150, 20, 40), _square(160, 30, 20)),
        (True, True),
        Style(fill="#0000ff", fill_rule="nonzero"),
    )
    placed = [PlacedArt("a.svg", "primary", (red, ring_eo, ring_nz))]
    out = tmp_path / "p.png"
    render_png(out, c, placed, size_px=400)
    img = _png(out)
    assert img.shape[:2] == (round(400 * 108 / 208), 400)
    W = 400
    r, col = _px(40, 40, W, c)
    np.testing.assert_allclose(
        img[r, col, :3], [1, 0, 0], atol=0.02
    )  # inside the red square
    r, col = _px(80, 80, W, c)
    np.testing.assert_allclose(
        img[r, col, :3], [1, 1, 1], atol=0.02
    )  # empty: background
    r, col = _px(120, 40, W, c)
    np.testing.assert_allclose(img[r, col, :3], [1, 1, 1], atol=0.02)  # evenodd hole
    r, col = _px(104, 40, W, c)
    np.testing.assert_allclose(img[r, col, :3], [0, 0, 1], atol=0.02)  # evenodd ring
    r, col = _px(170, 40, W, c)
    np.testing.assert_allclose(
        img[r, col, :3], [0, 0, 1], atol=0.02
    )  # nonzero, same orientation: filled
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.png"]


def test_png_y_down_and_stroke_width_in_data_units(tmp_path):
    c = _simple_container()
    line = ArtPath(
        (np.array([[20.0, 80.0], [180.0, 80.0]]),),
        (False,),
        Style(fill=None, stroke="#000000", stroke_width=10.0),
    )
    out = tmp_path / "l.png"
    render_png(
        out,
        c,
        [PlacedArt("a.svg", "primary", (line,), stroke_scale=0.5)],
        size_px=816,
        show_container=False,
    )
    img = _png(out)
    W = img.shape[1]
    scale = W / 208.0  # pixels per data unit (200 + 2 x 4 margin)
    col = W // 2
    dark = np.nonzero(img[:, col, 0] < 0.5)[0]
    assert len(dark) == pytest.approx(
        5.0 * scale, abs=2
    )  # 10 x stroke_scale 0.5 data units
    assert dark.mean() == pytest.approx(
        (80 + 4) * scale, abs=2
    )  # y = 80 is in the lower part


def test_png_deterministic_transparent_and_validated(tmp_path):
    c = _simple_container()
    placed = _placed()
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    render_png(a, c, placed, size_px=200)
    render_png(b, c, placed, size_px=200)
    assert a.read_bytes() == b.read_bytes()
    t = tmp_path / "t.png"
    render_png(t, c, [], size_px=100, background=None, show_container=False)
    assert _png(t)[..., 3].max() == 0.0
    with pytest.raises(ParameterError):
        render_png(tmp_path / "x.png", c, [], size_px=0)
    with pytest.raises(ParameterError):
        render_png(tmp_path / "x.png", c, [], background="not-a-colour")
    tall = Container("t.svg", shapely.box(0, 0, 10, 50))
    render_png(t, tall, [], size_px=300)
    assert _png(t).shape[:2] == (300, round(300 * 12 / 52))


def test_png_does_not_touch_pyplot(tmp_path):
    import subprocess
    import sys

    code = (
        "import sys, shapely\n"
        "from repulsionpak.render.png import render_png\n"
        "from repulsionpak.types import Container\n"
        f"render_png({str(tmp_path / 'p.png')!r}, Container('b.svg', shapely.box(0, 0, 1, 1)), [], size_px=32)\n"
        "assert 'matplotlib.pyplot' not in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
    assert (tmp_path / "p.png").stat().st_size > 0


# --------------------------------------------------------------------------- group opacity


GROUP_OPACITY = """<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">
<g opacity="0.5"><g style="opacity:0.8">
  <rect width="40" height="40" fill="#ff0000"/><rect x="20" y="20" width="40" height="40" fill="#00ff00"/>
</g><rect x="50" y="50" width="40" height="40" fill="#0000ff" opacity="0.5"/></g>
<rect x="0" y="60" width="30" height="30"/>
</svg>"""


def test_translucent_groups_are_written_as_groups(tmp_path):
    """Shapes overlapping inside a group with opacity compose as one layer: the group is
    written back as <g opacity> around them, not as the product on each path (where the
    red square would show through the green one)."""
    src = tmp_path / "el.svg"
    src.write_text(GROUP_OPACITY)
    el = load_element(src)
    assert [a.style.opacity for a in el.paths] == pytest.approx([0.4, 0.4, 0.25, 1.0])
    assert [len(a.style.layers) for a in el.paths] == [2, 2, 1, 0]
    box = tmp_path / "box.svg"
    box.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
                   '<rect width="100" height="100" fill="none"/></svg>')
    out = tmp_path / "out.svg"
    write_packing_svg(out, load_container(box), [PlacedArt("el.svg", "primary", el.paths)], 1.0)
    group = next(g for g in ET.parse(out).getroot().iter(f"{NS}g") if g.get("class") == "element primary")
    outer = [c for c in group if c.tag == f"{NS}g"]
    assert [g.get("opacity") for g in outer] == ["0.5"]
    inner = [c for c in outer[0] if c.tag == f"{NS}g"]
    assert [g.get("opacity") for g in inner] == ["0.8"] and len(list(inner[0])) == 2
    assert [p.get("opacity") for p in inner[0]] == [None, None]  # the groups carry it
    assert [p.get("opacity") for p in outer[0] if p.tag == f"{NS}path"] == ["0.5"]
    # read back: the same shapes, the same opacity per shape
    _, placed, _ = read_packing_svg(out)
    assert [a.style.opacity for a in placed[0].paths] == pytest.approx([0.4, 0.4, 0.25, 1.0])
    # and drawn as the source is drawn (an independent renderer)
    resvg_py = pytest.importorskip("resvg_py")
    import io as _io

    import matplotlib.image as mpimg

    def pixel(path, x, y):
        png = bytes(resvg_py.svg_to_bytes(svg_path=str(path), width=100, height=100))
        return mpimg.imread(_io.BytesIO(png), format="png")[y, x]

    for x, y in [(30, 30), (10, 10), (55, 55), (70, 70), (15, 75)]:  # overlap, red, green+blue, blue, black
        np.testing.assert_allclose(pixel(out, x, y), pixel(src, x, y), atol=2 / 255)


@pytest.mark.parametrize("root", [
    'width="1200" height="600" viewBox="0 0 600 600" preserveAspectRatio="xMaxYMid meet"',
    'width="1200" height="600" viewBox="0 0 600 600" preserveAspectRatio="none"',
    'width="1200" height="600" viewBox="0 0 600 600" transform="translate(100 20)"',
])
def test_the_output_overlays_its_container_file_on_the_page(tmp_path, root):
    """Both files drawn at the same size: the output's container outline lies where the
    input's does (preserveAspectRatio was dropped: the output moved 300 px left)."""
    pytest.importorskip("resvg_py")
    from render_checks import resvg_mask

    src = tmp_path / "c.svg"
    src.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" {root}><path fill="#000" '
                   'd="M300,50 C450,50 550,170 550,300 C550,450 420,550 300,550 C160,550 50,440 50,300 '
                   'C50,160 150,50 300,50 Z"/></svg>')
    c = load_container(src)
    out = tmp_path / "o.svg"
    write_packing_svg(out, c, [], 5.0)

    a, b = resvg_mask(src, 1200, 600), resvg_mask(out, 1200, 600)
    cols = lambda m: np.flatnonzero(m.any(axis=0))  # noqa: E731
    assert a.sum() > 1000 and b.sum() > 1000
    assert abs(cols(a)[0] - cols(b)[0]) <= 2 and abs(cols(a)[-1] - cols(b)[-1]) <= 2
    rows = lambda m: np.flatnonzero(m.any(axis=1))  # noqa: E731
    assert abs(rows(a)[0] - rows(b)[0]) <= 2 and abs(rows(a)[-1] - rows(b)[-1]) <= 2
