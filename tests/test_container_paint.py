"""The container never hides the art: drawn as an outline by default, as-drawn or not at all
on request, with a warning when its own paint would hide the art; every output alike."""

from __future__ import annotations

import io
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import shapely

from repulsionpak.io import load_container, read_packing_svg
from repulsionpak.render.png import render_png
from repulsionpak.render.svg import write_packing_svg
from repulsionpak.render.container_paint import hidden_art, hiding_warning, outline_colour, outline_width
from repulsionpak.types import ArtPath, PlacedArt, Style

NS = "{http://www.w3.org/2000/svg}"
EX = Path(__file__).resolve().parents[1] / "src" / "repulsionpak" / "examples"

DISC = ('<svg xmlns="http://www.w3.org/2000/svg" width="200" height="200" viewBox="0 0 200 200">'
        '<circle id="c" cx="100" cy="100" r="90" fill="{fill}"{stroke}/></svg>')


def _container(tmp_path, fill="currentColor", stroke=""):
    f = tmp_path / "disc.svg"
    f.write_text(DISC.format(fill=fill, stroke=stroke))
    return load_container(f)


def _square(x, y, s):
    return np.array([[x, y], [x + s, y], [x + s, y + s], [x, y + s]], float)


def _copies(fill="#000000", stroke=None):
    """Nine 20-unit squares inside the disc, 10 units apart."""
    return [PlacedArt("sq.svg", "primary", (ArtPath((_square(x, y, 20),), (True,),
                                                    Style(fill=fill, stroke=stroke, stroke_width=2.0)),))
            for x in (60, 90, 120) for y in (60, 90, 120)]


def _group(svg_path):
    return next(g for g in ET.parse(svg_path).getroot().iter(f"{NS}g") if g.get("id") == "container")


def test_default_outline_is_the_exact_region_stroked(tmp_path):
    c = _container(tmp_path)
    out = tmp_path / "o.svg"
    write_packing_svg(out, c, _copies(), 4.0)
    group = _group(out)
    drawn = [e for e in group if e.get("class") != "container-region"]
    assert [e.get("class") for e in drawn] == ["container-outline"] and drawn[0].tag == f"{NS}path"
    o = drawn[0]
    assert o.get("fill") == "none" and o.get("stroke") == "#000000"
    assert float(o.get("stroke-width")) == pytest.approx(min(math.hypot(180, 180) / 700, 4.0 / 3), rel=1e-5)
    region = next(e for e in group if e.get("class") == "container-region")
    assert o.get("d") == region.get("d")  # the exact geometry the packing was made in
    c2, placed, info = read_packing_svg(out)
    assert c2.area == pytest.approx(c.area, rel=1e-6) and len(placed) == 9


def test_none_leaves_only_the_invisible_region(tmp_path):
    c = _container(tmp_path)
    out = tmp_path / "o.svg"
    write_packing_svg(out, c, _copies(), 4.0, container_paint="none")
    group = _group(out)
    assert [e.get("class") for e in group] == ["container-region"]
    assert group[0].get("fill") == "none" and group[0].get("stroke") == "none"
    c2, _, _ = read_packing_svg(out)  # evaluate can still read the packing back
    assert c2.area == pytest.approx(c.area, rel=1e-6)


def test_as_drawn_keeps_the_containers_markup(tmp_path):
    c = _container(tmp_path, fill="#dd2e44", stroke=' stroke="#333333" stroke-width="3"')
    out = tmp_path / "o.svg"
    write_packing_svg(out, c, _copies(), 4.0, container_paint="as-drawn")
    circle = _group(out).find(f"{NS}circle")
    assert circle is not None and circle.get("id") == "c"
    assert (circle.get("fill"), circle.get("stroke"), circle.get("stroke-width")) == ("#dd2e44", "#333333", "3")


def test_unknown_paint_is_refused(tmp_path):
    from repulsionpak.errors import ParameterError

    with pytest.raises(ParameterError, match="outline, as-drawn, none"):
        write_packing_svg(tmp_path / "o.svg", _container(tmp_path), [], 4.0, container_paint="filled")


def test_outline_colour_follows_the_container(tmp_path):
    assert outline_colour(_container(tmp_path)) == "#000000"  # currentColor
    assert outline_colour(_container(tmp_path, fill="#8b0000")) == "#8b0000"  # dark enough: kept
    assert outline_colour(_container(tmp_path, fill="#dd2e44", stroke=' stroke="#123456"')) == "#123456"
    pale = outline_colour(_container(tmp_path, fill="#ffffff"))  # would vanish on white: darkened
    rgb = np.array([int(pale[i:i + 2], 16) for i in (1, 3, 5)]) / 255
    assert rgb.max() < 0.75 and np.ptp(rgb) < 1e-6  # grey, hue kept (none)


def _png_rgb(data_or_path):
    from PIL import Image

    img = Image.open(io.BytesIO(data_or_path) if isinstance(data_or_path, bytes) else data_or_path)
    return np.asarray(img.convert("RGB"), dtype=float)


def test_png_follows_the_choice(tmp_path):
    """A point of the container between copies is white with the outline, black as drawn;
    the edge is dark with the outline and white with none."""
    c = _container(tmp_path)
    placed = _copies(fill="#1b998b")
    imgs = {}
    for paint in ("outline", "as-drawn", "none"):
        f = tmp_path / f"{paint}.png"
        render_png(f, c, placed, size_px=200, container_paint=paint, gap=4.0)
        imgs[paint] = _png_rgb(f)
    assert imgs["outline"].shape == (200, 200, 3)  # the frame is the viewBox 0 0 200 200
    inside = (40, 100)  # (row, col): container, no copy
    edge = (100, 10)  # on the circle x = 10, y = 100
    assert imgs["outline"][inside].min() > 240 and imgs["none"][inside].min() > 240
    assert imgs["as-drawn"][inside].max() < 15
    near = (slice(edge[0] - 1, edge[0] + 2), slice(edge[1] - 1, edge[1] + 2))
    assert imgs["outline"][near].min() < 120 and imgs["none"][near].min() > 240
    for img in imgs.values():  # the art is drawn in all three
        assert np.allclose(img[70, 70], [0x1b, 0x99, 0x8b], atol=3)


