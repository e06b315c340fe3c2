"""Parse an SVG file into shapes: user-unit matrices and styles, not yet flattened.

Owns :func:`parse_svg_shapes`, which runs the reader's pipeline -- hardened XML
(:mod:`.svg_harden`), the CSS cascade (:mod:`.svg_css`), ``<use>`` viewports, lengths,
markers, images, what is drawn (:mod:`.svg_sanitize`), text as glyph outlines, clip paths
-- hands the cleaned tree to svgelements and walks it into :class:`SvgShape` s of an
:class:`SvgDocument` (opacity layers, holes, clip refs, markers placed), and the root
viewport checks (zero size, invalid ``viewBox``, ``display="none"``).

Coordinates are the file's *user units*: every nested ``transform`` is applied, the root's
viewBox -> viewport scaling is not (svgelements applies it while parsing; every shape's
matrix is multiplied by the inverse of the root viewport matrix).

Notes
-----
Unsupported content is collected as notes and reported in one warning naming the file.
"""

from __future__ import annotations

import dataclasses
import functools
import io
import itertools
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..types import Style
from .files import warn
from .svg_clip import ClipChild, ClipDef, ClipRef, clip_defs, clip_refs, hoist_clip_paths
from .svg_css import apply_stylesheets
from .svg_harden import check_attributes, check_tree, parse_xml_hardened
from .svg_image import images_to_rects
from .svg_lengths import resolve_lengths, resolve_transform_origin
from .svg_markers import (MARKABLE, clip_box, drop_marker_attribute, marker_ids, marker_svg, placements,
                          resolve_marker_lengths, resolve_overflow_inherit)
from .svg_sanitize import sanitize, shape_sizes
from .svg_style import clamp01, context_paint, float_attr, gradient_colours, shape_stroke_width, style_of
from .svg_text import text_to_paths
from .svg_use import expand_viewport_uses
from .svg_viewports import ROOT_VIEW_ATTRS, circle_percentages, reference_size, user_length
from .svg_xml import drop_use_cycles, href, integer_rgb_colours
from .svg_xml import inline_declarations as _inline_declarations
from .svg_xml import local_name as _local

__all__ = ["SvgDocument", "SvgShape", "parse_svg_shapes"]


@dataclass
class SvgShape:
    """One drawable shape of an SVG file, before flattening.

    ``segments``: svgelements path segments in the shape's local coordinates;
    ``matrix``: (3, 3) affine matrix local -> file user units (column-vector form).
    ``attrs``: the shape's own attributes; ``groups``: own attributes of its ancestor
    groups, outermost first.
    """

    segments: list
    matrix: np.ndarray
    style: Style
    hole: bool
    attrs: dict
    groups: tuple = ()
    #: clip paths that apply (own and ancestors', :class:`~.svg_clip.ClipRef`)
    clips: tuple = ()
    #: ``visibility:hidden``/``collapse`` (``display:none`` shapes are never parsed)
    hidden: bool = False
    node: object = None  # the svgelements shape (resolved presentation values, tag)


@dataclass
class SvgDocument:
    shapes: list[SvgShape]
    svg_root: dict
    root_attrs: dict = field(default_factory=dict)
    metadata_text: str | None = None
    #: the ``<clipPath>`` definitions (:class:`~.svg_clip.ClipDef` by id), if any shape is clipped
    clip_defs: dict = field(default_factory=dict)
    xml: object = None  # the (sanitised) ElementTree root, for paint servers
    #: the root's transform and viewBox mapping stretch or shear what the file draws
    #: (``preserveAspectRatio="none"``, a root ``transform="scale(2 1)"``): (sx, sy) its
    #: principal scales, None when they only scale uniformly, turn or mirror it
    stretch: tuple[float, float] | None = None


def _matrix_to_np(m) -> np.ndarray:
    return np.array([[m.a, m.c, m.e], [m.b, m.d, m.f], [0.0, 0.0, 1.0]], dtype=float)


def _is_hole(attrs: dict) -> bool:
    cls = str(attrs.get("class") or "").lower()
    if re.search(r"(^|[\s_-])holes?($|[\s_-])", cls):
        return True
    if str(attrs.get("id") or "").lower().startswith("hole"):
        return True
    return str(attrs.get("data-path-type") or "").strip() == "7"


