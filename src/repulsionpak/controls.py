"""Designer controls per element: rotation limits, rigid and stiff elements,
frequencies and pinned copies.

An :class:`~repulsionpak.types.Element` may carry an :class:`ElementControls`
(``element.controls``); the element manifest (:mod:`repulsionpak.io.manifest`) and the
CLI shortcuts ``--rotation``, ``--rigid``, ``--stiffness`` build them. An element without
controls (``None``) or with the default ones packs exactly as before.

Angles are in degrees, clockwise on screen (SVG's y axis points down), measured on the
art as drawn in its source file.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .errors import ParameterError
from .types import ROTATIONS, ElementControls, Pin

def parse_rotation(text: str) -> tuple[str, float | None]:
    """CLI ``--rotation``: ``free``, ``fixed``, ``fixed:DEG``, ``limited:DEG``, ``upright`` or
    ``upright:DEG`` -> (rotation, angle for fixed / max_rotation for limited and upright,
    or None)."""
    name, _, arg = text.partition(":")
    name = name.strip().lower()
    if name not in ROTATIONS:
        raise ParameterError(f"--rotation must be free, fixed[:ANGLE], limited:DEG or upright[:DEG], got {text!r}")
    if not arg:
        return name, None
    if name == "free":
        raise ParameterError(f"--rotation free takes no angle, got {text!r}")
    try:
        value = float(arg)
    except ValueError:
        raise ParameterError(f"--rotation {name}: {arg!r} is not a number of degrees") from None
    return name, value


def cli_controls(rotation: str | None = None, rigid: bool = False,
                 stiffness: float | None = None) -> ElementControls | None:
    """Default controls from the CLI shortcuts, or None when none is given."""
    if rotation is None and not rigid and stiffness is None:
        return None
    kw: dict = {"rigid": bool(rigid)}
    if rotation is not None:
        name, value = parse_rotation(rotation)
        kw["rotation"] = name
        if value is not None:
            kw["angle" if name == "fixed" else "max_rotation"] = value
    if stiffness is not None:
        kw["stiffness"] = float(stiffness)
    try:
        return ElementControls(**kw)
    except ParameterError as e:  # name the option, not the manifest key
        option = "--stiffness" if "stiffness" in str(e) else "--rotation"
        raise ParameterError(f"{option}: {e}") from None


def controls_of(elements: Sequence) -> list[ElementControls]:
    """Each element's controls (the defaults where it has none)."""
    return [getattr(e, "controls", None) or ElementControls() for e in elements]


def any_controls(elements: Sequence) -> bool:
    return any(not c.is_default for c in controls_of(elements))


def weighted_assignment(weights: Sequence[float], count: int, rng: np.random.Generator) -> np.ndarray:
    """(count,) library indices with element i drawn ~ count·w_i/Σw times (exactly its
    floor, the remainders drawn at random by their fractional parts), shuffled."""
    w = np.asarray(weights, dtype=float)
    if not (w.sum() > 0):
        raise ParameterError("every element has weight 0: there is nothing to pack freely")
    expect = count * w / w.sum()
    n = np.floor(expect).astype(np.int64)
    rest = count - int(n.sum())
    if rest > 0:
        frac = expect - n
        extra = rng.choice(len(w), size=rest, replace=False, p=frac / frac.sum())
        n[extra] += 1
    out = np.repeat(np.arange(len(w)), n)
    return out[rng.permutation(len(out))]


def initial_angles(ctrls: Sequence[ElementControls], assignment: np.ndarray, angles: np.ndarray,
                   rng: np.random.Generator) -> np.ndarray:
    """Start angles (radians): fixed elements at their angle, limited ones uniformly in
    their range, free ones keep ``angles``."""
    out = np.array(angles, dtype=float, copy=True)
    for k, i in enumerate(assignment):
        lim = ctrls[int(i)].limits
        if lim is not None:
            out[k] = lim[0] if lim[0] == lim[1] else rng.uniform(lim[0], lim[1])
    return out


