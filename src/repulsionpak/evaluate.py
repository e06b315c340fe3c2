"""Quality metrics of a finished packing (paper sec. 11) and their plots.

Everything here is a pure function of geometry (numpy arrays / shapely geometries in,
plain ``dict``/``list``/``float`` out, JSON-serialisable); only :func:`evaluate_file`
reads a file (through :func:`repulsionpak.io.read_packing_svg`) and only the plot
functions write one.

Metrics
-------
* :func:`art_geometry` – the area one placed element's art actually paints (fills with
  their fill rule, plus strokes buffered by half the scaled stroke width).
* :func:`area_fraction`, :func:`overlap_area`, :func:`outside`, :func:`gap_statistics`.
* From :mod:`repulsionpak.metrics` (issue 10, art only): the exact area outside the
  container, each element's distance to the container's edge and its distortion from
  its source (when the sources are given).
* :func:`scp` – the spherical contact probability Q_s(r): the probability that a disc of
  radius r centred at a uniformly random point of the container lies entirely in the
  negative space (inside the container, outside every element's art), and
  H_s(r) = 1 − Q_s(r)/Q_s(0). Q_s(0) = 1 − A (A = area fraction).

SCP discretisation
------------------
The container and the union of the art are rasterised by *pixel-centre sampling* (an
exact scanline rasteriser, no anti-aliasing) on a grid whose longer side has ``grid``
pixels over the container's bounds, plus a margin of ``margin`` pixels. The negative
space is ``container & ~art``. An exact Euclidean distance transform
(:func:`repulsionpak.geometry.edt.distance_transform`, tested against
``scipy.ndimage.distance_transform_edt``; spacing = pixel size) gives, for each negative pixel, the distance D to the nearest
non-negative pixel *centre*. For an axis-aligned boundary, the pixel whose centre is at
D = k·h covers exactly the true boundary distances [(k−1)·h, k·h]; the default
``estimator="interval"`` therefore lets each negative pixel contribute the fraction of
that interval that is ≥ r::

    Q_s(r) = Σ_neg clip((D − r)/h, 0, 1) / N_container

i.e. the piecewise-linear interpolation between the staircase values at the pixels'
mean distance D − h/2. This is exact for grid-aligned stripes (the paper's Fig. 9a
reference) and unbiased to well under 1 % of Q_s(0) for other shapes (tests compare it
against :func:`scp_vector`, the exact polygon-offset computation).
``estimator="centre"`` is the step function ``[D − h/2 ≥ r]`` (error up to one pixel
per gap, i.e. 1/(gap in pixels) of Q_s(0)), ``estimator="raw"`` the paper's naive
``[D ≥ r]`` (biased by half a pixel).
"""

from __future__ import annotations

import math
import numbers
import os
from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np
import shapely
from shapely.geometry import Polygon, box

from . import metrics as _metrics
from .blas import with_one_blas_thread
from .errors import ParameterError
from .geometry.edt import distance_transform
from .geometry.outline import _polygonal
from .geometry.robust import overlay
from .geometry.robust import union_all as robust_union_all
from .types import Container, PlacedArt

__all__ = [
    "art_geometry",
    "area_fraction",
    "overlap_area",
    "outside",
    "gap_statistics",
    "rasterize",
    "scp",
    "scp_vector",
    "default_r_grid",
    "ideal_stripes_q",
    "evaluate",
    "evaluate_file",
    "format_table",
    "plot_scp",
    "plot_scp_bands",
    "stripes_reference",
    "square_grid_reference",
    "perturbed_squares_reference",
    "equivalent_stripe_width",
]

_CAP = {"butt": "flat", "round": "round", "square": "square"}
_JOIN = {"miter": "mitre", "miter-clip": "mitre", "arcs": "round", "round": "round", "bevel": "bevel"}
_SVG_MITER_LIMIT = 4.0  # SVG's default stroke-miterlimit (Style does not carry one)


# --------------------------------------------------------------------------- geometry


def art_geometry(placed: PlacedArt) -> shapely.Geometry:
    """The area covered by the art of one placed element (see
    :func:`repulsionpak.geometry.outline.art_area`; strokes scaled by ``stroke_scale``)."""
    return placed.art


def _as_geoms(art_geoms: Iterable) -> list:
    return [_polygonal(g) for g in art_geoms]


def _union(geoms: Sequence) -> shapely.Geometry:
    geoms = [g for g in geoms if g is not None and not g.is_empty]
    if not geoms:
        return Polygon()
    return _polygonal(robust_union_all(geoms))


