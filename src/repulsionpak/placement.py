"""Initial placement (sec. 4): how many elements, which ones, how big, and where."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely

from .errors import ParameterError
from .params import PlacementParams
from .preprocess import Outline, Template


def estimate_count(container_area: float, gap: float, params: PlacementParams) -> int:
    """Number of elements when none is given: container area / (element_size · gap)²."""
    if params.count is not None:
        return int(params.count)
    size = params.element_size * gap
    return max(1, int(round(container_area / (size * size))))


def gap_for_count(container_area: float, count: int, params: PlacementParams) -> float:
    """The gap at which ``count`` elements are ``element_size`` gaps across: the inverse of
    :func:`estimate_count` (what the default gap caps itself at when a count is asked)."""
    return float(np.sqrt(container_area / count) / params.element_size)


def assign_elements(n_library: int, count: int, rng: np.random.Generator) -> np.ndarray:
    """Cycle through a shuffled library until ``count`` elements are assigned (sec. 4 step 2).

    Returns (count,) int indices into the library.
    """
    if n_library < 1:
        raise ParameterError("the element library is empty")
    order = rng.permutation(n_library)
    return order[np.arange(count) % n_library]


def final_scale(outlines: Sequence[Outline], assignment: np.ndarray, container_area: float,
                offset: float, target_fraction: float) -> float:
    """Common scale (file → container units) at which the assigned elements' skins (art
    offset by ``offset``) would cover ``target_fraction`` of the container; relative sizes
    are kept (one scale for all)."""
    used = [outlines[i] for i in assignment]
    target = target_fraction * container_area

    def total(s: float) -> float:
        return sum(o.skin_area(s, offset) for o in used)

    if total(0.0) >= 0.5 * target:
        raise ParameterError(
            f"the gap is too large for this container: {len(used)} element skins {offset:g} units "
            f"wide alone would fill it; use a smaller --gap or fewer elements (--count)")
    lo, hi = 0.0, 1.0
    while total(hi) < target:
        hi *= 2.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if total(mid) < target else (lo, mid)
    return 0.5 * (lo + hi)


def blue_noise(region, count: int, rng: np.random.Generator, candidates_per_point: int = 30) -> np.ndarray:
    """``count`` well-spaced random points inside ``region`` by farthest-point sampling of
    uniform candidates (a blue-noise set like Bridson's [4], with an exact count). (count, 2)."""
    minx, miny, maxx, maxy = region.bounds
    want = max(64, count * candidates_per_point)
    pts = np.empty((0, 2))
    frac = max(region.area / ((maxx - minx) * (maxy - miny)), 1e-3)
    for _ in range(50):
        m = int(want / frac * 1.2) + 16
        cand = np.column_stack([rng.uniform(minx, maxx, m), rng.uniform(miny, maxy, m)])
        cand = cand[shapely.contains_xy(region, cand[:, 0], cand[:, 1])]
        pts = np.vstack([pts, cand])
        if len(pts) >= want:
            break
    if len(pts) == 0:
        raise ParameterError("could not sample points inside the container")
    pts = pts[:want]
    # farthest-point sampling over the coordinates as two arrays, the temporaries reused:
    # dx² + dy² is the row sum numpy gives for ((pts - p) ** 2).sum(axis=1), so the same
    # choices at a fraction of the cost (the 1,000-element poster: 0.53 -> 0.04 s,
    # `python benchmarks/bench.py placing`)
    x, y = np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1])
    dx, dy = np.empty_like(x), np.empty_like(y)

    def d2_to(k, out):
        np.subtract(x, x[k], out=dx)
        np.subtract(y, y[k], out=dy)
        np.multiply(dx, dx, out=dx)
        np.multiply(dy, dy, out=dy)
        return np.add(dx, dy, out=out)

    chosen = np.empty(count, dtype=np.int64)
    chosen[0] = rng.integers(len(pts))
    d2 = d2_to(chosen[0], np.empty_like(x))
    e2 = np.empty_like(x)
    for k in range(1, count):
        chosen[k] = int(np.argmax(d2))
        np.minimum(d2, d2_to(chosen[k], e2), out=d2)
    return pts[chosen]


