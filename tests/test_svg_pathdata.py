"""Path data and polygon points are read as browsers draw them: up to their first error (SVG 2,
path data error handling), with a warning that says where and what the error is."""

from __future__ import annotations

import math
import warnings

import pytest

from repulsionpak.errors import InputError
from repulsionpak.io import load_element
from repulsionpak.io.svg_pathdata import path_data_error
from repulsionpak.preprocess import outline_of

SQUARE = "M0,0 L50,0 L50,50 L0,50 Z"


@pytest.mark.parametrize("d", [
    "", "  ", SQUARE, "m0 0l50-0 0 50-50 0z", "M0,0L50,0,50,50,0,50z", "M.5.5L50.5.5 50 50 0 50Z",
    "M0 0 a25 25 0 0150 0 v50 h-50z",  # flags written without separators
    "M1e2,0 L-1.5E+1 .2e-1 H 3 V4 C1 2 3 4 5 6 S1 2 3 4 Q1 2 3 4 T5 6 z M1 1",
    "M 0 0 L, 10 10, M 5 5",  # commas where browsers accept them
])
def test_valid_path_data(d):
    assert path_data_error(d) is None


@pytest.mark.parametrize("d, valid, reason", [
    ("L0,0 L50,0 L50,50 Z", "", "must start with a move-to"),
    ("M0,0 L50,0 L50,50 20 L0,50 Z", "M0,0 L50,0 L50,50 ", "L takes 2 numbers"),
    ("M0,0 L50,0 A5,5 0 0 1 50,50 20,20 L0,50 Z", "M0,0 L50,0 A5,5 0 0 1 50,50 ", "an arc (A) takes 7"),
    ("M0,0 L50,0 A5,5 0 2 1 50,50 L0,50 Z", "M0,0 L50,0 ", "each flag 0 or 1"),
    ("M0 0 C 10 10 20 20 30 30 40 40 Z", "M0 0 C 10 10 20 20 30 30 ", "C takes 6 numbers"),
    ("M0,0 L50,0 L50,50 Z 5", "M0,0 L50,0 L50,50 Z ", "'5' is not a path command"),
    ("M1e2 0 L 50 1e L0 50Z", "M1e2 0 L 50 1", "'e' is not a path command"),
    ("M0,0 L50,0 NaN", "M0,0 L50,0 ", "'N' is not a path command"),
])
def test_first_error_and_what_is_drawn(d, valid, reason):
    err = path_data_error(d)
    assert err is not None
    assert d[: err.valid] == valid
    assert err.at >= err.valid
    assert reason in err.reason


def _element(tmp_path, d):
    p = tmp_path / "e.svg"
    p.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 200 100"><path d="{d}"/></svg>')
    return p


def test_element_is_read_up_to_the_error(tmp_path):
    # a square, then a second subpath whose arc has a flag 2: a browser draws the square only
    # (svgelements alone read the arc anyway and added ~880 units² of it)
    p = _element(tmp_path, SQUARE + " M60,0 L110,0 A5,5 0 2 1 110,50 L60,50 Z")
    with pytest.warns(UserWarning, match=r"e\.svg: <path> d=\.\.\. has invalid data near 'A5,5 0 2 1"):
        el = load_element(p)
    assert outline_of(el).geometry.area == pytest.approx(2500.0)


def test_arc_with_extra_numbers_draws_its_first_segment(tmp_path):
    p = _element(tmp_path, "M0,0 L50,0 A5,5 0 0 1 50,50 20,20 L0,50 Z")
    with pytest.warns(UserWarning, match="takes 7 values"):
        el = load_element(p)
    # the triangle (0,0) (50,0) (50,50) and the half disc the arc bulges (radius scaled to 25)
    assert outline_of(el).geometry.area == pytest.approx(1250 + math.pi * 25**2 / 2, rel=5e-3)


def test_no_move_to_draws_nothing(tmp_path):
    with pytest.warns(UserWarning, match="must start with a move-to"), pytest.raises(InputError, match="e.svg"):
        load_element(_element(tmp_path, "L0,0 L50,0 L50,50 Z"))


def test_one_warning_for_many_bad_shapes(tmp_path):
    p = tmp_path / "m.svg"
    p.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
                 '<path d="M0,0 L50,0 L50,50 20"/><path d="M0,60 L50,60 L50,90 9"/>'
                 '<path d="M60,60 L90,60 L90,90 9"/></svg>')
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        load_element(p)
    msgs = [str(x.message) for x in w if "invalid data" in str(x.message)]
    assert len(msgs) == 1 and "(and 2 more shapes)" in msgs[0]


@pytest.mark.parametrize("points, area, warns", [
    ("1e1,0 50.5.5 50,50", 1002.5, None),  # "50.5.5" is 50.5 and .5 (svgelements read one number)
    ("-5-5 50-5 50,50", 1512.5, None),
    ("0,0 50,0 50,50 0", 1250.0, "an odd number of coordinates"),  # the last number is ignored
    ("0 0 50 0 50 50 x 0 50", 1250.0, "has invalid data near"),  # drawn up to the error
])
def test_polygon_points_read_as_browsers_do(tmp_path, points, area, warns):
    p = tmp_path / "p.svg"
    p.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100"><polygon points="{points}"/></svg>')
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        el = load_element(p)
    msgs = [str(x.message) for x in w if "points=" in str(x.message)]
    assert (warns is None and not msgs) or (warns is not None and len(msgs) == 1 and warns in msgs[0])
    assert outline_of(el).geometry.area == pytest.approx(area)