def _clusters(geoms: np.ndarray) -> list[np.ndarray]:
    """Indices of ``geoms`` grouped into connected clusters of intersecting geometries."""
    n = len(geoms)
    parent = np.arange(n)

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    i, j = shapely.STRtree(geoms).query(geoms, predicate="intersects")
    for a, b in zip(i[i < j].tolist(), j[i < j].tolist()):
        ra, rb = root(a), root(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    roots = np.array([root(k) for k in range(n)], dtype=np.int64)
    order = np.argsort(roots, kind="stable")
    return np.split(order, np.flatnonzero(np.diff(roots[order])) + 1)


def area_fraction(container_region, art_geoms) -> float:
    """Area of (union of the art ∩ container) / container area (overlaps counted once).

    The union is taken within each cluster of intersecting elements only (a packing's
    elements are a gap apart: nearly all clusters are single elements), and the areas of
    the clusters inside the container summed: one union of every element's art (a
    hundred dots each: 27,000 polygons for 267 copies, 4 s; 386,000 for a thousand dots)
    nodes all of it together for nothing. The value is the same up to rounding (the
    sum's order)."""
    region = _polygonal(container_region)
    if region.area <= 0:
        raise ParameterError("the container has no area")
    geoms = np.array([g for g in _as_geoms(art_geoms) if g is not None and not g.is_empty], dtype=object)
    if not len(geoms):
        return 0.0
    shapely.prepare(region)
    total = 0.0
    for members in _clusters(geoms):
        art = geoms[members[0]] if len(members) == 1 else _union(list(geoms[members]))
        if shapely.contains(region, art):
            total += float(art.area)
        else:
            total += float(overlay(shapely.intersection, art, region).area)
    return total / float(region.area)


def _pairs(geoms: list, predicate: str = "intersects", distance: float | None = None) -> np.ndarray:
    """Index pairs (i < j) of geometries satisfying ``predicate`` (STRtree)."""
    if len(geoms) < 2:
        return np.empty((0, 2), dtype=int)
    tree = shapely.STRtree(geoms)
    if predicate == "dwithin":
        idx = tree.query(geoms, predicate="dwithin", distance=distance)
    else:
        idx = tree.query(geoms, predicate=predicate)
    i, j = idx
    keep = i < j
    return np.stack([i[keep], j[keep]], axis=1)


def overlap_area(art_geoms) -> float:
    """Sum over element pairs of the area of their art's intersection (0 = no overlap)."""
    geoms = _as_geoms(art_geoms)
    pairs = _pairs(geoms)
    if len(pairs) == 0:
        return 0.0
    a = np.array(geoms, dtype=object)
    inter = overlay(shapely.intersection, a[pairs[:, 0]], a[pairs[:, 1]])
    return float(np.sum(shapely.area(inter)))


def outside(container_region, art_geoms, tol: float = 0.0) -> list[int]:
    """Indices of the elements whose art extends outside the container by more than ``tol``.

    ``tol`` is a *length*: element i is listed when some of its art (of non-negligible
    area, > 1e-9 of the container area) lies farther than ``tol`` outside the container,
    i.e. when ``art_i − buffer(container, tol)`` is not empty. ``tol = 0`` flags any
    art outside the container; art touching the boundary from inside is never flagged.
    """
    region = _polygonal(container_region)
    eps = 1e-9 * max(region.area, 1e-300)
    grown = region.buffer(tol, quad_segs=16) if tol > 0 else region
    shapely.prepare(grown)
    out = []
    for i, g in enumerate(_as_geoms(art_geoms)):
        if g.is_empty or shapely.contains(grown, g):
            continue
        if overlay(shapely.difference, g, grown).area > eps:
            out.append(i)
    return out


def _stats(values: Sequence[float]) -> dict:
    v = np.asarray([x for x in values if x is not None and np.isfinite(x)], dtype=float)
    if len(v) == 0:
        return {"median": None, "p10": None, "p90": None, "mean": None, "min": None, "max": None}
    return {
        "median": float(np.median(v)),
        "p10": float(np.percentile(v, 10)),
        "p90": float(np.percentile(v, 90)),
        "mean": float(np.mean(v)),
        "min": float(np.min(v)),
        "max": float(np.max(v)),
    }


def _nearest_distances(geoms: np.ndarray) -> np.ndarray:
    """Distance from each of ``geoms`` (non-empty) to the nearest other one (0 when they
    touch or overlap; exact duplicates count as touching).

    Exact, by rounds of growing radius R: the pairs within R (an STRtree ``dwithin``
    query) settle every geometry that has one, since its nearest is then among them;
    the others go on with 2R. ``STRtree.query_nearest`` gives the same values but,
    among packed shapes whose bounding boxes all overlap their neighbours', measures
    many more pairs (the heart's 176 copies: 1.1 s against 0.2–0.4 s)."""
    n = len(geoms)
    dist = np.full(n, np.inf)
    tree = shapely.STRtree(geoms)
    size = np.sqrt(np.median(shapely.area(shapely.envelope(geoms))))
    radius = max(size / 16.0, 1e-12)
    left = np.arange(n)
    while len(left):
        q, t = tree.query(geoms[left], predicate="dwithin", distance=radius)
        keep = left[q] != t
        q, t = q[keep], t[keep]
        if len(q):
            d = shapely.distance(geoms[left[q]], geoms[t])
            np.minimum.at(dist, left[q], d)
        left = left[~np.isfinite(dist[left])]
        if radius > 1e300:
            break
        radius *= 2.0
    return dist


def gap_statistics(art_geoms) -> dict:
    """Distance from each element's art to its nearest neighbour's art, and its statistics.

    Returns ``{"median", "p10", "p90", "mean", "min", "max", "values"}``; ``values[i]`` is
    element i's nearest-neighbour distance (0 when it touches or overlaps another,
    ``None`` for an element without art or when there is no other element). The
    statistics ignore ``None`` entries (and are ``None`` when nothing is left).
    """
    geoms = _as_geoms(art_geoms)
    n = len(geoms)
    values: list[float | None] = [None] * n
    ok = [i for i, g in enumerate(geoms) if not g.is_empty]
    if len(ok) >= 2:
        dist = _nearest_distances(np.array([geoms[i] for i in ok], dtype=object))
        for k, i in enumerate(ok):
            if np.isfinite(dist[k]):
                values[i] = float(dist[k])
    out = _stats(values)
    out["values"] = values
    return out


# --------------------------------------------------------------------------- raster


class _Grid:
    """A pixel grid: origin (x0, y0) of pixel (0, 0)'s corner, pixel size h, shape."""

    def __init__(self, bounds, grid: int, margin: int):
        minx, miny, maxx, maxy = (float(b) for b in bounds)
        ext = max(maxx - minx, maxy - miny)
        if not np.isfinite(ext) or ext <= 0:
            raise ParameterError("the container has an empty or degenerate extent")
        if grid < 8:
            raise ParameterError(f"grid must be at least 8 pixels, got {grid}")
        self.h = ext / int(grid)
        self.x0 = minx - margin * self.h
        self.y0 = miny - margin * self.h
        self.nx = int(math.ceil((maxx - minx) / self.h - 1e-9)) + 2 * margin
        self.ny = int(math.ceil((maxy - miny) / self.h - 1e-9)) + 2 * margin

    @property
    def shape(self) -> tuple[int, int]:
        return (self.ny, self.nx)


def _rings(geom) -> list[np.ndarray]:
    out = []
    for p in shapely.get_parts(_polygonal(geom)):
        if p.geom_type != "Polygon" or p.is_empty:
            continue
        out.append(np.asarray(p.exterior.coords)[:, :2])
        out.extend(np.asarray(r.coords)[:, :2] for r in p.interiors)
    return out


def _burn(mask: np.ndarray, geom, g: _Grid) -> None:
    """OR into ``mask`` the pixels whose centre lies inside ``geom`` (evenodd over rings).

    Scanline rasteriser: for every edge and every pixel row whose centre y lies in the
    edge's half-open y range, the crossing toggles the parity of all pixels whose
    centre x is >= the crossing; a cumulative sum along the rows turns toggles into
    coverage. Exact pixel-centre sampling, independent of Pillow's conventions.
    """
    rings = _rings(geom)
    if not rings:
        return
    x0s, y0s, x1s, y1s = [], [], [], []
    for r in rings:
        px = (r[:, 0] - g.x0) / g.h
        py = (r[:, 1] - g.y0) / g.h
        x0s.append(px[:-1])
        y0s.append(py[:-1])
        x1s.append(px[1:])
        y1s.append(py[1:])
    xa, ya, xb, yb = (np.concatenate(v) for v in (x0s, y0s, x1s, y1s))
    ylo = np.minimum(ya, yb)
    yhi = np.maximum(ya, yb)
    # rows k with centre k + 0.5 in [ylo, yhi)
    k0 = np.ceil(ylo - 0.5).astype(np.int64)
    k1 = np.ceil(yhi - 0.5).astype(np.int64)  # exclusive
    k0 = np.maximum(k0, 0)
    k1 = np.minimum(k1, g.ny)
    cnt = k1 - k0
    sel = cnt > 0
    if not np.any(sel):
        return
    xa, ya, xb, yb, k0, cnt = xa[sel], ya[sel], xb[sel], yb[sel], k0[sel], cnt[sel]
    e = np.repeat(np.arange(len(cnt)), cnt)
    start = np.repeat(np.cumsum(cnt) - cnt, cnt)
    rows = k0[e] + (np.arange(len(e)) - start)
    yc = rows + 0.5
    t = (yc - ya[e]) / (yb[e] - ya[e])
    xc = xa[e] + t * (xb[e] - xa[e])
    cols = np.ceil(xc - 0.5)
    cols = np.clip(cols, 0, g.nx).astype(np.int64)
    r0, r1 = int(rows.min()), int(rows.max()) + 1
    c0, c1 = int(cols.min()), int(cols.max()) + 1
    acc = np.zeros((r1 - r0, c1 - c0 + 1), dtype=np.int32)
    np.add.at(acc, (rows - r0, cols - c0), 1)
    cov = (np.cumsum(acc, axis=1) & 1).astype(bool)[:, : c1 - c0]
    c1c = min(c1, g.nx)
    mask[r0:r1, c0:c1c] |= cov[:, : c1c - c0]


def rasterize(geoms, bounds, grid: int = 1000, margin: int = 2) -> tuple[np.ndarray, dict]:
    """Rasterise geometries by pixel-centre sampling on the grid :func:`scp` uses.

    Returns ``(mask, info)``: a boolean (rows, cols) array, row 0 at the smallest y, and
    ``{"pixel_size", "x0", "y0"}`` (pixel (i, j) has centre
    ``(x0 + (j + 0.5) * pixel_size, y0 + (i + 0.5) * pixel_size)``).
    """
    g = _Grid(bounds, grid, margin)
    mask = np.zeros(g.shape, dtype=bool)
    if isinstance(geoms, shapely.Geometry):
        geoms = [geoms]
    for geom in geoms:
        _burn(mask, geom, g)
    return mask, {"pixel_size": g.h, "x0": g.x0, "y0": g.y0}


def default_r_grid(r_max: float, gap: float | None = None, steps: int = 100) -> np.ndarray:
    """The r values of :func:`scp` by default.

    Without ``gap``: ``steps`` equal steps from 0 to ``r_max``. With ``gap``: the r grid
    extends to ``max(r_max, 1.5 * gap)`` with a step dividing gap/2, so gap/2 is one of
    its values exactly (at least 10 steps below gap/2, at most 2000 steps in all).
    """
    r_max = float(r_max) if r_max is not None and np.isfinite(r_max) else 0.0
    if gap is None:
        if r_max <= 0:
            return np.zeros(1)
        return np.linspace(0.0, r_max, steps + 1)
    gap = float(gap)
    if not gap > 0:
        raise ParameterError(f"gap must be positive, got {gap}")
    half = 0.5 * gap
    top = max(r_max, 1.5 * gap)
    n_half = max(10, int(round(steps * half / top)))
    step = half / n_half
    n = min(int(math.ceil(top / step - 1e-9)), 2000)
    n = max(n, int(math.ceil(1.5 * gap / step - 1e-9)))
    r = np.arange(n + 1, dtype=float) * step
    r[n_half] = half
    return r


def _q_values(d: np.ndarray, h: float, r: np.ndarray, n_cont: int, estimator: str) -> np.ndarray:
    """Q_s at each r from the negative pixels' EDT values ``d`` (see module docstring)."""
    r = np.asarray(r, dtype=float)
    if n_cont == 0:
        return np.zeros_like(r)
    d = np.sort(d.ravel())
    n = len(d)
    if estimator == "raw":
        return (n - np.searchsorted(d, r, side="left")) / n_cont
    if estimator == "centre":
        return (n - np.searchsorted(d - 0.5 * h, r, side="left")) / n_cont
    if estimator != "interval":
        raise ParameterError(f"unknown SCP estimator {estimator!r} (interval, centre, raw)")
    # Σ clip((d - r)/h, 0, 1) = #{d >= r + h} + Σ_{r < d < r + h} (d - r)/h
    csum = np.concatenate([[0.0], np.cumsum(d)])
    lo = np.searchsorted(d, r, side="right")
    hi = np.searchsorted(d, r + h, side="left")
    full = n - hi
    part = (csum[hi] - csum[lo] - (hi - lo) * r) / h
    return (full + part) / n_cont


def scp(
    container_region,
    art_geoms,
    r: np.ndarray | None = None,
    grid: int = 1000,
    *,
    gap: float | None = None,
    r_max: float | None = None,
    margin: int = 2,
    estimator: str = "interval",
) -> dict:
    """Spherical contact probability Q_s(r) of a packing (paper sec. 11), by raster.

    ``container_region``: the container (shapely, holes allowed); ``art_geoms``: one
    polygonal geometry per element (e.g. from :func:`art_geometry`). The grid's longer
    side has ``grid`` pixels over the container's bounds (plus ``margin`` pixels of
    outside on each side). ``r``: the radii to evaluate (container units); by default
    :func:`default_r_grid` up to ``r_max`` (default: the largest distance in the
    negative space, where Q_s reaches 0), including gap/2 exactly when ``gap`` is given.
    See the module docstring for the ``estimator`` s.

    Returns ``{"r", "q", "h", "q0", "pixel_size", "shape"}``: lists of floats,
    ``h[i] = 1 − q[i]/q0`` (``None`` when q0 = 0).
    """
    region = _polygonal(container_region)
    if region.is_empty or region.area <= 0:
        raise ParameterError("the container has no area")
    g = _Grid(region.bounds, grid, margin)
    cont = np.zeros(g.shape, dtype=bool)
    _burn(cont, region, g)
    art = np.zeros(g.shape, dtype=bool)
    for geom in _as_geoms(art_geoms):
        if not geom.is_empty:
            _burn(art, geom, g)
    neg = cont & ~art
    n_cont = int(cont.sum())
    if n_cont == 0:
        raise ParameterError("the container is smaller than one pixel of the SCP grid; raise grid")
    if neg.any():
        dist = distance_transform(neg, g.h)
        d = dist[neg]
    else:
        d = np.zeros(0)
    if r is None:
        top = float(d.max()) if len(d) else 0.0
        if estimator == "centre":
            top -= 0.5 * g.h
        r = default_r_grid(top if r_max is None else r_max, gap)
    r = np.asarray(r, dtype=float).ravel()
    q = _q_values(d, g.h, r, n_cont, estimator)
    q0 = float(_q_values(d, g.h, np.zeros(1), n_cont, estimator)[0])
    h = [None if q0 <= 0 else float(1.0 - qi / q0) for qi in q]
    return {
        "r": [float(x) for x in r],
        "q": [float(x) for x in q],
        "h": h,
        "q0": q0,
        "pixel_size": float(g.h),
        "shape": [int(g.ny), int(g.nx)],
    }


def scp_vector(container_region, art_geoms, r, quad_segs: int = 32) -> dict:
    """Q_s(r) computed exactly with polygon offsets (slow; a reference for :func:`scp`).

    Q_s(r) = area(container eroded by r − union(art) dilated by r) / container area.
    """
    region = _polygonal(container_region)
    art = _union(_as_geoms(art_geoms))
    neg = overlay(shapely.difference, region, art)
    r = np.asarray(r, dtype=float).ravel()
    q = []
    for ri in r:
        if ri <= 0:
            q.append(neg.area / region.area)
            continue
        free = overlay(shapely.difference, region.buffer(-ri, quad_segs=quad_segs), art.buffer(ri, quad_segs=quad_segs))
        q.append(free.area / region.area)
    q0 = neg.area / region.area
    return {
        "r": [float(x) for x in r],
        "q": [float(x) for x in q],
        "h": [None if q0 <= 0 else float(1 - x / q0) for x in q],
        "q0": float(q0),
    }


def ideal_stripes_q(r, q0: float, gap: float) -> np.ndarray:
    """The ideal (stripes) SCP: the line from (0, q0) to (gap/2, 0), then 0."""
    r = np.asarray(r, dtype=float)
    return q0 * np.clip(1.0 - 2.0 * r / gap, 0.0, None)


# --------------------------------------------------------------------------- evaluate


def _q_at(res: dict, r0: float) -> float | None:
    r = np.asarray(res["r"], dtype=float)
    q = np.asarray(res["q"], dtype=float)
    if len(r) == 0:
        return None
    k = np.flatnonzero(np.isclose(r, r0, rtol=0, atol=1e-12 * max(1.0, abs(r0))))
    if len(k):
        return float(q[k[0]])
    return float(np.interp(r0, r, q))


@with_one_blas_thread
def evaluate(
    container: Container,
    placed: list[PlacedArt],
    gap: float,
    grid: int = 1000,
    *,
    outside_tol: float | None = None,
    with_scp: bool = True,
    sources=None,
    margin: float | None = None,
    workers: int = 1,
    primary_scp: bool | None = None,
) -> dict:
    """All metrics of a packing as a JSON-serialisable dict (as ``repulsionpak evaluate --json`` prints it).

    Keys: ``area_fraction``, ``overlap_area``, ``n_primary``, ``n_secondary``,
    ``n_elements``, ``n_outside`` / ``outside`` (elements whose art lies more than
    ``outside_tol`` outside the container, default 5 % of ``gap``; see :func:`outside`),
    ``gap`` {median, p10, p90, mean, min, max, requested, values},
    ``deformation`` {mean, max, values} (``None`` entries when unknown),
    ``scp`` {r, q, h, q0, pixel_size, shape} (r includes gap/2 exactly),
    ``scp_at_half_gap`` = Q_s(gap/2) and ``scp_ratio`` = Q_s(gap/2)/Q_s(0).
    With ``with_scp=False`` the three SCP entries are ``None`` (the raster and its
    distance transform are the slow part; ``pack`` reports do without them).

    What the primaries do alone (the pocket copies hide a loose packing from the
    measures above, which count every copy): ``area_fraction_primary`` (the primaries'
    art only), ``scp_ratio_primary`` = Q_s(gap/2)/Q_s(0) with only the primaries' art
    (``None`` without SCP; ``primary_scp`` True computes it even with ``with_scp=False``,
    default: as ``with_scp``), ``median_primary_size`` (the median primary's size, the
    square root of its art's area, container units; ``None`` without primaries) and
    ``smallest_secondary_rel``, the smallest secondary copy's size over it (``None``
    without primaries or secondaries).

    Issue 10's art-only measurements (:mod:`repulsionpak.metrics`):
    ``outside_area`` (art area outside the container, exact), ``edge`` {min, margin,
    n_below_margin, values}: each element's art distance to the container's boundary,
    and how many are closer than 0.98 × ``margin`` (default gap/2); ``distortion``
    {median, p95, max, values}: per element, area(best similar copy of its source △
    the placed art) / its area. ``sources`` gives the source art: a mapping
    ``data-source`` name → shapely geometry, or the library :class:`Element` s; without
    it (or for an unknown name) the distortion values are ``None``. A copy that carries its
    ``frame`` starts the fit from that rotation; ``workers`` threads fit several copies at
    once (the values do not depend on it).
    """
    if not isinstance(container, Container):
        raise ParameterError(f"evaluate(): the container must be a Container, got {type(container).__name__}")
    if hasattr(placed, "placed") and hasattr(placed, "gap"):  # a Packing
        raise ParameterError("evaluate(): give the packing's placed art, packing.placed, not the Packing")
    placed = list(placed) if hasattr(placed, "__iter__") and not isinstance(placed, (str, bytes)) else None
    if placed is None or not all(isinstance(p, PlacedArt) for p in placed):
        raise ParameterError("evaluate(): placed must be a list of PlacedArt (a packing's .placed, or "
                             "read_packing_svg(path)[1])")
    if isinstance(gap, bool) or not isinstance(gap, numbers.Real) or not np.isfinite(gap) or gap <= 0:
        raise ParameterError(f"gap must be a positive number, got {gap!r}")
    gap = float(gap)
    region = _polygonal(container.region)
    geoms = [art_geometry(p) for p in placed]
    af = area_fraction(region, geoms)
    tol = 0.05 * gap if outside_tol is None else float(outside_tol)
    out_idx = outside(region, geoms, tol)
    gs = gap_statistics(geoms)
    gs["requested"] = gap
    defs = [None if p.deformation is None else float(p.deformation) for p in placed]
    known = [d for d in defs if d is not None and np.isfinite(d)]
    edges = _metrics.edge_distances(region, geoms)
    margin = 0.5 * gap if margin is None else float(margin)
    if not (np.isfinite(margin) and margin >= 0):
        raise ParameterError(f"margin must be a non-negative number, got {margin!r}")
    known_edges = [e for e in edges if e is not None]
    if sources is not None and not isinstance(sources, dict):
        sources = _metrics.source_geometries(sources)
    dist = (_metrics.distortions(geoms, [p.source for p in placed], sources,
                                 angles=[_metrics.frame_angle(p.frame) for p in placed],
                                 workers=workers) if sources
            else [None] * len(placed))
    s = q_half = q0 = None
    if with_scp:
        s = scp(region, geoms, grid=grid, gap=gap)
        q_half = _q_at(s, 0.5 * gap)
        q0 = s["q"][0] if s["q"] else None
    alone = _primaries_alone(region, geoms, [p.kind for p in placed], gap, grid,
                             with_scp if primary_scp is None else primary_scp)
    return {
        "area_fraction": float(af),
        "overlap_area": overlap_area(geoms),
        "n_primary": sum(1 for p in placed if p.kind == "primary"),
        "n_secondary": sum(1 for p in placed if p.kind == "secondary"),
        "n_elements": len(placed),
        "n_outside": len(out_idx),
        "outside": out_idx,
        "outside_tol": tol,
        "container_area": float(region.area),
        "gap": gs,
        "deformation": {
            "mean": float(np.mean(known)) if known else None,
            "max": float(np.max(known)) if known else None,
            "values": defs,
        },
        "outside_area": _metrics.outside_area(region, geoms),
        "edge": {
            "min": min(known_edges) if known_edges else None,
            "margin": margin,
            "n_below_margin": sum(1 for e in known_edges if e < 0.98 * margin),
            "values": edges,
        },
        "distortion": _metrics.distortion_summary(dist, [p.kind for p in placed]),
        "scp": s,
        "scp_at_half_gap": q_half,
        "scp_ratio": (q_half / q0) if (q_half is not None and q0) else None,
        **alone,
    }


def _primaries_alone(region, geoms: list, kinds: list[str], gap: float, grid: int, with_scp: bool) -> dict:
    """The keys of :func:`evaluate` that measure the primaries without the pocket copies:
    ``area_fraction_primary``, ``scp_ratio_primary`` (None unless ``with_scp``),
    ``median_primary_size`` and ``smallest_secondary_rel`` (sizes: the square root of
    the art's area)."""
    prim = [g for g, k in zip(geoms, kinds) if k == "primary"]
    sizes = [float(np.sqrt(g.area)) for g in prim]
    sec = [float(np.sqrt(g.area)) for g, k in zip(geoms, kinds) if k != "primary"]
    median = float(np.median(sizes)) if sizes else None
    ratio = None
    if with_scp and prim:
        sp = scp(region, prim, grid=grid, gap=gap)
        q0 = sp["q"][0] if sp["q"] else None
        ratio = _q_at(sp, 0.5 * gap) / q0 if q0 else None
    return {
        "area_fraction_primary": float(area_fraction(region, prim)) if prim else 0.0,
        "scp_ratio_primary": ratio,
        "median_primary_size": median,
        "smallest_secondary_rel": (min(sec) / median) if (sec and median) else None,
    }


def _recorded_margin(info: dict | None) -> float | None:
    """The edge margin a packing was verified with, from its metadata (None if absent)."""
    meta = (info or {}).get("metadata")
    inv = meta.get("invariants") if isinstance(meta, dict) else None
    m = inv.get("margin") if isinstance(inv, dict) else None
    try:
        m = float(m)
    except (TypeError, ValueError):
        return None
    return m if math.isfinite(m) and m >= 0 else None


def evaluate_file(path: str | os.PathLike, gap: float | None = None, grid: int = 1000,
                  sources=None, workers: int = 1, margin: float | None = None) -> dict:
    """:func:`evaluate` of a packing SVG written by repulsionpak.

    The gap is ``gap`` if given, else the root's ``data-gap``; :class:`ParameterError`
    when neither is known. The edge margin is ``margin`` if given, else the one the
    packing was made with (its metadata's verification, when the file's own gap is
    used), else half the gap. ``sources``: the source element art for the distortion
    (see :func:`evaluate`), e.g. ``load_elements([...])``.
    """
    from .io import read_packing_svg  # local: io is written separately

    container, placed, meta = read_packing_svg(path)
    own_gap = gap is None
    if gap is None:
        meta = meta or {}
        for key in ("gap", "data-gap", "data_gap"):
            if meta.get(key) not in (None, ""):
                try:
                    gap = float(meta[key])
                except (TypeError, ValueError) as exc:
                    raise ParameterError(f"{path}: data-gap is not a number: {meta[key]!r}") from exc
                break
    if gap is None:
        raise ParameterError(f"{path}: the file has no data-gap; give the gap explicitly (--gap)")
    if margin is None and own_gap:
        margin = _recorded_margin(meta)
    result = evaluate(container, placed, gap, grid=grid, sources=sources, workers=workers, margin=margin)
    result["file"] = str(path)
    return result


# --------------------------------------------------------------------------- report


def _fmt(x: Any, nd: int = 4) -> str:
    if x is None:
        return "-"
    if isinstance(x, (int, np.integer)) and not isinstance(x, bool):
        return str(int(x))
    x = float(x)
    if x != 0 and (abs(x) >= 1e5 or abs(x) < 1e-3):
        return f"{x:.3e}"
    return f"{x:.{nd}f}"


def format_table(result: dict) -> str:
    """A short human-readable summary of an :func:`evaluate` result (aligned columns)."""
    g = result.get("gap") or {}
    d = result.get("deformation") or {}
    rows: list[tuple[str, str]] = []
    if "file" in result:
        rows.append(("file", str(result["file"])))
    rows += [
        ("elements", f"{result.get('n_primary', 0)} primary, {result.get('n_secondary', 0)} secondary"),
        ("area fraction", _fmt(result.get("area_fraction"))),
        ("overlap area", _fmt(result.get("overlap_area"))),
        ("outside container", _fmt(result.get("n_outside"))),
        ("gap requested", _fmt(g.get("requested"))),
        ("gap median", _fmt(g.get("median"))),
        ("gap p10 / p90", f"{_fmt(g.get('p10'))} / {_fmt(g.get('p90'))}"),
        ("gap min", _fmt(g.get("min"))),
        ("deformation mean / max", f"{_fmt(d.get('mean'))} / {_fmt(d.get('max'))}"),
    ]
    if "outside_area" in result:
        rows.append(("outside area", _fmt(result.get("outside_area"))))
    e = result.get("edge") or {}
    if e:
        rows.append(("edge distance min", _fmt(e.get("min"))))
        margin = e.get("margin")
        rows.append((f"closer than 0.98 × {_fmt(margin)} to edge" if margin is not None else "closer than the margin",
                     _fmt(e.get("n_below_margin"))))
    dd = result.get("distortion") or {}
    if dd.get("median") is not None:
        rows.append(("distortion median / p95", f"{_fmt(dd.get('median'))} / {_fmt(dd.get('p95'))}"))
        prim = (dd.get("by_kind") or {}).get("primary") or {}
        if prim.get("median") is not None and dd.get("by_kind", {}).get("secondary"):
            rows.append(("  primaries: median / p95 / max",
                         f"{_fmt(prim['median'])} / {_fmt(prim['p95'])} / {_fmt(prim['max'])}"))
    s = result.get("scp") or {}
    if s.get("q"):
        rows.append(("Q_s(0) = 1 - A (raster)", _fmt(s["q"][0])))
    if result.get("scp_at_half_gap") is not None:
        rows.append(("Q_s(gap/2)", _fmt(result["scp_at_half_gap"])))
    if result.get("scp_ratio") is not None:
        rows.append(("Q_s(gap/2) / Q_s(0)", _fmt(result["scp_ratio"])))
    if "area_fraction_primary" in result:
        rows.append(("primaries alone: area fraction", _fmt(result.get("area_fraction_primary"))))
        rows.append(("primaries alone: Q_s(gap/2) / Q_s(0)", _fmt(result.get("scp_ratio_primary"))))
        rows.append(("smallest secondary / median primary (√area)", _fmt(result.get("smallest_secondary_rel"))))
    gap = g.get("requested")
    if gap and s.get("r"):
        for f in (0.25, 0.75, 1.0):
            rows.append((f"Q_s({f:g} gap)", _fmt(_q_at(s, f * gap))))
    w = max(len(k) for k, _ in rows)
    head = f"{'metric':<{w}}  value"
    lines = [head, "-" * max(len(head), w + 2 + max(len(v) for _, v in rows))]
    lines += [f"{k:<{w}}  {v}" for k, v in rows]
    return "\n".join(lines)


# --------------------------------------------------------------------------- plots


def _scp_of(result: dict) -> dict:
    return result["scp"] if "scp" in result else result


def _gap_of(result: dict) -> float | None:
    g = result.get("gap")
    if isinstance(g, dict):
        return g.get("requested")
    if isinstance(g, (int, float)):
        return float(g)
    return None


def _new_figure():
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 4.5), dpi=120)
    FigureCanvasAgg(fig)
    return fig


