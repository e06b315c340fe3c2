"""The flow in a packing run: the field over the container, aligned start angles, and the
steering attached to the simulation model (the few lines :func:`repulsionpak.pack.pack`
calls)."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

import numpy as np

from ..errors import ParameterError
from .align import element_axis, flow_targets
from .field import FlowField, field_from_guides
from .guides import load_guides
from .bend import BEND_SHARE, FlowBend, max_turn
from .steer import FlowSteer

#: degrees a free copy that aligns may turn away from the field (its rotation window)
ALIGN_TOLERANCE = 4.0


def run_field(flow, container) -> FlowField:
    """``flow`` (a :class:`FlowField`, or the path of a guide SVG) as the field over
    ``container``."""
    if isinstance(flow, FlowField):
        return flow
    if isinstance(flow, (str, os.PathLike)):
        return field_from_guides(load_guides(flow), container.region.bounds)
    raise ParameterError(f"flow must be a guide SVG's path or a FlowField, got {type(flow).__name__}")


def check_elements(elements: Sequence) -> None:
    """Refuse ``flow_bend`` on an element that does not follow the flow (``flow = "ignore"``)
    or is rigid: its copies have no streamline to bend along, or cannot bend."""
    for e in elements:
        c = getattr(e, "controls", None)
        if c is not None and c.flow_bend and (c.flow == "ignore" or c.rigid):
            why = 'flow = "ignore"' if c.flow == "ignore" else "rigid = true"
            raise ParameterError(f"{e.source}: flow_bend needs an element that follows the flow and may "
                                 f"bend; it has {why}")


class Orienter:
    """Aligned start angles for :func:`repulsionpak.placement.place`: ``orient(positions,
    angles)`` turns every aligning copy onto its target at its position."""

    def __init__(self, field: FlowField, elements: Sequence, assignment: np.ndarray, ctrls: Sequence):
        self.field = field
        self.ctrls = [ctrls[int(i)] for i in assignment]
        axes = {}
        for i in set(map(int, assignment)):
            axes[i] = math.radians(element_axis(elements[i])[0])
        self.axes = np.array([axes[int(i)] for i in assignment])

    def __call__(self, positions: np.ndarray, angles: np.ndarray) -> np.ndarray:
        on, centre, _ = flow_targets(self.field, positions, self.ctrls, self.axes, 0.0)
        out = np.array(angles, float, copy=True)
        out[on] = centre[on]
        return out


def attach(model, field: FlowField, placement, ctrls: Sequence, elements: Sequence, pinned, unit: float,
           params=None, templates=None) -> None:
    """Steer the model's free aligning copies (``ctrls`` per copy, ``pinned`` copies left
    alone) by ``field``; the model's rotation windows are set for the start. Copies whose
    controls ask for ``flow_bend`` also bend along it (:mod:`.bend`), within a share of the
    shape promise of ``params`` (default parameters when None; ``templates``, the meshed
    elements, relate the art's length to the mesh's)."""
    n = len(ctrls)
    idx = np.asarray(placement.template_index)[:n]
    free = ~np.asarray(pinned, bool)[:n] if pinned is not None else np.ones(n, bool)
    axes = np.zeros(n)
    cache: dict = {}
    for k in range(n):
        if free[k]:
            i = int(idx[k])
            if i not in cache:
                cache[i] = math.radians(element_axis(elements[i])[0])
            axes[k] = cache[i]
    steer = FlowSteer.for_copies(field, np.asarray(placement.position, float)[:n], placement.angle[:n],
                                 ctrls, axes, math.radians(ALIGN_TOLERANCE), unit)
    keep = free[steer.index]
    steer.index, steer.offset, steer.half, steer.rest = (steer.index[keep], steer.offset[keep],
                                                         steer.half[keep], steer.rest[keep])
    model.rot_on[steer.index] = True
    model.rot_lo[steer.index], model.rot_hi[steer.index] = steer.windows(
        np.asarray(placement.position, float)[steer.index])
    model.flow = steer
    bending = [j for j, k in enumerate(steer.index) if ctrls[int(k)].flow_bend]
    if bending:
        steer.bend = _bend(model, field, steer, np.array(bending), idx, elements, params, unit, templates)


def bend_cap(element, axis_deg: float, params=None) -> float:
    """The largest turning (radians, over the art's length along ``axis_deg``) a copy of
    ``element`` may bend: its art distortion stays within :data:`~.bend.BEND_SHARE` of the
    verification's straightening limit (``verify.straighten`` × ``sim.bend_limit``, or
    ``bend_limit_convex`` for an element covering ≥ 0.9 of its convex hull, as
    :func:`repulsionpak.render.placed.is_convex`) of ``params`` (defaults when None)."""
    import shapely  # noqa: PLC0415

    from ..art_area import art_area  # noqa: PLC0415
    from ..params import Params  # noqa: PLC0415

    p = params if params is not None else Params()
    g = art_area(element.paths)
    hull = g.convex_hull.area
    convex = hull > 0 and g.area >= 0.9 * hull
    limit = (p.sim.bend_limit_convex if convex else p.sim.bend_limit) * p.verify.straighten
    return max_turn(shapely.make_valid(g), axis_deg, BEND_SHARE * limit)


def _mesh_over_art(template, axis: float) -> float:
    """The template's mesh length over its art's length along ``axis`` (radians; the
    outline is in the source's units, the mesh at the template's scale)."""
    import shapely  # noqa: PLC0415

    a = np.array([math.cos(axis), math.sin(axis)])
    art = shapely.get_coordinates(template.outline.geometry) @ a
    mesh = np.asarray(template.verts, float) @ a
    if not len(art) or not np.ptp(art) > 0:
        return 1.0
    return float(np.ptp(mesh) / (np.ptp(art) * template.scale))


def _bend(model, field: FlowField, steer: FlowSteer, rows: np.ndarray, idx: np.ndarray, elements: Sequence,
          params, unit: float, templates=None) -> FlowBend:
    """The bend of the aligning copies ``steer.index[rows]`` (``idx``: each copy's
    element), applied to their rest shapes at once; their mesh bend limits give up
    :data:`~.bend.BEND_SHARE` of the budget to the bend."""
    copies = steer.index[rows]
    offset = steer.offset[rows]
    turns: dict = {}
    turn = np.zeros(len(copies))
    for r, (k, off) in enumerate(zip(copies, offset)):
        i = int(idx[k])
        key = (i, round(float(off), 9))
        if key not in turns:
            turns[key] = bend_cap(elements[i], math.degrees(-off), params)
            if templates is not None:  # the cap is the art's turning: the longer mesh turns more
                turns[key] *= _mesh_over_art(templates[i], -float(off))
        turn[r] = turns[key]
    axis = steer.rest[rows] - offset  # the axis in the placed rest shape's frame
    bend = FlowBend.for_copies(field, model, copies, axis, turn, unit)
    model.bend_limit[copies] *= 1.0 - BEND_SHARE
    bend.update(model.x_rest.copy(), model)  # the start: bent for the placed positions
    return bend


__all__ = ["ALIGN_TOLERANCE", "Orienter", "attach", "bend_cap", "check_elements", "extend", "run_field"]


def extend(model, base, ctrls: Sequence, angles: np.ndarray) -> None:
    """Steer the copies ``model`` adds to ``base`` (the secondary phase's pocket copies,
    ``ctrls`` and start ``angles`` (radians) per added copy) by ``base.flow`` too.

    Notes
    -----
    The model knows no element files, so a copy's axis is its controls' ``axis`` or the
    principal axis of its rest skin ring (placed at its start angle, that angle taken
    off): the skin is the art offset by a fraction of the gap, so its long axis is the
    art's for elongated elements. A copy whose start angle is off its target is turned
    onto it by the first projection.
    """
    import shapely  # noqa: PLC0415

    from .align import principal_axis  # noqa: PLC0415

    old: FlowSteer = base.flow
    m0 = base.n_elements
    n = model.n_elements - m0
    if n <= 0:
        model.flow = old
        return
    vs, ns = model.elem_vstart, model.elem_nskin
    cent = np.zeros((n, 2))
    axes = np.zeros(n)
    for k in range(n):
        e = m0 + k
        pts = model.x_rest[vs[e]:vs[e + 1]]
        cent[k] = pts.mean(axis=0) * old.unit
        c = ctrls[k]
        if c.axis is not None:
            axes[k] = math.radians(c.axis)
        else:
            ring = model.x_rest[vs[e]:vs[e] + ns[e]]
            deg = principal_axis(shapely.Polygon(ring).buffer(0))[0]
            a = math.radians(deg) - float(angles[k])  # back to the source's frame
            axes[k] = math.atan2(math.sin(2 * a), math.cos(2 * a)) / 2  # a line: within ±90°
    new = FlowSteer.for_copies(old.field, cent, angles, ctrls, axes, math.radians(ALIGN_TOLERANCE), old.unit)
    idx = new.index + m0
    model.rot_on[idx] = True
    model.rot_lo[idx], model.rot_hi[idx] = new.windows(cent[new.index])
    model.flow = FlowSteer(old.field, np.concatenate([old.index, idx]), np.concatenate([old.offset, new.offset]),
                           np.concatenate([old.half, new.half]), np.concatenate([old.rest, new.rest]), old.unit)
