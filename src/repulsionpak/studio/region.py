"""The container a designer paints: a loaded region plus brush strokes, as shapely geometry.

A stroke is a polyline swept by a round brush (``buffer`` of the line by the brush's
radius); painting unites it with the region, erasing subtracts it, in the order drawn.
The result is written as a one-path SVG so that it is read back by the same reader as any
container file (:func:`region_svg`), and a run, a saved project and the ``repulsionpak
pack`` command line all see the same polygon.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely

from ..errors import ParameterError

MODES = ("paint", "erase")
#: most points a stroke may carry (a page sends one per pointer move)
MAX_STROKE_POINTS = 20_000
#: segments of a quarter circle of the brush (the container is flattened anyway)
QUAD_SEGS = 8


@dataclass(frozen=True)
class Stroke:
    """One brush stroke, container units.

    Parameters
    ----------
    mode : {"paint", "erase"}
    points : tuple of (x, y)
        The brush centre along the stroke (one point: a dab).
    radius : float
        The brush radius, > 0.
    """

    mode: str
    points: tuple[tuple[float, float], ...]
    radius: float

    @staticmethod
    def parse(msg: object) -> "Stroke":
        """A stroke from the page's JSON (``mode``, ``points`` [[x, y], ...], ``radius``);
        raises :class:`ParameterError` naming what is wrong."""
        if not isinstance(msg, dict):
            raise ParameterError(f"a stroke must be an object, got {type(msg).__name__}")
        mode = msg.get("mode")
        if mode not in MODES:
            raise ParameterError(f"stroke mode must be one of {', '.join(MODES)}, got {mode!r}")
        r = msg.get("radius")
        if isinstance(r, bool) or not isinstance(r, (int, float)) or not (math.isfinite(r) and r > 0):
            raise ParameterError(f"brush radius must be a positive number, got {r!r}")
        pts = msg.get("points")
        if not isinstance(pts, list) or not pts:
            raise ParameterError("a stroke needs at least one point")
        if len(pts) > MAX_STROKE_POINTS:
            raise ParameterError(f"a stroke has at most {MAX_STROKE_POINTS} points, got {len(pts)}")
        out = []
        for p in pts:
            if (not isinstance(p, (list, tuple)) or len(p) != 2
                    or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                               for v in p)):
                raise ParameterError(f"stroke points must be [x, y] pairs of finite numbers, got {p!r}")
            out.append((float(p[0]), float(p[1])))
        return Stroke(mode, tuple(out), float(r))

    def shape(self) -> shapely.Geometry:
        """The area the brush swept: the polyline buffered by ``radius`` (round ends)."""
        pts = np.asarray(self.points, float)
        keep = np.ones(len(pts), bool)
        keep[1:] = np.any(np.diff(pts, axis=0) != 0, axis=1)  # repeated points add nothing
        pts = pts[keep]
        geom = shapely.Point(pts[0]) if len(pts) == 1 else shapely.LineString(pts)
        return shapely.buffer(geom, self.radius, quad_segs=QUAD_SEGS)

    def to_dict(self) -> dict:
        return {"mode": self.mode, "radius": self.radius, "points": [list(p) for p in self.points]}


def painted_region(base: shapely.Geometry | None, strokes: Sequence[Stroke],
                   min_area: float = 0.0) -> shapely.Geometry:
    """The region after ``strokes`` applied to ``base`` in order.

    Parameters
    ----------
    base : shapely (Multi)Polygon or None
        The loaded container's region (None or empty: a blank canvas).
    strokes : sequence of Stroke
        Painted strokes are united with the region, erased ones subtracted.
    min_area : float
        Parts smaller than this are dropped (crumbs an eraser leaves behind).

    Returns
    -------
    shapely Polygon or MultiPolygon
        Valid; empty when nothing is painted.
    """
    region = shapely.Polygon() if base is None else base
    for s in strokes:
        shape = s.shape()
        region = shapely.union(region, shape) if s.mode == "paint" else shapely.difference(region, shape)
    region = shapely.make_valid(region)
    parts = [p for p in shapely.get_parts(region)
             if isinstance(p, shapely.Polygon) and not p.is_empty and p.area > min_area]
    if not parts:
        return shapely.Polygon()
    return parts[0] if len(parts) == 1 else shapely.MultiPolygon(parts)


def _ring_d(coords: np.ndarray) -> str:
    pts = np.asarray(coords)[:-1]
    return "M" + "L".join(f"{x:.6g} {y:.6g}" for x, y in pts) + "Z"


def region_svg(region: shapely.Geometry, view_box: Sequence[float]) -> str:
    """A container file of ``region``: one black path (even-odd fill) in a document whose
    ``viewBox`` (x, y, width, height) is the canvas, user units = container units."""
    if region.is_empty:
        raise ParameterError("the container is empty: paint a region or open a container file")
    d = []
    for poly in shapely.get_parts(region):
        d.append(_ring_d(poly.exterior.coords))
        d.extend(_ring_d(r.coords) for r in poly.interiors)
    x, y, w, h = (float(v) for v in view_box)
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<svg xmlns="http://www.w3.org/2000/svg" width="{w:.6g}" height="{h:.6g}" '
            f'viewBox="{x:.6g} {y:.6g} {w:.6g} {h:.6g}">\n'
            f'  <path id="container" fill="#000" fill-rule="evenodd" d="{"".join(d)}"/>\n'
            '</svg>\n')


def rings_of(region: shapely.Geometry, decimals: int = 3) -> list[list[list[float]]]:
    """Every ring (exteriors and holes) of ``region`` as [[x, y], ...] without the closing point."""
    out = []
    for poly in shapely.get_parts(region):
        if poly.is_empty:
            continue
        out.append(np.round(np.asarray(poly.exterior.coords)[:-1], decimals).tolist())
        out.extend(np.round(np.asarray(r.coords)[:-1], decimals).tolist() for r in poly.interiors)
    return out


__all__ = ["MODES", "Stroke", "painted_region", "region_svg", "rings_of"]
