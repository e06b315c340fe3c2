"""Every tunable parameter, as frozen dataclasses (one per stage).

Units: lengths marked *container units* are in the user units of the container file;
force constants are the paper's (sec. 5), valid for a container whose larger bounding-box
side is 1000 units. The simulation runs in such normalised units (see
``sim.model.SimFrame``), which is how the defaults "work for any container size".

Parameters are data: load them from TOML with :func:`load_config`, change them with
:meth:`Params.with_` (``Params(gap=5).with_(sim__k_edge=40)``).
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import operator
import tomllib
import typing
from dataclasses import dataclass, field, fields
from pathlib import Path

from .errors import ConfigError, ParameterError


def _doc(default, unit: str, text: str, **kw):
    """A dataclass field carrying its unit and documentation in ``metadata``."""
    return field(default=default, metadata={"unit": unit, "doc": text, **kw})


@dataclass(frozen=True)
class PreprocessParams:
    """Sec. 4: skins, meshes and barycentric binding."""

    mesh_spacing: float = _doc(
        1.0, "× gap", "Spacing of the skin's boundary samples, as a multiple of the gap (paper: 1).")
    skin_offset: float = _doc(
        0.5, "× gap", "Skin width around the art, as in the paper. Repulsion compresses the skin "
        "where meshes touch (10–30 % on the heart scene), so arts end closer than the gap at "
        "those contacts; the verification bends them apart there (verify.dent). A wider skin "
        "(0.6) kept them apart in the simulation, at the cost of every other gap: main suite "
        "area 0.5579 -> 0.5645 and Q_s promise 13 -> 16 of 26 at 0.5.")
    skin_tolerance: float = _doc(
        0.05, "× gap", "Largest distance between the resampled skin and the exact offset curve: "
        "tight bends get extra samples so the gap holds at tips (paper: uniform samples only). "
        "A speed knob for large scenes: 0.1 takes the 1,000-element poster from 175,634 to "
        "152,381 vertices and 150 to 127 s with the same promises, but packs the paper's heart "
        "a little looser (20 animals alone, seeds 1-16: mean area 0.545 -> 0.535; with the cat "
        "heads 0.641 -> 0.634; docs/algorithm.md, 'adaptive skin resampling').")
    interior_points: bool = _doc(
        True, "-", "Allow Steiner points inside the skin for a quality triangulation.")
    min_angle: float = _doc(
        20.0, "degrees", "Smallest triangle angle the mesh refinement aims at (at most 34).")
    flatten_tolerance: float = _doc(
        0.25, "× gap", "Maximum chord error when flattening curves (at most gap/4).")
    min_boundary_vertices: int = _doc(
        12, "-", "A skin gets at least this many boundary samples, however small it is.")


@dataclass(frozen=True)
class PlacementParams:
    """Sec. 4: initial placement."""

    count: int | None = _doc(
        None, "elements", "Number of primary elements; None estimates it from the container area.")
    element_size: float = _doc(
        15.0, "× gap", "Typical final element diameter used to estimate the count (when count is None): "
        "the larger, the fewer and bigger the elements, and the less of the container their gaps take "
        "(15 covers more than 12 on 48 of the 53 suite scenes, see docs/quality.md).")
    initial_fraction: float = _doc(
        0.075, "-", "Share of the container area the skins occupy at the start (paper: 5–10%). "
        "0.22 packed the paper's heart denser and in fewer iterations at the paper's growth rate "
        "(docs/algorithm.md), "
        "but its larger start leaves skins past the container's edge in the first frames and "
        "loosens some suite scenes, so it is not the default.")
    follow_room: bool = _doc(
        True, "-", "Size and count the primaries from the room the container has (its separate "
        "regions and their local width, repulsionpak.sizing) when it is uneven: several regions, or "
        "a tenth of it narrower than element_size gaps. A round container is placed as in the paper.")
    width_share: float = _doc(
        1.0, "-", "When the primaries follow the room, the size an element aims for where the container "
        "is w wide is min(element_size gaps, width_share × w): 1 packs one row across a band.")
    variety: float = _doc(
        3.0, "-", "When the primaries follow the room, no element takes more than this many times "
        "its share of the copies (count / library size) while others are left: 1 uses every element "
        "equally, as the paper's cycle does; more lets the elements that fit best (round ones) "
        "take more cells.")
    room_everywhere: bool = _doc(
        False, "-", "Place the primaries by the room policy (repulsionpak.sizing: cells, each copy "
        "the element, angle and size that fit its cell) in every container, round ones and given "
        "counts included (beyond the paper; see docs/quality.md).")
    min_element_size: float = _doc(
        3.0, "× gap", "A region narrower than this (its largest inscribed circle) gets no primary of "
        "its own when the primaries follow the room; the pocket fill may still put small copies there.")
    target_fraction: float = _doc(
        0.86, "-", "Share of the container area the skins are expected to fill at the end; "
        "fixes the scale at which skins are built so the final art gap matches the requested gap.")
    rotate: bool = _doc(True, "-", "Give every element a random initial orientation.")
    candidates_per_point: int = _doc(30, "-", "Candidates per point for farthest-point blue noise.")
    start_width: float = _doc(
        0.6, "× element radius", "The paper's placement starts an element only where the container "
        "is at least this wide (a disc of half this width inside it covers the point), so none "
        "starts in a tip or slit it cannot grow in: farthest-point sampling takes the extremes first, "
        "and copies started at the tips of a crescent's horns ended squeezed and dropped by the "
        "verification. Halved while it would leave less than half of the container; 0 = anywhere "
        "(the paper). The main suite keeps the same 213 promise checks with 0, 0.6 and 1.0: mean "
        "area 0.5758, 0.5760, 0.5764; Q_s ratio 0.402, 0.398, 0.398.")
    max_vertices: int = _doc(
        1_000_000, "vertices", "Largest mesh a run may need, estimated as the container's area / gap² "
        "(the meshes are sampled a gap apart; runs measured 0.4–1.2 times that): a finer gap is refused "
        "before anything is built (1M vertices take about 4 GB and an hour). Raise it to try anyway.")


@dataclass(frozen=True)
class SimParams:
    """Sec. 5–8: forces, integration, growth, self-intersection, stopping."""

    k_repulsion: float | None = _doc(
        None, "paper units", "k_r, strength of the repulsion force (Eq. 2). None: 80 when the pockets "
        "are filled; when they are not (--no-pocket-fill), where only the primaries' own spacing "
        "leaves the negative space even, 320 at the default gap (1% of the container's larger side) "
        "and above, following the gap squared below it and never below 80: 14 primaries-only scenes, area 0.6333 -> "
        "0.6482, Q_s ratio 0.552 -> 0.540; the heart with 30 animals, seeds 1-27: +0.009. With the "
        "pockets filled it made the main suite's area no higher and its Q_s ratio worse (0.395 -> "
        "0.410), and at a third of the default gap 320 lowered 300 elements' area by 0.011-0.017. "
        "Below half the default gap (0.5%) both follow the gap: 80 x (gap^2 + soft) / (25 + soft) in "
        "simulation units, the push across a gap as at 0.5%: the 1,000-element poster (0.17%) "
        "art area 0.660 -> 0.688, primaries 0.636 -> 0.671 (docs/algorithm.md).")
    k_edge: float = _doc(
        20.0, "paper units", "k_e, strength of the quadratic edge springs (Eq. 3). The paper's example "
        "is 40 (its authors' own parameter file uses 7 against k_r = 100); 20 deforms more and packs "
        "denser with the gap still within ~15% (measured on the heart scene).")
    k_shape: float = _doc(
        0.0, "paper units", "Strength of the shape-matching force that pulls every mesh towards the "
        "best rotated, scaled copy of its rest shape (beyond the paper; 0 = the paper's springs "
        "only). Higher keeps shapes truer, lower lets them bend to fill (see docs/quality.md).")
    bend_limit: float = _doc(
        0.2, "-", "Largest distortion of an element's art (area of the symmetric difference with "
        "its best rotated, scaled copy, over its area) the simulation allows: a mesh bent "
        "further is pulled back onto the limit after every step (beyond the paper; 0 = no limit).")
    bend_limit_convex: float = _doc(
        0.08, "-", "The same for nearly convex elements (art ≥ 0.9 of its convex hull), "
        "whose dents show more.")
    skin_width: float = _doc(
        0.8, "× rest width", "Each skin vertex is kept at least this share of its rest distance "
        "outside the nearest point of its art (beyond the paper: a squashed skin let arts whose skins "
        "touched stand well under the gap apart; 0 = off).")
    narrow_skins: bool = _doc(
        True, "-", "When growth stops, the skin of a copy grown past its planned size is narrowed back "
        "to the width it was built with, half the gap (beyond the paper: a skin grows with its copy, "
        "so the copies that grew most kept their neighbours up to 1.5 gaps off).")
    k_overlap: float = _doc(80.0, "paper units", "k_o, strength of the overlap force (Eq. 4).")
    k_boundary: float = _doc(80.0, "paper units", "k_b, strength of the boundary force (Eq. 5).")
    soft: float = _doc(1.0, "paper units²", "ς, soft parameter bounding the repulsion (Eq. 2).")
    dt: float = _doc(0.1, "-", "Δt, explicit Euler time step (paper: 0.1).")
    velocity_cap: float = _doc(
        10.0, "× Δt", "Velocities are capped at velocity_cap·Δt (paper: 5). The cap is in the 1000-unit "
        "frame, so it holds small elements back most (large ones get the cap their growth needs, "
        "growth_headroom): at 5 the 1,000-element poster's jam parted its overlaps at 0.05 units a step "
        "and crept on for 2,977 iterations; at 10, 2,534 to a denser packing (meshes 0.887 -> 0.898 of "
        "the container, art 0.731 -> 0.734), while both suites, the primaries-only scenes and the heart "
        "with 30 animals stay within +-0.0005 of their area and keep the same promises, the default "
        "heart to the byte (docs/algorithm.md).")
    k_growth: float | None = _doc(
        None, "-", "k_g, growth rate: rest lengths (1 + n·k_g·Δt)·L (sec. 6; the paper: 0.01). None: "
        "0.06 when the pockets are filled, 0.04 when they are not (--no-pocket-fill). With the "
        "pockets filled 0.06 walks the jam in fewer steps at the same density (main suite: 19 % fewer "
        "iterations, mean area 0.5774 -> 0.5786, the same promises); the primaries alone, which must "
        "fill the voids themselves, pack looser at it (the heart with 30 animals, seeds 1-3: area "
        "0.583 -> 0.567, Q_s ratio 0.463 -> 0.491; docs/algorithm.md).")
    fast_growth: int = _doc(
        1, "× k_g", "An element with room grows this many times faster (beyond the paper): while "
        "no other skin and no container edge is within fast_growth_clearance of its skin, its growth "
        "counter n_M advances by this many steps per iteration, and its velocity cap follows; with a "
        "neighbour that close it grows at the paper's rate (1 = the paper's rule everywhere). "
        "At the paper's k_growth (0.01), 4 cut the heart's primary iterations by a quarter, but the "
        "elements with room outgrew those placed close together (size spread p90/p10 1.6 -> "
        "2.2-2.6), so it is off by default (docs/algorithm.md).")
    fast_growth_clearance: float = _doc(
        0.5, "× gap", "The room an element needs around its skin to grow at the fast_growth rate.")
    fast_growth_until: float = _doc(
        0.7, "-", "Fast growth ends once an element has grown this share of the way from its placed "
        "size to its largest (max_size): the last stretch, where the jam forms, is grown at the "
        "paper's rate everywhere.")
    growth_headroom: float = _doc(
        2.0, "-", "An element's velocity cap is at least this many times the speed its farthest "
        "vertex needs to follow its growth (k_g × its placed radius), so large elements are not "
        "held back by velocity_cap: beyond the paper, whose cap let meshes wider than ~100 units "
        "of the 1000-unit frame lag behind their rest lengths, ripple and cross (0 = the paper's "
        "cap alone).")
    cell_size: float = _doc(
        0.65, "× element size", "Neighbour-grid cell width relative to the typical final element "
        "diameter (paper: 6–10% of a container holding ~25 elements).")
    boundary_inset: float = _doc(
        0.1, "× gap", "The boundary force acts on the container shrunk by this much (paper: 0), so "
        "skins, which the penalty force lets poke out a little, keep their art inside.")
    k_corner: float = _doc(
        800.0, "paper units", "Strength with which a reflex container corner found inside a mesh pushes "
        "that triangle off it, along the corner's bisector into the container (beyond the paper; a "
        "fixed obstacle, so stiffer than k_b).")
    k_align: float = _doc(
        10.0, "paper units", "Strength of the torque that turns elongated elements (skin anisotropy "
        "above 0.4, fully from 0.8: rectangles of about 1.8:1 and 4:1) parallel to their elongated neighbours and to "
        "the container's edge while they grow (beyond the paper: thin elements at random angles jam "
        "like spilled matches). 60 5:1 bars in a square: area 0.764 -> 0.789, Q_s ratio 0.55 -> 0.48 "
        "(docs/algorithm.md); 0 = off, the paper.")
    align_reach: float = _doc(
        2.0, "× gap", "A skin vertex this close to the container's edge lets the edge's tangent vote "
        "in its element's alignment (k_align).")
    k_adhesion: float = _doc(
        50.0, "paper units", "While the packing settles (after growth stopped), each skin vertex "
        "outside every other mesh is drawn toward the nearest neighbouring skin within adhesion_reach "
        "with k_adhesion x (1 - d / reach), so that the channels wider than the gap close a little and "
        "the elements bend into them (beyond the paper; 0 = off). Main suite: mean area 0.5786 -> "
        "0.5833, Q_s ratio 0.396 -> 0.383, the same promises kept; the heart with 30 animals and no "
        "pockets, seeds 1-9: 0.580 -> 0.583, Q_s ratio 0.465 -> 0.459; the 1,000-element poster "
        "0.688 -> 0.726. While growing it made packings looser (docs/algorithm.md).")
    adhesion_reach: float = _doc(
        2.0, "× gap", "The farthest neighbouring skin that draws a skin vertex while the packing "
        "settles (k_adhesion).")
    hard_boundary: bool = _doc(
        True, "-", "While settling (after growth stopped), move vertices that left the container "
        "back onto its boundary after every step (beyond the paper's penalty force alone).")
    outside_block: float = _doc(
        0.25, "× gap", "A skin vertex this far outside the container blocks its element's growth "
        "(beyond the paper: keeps growth pressure from pushing border elements out).")
    contact_depth: float = _doc(
        0.0, "× gap", "A skin vertex inside another mesh stops its element's growth only when it lies "
        "deeper than this (beyond the paper, which stops it at any overlap; 0 = the paper's rule): "
        "in the jam most elements touch a neighbour at a point or two while the rest of them faces "
        "room, and the verification bends the contacts that end closer than the gap floor apart "
        "(verify.dent). The heart with 30 animals, seeds 1-6: area 0.526 -> 0.543 at 0.1 (0.531 at "
        "0.05, 0.538 at 0.2), 16 % more iterations; but the main suite's mean area 0.5617 -> 0.5595 "
        "at 0.1 (letters and mixed bands lose up to 0.03), so off by default.")
    one_sided_growth: float = _doc(
        0.0, "-", "An element whose vertices inside other meshes all press from about one side keeps "
        "growing (beyond the paper, which stops it at any contact): the unit directions from its "
        "centre to those vertices must sum to at least this share of their number (0 = off, the "
        "paper's rule; 0.5: within about ±60°). The heart with 30 animals, no pocket fill, seeds 1-6: "
        "mean area 0.495 -> 0.505 at 0.5, ~18 % more iterations; mixed on the suite, so off by default.")
    max_size: float | None = _doc(
        None, "× nominal size", "Elements stop growing at this multiple of the size their skin was "
        "built for (beyond the paper). None: 1.3 when the pockets are filled, which keeps relative "
        "sizes and leaves the voids to the pocket copies; 2.0 when they are not (--no-pocket-fill), "
        "where the primaries must fill the voids themselves: 14 primaries-only scenes, area "
        "0.6205 -> 0.6301, Q_s ratio 0.571 -> 0.558, none lower by more than 0.001; with the pockets filled it made the "
        "main suite's area no higher (0.5774 -> 0.5769, docs/algorithm.md).")
    requery_every: int = _doc(
        32, "iterations", "Full neighbour query every this many iterations; in between the closest "
        "points follow the neighbours' skins locally (1 = the paper's full query every step). "
        "The query window reaches at least one cell (~8 gaps) while vertices move at most "
        "velocity_cap·Δt² per step, so no neighbour that matters can appear in between.")
    min_triangle_area: float = _doc(
        0.2, "× rest area", "Triangles squeezed below this share of their rest area push back "
        "(beyond the paper: keeps meshes from folding); 0 disables.")
    threads: int = _doc(0, "-", "numba threads; 0 = automatic: one, or every core (at most "
                        "$REPULSIONPAK_THREADS) while measured iterations show that more threads are faster "
                        "(they are not beside a busy process), once the parallel kernels are compiled; "
                        "see parallel_threshold.")
    parallel_threshold: int = _doc(
        1000, "vertices", "With threads = 0, scenes with fewer vertices run on one thread "
        "(two threads: 0.86x as fast at 340 vertices, 1.1x at 700, 1.4x at 1,400 on 2 cores).")
    far_update: float = _doc(
        2.0, "× gap", "Between full queries, closest points on neighbours farther than this are "
        "not refreshed (their repulsion is weak and changes slowly).")
    relax_passes: int = _doc(2, "-", "Self-intersection relaxation cycles per step (sec. 7: 2–3).")
    relax_fraction: float = _doc(0.5, "× mean edge", "Minimum distance of non-neighbouring vertices.")
    stop_window: int = _doc(100, "iterations", "w, sliding window of the stopping rule (sec. 8).")
    stop_epsilon: float = _doc(
        2e-5, "relative / iteration", "ε: stop when the RMS of the per-iteration change of the "
        "moving meshes' area fraction over the window, divided by that area fraction, falls below "
        "this (the paper samples once per second with ε = 0.01; we sample every iteration).")
    stop_vertices: int = _doc(
        25_000, "vertices", "Beyond the paper: with more moving vertices than this, the stopping threshold is "
        "stop_epsilon × moving vertices / stop_vertices, the same gain asked of each unit of work as a "
        "scene of this size asks of an iteration (the paper samples once per second, so its threshold per "
        "iteration grew with the cost of an iteration too). Every scene of both suites (the largest: "
        "21,927) and the paper's heart are below it and stop as before. The 1,000-element poster "
        "(122,825: 4.9x) stops after 1,076 primary iterations instead of 2,534 (0.64-0.76 of the "
        "time), at art area 0.724 instead of 0.734; 400 of its elements (48,600: 1.9x) after 2,045 "
        "instead of 2,233, at 0.730 instead of 0.731 (docs/benchmarks.md). 0 = off: stop_epsilon per "
        "iteration at any size.")
    min_iterations: int = _doc(300, "iterations", "Never stop before this many iterations.")
    max_iterations: int = _doc(20000, "iterations", "Bound on the iterations of each phase before it "
                               "settles (the settle_iterations follow).")
    relocations: int | None = _doc(
        None, "moves", "Beyond the paper: where the run would stop, the element whose skin has the "
        "smallest inscribed circle is moved into the largest void (turned to fit it) and the run grows on; "
        "at the next convergence the move is kept if the skins, inset by their width, cover more and the "
        "moved element is no smaller, else the state is put back. At most this "
        "many moves. None: 5 when the pockets are not filled (--no-pocket-fill), 0 when they are "
        "(pocket copies fill the voids). Pinned, rigid and turn-limited elements and flow runs are "
        "not moved. The heart with 30 animals and no pocket fill, seeds 1-12: art area 0.535 -> 0.556, "
        "Q_s ratio 0.523 -> 0.491, primary iterations +50 % (docs/algorithm.md).")
    settle_iterations: int = _doc(
        100, "iterations", "Extra iterations without growth after stopping, to resolve the last overlaps. "
        "The overlaps growth leaves are resolved within the first few dozen; those left then stay "
        "(about 100 skin vertices inside a neighbour on the heart, from 50 to 300 settling "
        "iterations) for the verification to bend apart, while the springs relax the shapes a "
        "little more (the suite's distortion p95 0.0963 with 300, 0.0976 with 100). The heart "
        "with 30 animals, seeds 1-3: area 0.513 with 0, 0.533-0.535 with 25-150, 0.531 with "
        "300; the main suite keeps the same promises with 100 as with 300, mean area 0.5658 "
        "either way.")

    def growth_cap(self, filled: bool = True) -> float:
        """The largest size an element grows to, × its nominal size.

        Parameters
        ----------
        filled : bool
            Whether copies fill the pockets of this run (the pocket phase's own copies:
            True).

        Returns
        -------
        float
            ``max_size``; for None :data:`MAX_SIZE_FILLED` when the pockets are filled and
            :data:`MAX_SIZE_UNFILLED` when they are not (the primaries then fill the voids).
        """
        return _given_or(self.max_size, MAX_SIZE_FILLED if filled else MAX_SIZE_UNFILLED)

    def growth_rate(self, filled: bool = True) -> float:
        """k_g, the growth rate: ``k_growth``; for None :data:`K_GROWTH_FILLED` when the
        pockets are ``filled`` and :data:`K_GROWTH_UNFILLED` when they are not (as
        :meth:`growth_cap`)."""
        return _given_or(self.k_growth, K_GROWTH_FILLED if filled else K_GROWTH_UNFILLED)

    def repulsion(self, filled: bool = True, gap: float | None = None) -> float:
        """k_r, the repulsion's strength.

        Parameters
        ----------
        filled : bool
            Whether copies fill the pockets of this run (the pocket phase's own copies:
            True).
        gap : float, optional
            The run's gap in simulation units (the container's larger side is 1000);
            None: the default gap, :data:`DEFAULT_GAP_SIM`.

        Returns
        -------
        float
            ``k_repulsion``; for None :data:`K_REPULSION_FILLED` when the pockets are filled,
            and when they are not :data:`K_REPULSION_UNFILLED` × (gap / the default gap)² for
            gaps below the default one, at least :data:`K_REPULSION_FILLED`;
            :data:`K_REPULSION_UNFILLED` at the default gap and above. Either way, below
            :data:`SMALL_GAP_SIM` the strength is :data:`K_REPULSION_FILLED` × (gap² + ς) /
            (SMALL_GAP_SIM² + ς): the push across a gap stays what it is at that gap.

        Notes
        -----
        Neighbouring skins lie about a gap apart, so the push between them, k_r/(d² + ς),
        grows as the gap shrinks: k_r following the gap squared pushes them alike at any gap.
        Measured: 320 packed the primaries denser than 80 at the default gap (10 units:
        the heart, the shipped containers) and less densely at a third of it (300 elements
        in a 1000 × 1500 rectangle, 3.1 units: art area 0.679 / 0.680 against 0.696 / 0.691).
        Above the default gap nothing was measured, so the strength stays 320 there (raised
        with the gap squared, 363 at the heart's 10.7 units, the alignment of a scene of bars
        came apart). With the pockets filled, 80 at every gap pushed the 1,000-element
        poster's elements (1.7 units) 25 times harder across their gaps than at the default
        one: with k_r 20 its art area was 0.682 against 0.660, with 5 0.692; from 5 units up
        (the suites' smallest gap, 0.5 %) following the gap was no better (main suite mean
        area +0.0007, held-out −0.003, one promise fewer), so it only starts below.
        """
        if self.k_repulsion is not None:
            return float(self.k_repulsion)
        g = DEFAULT_GAP_SIM if gap is None else float(gap)
        if g < SMALL_GAP_SIM:
            return K_REPULSION_FILLED * (g * g + self.soft) / (SMALL_GAP_SIM ** 2 + self.soft)
        if filled:
            return K_REPULSION_FILLED
        if g >= DEFAULT_GAP_SIM * (1.0 - 1e-6):  # (the default gap as computed: 10 up to rounding)
            return K_REPULSION_UNFILLED
        return max(K_REPULSION_FILLED, K_REPULSION_UNFILLED * (g / DEFAULT_GAP_SIM) ** 2)

    def for_run(self, filled: bool, gap: float | None = None) -> "SimParams":
        """These parameters with ``max_size``, ``k_repulsion`` and ``k_growth`` resolved
        (:meth:`growth_cap`, :meth:`repulsion`, :meth:`growth_rate`) for a run whose pockets
        are ``filled`` or not, at ``gap`` (simulation units): what the primary phase's
        simulator is given."""
        return dataclasses.replace(self, max_size=self.growth_cap(filled), k_repulsion=self.repulsion(filled, gap),
                                   k_growth=self.growth_rate(filled))


def _given_or(value: float | None, default: float) -> float:
    """``value`` as a float, or ``default`` where it is None (a parameter resolved per run)."""
    return float(default if value is None else value)


#: k_g when the pockets are filled: the jam is walked in fewer steps at the same density
#: (main suite: 80,435 -> 64,979 iterations, mean area 0.5774 -> 0.5786)
K_GROWTH_FILLED = 0.06
#: k_g when nothing fills the pockets: the primaries alone pack denser at it than at 0.06
#: (the heart with 30 animals, seeds 1-3: area 0.567 -> 0.583)
K_GROWTH_UNFILLED = 0.04
#: the growth cap (× nominal size) when the pockets are filled: an element that finds room
#: early does not dwarf its twins that got stuck, and the voids go to the pocket copies
MAX_SIZE_FILLED = 1.3
#: the growth cap when nothing fills the pockets: the primaries grow into the voids
#: (the heart with 30 animals, seeds 1-9: art area 0.5558 -> 0.5682)
MAX_SIZE_UNFILLED = 2.0
#: k_r when the pockets are filled (the strength the main suite is measured at)
K_REPULSION_FILLED = 80.0
#: k_r when nothing fills the pockets, at the default gap (:data:`DEFAULT_GAP_SIM`):
#: elements kept further apart while they grow meet more evenly, and the voids they leave
#: are smaller (the heart with 30 animals, seeds 1-27: art area 0.5654 -> 0.5742)
K_REPULSION_UNFILLED = 320.0
#: the default gap in simulation units: 1 % of the container's larger side (1000 units)
DEFAULT_GAP_SIM = 10.0
#: below this gap (simulation units, 0.5 % of the container's larger side: the suites'
#: smallest) k_r follows the gap: :meth:`SimParams.repulsion`
SMALL_GAP_SIM = 5.0


@dataclass(frozen=True)
class SecondaryParams:
    """Sec. 9: secondary elements."""

    auto: bool = _doc(
        True, "-", "Without secondary elements given, fill the pockets the primaries leave with "
        "small copies of the primaries themselves (false: leave them empty).")
    d_min: float = _doc(
        0.8, "× gap", "d_min: seeds need at least this distance to the nearest mesh or the "
        "boundary (paper: 5–10 px on a 1000 px grid, about one gap); a copy there has art about "
        "0.3 gap across, so pockets down to about 2.6 gaps wide between neighbouring art get one.")
    d_sep: float = _doc(2.0, "× gap", "d_sep: kept seeds are at least this far apart (paper: 10 px); "
                        "in a pocket of half-width d, at least 2d/1.34 - 0.15 gap apart (the room a copy "
                        "as wide as the pocket takes).")
    grid: int = _doc(1000, "pixels", "Longer side of the distance-transform grid the pockets are "
                     "measured on; more pixels where it would leave fewer than 6 across a gap (up to "
                     "4000: a small gap beside the container, as on a poster of 1,000 elements).")
    max_count: int | None = _doc(None, "elements", "Upper bound on the number of secondary elements.")
    initial_fraction: float = _doc(
        0.5, "-", "Initial secondary size relative to its pocket (its skin's radius = fraction × distance).")
    stop_epsilon: float = _doc(
        1e-4, "relative / iteration", "ε of the pocket phase's stopping rule (sim.stop_epsilon is "
        "the primaries'): copies in their pockets take ~99 % of their room within a few hundred "
        "iterations and then creep; at the primaries' 2e-5 that creep was 30-40 % of the phase. "
        "The heart, seeds 1-3, with 1e-4 and 150 settling iterations: pocket iterations "
        "1,140-1,384 -> 759-798, area and Q_s(gap/2)/Q_s(0) within ±0.001.")
    settle_iterations: int = _doc(
        50, "iterations", "Iterations without growth after the pocket phase stops "
        "(sim.settle_iterations is the primaries'; the heart, seeds 1-3: area 0.612 and "
        "Q_s(gap/2)/Q_s(0) 0.393 with 25, 50 or 150).")
    candidates: int | None = _doc(
        None, "elements", "Elements each pocket tries (the next ones of the shuffled cycle); the one whose "
        "copy, fitted to the pocket, covers the most art is placed, so compact elements take more "
        "pockets. None: every element for the automatic fill (copies of the primaries), 1 for "
        "secondaries given with --secondary (the designer's mix, assigned at random as in the paper). "
        "Not with designer controls.")
    min_size: float = _doc(
        0.2, "× median primary size", "Smallest automatic pocket copy (no --secondary given): a copy's "
        "size is the square root of its art's area (the ink it puts down, whatever its shape or "
        "orientation; a bounding circle would count a whisker or a tail as size), and no copy is "
        "placed, or kept after the verification, below this share of the median primary's. "
        "Secondaries given with --secondary are the designer's and are sized by their pockets only "
        "(0 = no floor).")
    fill_holes: bool = _doc(
        False, "-", "Put undeformed secondary copies in the holes of the packed art (a ring's "
        "middle, a letter's counter, the inside of a logo) that can hold one a gap away from its "
        "edge (CLI --fill-holes); off: holes stay empty, as a designer expects of a logo or a "
        "letter. Part of the pocket fill (off with it).")
    fill_leftover: bool = _doc(
        True, "-", "After the verification, every pocket of the negative space still wide enough "
        "to hold a circle of hole_min_radius a gap from all art (room left by an element the "
        "verification dropped, or that the simulated fill did not reach) gets undeformed "
        "secondary copies, like a hole; part of the pocket fill (off with it).")
    hole_min_radius: float = _doc(
        0.5, "× gap", "Smallest inscribed circle of a hole's free part (the hole shrunk by the gap) "
        "that gets a copy (at 1.0, 5-pointed stars at a 0.5% gap kept Q_s(gap/2)/Q_s(0) at "
        "0.46-0.48; see docs/algorithm.md).")
    hole_depth: int = _doc(2, "-", "Holes of hole copies are filled too, this many levels deep.")


@dataclass(frozen=True)
class RenderParams:
    """Output curves: the deformation map and the curve fitting (``render`` package)."""

    smooth_map: bool = _doc(
        True, "-", "Map the art with a thin-plate spline through the mesh vertices (smooth); "
        "false: the paper's per-triangle barycentric map (kinks at triangle edges).")
    curve_tolerance: float = _doc(
        1e-3, "× element size", "Largest distance between the written curves and the exact "
        "mapped outline, relative to the copy's bounding-box diagonal.")
    max_gap_share: float = _doc(
        0.02, "× gap", "The curve tolerance never exceeds this share of the gap, so fitting "
        "cannot eat into the gap between neighbours.")
    angle_tolerance: float = _doc(
        2.0, "degrees", "Largest angle between the written curve's direction and the exact "
        "mapped outline's at any sample: keeps the curvature of the fit close to the exact "
        "one, so smooth art has no visible bends at the joints of the fitted pieces.")
    smoothing: float = _doc(
        0.002, "-", "λ of a smoothing thin-plate spline (coordinates scaled to the element's "
        "size); 0 passes exactly through every mesh vertex. The default irons out the ripples "
        "the simulation leaves in pressed skins, which an exact map writes into the art as "
        "waves (10:1 bars: absolute turning of a primary's outline, 1 for a rectangle, median "
        "1.16 → 1.06, 90th percentile 1.58 → 1.18). It moves the art off the mesh (≤ 0.2 gap); "
        "the final verification measures the art itself, so the promises hold (the "
        "before/after numbers: docs/algorithm.md, \"Ripples\").")
    samples: float = _doc(
        8.0, "per mesh spacing", "Samples of each source segment per mesh edge length when "
        "mapping it (curves get 8 to 128 samples, lines 3 to 128).")


@dataclass(frozen=True)
class VerifyParams:
    """The final check of the promises on the art, and its repair (``verify/``)."""

    min_gap: float = _doc(
        0.9, "× gap", "Every element's art keeps at least this distance to every other element's "
        "art; closer elements are shrunk about their centroid (their shape is kept).")
    min_scale: float = _doc(
        0.5, "-", "An element that would have to shrink below this share of its size is dropped "
        "(with a warning naming it).")
    repair: bool = _doc(True, "-", "Shrink or drop offenders; false: only verify and report.")
    grow_to: float = _doc(
        1.0, "× gap", "After the repair, elements grow (about their centroid, shape kept) into the "
        "room around them until they are this close to a neighbour or the margin from the edge "
        "(0: no growth).")
    max_grow: float = _doc(1.15, "-", "An element grows to at most this multiple of its size.")
    gather: float = _doc(
        1.1, "× gap", "After the growth, an element farther than this from its nearest neighbour "
        "moves towards it until they are grow_to apart (a band of copies limited by its width "
        "otherwise ends with every gap a little wide); 0: off.")
    dent: int = _doc(
        3, "rounds", "Before any element is moved or shrunk, elements closer than min_gap to a "
        "neighbour or than the margin to the edge are bent away from the contact by a smooth "
        "local bump, in this many rounds of measuring and bending (0: off; the repair then "
        "shrinks whole elements for what are mostly contacts of one limb). The heart with 30 "
        "animals, seeds 1-3: the same area with 2, 4 or 8 rounds (±0.002); the poster's "
        "1,400 elements take ~2 s a round.")
    dent_radius: float = _doc(
        1.0, "× gap", "The width (Gaussian ρ) of a dent: the art within about two radii of the "
        "contact bends with it. Every dent costs its element area along about 2.5 ρ of outline; "
        "2 (smoother, wider dents) against 1: main suite mean area 0.5692 -> 0.5758, held-out "
        "0.5399 -> 0.5452, the same promises kept, distortion p95 0.103 -> 0.106.")
    straighten: float = _doc(
        0.75, "× sim.bend_limit", "An element whose art ends up distorted beyond this multiple of "
        "its bend limit (symmetric difference with its best rotated, scaled copy, over its "
        "area) is replaced by that unbent copy; 0 never replaces (nor does sim.bend_limit = 0). "
        "0.75 × 0.2 = 0.15 (0.06 for nearly convex elements): every element keeps the shape "
        "promise itself, not only the 95th percentile of its category (thin-stroked '@' "
        "primaries reached 0.151 with 1.25).")


@dataclass(frozen=True)
class OutputParams:
    """How the written packing looks (SVG, PDF, PNG, the live view, batch's contact sheet)."""

    container_paint: str = _doc(
        "outline", "-", "How the container is drawn: 'outline' (its exact geometry as a thin "
        "stroke, no fill, as in the paper's figures: it never hides the art), 'as-drawn' (its own "
        "markup, fill and stroke, under the art) or 'none' (left out; the invisible region the "
        "packing is measured with is still written).", choices=("outline", "as-drawn", "none"))


#: what :func:`_plain` returns for a value of another type
_MISMATCH = object()


def _annotated(tp) -> tuple[type, bool]:
    """(the type a field's annotation names, whether it admits None)."""
    args = typing.get_args(tp)
    return (next((a for a in args if a is not type(None)), tp) if args else tp), type(None) in args


def _plain(value, base: type):
    """``value`` as the plain Python ``base`` (bool, int or float; numpy scalars too), or
    :data:`_MISMATCH`. A float too large for one raises OverflowError."""
    import numbers  # noqa: PLC0415

    is_bool = isinstance(value, bool) or type(value).__name__ == "bool_"  # numpy's too
    if base is bool:
        return bool(value) if is_bool else _MISMATCH
    if base is int and not is_bool:
        try:
            return operator.index(value)
        except TypeError:
            return _MISMATCH
    if base is float and isinstance(value, numbers.Real) and not is_bool:
        return float(value)
    if base is str and isinstance(value, str):
        return value
    return _MISMATCH


def _typed_value(value, tp, where: str, nullable: bool = False):
    """``value`` as the plain Python type the field's annotation ``tp`` names (a bool, an
    int, a float), or ParameterError."""
    base, optional = _annotated(tp)
    if value is None:
        if nullable or optional:
            return None
        raise ParameterError(f"{where} must be set, got None")
    v = _plain(value, base)
    if v is _MISMATCH:
        raise ParameterError(f"{where} must be {'an' if base is int else 'a'} "
                             f"{'string' if base is str else base.__name__}, "
                             f"got {value!r} ({type(value).__name__})")
    return v


def _same(a, b) -> bool:
    return type(a) is type(b) and (a == b or a != a)  # NaN stays NaN (refused later)


#: how much looser a draft's stopping rule is (:meth:`Params.drafted`, ``--draft``)
DRAFT_FACTOR = 4.0


@dataclass(frozen=True)
class Params:
    """All parameters of a packing run."""

    gap: float = _doc(None, "container units", "d_gap, the desired distance between neighbouring "
                      "elements' art in the final packing. None: 1% of the container's larger side, at most 4% of the widest circle inside it.")
    seed: int | None = _doc(None, "-", "Random seed; the same seed gives the same packing.")
    margin: float | None = _doc(None, "container units", "Smallest distance between any art and "
                                "the container's edge. None: half the gap.")
    preprocess: PreprocessParams = field(default_factory=PreprocessParams)
    placement: PlacementParams = field(default_factory=PlacementParams)
    sim: SimParams = field(default_factory=SimParams)
    secondary: SecondaryParams = field(default_factory=SecondaryParams)
    render: RenderParams = field(default_factory=RenderParams)
    verify: VerifyParams = field(default_factory=VerifyParams)
    output: OutputParams = field(default_factory=OutputParams)

    def _typed(self) -> "Params":
        """These parameters with every number a plain Python one (see :meth:`validate`);
        self when nothing changes."""
        changes: dict = {}
        hints = typing.get_type_hints(Params)
        for f in fields(Params):
            v = getattr(self, f.name)
            if f.name in _SECTIONS:
                cls = _SECTIONS[f.name]
                if not isinstance(v, cls):
                    raise ParameterError(
                        f"params.{f.name} must be a {cls.__name__}, got {type(v).__name__} "
                        "(params_from_dict builds Params from nested dicts, as a TOML file has them)")
                sub_hints = typing.get_type_hints(cls)
                sub = {g.name: _typed_value(getattr(v, g.name), sub_hints[g.name], f"{f.name}.{g.name}",
                                            g.default is None)
                       for g in fields(cls)}
                sub = {k: x for k, x in sub.items() if not _same(x, getattr(v, k))}
                if sub:
                    changes[f.name] = dataclasses.replace(v, **sub)
            else:
                t = _typed_value(v, hints[f.name], f.name, f.default is None)
                if not _same(t, v):
                    changes[f.name] = t
        return dataclasses.replace(self, **changes) if changes else self

    def validate(self) -> "Params":
        """Raise :class:`ParameterError` on values that cannot work; return the parameters
        with their numbers as plain Python ``float``/``int`` (numpy scalars, an ``int``
        for a float: what TOML would give), self when they were already."""
        typed = self._typed()
        if typed is not self:
            return typed.validate()
        if self.gap is not None and not (math.isfinite(self.gap) and self.gap > 0):
            raise ParameterError(f"gap must be a positive number, got {self.gap!r}")
        if self.margin is not None and not (math.isfinite(self.margin) and self.margin >= 0):
            raise ParameterError(f"margin must be a number >= 0, got {self.margin!r}")
        if self.seed is not None:
            try:
                seed_ok = 0 <= operator.index(self.seed) < 2**64
            except TypeError:
                seed_ok = False
            if not seed_ok:
                raise ParameterError(f"seed must be an integer in [0, 2**64), got {self.seed!r}")
        for section, cls in _SECTIONS.items():  # NaN / inf slip through the range checks
            sub = getattr(self, section)
            for f in fields(cls):
                v = getattr(sub, f.name)
                if isinstance(v, float) and not math.isfinite(v):
                    raise ParameterError(f"{section}.{f.name} must be a finite number, got {v!r}")
        p, s, pl = self.preprocess, self.sim, self.placement
        sec = self.secondary
        checks = [
            (p.mesh_spacing > 0, "preprocess.mesh_spacing must be > 0"),
            (p.skin_tolerance > 0, "preprocess.skin_tolerance must be > 0"),
            (0 < p.skin_offset <= 2, "preprocess.skin_offset must be in (0, 2] (× gap)"),
            (0 < p.min_angle <= 34, "preprocess.min_angle must be in (0, 34] degrees"),
            (0 < p.flatten_tolerance <= 0.25, "preprocess.flatten_tolerance must be in (0, 0.25]"),
            (3 <= p.min_boundary_vertices <= 100_000, "preprocess.min_boundary_vertices must be in [3, 100000]"),
            (pl.count is None or pl.count >= 1, "placement.count must be >= 1"),
            (pl.count is None or pl.count <= MAX_COUNT, f"placement.count must be <= {MAX_COUNT}"),
            (pl.candidates_per_point >= 1, "placement.candidates_per_point must be >= 1"),
            (pl.start_width >= 0, "placement.start_width must be >= 0"),
            (pl.max_vertices >= 1, "placement.max_vertices must be >= 1"),
            (pl.element_size > 0, "placement.element_size must be > 0"),
            (pl.min_element_size > 0, "placement.min_element_size must be > 0"),
            (pl.width_share > 0, "placement.width_share must be > 0"),
            (pl.variety >= 1, "placement.variety must be >= 1"),
            (0 < pl.initial_fraction < pl.target_fraction <= 1,
             "need 0 < placement.initial_fraction < placement.target_fraction <= 1"),
            (s.dt > 0 and s.dt <= 0.5, "sim.dt must be in (0, 0.5]"),
            (s.velocity_cap > 0, "sim.velocity_cap must be > 0"),
            (s.growth_headroom >= 0, "sim.growth_headroom must be >= 0"),
            *[(getattr(s, k) >= 0, f"sim.{k} must be >= 0 (a force constant), got {getattr(s, k)!r}")
              for k in ("k_edge", "k_overlap", "k_boundary", "k_shape", "k_align", "k_adhesion")],
            (s.k_repulsion is None or s.k_repulsion >= 0,
             f"sim.k_repulsion must be >= 0 (a force constant), got {s.k_repulsion!r}"),
            (s.align_reach >= 0, "sim.align_reach must be >= 0 (× gap)"),
            (s.adhesion_reach > 0, "sim.adhesion_reach must be > 0 (× gap)"),
            (s.k_growth is None or s.k_growth >= 0, "sim.k_growth must be >= 0"),
            (s.fast_growth >= 1, "sim.fast_growth must be >= 1"),
            (s.fast_growth_clearance >= 0, "sim.fast_growth_clearance must be >= 0"),
            (s.bend_limit >= 0 and s.bend_limit_convex >= 0, "sim.bend_limit and bend_limit_convex must be >= 0"),
            (0 <= s.skin_width <= 1, "sim.skin_width must be in [0, 1]"),
            (s.soft > 0, "sim.soft must be > 0"),
            (s.cell_size > 0, "sim.cell_size must be > 0"),
            (s.stop_window >= 2, "sim.stop_window must be >= 2"),
            (s.stop_vertices >= 0, "sim.stop_vertices must be >= 0 (0 = off)"),
            (0 <= s.one_sided_growth <= 1, "sim.one_sided_growth must be in [0, 1]"),
            (s.contact_depth >= 0, "sim.contact_depth must be >= 0 (× gap)"),
            (s.requery_every >= 1, "sim.requery_every must be >= 1"),
            (s.threads >= 0, "sim.threads must be >= 0 (0 = automatic)"),
            (s.relocations is None or s.relocations >= 0, "sim.relocations must be >= 0"),
            (s.max_size is None or s.max_size > 0, "sim.max_size must be > 0 (× nominal size)"),
            (s.max_iterations >= 1, "sim.max_iterations must be >= 1"),
            (s.stop_window <= 1_000_000, "sim.stop_window must be <= 1000000"),
            (min(s.min_iterations, s.settle_iterations, s.relax_passes) >= 0,
             "sim.min_iterations, settle_iterations and relax_passes must be >= 0"),
            (min(s.relax_fraction, s.stop_epsilon, s.boundary_inset, s.k_corner, s.outside_block,
                 s.min_triangle_area) >= 0,
             "sim.relax_fraction, stop_epsilon, boundary_inset, k_corner, outside_block and "
             "min_triangle_area must be >= 0"),
            (sec.d_min > 0 and sec.d_sep > 0, "secondary.d_min and d_sep must be > 0"),
            (64 <= sec.grid <= 10_000, "secondary.grid must be in [64, 10000]"),
            (sec.max_count is None or sec.max_count >= 0, "secondary.max_count must be >= 0"),
            (sec.candidates is None or sec.candidates >= 1, "secondary.candidates must be >= 1"),
            (0 < sec.initial_fraction <= 1, "secondary.initial_fraction must be in (0, 1]"),
            (sec.stop_epsilon >= 0 and sec.settle_iterations >= 0,
             "secondary.stop_epsilon and settle_iterations must be >= 0"),
            (sec.hole_min_radius > 0, "secondary.hole_min_radius must be > 0"),
            (0 <= sec.min_size <= 1, "secondary.min_size must be in [0, 1] (× the median primary's size)"),
            (0 <= sec.hole_depth <= 10, "secondary.hole_depth must be in [0, 10]"),
            (1e-7 <= self.render.curve_tolerance <= 0.05, "render.curve_tolerance must be in [1e-7, 0.05]"),
            # a looser fit eats into the gap, and the checks' flattening of it (a tenth of the
            # tolerance) drifts from what evaluate measures on the file: 0.5 let 14 of 159
            # copies end under 0.9 gap while the report said every promise held
            (0 < self.render.max_gap_share <= 0.05, "render.max_gap_share must be in (0, 0.05]"),
            (1 <= self.render.samples <= 64, "render.samples must be in [1, 64]"),
            (0 <= self.render.smoothing <= 1, "render.smoothing must be in [0, 1]"),
            (0.05 <= self.render.angle_tolerance <= 45, "render.angle_tolerance must be in [0.05, 45] degrees"),
            (0 <= self.verify.min_gap <= 2, "verify.min_gap must be in [0, 2] (× gap)"),
            (0 < self.verify.min_scale <= 1, "verify.min_scale must be in (0, 1]"),
            (self.verify.straighten >= 0, "verify.straighten must be >= 0"),
            (self.verify.grow_to == 0 or self.verify.grow_to >= self.verify.min_gap,
             f"verify.grow_to ({self.verify.grow_to!r}) must be 0 or >= verify.min_gap ({self.verify.min_gap!r})"),
            (self.verify.max_grow >= 1, "verify.max_grow must be >= 1"),
            (self.verify.gather == 0 or self.verify.gather > self.verify.grow_to > 0,
             f"verify.gather ({self.verify.gather!r}) must be 0 or > verify.grow_to ({self.verify.grow_to!r}) > 0"),
        ]
        for ok, msg in checks:
            if not ok:
                raise ParameterError(msg)
        for f in fields(OutputParams):  # the string fields name one of their choices
            v, choices = getattr(self.output, f.name), f.metadata["choices"]
            if v not in choices:
                close = difflib.get_close_matches(str(v), choices, n=1, cutoff=0.5)
                raise ParameterError(f"output.{f.name} must be one of {', '.join(choices)}, got {v!r}"
                                     + (f"; did you mean '{close[0]}'?" if close else ""))
        return self

    def with_(self, **changes) -> "Params":
        """These parameters with some changed, validated.

        Parameters
        ----------
        **changes
            Top-level names (``gap=5``, ``seed=1``) and nested ones with a double
            underscore between section and name (``sim__k_edge=40``,
            ``placement__count=30``).

        Returns
        -------
        Params
            A new, validated :class:`Params` (see :meth:`validate`).

        Raises
        ------
        ParameterError
            An unknown name (the message lists the valid ones) or a value that cannot work.
        """
        top_valid = [f.name for f in fields(Params)]
        top: dict = {}
        nested: dict[str, dict] = {}
        for key, value in changes.items():
            section, sep, name = key.partition("__")
            if not sep:
                if key not in top_valid:
                    raise _unknown_name(key, top_valid + [f"{s}__{f.name}" for s, c in _SECTIONS.items()
                                                          for f in fields(c)])
                top[key] = value
            elif section not in _SECTIONS:
                raise _unknown_name(key, [f"{s}__NAME" for s in _SECTIONS], "section ")
            else:
                valid = [f.name for f in fields(_SECTIONS[section])]
                if name not in valid:
                    raise _unknown_name(key, [f"{section}__{v}" for v in valid])
                nested.setdefault(section, {})[name] = value
        new = dataclasses.replace(self, **top)
        for section, sub in nested.items():
            new = dataclasses.replace(new, **{section: dataclasses.replace(getattr(new, section), **sub)})
        return new.validate()

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    def without_pocket_fill(self) -> "Params":
        """These parameters with the pockets left empty (``repulsionpak pack
        --no-pocket-fill``, the Inkscape dialog's and the studio's pocket fill unticked): no
        automatic small copies of the elements (``secondary.auto``), no leftover fill and no
        hole fill (``secondary.fill_leftover``, ``secondary.fill_holes``).

        Returns
        -------
        Params
            The new parameters, validated.

        Notes
        -----
        Secondary elements given explicitly (``--secondary``) are still simulated into the
        pockets; only the fills are off. Without pocket copies the primaries fill the voids
        themselves, and the simulation's defaults for such a run follow (the growth cap,
        repulsion and growth rate of :meth:`SimParams.for_run`; the moves at convergence).
        """
        return dataclasses.replace(self, secondary=dataclasses.replace(
            self.secondary, auto=False, fill_holes=False, fill_leftover=False)).validate()

    def drafted(self, factor: float = DRAFT_FACTOR) -> "Params":
        """These parameters for a draft (``repulsionpak pack --draft``): both growth phases
        stop at ``factor`` times their stopping threshold (``sim.stop_epsilon``,
        ``secondary.stop_epsilon``); nothing else changes.

        Parameters
        ----------
        factor : float
            How much looser the stopping rule is (> 0; 1 gives the same parameters).

        Returns
        -------
        Params
            The new parameters, validated. The report and the SVG's metadata list them, so a
            draft is recognisable by its thresholds.

        Notes
        -----
        Much of a packing's simulation is its primaries' last creep, where the jam gains a
        few thousandths of the area over many iterations, and the pocket copies take part
        of what it leaves: at 4x the main suite's primaries run 44,384 iterations instead
        of 65,279 and its scenes lose 0.0045 of art area on average (docs/benchmarks.md,
        "A draft"). On a scene with more moving vertices than ``sim.stop_vertices`` the
        factor multiplies its threshold per unit of work, which already stops the
        primaries early: the 1,000-element poster's stop after 713 iterations instead of
        1,076, but its looser jam leaves pockets for 688 copies instead of 497, whose
        verification takes the time back (about the same seconds), at art area 0.710
        against 0.724.
        """
        if not (isinstance(factor, (int, float)) and math.isfinite(factor) and factor > 0):
            raise ParameterError(f"the draft factor must be a positive number, got {factor!r}")
        return dataclasses.replace(
            self, sim=dataclasses.replace(self.sim, stop_epsilon=self.sim.stop_epsilon * factor),
            secondary=dataclasses.replace(self.secondary,
                                          stop_epsilon=self.secondary.stop_epsilon * factor)).validate()


#: Largest number of primary elements accepted (memory and time grow with it).
MAX_COUNT = 100_000

_SECTIONS = {"preprocess": PreprocessParams, "placement": PlacementParams,
             "sim": SimParams, "secondary": SecondaryParams, "render": RenderParams,
             "verify": VerifyParams, "output": OutputParams}


def _unknown_name(key: str, valid: list[str], what: str = "") -> ParameterError:
    """ParameterError for :meth:`Params.with_`: the unknown name, the closest valid one or all."""
    close = difflib.get_close_matches(key, valid, n=1, cutoff=0.6)
    hint = f"did you mean '{close[0]}'? " if close else ""
    return ParameterError(f"Params.with_(): unknown {what}name '{key}'; {hint}valid names: {', '.join(valid)}")


def _check_type(value, tp, where: str, source: str):
    """Coerce ``value`` to the annotated type ``tp`` or raise ConfigError."""
    base, optional = _annotated(tp)
    if value is None:
        if optional:
            return None
        raise ConfigError(f"{source}: {where} must not be empty")
    try:
        v = _plain(value, base)
    except OverflowError:
        raise ConfigError(f"{source}: {where} is too large ({str(value)[:20]}...)") from None
    if v is _MISMATCH:
        name = "string" if base is str else getattr(base, "__name__", str(base))
        article = "an" if name[:1] in "aeiou" else "a"
        raise ConfigError(f"{source}: {where} must be {article} {name}, got {value!r} ({type(value).__name__})")
    return v


def _unknown(key: str, valid: list[str], where: str, source: str) -> ConfigError:
    key = str(key)
    close = difflib.get_close_matches(key, valid, n=1, cutoff=0.5)
    hint = f"; did you mean '{close[0]}'?" if close else f"; valid keys: {', '.join(sorted(valid))}"
    return ConfigError(f"{source}: unknown key '{where}{key}'{hint}")


def params_from_dict(data: dict, source: str = "config", base: Params | None = None) -> Params:
    """Build :class:`Params` from a nested dict (as read from TOML), strictly."""
    base = base or Params()
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: expected a table of parameters")
    top_hints = typing.get_type_hints(Params)
    top_valid = [f.name for f in fields(Params)]
    changes: dict = {}
    for key, value in data.items():
        if key in _SECTIONS:
            cls = _SECTIONS[key]
            if not isinstance(value, dict):
                raise ConfigError(f"{source}: [{key}] must be a table")
            hints = typing.get_type_hints(cls)
            valid = [f.name for f in fields(cls)]
            sub = {}
            for k2, v2 in value.items():
                if k2 not in valid:
                    raise _unknown(k2, valid, f"{key}.", source)
                sub[k2] = _check_type(v2, hints[k2], f"{key}.{k2}", source)
            changes[key] = dataclasses.replace(getattr(base, key), **sub)
        elif key in top_valid:
            changes[key] = _check_type(value, top_hints[key], key, source)
        else:
            all_keys = top_valid + [f"{s}.{f.name}" for s, c in _SECTIONS.items() for f in fields(c)]
            raise _unknown(key, all_keys, "", source)
    try:
        return dataclasses.replace(base, **changes).validate()
    except ParameterError as exc:
        raise ConfigError(f"{source}: {exc}") from None


def load_config(path: str | Path, base: Params | None = None) -> Params:
    """Read a TOML file of parameters (sections ``[sim]``, ``[placement]`` ...)."""
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such config file") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, expected a TOML file") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not a text file (TOML must be UTF-8)") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except ValueError as exc:  # e.g. a NUL byte in the path
        raise ConfigError(f"{str(path)!r}: not a usable config path ({exc})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: invalid TOML: {exc}") from None
    except RecursionError:
        raise ConfigError(f"{path}: invalid TOML: arrays or tables nested too deeply") from None
    return params_from_dict(data, source=str(path), base=base)


def describe() -> list[tuple[str, object, str, str]]:
    """(key, default, unit, doc) for every parameter, for docs and ``--help``."""
    rows = []
    for f in fields(Params):
        if f.name in _SECTIONS:
            for g in fields(_SECTIONS[f.name]):
                d = g.default if g.default is not dataclasses.MISSING else None
                rows.append((f"{f.name}.{g.name}", d, g.metadata.get("unit", ""), g.metadata.get("doc", "")))
        else:
            rows.append((f.name, f.default, f.metadata.get("unit", ""), f.metadata.get("doc", "")))
    return rows
