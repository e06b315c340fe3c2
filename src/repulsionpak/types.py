"""Plain data types that flow between the stages (io → preprocess → ... → render).

All coordinates are float64 arrays of shape (K, 2), y pointing down (SVG convention),
in the user units of the file they came from.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely


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

    @property
    def visible(self) -> bool:
        """True when the shape paints anything (fill or stroke, non-zero opacity)."""
        if self.opacity <= 0:
            return False
        has_fill = self.fill is not None and self.fill_opacity > 0
        has_stroke = self.stroke is not None and self.stroke_opacity > 0 and self.stroke_width > 0
        return has_fill or has_stroke


@dataclass(frozen=True, eq=False)
class ArtPath:
    """One drawable SVG shape: one or more flattened subpaths painted with one style.

    ``subpaths[i]`` is a (K_i, 2) float64 array with K_i >= 2 and no repeated closing
    point; ``closed[i]`` says whether subpath i ends with ``Z``.
    """

    subpaths: tuple[np.ndarray, ...]
    closed: tuple[bool, ...]
    style: Style = field(default_factory=Style)

    def transformed(self, fn) -> "ArtPath":
        """Return a copy whose every subpath is ``fn(points) -> points``."""
        return ArtPath(tuple(np.asarray(fn(p), dtype=float) for p in self.subpaths), self.closed, self.style)

    @property
    def n_points(self) -> int:
        return int(sum(len(p) for p in self.subpaths))


@dataclass(frozen=True, eq=False)
class Element:
    """An element of the library, as drawn: its art in paint order (first = back)."""

    name: str  # e.g. "cat"
    source: str  # file name written to data-source, e.g. "cat.svg"
    paths: tuple[ArtPath, ...]

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

    @property
    def area(self) -> float:
        return float(self.region.area)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        return tuple(float(b) for b in self.region.bounds)  # type: ignore[return-value]


@dataclass(frozen=True, eq=False)
class PlacedArt:
    """One element as it appears in the finished packing (container user units).

    ``paths`` are already deformed; ``stroke_scale`` multiplies every stroke width of
    ``paths`` (the element's overall scale from its file units to the container's).
    ``deformation`` is a dimensionless measure of how far the element's mesh is from a
    similarity transform of its rest shape (0 = rigid); ``None`` if unknown.
    """

    source: str
    kind: str  # "primary" | "secondary"
    paths: tuple[ArtPath, ...]
    stroke_scale: float = 1.0
    deformation: float | None = None
