"""Hole fill: undeformed copies in the holes of the packed art (rings, letters' counters).

An element's mesh covers its whole outline, holes included (the simulation packs outer
shapes), so the counter of an ``O`` or the middle of a ring stays empty however well the
elements are packed: negative space far from any art, which the paper's evenness measure
Q_s(gap/2)/Q_s(0) counts like any other pocket (on the ring scene of our suite the holes
are 28% of the container). A hole is a pocket, and this is the pocket fill for it: after
the verification, every hole whose free part (the hole shrunk by the gap) can hold a
circle of at least ``secondary.hole_min_radius`` gaps gets one copy of a secondary
element (the primaries themselves when none are given, as in the pocket fill), undeformed,
turned as its element's rotation control allows, placed on the centre of the largest
inscribed circle and scaled up until it touches the free part's edge, so it keeps exactly
the gap to its host. Copies with holes of their own are filled in turn, ``hole_depth``
levels deep. Every copy is a gap away from everything by construction (the free part
excludes the other elements' art dilated by the gap too); the final evaluation checks it
again on the written curves.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely

from .types import ElementControls
from .art_area import art_area
from .geometry.dilate import covering, dilation, room_left
from .geometry.robust import overlay
from .geometry.robust import union_all as robust_union_all
from .params import RenderParams
from .render.placed import curve_tolerance, refined
from .threads import thread_map
from .types import ArtPath, Element, PlacedArt

__all__ = ["fill_holes", "fill_pockets", "HoleLibrary"]


@dataclass(frozen=True, eq=False)
class HoleLibrary:
    """The elements hole copies are drawn from, centred on their art's centroid."""

    elements: tuple[Element, ...]
    centres: np.ndarray  # (n, 2) file units
    geoms: tuple  # art area, centred, file units
    radii: np.ndarray  # largest distance of the art from its centre
    weights: np.ndarray  # relative frequency (controls' weight), normalised
    controls: tuple[ElementControls, ...]
    points: np.ndarray  # (n,) points of each element's art (what a copy of it costs to fit and build)
    axes: np.ndarray  # (n,) direction of each element's long axis, radians (file units)

    @staticmethod
    def of(elements: Sequence[Element]) -> "HoleLibrary | None":
        els, centres, geoms, radii, weights, ctrls, points, axes = [], [], [], [], [], [], [], []
        for e in elements:
            c = getattr(e, "controls", None) or ElementControls()
            g = art_area(e.paths)
            if g.is_empty or not g.area > 0 or c.weight <= 0:
                continue
            ctr = np.array(g.centroid.coords[0])
            g0 = shapely.affinity.translate(g, -ctr[0], -ctr[1])
            pts = np.concatenate([np.asarray(p.exterior.coords) for p in getattr(g0, "geoms", [g0])])
            els.append(e)
            centres.append(ctr)
            geoms.append(g0)
            radii.append(float(np.sqrt((pts ** 2).sum(axis=1).max())))
            axes.append(_long_axis(g0))
            weights.append(c.weight)
            ctrls.append(c)
            points.append(sum(len(q) for a in e.paths for q in a.subpaths))
        if not els:
            return None
        w = np.asarray(weights, dtype=float)
        return HoleLibrary(tuple(els), np.asarray(centres), tuple(geoms), np.asarray(radii),
                           w / w.sum(), tuple(ctrls), np.asarray(points, dtype=float), np.asarray(axes))


def _long_axis(geom) -> float:
    """Direction (radians) of the long side of ``geom``'s minimum rotated rectangle."""
    c = np.asarray(shapely.get_coordinates(shapely.minimum_rotated_rectangle(geom)))
    if len(c) < 4:
        return 0.0
    a, b = c[1] - c[0], c[2] - c[1]
    u = a if np.hypot(*a) >= np.hypot(*b) else b
    return float(math.atan2(u[1], u[0]))


@dataclass
class FillBudget:
    """Work the leftover and hole fills may still do, in art points handled: every fit
    of a copy costs :data:`COPY_COST` plus the points of each element it tries, and a
    copy built (its written curves and their exact art) :data:`BUILD_COST` × its
    points. A fill stops, whatever room is left, once ``left`` is spent.

    Notes
    -----
    A copy of detailed art is expensive however small it is (a line of text: 3,000
    points, about 0.2 s to fit, write and measure exactly): without a bound the fill of a
    container around one text element placed 395 copies in 325 s. The bound is set from
    the primary simulation's own work (:func:`budget_for`), so the fill takes about as
    long as that at most, on any machine, and its result does not depend on the
    machine's speed."""

    left: float

    def take(self, cost: float) -> None:
        self.left -= cost

    @property
    def spent(self) -> bool:
        return self.left <= 0


