"""The example data shipped in ``repulsionpak/examples`` is present, valid and has the
topology each file is meant to exercise (holes, several regions, open strokes ...).

The geometry here is computed independently of the package's own SVG reader, with
svgelements + shapely, so that these tests check the data rather than the reader.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import shapely
import svgelements as se
from shapely.geometry import Point, Polygon
from shapely.ops import unary_union

from repulsionpak import examples
from repulsionpak.errors import ParameterError

SVG_NS = "{http://www.w3.org/2000/svg}"


def all_files() -> list[Path]:
    return examples.element_files() + examples.secondary_files() + examples.container_files()


# --------------------------------------------------------------------------- helpers


def _subpaths(shape: se.Shape) -> list[tuple[np.ndarray, bool]]:
    """Flattened subpaths of one shape, transforms applied: [(points (K, 2), closed)]."""
    path = se.Path(shape)
    path.reify()
    out = []
    for sub in path.as_subpaths():
        pts: list[tuple[float, float]] = []
        closed = False
        for seg in se.Path(sub):
            if isinstance(seg, se.Move):
                pts.append((seg.end.x, seg.end.y))
            elif isinstance(seg, se.Close):
                closed = True
            elif isinstance(seg, se.Line):
                pts.append((seg.end.x, seg.end.y))
            else:
                pts.extend(map(tuple, seg.npoint(np.linspace(0, 1, 33)[1:])))
        if len(pts) >= 2:
            out.append((np.asarray(pts, dtype=float), closed))
    return out


def _shapes(path: Path) -> list[se.Shape]:
    svg = se.SVG.parse(str(path))
    return [e for e in svg.elements() if isinstance(e, se.Shape)]


def _painted(color) -> bool:
    return color is not None and color.value is not None


def _region(shape: se.Shape) -> shapely.Geometry:
    """The area enclosed by a shape's closed subpaths, honouring fill-rule."""
    polys = [Polygon(p).buffer(0) for p, _ in _subpaths(shape) if len(p) >= 3]
    if shape.values.get("fill-rule", "nonzero") == "evenodd":
        geom = Polygon()
        for poly in polys:
            geom = geom.symmetric_difference(poly)
        return geom
    return unary_union(polys)


def container_region(path: Path) -> shapely.Geometry:
    return unary_union([_region(s) for s in _shapes(path)])


def filled_union(path: Path) -> shapely.Geometry:
    return unary_union([_region(s) for s in _shapes(path) if _painted(s.fill)])


def _parts(geom: shapely.Geometry) -> list[Polygon]:
    return [g for g in getattr(geom, "geoms", [geom]) if not g.is_empty]


# --------------------------------------------------------------------------- inventory


def test_counts():
    assert len(examples.element_files()) >= 8
    assert len(examples.secondary_files()) >= 2
    assert len(examples.container_files()) >= 3


def test_required_files_present():
    names = {p.name for p in examples.element_files()}
    for required in ["lizard.svg", "octopus.svg", "rabbit.svg", "fish.svg", "donut.svg",
                     "leaf.svg", "exclamation.svg", "snake.svg"]:
        assert required in names
    assert {"dot.svg", "star.svg"} <= {p.name for p in examples.secondary_files()}
    assert {"circle.svg", "frame.svg", "two_hearts.svg", "cloud.svg", "heart.svg"} <= set(
        p.name for p in examples.container_files()
    )


def test_helpers_and_defaults():
    assert examples.examples_dir().is_dir()
    default = examples.container_file()
    assert default.is_file() and default.stem == examples.DEFAULT_CONTAINER
    assert examples.container_file("frame.svg") == examples.container_file("frame")
    assert examples.DEFAULT_CONTAINER in examples.container_names()
    with pytest.raises(ParameterError, match="available"):
        examples.container_file("no-such-container")
    # the default gap is about 1 % of the default container's size
    minx, miny, maxx, maxy = container_region(default).bounds
    size = max(maxx - minx, maxy - miny)
    assert 0.003 * size <= examples.DEFAULT_GAP <= 0.03 * size


# --------------------------------------------------------------------------- every file


@pytest.mark.parametrize("path", all_files(), ids=lambda p: f"{p.parent.name}/{p.name}")
def test_is_svg_with_viewbox(path: Path):
    root = ET.parse(path).getroot()
    assert root.tag == f"{SVG_NS}svg"
    numbers = [float(v) for v in re.split(r"[\s,]+", root.get("viewBox", "").strip()) if v]
    assert len(numbers) == 4 and numbers[2] > 0 and numbers[3] > 0


@pytest.mark.parametrize(
    "path", examples.element_files() + examples.secondary_files(), ids=lambda p: p.name
)
def test_element_has_filled_area(path: Path):
    geom = filled_union(path)
    assert geom.is_valid and not geom.is_empty and geom.area > 0


