"""SVG ``clip-path`` applied geometrically to element art and container shapes.

The reader records, for every shape, the clip paths that apply to it (its own
``clip-path`` and its ancestor groups', outermost first) as :class:`ClipRef`\\ s: the
``<clipPath>`` id and the *user space of the referencing element* (its transform
included; the file's user units for the root ``<svg>``) as a matrix to the file's user
units. The ``<clipPath>`` definitions are collected once per file as
:class:`ClipDef`\\ s: their children's geometry, and the clipPath's own ``transform``.

:class:`ClipResolver` turns a shape's refs into one clip region (the intersection of
the refs' regions, file user units) following SVG's rules:

* ``clipPathUnits="userSpaceOnUse"`` (default): the children's coordinates are in the
  referencing element's user space; ``"objectBoundingBox"``: fractions of that
  element's bounding box (its geometry, strokes excluded; for a group, the union over
  its shapes). The clipPath's ``transform`` applies after that box mapping, as Gecko
  and Blink do: user space <- clipPath transform <- box <- child.
* Each child's raw geometry counts whatever its fill and stroke (every subpath closed),
  filled by its ``clip-rule``; children with ``display:none`` (never parsed) or
  ``visibility:hidden`` do not; a ``clip-path`` on the ``<clipPath>`` itself or on a
  child intersects further.
* A ``clip-path`` that names no ``<clipPath>`` of the file is ignored with a warning,
  as browsers do (CSS Masking: "treated as if it had not been specified"); so are CSS
  basic shapes (``circle(50%)``), which are not supported. A ``<clipPath>`` without
  usable children clips everything away.

:func:`clip_art` then cuts one drawn path with a region: unchanged when the region
covers its painted area, dropped when they do not meet, otherwise replaced by closed
polygons of the same colours -- the clipped fill, and the clipped stroke *area* as a
filled shape (so the art that is packed and written is exactly what is visible).

This module depends on ``types``, ``errors`` and ``geometry`` only; the reader passes
its flattening and fill-rule functions in (no import cycle inside ``io``).
"""

from __future__ import annotations

import dataclasses
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import shapely

from ..errors import InputError
from ..art_area import art_area
from .svg_xml import TEXT_GROUP
from .svg_xml import local_name as _local
from ..types import ArtPath, ShapeSource, Style

__all__ = [
    "ClipChild",
    "ClipDef",
    "ClipRef",
    "ClipResolver",
    "clip_art",
    "clip_defs",
    "clip_refs",
    "hoist_clip_paths",
]

_SVG_NS = "http://www.w3.org/2000/svg"
#: Deepest chain of clip paths clipping clip paths that is followed.
MAX_CLIP_DEPTH = 32
#: A drawn path is left untouched when the part of its painted area outside the clip
#: region is below this fraction of that area (flattening noise along a shared edge).
COVER_TOLERANCE = 1e-9

_URL = re.compile(r"""^\s*url\(\s*['"]?\s*#([^)'"\s]+)\s*['"]?\s*\)\s*$""", re.IGNORECASE)


@dataclass(frozen=True, eq=False)
class ClipRef:
    """One ``clip-path="url(#id)"`` on a shape or group.

    ``matrix`` (3, 3): the referencing element's user space (its own ``transform``
    included) -> file user units, column-vector form. Identity matters: every shape
    under a clipped group shares the group's ref (the group's bounding box is the union
    of those shapes').
    """

    clip_id: str
    matrix: np.ndarray


@dataclass
class ClipChild:
    """One shape inside a ``<clipPath>``: svgelements segments with ``matrix`` (3, 3)
    child -> clipPath content space (the child's own transform and those of any
    ``<use>``/``<g>`` between it and the ``<clipPath>``)."""

    segments: list
    matrix: np.ndarray
    rule: str = "nonzero"
    clip_id: str | None = None  # the child's own clip-path