def _save_atomic(fig, out_png) -> Path:
    import io

    from .io.files import atomic_write_bytes

    out = Path(out_png)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    atomic_write_bytes(out, buf.getvalue())
    return out


def _decorate(ax, gap: float | None, r_hi: float) -> None:
    if gap:
        ax.axvline(0.5 * gap, color="0.4", lw=0.8, ls=":", label=r"$r = d_{gap}/2$")
    ax.set_xlim(0, r_hi if r_hi > 0 else 1)
    ax.set_ylim(bottom=0)
    ax.set_xlabel("r (container units)")
    ax.set_ylabel(r"$Q_s(r)$")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")


def _r_extent(curves: list[tuple[np.ndarray, np.ndarray]], gap: float | None) -> float:
    """x range of a plot: up to where every curve has (nearly) reached 0, >= 1.5 gap."""
    hi = 0.0
    for r, q in curves:
        if len(r) == 0:
            continue
        small = np.flatnonzero(q <= 1e-3 * max(q[0], 1e-12))
        hi = max(hi, float(r[small[0]]) if len(small) else float(r[-1]))
    if gap:
        hi = max(hi * 1.05, 1.5 * gap)
    return hi


def plot_scp(
    results: list[tuple[str, dict]], out_png, gap: float | None = None, ideal: bool = True
) -> Path:
    """Plot Q_s(r) of several packings overlaid into ``out_png`` (written atomically).

    ``results``: ``(label, result)`` with ``result`` an :func:`evaluate` or :func:`scp`
    dict. ``gap`` (default: the first result's requested gap) adds a vertical marker at
    gap/2 and, when ``ideal``, the ideal stripes line from (0, Q_s(0)) to (gap/2, 0)
    (dashed; one per curve in its colour for up to 3 curves, else one at the mean Q_s(0)).
    """
    if not results:
        raise ParameterError("plot_scp needs at least one result")
    if gap is None:
        gap = next((g for g in (_gap_of(res) for _, res in results) if g), None)
    fig = _new_figure()
    ax = fig.add_subplot(1, 1, 1)
    q0s, curves = [], []
    for k, (label, res) in enumerate(results):
        s = _scp_of(res)
        r = np.asarray(s["r"], dtype=float)
        q = np.asarray(s["q"], dtype=float)
        (line,) = ax.plot(r, q, lw=1.6, label=str(label), color=f"C{k % 10}")
        curves.append((r, q))
        q0s.append(float(q[0]) if len(q) else 0.0)
        if ideal and gap and len(results) <= 3:
            ax.plot([0, 0.5 * gap], [q0s[-1], 0], ls="--", lw=1.0, color=line.get_color(),
                    label=f"ideal stripes ({label})")
    if ideal and gap and len(results) > 3:
        ax.plot([0, 0.5 * gap], [float(np.mean(q0s)), 0], ls="--", lw=1.2, color="k",
                label=r"ideal stripes (mean $Q_s(0)$)")
    ax.set_title("Spherical contact probability")
    _decorate(ax, gap, _r_extent(curves, gap))
    return _save_atomic(fig, out_png)