def _dots(segments: list, style: Style) -> list:
    """SVG paints a zero-length subpath of a stroke with round or square caps as a dot (a
    disc, or a square along the x axis): such a subpath (``M18 3 L18 3``, ``M4 3 z``; a
    lone ``M`` is not drawn) becomes a line along x, 1% of the stroke width long, which
    the stroke geometry and the writer draw like the browser's dot (they were left out)."""
    if style.stroke is None or not style.stroke_width > 0 or style.stroke_linecap not in ("round", "square"):
        return segments
    import svgelements as se

    def zero_length(seg) -> bool:
        pts = [getattr(seg, a, None) for a in ("start", "control", "control1", "control2", "end")]
        pts = [complex(*q) for q in pts if q is not None]
        return len(pts) >= 2 and all(q == pts[0] for q in pts)

    out, run = [], []
    for seg in segments + [None]:
        if seg is None or isinstance(seg, se.Move):
            if len(run) > 1 and run[0].end is not None and all(zero_length(q) for q in run[1:]):
                x, y = run[0].end
                run = [run[0], se.Line(se.Point(x, y), se.Point(x + 0.01 * style.stroke_width, y))]
            out.extend(run)
            run = []
        if seg is not None:
            run.append(seg)
    return out


def _smooth_controls(segments: list) -> list:
    """SVG reflects the previous control point for ``S`` only after a cubic (``C``/``S``)
    and for ``T`` only after a quadratic (``Q``/``T``); otherwise the first control point
    is the current point. svgelements reflected any previous control (an ``S`` after a
    ``T`` bent away from the curve): corrected here, in place."""
    import svgelements as se

    prev = None
    for seg in segments:
        if getattr(seg, "smooth", False) and seg.start is not None:
            if isinstance(seg, se.CubicBezier) and not isinstance(prev, se.CubicBezier):
                seg.control1 = se.Point(seg.start)
            elif isinstance(seg, se.QuadraticBezier) and not isinstance(prev, se.QuadraticBezier):
                seg.control = se.Point(seg.start)
        prev = seg
    return segments


def _det_scale(mat: np.ndarray) -> float:
    """The length scale of the (3, 3) affine ``mat``: sqrt(|det|) of its linear part."""
    return math.sqrt(abs(mat[0, 0] * mat[1, 1] - mat[0, 1] * mat[1, 0]))


_SIZE_ATTRS = {"Circle": ("r",), "Ellipse": ("rx", "ry"), "Rect": ("width", "height")}


def _negative_size(kind: str, attrs: dict) -> str | None:
    """The attribute of a circle, ellipse or rect whose value is negative (an error in SVG:
    the shape is not rendered), if any."""
    for name in _SIZE_ATTRS.get(kind, ()):
        v = attrs.get(name)
        if v is None:
            continue
        m = re.match(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)", str(v))
        if m and float(m.group(1)) < 0:
            return name
    return None