#: fixed cost of one fit, in art points (the inscribed circle, a few shapely calls)
COPY_COST = 200.0
#: building a copy (written curves, exact art) costs this many times its points, against
#: one for each random pick tried (a transformed outline and about 13 containment tests)
BUILD_COST = 4.0
#: art points the fills may handle per vertex-iteration of the primary simulation: one
#: vertex-iteration costs about 0.3-0.5 µs, one point of a fill 7-15 µs (measured on the
#: Arabic test text in a circle, one thread: at 0.037 the fill took twice the primary
#: simulation's time), so this keeps the fills' time to about half the primary
#: simulation's (the secondary phase may take the other half: secondary.SECONDARY_WORK)
FILL_WORK = 0.0075


#: the fills' budget is never less than for this many vertex-iterations (about 2 s of
#: simulation): one small primary alone in a narrow band still gets its copies
MIN_FILL_WORK = 4e6


def budget_for(vertices: int, iterations: int) -> FillBudget:
    """The fills' budget for a primary simulation of ``vertices`` × ``iterations``."""
    return FillBudget(FILL_WORK * max(float(vertices) * float(iterations), MIN_FILL_WORK))


def _angle(c: ElementControls, rng: np.random.Generator) -> float:
    lim = c.limits
    if lim is None:
        return float(rng.uniform(0.0, 2.0 * math.pi))
    lo, hi = lim
    return float(lo if hi <= lo else rng.uniform(lo, hi))


def _matrix(scale: float, angle: float, centre_src: np.ndarray, at: np.ndarray) -> np.ndarray:
    """(3, 3) map: file units, about the art's centre -> container units at ``at``
    (turned ``angle`` radians clockwise on screen, y down)."""
    c, s = math.cos(angle) * scale, math.sin(angle) * scale
    m = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    m[:2, 2] = at - m[:2, :2] @ centre_src
    return m


def _place(geom0, scale: float, angle: float, at: np.ndarray):
    """``geom0`` (centred on its art's centre) under :func:`_matrix`."""
    m = _matrix(scale, angle, np.zeros(2), at)
    return shapely.affinity.affine_transform(geom0, [m[0, 0], m[0, 1], m[1, 0], m[1, 1], m[0, 2], m[1, 2]])


def _place_all(geoms0: Sequence, scales: Sequence[float], angles: Sequence[float], at: np.ndarray) -> np.ndarray:
    """``_place(geoms0[j], scales[j], angles[j], at)`` of each j, as an array: one
    coordinate transform for all (the same arithmetic, so the same coordinates)."""
    geoms = np.empty(len(geoms0), dtype=object)
    geoms[:] = list(geoms0)
    if not len(geoms):
        return geoms
    cs = [(math.cos(a) * sc, math.sin(a) * sc) for a, sc in zip(angles, scales)]  # as _matrix
    n = shapely.get_num_coordinates(geoms)
    c = np.repeat([q[0] for q in cs], n)
    s = np.repeat([q[1] for q in cs], n)

    def move(xy):  # shapely.affinity.affine_transform's arithmetic, per coordinate
        x, y = xy.T
        return np.stack([c * x + -s * y + at[0], s * x + c * y + at[1]]).T

    return shapely.transform(geoms, move)


def _written(art: ArtPath, m: np.ndarray, tol: float) -> ArtPath:
    """``art`` under the similarity ``m``, as the writer will write it (:func:`refined`)."""
    return refined(art.transformed(lambda p: np.asarray(p) @ m[:2, :2].T + m[:2, 2]), tol)


def _holes(geom) -> list:
    """``(hole, islands)`` for every hole of ``geom``'s polygons: the hole as a polygon and
    the other parts of ``geom`` inside it (a bullseye's centre disc, the dot in a ring)."""
    parts = [p for p in getattr(geom, "geoms", [geom]) if isinstance(p, shapely.Polygon)]
    out = []
    for p in parts:
        for r in p.interiors:
            hole = shapely.Polygon(r)
            out.append((hole, [q for q in parts if q is not p and q.intersects(hole)]))
    return out


#: picks of a fit (of its ``trials``) that turn a free copy's long axis along the pocket's
ALONG_TRIES = 2
#: a copy fitted on its source's polylines whose written curves reach out of the free
#: part is scaled by FIT_SHRINK, at most FIT_STEPS times (a source is flattened at 1e-3
#: of its size: the curves bulge up to that much beyond its chords)
FIT_SHRINK, FIT_STEPS = 0.998, 6


