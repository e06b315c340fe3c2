"""The flow field as the pages draw it: arrows on a grid inside the container, one SVG path.

The live view (``pack --live --flow G.svg``) and the studio show the field the elements
follow as a layer of arrows over the stage, as the output's ``debug-flow`` layer draws
them (:meth:`repulsionpak.flow.FlowField.arrows`).
"""

from __future__ import annotations

#: arrows along the container's longer side (as the output's debug layer)
ARROWS_PER_SIDE = 30


def field_path(field, region, per_side: int = ARROWS_PER_SIDE) -> str:
    """The ``d`` of one path drawing ``field``'s arrows inside ``region``.

    Parameters
    ----------
    field : repulsionpak.flow.FlowField
    region : shapely geometry
        The container's region (container units).
    per_side : int
        Arrows along the region's longer side.

    Returns
    -------
    str
        Each arrow a shaft (tail to tip) and a head (two strokes to the tip), two decimals;
        empty for an empty region.
    """
    if region.is_empty:
        return ""
    x0, y0, x1, y1 = region.bounds
    spacing = max(x1 - x0, y1 - y0) / per_side
    parts = []
    for a in field.arrows(region, spacing):
        t, p, left, _, right, _ = a
        parts.append(f"M{t[0]:.2f} {t[1]:.2f}L{p[0]:.2f} {p[1]:.2f}M{left[0]:.2f} {left[1]:.2f}"
                     f"L{p[0]:.2f} {p[1]:.2f}L{right[0]:.2f} {right[1]:.2f}")
    return "".join(parts)


__all__ = ["ARROWS_PER_SIDE", "field_path"]
