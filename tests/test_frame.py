"""The frame of the output: the input's viewBox, grown where the container or art reaches past it;
the SVG and the PNG preview show the same frame."""

from __future__ import annotations

import io
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from repulsionpak.io import load_container, read_packing_svg
from repulsionpak.render.png import render_png
from repulsionpak.render.svg import write_packing_svg
from repulsionpak.render.container_paint import outline_width
from repulsionpak.render.frame import packing_frame
from repulsionpak.types import ArtPath, PlacedArt, Style

# Font Awesome's tree reaches from y = -32 to 544 in a 448 x 512 viewBox
TREE = ('<svg xmlns="http://www.w3.org/2000/svg" {root}>'
        '<path d="M224 -32 L420 300 L300 300 L400 544 L48 544 L148 300 L28 300 Z"/></svg>')


def _container(tmp_path, root='viewBox="0 0 448 512"', body=None):
    f = tmp_path / "tree.svg"
    f.write_text(body or TREE.format(root=root))
    return load_container(f)


def _square(x, y, s):
    return np.array([[x, y], [x + s, y], [x + s, y + s], [x, y + s]], float)


def _art(cx, cy, s=16.0, fill="#d7263d"):
    return PlacedArt("sq.svg", "primary", (ArtPath((_square(cx - s / 2, cy - s / 2, s),), (True,),
                                                   Style(fill=fill)),))


def test_overflowing_container_grows_the_viewbox(tmp_path):
    c = _container(tmp_path, 'width="448" height="512" viewBox="0 0 448 512"')
    f = packing_frame(c, [], "outline", outline_width(c, 5.0))
    x, y, w, h = f.view
    assert x == 0 and w == 448  # nothing reaches past the sides
    assert y < -32 and y > -32 - 3  # the tip plus a small margin
    assert y + h > 544 and y + h < 544 + 3
    attrs = dict(f.root_attrs)
    assert [k for k, _ in f.root_attrs] == ["width", "height", "viewBox"]
    assert float(attrs["width"]) == 448  # a user unit keeps its size on the page
    assert float(attrs["height"]) == pytest.approx(512 * h / 512, abs=1e-3)
    assert list(map(float, attrs["viewBox"].split())) == pytest.approx([x, y, w, h], abs=1e-3)


def test_a_frame_that_holds_everything_is_kept_as_given(tmp_path):
    body = ('<svg xmlns="http://www.w3.org/2000/svg" width="4in" height="2in" viewBox="-10 -10 200 100" '
            'preserveAspectRatio="xMinYMin meet"><rect x="0" y="0" width="100" height="50"/></svg>')
    c = _container(tmp_path, body=body)
    f = packing_frame(c, [_art(50, 25)], "outline", 0.5)
    assert f.root_attrs == (("width", "4in"), ("height", "2in"), ("viewBox", "-10 -10 200 100"),
                            ("preserveAspectRatio", "xMinYMin meet"))
    assert f.view == (-10, -10, 200, 100)


def test_units_scale_with_the_grown_frame(tmp_path):
    body = ('<svg xmlns="http://www.w3.org/2000/svg" width="4in" height="2in" viewBox="0 0 200 100">'
            '<rect x="-20" y="0" width="100" height="130"/></svg>')
    c = _container(tmp_path, body=body)
    f = packing_frame(c, [], "none", 0.5)
    x, y, w, h = f.view
    assert x < -20 and y == 0 and y + h > 130
    attrs = dict(f.root_attrs)
    assert attrs["width"].endswith("in") and float(attrs["width"][:-2]) == pytest.approx(4 * w / 200, abs=1e-3)
    assert float(attrs["height"][:-2]) == pytest.approx(2 * h / 100, abs=1e-3)