def _fit_copy(part, library: HoleLibrary, gap: float, rng: np.random.Generator, min_radius: float,
              render: RenderParams, trials: int, min_area: float = 0.0, budget: FillBudget | None = None):
    """One undeformed copy inside the polygon ``part`` (a free region: everything in it is
    at least the gap from all art), centred on its largest inscribed circle and scaled up
    until it touches the edge, the largest of ``trials`` random picks; (copy, its art)
    or None when the circle is below ``min_radius`` or nothing of at least ``min_area``
    of art (container units², the size floor squared) fits. ``budget`` is charged the
    work done (:class:`FillBudget`)."""
    if budget is not None:
        budget.take(COPY_COST)
    line = shapely.maximum_inscribed_circle(part, 0.01 * gap)
    at = np.asarray(line.coords[0])
    r = float(line.length)
    if r < min_radius:
        return None
    shapely.prepare(part)
    axis = _long_axis(part)
    picks, angles = [], []
    for t in range(trials):
        k = int(rng.choice(len(library.elements), p=library.weights))
        angle = _angle(library.controls[k], rng)
        if t < ALONG_TRIES and library.controls[k].limits is None:
            # a free copy's first picks lie along the pocket (either way round): a bar
            # fills a long pocket only along it, and random angles seldom find that
            angle = axis - library.axes[k] + math.pi * (t % 2)
        if budget is not None:
            budget.take(library.points[k])
        picks.append(k)
        angles.append(angle)
    # every pick at once: fits inside the inscribed circle, then grows until it touches
    # the free part's edge (bisection of its scale)
    g0 = [library.geoms[k] for k in picks]
    lo = [r / library.radii[k] for k in picks]
    fits = shapely.contains(part, _place_all(g0, lo, angles, at))
    live = [j for j in range(len(picks)) if fits[j]]
    hi = [3.0 * x for x in lo]
    for _ in range(12):
        if not live:
            break
        mid = [0.5 * (lo[j] + hi[j]) for j in live]
        inside = shapely.contains(part, _place_all([g0[j] for j in live], mid, [angles[j] for j in live], at))
        for j, m, ok in zip(live, mid, inside):
            if ok:
                lo[j] = m
            else:
                hi[j] = m
    best = None
    for j in live:
        area = lo[j] * lo[j] * g0[j].area
        if best is None or area > best[0]:
            best = (area, lo[j], picks[j], angles[j])
    if best is None or best[0] < min_area:
        return None
    _, s, k, angle = best
    e = library.elements[k]
    if budget is not None:
        budget.take(BUILD_COST * library.points[k])
    for _ in range(FIT_STEPS):  # what is written must fit, not only the source's polylines
        m = _matrix(s, angle, library.centres[k], at)
        tol = curve_tolerance(2.0 * s * library.radii[k], gap, render)
        paths = tuple(_written(a, m, tol) for a in e.paths)
        copy = PlacedArt(e.source, "secondary", paths, stroke_scale=s, deformation=0.0,
                         paint_servers=dict(e.paint_servers), frame=m, tolerance=tol)
        if part.contains(copy.art):
            return (copy, copy.art) if copy.art.area >= min_area else None
        s *= FIT_SHRINK
    return None


def fill_holes(placed: list[PlacedArt], library: HoleLibrary, gap: float, rng: np.random.Generator,
               min_radius: float, depth: int = 2, render: RenderParams = RenderParams(),
               trials: int = 6, limit: int | None = None, min_size: float = 0.0,
               budget: FillBudget | None = None) -> list[PlacedArt]:
    """Copies of ``library`` elements in the holes of ``placed`` (see the module
    docstring), at most ``limit``; returns the new copies only. ``min_radius``: the smallest inscribed
    circle of a hole's free part that gets a copy (container units); ``min_size``: the
    smallest copy (square root of its art's area, container units); ``budget``: the
    fill stops once it is spent (:class:`FillBudget`). Copies keep
    1.005 × the gap from their hosts: the writer rounds their curves by at most a fifth
    of their tolerance, itself at most 0.02 gap."""
    geoms = [p.art for p in placed]
    tree = shapely.STRtree(geoms)
    keep = 1.005 * gap
    out: list[PlacedArt] = []
    queue = [(g, 0) for g in geoms]
    added: list = []
    while queue and (limit is None or len(out) < limit) and not (budget is not None and budget.spent):
        host, level = queue.pop(0)
        if level >= depth:
            continue
        for hole, islands in _holes(host):
            if hole.area < max(math.pi * min_radius ** 2, min_size ** 2):
                continue
            free = hole.buffer(-keep)
            for g in islands:  # the host's own art inside the hole keeps the gap too
                free = overlay(shapely.difference, free, g.buffer(keep))
            others = [geoms[j] for j in tree.query(hole)] + added
            for g in others:  # none expected (meshes cover holes); never closer than the gap
                if g is not host and g.intersects(hole):
                    free = overlay(shapely.difference, free, g.buffer(keep))
            here: list = []  # copies put in this hole: parts of a pinched hole may be close
            for part in getattr(free, "geoms", [free]):
                for g in here:
                    part = overlay(shapely.difference, part, g.buffer(keep))
                if isinstance(part, shapely.MultiPolygon):
                    part = max(part.geoms, key=lambda q: q.area)
                if part.is_empty or not isinstance(part, shapely.Polygon):
                    continue
                if (limit is not None and len(out) >= limit) or (budget is not None and budget.spent):
                    break
                got = _fit_copy(part, library, gap, rng, min_radius, render, trials, min_size ** 2, budget)
                if got is None:
                    continue
                copy, g = got
                out.append(copy)
                added.append(g)
                here.append(g)
                queue.append((g, level + 1))
    return out


