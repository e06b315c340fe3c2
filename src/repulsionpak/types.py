"""Plain data types that flow between the stages (io → preprocess → ... → render).

All coordinates are float64 arrays of shape (K, 2), y pointing down (SVG convention),
in the user units of the file they came from.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import shapely

from .art_area import art_area
from .errors import ParameterError


@dataclass(frozen=True)
class Style:
    """Presentation attributes kept from the input and written back unchanged.

    Colours are SVG colour strings as they should be written (``"#f06465"``), or
    ``None`` for ``none``. ``stroke_width`` is in the file's user units *before* any
    scaling of the element (render scales it with the element).
    """

    fill: str | None = "#000000"
    stroke: str | None = None
    stroke_width: float = 1.0
    opacity: float = 1.0
    fill_opacity: float = 1.0
    stroke_opacity: float = 1.0
    fill_rule: str = "nonzero"  # "nonzero" | "evenodd"
    stroke_linecap: str = "butt"
    stroke_linejoin: str = "miter"
    stroke_miterlimit: float = 4.0
    #: dash and gap lengths (user units before scaling, like ``stroke_width``); () = solid
    stroke_dasharray: tuple[float, ...] = ()
    stroke_dashoffset: float = 0.0
    #: SVG's ``paint-order`` ("normal": fill, then stroke, then markers; "stroke": the
    #: stroke below the fill, as outlined lettering is drawn)
    paint_order: str = "normal"
    #: the groups with an opacity below 1 this shape is drawn in, outermost first, as
    #: ``(key, opacity)`` (``key`` tells groups of one file apart): written back as nested
    #: ``<g opacity>`` around the paths, so shapes overlapping inside a translucent group
    #: compose as one layer, as browsers draw them. ``opacity`` is the product of the
    #: shape's own and these (what previews and visibility use).
    layers: tuple[tuple[int, float], ...] = ()

    @property
    def visible(self) -> bool:
        """True when the shape paints anything (fill or stroke, non-zero opacity)."""
        if self.opacity <= 0:
            return False
        has_fill = self.fill is not None and self.fill_opacity > 0
        has_stroke = self.stroke is not None and self.stroke_opacity > 0 and self.stroke_width > 0
        return has_fill or has_stroke


def _affine_of(fn) -> np.ndarray | None:
    """The (3, 3) matrix of ``fn`` on (K, 2) point arrays if it is affine, else None."""
    probe = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.37, -1.91]])
    try:
        out = np.asarray(fn(probe.copy()), dtype=float)
    except Exception:  # noqa: BLE001  (fn may only accept real subpaths)
        return None
    if out.shape != (4, 2) or not np.all(np.isfinite(out)):
        return None
    m = np.eye(3)
    m[:2, 0] = out[1] - out[0]
    m[:2, 1] = out[2] - out[0]
    m[:2, 2] = out[0]
    scale = 1.0 + float(np.abs(out).max())
    if np.abs(probe[3] @ m[:2, :2].T + m[:2, 2] - out[3]).max() > 1e-9 * scale:
        return None
    return m


#: the segment orders a :class:`CurveSubpath` may hold: line, quadratic, cubic
_ORDERS = frozenset((1, 2, 3))


@dataclass(frozen=True, eq=False)
class CurveSubpath:
    """One subpath as drawn: a chain of line, quadratic and cubic Bézier segments.

    ``order[i]`` is 1 (line), 2 (quadratic) or 3 (cubic); ``ctrl[i]`` (4, 2) holds the
    segment's ``order + 1`` control points followed by copies of its end point. Segment
    i ends where segment i + 1 starts; a closed subpath's last segment ends at the first
    segment's start (an explicit closing line is included when the drawing has one).
    Arcs are stored as cubics (at most 45° each, error < 1e-5 of the radius).
    """

    order: np.ndarray  # (n,) int8
    ctrl: np.ndarray  # (n, 4, 2) float64
    closed: bool

    def __post_init__(self):
        """Check the segments and store ``order`` as int8 (n,), ``ctrl`` as float (n, 4, 2).

        Notes
        -----
        The orders are checked as a set of Python ints: the writer and the dents make
        ~100,000 subpaths on a 1,000-element poster, and the three array comparisons
        were half of each one's cost."""
        order = np.asarray(self.order, dtype=np.int8).reshape(-1)
        ctrl = np.asarray(self.ctrl, dtype=float).reshape(-1, 4, 2)
        if len(order) != len(ctrl) or len(order) == 0 or not set(order.tolist()) <= _ORDERS:
            raise ValueError("CurveSubpath needs n >= 1 segments with order 1, 2 or 3 and ctrl of shape (n, 4, 2)")
        object.__setattr__(self, "order", order)
        object.__setattr__(self, "ctrl", ctrl)

    @property
    def start(self) -> np.ndarray:
        return self.ctrl[0, 0]

    def end_points(self) -> np.ndarray:
        """(n, 2) end point of every segment."""
        return self.ctrl[np.arange(len(self.order)), self.order]

    def transformed(self, matrix: np.ndarray) -> "CurveSubpath":
        """The subpath under the affine map ``matrix`` (3, 3) (exact for Béziers)."""
        m = np.asarray(matrix, dtype=float)
        return CurveSubpath(self.order, self.ctrl @ m[:2, :2].T + m[:2, 2], self.closed)


