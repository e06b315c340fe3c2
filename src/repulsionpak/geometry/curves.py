"""Bézier segments as arrays: evaluation, derivatives, flattening, SVG path data.

A chain of segments is a :class:`~repulsionpak.types.CurveSubpath`: ``order`` (n,) with
1 = line, 2 = quadratic, 3 = cubic and ``ctrl`` (n, 4, 2) control points (unused rows
repeat the end point).

Notes
-----
The reader (``io``: an element's source curves, thinning traced art) and the writers
(``render``) both work on these curves, so they are geometry, below both.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numba import njit

from ..types import CurveSubpath

__all__ = ["as_cubics", "bezier", "bezier_deriv", "cubic_points", "decimals_for", "flatten_subpath", "path_data",
           "round_curves", "segment_count"]


def bezier(ctrl: np.ndarray, order: int, t: np.ndarray) -> np.ndarray:
    """Points (m, 2) of one segment ``ctrl`` (4, 2) of ``order`` at parameters ``t`` (m,)."""
    t = np.asarray(t, dtype=float)[:, None]
    s = 1.0 - t
    p = ctrl
    if order == 1:
        return s * p[0] + t * p[1]
    if order == 2:
        return s * s * p[0] + 2 * s * t * p[1] + t * t * p[2]
    return s**3 * p[0] + 3 * s * s * t * p[1] + 3 * s * t * t * p[2] + t**3 * p[3]


def bezier_deriv(ctrl: np.ndarray, order: int, t: np.ndarray) -> np.ndarray:
    """Derivatives d/dt (m, 2) of one segment at parameters ``t`` (m,)."""
    t = np.asarray(t, dtype=float)[:, None]
    s = 1.0 - t
    p = ctrl
    if order == 1:
        return np.broadcast_to(p[1] - p[0], (len(t), 2)).copy()
    if order == 2:
        return 2 * s * (p[1] - p[0]) + 2 * t * (p[2] - p[1])
    return 3 * s * s * (p[1] - p[0]) + 6 * s * t * (p[2] - p[1]) + 3 * t * t * (p[3] - p[2])


def as_cubics(order: np.ndarray, ctrl: np.ndarray) -> np.ndarray:
    """Segments ``order`` (n,), ``ctrl`` (n, 4, 2) as cubic control points (n, 4, 2), the
    same curves with the same parametrisation (lines and quadratics degree-elevated
    exactly)."""
    c = np.array(ctrl, dtype=float)
    q = order == 2
    c[q, 1] = ctrl[q, 0] + 2.0 / 3.0 * (ctrl[q, 1] - ctrl[q, 0])
    c[q, 2] = ctrl[q, 2] + 2.0 / 3.0 * (ctrl[q, 1] - ctrl[q, 2])
    c[q, 3] = ctrl[q, 2]
    ln = order == 1
    c[ln, 1] = ctrl[ln, 0] + (ctrl[ln, 1] - ctrl[ln, 0]) / 3.0
    c[ln, 2] = ctrl[ln, 0] + 2.0 * (ctrl[ln, 1] - ctrl[ln, 0]) / 3.0
    c[ln, 3] = ctrl[ln, 1]
    return c


def cubic_points(c: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points and derivatives d/dt (m, 2) of cubics ``c`` (m, 4, 2), each at its own
    parameter ``t`` (m,)."""
    t = np.asarray(t, dtype=float)[:, None]
    s = 1.0 - t
    pts = s**3 * c[:, 0] + 3 * s * s * t * c[:, 1] + 3 * s * t * t * c[:, 2] + t**3 * c[:, 3]
    der = 3 * s * s * (c[:, 1] - c[:, 0]) + 6 * s * t * (c[:, 2] - c[:, 1]) + 3 * t * t * (c[:, 3] - c[:, 2])
    return pts, der