# -- the packing side ----------------------------------------------------------------

def pin_transform(outline, pin: Pin) -> tuple[np.ndarray, float]:
    """(position, angle radians) of a copy of the template of ``outline`` at ``pin``: the
    template is centred on the outline's centroid; the pin places the centre of its
    bounding box."""
    x0, y0, x1, y1 = outline.geometry.bounds
    off = (np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1)]) - outline.center) * pin.scale
    a = math.radians(pin.angle)
    c, s = math.cos(a), math.sin(a)
    return np.array([pin.x, pin.y]) - np.array([c * off[0] - s * off[1], s * off[0] + c * off[1]]), a


def prepare_controlled(container, elements, params, rng, gap, flow=None):
    """:func:`repulsionpak.pack.prepare` with designer controls: weighted assignment,
    start angles within the rotation limits (along ``flow``, a
    :class:`repulsionpak.flow.FlowField`, where given), and pinned copies (frozen, appended
    after the free ones; the free ones are placed around them). Returns (templates,
    placement, pinned mask (M,), controls (M,))."""
    import shapely  # noqa: PLC0415

    from .inputs import margin_of
    from .placement import Placement, assign_elements, estimate_count, final_scale, place, placed_vertices
    from .preprocess import build_template, outline_of

    ctrls = controls_of(elements)
    outlines = [outline_of(e) for e in elements]
    pins = [(i, p) for i, c in enumerate(ctrls) for p in c.pins]
    pin_templates = [build_template(outlines[i], p.scale, gap, params.preprocess) for i, p in pins]
    pin_pos, pin_ang, pin_skins = [], [], []
    for (i, p), t in zip(pins, pin_templates):
        pos, a = pin_transform(outlines[i], p)
        pin_pos.append(pos)
        pin_ang.append(a)
        pin_skins.append(shapely.Polygon(placed_vertices(t, pos, a, 1.0)[:t.n_skin]))
    region = container.region
    margin = margin_of(params, gap)
    inner = shapely.buffer(region, -(1.0 - 1e-6) * margin) if margin > 0 else region
    arts = []
    for k, (i, p) in enumerate(pins):
        o = outlines[i]
        art = shapely.affinity.rotate(shapely.affinity.scale(
            shapely.affinity.translate(o.geometry, -o.center[0], -o.center[1]), p.scale, p.scale,
            origin=(0, 0)), pin_ang[k], origin=(0, 0), use_radians=True)
        arts.append(shapely.affinity.translate(art, *pin_pos[k]))
    for k, ((i, p), art) in enumerate(zip(pins, arts)):
        where = f"{elements[i].source}: pin ({p.x:g}, {p.y:g})"
        if not shapely.covers(inner, art):
            raise ParameterError(f"{where} lies (partly) outside the container or closer than the "
                                 f"edge margin ({margin:g}) to its edge; move it inwards or make it smaller")
        for (j, q), other in zip(pins[k + 1:], arts[k + 1:]):
            # the art a gap apart, as the packing keeps it (their skins, 0.6 gap wide each,
            # may overlap: pinned meshes never move; the check was on them, and refused pins
            # whose art stood 1.17 gaps apart)
            d = float(art.distance(other))
            if d < gap:
                raise ParameterError(
                    f"{where} {'overlaps' if d == 0 else f'is {d:.3g} from'} the pin ({q.x:g}, {q.y:g}) of "
                    f"{elements[j].source}{'' if d == 0 else f', closer than the gap ({gap:g})'}; move them apart")
    free = region
    if pin_skins:
        free = shapely.difference(region, shapely.buffer(shapely.union_all(pin_skins), 0.5 * gap))
        if free.is_empty or free.area <= 0:
            raise ParameterError("the pinned copies cover the whole container: nothing left to pack")
    weights = [c.weight for c in ctrls]
    count = estimate_count(free.area, gap, params.placement)
    if len(set(weights)) == 1 and weights[0] > 0:
        assignment = assign_elements(len(elements), count, rng)
    else:
        assignment = weighted_assignment(weights, count, rng)
    scale = final_scale(outlines, assignment, free.area, params.preprocess.skin_offset * gap,
                        params.placement.target_fraction)
    templates = [build_template(o, scale, gap, params.preprocess) for o in outlines]
    orient = None
    if flow is not None:
        from .flow.hook import Orienter  # noqa: PLC0415

        orient = Orienter(flow, elements, assignment, ctrls)
    placement = place(templates, assignment, free, params.placement, rng,
                      angle_fn=lambda a: initial_angles(ctrls, assignment, a, rng), orient=orient)
    n = len(assignment)
    if pins:
        placement = Placement(
            np.concatenate([placement.template_index, len(templates) + np.arange(len(pins))]),
            np.vstack([placement.position, np.array(pin_pos)]),
            np.concatenate([placement.angle, np.array(pin_ang)]),
            np.concatenate([np.full(n, placement.shrink_of(0)), np.ones(len(pins))]))
    pinned = np.zeros(n + len(pins), bool)
    pinned[n:] = True
    per_elem = [ctrls[int(i)] for i in assignment] + [ctrls[i] for i, _ in pins]
    return templates + pin_templates, placement, pinned, per_elem