def wide_part(region, radius: float):
    """The part of ``region`` covered by discs of ``radius`` inside it (its morphological
    opening): the tips and slits narrower than 2·``radius`` left out.

    Parameters
    ----------
    region : shapely geometry
        A polygonal area.
    radius : float
        The disc's radius; <= 0 returns ``region``.

    Returns
    -------
    shapely geometry
        The opening by the largest of ``radius``, ``radius``/2, ``radius``/4 ... that keeps
        at least half of ``region``'s area; ``region`` itself when none does (a band
        narrower than the disc everywhere).
    """
    floor = 1e-3 * np.sqrt(region.area)
    while radius > floor:
        opened = shapely.buffer(shapely.buffer(region, -radius), radius)
        if not opened.is_empty and opened.area >= 0.5 * region.area:
            return opened
        radius *= 0.5
    return region


@dataclass(frozen=True, eq=False)
class Placement:
    """Initial transforms of the placed elements: x = shrink · R(angle) · v + position."""

    template_index: np.ndarray  # (M,) int into the template list
    position: np.ndarray  # (M, 2)
    angle: np.ndarray  # (M,) radians
    shrink: float | np.ndarray  # initial scale relative to the template (sec. 4 step 3):
    # one for all (primaries, relative sizes kept) or (M,) (secondaries, sized to their pocket)

    def shrink_of(self, k: int) -> float:
        return float(self.shrink if np.ndim(self.shrink) == 0 else self.shrink[k])


def placed_vertices(t: Template, position: np.ndarray, angle: float, shrink: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, -s], [s, c]])
    return (t.verts @ rot.T) * shrink + position


def place(templates: Sequence[Template], assignment: np.ndarray, region, params: PlacementParams,
          rng: np.random.Generator, angle_fn=None, positions: np.ndarray | None = None,
          orient=None) -> Placement:
    """Blue-noise positions, random orientations, and a common shrink so the skins cover
    ``initial_fraction`` of the container without overlapping each other (sec. 4). The
    positions lie where the container is at least ``start_width`` final element radii
    wide (:func:`wide_part`).
    ``angle_fn(angles)`` (designer controls) may replace the random orientations; given
    ``positions`` ((count, 2), e.g. :func:`repulsionpak.sizing.spread`'s) replace the blue noise;
    ``orient(positions, angles)`` (a flow field: :class:`repulsionpak.flow.hook.Orienter`)
    turns the copies by where they are."""
    count = len(assignment)
    skin_total = sum(templates[i].skin_area for i in assignment)
    shrink = float(np.sqrt(params.initial_fraction * region.area / skin_total))
    if positions is None:
        final_r = float(np.mean([templates[i].radius for i in assignment]))  # mean final radius
        inner = shapely.buffer(region, -0.5 * (final_r * shrink))  # half a placed radius in
        if inner.is_empty or inner.area < 0.2 * region.area:
            inner = region
        inner = wide_part(inner, 0.5 * params.start_width * final_r)
        positions = blue_noise(inner, count, rng, params.candidates_per_point)
    positions = np.asarray(positions, float)
    angles = rng.uniform(0.0, 2 * np.pi, count) if params.rotate else np.zeros(count)
    if angle_fn is not None:
        angles = angle_fn(angles)
    if orient is not None:
        angles = orient(positions, angles)
    for _ in range(40):
        skins = [shapely.Polygon(placed_vertices(templates[i], positions[k], angles[k], shrink)[:templates[i].n_skin])
                 for k, i in enumerate(assignment)]
        tree = shapely.STRtree(skins)
        a, b = tree.query(skins, predicate="intersects")
        overlapping = np.any(a < b)
        outside = sum(float(shapely.difference(s, region).area) for s in skins)
        if not overlapping and outside <= 0.02 * sum(s.area for s in skins):
            break
        shrink *= 0.9
    return Placement(np.asarray(assignment), positions, angles, shrink)