def plot_scp_bands(groups: dict[str, list[dict]], out_png, gap: float | None) -> Path:
    """Plot the mean ± one standard deviation of Q_s(r) per group into ``out_png``.

    ``groups`` maps a label (e.g. ``"k_e = 10"``) to a list of :func:`evaluate` /
    :func:`scp` results; each curve is interpolated onto a common r grid (Q_s held at
    its last value beyond its own r range) before averaging.
    """
    groups = {k: v for k, v in groups.items() if v}
    if not groups:
        raise ParameterError("plot_scp_bands needs at least one non-empty group")
    curves = {k: [_scp_of(res) for res in v] for k, v in groups.items()}
    r_top = _r_extent(
        [(np.asarray(s["r"], float), np.asarray(s["q"], float)) for v in curves.values() for s in v], gap
    )
    rr = np.linspace(0.0, r_top if r_top > 0 else 1.0, 301)
    fig = _new_figure()
    ax = fig.add_subplot(1, 1, 1)
    q0s = []
    for k, (label, ss) in enumerate(curves.items()):
        Q = np.array([np.interp(rr, np.asarray(s["r"], float), np.asarray(s["q"], float)) for s in ss])
        mean, std = Q.mean(axis=0), Q.std(axis=0)
        color = f"C{k % 10}"
        ax.fill_between(rr, mean - std, mean + std, color=color, alpha=0.25, lw=0)
        ax.plot(rr, mean, color=color, lw=1.8, label=f"{label} (n={len(ss)})")
        q0s.append(float(mean[0]))
    if gap:
        ax.plot([0, 0.5 * gap], [float(np.mean(q0s)), 0], ls="--", lw=1.2, color="k",
                label=r"ideal stripes (mean $Q_s(0)$)")
    ax.set_title(r"Spherical contact probability (mean $\pm$ std)")
    _decorate(ax, gap, float(rr[-1]))
    return _save_atomic(fig, out_png)