@dataclass
class ClipDef:
    """A ``<clipPath>`` element."""

    clip_id: str
    bbox_units: bool  # clipPathUnits="objectBoundingBox"
    children: list[ClipChild] = field(default_factory=list)
    clip_id_of_clip: str | None = None  # clip-path on the <clipPath> itself
    #: (3, 3) the ``<clipPath>``'s own ``transform``. As browsers do (Gecko
    #: ``SVGClipPathFrame``, Blink ``LayoutSVGResourceClipper``), it applies in the
    #: referencing element's user space, after the bounding-box mapping:
    #: user <- transform <- bbox <- child.
    matrix: np.ndarray = field(default_factory=lambda: np.eye(3))


def hoist_clip_paths(root: ET.Element) -> int:
    """Move every ``<clipPath>`` into a ``<defs>`` that is the root's first child.

    A clip path's coordinates never depend on where it is defined (they are in the user
    space of the element that references it), and it may be referenced even from
    inside ``display:none``. Moving it out of its ancestors lets svgelements parse it
    with the root's transform only (cancelled by the reader's inverse viewport) and
    register it whatever its ancestors' display. Returns the number moved.
    """
    parent = {c: p for p in root.iter() for c in p}
    found = [el for el in root.iter() if _local(el.tag) == "clipPath"]
    outer = []
    for el in found:  # a clipPath nested in another one stays with it
        anc, nested = parent.get(el), False
        while anc is not None:
            if _local(anc.tag) == "clipPath":
                nested = True
                break
            anc = parent.get(anc)
        if not nested:
            outer.append(el)
    if not outer:
        return 0
    defs = ET.Element(f"{{{_SVG_NS}}}defs" if root.tag.startswith("{") else "defs")
    for el in outer:
        p = parent.get(el)
        # clip-rule is inherited from where the clipPath stands: kept when it moves
        if el.get("clip-rule") is None and "clip-rule" not in (el.get("style") or ""):
            anc = p
            while anc is not None and anc is not root:
                rule = _own_property(anc, "clip-rule")
                if rule is not None:
                    el.set("clip-rule", rule)
                    break
                anc = parent.get(anc)
        if p is not None:
            p.remove(el)
        defs.append(el)
    root.insert(0, defs)
    return len(outer)


def _own_property(el: ET.Element, name: str) -> str | None:
    value = el.get(name)
    for decl in str(el.get("style") or "").split(";"):
        k, _, v = decl.partition(":")
        if k.strip().lower() == name:
            value = v.strip()
    return value if value and value.strip().lower() != "inherit" else None


def clip_refs(value, matrix: np.ndarray, notes: set[str]) -> tuple[ClipRef, ...]:
    """The ref of a ``clip-path`` property value (empty for none / unsupported)."""
    if value is None:
        return ()
    s = str(value).strip()
    if not s or s.lower() in ("none", "inherit", "initial", "unset"):
        return ()
    m = _URL.match(s)
    if m is None:
        notes.add(f"clip-path {s[:40]!r} (only url(#id) is supported; drawn unclipped)")
        return ()
    return (ClipRef(m.group(1), np.array(matrix, dtype=float)),)


def _np_matrix(m) -> np.ndarray:
    return np.array([[m.a, m.c, m.e], [m.b, m.d, m.f], [0.0, 0.0, 1.0]], dtype=float)


def url_id(value) -> str | None:
    """The id of a ``url(#id)`` reference (a clip-path, a marker ...), or None."""
    m = _URL.match(str(value)) if value else None
    return m.group(1) if m else None


