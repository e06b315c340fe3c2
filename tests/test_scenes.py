"""Tests of benchmarks/scenes.py: the generated SVGs read back as the shapes they claim
(areas, holes, regions, scale) and the suite spans issue 10's matrix."""

from __future__ import annotations

import math

import pytest
import shapely

import scenes
from repulsionpak.errors import ParameterError
from repulsionpak.art_area import art_area
from repulsionpak.io import load_container, load_element


def _element_area(tmp_path, kind, scale=1.0):
    f = tmp_path / f"{kind}-{scale:g}.svg"
    f.write_text(scenes.element_svg(kind, scale=scale))
    e = load_element(f, tolerance=1e-4 * scale)
    return art_area(e.paths)


def _crescent_area(r=50.0):
    ri, d = 0.8 * r, 0.45 * r
    outer = shapely.Point(0, 0).buffer(r, quad_segs=512)
    inner = shapely.Point(d, 0).buffer(ri, quad_segs=512)
    return outer.difference(inner).area


EXPECTED = {  # element kind -> (area at scale 1, holes)
    "square": (100.0**2, 0),
    "disc": (math.pi * 50**2, 0),
    "triangle": (3 * math.sqrt(3) / 4 * 50**2, 0),
    "hexagon": (3 * math.sqrt(3) / 2 * 50**2, 0),
    "star5": (5 * 50 * 20 * math.sin(math.pi / 5), 0),  # 10 triangles centre–tip–notch
    "star8": (8 * 50 * 22.5 * math.sin(math.pi / 8), 0),
    "bar": (100.0 * 20.0, 0),
    "cross": (2 * 100 * 28 - 28 * 28, 0),
    "crescent": (_crescent_area(), 0),
    "ring": (math.pi * (50**2 - 30**2), 1),
}


@pytest.mark.parametrize("kind", list(EXPECTED))
def test_plain_elements_read_back_exactly(tmp_path, kind):
    area, holes = EXPECTED[kind]
    g = _element_area(tmp_path, kind)
    assert g.geom_type == "Polygon" and len(g.interiors) == holes
    assert g.area == pytest.approx(area, rel=2e-3)
    assert scenes.element_category(kind) == scenes.ELEMENT_KINDS[kind]


@pytest.mark.parametrize("scale", [0.01, 100.0])
def test_scale_multiplies_every_coordinate(tmp_path, scale):
    for kind in ("ring", "star5", "glyph-g"):
        base = _element_area(tmp_path, kind)
        g = _element_area(tmp_path, kind, scale)
        assert g.area == pytest.approx(base.area * scale**2, rel=1e-3)
        assert g.bounds[2] == pytest.approx(base.bounds[2] * scale, rel=1e-3)
    f = tmp_path / "c.svg"
    f.write_text(scenes.container_svg("circle", scale=scale))
    c = load_container(f, tolerance=1e-4 * scale)
    assert c.area == pytest.approx(math.pi * (500 * scale) ** 2, rel=1e-3)


@pytest.mark.parametrize("char, holes", [("A", 1), ("B", 2), ("O", 1), ("R", 1), ("S", 0), ("g", 1), ("&", 1)])
def test_glyphs_are_compound_paths_with_counters(tmp_path, char, holes):
    g = _element_area(tmp_path, f"glyph-{char}")
    assert g.geom_type == "Polygon" and len(g.interiors) == holes
    # a glyph of font size 100 paints a few thousand square units
    assert 1000 < g.area < 4000
    # the file's viewBox holds the glyph (y down, box at the origin)
    assert g.bounds[0] >= -1e-9 and g.bounds[1] >= -1e-9
    assert scenes.element_category(f"glyph-{char}.svg") == "letter"


def test_glyph_rejects_non_characters():
    with pytest.raises(ParameterError):
        scenes.glyph_svg("AB")
    with pytest.raises(ParameterError):
        scenes.glyph_svg(" ")
    with pytest.raises(ParameterError):
        scenes.element_svg("blob")
    with pytest.raises(ParameterError):
        scenes.element_svg("square", scale=0.0)