@dataclass(frozen=True, eq=False)
class ShapeSource:
    """What a shape looked like in its SVG file, beyond its flattened outline.

    ``curves``: the exact outline (user units of the file, or container units for
    placed art). ``tag`` and ``attrs``: the shape's own markup (geometry attributes and
    resolved presentation attributes, without ``transform``), and ``matrix`` (3, 3) the
    composed transform from its local coordinates to user units — the container group of
    the output redraws its shapes from these. ``fill_paint``/``stroke_paint``: id of the
    gradient or pattern the shape is painted with (a key of the element's
    ``paint_servers``), ``local_bbox`` (x0, y0, x1, y1) its bounding box in local
    coordinates (for ``objectBoundingBox`` units); ``id`` its own id, if any.
    """

    curves: tuple[CurveSubpath, ...]
    tag: str = "path"
    attrs: tuple[tuple[str, str], ...] = ()
    matrix: np.ndarray = field(default_factory=lambda: np.eye(3))
    fill_paint: str | None = None
    stroke_paint: str | None = None
    local_bbox: tuple[float, float, float, float] | None = None
    id: str | None = None


@dataclass(frozen=True, eq=False)
class ArtPath:
    """One drawable SVG shape: one or more flattened subpaths painted with one style.

    ``subpaths[i]`` is a (K_i, 2) float64 array with K_i >= 2 and no repeated closing
    point; ``closed[i]`` says whether subpath i ends with ``Z``.
    """

    subpaths: tuple[np.ndarray, ...]
    closed: tuple[bool, ...]
    style: Style = field(default_factory=Style)
    source: ShapeSource | None = None  # exact curves and markup, when known (SVG input, rendered art)

    def transformed(self, fn) -> "ArtPath":
        """Return a copy whose every subpath is ``fn(points) -> points``.

        When ``fn`` is affine (checked on four points) the curve-level ``source`` moves
        with it (curves and paint transform); otherwise it is dropped. Several paths under
        one ``fn``: :func:`transformed_paths`."""
        return self._moved(fn, None if self.source is None else _affine_of(fn))

    def _moved(self, fn, m: np.ndarray | None) -> "ArtPath":
        """:meth:`transformed` with ``m``, :func:`_affine_of` ``fn``, given."""
        subs = tuple(np.asarray(fn(p), dtype=float) for p in self.subpaths)
        src = self.source
        if src is not None:
            src = None if m is None else dataclasses.replace(
                src, curves=tuple(c.transformed(m) for c in src.curves),
                matrix=m @ np.asarray(src.matrix, dtype=float))
        return ArtPath(subs, self.closed, self.style, source=src)

    @property
    def n_points(self) -> int:
        return int(sum(len(p) for p in self.subpaths))


def transformed_paths(paths: Sequence[ArtPath], fn) -> tuple[ArtPath, ...]:
    """Several paths under one map, as :meth:`ArtPath.transformed` moves each.

    Parameters
    ----------
    paths : sequence of ArtPath
        The paths (e.g. one copy's art).
    fn : callable
        ``fn(points) -> points`` on (K, 2) arrays, the same map for every path.

    Returns
    -------
    tuple of ArtPath
        ``tuple(a.transformed(fn) for a in paths)``, to the bit: ``fn`` is probed for its
        affine matrix once for all of them.

    Notes
    -----
    A copy's art is a dozen paths moved by one map; the probe (``fn`` on four points and
    a check) was a third of the cost of moving a path, thousands of times over in the
    repairs of a 1,000-element poster."""
    m = None
    probed = False
    out = []
    for a in paths:
        if a.source is not None and not probed:
            m, probed = _affine_of(fn), True
        out.append(a._moved(fn, m))
    return tuple(out)