def clip_defs(doc, inv_viewport, notes: set[str]) -> dict[str, ClipDef]:
    """Every ``<clipPath>`` of a parsed svgelements document (see
    :func:`hoist_clip_paths`), keyed by id; ``inv_viewport``: the inverse of the root's
    viewport matrix (svgelements ``Matrix``)."""
    import svgelements as se

    out: dict[str, ClipDef] = {}

    def gather(node, cd: ClipDef, inv_clip: np.ndarray):
        for child in node:
            vals = getattr(child, "values", None) or {}
            vis = str(vals.get("visibility", "visible")).strip().lower()
            if isinstance(child, se.Shape):
                if vis in ("hidden", "collapse"):
                    continue
                rule = str(vals.get("clip-rule", "nonzero")).strip().lower()
                cd.children.append(
                    ClipChild(
                        list(child.segments(transformed=False)),
                        inv_clip @ _np_matrix(child.transform * inv_viewport),
                        "evenodd" if rule == "evenodd" else "nonzero",
                        url_id(vals.get("clip-path")),
                    )
                )
            elif isinstance(child, se.Use) or (isinstance(child, se.Group) and vals.get(TEXT_GROUP)):
                gather(child, cd, inv_clip)  # (text is drawn as groups of glyph outlines)
            elif isinstance(child, se.Group):  # not a valid child of a clipPath: ignored, as
                continue  # browsers do
            elif isinstance(child, se.Text):
                notes.add("text inside a clipPath (does not clip)")

    for key, obj in list(getattr(doc, "objects", {}).items()):
        if not isinstance(obj, se.ClipPath) or key in out:
            continue
        units = str(getattr(obj, "unit_type", "") or "").strip()
        tf = (obj.values or {}).get("transform")
        # svgelements accumulates the transforms of the ancestors (the root's viewport
        # only, after hoist_clip_paths) into the clipPath's own
        clip_m = _np_matrix(se.Matrix(tf) * inv_viewport) if tf else np.eye(3)
        cd = ClipDef(
            str(key),
            units == "objectBoundingBox",
            clip_id_of_clip=url_id((obj.values or {}).get("clip-path")),
            matrix=clip_m,
        )
        if np.all(np.isfinite(clip_m)) and abs(np.linalg.det(clip_m)) > 0:
            gather(obj, cd, np.linalg.inv(clip_m))
        # else: a singular transform clips everything away (no children)
        out[cd.clip_id] = cd
    return out


Flatten = Callable[[list, np.ndarray], list]  # (segments, matrix) -> [(points (K, 2), closed)]
Region = Callable[[list, str], shapely.Geometry]  # (rings, fill rule) -> (Multi)Polygon


