"""Measures of the written curves: deviation from the exact map, kinks, curve share.

Used by the tests and by ``benchmarks/output_curves.py`` (numbers in docs/quality.md).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely

from ..params import RenderParams
from ..types import ArtPath
from ..geometry.curves import bezier, flatten_subpath
from .deform import art_curves, linear_weights, tps_weights

__all__ = ["curve_share", "dense_polyline", "deviation", "exact_outlines", "kink_stats", "turning_angles"]


def exact_outlines(template, verts: np.ndarray, smooth: bool = True,
                   per_segment: int = 96, smoothing: float | None = None) -> list[list[np.ndarray]]:
    """The art of one copy mapped exactly: per art path, per subpath, ``per_segment``
    samples of every source segment mapped through the deformation (container units);
    ``smoothing``: the map's λ (default: the renderer's, ``RenderParams().smoothing``)."""
    if smoothing is None:
        smoothing = RenderParams().smoothing
    s, c = template.scale, template.outline.center
    rest = np.array([[s, 0.0, -s * c[0]], [0.0, s, -s * c[1]], [0.0, 0.0, 1.0]])
    t = np.arange(per_segment) / per_segment
    chunks, index = [], []
    for a, art in enumerate(template.element.paths):
        for k, sub in enumerate(art_curves(art)):
            sub = sub.transformed(rest)
            pts = np.concatenate([bezier(cc, int(o), t) for o, cc in zip(sub.order, sub.ctrl)]
                                 + [sub.ctrl[-1, int(sub.order[-1])][None]])
            chunks.append(pts)
            index.append((a, k, sub.closed))
    if not chunks:
        return []
    allp = np.concatenate(chunks)
    if smooth:
        W, _ = tps_weights(template.verts, allp, smoothing=smoothing)
    else:
        W, _ = linear_weights(template.verts, template.tris, allp)
    mapped = W @ verts
    out: list[list[np.ndarray]] = [[] for _ in template.element.paths]
    i = 0
    for (a, _, closed), ch in zip(index, chunks):
        out[a].append(mapped[i:i + len(ch)])
        i += len(ch)
    return out


def _written_lines(art: ArtPath, tol: float) -> list[np.ndarray]:
    if art.source is not None and art.source.curves:
        lines = []
        for c in art.source.curves:
            p = flatten_subpath(c, tol)
            lines.append(np.vstack([p, p[:1]]) if c.closed else p)
        return lines
    return [np.vstack([p, p[:1]]) if cl else np.asarray(p) for p, cl in zip(art.subpaths, art.closed)]


def deviation(written: Sequence[ArtPath], exact: list[list[np.ndarray]], tol: float) -> float:
    """Largest distance between the written curves (flattened to ``tol``/100) and the exact
    mapped outline, both ways (a Hausdorff distance over all paths of one copy).

    ``written`` and ``exact`` must list the same paths and subpaths (as
    :func:`~repulsionpak.render.render_copy` and :func:`exact_outlines` do for one copy).
    """
    worst = 0.0
    for art, ex in zip(written, exact):
        lines = _written_lines(art, tol / 100.0)
        for w, e in zip(lines, ex):
            if len(w) < 2 or len(e) < 2:
                continue
            lw, le = shapely.LineString(w), shapely.LineString(e)
            d1 = shapely.distance(shapely.points(e), lw).max()
            d2 = shapely.distance(shapely.points(w), le).max()
            # the exact outline between its dense samples: chord error of 96 samples/segment
            worst = max(worst, float(d1), float(d2))
    return worst


def turning_angles(poly: np.ndarray, n: int = 400) -> np.ndarray:
    """Turning angle (degrees, signed) at ``n`` points equally spaced by arc length along
    the closed polyline ``poly`` (K, 2): the direction change between neighbouring chords."""
    ring = np.vstack([poly, poly[:1]])
    seg = np.hypot(*np.diff(ring, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    u = np.linspace(0.0, s[-1], n, endpoint=False)
    x = np.interp(u, s, ring[:, 0])
    y = np.interp(u, s, ring[:, 1])
    d = np.diff(np.column_stack([np.append(x, x[0]), np.append(y, y[0])]), axis=0)
    a = np.arctan2(d[:, 1], d[:, 0])
    turn = np.angle(np.exp(1j * (a - np.roll(a, 1))))
    return np.degrees(turn)


def dense_polyline(sub, per_segment: int = 256) -> np.ndarray:
    """A curve subpath sampled ``per_segment`` times per segment (uniform in t), (K, 2)."""
    t = np.arange(per_segment) / per_segment
    pts = np.concatenate([bezier(c, int(o), t) for o, c in zip(sub.order, sub.ctrl)])
    return pts if sub.closed else np.vstack([pts, sub.ctrl[-1, int(sub.order[-1])]])


def kink_stats(outline, n: int = 400) -> tuple[float, float]:
    """(largest turning angle, largest jump of the turning angle between neighbouring
    samples), degrees, for a closed outline — a CurveSubpath (sampled densely first) or
    a polyline (K, 2) — sampled ``n`` times by arc length (see :func:`turning_angles`).
    A smooth outline turns a little at every sample; a kink turns a lot at one."""
    poly = dense_polyline(outline) if hasattr(outline, "order") else np.asarray(outline, dtype=float)
    t = turning_angles(poly, n)
    return float(np.abs(t).max()), float(np.abs(np.diff(np.append(t, t[0]))).max())


def curve_share(paths: Sequence[ArtPath]) -> tuple[int, int]:
    """(curved segments, all segments) written for ``paths`` (polylines count as lines)."""
    curved = total = 0
    for art in paths:
        if art.source is not None and art.source.curves:
            for c in art.source.curves:
                curved += int((c.order > 1).sum())
                total += len(c.order)
        else:
            total += sum(len(p) - (0 if cl else 1) for p, cl in zip(art.subpaths, art.closed))
    return curved, total
