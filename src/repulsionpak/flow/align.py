"""Each element's axis, each copy's target orientation in a flow field, and the measure of
alignment on the output art.

Angles are radians internally and degrees at the boundary (the manifest's ``axis``, the
measure), clockwise on screen (SVG's y axis points down), in the element's source frame.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


def _ring_moments(coords: np.ndarray) -> np.ndarray:
    """(area, Σx, Σy, Σxx, Σyy, Σxy) integrals of a closed ring (signed, Green's theorem)."""
    x, y = coords[:-1, 0], coords[:-1, 1]
    x1, y1 = coords[1:, 0], coords[1:, 1]
    c = x * y1 - x1 * y
    a = c.sum() / 2
    sx = ((x + x1) * c).sum() / 6
    sy = ((y + y1) * c).sum() / 6
    sxx = ((x * x + x * x1 + x1 * x1) * c).sum() / 12
    syy = ((y * y + y * y1 + y1 * y1) * c).sum() / 12
    sxy = ((x * y1 + 2 * x * y + 2 * x1 * y1 + x1 * y) * c).sum() / 24
    return np.array([a, sx, sy, sxx, syy, sxy])


def principal_axis(geometry) -> tuple[float, float]:
    """(angle in degrees in (-90, 90], elongation = sqrt(λ_max/λ_min)) of the long axis of a
    polygonal shapely geometry (second moments of area about its centroid)."""
    import shapely  # noqa: PLC0415

    m = np.zeros(6)
    for poly in getattr(geometry, "geoms", [geometry]):
        if not isinstance(poly, shapely.Polygon) or poly.is_empty:
            continue
        poly = shapely.geometry.polygon.orient(poly, 1.0)
        m += _ring_moments(np.asarray(poly.exterior.coords))
        for r in poly.interiors:
            m += _ring_moments(np.asarray(r.coords))
    a = m[0]
    if not a > 0:
        return 0.0, 1.0
    cx, cy = m[1] / a, m[2] / a
    ixx, iyy, ixy = m[3] / a - cx * cx, m[4] / a - cy * cy, m[5] / a - cx * cy
    ang = 0.5 * math.atan2(2 * ixy, ixx - iyy)
    deg = math.degrees(ang)
    if deg <= -90:
        deg += 180
    tr, det = ixx + iyy, ixx * iyy - ixy * ixy
    disc = math.sqrt(max(tr * tr / 4 - det, 0.0))
    lo, hi = tr / 2 - disc, tr / 2 + disc
    return deg, math.sqrt(hi / lo) if lo > 0 else float("inf")


def element_axis(element) -> tuple[float, bool]:
    """(axis in degrees in the source's frame, directed) of an element: its controls'
    ``axis`` (directed: the copy's axis points along the flow), or the principal axis of
    its art (undirected; the direction nearer the drawing's +x is taken)."""
    c = getattr(element, "controls", None)
    if c is not None and getattr(c, "axis", None) is not None:
        return float(c.axis), True
    from ..art_area import art_area  # noqa: PLC0415

    return principal_axis(art_area(element.paths))[0], False


def flow_targets(field, centroids: np.ndarray, ctrls: Sequence, axes: np.ndarray,
                 tolerance: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each copy's target orientation in ``field`` and how far it may turn from it.

    Parameters
    ----------
    field : FlowField
    centroids : (M, 2) array
        The copies' centroids, container units.
    ctrls : sequence of ElementControls
        Each copy's controls (``flow``, ``rotation``, ``angle``, ``max_rotation``).
    axes : (M,) array
        Each copy's axis (radians, source frame: :func:`element_axis`).
    tolerance : float
        Half-width (radians) of the window of a free element that aligns.

    Returns
    -------
    on : (M,) bool
        The copy follows the field (``flow = "align"``).
    centre, half : (M,) arrays
        Target orientation (radians) and half-width of its window.

    Notes
    -----
    A free copy turns its axis onto the field: centre θ − axis, ± ``tolerance``.
    ``upright``: the drawing's up side points to the left of the flow, i.e. its +x along
    the flow: centre θ + angle, within the controls' window (``ElementControls.limits``:
    ± max_rotation, less the upright margin); the axis does not matter. ``limited`` and
    ``fixed``: centre θ − axis + angle, within the same window (0 when fixed).
    """
    theta = field.angle(centroids)
    M = len(ctrls)
    on = np.array([getattr(c, "flow", "align") == "align" for c in ctrls], bool)
    centre = np.zeros(M)
    half = np.zeros(M)
    for k, c in enumerate(ctrls):
        a = math.radians(c.angle)
        lim = c.limits
        spread = np.pi if lim is None else 0.5 * (lim[1] - lim[0])
        if c.rotation == "upright":
            centre[k], half[k] = theta[k] + a, spread
        elif c.rotation in ("limited", "fixed"):
            centre[k], half[k] = theta[k] - axes[k] + a, spread
        else:
            centre[k], half[k] = theta[k] - axes[k], tolerance
    return on, centre, half


@dataclass(frozen=True)
class AlignStats:
    """Alignment of a packing's copies: ``angles`` (degrees, one per measured copy: the
    angle between the copy's axis and the field at its centroid, in [0, 90] for an
    undirected axis, [0, 180] for a directed one), their median and 90th percentile."""

    angles: np.ndarray

    @property
    def median(self) -> float:
        return float(np.median(self.angles)) if len(self.angles) else float("nan")

    @property
    def p90(self) -> float:
        return float(np.percentile(self.angles, 90)) if len(self.angles) else float("nan")

    def to_dict(self) -> dict:
        return {"count": int(len(self.angles)), "median": round(self.median, 2), "p90": round(self.p90, 2),
                "max": round(float(self.angles.max()), 2) if len(self.angles) else None}


def copy_rotations(placed: Sequence, elements: Sequence) -> tuple[np.ndarray, np.ndarray, list]:
    """(rotation degrees, centroid (K, 2), element) of each output copy whose source is
    among ``elements``: the rotation of the best similar copy of the source's art in area
    (:func:`repulsionpak.measure.similarity.distortion`), started from the copy's frame."""
    from ..art_area import art_area  # noqa: PLC0415
    from ..measure.similarity import distortion, frame_angle  # noqa: PLC0415

    by_name = {}
    for e in elements:
        by_name.setdefault(e.source, e)
    src_area = {k: art_area(e.paths) for k, e in by_name.items()}
    rots, cents, which = [], [], []
    for p in placed:
        e = by_name.get(p.source)
        if e is None:
            continue
        geom = art_area(p.paths, p.stroke_scale)
        if geom.is_empty:
            continue
        fit = distortion(src_area[p.source], geom, return_fit=True, angle=frame_angle(p.frame))
        if fit is None:
            continue
        rots.append(fit[1][0])
        c = geom.centroid
        cents.append((c.x, c.y))
        which.append(e)
    return np.array(rots, float), np.array(cents, float).reshape(-1, 2), which