@pytest.mark.parametrize("kind, area, parts, holes", [
    ("circle", math.pi * 500**2, 1, 0),
    ("square", 1000.0**2, 1, 0),
    ("star", 5 * 500 * 225 * math.sin(math.pi / 5) / math.sin(2 * math.pi / 5) ** 2, 1, 0),
    ("band", (240 / 360) * math.pi * (500**2 - 275**2), 1, 0),
    ("holed", 1000.0**2 - math.pi * 175**2, 1, 1),
    ("two", math.pi * 230**2 + 480 * 460, 2, 0),
    # holdout containers
    ("triangle", math.sqrt(3) / 4 * 1000.0**2, 1, 0),
    ("ellipse", math.pi * 500 * 250, 1, 0),
    ("annulus", math.pi * (500**2 - 225**2), 1, 1),
    ("ell", 1000.0**2 - 550.0**2, 1, 0),
    ("hexagon", 3 * math.sqrt(3) / 2 * 500**2, 1, 0),
])
def test_containers_read_back_exactly(tmp_path, kind, area, parts, holes):
    f = tmp_path / f"{kind}.svg"
    f.write_text(scenes.container_svg(kind))
    c = load_container(f, tolerance=0.01)
    polys = list(shapely.get_parts(c.region))
    assert len(polys) == parts and sum(len(p.interiors) for p in polys) == holes
    assert c.area == pytest.approx(area, rel=1e-3)
    assert max(c.bounds[2] - c.bounds[0], c.bounds[3] - c.bounds[1]) == pytest.approx(1000.0, rel=1e-3)
    assert c.bounds[0] >= -1e-6 and c.bounds[1] >= -1e-6


def test_suite_spans_the_matrix():
    suite = scenes.suite()
    assert len(suite) >= 24 and len({s.name for s in suite}) == len(suite)
    assert {s.container for s in suite} == {"circle", "square", "star", "band", "holed", "two"}
    tags = {t for s in suite for t in s.tags}
    assert {"convex", "spiky", "thin", "holed", "letter"} <= tags
    assert min(s.gap for s in suite) == 0.005 and max(s.gap for s in suite) == 0.03
    assert min(s.scale for s in suite) == 0.01 and max(s.scale for s in suite) == 100.0
    assert min(s.count for s in suite) == 5 and max(s.count for s in suite) == 300
    for cat in ("convex", "spiky", "thin", "holed", "letter"):  # each category in >= 3 containers
        assert len({s.container for s in suite if cat in s.tags}) >= 3, cat
    fast = scenes.fast_suite()
    assert 3 <= len(fast) <= 4 and all(s.count <= 12 for s in fast)
    assert not {s.name for s in fast} & {s.name for s in suite}


def test_scene_writes_files_and_knows_its_gap(tmp_path):
    sc = scenes.Scene("t", "holed", ("ring", "glyph-A", "ring"), gap=0.02, count=5, scale=10.0)
    assert sc.tags == ("holed", "letter") and sc.category == "mixed"
    files = sc.write(tmp_path)
    assert files.gap == pytest.approx(200.0) and sc.size == 10000.0
    assert [p.name for p in files.elements] == ["ring.svg", "glyph-A.svg"]
    assert files.categories() == {"ring.svg": "holed", "glyph-A.svg": "letter"}
    c = load_container(files.container)
    assert c.bounds[2] == pytest.approx(10000.0)
    with pytest.raises(ParameterError):
        scenes.write_suite([sc, sc], tmp_path)


@pytest.mark.parametrize("kw", [dict(container="blob"), dict(elements=()), dict(gap=0.0),
                                dict(count=0), dict(scale=-1.0), dict(name="a b"), dict(elements=("blob",))])
def test_scene_validates(kw):
    args = dict(name="x", container="circle", elements=("square",))
    args.update(kw)
    with pytest.raises(ParameterError):
        scenes.Scene(**args)


# --------------------------------------------------------------------------- holdout suite

HOLDOUT_EXPECTED = {  # element kind -> (category, area at scale 1 or None, holes)
    "heart": ("spiky", None, 0),
    "bean": ("spiky", None, 0),
    "gear": ("spiky", None, 0),
    "arrow": ("thin", 65 * 16 + 0.5 * 50 * 35, 0),
    "ell": ("thin", 100 * 25 + 75 * 25, 0),
    "keyhole": ("thin", None, 0),
    "thinring": ("holed", math.pi * (50**2 - 42.5**2), 1),
    "pentagon": ("convex", 2.5 * 50**2 * math.sin(2 * math.pi / 5), 0),
    "ellipse": ("convex", math.pi * 50 * 50 / 3, 0),
}


