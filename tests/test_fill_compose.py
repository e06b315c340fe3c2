"""The nonzero fill of many subpaths (a line of text) composed as few set operations:
the same region as composing them one by one, in far less time."""

import numpy as np
import shapely
from shapely.geometry import Polygon

from repulsionpak import art_area as outline
from repulsionpak.types import ArtPath, Style


def _square(x, y, s, ccw=True):
    pts = np.array([[x, y], [x + s, y], [x + s, y + s], [x, y + s]], float)
    return pts if ccw else pts[::-1].copy()


def _one_by_one(polys, order, fill):
    out = Polygon()
    for i in order:
        out = shapely.union(out, polys[i]) if fill[i] else shapely.difference(out, polys[i])
    return out


def test_glyph_like_subpaths_compose_to_the_same_region(monkeypatch):
    """Rows of 'glyphs': an outer contour, a counter (opposite orientation), an island in
    the counter, and contours that overlap their neighbours'; the levelled composition
    gives exactly the region of the one-by-one composition."""
    rng = np.random.default_rng(3)
    subs = []
    for k in range(40):
        x, y = 12.0 * (k % 10) + rng.uniform(0, 3), 15.0 * (k // 10)
        subs += [_square(x, y, 11), _square(x + 3, y + 3, 5, ccw=False), _square(x + 4.5, y + 4.5, 2)]
    subs.append(_square(-5, -5, 200, ccw=False))  # a frame drawn around all of them, reversed
    subs.append(_square(50, 20, 30))  # a blob across several glyphs
    path = ArtPath(tuple(subs), (True,) * len(subs), Style(fill="#000"))
    fast = outline._fill_geometry(path)
    monkeypatch.setattr(outline, "_compose", _one_by_one)
    slow = outline._fill_geometry(path)
    assert fast.area > 0
    assert shapely.symmetric_difference(fast, slow).area <= 1e-9 * slow.area
