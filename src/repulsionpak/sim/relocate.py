"""Moves at convergence (beyond the paper): the most cramped element into the largest void.

Growth stops element by element where each first meets its neighbours, so a packing can
converge with a small element wedged between large ones and, elsewhere, a void no
neighbour can grow into. Where the run would settle, :class:`Relocator` lifts the element
whose skin has the smallest inscribed circle into the largest void of the container (turned
to fit it, shrunk if it must be to clear its new neighbours), lets the run go on growing,
and at the next convergence keeps the move if the skins then cover more of the container
and the moved element is no smaller than before, else puts the whole state back as it was.
A run makes at most ``tries`` moves; it settles when none is left or no element fits a void.

Notes
-----
The paper's remedy for the voids is the secondary elements (sec. 9); when the pockets are
not filled (``--no-pocket-fill``) the primaries must fill them, which is what the moves
are for (docs/algorithm.md, "moves at convergence", has the measurements).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely

__all__ = ["Relocator", "largest_void"]

#: a void is worth a move when its inscribed circle is this much wider than the element's
#: (1.0: as wide; an element moved into a void as wide as itself grows on into it, up to
#: the growth cap of a run without pocket copies, 2×: the heart with 30 animals, seeds 1-9,
#: 0.5682 at 1.3, 0.5718 at 1.0)
VOID_RATIO = 1.0
#: the turns tried when a moved element is fitted into its void
TURNS = 12
#: the smallest share of its size a moved element is shrunk to, to clear its neighbours
SMALLEST = 0.4
#: iterations a move runs before it is judged (the stopping rule's window is 100)
WAIT = 200
#: the inscribed circles to this share of the container's larger side (sim units: 1000)
_TOLERANCE = 0.5


def _skin_polygons(model, x) -> list:
    """Each element's skin at positions ``x`` as a valid shapely polygon (sim units)."""
    return [shapely.make_valid(shapely.Polygon(ring)) for ring in model.skin_rings(x)]


def largest_void(region, skins) -> tuple[float, np.ndarray] | None:
    """The largest circle in ``region`` clear of every polygon of ``skins``.

    Parameters
    ----------
    region : shapely geometry
        The container (sim units).
    skins : sequence of shapely geometry
        The meshes' skins.

    Returns
    -------
    (radius, centre) or None
        None when the skins cover the region.
    """
    free = shapely.difference(region, shapely.union_all(skins))
    best = None
    for part in shapely.get_parts(free):
        if part.is_empty or part.area <= 0:
            continue
        mic = shapely.maximum_inscribed_circle(part, _TOLERANCE)
        if best is None or mic.length > best[0]:
            best = (float(mic.length), shapely.get_coordinates(mic)[0])
    return best