def test_hidden_art_is_measured_on_what_shows(tmp_path):
    black = _container(tmp_path)
    share, colour = hidden_art(black, _copies(fill="#000000"))
    assert share == pytest.approx(1.0) and colour == "#000000"
    assert hidden_art(black, _copies(fill="#ffcc4d")) is None  # yellow on black: seen
    # a dark grey stroke over a yellow body: only the stroke's band hides
    share, _ = hidden_art(black, _copies(fill="#ffcc4d", stroke="#222222"))
    outer = 22 ** 2 - (4 - math.pi)  # the square and its 2-unit stroke (round buffer corners)
    assert share == pytest.approx((outer - 18 ** 2) / outer, abs=1e-3)
    red = _container(tmp_path, fill="#dd2e44")  # Twemoji's red
    share, colour = hidden_art(red, _copies(fill="#be1931"))  # a red apple on it
    assert share == pytest.approx(1.0) and colour == "#dd2e44"
    assert hidden_art(_container(tmp_path, fill="none", stroke=' stroke="#000"'), _copies()) is None


def test_warning_says_how_to_change_it(tmp_path):
    c = _container(tmp_path)
    msg = hiding_warning(c, _copies(), "as-drawn")
    assert msg is not None and "--container-paint outline" in msg and "100%" in msg and "disc.svg" in msg
    assert hiding_warning(c, _copies(), "outline") is None
    assert hiding_warning(c, _copies(fill="#ffcc4d"), "as-drawn") is None


def _cli(args):
    from typer.testing import CliRunner

    from repulsionpak.cli import app

    return CliRunner().invoke(app, args)


def test_cli_option_config_and_warning(tmp_path):
    disc = tmp_path / "disc.svg"
    disc.write_text(DISC.format(fill="currentColor", stroke=""))
    el = tmp_path / "blob.svg"
    el.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 20 20"><path fill="currentColor" '
                  'd="M2 10 C2 2 18 2 18 10 C18 18 2 18 2 10 Z"/></svg>')
    base = ["pack", str(disc), str(el), "--count", "4", "--max-iterations", "150", "--seed", "1", "-q",
            "--no-pocket-fill"]
    with pytest.warns(UserWarning, match="--container-paint outline"):  # black on black
        r = _cli([*base, "-o", str(tmp_path / "a.svg"), "--png", str(tmp_path / "a.png"),
                  "--container-paint", "as-drawn"])
    assert r.exit_code == 0, r.output
    assert _group(tmp_path / "a.svg").find(f"{NS}circle") is not None
    img = _png_rgb(tmp_path / "a.png")
    h, w = img.shape[:2]
    assert img[h // 2 - 5:h // 2 + 5, w // 2 - 5:w // 2 + 5].max() < 15  # the PNG draws it as-drawn too
    cfg = tmp_path / "c.toml"
    cfg.write_text('[output]\ncontainer_paint = "none"\n')
    r = _cli([*base, "-o", str(tmp_path / "b.svg"), "--config", str(cfg), "--report", str(tmp_path / "b.json")])
    assert r.exit_code == 0, r.output
    assert [e.get("class") for e in _group(tmp_path / "b.svg")] == ["container-region"]
    import json

    assert json.loads((tmp_path / "b.json").read_text())["params"]["output"]["container_paint"] == "none"
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the default: the outline, no warning
        r = _cli([*base, "-o", str(tmp_path / "c.svg")])
    assert r.exit_code == 0, r.output
    assert [e.get("class") for e in _group(tmp_path / "c.svg")] == ["container-outline", "container-region"]
    r = _cli([*base, "-o", str(tmp_path / "d.svg"), "--container-paint", "filled"])
    assert r.exit_code == 3 and "--container-paint must be one of outline, as-drawn, none" in r.output


def test_live_scene_follows_the_choice(tmp_path):
    from repulsionpak.live.controller import LiveController

    c = _container(tmp_path, fill="#dd2e44")
    scene = LiveController(c, 4.0).scene()
    assert scene["paint"] == "outline" and scene["colour"] == outline_colour(c)
    assert scene["width"] == pytest.approx(outline_width(c, 4.0))
    drawn = LiveController(c, 4.0, container_paint="as-drawn").scene()
    group = ET.fromstring(drawn["markup"])
    assert group.get("id") == "container" and group.find("circle").get("fill") == "#dd2e44"
    assert LiveController(c, 4.0, container_paint="none").scene()["paint"] == "none"


def test_batch_thumbnail_follows_the_choice(tmp_path):
    """The contact sheet's tiles are png_bytes of each packing with its container paint."""
    from repulsionpak.render.png import png_bytes

    c = _container(tmp_path)
    a = _png_rgb(png_bytes(c, _copies(fill="#1b998b"), size_px=100, container_paint="as-drawn", gap=4.0))
    b = _png_rgb(png_bytes(c, _copies(fill="#1b998b"), size_px=100, gap=4.0))
    assert a[20, 50].max() < 15 and b[20, 50].min() > 240
    region = shapely.Point(100, 100).buffer(90)
    assert region.area == pytest.approx(c.area, rel=1e-3)