# --------------------------------------------------------------------------- references


def _size2(size) -> tuple[float, float]:
    if np.ndim(size) == 0:
        return float(size), float(size)
    w, h = size
    return float(w), float(h)


def _check_pos(**kw) -> None:
    for k, v in kw.items():
        if not (np.isfinite(v) and v > 0):
            raise ParameterError(f"{k} must be positive, got {v}")


def stripes_reference(width: float, gap: float, size) -> tuple[Polygon, list[Polygon]]:
    """Fig. 9a: horizontal stripes of width ``width`` separated by ``gap``.

    ``size``: container width, or ``(width, height)``; the height is rounded to a whole
    number (>= 1) of periods ``width + gap``. The container ``[0, W] x [0, n·p]`` starts
    with a stripe at y = 0 and ends with a full gap bounded by its edge, so every gap is
    exactly ``gap`` wide: Q_s(0) = gap / (gap + width) exactly, and
    Q_s(r) = Q_s(0)·(1 − 2r/gap)·(1 − 2r/W) for r <= gap/2 (the last factor is the
    container's vertical edges; → the ideal line for W >> gap).
    """
    _check_pos(width=width, gap=gap)
    w, hgt = _size2(size)
    p = width + gap
    n = max(1, int(round(hgt / p)))
    container = box(0.0, 0.0, w, n * p)
    return container, [box(0.0, i * p, w, i * p + width) for i in range(n)]