@pytest.mark.parametrize("path", examples.container_files(), ids=lambda p: p.name)
def test_container_paths_closed_and_valid(path: Path):
    shapes = _shapes(path)
    assert shapes
    for shape in shapes:
        assert all(closed for _, closed in _subpaths(shape)), f"open subpath in {path.name}"
    region = container_region(path)
    assert region.is_valid and region.area > 0


# --------------------------------------------------------------------------- topology


def test_frame_container_has_a_hole():
    region = container_region(examples.container_file("frame"))
    parts = _parts(region)
    assert len(parts) == 1
    assert len(parts[0].interiors) >= 1


def test_two_hearts_container_has_two_regions():
    region = container_region(examples.container_file("two_hearts"))
    assert region.geom_type == "MultiPolygon"
    assert len(region.geoms) == 2


def test_circle_container_is_convex():
    region = container_region(examples.container_file("circle"))
    assert region.area / region.convex_hull.area > 0.999


def test_cloud_container_is_concave_and_in_physical_units():
    path = examples.container_file("cloud")
    root = ET.parse(path).getroot()
    assert root.get("width", "").endswith("mm") and root.get("height", "").endswith("mm")
    region = container_region(path)
    assert region.area / region.convex_hull.area < 0.98


def _element(name: str) -> Path:
    return examples.examples_dir() / "elements" / f"{name}.svg"


def test_exclamation_element_is_in_several_parts():
    assert len(_parts(filled_union(_element("exclamation")))) >= 2


def test_donut_element_has_a_hole():
    parts = _parts(filled_union(_element("donut")))
    assert len(parts) == 1 and len(parts[0].interiors) >= 1


def test_leaf_element_has_open_stroked_lines():
    open_strokes = [
        s
        for s in _shapes(_element("leaf"))
        if _painted(s.stroke)
        and not _painted(s.fill)
        and any(not closed for _, closed in _subpaths(s))
    ]
    assert open_strokes
    # the stem sticks out of the blade
    blade = filled_union(_element("leaf"))
    stem_ends = [Point(p[0]) for s in open_strokes for p, _ in _subpaths(s)]
    assert any(not blade.buffer(1.0).contains(pt) for pt in stem_ends)


def test_elements_vary_in_size():
    def extent(name: str) -> float:
        minx, miny, maxx, maxy = filled_union(_element(name)).bounds
        return max(maxx - minx, maxy - miny)

    assert 90 <= extent("fish") <= 110
    assert extent("mouse") < 0.7 * extent("fish")
    assert extent("snake") > 1.2 * extent("fish")


def test_default_gap_follows_the_width_of_long_thin_containers():
    from repulsionpak.io import load_container
    from repulsionpak.inputs import default_gap
    from repulsionpak.types import Container

    # the examples keep 1 % of their larger side
    for path in examples.container_files():
        c = load_container(path)
        minx, miny, maxx, maxy = c.bounds
        assert default_gap(c) == pytest.approx(0.01 * max(maxx - minx, maxy - miny), rel=1e-3)
    # a 20:1 strip 100 high: 1 % of its length would be a fifth of its height (3
    # elements fitted); the gap is 4 % of its height instead
    strip = Container(source="strip", region=shapely.box(0, 0, 2000, 100))
    assert default_gap(strip) == pytest.approx(4.0, rel=1e-3)
    # a thin ring 30 wide and 1000 across: 1.2, not 10
    ring = Container(source="ring", region=Point(0, 0).buffer(500, 256).difference(Point(0, 0).buffer(470, 256)))
    assert default_gap(ring) == pytest.approx(1.2, rel=1e-2)


def test_default_gap_leaves_room_for_the_count_asked():
    import dataclasses

    from repulsionpak.inputs import default_gap
    from repulsionpak.params import Params
    from repulsionpak.placement import estimate_count
    from repulsionpak.types import Container

    poster = Container(source="poster", region=shapely.box(0, 0, 1000, 1500))
    placement = Params().placement
    assert default_gap(poster) == pytest.approx(15.0)
    assert default_gap(poster, placement) == pytest.approx(15.0)  # no count: as before
    many = dataclasses.replace(placement, count=1000)
    g = default_gap(poster, many)
    # 1,000 elements element_size gaps across fill the poster's area
    assert g == pytest.approx((1000 * 1500 / 1000) ** 0.5 / placement.element_size, rel=1e-3)
    free = dataclasses.replace(placement, count=None)
    assert estimate_count(poster.region.area, g, free) == 1000
    few = dataclasses.replace(placement, count=10)  # few elements: the 1 % gap stays
    assert default_gap(poster, few) == pytest.approx(15.0)
