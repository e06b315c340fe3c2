"""Fit Bézier segments to densely mapped source segments, within a tolerance.

Corners of the source stay corners and its smooth joints stay smooth: the end tangents
of a fitted piece are the exact derivatives of the mapped source curve (``Df · c'(t)``),
which are parallel on both sides of a smooth joint. A source line stays a line when its
mapped samples are within the tolerance of the chord (and a curve meeting it at a smooth
joint takes the line's direction as its end tangent). Other pieces are a quadratic when
one fits (its control point where the two end tangents meet: two numbers fewer than a
cubic), otherwise a cubic with the exact end tangents: the Hermite piece (exact end
derivatives), then least squares with Newton reparametrisation, then a pattern search
over the two tangent lengths for the largest error (the least-squares cubic minimises
the mean error; a piece must keep the largest one within the tolerance). A piece fits
when every sample is within the tolerance of it, its direction within the angle
tolerance of the mapped curve's at every sample (half of it next to its ends, so joints
keep the exact curve's curvature) and both tangent arms are at least ``ARM_MIN`` of its
chord (a shorter arm turns the curve right next to its joint: a near-kink).

Each source segment is fitted on its own first, and kept so when every segment of its
run (curved segments meeting at smooth joints) takes one piece: a copy that is only
moved, turned and scaled writes exactly its source's segments. When the deformation
needs more pieces, the whole run is refitted greedily: from its start, the longest span
of samples one piece fits (binary search over the end sample), then the rest, so joints
fall wherever they are needed, also across the source's smooth joints.

The distance checked is an upper bound of the true one: each sample's distance to the
curve point at a Newton-refined parameter. Compiled with numba (one call per subpath).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..types import CurveSubpath

__all__ = ["fit_subpath"]

#: a joint whose mapped tangents differ by less than this (radians) is smooth: the
#: curve beside a straight line then takes the line's direction as its end tangent, and
#: curves meeting there may be refitted together (a corner never is)
SNAP_ANGLE = math.radians(2.0)
#: shortest tangent arm (control point to end point) of a fitted piece, × its chord: a
#: piece whose arm is much shorter turns by up to the angle tolerance within a tiny
#: length next to its joint, which looks like a kink (found by the search otherwise)
ARM_MIN = 0.1
#: samples next to each end of a piece whose direction must be within END_SHARE of the
#: angle tolerance
END_SAMPLES = 2
END_SHARE = 0.6
#: least-squares passes (each followed by a Newton reparametrisation) before the search
LSQ_ITERATIONS = 4
#: largest number of cubics the search over the two tangent lengths evaluates
SEARCH_EVALS = 48
#: ... and only from a cubic whose score (largest error / tolerance, or direction error /
#: angle tolerance) is at most this
SEARCH_FROM = 5.0


@njit(cache=True)
def _eval(c, u):
    s = 1.0 - u
    b0, b1, b2, b3 = s * s * s, 3.0 * s * s * u, 3.0 * s * u * u, u * u * u
    return (b0 * c[0, 0] + b1 * c[1, 0] + b2 * c[2, 0] + b3 * c[3, 0],
            b0 * c[0, 1] + b1 * c[1, 1] + b2 * c[2, 1] + b3 * c[3, 1])


@njit(cache=True)
def _max_error(c, u, q, lo, hi, stop):
    """Largest distance of samples q[lo:hi] from cubic c (refines u in place); returns
    early, with a value above ``stop``, once one sample is further than that."""
    worst = 0.0
    for i in range(lo, hi):
        k = i - lo
        x, y = _eval(c, u[k])
        best = (x - q[i, 0]) ** 2 + (y - q[i, 1]) ** 2
        uu = u[k]
        for _ in range(3):
            s = 1.0 - uu
            d1x = 3.0 * (s * s * (c[1, 0] - c[0, 0]) + 2.0 * s * uu * (c[2, 0] - c[1, 0]) + uu * uu * (c[3, 0] - c[2, 0]))
            d1y = 3.0 * (s * s * (c[1, 1] - c[0, 1]) + 2.0 * s * uu * (c[2, 1] - c[1, 1]) + uu * uu * (c[3, 1] - c[2, 1]))
            d2x = 6.0 * (s * (c[2, 0] - 2.0 * c[1, 0] + c[0, 0]) + uu * (c[3, 0] - 2.0 * c[2, 0] + c[1, 0]))
            d2y = 6.0 * (s * (c[2, 1] - 2.0 * c[1, 1] + c[0, 1]) + uu * (c[3, 1] - 2.0 * c[2, 1] + c[1, 1]))
            bx, by = _eval(c, uu)
            rx, ry = bx - q[i, 0], by - q[i, 1]
            num = rx * d1x + ry * d1y
            den = d1x * d1x + d1y * d1y + rx * d2x + ry * d2y
            if abs(den) < 1e-300:
                break
            un = min(1.0, max(0.0, uu - num / den))
            nx, ny = _eval(c, un)
            e = (nx - q[i, 0]) ** 2 + (ny - q[i, 1]) ** 2
            if e < best:
                best = e
                uu = un
            else:
                break
        u[k] = uu
        if best > worst:
            worst = best
            if worst > stop * stop:
                break
    return math.sqrt(worst)


@njit(cache=True)
def _forward(c, u, g, lo, hi, cos_tol):
    """True when the cubic c heads the way the mapped curve does at every sample: the
    angle between B'(u_i) and g_i is below the angle tolerance. A fitted piece then never
    doubles back, loops, or bends sharply where the exact curve does not."""
    for i in range(lo, hi):
        uu = u[i - lo]
        s = 1.0 - uu
        dx = 3.0 * (s * s * (c[1, 0] - c[0, 0]) + 2.0 * s * uu * (c[2, 0] - c[1, 0]) + uu * uu * (c[3, 0] - c[2, 0]))
        dy = 3.0 * (s * s * (c[1, 1] - c[0, 1]) + 2.0 * s * uu * (c[2, 1] - c[1, 1]) + uu * uu * (c[3, 1] - c[2, 1]))
        dot = dx * g[i, 0] + dy * g[i, 1]
        n = math.hypot(dx, dy) * math.hypot(g[i, 0], g[i, 1])
        if dot <= 0.0 or (n > 0 and dot < cos_tol * n):
            return False
    return True


@njit(cache=True)
def _line_error(q, lo, hi):
    """Largest distance of q[lo:hi] from the chord q[lo] -> q[hi-1] (as a segment)."""
    ax, ay = q[lo, 0], q[lo, 1]
    vx, vy = q[hi - 1, 0] - ax, q[hi - 1, 1] - ay
    c2 = vx * vx + vy * vy
    worst = 0.0
    for i in range(lo, hi):
        px, py = q[i, 0] - ax, q[i, 1] - ay
        w = 0.0 if c2 <= 0 else min(1.0, max(0.0, (px * vx + py * vy) / c2))
        d = (px - w * vx) ** 2 + (py - w * vy) ** 2
        if d > worst:
            worst = d
    return math.sqrt(worst)


@njit(cache=True)
def _line_fits(q, g, lo, hi, tol, cos_tol):
    """True when the chord q[lo] -> q[hi-1] is within ``tol`` of every sample and within
    the angle tolerance of the mapped curve's direction at every sample (the test every
    fitted piece passes: a line kept straight where the map bends it would otherwise meet
    its smooth neighbours at a visible angle)."""
    if _line_error(q, lo, hi) > tol:
        return False
    vx, vy = q[hi - 1, 0] - q[lo, 0], q[hi - 1, 1] - q[lo, 1]
    for i in range(lo, hi):
        dot = vx * g[i, 0] + vy * g[i, 1]
        n = math.hypot(vx, vy) * math.hypot(g[i, 0], g[i, 1])
        if n > 0 and dot < cos_tol * n:
            return False
    return True


@njit(cache=True)
def _lsq(q, u, lo, hi, c):
    """Least-squares tangent lengths for cubic c (ends and unit tangents fixed); in place."""
    p0x, p0y, p3x, p3y = c[0, 0], c[0, 1], c[3, 0], c[3, 1]
    t0x, t0y = c[1, 0] - p0x, c[1, 1] - p0y
    t3x, t3y = c[2, 0] - p3x, c[2, 1] - p3y
    n0 = math.hypot(t0x, t0y)
    n3 = math.hypot(t3x, t3y)
    if n0 <= 0 or n3 <= 0:
        return
    t0x, t0y, t3x, t3y = t0x / n0, t0y / n0, t3x / n3, t3y / n3
    m00 = m01 = m11 = v0 = v1 = 0.0
    for i in range(lo, hi):
        uu = u[i - lo]
        s = 1.0 - uu
        b0, b1, b2, b3 = s * s * s, 3.0 * s * s * uu, 3.0 * s * uu * uu, uu * uu * uu
        a1x, a1y = b1 * t0x, b1 * t0y
        a2x, a2y = b2 * t3x, b2 * t3y
        rx = q[i, 0] - (b0 + b1) * p0x - (b2 + b3) * p3x
        ry = q[i, 1] - (b0 + b1) * p0y - (b2 + b3) * p3y
        m00 += a1x * a1x + a1y * a1y
        m01 += a1x * a2x + a1y * a2y
        m11 += a2x * a2x + a2y * a2y
        v0 += a1x * rx + a1y * ry
        v1 += a2x * rx + a2y * ry
    det = m00 * m11 - m01 * m01
    chord = math.hypot(p3x - p0x, p3y - p0y)
    if abs(det) < 1e-300:
        alpha = beta = chord / 3.0
    else:
        alpha = (v0 * m11 - v1 * m01) / det
        beta = (m00 * v1 - m01 * v0) / det
        if not (alpha > 1e-6 * chord and beta > 1e-6 * chord and alpha < 1e6 * (chord + 1e-300)
                and beta < 1e6 * (chord + 1e-300)):
            alpha = beta = chord / 3.0
    c[1, 0], c[1, 1] = p0x + alpha * t0x, p0y + alpha * t0y
    c[2, 0], c[2, 1] = p3x + beta * t3x, p3y + beta * t3y


@njit(cache=True)
def _copy4(dst, src):
    """dst[:, :] = src for (4, 2) arrays, as a loop: numba compiles a slice assignment with
    its broadcasting checks and their error messages (2.9 of the 6.9 s the first run spent
    compiling this module)."""
    for r in range(4):
        dst[r, 0] = src[r, 0]
        dst[r, 1] = src[r, 1]


@njit(cache=True)
def _angle_score(c, u, g, lo, hi, ang_tol):
    """Largest angle between the cubic's direction B'(u_i) and the mapped curve's g_i over
    samples [lo, hi), over the angle tolerance; next to the ends (END_SAMPLES samples) over
    END_SHARE of it, so the curvature at a joint follows the exact curve's and neighbouring
    pieces meet without a visible change of curvature (π / ang_tol where B' vanishes)."""
    worst = 0.0
    for i in range(lo, hi):
        uu = u[i - lo]
        s = 1.0 - uu
        dx = 3.0 * (s * s * (c[1, 0] - c[0, 0]) + 2.0 * s * uu * (c[2, 0] - c[1, 0]) + uu * uu * (c[3, 0] - c[2, 0]))
        dy = 3.0 * (s * s * (c[1, 1] - c[0, 1]) + 2.0 * s * uu * (c[2, 1] - c[1, 1]) + uu * uu * (c[3, 1] - c[2, 1]))
        if dx == 0.0 and dy == 0.0:
            return math.pi / ang_tol
        a = abs(math.atan2(dx * g[i, 1] - dy * g[i, 0], dx * g[i, 0] + dy * g[i, 1])) / ang_tol
        if i - lo <= END_SAMPLES or hi - 1 - i <= END_SAMPLES:
            a /= END_SHARE
        if a > worst:
            worst = a
    return worst


@njit(cache=True)
def _score(c, u, q, g, lo, hi, tol, ang_tol, stop):
    """max(distance / tol, direction error / angle tolerance, ARM_MIN × chord / shorter
    tangent arm) of cubic c: <= 1 fits.
    Above ``stop``, only a lower bound of the score (the search then rejects c anyway)."""
    chord = math.hypot(c[3, 0] - c[0, 0], c[3, 1] - c[0, 1])
    arm = min(math.hypot(c[1, 0] - c[0, 0], c[1, 1] - c[0, 1]), math.hypot(c[2, 0] - c[3, 0], c[2, 1] - c[3, 1]))
    short = ARM_MIN * chord / arm if arm > 0 else 1e300
    if short > stop:
        return short
    err = _max_error(c, u, q, lo, hi, stop * tol) / tol
    if err > stop:
        return err
    ang = _angle_score(c, u, g, lo, hi, ang_tol)
    return max(err, ang, short)


@njit(cache=True)
def _search(c, u, q, g, lo, hi, tol, ang_tol, max_evals):
    """Pattern search over the two tangent lengths of cubic c (end points and tangent
    directions fixed) for the smallest :func:`_score`; stops as soon as it is <= 1.
    Starts from c (in place); returns the best score."""
    p0x, p0y, p3x, p3y = c[0, 0], c[0, 1], c[3, 0], c[3, 1]
    t0x, t0y = c[1, 0] - p0x, c[1, 1] - p0y
    t3x, t3y = c[2, 0] - p3x, c[2, 1] - p3y
    n0 = math.hypot(t0x, t0y)
    n3 = math.hypot(t3x, t3y)
    chord = math.hypot(p3x - p0x, p3y - p0y)
    if n0 <= 0 or n3 <= 0 or chord <= 0:
        return 1e300
    t0x, t0y, t3x, t3y = t0x / n0, t0y / n0, t3x / n3, t3y / n3
    la, lb = math.log(n0), math.log(n3)
    f0 = _score(c, u, q, g, lo, hi, tol, ang_tol, 1e300)
    evals = 0
    trial = np.empty((4, 2))
    _copy4(trial, c)
    step = 0.25
    while f0 > 1.0 and step > 1e-3 and evals < max_evals:
        moved = False
        for k in range(8):
            da = (1.0, -1.0, 0.0, 0.0, 1.0, -1.0, 1.0, -1.0)[k] * step
            db = (0.0, 0.0, 1.0, -1.0, 1.0, -1.0, -1.0, 1.0)[k] * step
            al, be = math.exp(la + da), math.exp(lb + db)
            if al > 4.0 * chord or be > 4.0 * chord:
                continue
            trial[1, 0], trial[1, 1] = p0x + al * t0x, p0y + al * t0y
            trial[2, 0], trial[2, 1] = p3x + be * t3x, p3y + be * t3y
            f = _score(trial, u, q, g, lo, hi, tol, ang_tol, f0)
            evals += 1
            if f < f0:
                f0 = f
                la += da
                lb += db
                _copy4(c, trial)
                moved = True
                break
        if not moved:
            step *= 0.5
    return f0


@njit(cache=True)
def _try_span(order, q, g, t, a, b, tol, cos_tol, ang_tol, tsx, tsy, us, tex, tey, ue, c, u, best):
    """Fit samples [a, b) (ends included) with one piece: a line (source lines), a
    quadratic, else a cubic with the exact end tangents (Hermite, then least squares with
    reparametrisation, then a search over the tangent lengths). Returns the order of the
    piece that fits (control points in ``c``; a quadratic's control point in row 1; ``order``
    1 allows a line, for a whole source line) or 0
    when none does (the closest cubic then in ``best``); -1 for a zero-length span."""
    m = b - a
    p0x, p0y = q[a, 0], q[a, 1]
    p3x, p3y = q[b - 1, 0], q[b - 1, 1]
    ext = 0.0
    big = 0.0
    for i in range(a, b):
        ext = max(ext, math.hypot(q[i, 0] - p0x, q[i, 1] - p0y))
        big = max(big, abs(q[i, 0]), abs(q[i, 1]))
    if ext <= 1e-12 * (1.0 + big):
        return -1
    chord = math.hypot(p3x - p0x, p3y - p0y)
    if order == 1 and chord > 0 and _line_fits(q, g, a, b, tol, cos_tol):
        c[0, 0], c[0, 1] = p0x, p0y
        for r in range(1, 4):
            c[r, 0], c[r, 1] = p3x, p3y
        return 1
    span = t[b - 1] - t[a]
    for i in range(a, b):
        u[i - a] = (t[i] - t[a]) / span if span > 0 else (i - a) / max(1, m - 1)
    d0x, d0y = g[a, 0] * span, g[a, 1] * span
    d3x, d3y = g[b - 1, 0] * span, g[b - 1, 1] * span
    n0 = math.hypot(d0x, d0y)
    n3 = math.hypot(d3x, d3y)
    if us == 1:
        d0x, d0y = tsx * n0, tsy * n0
    if ue == 1:
        d3x, d3y = tex * n3, tey * n3
    if n0 <= 1e-300:  # degenerate derivative: direction to the next sample
        d0x, d0y = q[a + 1, 0] - p0x, q[a + 1, 1] - p0y
        n0 = math.hypot(d0x, d0y)
    if n3 <= 1e-300:
        d3x, d3y = p3x - q[b - 2, 0], p3y - q[b - 2, 1]
        n3 = math.hypot(d3x, d3y)
    if n0 <= 1e-300 or n3 <= 1e-300:
        c[0, 0], c[0, 1] = p0x, p0y
        for r in range(1, 4):
            c[r, 0], c[r, 1] = p3x, p3y
        return 1
    t0x, t0y, t3x, t3y = d0x / n0, d0y / n0, d3x / n3, d3y / n3
    # a quadratic when one fits (fewer numbers): control point where the end tangents meet
    det = t0x * t3y - t3x * t0y  # p0 + al·t0 = p3 - be·t3
    if abs(det) > 1e-9:
        vx, vy = p3x - p0x, p3y - p0y
        al = (vx * t3y - t3x * vy) / det
        be = (t0x * vy - t0y * vx) / det
        if al > 1.5 * ARM_MIN * chord and be > 1.5 * ARM_MIN * chord and al < 4 * chord and be < 4 * chord:
            cx, cy = p0x + al * t0x, p0y + al * t0y
            c[0, 0], c[0, 1] = p0x, p0y
            c[1, 0], c[1, 1] = p0x + 2.0 / 3.0 * (cx - p0x), p0y + 2.0 / 3.0 * (cy - p0y)
            c[2, 0], c[2, 1] = p3x + 2.0 / 3.0 * (cx - p3x), p3y + 2.0 / 3.0 * (cy - p3y)
            c[3, 0], c[3, 1] = p3x, p3y
            err = _max_error(c, u, q, a, b, 1e300)
            if not _forward(c, u, g, a, b, cos_tol):
                err = 1e300
            if err <= tol:
                c[1, 0], c[1, 1] = cx, cy
                return 2
            for i in range(a, b):
                u[i - a] = (t[i] - t[a]) / span if span > 0 else (i - a) / max(1, m - 1)
    # cubic Hermite with the exact end derivatives
    c[0, 0], c[0, 1] = p0x, p0y
    c[1, 0], c[1, 1] = p0x + d0x / 3.0, p0y + d0y / 3.0
    c[2, 0], c[2, 1] = p3x - d3x / 3.0, p3y - d3y / 3.0
    c[3, 0], c[3, 1] = p3x, p3y
    score = _score(c, u, q, g, a, b, tol, ang_tol, SEARCH_FROM)
    if score <= 1.0:
        return 3
    _copy4(best, c)
    best_score = score
    # least squares, same tangent directions, refined parameters; starting from the
    # chord-length parameters (the segment parameter's speed can differ along a span,
    # most across the joints of a run)
    total = 0.0
    u[0] = 0.0
    for i in range(a + 1, b):
        total += math.hypot(q[i, 0] - q[i - 1, 0], q[i, 1] - q[i - 1, 1])
        u[i - a] = total
    for i in range(a, b):
        u[i - a] = u[i - a] / total if total > 0 else (i - a) / max(1, m - 1)
    for _ in range(LSQ_ITERATIONS):
        _lsq(q, u, a, b, c)
        score = _score(c, u, q, g, a, b, tol, ang_tol, SEARCH_FROM)
        if score <= 1.0:
            return 3
        if score < best_score:
            _copy4(best, c)
            best_score = score
    # the least-squares cubic minimises the mean error, not the largest one: search the
    # two tangent lengths for one within the distance and angle tolerances
    if best_score <= SEARCH_FROM:
        _copy4(c, best)
        if _search(c, u, q, g, a, b, tol, ang_tol, SEARCH_EVALS) <= 1.0:
            return 3
    return 0


@njit(cache=True)
def _emit(kind, c, out_o, out_c, n_out):
    out_o[n_out] = 3 if kind == 0 else kind
    _copy4(out_c[n_out], c)
    if kind == 2:  # quadratic: rows p0, control, p2, p2
        out_c[n_out, 3, 0], out_c[n_out, 3, 1] = c[3, 0], c[3, 1]
        out_c[n_out, 2, 0], out_c[n_out, 2, 1] = c[3, 0], c[3, 1]


@njit(cache=True)
def _fit_piece(order, q, g, t, lo, hi, tol, cos_tol, tsx, tsy, use_ts, tex, tey, use_te, out_o, out_c,
               count):
    """Fit samples [lo, hi) (ends included); appends pieces at ``count[0]`` and advances it.

    One piece when one fits; otherwise greedy from the start: the longest span of samples
    that one piece fits (binary search over its end sample), then the rest the same way.
    Joints fall on samples and take the exact mapped tangent there.

    The count lives in a one-element array, not an int argument: the caller's first call
    would pass the literal 0 and numba would compile this function twice (``Literal[int]``
    and ``int64``), a second of the first run's compilation. For the same reason the
    constant arguments below are typed ``np.int64``."""
    cubic, off = np.int64(3), np.int64(0)
    n_out = count[0]
    ang_tol = math.acos(min(1.0, max(-1.0, cos_tol)))
    c = np.empty((4, 2))
    best = np.empty((4, 2))
    keep = np.empty((4, 2))
    u = np.empty(hi - lo)
    a = lo
    while a < hi - 1:
        us = use_ts if a == lo else 0
        kind = _try_span(order if a == lo else cubic, q, g, t, a, hi, tol, cos_tol, ang_tol, tsx, tsy, us, tex,
                         tey, use_te, c, u, best)
        if kind != 0:
            if kind > 0:
                _emit(kind, c, out_o, out_c, n_out)
                n_out += 1
            break
        # longest fitting span [a, e] with a < e < hi - 1; [a, a + 1] always counts as fitting
        good, bad = a + 1, hi - 1
        kg = 3
        _copy4(keep, best)
        have = False
        while bad - good > 1:
            mid = (good + bad) // 2
            k = _try_span(cubic, q, g, t, a, mid + 1, tol, cos_tol, ang_tol, tsx, tsy, us, 0.0, 0.0, off,
                          c, u, best)
            if k != 0:
                good = mid
                kg = k
                _copy4(keep, c)
                have = True
            else:
                bad = mid
        if not have:  # two neighbouring samples: the cubic with their exact tangents
            k = _try_span(cubic, q, g, t, a, good + 1, tol, cos_tol, ang_tol, tsx, tsy, us, 0.0, 0.0, off,
                          c, u, best)
            kg = k
            _copy4(keep, c if k != 0 else best)
        if kg >= 0:
            _emit(kg, keep, out_o, out_c, n_out)
            n_out += 1
        a = good
    count[0] = n_out


@njit(cache=True, nogil=True)
def _fit_chain(order, seg_start, closed, q, g, t, tol, cos_tol, snap):
    n = len(order)
    straight = np.zeros(n, np.bool_)
    for k in range(n):
        if order[k] == 1:
            a, b = seg_start[k], seg_start[k + 1]
            if math.hypot(q[b - 1, 0] - q[a, 0], q[b - 1, 1] - q[a, 1]) > 0:
                straight[k] = _line_fits(q, g, a, b, tol, cos_tol)
    ts = np.zeros((n, 2))
    te = np.zeros((n, 2))
    use_ts = np.zeros(n, np.int64)
    use_te = np.zeros(n, np.int64)
    cos_snap = math.cos(snap)
    for k in range(n):
        if not straight[k]:
            continue
        a, b = seg_start[k], seg_start[k + 1]
        dx, dy = q[b - 1, 0] - q[a, 0], q[b - 1, 1] - q[a, 1]
        nd = math.hypot(dx, dy)
        dx, dy = dx / nd, dy / nd
        if k > 0 or closed:
            j = (k - 1) % n
            if not straight[j]:
                e = seg_start[j + 1] - 1
                gn = math.hypot(g[e, 0], g[e, 1])
                if gn > 0 and (g[e, 0] * dx + g[e, 1] * dy) / gn > cos_snap:
                    te[j, 0], te[j, 1] = dx, dy
                    use_te[j] = 1
        if k < n - 1 or closed:
            j = (k + 1) % n
            if not straight[j]:
                s = seg_start[j]
                gn = math.hypot(g[s, 0], g[s, 1])
                if gn > 0 and (g[s, 0] * dx + g[s, 1] * dy) / gn > cos_snap:
                    ts[j, 0], ts[j, 1] = dx, dy
                    use_ts[j] = 1
    cap = 0
    for k in range(n):
        cap += max(1, seg_start[k + 1] - seg_start[k])
    out_o = np.empty(cap, np.int8)
    out_c = np.empty((cap, 4, 2))
    count = np.zeros(1, np.int64)
    # a parameter running along the whole chain (segment k spans [k, k + 1])
    tc = np.empty(len(t))
    for k in range(n):
        for i in range(seg_start[k], seg_start[k + 1]):
            tc[i] = k + t[i]
    ang_tol = math.acos(min(1.0, max(-1.0, cos_tol)))
    c = np.empty((4, 2))
    best = np.empty((4, 2))
    u = np.empty(len(t))
    kind = 0
    k = 0
    while k < n:
        # a run: curved segments meeting at smooth joints (mapped tangents within the snap
        # angle; never across a corner, a kept straight line or the start of the chain)
        j = k
        while j + 1 < n and not straight[j] and not straight[j + 1]:
            e, s = seg_start[j + 1] - 1, seg_start[j + 1]
            gn = math.hypot(g[e, 0], g[e, 1]) * math.hypot(g[s, 0], g[s, 1])
            if not (gn > 0 and (g[e, 0] * g[s, 0] + g[e, 1] * g[s, 1]) > cos_snap * gn):
                break
            j += 1
        if j == k:
            _fit_piece(order[k], q, g, tc, seg_start[k], seg_start[k + 1], tol, cos_tol,
                       ts[k, 0], ts[k, 1], use_ts[k], te[k, 0], te[k, 1], use_te[k], out_o, out_c, count)
        else:
            # each segment of the run in one piece, as in the source, when every one fits;
            # else the run as a whole, joints wherever they are needed
            n0 = count[0]
            for i in range(k, j + 1):
                kind = _try_span(order[i], q, g, tc, seg_start[i], seg_start[i + 1], tol, cos_tol, ang_tol,
                                 ts[i, 0], ts[i, 1], use_ts[i], te[i, 0], te[i, 1], use_te[i], c, u, best)
                if kind == 0:
                    break
                if kind > 0:
                    _emit(kind, c, out_o, out_c, count[0])
                    count[0] += 1
            if kind == 0:
                count[0] = n0
                _fit_piece(np.int64(3), q, g, tc, seg_start[k], seg_start[j + 1], tol, cos_tol,
                           ts[k, 0], ts[k, 1], use_ts[k], te[j, 0], te[j, 1], use_te[j], out_o, out_c, count)
        k = j + 1
    n_out = count[0]
    return out_o[:n_out], out_c[:n_out]


def fit_subpath(order: np.ndarray, seg_start: np.ndarray, closed: bool, q: np.ndarray,
                g: np.ndarray, t: np.ndarray, tol: float, angle_tol: float = 1.0) -> CurveSubpath | None:
    """Fit every segment of one mapped subpath; returns the written curves (or None).

    ``order`` (n,) source segment orders, ``seg_start`` (n + 1,) sample ranges into the
    mapped samples ``q`` (P, 2) with derivatives ``g`` (P, 2) (d/dt) at segment
    parameters ``t`` (P,) (see ``MapPlan``); ``tol`` the largest distance allowed,
    ``angle_tol`` (degrees) the largest angle between the fitted and the exact curve's
    direction at any sample.
    """
    orders, ctrl = _fit_chain(np.asarray(order, np.int64), np.asarray(seg_start, np.int64),
                              bool(closed), np.ascontiguousarray(q, dtype=float),
                              np.ascontiguousarray(g, dtype=float), np.ascontiguousarray(t, dtype=float),
                              float(tol), math.cos(math.radians(angle_tol)), SNAP_ANGLE)
    if len(orders) == 0:
        return None
    ctrl = ctrl.copy()
    for k in range(1, len(ctrl)):  # exact joints
        ctrl[k, 0] = ctrl[k - 1, orders[k - 1]]
    if closed:
        ctrl[-1, orders[-1]:] = ctrl[0, 0]
    for k in range(len(ctrl)):  # unused rows repeat the end point
        ctrl[k, orders[k] + 1:] = ctrl[k, orders[k]]
    return CurveSubpath(orders, ctrl, bool(closed))
