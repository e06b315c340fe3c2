"""The room a container really has: its separate regions and how wide it is where.

Placement (sec. 4) sizes the primaries from the gap alone (``placement.element_size``
gaps across). That fits a round container, but an archipelago's islands, a country's
peninsulas or a long thin band are narrower than such an element: they got none, or one
that could not grow. This module measures the container on a raster: the parts
(connected regions), the depth (distance to the edge) and the *local width* of every
point — the diameter of the largest disc inside the container that covers it (the
"local thickness" of a shape) — from which :mod:`repulsionpak.sizing` chooses how many
primaries each part gets and how big each one is.

Notes
-----
The local width at level r is the opening of the container by a disc of radius r: the
points within r of a centre at least r deep. One exact distance transform per level
(levels 1.12× apart, from a quarter of the gap: nothing narrower than half a gap matters
to a placement) gives it for every pixel; the raster is ~400 pixels on the longer side and
at least 3 pixels per gap, so the widths are within a level and a pixel.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import shapely

from .geometry.edt import distance_transform

#: ratio of consecutive width levels
LEVEL_STEP = 1.12


@dataclass(frozen=True, eq=False)
class Room:
    """The container on a raster of square pixels ``h`` wide (container units).

    ``part`` (ny, nx) int: index of the region (``parts``) holding each pixel centre, -1
    outside; ``depth`` (ny, nx): distance of each pixel centre to the container's edge,
    0 outside; ``levels``: the disc radii the local width is measured at, increasing.
    Pixel (j, i) has its centre at ``origin + h · (i + ½, j + ½)``.
    """

    parts: list[shapely.Polygon]
    origin: np.ndarray
    h: float
    part: np.ndarray
    depth: np.ndarray
    levels: tuple[float, ...]

    def opened(self, r: float) -> np.ndarray:
        """(ny, nx) bool: the pixels within ``r`` of a centre at least ``r`` deep (the
        container opened by a disc of radius ``r``)."""
        core = self.depth >= r
        reach = distance_transform(~core, self.h)  # distance of every pixel to the nearest centre r deep
        return (reach <= r) & (self.part >= 0)

    @cached_property
    def width(self) -> np.ndarray:
        """(ny, nx) local width: the diameter of the largest disc (a level) inside the
        container covering the pixel centre, twice its depth below the first level, 0
        outside. One distance transform per level, computed when first asked for."""
        mask = self.part >= 0
        width = np.where(mask, 2.0 * self.depth, 0.0)
        for r in self.levels:
            width[self.opened(r)] = 2.0 * r
        return width

    def wide(self, base: float) -> np.ndarray:
        """(ny, nx) bool: the pixels whose local width is at least ``base``, i.e.
        ``width >= base`` inside the container.

        Notes
        -----
        Only the levels of at least ``base``/2 are transformed (10 of 41 on the paper's
        heart): a pixel opened at one of them is that wide; one opened only at smaller
        levels is narrower; one opened at none is less than the first level deep, so
        narrower too when that level is at most ``base``/2 (else every level is needed)."""
        if "width" in self.__dict__ or not self.levels or 2.0 * self.levels[0] > base:
            return (self.width >= base) & (self.part >= 0)
        out = np.zeros(self.part.shape, np.bool_)
        for r in self.levels:
            if 2.0 * r >= base:
                out |= self.opened(r)
        return out

    def centres(self, mask: np.ndarray) -> np.ndarray:
        """(K, 2) centres of the pixels where ``mask`` is True, in row-major order."""
        j, i = np.nonzero(mask)
        return self.origin + self.h * np.column_stack([i + 0.5, j + 0.5])

    def at(self, points: np.ndarray, grid: np.ndarray) -> np.ndarray:
        """Values of a (ny, nx) ``grid`` at (K, 2) ``points`` (nearest pixel)."""
        ij = np.floor((np.asarray(points, float) - self.origin) / self.h).astype(np.int64)
        i = np.clip(ij[:, 0], 0, grid.shape[1] - 1)
        j = np.clip(ij[:, 1], 0, grid.shape[0] - 1)
        return grid[j, i]

    def part_area(self) -> np.ndarray:
        """(P,) exact area of each part."""
        return np.array([p.area for p in self.parts])

    def part_width(self) -> np.ndarray:
        """(P,) largest local width in each part (its inscribed circle's diameter, to a pixel)."""
        out = np.zeros(len(self.parts))
        np.maximum.at(out, self.part[self.part >= 0], self.width[self.part >= 0])
        return out


def room_of(region, gap: float, pixels: int = 400) -> Room:
    """Measure ``region`` (a shapely (Multi)Polygon, container units) on a raster of about
    ``pixels`` on its longer side, and at least 3 pixels per ``gap`` (at most 2,000).

    Returns a :class:`Room`. Parts are the region's polygons (holes kept); a part too small
    to hold a pixel centre has no pixels (and a part width of 0)."""
    minx, miny, maxx, maxy = region.bounds
    side = max(maxx - minx, maxy - miny)
    h = min(side / pixels, gap / 3.0)
    h = max(h, side / 2000.0)
    nx = int(np.ceil((maxx - minx) / h)) + 2
    ny = int(np.ceil((maxy - miny) / h)) + 2
    origin = np.array([minx - h, miny - h])
    parts = [p for p in shapely.get_parts(region) if not p.is_empty and p.area > 0]
    label = np.full((ny, nx), -1, np.int64)
    for k, p in enumerate(parts):
        bx0, by0, bx1, by1 = p.bounds
        i0, i1 = int((bx0 - origin[0]) / h), int(np.ceil((bx1 - origin[0]) / h))
        j0, j1 = int((by0 - origin[1]) / h), int(np.ceil((by1 - origin[1]) / h))
        ii, jj = np.meshgrid(np.arange(i0, i1), np.arange(j0, j1))
        x = origin[0] + h * (ii + 0.5)
        y = origin[1] + h * (jj + 0.5)
        inside = shapely.contains_xy(p, x, y)
        label[jj[inside], ii[inside]] = k
    mask = label >= 0
    depth = distance_transform(mask, h)
    top = float(depth.max()) if mask.any() else 0.0
    levels = []
    r = max(0.5 * h, 0.25 * gap)
    while r <= top:
        levels.append(r)
        r *= LEVEL_STEP
    return Room(parts, origin, h, label, depth, tuple(levels))