@pytest.mark.parametrize("kind", list(HOLDOUT_EXPECTED))
def test_holdout_elements_have_their_category_and_area(tmp_path, kind):
    cat, area, holes = HOLDOUT_EXPECTED[kind]
    assert scenes.element_category(f"{kind}.svg") == cat
    g = _element_area(tmp_path, kind)
    assert g.geom_type == "Polygon" and len(g.interiors) == holes
    minx, miny, maxx, maxy = g.bounds
    assert max(maxx - minx, maxy - miny) == pytest.approx(100.0, abs=6.0) and min(minx, miny) > -1e-6
    if area is not None:
        assert g.area == pytest.approx(area, rel=2e-3)
    else:  # a concave / necked shape: well inside its box, but not a sliver
        assert 0.35 * (maxx - minx) * (maxy - miny) < g.area < 0.85 * (maxx - minx) * (maxy - miny)
        assert g.convex_hull.area > 1.03 * g.area  # genuinely non-convex (heart: 1.036)


def test_glyph_container_is_a_big_letter(tmp_path):
    f = tmp_path / "glyph.svg"
    f.write_text(scenes.container_svg("glyph", scale=0.1))
    c = load_container(f, tolerance=0.001)
    (poly,) = shapely.get_parts(c.region)  # 'C': one region, no hole
    assert len(poly.interiors) == 0
    assert max(c.bounds[2] - c.bounds[0], c.bounds[3] - c.bounds[1]) == pytest.approx(100.0, rel=1e-3)
    assert 0.15 * 100.0**2 < c.area < 0.4 * 100.0**2  # a stroke, not a box
    assert poly.convex_hull.area > 2 * poly.area


def test_holdout_suite_is_new_and_writes_valid_files(tmp_path):
    hold, main = scenes.holdout_suite(), scenes.suite() + scenes.fast_suite()
    assert 18 <= len(hold) <= 28 and len({s.name for s in hold}) == len(hold)
    assert not {s.name for s in hold} & {s.name for s in main}
    assert not {s.seed for s in hold} & {s.seed for s in main} and min(s.seed for s in hold) >= 200
    main_glyphs = {e for s in main for e in s.elements if e.startswith("glyph-")}
    hold_glyphs = {e for s in hold for e in s.elements if e.startswith("glyph-")}
    assert len(hold_glyphs) >= 6 and not hold_glyphs & main_glyphs
    new_kinds = set(HOLDOUT_EXPECTED)
    assert new_kinds <= {e for s in hold for e in s.elements}
    assert {"triangle", "ellipse", "annulus", "ell", "glyph", "hexagon"} <= {s.container for s in hold}
    assert 0.005 <= min(s.gap for s in hold) and max(s.gap for s in hold) <= 0.03
    assert min(s.scale for s in hold) == 0.01 and max(s.scale for s in hold) == 100.0
    assert all(5 <= s.count <= 200 for s in hold) and sum(s.count > 100 for s in hold) <= 2
    assert sum(s.count <= 60 for s in hold) >= len(hold) - 2
    for files in scenes.write_suite(hold, tmp_path):
        sc = files.scene
        c = load_container(files.container, tolerance=files.gap / 50)
        assert max(c.bounds[2] - c.bounds[0], c.bounds[3] - c.bounds[1]) == pytest.approx(sc.size, rel=1e-3)
        assert files.gap == pytest.approx(sc.gap * sc.size, rel=1e-5)
        for e in files.elements:
            g = art_area(load_element(e, tolerance=1e-3 * sc.scale).paths)
            assert g.area > 500 * sc.scale**2, e.name  # drawn about 100 x scale units across
        assert set(files.categories().values()) == set(sc.tags)


def test_contract_holdout_never_writes_docs(capsys):
    import importlib.util
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    spec = importlib.util.spec_from_file_location("contract_bench", root / "benchmarks" / "contract.py")
    contract = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(contract)
    with pytest.raises(SystemExit):  # refused before anything is packed
        contract.main(["--suite", "holdout", "--out-dir", str(root / "docs"), "--only", "ho-mixed-ellipse-5"])
    assert "never writes docs" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # nor do other seeds
        contract.main(["--reseed", "1000", "--out-dir", str(root / "docs"), "--only", "fast-convex"])
    assert "nor does --reseed" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        contract.main(["--suite", "holdout", "--only", "no-such-scene"])
