"""Flattening parsed SVG shapes into polylines within a chord tolerance.

Owns :func:`flatten_shape` (Béziers and elliptical arcs sampled with a piece count that
bounds the chord error), the automatic tolerance (:func:`default_tolerance`: 1e-3 of the
bounding-box diagonal) and the cap on a user-given one (:func:`flattening_tolerance`,
:func:`check_tolerance`), :func:`shape_bounds`, and :func:`shape_clipper`, which resolves a
shape's clip paths to a region with this flattening.

Notes
-----
Every vertex is counted against the file's :class:`~.files.PointBudget`, so a file of
huge curves fails with a clear error instead of exhausting memory.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError, ParameterError
from ..types import Style
from .files import PointBudget, check_coordinates, warn
from .regions import clean_points, rings_to_region
from .svg_clip import ClipResolver
from .svg_shapes import SvgDocument, SvgShape

__all__ = ["MAX_TOLERANCE_FACTOR", "check_tolerance", "default_tolerance", "flatten_shape",
           "flattening_tolerance", "shape_bounds", "shape_clipper"]


#: A user-given flattening tolerance is capped at this multiple of the automatic one
#: (1e-3 x bounding-box diagonal): a huge tolerance (e.g. from an absurd gap) would
#: otherwise collapse arcs to chords and a circle to a line.
MAX_TOLERANCE_FACTOR = 10.0


def check_tolerance(tolerance: float | None) -> float | None:
    """Validate a user-given flattening tolerance (None = automatic)."""
    if tolerance is None:
        return None
    try:
        tol = float(tolerance)
    except (TypeError, ValueError):
        raise ParameterError(
            f"tolerance must be a positive number, got {tolerance!r}"
        ) from None
    if not math.isfinite(tol) or tol <= 0:
        raise ParameterError(
            f"tolerance must be a positive finite number, got {tolerance!r}"
        )
    return tol


def _pt(p) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))


def _control_points(seg) -> list:
    import svgelements as se

    if isinstance(seg, se.Arc):
        c, u, v = (
            np.array(_pt(seg.center)),
            np.array(_pt(seg.prx)) - np.array(_pt(seg.center)),
            np.array(_pt(seg.pry)) - np.array(_pt(seg.center)),
        )
        return [
            _pt(seg.start),
            _pt(seg.end),
            *(c + su * u + sv * v for su in (-1, 1) for sv in (-1, 1)),
        ]
    pts = []
    for name in ("start", "control", "control1", "control2", "end"):
        p = getattr(seg, name, None)
        if p is not None:
            pts.append(_pt(p))
    return pts


def shape_bounds(shapes: list[SvgShape]) -> np.ndarray | None:
    """Cheap bounding box (x0, y0, x1, y1) of shapes from their control points (user units)."""
    boxes = []
    for sh in shapes:
        pts = [p for seg in sh.segments for p in _control_points(seg)]
        if not pts:
            continue
        with np.errstate(all="ignore"):
            a = np.asarray(pts, dtype=float) @ sh.matrix[:2, :2].T + sh.matrix[:2, 2]
        boxes.append(np.concatenate([a.min(axis=0), a.max(axis=0)]))
    if not boxes:
        return None
    b = np.array(boxes)
    return np.concatenate([b[:, :2].min(axis=0), b[:, 2:].max(axis=0)])


def default_tolerance(bounds) -> float:
    """1e-3 x the bounding-box diagonal (a tiny positive number for a degenerate box)."""
    if bounds is None:
        return 1e-9
    diag = float(np.hypot(bounds[2] - bounds[0], bounds[3] - bounds[1]))
    return 1e-3 * diag if diag > 0 and math.isfinite(diag) else 1e-9


def flattening_tolerance(shapes: list[SvgShape], tolerance: float | None) -> float:
    """The chord tolerance for ``shapes``: the automatic one (1e-3 x bounding-box
    diagonal) when ``tolerance`` is None, else ``tolerance`` capped at
    :data:`MAX_TOLERANCE_FACTOR` x the automatic one (a finer flattening than asked for
    is always acceptable; a coarser one would collapse curves)."""
    auto = default_tolerance(shape_bounds(shapes))
    if tolerance is None:
        return auto
    return min(tolerance, MAX_TOLERANCE_FACTOR * auto) if auto > 1e-9 else tolerance


def flatten_shape(
    path, sh: SvgShape, tol: float, budget: PointBudget
) -> list[tuple[np.ndarray, bool]]:
    """Flatten one shape into (K, 2) polylines in user units with chord error <= ``tol``.

    Béziers are sampled uniformly in t with n = ceil(sqrt(max|B''| / (8 tol))) pieces
    (the interpolation error bound h^2/8 max|B''|), elliptical arcs with
    n = ceil(|sweep| sqrt(K / (8 tol))) with K bounding |B''| of the (transformed) arc.
    Returns [(points, closed)] with consecutive duplicates and repeated closing points
    removed; subpaths with fewer than 2 distinct points are dropped.
    """
    import svgelements as se

    L = sh.matrix[:2, :2]
    t = sh.matrix[:2, 2]
    out: list[tuple[np.ndarray, bool]] = []
    cur: list[np.ndarray] | None = None
    eps = tol * 1e-6

    def flush(closed: bool):
        nonlocal cur
        if cur is None:
            return
        local = np.concatenate(cur, axis=0)
        cur = None
        with np.errstate(all="ignore"):
            pts = local @ L.T + t
        check_coordinates(path, pts)
        pts = clean_points(pts, closed, eps)
        if len(pts) >= 2:
            out.append((pts, closed))

    for seg in sh.segments:
        if isinstance(seg, se.Move):
            flush(False)
            if seg.end is None:
                continue
            cur = [np.array([_pt(seg.end)])]
            budget.take(1)
            continue
        if isinstance(seg, se.Close):
            flush(True)
            continue
        if seg.start is None or seg.end is None:
            continue
        if cur is None:
            cur = [np.array([_pt(seg.start)])]
            budget.take(1)
        if isinstance(seg, se.Linear):
            cur.append(np.array([_pt(seg.end)]))
            budget.take(1)
        elif isinstance(seg, (se.QuadraticBezier, se.CubicBezier)):
            if isinstance(seg, se.QuadraticBezier):
                P = np.array([_pt(seg.start), _pt(seg.control), _pt(seg.end)])
                d = (P[0] - 2 * P[1] + P[2]) @ L.T
                bound = 2.0 * float(np.hypot(*d))
            else:
                P = np.array(
                    [_pt(seg.start), _pt(seg.control1), _pt(seg.control2), _pt(seg.end)]
                )
                d1 = (P[0] - 2 * P[1] + P[2]) @ L.T
                d2 = (P[1] - 2 * P[2] + P[3]) @ L.T
                bound = 6.0 * max(float(np.hypot(*d1)), float(np.hypot(*d2)))
            if not np.all(np.isfinite(P)) or not math.isfinite(bound):
                raise InputError(
                    path,
                    "has non-finite coordinates (NaN or infinity); check the path data",
                )
            n = max(1, math.ceil(math.sqrt(bound / (8.0 * tol)))) if bound > 0 else 1
            n = budget.take(n)
            s = np.linspace(0.0, 1.0, n + 1)[1:, None]
            r = 1.0 - s
            if len(P) == 3:
                pts = r * r * P[0] + 2 * r * s * P[1] + s * s * P[2]
            else:
                pts = (
                    r**3 * P[0]
                    + 3 * r * r * s * P[1]
                    + 3 * r * s * s * P[2]
                    + s**3 * P[3]
                )
            pts[-1] = P[-1]
            cur.append(pts)
        elif isinstance(seg, se.Arc):
            end = np.array([_pt(seg.end)])
            if (
                seg.center is None
                or seg.prx is None
                or seg.pry is None
                or not seg.sweep
            ):
                cur.append(end)
                budget.take(1)
                continue
            c = np.array(_pt(seg.center))
            u = (np.array(_pt(seg.prx)) - c) @ L.T
            v = (np.array(_pt(seg.pry)) - c) @ L.T
            K = math.sqrt(float(u @ u + v @ v))
            sweep = abs(float(seg.sweep))
            if not (math.isfinite(K) and math.isfinite(sweep)):
                raise InputError(
                    path,
                    "has non-finite coordinates (NaN or infinity); check the path data",
                )
            if K == 0 or seg.rx == 0 or seg.ry == 0:
                cur.append(end)
                budget.take(1)
                continue
            n = max(1, math.ceil(sweep * math.sqrt(K / (8.0 * tol))))
            n = budget.take(n)
            pts = np.asarray(
                seg.npoint(np.linspace(0.0, 1.0, n + 1)[1:]), dtype=float
            ).reshape(-1, 2)
            pts[-1] = end[0]
            cur.append(pts)
        else:  # unknown segment type: keep its end point
            cur.append(np.array([_pt(seg.end)]))
            budget.take(1)
    flush(False)
    return out


def shape_clipper(path, doc: SvgDocument, tol: float, budget: PointBudget):
    """``clip(shape) -> region | None``: the clip region of a shape of ``doc`` in file
    user units (the intersection of its own and its groups' ``clip-path``), or None when
    nothing clips it. See :mod:`.svg_clip`."""
    if not any(s.clips for s in doc.shapes):
        return lambda sh: None

    def flatten(segments, matrix):
        return flatten_shape(path, SvgShape(segments, matrix, Style(), False, {}), tol, budget)

    resolver = ClipResolver(
        path,
        doc.clip_defs,
        doc.shapes,
        flatten,
        lambda rings, rule: rings_to_region(rings, rule, path),
        lambda message: warn(path, message),
    )
    return lambda sh: resolver.region(sh.clips) if sh.clips else None