@njit(cache=True, nogil=True)
def _flatten(order, ctrl, tol, closed):
    """Points of every segment, uniform pieces with chord error <= tol (h²/8 · max|B''|),
    without repeated points (:func:`_distinct`)."""
    n = len(order)
    counts = np.ones(n, np.int64)
    for k in range(n):
        c = ctrl[k]
        if order[k] == 2:
            bound = 2.0 * math.hypot(c[0, 0] - 2 * c[1, 0] + c[2, 0], c[0, 1] - 2 * c[1, 1] + c[2, 1])
        elif order[k] == 3:
            bound = 6.0 * max(math.hypot(c[0, 0] - 2 * c[1, 0] + c[2, 0], c[0, 1] - 2 * c[1, 1] + c[2, 1]),
                              math.hypot(c[1, 0] - 2 * c[2, 0] + c[3, 0], c[1, 1] - 2 * c[2, 1] + c[3, 1]))
        else:
            bound = 0.0
        if bound > 0:
            counts[k] = max(1, min(4096, int(math.ceil(math.sqrt(bound / (8.0 * tol))))))
    total = 1  # a loop, not counts.sum(): loading a kernel that calls it imports scipy (0.2 s)
    for k in range(n):
        total += counts[k]
    out = np.empty((total, 2))
    out[0, 0], out[0, 1] = ctrl[0, 0, 0], ctrl[0, 0, 1]  # scalars: a row assignment compiles slowly
    j = 1
    for k in range(n):
        c = ctrl[k]
        m = counts[k]
        for i in range(1, m + 1):
            t = i / m
            s = 1.0 - t
            if order[k] == 1:
                x, y = s * c[0, 0] + t * c[1, 0], s * c[0, 1] + t * c[1, 1]
            elif order[k] == 2:
                x = s * s * c[0, 0] + 2 * s * t * c[1, 0] + t * t * c[2, 0]
                y = s * s * c[0, 1] + 2 * s * t * c[1, 1] + t * t * c[2, 1]
            else:
                x = s * s * s * c[0, 0] + 3 * s * s * t * c[1, 0] + 3 * s * t * t * c[2, 0] + t * t * t * c[3, 0]
                y = s * s * s * c[0, 1] + 3 * s * s * t * c[1, 1] + 3 * s * t * t * c[2, 1] + t * t * t * c[3, 1]
            out[j, 0], out[j, 1] = x, y
            j += 1
    return _distinct(out, closed)


@njit(cache=True)
def _chebyshev(dx, dy):
    """``max(|dx|, |dy|)`` as numpy takes it: NaN if either is (Python's ``max`` would
    drop it), so that no comparison with it holds."""
    if math.isnan(dx) or math.isnan(dy):
        return math.nan
    return max(abs(dx), abs(dy))


@njit(cache=True)
def _distinct(out, closed):
    """``out`` (K, 2) without the points within eps = 1e-12 · (1 + max |coordinate|) of the
    one before them in x and y, nor, ``closed``, a last point so close to the first (when
    more than two are left); a new array. The coordinates' maximum as numpy's (NaN if
    any is): no point is then kept after the first."""
    top = 0.0
    for v in out.ravel():
        if math.isnan(v) or abs(v) > top:
            top = abs(v)
            if math.isnan(v):
                break
    eps = 1e-12 * (1.0 + top)
    keep = np.empty(len(out), np.bool_)
    n = 0
    for i in range(len(out)):
        keep[i] = i == 0 or _chebyshev(out[i, 0] - out[i - 1, 0], out[i, 1] - out[i - 1, 1]) > eps
        if keep[i]:
            n += 1
    res = np.empty((n, 2))
    k = 0
    for i in range(len(out)):
        if keep[i]:
            res[k, 0], res[k, 1] = out[i, 0], out[i, 1]
            k += 1
    if closed and n > 2 and _chebyshev(res[n - 1, 0] - res[0, 0], res[n - 1, 1] - res[0, 1]) <= eps:
        res = res[:n - 1].copy()
    return res


def flatten_subpath(sub: CurveSubpath, tol: float) -> np.ndarray:
    """Polyline (K, 2) within ``tol`` of the curves; no repeated points or closing point.

    Notes
    -----
    One kernel call flattens and drops the repeated points: the writer flattens every
    written subpath (a 1,000-element poster: 40,000), and the numpy steps of the
    dropping cost four times the flattening itself. The same points
    (``tests/test_render_curves.py``)."""
    return _flatten(sub.order.astype(np.int64), np.ascontiguousarray(sub.ctrl), float(tol), bool(sub.closed))


def decimals_for(tol: float) -> int:
    """Decimals of written coordinates: rounding moves a control point (and so the
    curve) by at most tol/5 (half a unit of the last decimal, in x and y)."""
    if not (tol > 0 and math.isfinite(tol)):
        return 4
    return int(min(8, max(0, math.ceil(-math.log10(tol / 5.0 / math.sqrt(0.5))))))


def round_curves(curves: Sequence[CurveSubpath], decimals: int) -> tuple[CurveSubpath, ...]:
    """The curves with every control point rounded as it is written."""
    return tuple(CurveSubpath(c.order, np.round(c.ctrl, decimals), c.closed) for c in curves)