def _shells(g):
    """``g`` with its holes filled (the union of its polygons' outer rings); ``g`` itself
    when it has none."""
    parts = shapely.get_parts(g)
    if not any(len(p.interiors) for p in parts if isinstance(p, shapely.Polygon)):
        return g
    return robust_union_all([shapely.Polygon(p.exterior) for p in parts if isinstance(p, shapely.Polygon)])


def fill_pockets(placed: list[PlacedArt], library: HoleLibrary, region, gap: float, margin: float,
                 rng: np.random.Generator, min_radius: float, render: RenderParams = RenderParams(),
                 trials: int = 6, limit: int | None = None, min_size: float = 0.0,
                 into_holes: bool = False, budget: FillBudget | None = None) -> list[PlacedArt]:
    """Undeformed copies in what is left of the negative space after the verification:
    the container shrunk by the edge margin, minus every element's art dilated by the
    gap, split into its connected pockets; each pocket whose largest inscribed circle is
    at least ``min_radius`` gets a copy (:func:`_fit_copy`), then every piece of what is
    left of it (largest first; a copy can split a pocket), until no piece holds that
    circle. The fill ends by itself: every copy takes at least a circle of ``min_radius``
    plus the gap out of its pocket. (No cap per pocket: the negative space between ten '5'
    glyphs 40 gaps tall is one connected pocket, and a cap of 64 copies left
    Q_s(gap/2)/Q_s(0) at 0.604.)
    These pockets are the room an element left when the verification had to drop it, or
    that the simulated pocket fill did not reach; every copy is a gap from all art and
    the margin from the edge by construction. Returns the new copies only, at most ``limit``.
    ``min_size`` (container units): no copy smaller (:func:`repulsionpak.secondary.art_size`)
    is placed. ``into_holes`` false: the holes of the art (a ring's middle, the inside of
    a logo) are not pockets; :func:`fill_holes` fills them when asked. ``budget``: the
    fill stops once it is spent (:class:`FillBudget`)."""
    keep = 1.005 * gap
    eps = 0.01 * gap
    reach = covering(keep + eps)  # 4-segment buffers that cover the true dilation
    # (one GEOS simplification per copy: on threads, the same outlines)
    geoms = thread_map(lambda p: shapely.simplify(p.art if into_holes else _shells(p.art), eps), placed)
    free = room_left(shapely.buffer(region, -(1.005 * margin)), geoms, reach)
    if free.is_empty:
        return []
    parts = [q for q in getattr(free, "geoms", [free]) if isinstance(q, shapely.Polygon)]
    least = max(math.pi * min_radius ** 2, min_size ** 2)  # a piece smaller holds no copy
    parts = [q for q in parts if q.area >= least]
    parts.sort(key=lambda q: -q.area)
    out: list[PlacedArt] = []
    for pocket in parts:
        todo = [pocket]  # the pocket, then every piece a copy leaves of it, largest first
        while todo and (limit is None or len(out) < limit) and not (budget is not None and budget.spent):
            part = todo.pop(0)
            got = _fit_copy(part, library, gap, rng, min_radius, render, trials, min_size ** 2, budget)
            if got is None:
                continue
            copy, g = got
            out.append(copy)
            rest = overlay(shapely.difference, part, dilation(g if into_holes else _shells(g), reach))
            todo += [q for q in getattr(rest, "geoms", [rest])
                     if isinstance(q, shapely.Polygon) and not q.is_empty and q.area >= least]
            todo.sort(key=lambda q: -q.area)
    return out