def test_width_and_height_without_viewbox_get_one(tmp_path):
    body = ('<svg xmlns="http://www.w3.org/2000/svg" width="100" height="100">'
            '<rect x="10" y="10" width="80" height="120"/></svg>')
    c = _container(tmp_path, body=body)
    f = packing_frame(c, [], "outline", 0.5)
    attrs = dict(f.root_attrs)
    x, y, w, h = map(float, attrs["viewBox"].split())
    assert (x, y, w) == (0, 0, 100) and 130 < y + h < 132
    assert float(attrs["height"]) == pytest.approx(h, abs=1e-3) and attrs["width"] == "100"


def test_art_past_the_frame_grows_it_too(tmp_path):
    c = _container(tmp_path)
    stroked = PlacedArt("s.svg", "primary", (ArtPath((np.array([[100.0, 520.0], [300.0, 560.0]]),), (False,),
                                                     Style(fill=None, stroke="#000", stroke_width=8.0)),))
    x, y, w, h = packing_frame(c, [stroked], "outline", 0.5).view
    assert y + h >= 560 + 4  # the stroke's half width included


def test_svg_and_png_show_the_same_frame_and_nothing_is_clipped(tmp_path):
    """A copy in the part of the container above the viewBox is drawn by a browser-grade
    renderer from the SVG, and the PNG preview shows the same picture (same frame)."""
    resvg = pytest.importorskip("resvg_py")
    from PIL import Image

    c = _container(tmp_path)
    placed = [_art(224, -8, 12.0), _art(224, 524, fill="#1b998b")]  # at the tip (y < 0), the foot (y > 512)
    svg, png = tmp_path / "o.svg", tmp_path / "o.png"
    write_packing_svg(svg, c, placed, 4.0)
    render_png(png, c, placed, size_px=500, gap=4.0)
    b = np.asarray(Image.open(png).convert("RGB"), dtype=float)
    a = np.asarray(Image.open(io.BytesIO(bytes(resvg.svg_to_bytes(svg_path=str(svg), width=b.shape[1],
                                                                background="#ffffff"))))
                   .convert("RGB"), dtype=float)
    assert b.shape[0] == 500 and abs(a.shape[0] - b.shape[0]) <= 1 and a.shape[1] == b.shape[1]
    h = min(a.shape[0], b.shape[0])

    def red(img):
        return (img[..., 0] > 180) & (img[..., 1] < 90) & (img[..., 2] < 110)

    def teal(img):
        return (img[..., 0] < 80) & (img[..., 1] > 120) & (img[..., 2] > 110)

    for mask in (red, teal):
        ma, mb = mask(a[:h]), mask(b[:h])
        assert ma.sum() > 50 and mb.sum() > 50  # drawn, not clipped
        ra, rb = np.argwhere(ma).mean(axis=0), np.argwhere(mb).mean(axis=0)
        assert np.abs(ra - rb).max() < 2.5  # at the same place in both pictures (old frames: ~28 px apart)
    # the container's tip and foot are inside the picture, with a little room
    dark = np.argwhere(a.max(axis=2) < 100)
    assert dark[:, 0].min() >= 1 and dark[:, 0].max() <= a.shape[0] - 2
    # read back: the frame is kept, the region is the container's
    c2, _, _ = read_packing_svg(svg)
    assert c2.region.symmetric_difference(c.region).area < 1e-3
    root = ET.parse(svg).getroot()
    assert float(root.get("viewBox").split()[1]) < -32


def test_root_transform_keeps_the_input_frame(tmp_path):
    c = _container(tmp_path, 'viewBox="0 0 448 512" transform="translate(10 0)"')
    f = packing_frame(c, [], "outline", 0.5)
    assert dict(f.root_attrs)["viewBox"] == "0 0 448 512"


def test_no_page_attributes_frame_the_drawing(tmp_path):
    c = _container(tmp_path, "")
    x, y, w, h = packing_frame(c, [], "outline", 0.5).view
    m = 0.02 * 576
    assert (x, y, w, h) == pytest.approx((28 - m, -32 - m, 392 + 2 * m, 576 + 2 * m))
