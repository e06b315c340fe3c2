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


def _path_data_py(curves: Sequence[CurveSubpath], decimals: int, relative: bool) -> str:
    """:func:`path_data` one segment at a time in Python: the reference the kernel
    (:func:`_path_bytes`) matches, and the writer of coordinates too large for it."""
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


@njit(cache=True, nogil=True)
def _put_units(buf, k, i, scale, decimals):
    """Write the number ``i`` units of the last decimal (:func:`_nums`' text) at
    ``buf[k:]``; returns the index after it."""
    if i == 0:
        buf[k] = 48
        return k + 1
    a = i
    if i < 0:
        buf[k] = 45
        k += 1
        a = -i
    whole = a // scale
    frac = a - whole * scale
    if whole > 0:
        n = 0
        w = whole
        while w > 0:
            n += 1
            w //= 10
        w = whole
        for j in range(n - 1, -1, -1):
            buf[k + j] = 48 + w % 10
            w //= 10
        k += n
    if frac > 0:
        buf[k] = 46
        k += 1
        digits = decimals
        while frac % 10 == 0:  # trailing zeros dropped
            frac //= 10
            digits -= 1
        for j in range(digits - 1, -1, -1):
            buf[k + j] = 48 + frac % 10
            frac //= 10
        k += digits
    return k


@njit(cache=True, nogil=True)
def _put_numbers(buf, k, units, count, first_sep, scale, decimals):
    """Write ``units[:count]`` as :func:`_join` does; ``first_sep``: whether the first
    number needs its separator (a space unless it starts with '-'). Returns the index
    after them."""
    prev_dot = False
    for j in range(count):
        i = units[j]
        starts_minus = i < 0
        starts_dot = 0 < i < scale  # ".5": no whole part
        if j > 0:
            if not (starts_minus or (starts_dot and prev_dot)):
                buf[k] = 32
                k += 1
        elif first_sep and not starts_minus:
            buf[k] = 32
            k += 1
        k = _put_units(buf, k, i, scale, decimals)
        prev_dot = abs(i) % scale != 0
    return k