def equivalent_stripe_width(side: float, gap: float) -> float:
    """Stripe width with the same area fraction as a grid of squares of ``side`` / ``gap``.

    A = (s/(s+g))² = d_s/(d_s+g)  ⇒  d_s = A·g/(1 − A).
    """
    a = (side / (side + gap)) ** 2
    return a * gap / (1.0 - a)


def square_grid_reference(side: float, gap: float, size) -> tuple[Polygon, list[Polygon]]:
    """Fig. 9b: a grid of axis-aligned squares of ``side`` separated by ``gap``.

    ``size``: container side or ``(w, h)``, rounded to whole periods ``p = side + gap``.
    Square (i, j) is ``[i·p, i·p + side] x [j·p, j·p + side]`` in the container
    ``[0, n·p] x [0, m·p]``: every channel is a full ``gap`` wide, the area fraction is
    exactly (side/p)² (see :func:`equivalent_stripe_width`), and the interior channel
    crossings hold discs of radius up to gap·√2/2.
    """
    _check_pos(side=side, gap=gap)
    w, hgt = _size2(size)
    p = side + gap
    nx = max(1, int(round(w / p)))
    ny = max(1, int(round(hgt / p)))
    container = box(0.0, 0.0, nx * p, ny * p)
    squares = [box(i * p, j * p, i * p + side, j * p + side) for j in range(ny) for i in range(nx)]
    return container, squares