def _num(x: float, decimals: int) -> str:
    s = f"{x:.{decimals}f}"
    if "." in s:
        s = s.rstrip("0").rstrip(".")
    if s.startswith("0."):
        s = s[1:]
    elif s.startswith("-0."):
        s = "-" + s[2:]
    return "0" if s in ("", "-0", "-") else s


#: beyond this many units of the last decimal a double no longer holds every decimal
#: exactly: such numbers are formatted one by one (:func:`_num`)
_EXACT_UNITS = 2.0 ** 50


def _nums(values: np.ndarray, decimals: int) -> list[str]:
    """:func:`_num` of every value (flattened), from integer units of the last decimal:
    the same strings, several times faster. The values are rounded to ``decimals``
    already (or differences of such), so ``values · 10^decimals`` is an integer up to
    rounding far below ½ and the two ways agree."""
    flat = np.asarray(values, dtype=np.float64).ravel()
    scale = 10 ** decimals
    units = flat * scale
    if not (np.abs(units).max(initial=0.0) < _EXACT_UNITS):
        return [_num(float(x), decimals) for x in flat]
    out = []
    append = out.append
    for i in np.rint(units).astype(np.int64).tolist():
        if i == 0:
            append("0")
            continue
        a = -i if i < 0 else i
        whole, frac = divmod(a, scale)
        if frac:
            text = (str(whole) if whole else "") + "." + str(frac).rjust(decimals, "0").rstrip("0")
        else:
            text = str(whole)
        append("-" + text if i < 0 else text)
    return out


def _join(nums: list[str]) -> str:
    """Numbers with the fewest separators SVG allows."""
    out = []
    prev = ""
    for s in nums:
        if out and not (s.startswith("-") or (s.startswith(".") and "." in prev)):
            out.append(" ")
        out.append(s)
        prev = s
    return "".join(out)


def path_data(curves: Sequence[CurveSubpath], decimals: int = 4, relative: bool = True) -> str:
    """Compact SVG path data of curve subpaths (coordinates rounded to ``decimals``).

    Relative commands are computed from the rounded absolute coordinates, so they add up
    exactly to the rounded curve (no drift). A closed subpath's final line back to its
    start becomes ``z``.
    """
    parts: list[str] = []
    cur = np.zeros(2)
    last_cmd = ""
    for sub in curves:
        ctrl = np.round(sub.ctrl, decimals)
        order = np.asarray(sub.order)
        start = ctrl[0, 0]
        rel = relative and bool(parts)
        p = start - cur if rel else start
        parts.append(("m" if rel else "M") + _join(_nums(p, decimals)))
        last_cmd = "l" if rel else "L"  # implicit command after a move
        cur = start
        n = len(order)
        if sub.closed and n > 1 and order[-1] == 1 and np.abs(ctrl[-1, 1] - start).max() == 0:
            n -= 1
        if n > 0:
            # all segments at once: each starts where the one before ends
            ends = ctrl[np.arange(n), order[:n]]
            starts = np.concatenate([start[None, :], ends[:-1]])
            step = (ctrl[:n, 1] - starts).tolist()  # a line's move (h / v / l / skip)
            # every number of the subpath at once: segment k's at text[6k : 6k + 2·order]
            text = _nums(ctrl[:n, 1:] - (starts[:, None, :] if relative else 0.0), decimals)
            for k, o in enumerate(order[:n].tolist()):
                at = 6 * k
                if o == 1:
                    dx, dy = step[k]
                    if dy == 0 and dx != 0:
                        cmd, nums = "h", text[at:at + 1]
                    elif dx == 0 and dy != 0:
                        cmd, nums = "v", text[at + 1:at + 2]
                    elif dx == 0 and dy == 0:
                        continue
                    else:
                        cmd, nums = "l", text[at:at + 2]
                else:
                    cmd = "q" if o == 2 else "c"
                    nums = text[at:at + 2 * o]
                if not relative:
                    cmd = cmd.upper()
                body = _join(nums)
                if cmd == last_cmd:
                    parts.append(("" if body.startswith("-") else " ") + body)
                else:
                    parts.append(cmd + body)
                last_cmd = cmd
            cur = ends[n - 1]
        if sub.closed:
            parts.append("z")
            last_cmd = ""
            cur = start
    return "".join(parts)


def segment_count(curves: Sequence[CurveSubpath]) -> dict[str, int]:
    """Number of written segments by kind: ``{"line": .., "quadratic": .., "cubic": ..}``."""
    o = np.concatenate([c.order for c in curves]) if curves else np.zeros(0, int)
    return {"line": int((o == 1).sum()), "quadratic": int((o == 2).sum()), "cubic": int((o == 3).sum())}
