"""Reference arrangements with a known SCP (the paper's Fig. 9): stripes and squares.

Ideal packings whose spherical contact probability is known in closed form or nearly so,
to calibrate :func:`repulsionpak.measure.scp` and to read a packing's curve against:
stripes a gap apart (:func:`stripes_reference`), a grid of squares
(:func:`square_grid_reference`) and that grid randomly turned and shifted
(:func:`perturbed_squares_reference`). Each returns ``(container, shapes)`` as shapely
polygons.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import Polygon, box

from ..errors import ParameterError

__all__ = ["stripes_reference", "square_grid_reference", "perturbed_squares_reference",
           "equivalent_stripe_width"]


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
