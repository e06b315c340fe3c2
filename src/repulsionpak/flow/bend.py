"""Bending along the flow (``flow_bend``, after FLOWPAK's skeletal strokes): a copy's rest
shape curves along the streamline through its centroid, within the shape promise.

The bend is an arc of constant curvature: each rest vertex at (s along the copy's axis,
t across it) from its centroid goes to the point at arc length s on the circle of
curvature κ tangent to the axis at the centroid, plus t times the circle's normal there
(:func:`bend_points`). κ is the streamline's mean curvature over the copy's length (its
turning between the two ends of the streamline traced through the centroid, over that
length: :func:`streamline_curvature`), capped so that the art's distortion stays within
a share of the shape promise (:func:`max_turn`) and the circle's radius stays above twice
the copy's half-width (no folded triangle).

:class:`FlowBend` holds the straight rest shapes; every ``every`` projections it writes
the bent rest of each bending copy, for its current centroid, size and direction, into
the model's ``x_rest`` (the reference of the bend limit, the rotation windows and the
shape-matching force) and its springs' rest lengths ``rest0`` (which hold the mesh's
shape: the default run has no shape-matching force).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: the share of an element's straightening limit (the art distortion beyond which the
#: verification replaces a copy by its unbent copy) its bend may use; the rest of the
#: budget is left to the deformation of the packing (its mesh bend limit is scaled by
#: 1 − BEND_SHARE)
BEND_SHARE = 0.6

#: projections between two updates of the bent rest shapes
BEND_EVERY = 10

#: largest |κ| × half-width: the bend's radius stays at least twice the half-width
MAX_KAPPA_WIDTH = 0.5


def bend_points(p: np.ndarray, centre: np.ndarray, axis: np.ndarray, kappa) -> np.ndarray:
    """``p`` bent along an arc of curvature ``kappa`` tangent to ``axis`` at ``centre``.

    Parameters
    ----------
    p : (K, 2) array
        The straight shape's points.
    centre : (2,) or (K, 2) array
        The point of the axis that stays put (per point, or one for all).
    axis : (2,) or (K, 2) array
        The unit axis direction (s grows along it); the normal is the axis turned by
        +90° (y down: clockwise on screen), and t is measured along it.
    kappa : float or (K,) array
        The signed curvature: the arc's tangent angle grows by κ per unit of s (the
        sign of ``atan2``'s angle).

    Returns
    -------
    (K, 2) array
        (s, t) → c + a·sin(κs)/κ + n·(1 − cos κs)/κ + t·(n·cos κs − a·sin κs).

    Notes
    -----
    An isometry along the axis: lengths along it are kept, lengths across it scale by
    1 + κt, so the shape stays a valid mesh while |κ·t| < 1.
    """
    p = np.asarray(p, float)
    a = np.broadcast_to(np.asarray(axis, float), p.shape)
    n = np.column_stack([-a[:, 1], a[:, 0]])
    d = p - centre
    s = (d * a).sum(axis=1)
    t = (d * n).sum(axis=1)
    k = np.broadcast_to(np.asarray(kappa, float), s.shape)
    ks = k * s
    small = np.abs(k) < 1e-12
    ksafe = np.where(small, 1.0, k)
    sin_k = np.where(small, s, np.sin(ks) / ksafe)
    cos_k = np.where(small, 0.5 * k * s * s, (1.0 - np.cos(ks)) / ksafe)
    c, sn = np.cos(ks), np.sin(ks)
    return (centre + a * sin_k[:, None] + n * cos_k[:, None]
            + t[:, None] * (n * c[:, None] - a * sn[:, None]))


def streamline_curvature(field, points: np.ndarray, lengths: np.ndarray, steps: int = 8) -> np.ndarray:
    """The mean curvature of the streamline through each point over ``lengths`` of it.

    Parameters
    ----------
    field : FlowField
    points : (K, 2) array
        Container units.
    lengths : (K,) array
        The length of streamline to average over (half on each side of the point).
    steps : int
        Midpoint (RK2) steps on each side.

    Returns
    -------
    (K,) array
        (θ(end) − θ(start)) / length traced, per unit of container length, signed as
        the field's angle (:meth:`FlowField.angle`): positive turns clockwise on screen.
    """
    p0 = np.atleast_2d(np.asarray(points, float))
    h = np.asarray(lengths, float) / (2 * steps)
    ends = []
    for sign in (1.0, -1.0):
        p = p0.copy()
        ref = field.direction(p0) * sign
        for _ in range(steps):
            d = field.direction(p)
            d *= np.where((d * ref).sum(axis=1) < 0, -1.0, 1.0)[:, None]  # keep the direction of travel
            dm = field.direction(p + 0.5 * h[:, None] * d)
            dm *= np.where((dm * d).sum(axis=1) < 0, -1.0, 1.0)[:, None]
            p = p + h[:, None] * dm
            ref = dm
        d = field.direction(p)
        d *= np.where((d * ref).sum(axis=1) < 0, -1.0, 1.0)[:, None]
        ends.append((p, d * sign))
    (pf, df), (pb, db) = ends
    turn = np.arctan2(df[:, 1], df[:, 0]) - np.arctan2(db[:, 1], db[:, 0])
    turn = np.mod(turn + np.pi, 2 * np.pi) - np.pi
    return turn / np.maximum(2 * steps * h, 1e-12)


def max_turn(geometry, axis_deg: float, budget: float) -> float:
    """The largest bend (radians of turning over the art's length along its axis) whose
    art distortion (:func:`repulsionpak.measure.similarity.distortion`) is ``budget``.

    Notes
    -----
    The distortion of a bend grows about linearly with its turning (a long ellipse
    0.032 per 10°, the flow scenes' fish 0.056, their leaf 0.047): measured at 15° and
    scaled, then measured again at that turn and scaled once more.
    """
    import shapely  # noqa: PLC0415

    from ..measure.similarity import distortion  # noqa: PLC0415

    c = geometry.centroid
    a = np.array([math.cos(math.radians(axis_deg)), math.sin(math.radians(axis_deg))])
    coords = shapely.get_coordinates(geometry)
    s = (coords - (c.x, c.y)) @ a
    length = float(s.max() - s.min()) if len(s) else 0.0
    if not length > 0 or not budget > 0:
        return 0.0

    def dist(turn: float) -> float:
        k = turn / length
        g = shapely.transform(geometry, lambda p: bend_points(p, np.array([c.x, c.y]), a, k))
        v = distortion(geometry, g)
        return float(v) if v is not None else 0.0

    turn = math.radians(15.0)
    for _ in range(2):
        d = dist(turn)
        if d <= 1e-9:
            return math.radians(90.0)
        turn = min(turn * budget / d, math.radians(90.0))
    return turn


@dataclass
class FlowBend:
    """The bending copies of a model.

    ``index`` (B,) their elements; ``axis`` (B,) each one's axis direction in its
    straight rest shape (radians); ``turn`` (B,) its largest turning over its length
    (radians); ``rest`` the straight rest vertices of every bending copy, concatenated
    (their model vertex indices in ``verts``, ``vptr`` (B+1,) the ranges); ``springs``
    the model spring indices of the bending copies, with ``spring_rest`` their straight
    rest lengths and ``spring_len`` their straight vertex distances; ``unit`` maps
    simulation units to the field's container units.
    """

    field: object
    index: np.ndarray
    axis: np.ndarray
    turn: np.ndarray
    verts: np.ndarray
    vptr: np.ndarray
    rest: np.ndarray
    springs: np.ndarray
    spring_rest: np.ndarray
    spring_len: np.ndarray
    unit: float
    every: int = BEND_EVERY
    calls: int = 0
    kappa: np.ndarray | None = None  # (B,) the last bend of each copy, rest units

    @staticmethod
    def for_copies(field, model, index: np.ndarray, axis: np.ndarray, turn: np.ndarray,
                   unit: float) -> "FlowBend":
        """The bend of the copies ``index`` of ``model`` (axis and largest turn each),
        their straight rest shapes taken from the model as it is."""
        index = np.asarray(index, np.int64)
        vs, sp = model.elem_vstart, model.spring_ptr
        verts = np.concatenate([np.arange(vs[e], vs[e + 1]) for e in index]) if len(index) else np.zeros(0, np.int64)
        vptr = np.concatenate([[0], np.cumsum([vs[e + 1] - vs[e] for e in index])]).astype(np.int64)
        springs = (np.concatenate([np.arange(sp[e], sp[e + 1]) for e in index]) if len(index)
                   else np.zeros(0, np.int64))
        rest = model.x_rest[verts].copy()
        ab = model.springs[springs]
        length = np.hypot(*(model.x_rest[ab[:, 0]] - model.x_rest[ab[:, 1]]).T)
        return FlowBend(field, index, np.asarray(axis, float), np.asarray(turn, float), verts, vptr, rest,
                        springs, model.rest0[springs].copy(), length, unit)

    def targets(self, x: np.ndarray) -> np.ndarray:
        """(B,) the curvature of each copy's bent rest (rest units) for vertices ``x``."""
        B = len(self.index)
        seg = np.repeat(np.arange(B), np.diff(self.vptr))
        cnt = np.diff(self.vptr).astype(float)
        xc = np.column_stack([np.bincount(seg, x[self.verts, i], B) for i in (0, 1)]) / cnt[:, None]
        rc = np.column_stack([np.bincount(seg, self.rest[:, i], B) for i in (0, 1)]) / cnt[:, None]
        w = self.rest - rc[seg]
        z = x[self.verts] - xc[seg]
        re = np.bincount(seg, (w * z).sum(axis=1), B)
        im = np.bincount(seg, w[:, 0] * z[:, 1] - w[:, 1] * z[:, 0], B)
        ww = np.bincount(seg, (w * w).sum(axis=1), B)
        scale = np.hypot(re, im) / np.maximum(ww, 1e-300)
        rot = np.arctan2(im, re)
        ax = np.column_stack([np.cos(self.axis), np.sin(self.axis)])
        s = (w * ax[seg]).sum(axis=1)
        t = (w * np.column_stack([-ax[:, 1], ax[:, 0]])[seg]).sum(axis=1)
        lo = np.full(B, np.inf)
        hi = np.full(B, -np.inf)
        np.minimum.at(lo, seg, s)
        np.maximum.at(hi, seg, s)
        half = np.zeros(B)
        np.maximum.at(half, seg, np.abs(t))
        length = np.maximum(hi - lo, 1e-12)  # rest units
        here = xc * self.unit
        kappa = streamline_curvature(self.field, here, length * scale * self.unit)  # container units
        world = self.axis + rot  # the axis's current direction
        d = self.field.direction(here)
        sign = np.where(np.cos(world) * d[:, 0] + np.sin(world) * d[:, 1] < 0, -1.0, 1.0)
        k = sign * kappa * self.unit * scale  # per rest unit
        cap = np.minimum(self.turn / length, MAX_KAPPA_WIDTH / np.maximum(half, 1e-12))
        return np.clip(k, -cap, cap)

    def update(self, x: np.ndarray, model) -> None:
        """Every ``every`` calls: write the bent rest shapes for vertices ``x`` into
        ``model.x_rest`` and their springs' rest lengths into ``model.rest0``."""
        self.calls += 1
        if not len(self.index) or (self.calls - 1) % self.every:
            return
        k = self.targets(x)
        self.kappa = k
        self.apply(model, k)

    def apply(self, model, kappa: np.ndarray) -> None:
        """Write the rest shapes bent by ``kappa`` (B,) into ``model``."""
        B = len(self.index)
        seg = np.repeat(np.arange(B), np.diff(self.vptr))
        cnt = np.diff(self.vptr).astype(float)
        rc = np.column_stack([np.bincount(seg, self.rest[:, i], B) for i in (0, 1)]) / cnt[:, None]
        ax = np.column_stack([np.cos(self.axis), np.sin(self.axis)])
        bent = bend_points(self.rest, rc[seg], ax[seg], kappa[seg])
        model.x_rest[self.verts] = bent
        ab = model.springs[self.springs]
        length = np.hypot(*(model.x_rest[ab[:, 0]] - model.x_rest[ab[:, 1]]).T)
        model.rest0[self.springs] = self.spring_rest * length / np.maximum(self.spring_len, 1e-300)





def source_axis(controls, axis_deg: float) -> float:
    """The direction (degrees, source frame) a copy with ``controls`` lays along the flow:
    its axis (``axis_deg``) when free, the drawing's +x turned by −angle when upright,
    axis − angle when limited or fixed (:func:`repulsionpak.flow.align.flow_targets`)."""
    if controls is None or controls.rotation == "free":
        return axis_deg
    if controls.rotation == "upright":
        return -controls.angle
    return axis_deg - controls.angle


def midline_curvature(geometry, axis_deg: float, trim: float = 0.2, slices: int = 17
                      ) -> tuple[float, float] | None:
    """(signed curvature, length) of the midline of ``geometry`` along ``axis_deg``.

    The shape is turned so the axis is +x about its centroid; each of ``slices`` vertical
    lines across the middle (1 − 2·``trim``) of its length meets it in an interval whose
    middle is a midline point; a parabola y = a + b·x + c·x² fitted to them gives the
    curvature 2c / (1 + b²)^1.5 at the centroid, signed as the field's angle (positive
    turns from the axis towards its +90°, clockwise on screen). None for an empty shape.
    """
    import shapely  # noqa: PLC0415

    if geometry.is_empty:
        return None
    c = geometry.centroid
    g = shapely.affinity.rotate(geometry, -axis_deg, origin=c)
    g = shapely.affinity.translate(g, -c.x, -c.y)
    x0, y0, x1, y1 = g.bounds
    length = x1 - x0
    xs, ys = [], []
    for x in np.linspace(x0 + trim * length, x1 - trim * length, slices):
        cut = g.intersection(shapely.LineString([(x, y0 - 1), (x, y1 + 1)]))
        if cut.is_empty:
            continue
        b = cut.bounds
        xs.append(x)
        ys.append(0.5 * (b[1] + b[3]))
    if len(xs) < 3:
        return None
    cc, bb, _ = np.polyfit(np.array(xs), np.array(ys), 2)
    return float(2 * cc / (1 + bb * bb) ** 1.5), float(length)


def curvature_match(placed, elements, field) -> dict:
    """The curvature of each output copy's art along its axis against the streamline's.

    Parameters
    ----------
    placed : sequence of PlacedArt
    elements : sequence of Element
        The sources; copies of ``flow = "ignore"`` elements are left out.
    field : FlowField

    Returns
    -------
    dict of (K,) arrays
        ``art`` the art midline's curvature (:func:`midline_curvature`, less the source's
        own: a fin on one side curves the midline of an unbent drawing), ``stream`` the
        streamline's mean curvature over the copy's length through its centroid (signed
        along the copy's axis), ``length`` the copy's length along its axis, ``source``
        the element names; container units.
    """
    from ..art_area import art_area  # noqa: PLC0415
    from ..measure.similarity import distortion, frame_angle  # noqa: PLC0415
    from .align import element_axis  # noqa: PLC0415

    by_name = {}
    for e in elements:
        by_name.setdefault(e.source, e)
    src = {k: art_area(e.paths) for k, e in by_name.items()}
    art, stream, length, names = [], [], [], []
    straight: dict = {}  # each source's own midline turning (an asymmetric drawing's is not 0)
    for p in placed:
        e = by_name.get(p.source)
        c = getattr(e, "controls", None)
        if e is None or (c is not None and c.flow == "ignore"):
            continue
        geom = art_area(p.paths, p.stroke_scale)
        if geom.is_empty:
            continue
        fit = distortion(src[p.source], geom, return_fit=True, angle=frame_angle(p.frame))
        if fit is None:
            continue
        direction = fit[1][0] + source_axis(c, element_axis(e)[0])
        m = midline_curvature(geom, direction)
        if p.source not in straight:
            own = midline_curvature(src[p.source], source_axis(c, element_axis(e)[0]))
            straight[p.source] = 0.0 if own is None else own[0] * own[1]
        if m is None:
            continue
        cen = np.array([[geom.centroid.x, geom.centroid.y]])
        k = streamline_curvature(field, cen, np.array([m[1]]))[0]
        u = field.direction(cen)[0]
        if math.cos(math.radians(direction)) * u[0] + math.sin(math.radians(direction)) * u[1] < 0:
            k = -k
        art.append(m[0] - straight[p.source] / m[1])
        stream.append(k)
        length.append(m[1])
        names.append(p.source)
    return {"art": np.array(art), "stream": np.array(stream), "length": np.array(length),
            "source": np.array(names, dtype=object)}


__all__ = ["BEND_EVERY", "BEND_SHARE", "FlowBend", "bend_points", "curvature_match", "max_turn",
           "midline_curvature", "source_axis", "streamline_curvature"]