def _diff(a: np.ndarray, b: np.ndarray, period: float) -> np.ndarray:
    d = np.mod(a - b + period / 2, period) - period / 2
    return np.abs(d)


def alignment_angles(placed: Sequence, elements: Sequence, field) -> AlignStats:
    """The angle between each output copy's axis and ``field`` at its centroid.

    Parameters
    ----------
    placed : sequence of PlacedArt
        The output copies (``packing.placed``, or read back from the SVG).
    elements : sequence of Element
        The source elements (their ``source`` names match the copies'); those with
        ``flow = "ignore"`` are left out.
    field : FlowField

    Returns
    -------
    AlignStats

    Notes
    -----
    Measured on the art, not the mesh: the copy's rotation is the best similarity fit of
    the source's art onto the copy's. Upright copies are measured by their +x direction
    (their up side to the left of the flow), others by their axis (:func:`element_axis`);
    an undirected axis is a line, compared modulo 180°.
    """
    rots, cents, which = copy_rotations(placed, elements)
    out = []
    theta = np.degrees(field.angle(cents)) if len(cents) else np.zeros(0)
    for r, t, e in zip(rots, theta, which):
        c = getattr(e, "controls", None)
        if c is not None and getattr(c, "flow", "align") == "ignore":
            continue
        if c is not None and c.rotation == "upright":
            out.append(_diff(r + c.angle, t, 360.0))
            continue
        axis, directed = element_axis(e)
        off = c.angle if c is not None and c.rotation in ("limited", "fixed") else 0.0
        out.append(_diff(r + axis - off, t, 360.0 if directed else 180.0))
    return AlignStats(np.array(out, float))


__all__ = ["AlignStats", "alignment_angles", "copy_rotations", "element_axis", "flow_targets",
           "principal_axis"]