@njit(cache=True, nogil=True)
def _path_bytes(ctrl, order, first, closed, relative, decimals):
    """:func:`path_data` of subpaths whose segments are ``ctrl`` (N, 4, 2), rounded to
    ``decimals`` already, and ``order`` (N,); subpath s has segments
    ``first[s]:first[s + 1]``, closed where ``closed[s]``. Returns the ASCII bytes."""
    n_seg = order.shape[0]
    n_sub = closed.shape[0]
    scale = 1
    for _ in range(decimals):
        scale *= 10
    fscale = float(scale)
    buf = np.empty((n_seg * 6 + n_sub * 2) * 26 + n_sub * 2 + 16, np.uint8)
    units = np.empty(6, np.int64)
    k = 0
    last = 0  # the last command written (0: none)
    cx = 0.0
    cy = 0.0
    for s in range(n_sub):
        a = first[s]
        b = first[s + 1]
        sx = ctrl[a, 0, 0]
        sy = ctrl[a, 0, 1]
        rel = relative and s > 0
        if rel:
            units[0] = np.int64(np.rint((sx - cx) * fscale))
            units[1] = np.int64(np.rint((sy - cy) * fscale))
            buf[k] = 109  # m
        else:
            units[0] = np.int64(np.rint(sx * fscale))
            units[1] = np.int64(np.rint(sy * fscale))
            buf[k] = 77  # M
        k = _put_numbers(buf, k + 1, units, 2, False, scale, decimals)
        last = 108 if rel else 76  # an implicit l after a move
        cx = sx
        cy = sy
        n = b - a
        if closed[s] and n > 1 and order[b - 1] == 1 and ctrl[b - 1, 1, 0] == sx and ctrl[b - 1, 1, 1] == sy:
            n -= 1
        px = sx
        py = sy
        for t in range(a, a + n):
            o = order[t]
            ox = px if relative else 0.0
            oy = py if relative else 0.0
            count = 2 * o  # the numbers written: 1 for h / v, 2 for l, 4 for q, 6 for c
            if o == 1:
                dx = ctrl[t, 1, 0] - px
                dy = ctrl[t, 1, 1] - py
                if dy == 0 and dx != 0:
                    cmd = 104  # h
                    units[0] = np.int64(np.rint((ctrl[t, 1, 0] - ox) * fscale))
                    count = 1
                elif dx == 0 and dy != 0:
                    cmd = 118  # v
                    units[0] = np.int64(np.rint((ctrl[t, 1, 1] - oy) * fscale))
                    count = 1
                elif dx == 0 and dy == 0:
                    continue
                else:
                    cmd = 108  # l
                    units[0] = np.int64(np.rint((ctrl[t, 1, 0] - ox) * fscale))
                    units[1] = np.int64(np.rint((ctrl[t, 1, 1] - oy) * fscale))
            else:
                cmd = 113 if o == 2 else 99  # q, c
                for j in range(o):
                    units[2 * j] = np.int64(np.rint((ctrl[t, 1 + j, 0] - ox) * fscale))
                    units[2 * j + 1] = np.int64(np.rint((ctrl[t, 1 + j, 1] - oy) * fscale))
            if not relative:
                cmd -= 32
            if cmd == last:
                k = _put_numbers(buf, k, units, count, True, scale, decimals)
            else:
                buf[k] = cmd
                k = _put_numbers(buf, k + 1, units, count, False, scale, decimals)
            last = cmd
            px = ctrl[t, o, 0]
            py = ctrl[t, o, 1]
        if n > 0:
            cx = px
            cy = py
        if closed[s]:
            buf[k] = 122  # z
            k += 1
            last = 0
            cx = sx
            cy = sy
    return buf[:k]


def path_data(curves: Sequence[CurveSubpath], decimals: int = 4, relative: bool = True) -> str:
    """Compact SVG path data of curve subpaths (coordinates rounded to ``decimals``).

    Relative commands are computed from the rounded absolute coordinates, so they add up
    exactly to the rounded curve (no drift). A closed subpath's final line back to its
    start becomes ``z``.

    Notes
    -----
    One kernel call writes the whole path (:func:`_path_bytes`): the writer formats every
    coordinate of every copy, and one segment at a time in Python that was most of the SVG
    writing. Coordinates whose units of the last decimal a double no longer holds exactly
    are written by the reference implementation, :func:`_path_data_py` (the same text
    elsewhere, ``tests/test_render_curves.py``).
    """
    if not curves:
        return ""
    ctrl = np.round(np.concatenate([np.asarray(c.ctrl, dtype=np.float64) for c in curves]), decimals)
    # a difference of two coordinates is at most twice the largest in units
    if not (2.0 * np.abs(ctrl).max(initial=0.0) * 10 ** decimals < _EXACT_UNITS) or not all(
            len(c.order) for c in curves):
        return _path_data_py(curves, decimals, relative)
    order = np.concatenate([np.asarray(c.order, dtype=np.int64) for c in curves])
    first = np.zeros(len(curves) + 1, np.int64)
    np.cumsum([len(c.order) for c in curves], out=first[1:])
    closed = np.array([bool(c.closed) for c in curves])
    return _path_bytes(ctrl, order, first, closed, bool(relative), int(decimals)).tobytes().decode("ascii")


def segment_count(curves: Sequence[CurveSubpath]) -> dict[str, int]:
    """Number of written segments by kind: ``{"line": .., "quadratic": .., "cubic": ..}``."""
    o = np.concatenate([c.order for c in curves]) if curves else np.zeros(0, int)
    return {"line": int((o == 1).sum()), "quadratic": int((o == 2).sum()), "cubic": int((o == 3).sum())}
