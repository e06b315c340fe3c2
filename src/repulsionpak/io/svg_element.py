"""An element from an SVG file: its visible shapes, flattened, clipped and checked.

Owns :func:`element_from_svg` (the shapes as the file draws them, clip paths applied,
with their curve-level source and paint servers), :func:`thin_dense_lines` (traced art of
thousands of straight segments thinned within a quarter of the output's curve tolerance)
and :func:`check_element_area` (art covering no area refused, very thin art warned about).

Notes
-----
The area check runs in milliseconds here instead of failing after a simulation that cannot
place the element.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import shapely

from ..art_area import art_area
from ..errors import InputError
from ..geometry.curves import flatten_subpath
from ..geometry.outline import (
    THIN_LINE_RELATIVE_THICKNESS,
    THIN_RELATIVE_THICKNESS,
    art_area_problem,
    relative_thickness,
)
from ..types import ArtPath, CurveSubpath, Element
from .files import PointBudget, warn
from .svg_clip import clip_art
from .svg_flatten import flatten_shape, flattening_tolerance, shape_clipper
from .svg_shapes import parse_svg_shapes
from .svg_source import paint_servers, shape_source
from .svg_xml import sprite_hint

__all__ = ["DENSE_TOLERANCE", "MAX_LINE_SEGMENTS", "check_element_area", "element_from_svg",
           "thin_dense_lines"]


def element_from_svg(path: Path, data: bytes, tolerance: float | None) -> Element:
    doc = parse_svg_shapes(path, data, as_drawn=True)
    shapes = [s for s in doc.shapes if s.style.visible]
    tol = flattening_tolerance(shapes, tolerance)
    budget = PointBudget(path)
    clip = shape_clipper(path, doc, tol, budget)
    arts = []
    n_clipped_away = 0
    for sh in shapes:
        subs = flatten_shape(path, sh, tol, budget)
        if subs:
            art = ArtPath(tuple(p for p, _ in subs), tuple(c for _, c in subs), sh.style,
                          source=shape_source(path, sh))
            region = clip(sh)
            kept = [art] if region is None else clip_art(art, region)  # clipped: polygons
            n_clipped_away += not kept
            arts.extend(kept)
    if not arts:
        why = (
            "every shape is clipped away by its clip-path"
            if n_clipped_away
            else "no filled or stroked shape"
        )
        raise InputError(
            path,
            f"has no visible geometry ({why}); an element needs at least one visible path"
            + sprite_hint(doc.xml),
        )
    arts = thin_dense_lines(arts)
    return Element(name=path.stem, source=path.name, paths=tuple(arts),
                   paint_servers=paint_servers(path, doc.xml, arts))


#: an element drawn with more straight segments than this (a traced or digitized
#: drawing; the suites' and examples' art has at most ~550) is thinned when read
MAX_LINE_SEGMENTS = 2000
#: ... within this share of its size: a quarter of the curve tolerance every copy is
#: written to (``render.curve_tolerance``, 0.001 of the copy's size), so no copy changes
DENSE_TOLERANCE = 2.5e-4


def _thin_runs(order: np.ndarray, ctrl: np.ndarray, closed: bool, tol: float):
    """The segments of one subpath with each run of consecutive lines reduced to the
    vertices Douglas–Peucker keeps within ``tol`` (run ends, and every curve, kept)."""
    n = len(order)
    keep_order, keep_ctrl = [], []
    i = 0
    while i < n:
        if order[i] != 1:
            keep_order.append(order[i])
            keep_ctrl.append(ctrl[i])
            i += 1
            continue
        j = i
        while j < n and order[j] == 1:
            j += 1
        pts = np.vstack([ctrl[i:j, 0], ctrl[j - 1, 1][None]])
        if j - i >= 3:
            kept = np.asarray(shapely.simplify(shapely.LineString(pts), tol, preserve_topology=False).coords)
            pts = kept if len(kept) >= 2 else pts[[0, -1]]
        for a, b in zip(pts[:-1], pts[1:]):
            keep_order.append(1)
            keep_ctrl.append(np.array([a, b, b, b]))
        i = j
    return CurveSubpath(np.array(keep_order, np.int8), np.array(keep_ctrl), closed)


def thin_dense_lines(arts: list[ArtPath]) -> list[ArtPath]:
    """``arts`` as they are, unless they hold more than :data:`MAX_LINE_SEGMENTS`
    straight segments: then each run of lines is thinned within
    :data:`DENSE_TOLERANCE` of the element's size (curves are kept as drawn). A 20,000-
    point polygon took ~10 minutes to pack (every copy mapped, fitted, verified and
    written with all 20,000 segments, a 29 MB SVG); thinned, it holds the detail its
    copies are written with."""
    def lines(art):
        if art.source is not None and art.source.curves:
            return sum(int((c.order == 1).sum()) for c in art.source.curves)
        return sum(len(p) for p in art.subpaths)

    if sum(lines(a) for a in arts) <= MAX_LINE_SEGMENTS:
        return arts
    pts = np.concatenate([np.asarray(p, dtype=float).reshape(-1, 2) for a in arts for p in a.subpaths])
    tol = DENSE_TOLERANCE * float(np.hypot(*np.ptp(pts, axis=0)))
    out = []
    for art in arts:
        if art.source is not None and art.source.curves:
            curves = tuple(_thin_runs(c.order, c.ctrl, c.closed, tol) for c in art.source.curves)
            subs = tuple(flatten_subpath(c, tol) for c in curves)  # lines: their end points
            out.append(dataclasses.replace(art, subpaths=subs,
                                           source=dataclasses.replace(art.source, curves=curves)))
        else:
            subs = []
            for p, closed in zip(art.subpaths, art.closed):
                ring = np.vstack([p, p[:1]]) if closed else np.asarray(p)
                kept = np.asarray(shapely.simplify(shapely.LineString(ring), tol, preserve_topology=False).coords)
                if not closed:
                    subs.append(kept)
                else:  # a ring thinned below a triangle stays as it was
                    subs.append(kept[:-1] if len(kept) > 3 else np.asarray(p))
            out.append(dataclasses.replace(art, subpaths=tuple(subs)))
    return out


def check_element_area(path, element: Element) -> None:
    """InputError naming ``path`` when the element's art covers no area (nothing
    filled or stroked, or degenerate shapes such as a path retracing itself): caught
    here, in milliseconds, instead of after a simulation that cannot place it. Art
    thinner than :data:`~repulsionpak.geometry.outline.THIN_RELATIVE_THICKNESS` of its
    size gets a warning, line art thinner than ``THIN_LINE_RELATIVE_THICKNESS`` another."""
    geom = art_area(element.paths)
    problem = art_area_problem(geom)
    if problem is not None:
        raise InputError(path, problem)
    t = relative_thickness(geom)
    if t < THIN_RELATIVE_THICKNESS:
        warn(
            path,
            f"the art is extremely thin (mean thickness {t:.1e} of its size): it will be "
            "almost invisible in the packing, and the simulation may not settle; "
            "thicken its strokes",
        )
    elif t < THIN_LINE_RELATIVE_THICKNESS:
        warn(
            path,
            f"the art is thin line work (mean thickness {t:.1e} of its size): its copies interlock "
            "easily, and the final check drops those it cannot separate (a warning names each); "
            "strokes of 1% of its size or more pack better",
        )
