"""Flow guides drawn in the studio: polylines in container units, in the order drawn (the
direction of travel), written as the guide SVG ``repulsionpak pack --flow`` reads.

The field the elements follow is :func:`repulsionpak.flow.field_from_guides` of these
strokes over the container's bounds, as ``pack`` computes it from the written file
(:func:`repulsionpak.flow.hook.run_field`), so the page's arrows, the run and the command
line see the same field.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..errors import ParameterError
from .region import MAX_STROKE_POINTS

#: the guide file's name in a project and on the command line
GUIDES_NAME = "guides.svg"
#: most guide strokes in a document
MAX_GUIDES = 200

Guide = tuple[tuple[float, float], ...]


def parse_guide(msg: object) -> Guide:
    """A guide stroke from the page's JSON (``{"points": [[x, y], ...]}``): at least two
    distinct finite points; raises :class:`ParameterError` naming what is wrong."""
    pts = msg.get("points") if isinstance(msg, dict) else None
    if not isinstance(pts, list):
        raise ParameterError("a guide needs points: [[x, y], ...]")
    if len(pts) > MAX_STROKE_POINTS:
        raise ParameterError(f"a guide has at most {MAX_STROKE_POINTS} points, got {len(pts)}")
    out: list[tuple[float, float]] = []
    for p in pts:
        if (not isinstance(p, (list, tuple)) or len(p) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in p)):
            raise ParameterError(f"guide points must be [x, y] pairs of finite numbers, got {p!r}")
        q = (float(p[0]), float(p[1]))
        if not out or q != out[-1]:
            out.append(q)
    if len(out) < 2:
        raise ParameterError("a guide needs two distinct points: drag along the direction of travel")
    return tuple(out)


def guides_svg(guides: Sequence[Guide], view_box: Sequence[float]) -> str:
    """The guide file of ``guides``: one stroked path per guide, in the order drawn, in a
    document whose ``viewBox`` is the canvas (user units = container units)."""
    if not guides:
        raise ParameterError("there are no flow guides: draw one with the guide tool")
    x, y, w, h = (float(v) for v in view_box)
    paths = []
    for i, g in enumerate(guides):
        d = "M" + "L".join(f"{px:.3f} {py:.3f}" for px, py in g)
        paths.append(f'  <path id="guide-{i + 1}" fill="none" stroke="#000" d="{d}"/>')
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<svg xmlns="http://www.w3.org/2000/svg" width="{w:.6g}" height="{h:.6g}" '
            f'viewBox="{x:.6g} {y:.6g} {w:.6g} {h:.6g}">\n' + "\n".join(paths) + "\n</svg>\n")


def guides_field(guides: Sequence[Guide], bounds):
    """The flow field of ``guides`` over ``bounds`` (as ``pack --flow`` makes it)."""
    from ..flow import field_from_guides

    return field_from_guides([np.asarray(g, float) for g in guides], tuple(bounds))


__all__ = ["GUIDES_NAME", "Guide", "MAX_GUIDES", "guides_field", "guides_svg", "parse_guide"]