def setup_model(model, ctrls, angles, pinned=None, base=None) -> None:
    """Fill the control arrays of ``model`` (sim/controls.py) for its elements from
    ``base``'s count on: ``ctrls`` and ``angles`` (start angles, radians) of those
    elements; ``base`` (the model it extends) gives the first ones."""
    M = model.n_elements
    m0 = 0 if base is None else base.n_elements
    on, lo, hi = np.zeros(M, bool), np.zeros(M), np.zeros(M)
    rigid, pin = np.zeros(M, bool), np.zeros(M, bool)
    allc = [ElementControls()] * M
    if base is not None and base.rot_on is not None:
        on[:m0], lo[:m0], hi[:m0] = base.rot_on, base.rot_lo, base.rot_hi
        rigid[:m0], pin[:m0] = base.rigid, base.pinned
        model.stiffness[:m0] = base.stiffness
        allc[:m0] = base.controls
    for k, (c, a) in enumerate(zip(ctrls, angles)):
        e = m0 + k
        allc[e] = c
        lim = c.limits
        if lim is not None:
            on[e], lo[e], hi[e] = True, lim[0] - a, lim[1] - a
        rigid[e] = c.rigid
        if not c.rigid:
            model.stiffness[e] = c.stiffness
            if c.stiffness != 1.0:  # a stiffer element may bend less, a softer one more
                model.bend_limit[e] /= c.stiffness
        else:
            model.bend_limit[e] = 0.0  # the projection keeps it exact
    if pinned is not None:
        pin[m0:m0 + len(pinned)] |= np.asarray(pinned, bool)
    model.rot_on, model.rot_lo, model.rot_hi, model.rigid, model.pinned = on, lo, hi, rigid, pin
    model.stiff_edges = bool((model.stiffness != 1.0).any())
    model.controls = allc
    if base is not None and getattr(base, "flow", None) is not None:  # the added copies follow the flow too
        from .flow.hook import extend  # noqa: PLC0415

        extend(model, base, list(ctrls), np.asarray(angles, float))


def straighten_limits(model, limits: np.ndarray) -> np.ndarray:
    """The verification's straightening limits under the controls: scaled by 1/stiffness;
    rigid and pinned copies are never bent."""
    if model.rot_on is None:
        return limits
    out = limits / model.stiffness
    out[model.rigid | model.pinned] = np.inf
    return out


__all__ = ["ElementControls", "Pin", "cli_controls", "parse_rotation", "controls_of", "any_controls",
           "weighted_assignment", "initial_angles", "ROTATIONS", "prepare_controlled", "setup_model",
           "straighten_limits", "pin_transform"]