class ClipResolver:
    """Clip regions (file user units) of the shapes of one file.

    ``defs``: :func:`clip_defs`; ``shapes``: every shape of the file (``.clips`` and
    ``.segments``/``.matrix``: bounding boxes of clipped groups are the union over the
    shapes sharing the group's ref); ``flatten``/``region``: the reader's flattening
    and fill-rule functions; ``warn(message)`` reports a missing clip path once.
    """

    def __init__(self, path, defs: dict[str, ClipDef], shapes, flatten: Flatten,
                 region: Region, warn: Callable[[str], None]):
        self.path, self.defs, self.shapes = path, defs, shapes
        self.flatten, self.region_of, self.warn = flatten, region, warn
        self._ref_regions: dict[int, shapely.Geometry | None] = {}
        self._by_place: dict[tuple, shapely.Geometry | None] = {}
        self._owners: dict[int, list] | None = None
        self._flat: dict[int, list] = {}
        self._missing: set[str] = set()

    def region(self, refs) -> shapely.Geometry | None:
        """Intersection of ``refs``' regions; None when nothing clips (no usable ref)."""
        out = None
        for ref in refs:
            g = self._ref_regions.get(id(ref), False)
            if g is False:
                # shapes clipped one by one by the same clip path in the same user space
                # share the region, unless it depends on their bounding boxes
                key = (ref.clip_id, ref.matrix.tobytes())
                if key in self._by_place:
                    g = self._by_place[key]
                else:
                    g = self._resolve(ref.clip_id, ref.matrix, lambda ref=ref: self._ref_bbox(ref), 0)
                    if not self._uses_bbox(ref.clip_id):
                        self._by_place[key] = g
                self._ref_regions[id(ref)] = g
            if g is None:
                continue
            out = g if out is None else shapely.intersection(out, g)
            if out.is_empty:
                break
        return out

    # ------------------------------------------------------------------ internals

    def _flat_shape(self, sh) -> list:
        key = id(sh)
        if key not in self._flat:
            self._flat[key] = self.flatten(sh.segments, sh.matrix)
        return self._flat[key]

    def _uses_bbox(self, clip_id: str) -> bool:
        """Whether the region of ``clip_id`` depends on the referencing element's box."""
        seen = set()
        while clip_id is not None and clip_id not in seen:
            seen.add(clip_id)
            cd = self.defs.get(clip_id)
            if cd is None:
                return False
            if cd.bbox_units:
                return True
            clip_id = cd.clip_id_of_clip
        return False

    def _ref_bbox(self, ref: ClipRef):
        """Bounding box (x0, y0, x1, y1) of the shapes under ``ref`` in its user space."""
        if self._owners is None:
            self._owners = {}
            for sh in self.shapes:
                for r in sh.clips:
                    self._owners.setdefault(id(r), []).append(sh)
        pts = [p for sh in self._owners.get(id(ref), []) for p, _ in self._flat_shape(sh)]
        return _bbox_in(pts, ref.matrix)

    def _resolve(self, clip_id: str, matrix: np.ndarray, bbox_fn, depth: int, chain: tuple = ()):
        if clip_id in chain:  # a cycle: the link that closes it is left out, as browsers (and
            if ("cycle", clip_id) not in self._missing:  # resvg) drop a recursive clip-path
                self._missing.add(("cycle", clip_id))
                self.warn(f"clip-path url(#{clip_id}) refers back to itself; that reference is "
                          "ignored (as browsers do)")
            return None
        chain = chain + (clip_id,)
        if depth > MAX_CLIP_DEPTH:
            raise InputError(
                self.path,
                f"clip paths clip each other more than {MAX_CLIP_DEPTH} levels deep "
                f"(a cycle through #{clip_id}?); simplify the clip paths",
            )
        cd = self.defs.get(clip_id)
        if cd is None:
            if clip_id not in self._missing:
                self._missing.add(clip_id)
                self.warn(f"clip-path url(#{clip_id}) does not name a <clipPath> of the file; "
                          "drawn unclipped (as browsers do)")
            return None
        m = matrix @ cd.matrix
        if cd.bbox_units:
            b = bbox_fn()
            if b is None or not (b[2] > b[0] and b[3] > b[1]):
                return shapely.Polygon()  # a zero-size box clips everything away
            m = m @ np.array([[b[2] - b[0], 0.0, b[0]], [0.0, b[3] - b[1], b[1]],
                              [0.0, 0.0, 1.0]])
        parts = []
        for ch in cd.children:
            cm = m @ ch.matrix
            subs = self.flatten(ch.segments, cm)
            rings = [p for p, _ in subs if len(p) >= 3]  # clipping closes every subpath
            g = self.region_of(rings, ch.rule) if rings else shapely.Polygon()
            if ch.clip_id is not None and not g.is_empty:
                pts = [p for p, _ in subs]
                sub = self._resolve(ch.clip_id, cm, lambda pts=pts, cm=cm: _bbox_in(pts, cm),
                                    depth + 1, chain)
                if sub is not None:
                    g = shapely.intersection(g, sub)
            if not g.is_empty:
                parts.append(g)
        out = _polygonal(shapely.union_all(parts)) if parts else shapely.Polygon()
        if cd.clip_id_of_clip is not None and not out.is_empty:
            sub = self._resolve(cd.clip_id_of_clip, matrix, bbox_fn, depth + 1, chain)
            if sub is not None:
                out = _polygonal(shapely.intersection(out, sub))
        return out