def parse_svg_shapes(path: str | Path, data: bytes, as_drawn: bool = False) -> SvgDocument:
    """Parse SVG bytes into shapes with user-unit matrices and styles (not flattened).

    ``as_drawn`` (elements): the shapes as the file shows them — turned, mirrored or
    stretched as a root ``transform`` or a non-uniform viewBox mapping
    (``preserveAspectRatio="none"``) draws them, at their user-unit size.

    Invisible shapes are kept (check ``shape.style.visible``); text is drawn as glyph
    outlines (:mod:`.svg_text`); images, filters and masks are reported with one warning
    naming the file. Clip paths are recorded
    (``shape.clips``, ``doc.clip_defs``) for :func:`shape_clipper`.
    """
    import svgelements as se

    root_xml = parse_xml_hardened(path, data)
    notes: set[str] = set()
    if drop_use_cycles(root_xml, href):
        notes.add("<use> drawing itself (that use skipped, as in browsers)")
    check_tree(path, root_xml)
    check_attributes(path, root_xml)
    apply_stylesheets(root_xml, notes)
    integer_rgb_colours(root_xml)
    expand_viewport_uses(root_xml)  # (before lengths: percentages refer to the new viewports)
    reference = reference_size(root_xml)
    circle_percentages(root_xml, reference)  # (before nested viewports become groups)
    drop_marker_attribute(root_xml)
    resolve_overflow_inherit(root_xml)
    for el in root_xml.iter():
        if isinstance(el.tag, str) and _local(el.tag) == "marker":
            resolve_marker_lengths(el, reference)
    resolve_lengths(root_xml, reference)
    resolve_transform_origin(root_xml, reference)
    images = images_to_rects(root_xml, Path(str(path)).parent, user_length, reference,
                             lambda b: parse_xml_hardened(path, b))
    if images["raster"]:
        notes.add("raster <image> (packed as the rectangle of its visible pixels, in their mean colour)")
    if images["unread"]:
        notes.add("<image> that could not be read (not drawn)")
    sanitize(path, root_xml, notes)
    shape_sizes(root_xml)
    fonts_missing = text_to_paths(root_xml, notes)
    if fonts_missing:
        warn(path, fonts_missing)
    hoist_clip_paths(root_xml)
    gradients = gradient_colours(root_xml)
    svg_root = {  # what places the user units on the page: an output with these overlays the input
        k: root_xml.get(k)
        for k in ROOT_VIEW_ATTRS
        if root_xml.get(k) is not None
    }
    root_attrs = {k: v for k, v in root_xml.attrib.items()}
    background = root_xml.get("background-color")
    for name, v, _ in _inline_declarations(root_xml.get("style")):
        background = v if name in ("background-color", "background") else background
    if background and background.strip().lower() not in ("transparent", "none", "initial", "inherit", "unset"):
        notes.add("background-color of the root <svg> (a page background, not part of the art)")
    meta_el = next((c for c in root_xml if _local(c.tag) == "metadata"), None)
    metadata_text = meta_el.text if meta_el is not None else None
    for k in ("width", "height"):
        v = root_xml.get(k)
        if v is not None and re.fullmatch(
            r"\s*[-+]?(0+(\.0*)?|\.0+)\s*[a-z%]*\s*", v, re.IGNORECASE
        ):
            raise InputError(
                path,
                f'the root <svg> has {k}="{v}", so nothing is rendered; give it a positive size',
            )
    vb = root_xml.get("viewBox")
    if vb is not None and vb.strip():  # as SVG has it: zero disables rendering, a negative size or
        parts = [v for v in re.split(r"[\s,]+", vb.strip()) if v]  # a malformed list invalidates the attribute
        try:
            vals = [float(v) for v in parts]
        except ValueError:
            vals = []
        if len(vals) == 4 and all(math.isfinite(v) for v in vals) and min(vals[2:]) == 0:
            raise InputError(path, f'the root <svg> has viewBox="{vb}" with a zero width or height, so nothing '
                                   "is rendered; give it a positive size")
        if len(vals) != 4 or not all(math.isfinite(v) for v in vals) or min(vals[2:]) < 0:
            notes.add(f'invalid root viewBox="{vb}" (ignored, as browsers do)')
            del root_xml.attrib["viewBox"]
            svg_root.pop("viewBox", None)
    clean = ET.tostring(root_xml, encoding="utf-8")

    doc = se.SVG.parse(io.BytesIO(clean), reify=False, on_error="ignore")
    if not isinstance(doc, se.SVG):
        display = root_xml.get("display")
        for name, v, _ in _inline_declarations(root_xml.get("style")):
            display = v if name == "display" else display
        if (display or "").strip().lower() == "none":
            raise InputError(path, 'the root <svg> has display="none", so nothing is drawn (as in browsers); '
                                   "remove it to use the art")
        raise InputError(path, "does not contain an <svg> document")
    root_tf = doc.values.get("transform") or ""
    vb = doc.viewbox_transform if doc.viewbox is not None else ""
    viewport = se.Matrix(f"{root_tf} {vb}".strip())
    if abs(viewport.determinant) == 0 or not all(
        math.isfinite(v)
        for v in (
            viewport.a,
            viewport.b,
            viewport.c,
            viewport.d,
            viewport.e,
            viewport.f,
        )
    ):
        raise InputError(
            path,
            "the root viewBox/size is degenerate (zero or non-finite); fix width, height and viewBox",
        )
    inv_viewport = ~viewport
    vp_scale = math.sqrt(abs(viewport.determinant))
    if as_drawn:  # what the root's transform and a non-uniform viewBox do to the shape
        a, b, c, d = (v / vp_scale for v in (viewport.a, viewport.b, viewport.c, viewport.d))
        if max(abs(a - 1), abs(b), abs(c), abs(d - 1)) > 1e-12:
            inv_viewport = inv_viewport * se.Matrix(a, b, c, d, 0, 0)

    shapes: list[SvgShape] = []

    def own(node) -> dict:
        vals = getattr(node, "values", None) or {}
        attrs = vals.get("attributes") or {}
        return dict(attrs)

    layer_keys = itertools.count(1)  # tells the translucent groups of this file apart

    def walk(node, opacity: float, hole: bool, groups: tuple, clips: tuple = (), layers: tuple = (),
             context: tuple = (None, None)):
        for child in node:
            if isinstance(child, se.Shape):
                attrs = own(child)
                bad = _negative_size(type(child).__name__, attrs)
                if bad:  # an error in SVG: browsers draw nothing (svgelements took |r|)
                    notes.add(f"<{type(child).__name__.lower()}> with a negative {bad} (not drawn, as in browsers)")
                    continue
                if "filter" in attrs:
                    notes.add("filter")
                if "mask" in attrs:
                    notes.add("mask (ignored, shape drawn unmasked)")
                markers = marker_ids(child.values) if type(child).__name__ in MARKABLE else {}
                m = child.transform * inv_viewport
                mat = _matrix_to_np(m)
                det_scale = _det_scale(mat)
                op = opacity * clamp01(float_attr(attrs.get("opacity"), 1.0))
                style = style_of(child, op, det_scale, vp_scale, gradients, notes, context)
                if isinstance(child, se.SimpleLine):  # a line has no inside: never filled
                    style = dataclasses.replace(style, fill=None)
                if style.stroke is not None and style.stroke_width > 0 and style.opacity > 0:
                    sv = np.linalg.svd(_matrix_to_np(child.transform * ~viewport)[:2, :2], compute_uv=False)
                    if sv[0] > 1.05 * sv[1]:  # a skewed or unevenly scaled stroke varies in width
                        notes.add("stroke under a skewing or uneven scaling transform "
                                  "(drawn with one even width)")
                if layers:
                    style = dataclasses.replace(style, layers=layers)
                segs = _dots(_smooth_controls(list(child.segments(transformed=False))), style)
                own_clips = clip_refs(child.values.get("clip-path"), mat, notes)
                vis = str(child.values.get("visibility", "visible")).strip().lower()
                shapes.append(
                    SvgShape(segs, mat, style, hole or _is_hole(attrs), attrs, groups,
                             clips + own_clips, vis in ("hidden", "collapse"), node=child)
                )
                if markers:  # drawn after the shape, with its opacity, groups and clips
                    for kind, mid in markers.items():
                        paints = tuple(str(context_paint(child.values.get(k, d), context) or "none")
                                       for k, d in (("fill", "black"), ("stroke", "none")))
                        for sh in marker_shapes(mid, kind, child, segs, mat, paints, op):
                            shapes.append(dataclasses.replace(
                                sh, groups=groups, clips=clips + own_clips + sh.clips,
                                hidden=sh.hidden or vis in ("hidden", "collapse"),
                                style=dataclasses.replace(sh.style, layers=layers) if layers else sh.style))
            elif isinstance(child, (se.Group, se.Use)):
                attrs = own(child)
                if "filter" in attrs:
                    notes.add("filter")
                if "mask" in attrs:
                    notes.add("mask (ignored, shape drawn unmasked)")
                group_op = clamp01(float_attr(attrs.get("opacity"), 1.0))
                op = opacity * group_op
                own_clips = clip_refs(
                    child.values.get("clip-path"),
                    _matrix_to_np(child.transform * inv_viewport),
                    notes,
                )
                inner = layers + ((next(layer_keys), group_op),) if group_op < 1.0 else layers
                inner_context = context
                if isinstance(child, se.Use):  # the context element of context-fill/-stroke
                    inner_context = tuple(context_paint(child.values.get(k, d), context)
                                          for k, d in (("fill", "black"), ("stroke", "none")))
                walk(child, op, hole or _is_hole(attrs), groups + (attrs,), clips + own_clips, inner,
                     inner_context)
            elif isinstance(child, se.Text):
                notes.add("text")
            elif isinstance(child, se.Image):
                notes.add("image")

    marker_clips: dict[str, ClipDef] = {}  # the boxes markers are clipped to

    @functools.cache
    def markers_by_id() -> dict:  # built when a shape first uses a marker
        return {el.get("id"): el for el in root_xml.iter()
                if isinstance(el.tag, str) and _local(el.tag) == "marker" and el.get("id")}

    @functools.cache
    def elements_by_id() -> dict:
        return {el.get("id"): el for el in root_xml.iter() if isinstance(el.tag, str) and el.get("id")}

    def marker_shapes(mid, kind, child, segs, mat, paints, op) -> list[SvgShape]:
        """The shapes ``kind`` (marker-start/-mid/-end) ``mid`` puts on ``child`` (see
        :mod:`.svg_markers`), in file user units."""
        el = markers_by_id().get(mid)
        if el is None:
            notes.add(f"{kind} naming no <marker> ({mid})")
            return []
        mats = [mat @ t for t in placements(segs, el, kind, shape_stroke_width(child))]
        if not mats:
            return []
        box = clip_box(el)
        if box is not None and not (box[2] > box[0] and box[3] > box[1]):
            return []  # a zero-size marker box draws nothing
        clip_id = f"\0marker#{mid}"  # not an XML id: cannot collide with the file's
        if box is not None and clip_id not in marker_clips:
            x0, y0, x1, y1 = box
            rect = se.Path(f"M{x0!r},{y0!r} H{x1!r} V{y1!r} H{x0!r} Z")
            marker_clips[clip_id] = ClipDef(clip_id, False, [ClipChild(list(rect.segments()), np.eye(3))])
        out: list[SvgShape] = []
        for m in mats:  # one placement at a time: each copy has its own clip box
            data = marker_svg(el, [m], *(p.replace('"', "'") for p in paints), elements_by_id())
            mdoc = se.SVG.parse(io.BytesIO(data), reify=False, on_error="ignore")
            box_ref = (ClipRef(clip_id, m),) if box is not None else ()
            for c in mdoc.elements():
                if isinstance(c, se.Image):
                    notes.add("image")
                if not isinstance(c, se.Shape):
                    continue
                if marker_ids(c.values):
                    notes.add("markers on the content of a marker (not drawn)")
                cm = _matrix_to_np(c.transform)
                cst = style_of(c, op * clamp01(float_attr(own(c).get("opacity"), 1.0)), _det_scale(cm),
                                vp_scale, gradients, notes)
                vis = str(c.values.get("visibility", "visible")).strip().lower()
                out.append(SvgShape(list(c.segments(transformed=False)), cm, cst, False, own(c),
                                    clips=box_ref, hidden=vis in ("hidden", "collapse"), node=c))
        return out

    root_own = own(doc)
    if "filter" in root_own:
        notes.add("filter")
    # a clip-path on the root <svg> is in the file's user units (as resvg draws it)
    root_clips = clip_refs(doc.values.get("clip-path"), np.eye(3), notes)
    root_op = clamp01(float_attr(root_own.get("opacity"), 1.0))
    walk(doc, root_op, False, (), root_clips, ((0, root_op),) if root_op < 1.0 else ())
    defs = clip_defs(doc, inv_viewport, notes) if any(s.clips for s in shapes) else {}
    defs.update(marker_clips)
    if notes:
        warn(path, "skipped unsupported content: " + ", ".join(sorted(notes)))
    sv = np.linalg.svd(_matrix_to_np(viewport)[:2, :2], compute_uv=False)
    stretch = (float(sv[0]), float(sv[1])) if sv[0] > sv[1] * (1 + 1e-9) else None
    return SvgDocument(shapes, svg_root, root_attrs, metadata_text, defs, xml=root_xml, stretch=stretch)