@dataclass(frozen=True, eq=False)
class Element:
    """An element of the library, as drawn: its art in paint order (first = back)."""

    name: str  # e.g. "cat"
    source: str  # file name written to data-source, e.g. "cat.svg"
    paths: tuple[ArtPath, ...]
    #: gradients and patterns the paths refer to: id -> self-contained SVG markup
    paint_servers: dict = field(default_factory=dict)
    #: designer controls (:class:`ElementControls`); None: defaults
    controls: object | None = None

    def all_points(self) -> np.ndarray:
        """All art vertices stacked, shape (P, 2)."""
        return np.concatenate([p for a in self.paths for p in a.subpaths], axis=0)


@dataclass(frozen=True, eq=False)
class Container:
    """The region to fill: a valid shapely (Multi)Polygon, holes included.

    ``paths`` are the outlines as drawn (for the output's ``<g id="container">``);
    ``svg_root`` holds the root attributes (``width``, ``height``, ``viewBox``) that
    reproduce the container file's coordinate system in the output.
    """

    source: str
    region: shapely.Geometry
    paths: tuple[ArtPath, ...] = ()
    svg_root: dict = field(default_factory=dict)
    #: gradients and patterns the outlines refer to: id -> self-contained SVG markup
    paint_servers: dict = field(default_factory=dict)
    #: the file it was read from (None: built in memory)
    path: str | None = None
    #: the curve tolerance it was flattened to (None: the reader's default, which
    #: :func:`repulsionpak.inputs.run_container` replaces by the run's)
    tolerance: float | None = None

    @property
    def area(self) -> float:
        return float(self.region.area)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        return tuple(float(b) for b in self.region.bounds)  # type: ignore[return-value]


class computed_once:
    """A read-only attribute computed on first use and kept in the instance
    (``functools.cached_property`` without its lock).

    Notes
    -----
    Python 3.11's ``cached_property`` holds one lock per attribute of a class, for all its
    instances: threads computing the art of different copies
    (:func:`repulsionpak.threads.thread_map`) would take turns. Two threads asking for the
    same copy's value at once may both compute it; they compute the same value.
    """

    def __init__(self, func):
        self.func = func
        self.__doc__ = func.__doc__
        self.name = func.__name__

    def __set_name__(self, owner, name: str) -> None:
        self.name = name

    def __get__(self, obj, objtype=None):
        if obj is None:
            return self
        cache = obj.__dict__
        if self.name not in cache:
            cache[self.name] = self.func(obj)
        return cache[self.name]


@dataclass(frozen=True, eq=False)
class PlacedArt:
    """One element as it appears in the finished packing (container user units).

    ``paths`` are already deformed; ``stroke_scale`` multiplies every stroke width of
    ``paths`` (the element's overall scale from its file units to the container's).
    ``deformation`` is a dimensionless measure of how far the element's mesh is from a
    similarity transform of its rest shape (0 = rigid); ``None`` if unknown.
    When the art was rendered as curves, each path's ``source.curves`` are the curves
    written and its ``subpaths`` a fine flattening of them (so metrics see exactly what is
    written); ``paint_servers`` are the copy's own gradients and patterns (ids unique).
    """

    source: str
    kind: str  # "primary" | "secondary"
    paths: tuple[ArtPath, ...]
    stroke_scale: float = 1.0
    deformation: float | None = None
    paint_servers: dict = field(default_factory=dict)
    #: (3, 3) similarity from the element's rest frame (its template: centred, at the
    #: template's scale) to container units, least squares over the mesh; None if unknown
    frame: np.ndarray | None = None
    #: the curve tolerance the art was fitted to (container units); the writer rounds the
    #: coordinates of curves to match it (to tol/5); None: 6 decimals
    tolerance: float | None = None
    #: a pinned copy (element controls): written with ``data-pinned="true"``
    pinned: bool = False

    @computed_once
    def art(self) -> shapely.Geometry:
        """The area its art covers (:func:`repulsionpak.art_area.art_area` of
        ``paths`` with ``stroke_scale``), computed once: the hole fill, the verification
        and the metrics all measure it (a copy is never changed in place; a changed copy
        is a new object)."""
        return art_area(self.paths, self.stroke_scale)