def _bbox_in(point_sets, matrix: np.ndarray):
    """Bounding box of file-unit points mapped back through ``matrix`` (None if none)."""
    pts = [p for p in point_sets if len(p)]
    if not pts:
        return None
    a = np.concatenate(pts, axis=0)
    try:
        inv = np.linalg.inv(matrix)
    except np.linalg.LinAlgError:
        return None
    with np.errstate(all="ignore"):
        q = a @ inv[:2, :2].T + inv[:2, 2]
    if not np.all(np.isfinite(q)):
        return None
    lo, hi = q.min(axis=0), q.max(axis=0)
    return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


def _polygonal(geom) -> shapely.Geometry:
    if geom is None or geom.is_empty:
        return shapely.Polygon()
    if not geom.is_valid:
        geom = shapely.make_valid(geom)
    if isinstance(geom, (shapely.Polygon, shapely.MultiPolygon)):
        return geom
    parts = [g for g in shapely.get_parts(geom)
             if isinstance(g, (shapely.Polygon, shapely.MultiPolygon)) and not g.is_empty]
    return shapely.union_all(parts) if parts else shapely.Polygon()


def polygon_rings(geom) -> list[np.ndarray]:
    """Exterior and interior rings of every polygon of ``geom`` as (K, 2) arrays without
    the repeated closing point (filled with ``evenodd`` they give back ``geom``)."""
    rings = []
    for poly in shapely.get_parts(geom):
        if not isinstance(poly, shapely.Polygon) or poly.is_empty:
            continue
        for ring in (poly.exterior, *poly.interiors):
            pts = np.asarray(ring.coords, dtype=float)[:-1]
            if len(pts) >= 3:
                rings.append(pts)
    return rings


def _as_fill(rings: list[np.ndarray], style: Style, colour, alpha: float,
             src: ShapeSource | None = None, paint: str | None = None) -> ArtPath:
    """The clipped part as a filled polygon; a gradient or pattern it was painted with
    (``paint``, an id) stays, mapped as on the whole shape (``src``'s transform and
    bounding box: a clip does not change the box a paint's ``objectBoundingBox`` is on)."""
    source = None
    if paint is not None and src is not None:
        source = ShapeSource(curves=(), tag="", matrix=src.matrix, fill_paint=paint, local_bbox=src.local_bbox)
    return ArtPath(tuple(rings), tuple(True for _ in rings),
                   dataclasses.replace(style, fill=colour, fill_opacity=alpha, stroke=None,
                                       fill_rule="evenodd"), source=source)


def clip_art(art: ArtPath, region: shapely.Geometry) -> list[ArtPath]:
    """``art`` clipped by ``region`` (file user units): ``[art]`` when the region
    covers what it paints, ``[]`` when they do not meet, else the clipped fill and the
    clipped stroke area as closed filled polygons (same colours, opacities and paint
    order: fill below stroke)."""
    painted = art_area([art])
    if painted.is_empty:
        return [art]  # paints nothing: nothing to clip (an invisible path stays as is)
    if region.is_empty:
        return []
    outside = shapely.difference(painted, region).area
    if outside <= COVER_TOLERANCE * painted.area:
        return [art]
    if not shapely.intersects(painted, region):
        return []
    st, src = art.style, art.source
    out = []
    fill = art_area([ArtPath(art.subpaths, art.closed, dataclasses.replace(st, stroke=None))])
    if not fill.is_empty:
        rings = polygon_rings(_polygonal(shapely.intersection(fill, region)))
        if rings:
            out.append(_as_fill(rings, st, st.fill, st.fill_opacity, src, src and src.fill_paint))
    stroke = art_area([ArtPath(art.subpaths, art.closed, dataclasses.replace(st, fill=None))])
    if not stroke.is_empty:
        rings = polygon_rings(_polygonal(shapely.intersection(stroke, region)))
        if rings:
            out.append(_as_fill(rings, st, st.stroke, st.stroke_opacity, src, src and src.stroke_paint))
    return out