@dataclass
class Relocator:
    """The moves of one simulation phase (see the module docstring).

    Parameters
    ----------
    region : shapely geometry
        The container in sim units.
    movable : (M,) bool
        The elements that may be moved (not pinned, rigid, turn-limited or following a flow).
    tries : int
        Most moves made.
    turn : bool
        Whether a moved element may be turned to fit its void.
    """

    region: object
    movable: np.ndarray
    tries: int
    turn: bool = True
    #: the skin's width (sim units): what lies deeper in a skin is about the art
    inset: float = 0.0
    #: elements moved or found not to fit, never moved again
    tried: np.ndarray = field(default=None)
    #: the move being tried: the state before it, the cover then, the element and its own
    #: share of it, and the iteration it began
    pending: dict | None = None
    #: (element, iteration, kept, iterations it ran) of every move judged
    moves: list = field(default_factory=list)

    def __post_init__(self):
        if self.tried is None:
            self.tried = ~np.asarray(self.movable, bool)

    # -- checkpoints -------------------------------------------------------------------
    def saved(self) -> dict:
        """What a checkpoint keeps (taken only while no move is pending)."""
        return {"tries": int(self.tries), "tried": np.flatnonzero(self.tried).tolist(),
                "moves": [list(m) for m in self.moves]}

    def load(self, saved: dict) -> None:
        """Continue from :meth:`saved` output."""
        self.tries = int(saved["tries"])
        self.tried = np.zeros(len(self.tried), bool)
        self.tried[np.asarray(saved["tried"], np.int64)] = True
        self.moves = [tuple(m) for m in saved["moves"]]
        self.pending = None

    def stop(self, sim) -> None:
        """The designer took over (the live view's edits): a pending move stays as it is,
        and no other is made (a state put back would undo the edit)."""
        p = self.pending
        if p is not None:
            self.pending = None
            self.moves.append((p["element"], p["iteration"], True, sim.state.iteration - p["iteration"]))
        self.tries = 0

    # -- the run's hooks ---------------------------------------------------------------
    def at_convergence(self, sim) -> bool:
        """Called where the run would settle. Judges the pending move (kept, or undone)
        and starts the next one; True while the run must go on growing."""
        st = sim.state
        if self.pending is not None and st.iteration - self.pending["iteration"] < WAIT:
            return True
        self.judge(sim)
        if self.tries <= 0:
            return False
        self.tries -= 1
        return self._move(sim)

    def judge(self, sim) -> None:
        """Keep the pending move if the moving skins, inset by their width, cover more now
        and the moved element is no smaller than before; else put the state back as it
        was when the move began."""
        p = self.pending
        if p is None:
            return
        self.pending = None
        skins = _skin_polygons(sim.model, sim.state.x)
        kept = self.cover(sim, skins) > p["cover"] and self._inner(skins[p["element"]]) >= p["own"]
        st = sim.state
        self.moves.append((p["element"], p["iteration"], bool(kept), st.iteration - p["iteration"]))
        if not kept:  # the run goes on from where the move began, as if it had not been made
            st.assign(p["state"])
            sim.mark_good()

    def cover(self, sim, skins=None) -> float:
        """What the moves maximise: the area of the moving skins inset by the skin's width
        (about the art's; the skins' own area would favour long thin elements, whose
        growth is mostly skin)."""
        if skins is None:
            skins = _skin_polygons(sim.model, sim.state.x)
        moving = [skins[e] for e in np.flatnonzero(sim.state.moving)]
        return float(shapely.area(shapely.buffer(moving, -self.inset)).sum()) if moving else 0.0

    def _inner(self, skin) -> float:
        """One skin's share of :meth:`cover`."""
        return float(shapely.buffer(skin, -self.inset).area)

    def _parts_of(self, points: np.ndarray) -> np.ndarray:
        """(n,) the part of the container (a separate region: an island) each point (n, 2)
        lies in, -1 for none."""
        parts = shapely.get_parts(self.region)
        out = np.full(len(points), -1, np.int64)
        if len(parts) == 1:
            out[shapely.contains_xy(parts[0], points[:, 0], points[:, 1])] = 0
            return out
        at, part = shapely.STRtree(parts).query(shapely.points(points), predicate="intersects")
        out[at] = part
        return out

    def _move(self, sim) -> bool:
        """Move the untried element with the smallest inscribed circle that fits the
        largest void (its circle × :data:`VOID_RATIO` within the void's, its skin clear of
        the neighbours there at :data:`SMALLEST` of its size or more); False when none does.
        An element alone in its part of the container (an island) moves only within it:
        moved away, it would leave that part empty."""
        m, st = sim.model, sim.state
        skins = _skin_polygons(m, st.x)
        void = largest_void(self.region, skins)
        if void is None:
            return False
        radius, centre = void
        inner = np.full(m.n_elements, np.inf)
        circles = {}
        inside = shapely.point_on_surface(np.asarray(skins, dtype=object))  # a point in each skin
        at = np.full((len(skins) + 1, 2), np.nan)  # (an empty skin has none: NaN, in no part)
        full = ~shapely.is_empty(inside)
        at[:-1][full] = shapely.get_coordinates(inside[full])
        at[-1] = centre
        where = self._parts_of(at)
        part, void_part = where[:-1], where[-1]
        per_part = np.bincount(part[part >= 0], minlength=max(int(part.max(initial=-1)) + 1, 1))
        for e in np.flatnonzero(~self.tried & st.moving):
            if part[e] >= 0 and per_part[part[e]] == 1 and part[e] != void_part:
                continue  # the only element of its island
            mic = shapely.maximum_inscribed_circle(skins[e], _TOLERANCE)
            inner[e] = mic.length
            circles[e] = shapely.get_coordinates(mic)[0]
        for e in np.argsort(inner, kind="stable"):
            if not radius >= VOID_RATIO * inner[e]:
                return False  # this element does not fit: no larger one does
            e = int(e)
            self.tried[e] = True
            s0, s1 = m.elem_vstart[e], m.elem_vstart[e + 1]
            fit = self._fit(skins, e, st.x[s0:s0 + m.elem_nskin[e]] - circles[e], centre)
            if fit is None:
                continue
            angle, scale = fit
            self.pending = {"state": st.copy(), "cover": self.cover(sim, skins), "own": self._inner(skins[e]),
                            "element": e, "iteration": st.iteration}
            st.x[s0:s1] = scale * (st.x[s0:s1] - circles[e]) @ _turn(angle) + centre
            st.v[s0:s1] = 0.0
            sim.update_contacts(full=True)
            sim.mark_good()
            return True
        return False

    def _fit(self, skins, e: int, ring: np.ndarray, centre: np.ndarray) -> tuple[float, float] | None:
        """(angle, scale) that put skin ``e`` (its vertices ``ring``, about its inscribed
        centre) at ``centre`` into the room the other skins leave: the turn that leaves least
        of it outside, then the largest scale down to :data:`SMALLEST` at which nothing is;
        None if there is none."""
        room = shapely.difference(self.region, shapely.union_all([s for k, s in enumerate(skins) if k != e]))

        def outside(t: float, scale: float) -> float:
            return shapely.difference(shapely.make_valid(shapely.Polygon(scale * ring @ _turn(t) + centre)),
                                      room).area

        angle, best = 0.0, outside(0.0, 1.0)
        if self.turn:
            for t in np.linspace(0.0, 2.0 * np.pi, TURNS, endpoint=False)[1:]:
                out = outside(t, 1.0)
                if out < best - 1e-9:
                    best, angle = out, t
        if best <= 0.0:
            return angle, 1.0
        # shrunk to clear its neighbours: a mesh put into another one would not find its
        # way out (its vertices have no side of entry)
        if outside(angle, SMALLEST) > 0.0:
            return None
        lo, hi = SMALLEST, 1.0
        for _ in range(12):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if outside(angle, mid) <= 0.0 else (lo, mid)
        return angle, lo


def _turn(t: float) -> np.ndarray:
    """The matrix that turns row vectors by ``t`` (counter-clockwise, y up)."""
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, s], [-s, c]])
