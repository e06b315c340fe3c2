"""Distortion: how far a placed copy's art is from a similar copy of its source.

distortion = min over similarity transforms T (rotation, uniform scale, translation; no
reflection) of area(T(source) △ copy) / area(copy): 0 for an exact rotated, scaled and
moved copy, about 2 for shapes that share nothing. The fit searches angles on a grid,
refines them, then runs a Nelder–Mead search on (angle, log scale, dx, dy), evaluating
candidates with the compiled overlap kernel (:mod:`repulsionpak.geometry.overlap`); the
value returned is GEOS's on the exact outlines.

* :func:`distortion` – one copy against its source.
* :func:`distortions` – every copy of a packing against the source its ``data-source`` names.
* :func:`source_geometries` – the ``sources`` mapping from library elements.
* :func:`distortion_summary` – median, p95, max, overall and per kind of element.
* :func:`frame_angle` – a copy's rotation from its similarity frame (the fit's start).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import shapely

from ..errors import ParameterError
from ..art_area import _polygonal, art_area
from ..geometry.overlap import OverlapGrid, intersection_areas, nelder_mead_sym, rings_of
from ..geometry.robust import overlay
from ..threads import thread_map

__all__ = ["distortion", "distortions", "source_geometries", "distortion_summary", "frame_angle"]


def _normalised(geom) -> tuple[shapely.Geometry, float]:
    """``geom`` moved to its centroid and scaled to unit area; returns (geometry, scale)."""
    c = geom.centroid
    s = math.sqrt(geom.area)
    return shapely.transform(geom, lambda xy: (xy - (c.x, c.y)) / s), s


def _sym_areas(a: shapely.Geometry, b: shapely.Geometry, params: np.ndarray) -> np.ndarray:
    """Areas of ``sym_diff(T_k(a), b)`` for the similarity transforms ``params[k] =
    (angle, log_scale, dx, dy)`` (radians, about the origin, then shifted). Vectorised:
    one coordinate transform and one shapely call for all k."""
    k = len(params)
    copies = np.full(k, a, dtype=object)
    m = len(shapely.get_coordinates(a))
    th = np.repeat(params[:, 0], m)
    sc = np.exp(np.repeat(params[:, 1], m))
    dx = np.repeat(params[:, 2], m)
    dy = np.repeat(params[:, 3], m)
    cos, sin = np.cos(th) * sc, np.sin(th) * sc

    def move(xy):
        x, y = xy[:, 0], xy[:, 1]
        return np.stack([cos * x - sin * y + dx, sin * x + cos * y + dy], axis=1)

    moved = shapely.transform(copies, move)
    # |A △ B| = |A| + |B| − 2 |A ∩ B| (one overlay, cheaper than the symmetric difference)
    inter = shapely.area(overlay(shapely.intersection, moved, b))
    return np.maximum(a.area * np.exp(2.0 * params[:, 1]) + b.area - 2.0 * inter, 0.0)


class _Search:
    """The fit's objective, area(T(a) △ b) for rows of similarity parameters, by the
    numba overlap kernel (:mod:`repulsionpak.geometry.overlap`, ~20× cheaper than a GEOS
    overlay per evaluation); rows the kernel cannot decide go to GEOS."""

    def __init__(self, a: shapely.Geometry, b: shapely.Geometry, ra=None):
        self.a, self.b = a, b
        self.ra = rings_of(a) if ra is None else ra  # (given: a's, made once)
        self.gb = OverlapGrid(rings_of(b))
        self.area_a, self.area_b = self.ra.area, self.gb.rings.area

    def __call__(self, params: np.ndarray) -> np.ndarray:
        inter = intersection_areas(self.ra, self.gb, params)
        out = np.maximum(self.area_a * np.exp(2.0 * params[:, 1]) + self.area_b - 2.0 * inter, 0.0)
        if not np.isfinite(out).all():
            bad = ~np.isfinite(out)
            out[bad] = _sym_areas(self.a, self.b, params[bad])
        return out

    def nelder_mead(self, p: np.ndarray, v: float) -> tuple[np.ndarray, float]:
        """:func:`_nelder_mead` on this objective, in compiled code when it can be."""
        res = nelder_mead_sym(self.ra, self.gb, p, v, _NM_SIZE, _NM_TOL, _NM_EVALS)
        return _nelder_mead(self, p, v) if res is None else res


#: the fit's search runs on unit-area outlines simplified to this
_SIMPLIFY = 1e-3


@dataclass(frozen=True, eq=False)
class _Shape:
    """A source as :func:`distortion` reads it, made once for all its copies: polygonal
    (``geom``), moved to its centroid and scaled to unit area (``unit``, scale ``size``),
    simplified (``simple``), and the rings of both (``unit_rings``, ``simple_rings``;
    None where ``simple`` is empty or invalid, which the fit does not use)."""

    geom: shapely.Geometry
    unit: shapely.Geometry
    size: float
    simple: shapely.Geometry
    unit_rings: object
    simple_rings: object

    @staticmethod
    def of(geom) -> "_Shape | None":
        """The shape of ``geom``; None when it has no area."""
        a = _polygonal(geom)
        if a.is_empty or not a.area > 0:
            return None
        an, sa = _normalised(a)
        a_s = shapely.simplify(an, _SIMPLIFY)
        usable = not a_s.is_empty and a_s.is_valid
        return _Shape(a, an, sa, a_s, rings_of(an), rings_of(a_s) if usable else None)


def distortion(source, copy, *, coarse: int = 48, fit_translation: bool = True,
               return_fit: bool = False, angle: float | None = None):
    """How far ``copy`` is from a similar copy of ``source``: min over similarity
    transforms T of area(T(source) △ copy) / area(copy).

    0 for an exact rotated / scaled / translated copy; about 2 for shapes that share
    nothing. Both are polygonal shapely geometries (holes allowed), in any units.

    The fit: both shapes are centred on their centroids and brought to unit area (so
    the uniform scale starts at sqrt(area ratio)); the rotation is searched on a grid of
    ``coarse`` angles, then refined around the best grid angle (and a second one when
    nearly as good) by successively
    finer grids (to ~0.01°); with ``fit_translation`` a final Nelder–Mead search
    refines angle, scale and translation together (it only ever lowers the value). Without it,
    the value is the centroid-aligned, area-matched fit (an upper bound). The search
    evaluates its candidates with the compiled overlap kernel
    (:mod:`repulsionpak.geometry.overlap`) on outlines simplified to a thousandth of
    the size; the value returned is GEOS's, on the exact outlines, at the best
    transform found.
    ``angle`` (radians): the copy's rotation relative to the source when it is known
    approximately (a packing knows each copy's frame: the least-squares similarity of its
    mesh): the Nelder–Mead search then starts there, without the angle grids (0.6 of
    the overlays on the heart's copies, values within 6·10⁻⁴ of the full search's; the
    fit found is the same unless the copy is bent so far that its best angle lies
    elsewhere).
    ``return_fit``: also return ``(angle_degrees, scale, dx, dy)`` of T in the copy's
    units (``source`` rotated about its centroid, scaled, centroid moved onto the
    copy's centroid plus (dx, dy)).

    Returns ``None`` when either shape has no area.
    """
    return _distortion(_Shape.of(source), copy, coarse=coarse, fit_translation=fit_translation,
                       return_fit=return_fit, angle=angle)


def _distortion(src: _Shape | None, copy, *, coarse: int = 48, fit_translation: bool = True,
                return_fit: bool = False, angle: float | None = None):
    """:func:`distortion` of the source ``src`` (:meth:`_Shape.of`, None: no area)."""
    b = _polygonal(copy)
    if src is None or b.is_empty or not b.area > 0:
        return (None, None) if return_fit else None
    if coarse < 8:
        raise ParameterError(f"coarse must be at least 8 angles, got {coarse}")
    an, sa = src.unit, src.size
    bn, sb = _normalised(b)
    # the search runs on outlines simplified to a thousandth of the size (far fewer
    # vertices for finely sampled curves, the optimum hardly moves); the value returned
    # is that of the exact outlines under the transform found
    b_s = shapely.simplify(bn, _SIMPLIFY)
    if src.simple_rings is None or b_s.is_empty or not b_s.is_valid:
        search = _Search(an, bn, src.unit_rings)
    else:
        search = _Search(src.simple, b_s, src.simple_rings)
    step = 2 * math.pi / coarse
    best_p, best_v = None, np.inf
    known = angle is not None and math.isfinite(angle)
    if known and fit_translation:
        # a known rotation: the simplex search alone, from there (it moves the angle by
        # degrees where it must, and costs ~60 overlays against ~100 with an angle grid first)
        best_p = np.array([float(angle), 0.0, 0.0, 0.0])
        best_v = float(search(best_p[None, :])[0])
        starts, first = [], step
    elif known:
        starts, first = [float(angle)], 0.5 * step
    else:
        grid = np.zeros((coarse, 4))
        grid[:, 0] = np.arange(coarse) * step
        vals = search(grid)
        order = np.argsort(vals)
        starts, first = [grid[order[0], 0]], step
        for i in order[1:]:  # a second, distinct local minimum when it is nearly as good
            d = abs((grid[i, 0] - starts[0] + math.pi) % (2 * math.pi) - math.pi)
            if d > 1.5 * step:
                if vals[i] <= 1.25 * vals[order[0]] + 1e-3:
                    starts.append(grid[i, 0])
                break
    offsets = np.linspace(-1.0, 1.0, 7)
    stop = math.radians(0.01)
    for t0 in starts:
        t, half = t0, first
        while half > stop:
            cand = np.zeros((len(offsets), 4))
            cand[:, 0] = t + offsets * half
            v = search(cand)
            k = int(np.argmin(v))
            t = cand[k, 0]
            half /= 3.0
            if v[k] < best_v:
                best_v, best_p = float(v[k]), cand[k].copy()
    tried = [best_p]
    if fit_translation and best_v > 1e-4:  # below that the fit is as good as it gets
        tried.append(search.nelder_mead(best_p, best_v)[0])
    # the search ran on the simplified outlines; the value is the exact one of the best fit
    exact = _sym_areas(an, bn, np.array(tried))
    k = int(np.argmin(exact))
    best_v, best_p = float(exact[k]), tried[k]
    value = best_v  # both normalised to unit area: the ratio to the copy's area
    if not return_fit:
        return value
    ang, ls, dx, dy = best_p
    return value, (math.degrees(ang) % 360.0, math.exp(ls) * sb / sa, dx * sb, dy * sb)


_NM_SIZE, _NM_TOL, _NM_EVALS = 0.02, 1e-3, 100


def _nelder_mead(objective, p, v, size: float = _NM_SIZE, tol: float = _NM_TOL, max_evals: int = _NM_EVALS):
    """Nelder–Mead on (angle, log scale, dx, dy) from ``p`` (value ``v``) for
    ``objective`` (rows of parameters → values), simplex of edge ``size`` (unit-area
    shapes: 2 % of their size, ~1.1° of angle); stops when the simplex is smaller than
    ``tol`` or after ``max_evals`` evaluations. Returns the best (parameters, value)
    found; never worse than the start."""
    f = lambda q: float(objective(q[None, :])[0])  # noqa: E731
    pts = np.vstack([p, p + np.eye(4) * size])
    vals = np.concatenate([[v], objective(pts[1:])])
    evals = 4
    while evals < max_evals:
        order = np.argsort(vals)
        pts, vals = pts[order], vals[order]
        if np.max(np.abs(pts[1:] - pts[0])) < tol:
            break
        centre = pts[:-1].mean(axis=0)
        xr = centre + (centre - pts[-1])
        fr = f(xr)
        evals += 1
        if fr < vals[0]:
            xe = centre + 2.0 * (centre - pts[-1])
            fe = f(xe)
            evals += 1
            pts[-1], vals[-1] = (xe, fe) if fe < fr else (xr, fr)
        elif fr < vals[-2]:
            pts[-1], vals[-1] = xr, fr
        else:
            xc = centre + 0.5 * ((xr if fr < vals[-1] else pts[-1]) - centre)
            fc = f(xc)
            evals += 1
            if fc < min(fr, vals[-1]):
                pts[-1], vals[-1] = xc, fc
            else:  # shrink towards the best
                pts[1:] = pts[0] + 0.5 * (pts[1:] - pts[0])
                vals[1:] = objective(pts[1:])
                evals += 4
    k = int(np.argmin(vals))
    return (pts[k], float(vals[k])) if vals[k] < v else (p, v)


def source_geometries(elements) -> dict[str, shapely.Geometry]:
    """``{element.source: art area}`` of library elements (the first of equal names wins),
    the ``sources`` :func:`distortions` and :func:`repulsionpak.measure.evaluate` take."""
    out: dict[str, shapely.Geometry] = {}
    for e in elements:
        out.setdefault(e.source, art_area(e.paths))
    return out


def distortions(art_geoms: Sequence, names: Sequence[str],
                sources: Mapping[str, shapely.Geometry], angles: Sequence[float | None] | None = None,
                workers: int = 1, **kw) -> list[float | None]:
    """:func:`distortion` of each placed element against the source named by
    ``names[i]`` (its ``data-source``); ``None`` when the source is unknown or either
    has no area. ``angles[i]``: the copy's approximate rotation, where known (see
    :func:`distortion`). ``workers`` > 1 fits that many elements at once in threads
    (the overlap kernel and shapely's overlays release the GIL); the values do
    not depend on it. ``kw`` goes to :func:`distortion`."""
    if len(art_geoms) != len(names):
        raise ParameterError(f"{len(art_geoms)} elements but {len(names)} source names")
    if angles is not None and len(angles) != len(names):
        raise ParameterError(f"{len(art_geoms)} elements but {len(angles)} angles")
    if int(workers) < 1:
        raise ParameterError(f"workers must be at least 1, got {workers!r}")
    prepared = {k: _Shape.of(g) for k, g in sources.items()}  # each source once, not per copy

    def one(i: int) -> float | None:
        if names[i] not in prepared:
            return None
        a = None if angles is None else angles[i]
        return _distortion(prepared[names[i]], art_geoms[i], angle=a, **kw)

    return thread_map(one, range(len(names)), workers=int(workers))


def frame_angle(frame) -> float | None:
    """Rotation (radians) of a placed copy's ``frame`` (its (3, 3) similarity from the
    source's orientation), ``None`` without one."""
    if frame is None:
        return None
    m = np.asarray(frame, dtype=float)
    return math.atan2(m[1, 0], m[0, 0])


def _distortion_stats(values) -> dict:
    v = np.array([x for x in values if x is not None and np.isfinite(x)], dtype=float)
    if len(v) == 0:
        return {"median": None, "p95": None, "max": None}
    return {"median": float(np.median(v)), "p95": float(np.percentile(v, 95)), "max": float(v.max())}


def distortion_summary(values: Sequence[float | None], kinds: Sequence[str] | None = None) -> dict:
    """``{"median", "p95", "max", "values"}`` of per-element distortions (``None``
    entries ignored; statistics ``None`` when nothing is known). With ``kinds`` (each
    element's ``"primary"`` / ``"secondary"``), also ``"by_kind"``: the same statistics
    and the count of each kind present — the pocket copies, small and often undeformed,
    pull the overall percentiles down, so the primaries' own are given too."""
    out = {**_distortion_stats(values), "values": [None if x is None else float(x) for x in values]}
    if kinds is not None:
        out["by_kind"] = {k: {**_distortion_stats([x for x, kk in zip(values, kinds) if kk == k]),
                              "n": sum(1 for kk in kinds if kk == k)}
                          for k in ("primary", "secondary") if k in kinds}
    return out