# --------------------------------------------------------------------------- designer controls


ROTATIONS = ("free", "fixed", "limited", "upright")
FLOWS = ("align", "ignore")
#: degrees an upright copy's mesh is held inside its ± max_rotation: the rotation of the
#: best similar copy of the deformed art can differ from the mesh's by a degree or two,
#: and the promise is on the art
UPRIGHT_MARGIN = 2.5


@dataclass(frozen=True)
class Pin:
    """A fixed copy: the centre of the art's bounding box at (``x``, ``y``) (container
    units), turned by ``angle`` degrees clockwise, at ``scale`` × the source's units."""

    x: float
    y: float
    angle: float = 0.0
    scale: float = 1.0


@dataclass(frozen=True)
class ElementControls:
    """How the copies of one element may move and deform.

    rotation: "free" | "fixed" (every copy at ``angle``) | "limited" (within
    ± ``max_rotation`` of ``angle``) | "upright" (the drawing's up side kept within
    ± ``max_rotation`` of ``angle``; with a flow field, up points to the left of the
    flow), degrees clockwise. axis: the element's axis in degrees in its source's
    frame (None: its principal axis); flow: "align" (follow a flow field) | "ignore";
    flow_bend: bend along the flow's streamline. rigid: the art never deforms
    (translation, rotation and growth only). stiffness: multiplier of the spring and
    shape-keeping constants (ignored when rigid). weight: relative frequency of free
    copies (0: none). pins: fixed copies that never move.
    """

    rotation: str = "free"
    angle: float = 0.0
    max_rotation: float = 20.0
    rigid: bool = False
    stiffness: float = 1.0
    weight: float = 1.0
    pins: tuple[Pin, ...] = ()
    axis: float | None = None
    flow: str = "align"
    flow_bend: bool = False

    def __post_init__(self):
        object.__setattr__(self, "pins", tuple(self.pins))
        if self.rotation not in ROTATIONS:
            raise ParameterError(f"rotation must be one of {', '.join(ROTATIONS)}, got {self.rotation!r}")
        for name in ("angle", "max_rotation", "stiffness", "weight"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ParameterError(f"{name} must be a finite number, got {v!r}")
        if self.flow not in FLOWS:
            raise ParameterError(f"flow must be one of {', '.join(FLOWS)}, got {self.flow!r}")
        if self.axis is not None and (isinstance(self.axis, bool) or not isinstance(self.axis, (int, float))
                                      or not math.isfinite(self.axis)):
            raise ParameterError(f"axis must be a finite number of degrees, got {self.axis!r}")
        if not isinstance(self.flow_bend, bool):
            raise ParameterError(f"flow_bend must be true or false, got {self.flow_bend!r}")
        if not 0 <= self.max_rotation <= 180:
            raise ParameterError(f"max_rotation must be between 0 and 180 degrees, got {self.max_rotation:g}")
        if not self.stiffness > 0:
            raise ParameterError(f"stiffness must be > 0, got {self.stiffness:g}")
        if not self.weight >= 0:
            raise ParameterError(f"weight must be >= 0, got {self.weight:g}")
        if not isinstance(self.rigid, bool):
            raise ParameterError(f"rigid must be true or false, got {self.rigid!r}")
        for p in self.pins:
            if not isinstance(p, Pin):
                raise ParameterError("pins must be Pin(x, y, angle, scale) values")
            if not (math.isfinite(p.x) and math.isfinite(p.y) and math.isfinite(p.angle)) or not p.scale > 0:
                raise ParameterError(f"pin {p}: x, y and angle must be finite and scale > 0")

    @property
    def is_default(self) -> bool:
        return self == ElementControls()

    @property
    def limits(self) -> tuple[float, float] | None:
        """(low, high) absolute orientation in radians, or None when free."""
        if self.rotation == "fixed":
            a = math.radians(self.angle)
            return a, a
        if self.rotation == "upright" and self.max_rotation < 180:
            a, d = math.radians(self.angle), math.radians(self.max_rotation)
            d -= min(math.radians(UPRIGHT_MARGIN), 0.25 * d)
            return a - d, a + d
        if self.rotation == "limited" and self.max_rotation < 180:
            a, d = math.radians(self.angle), math.radians(self.max_rotation)
            return a - d, a + d
        return None