def perturbed_squares_reference(
    side: float,
    gap: float,
    size,
    rng,
    rotate: bool = True,
    translate: bool = True,
    *,
    max_angle: float = 10.0,
    max_shift: float | None = None,
) -> tuple[Polygon, list[Polygon]]:
    """Fig. 9c/d: :func:`square_grid_reference` with random rotations and/or translations.

    ``rng``: a ``numpy.random.Generator`` or a seed. Each square is rotated about its
    centre by a uniform angle in ±``max_angle`` degrees (``rotate``) and shifted by a
    uniform offset in ±``max_shift`` per axis (``translate``; default ``gap/4``, so
    neighbouring gaps vary between gap/2 and 3·gap/2; at most what keeps the square
    inside its cell of side ``side + gap`` centred on its original centre).
    Squares staying in disjoint cells never overlap; a square is shrunk only when its
    rotated extent would not fit its cell (gap very small against side). Squares on the
    first row/column may poke out of the container by a little (their cells do);
    the negative space is measured inside the container anyway.
    """
    _check_pos(side=side, gap=gap)
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    container, squares = square_grid_reference(side, gap, size)
    p = side + gap
    out = []
    for sq in squares:
        cx, cy = sq.centroid.x, sq.centroid.y
        theta = math.radians(rng.uniform(-max_angle, max_angle)) if rotate else 0.0
        he = 0.5 * side * (abs(math.cos(theta)) + abs(math.sin(theta)))
        scale = 1.0
        if he > 0.5 * p * (1 - 1e-9):
            scale = 0.5 * p * (1 - 1e-9) / he
            he *= scale
        slack = max(0.0, 0.5 * p - he)
        m = min(0.25 * gap if max_shift is None else float(max_shift), slack)
        dx, dy = (rng.uniform(-m, m, size=2) if translate and m > 0 else (0.0, 0.0))
        c, s = math.cos(theta), math.sin(theta)
        hs = 0.5 * side * scale
        corners = np.array([[-hs, -hs], [hs, -hs], [hs, hs], [-hs, hs]])
        pts = corners @ np.array([[c, s], [-s, c]]) + [cx + dx, cy + dy]
        out.append(Polygon(pts))
    return container, out
