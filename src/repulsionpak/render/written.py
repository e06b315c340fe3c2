"""The geometry of exactly what is written, for the no-overlap / inside / gap checks."""

from __future__ import annotations

from collections.abc import Sequence

import shapely

from ..types import PlacedArt

__all__ = ["written_geometry"]


def written_geometry(placed: Sequence[PlacedArt]) -> list[shapely.Geometry]:
    """Per placed element, the area its written art covers (fills ∪ stroked outlines).

    Placed art rendered by :func:`~repulsionpak.render.placed_copy` carries, as its
    ``subpaths``, the written Bézier curves (rounded as written) flattened to a tenth of
    the curve tolerance, so this is the written drawing up to that flattening; art without
    curves is taken as its polylines, which is also what is written for it.
    """
    return [pa.art for pa in placed]
