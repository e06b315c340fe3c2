"""Viewports and their units: nested ``<svg>`` elements, percentages, the root's page mapping.

Owns :func:`nested_svgs_to_groups` (a nested ``<svg>`` becomes a ``<g>`` carrying its
viewport transform, clipped to its viewport unless ``overflow`` is visible),
:func:`wrap_in_viewport`, :func:`reference_size` (what percentages of the outermost
viewport refer to), :func:`circle_percentages` (a circle's ``r`` in percent of the
normalized diagonal), :func:`user_length` and :data:`ROOT_VIEW_ATTRS` (the root
attributes that place the file's user units on the page, kept for the output).

Notes
-----
svgelements leaks a nested svg's ``x``/``y`` into its children and takes a circle's
percentage radius per axis; resolving viewports here keeps coordinates as browsers have them.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

from .svg_xml import SVG_NS
from .svg_xml import inline_declarations as _inline_declarations
from .svg_xml import local_name as _local

__all__ = ["ROOT_VIEW_ATTRS", "circle_percentages", "nested_svgs_to_groups", "reference_size",
           "user_length", "wrap_in_viewport"]


#: attributes of the root <svg> that map its user units to the page (kept for the output)
ROOT_VIEW_ATTRS = ("width", "height", "viewBox", "preserveAspectRatio", "transform")


def circle_percentages(el: ET.Element, size: tuple[float, float]) -> None:
    """A circle's ``r`` given in percent is a share of its viewport's normalized diagonal,
    sqrt((w² + h²)/2) (SVG 2, "Units"); svgelements took it as a share of the width along x
    and of the height along y: ``r="40%"`` in a 200 × 100 viewport became an 80 × 40
    ellipse. Resolved here to user units, with the viewport of the nearest ``<svg>``
    (its viewBox, else its width and height)."""
    for child in el:
        if not isinstance(child.tag, str):
            continue
        name = _local(child.tag)
        if name == "svg":
            vb = (child.get("viewBox") or "").replace(",", " ").split()
            try:
                inner = (float(vb[2]), float(vb[3])) if len(vb) == 4 else (
                    user_length(child.get("width", "100%"), size[0]), user_length(child.get("height", "100%"), size[1]))
            except ValueError:
                inner = size
            circle_percentages(child, inner if all(math.isfinite(v) and v > 0 for v in inner) else size)
            continue
        r = child.get("r")
        if name == "circle" and r is not None and r.strip().endswith("%"):
            try:
                share = float(r.strip()[:-1]) / 100.0
            except ValueError:
                share = float("nan")
            if math.isfinite(share):
                child.set("r", repr(share * math.sqrt((size[0] ** 2 + size[1] ** 2) / 2.0)))
        circle_percentages(child, size)


def user_length(value, relative: float) -> float:
    import svgelements as se

    v = se.Length(value).value(relative_length=relative, ppi=96.0)
    return float(v) if isinstance(v, (int, float)) else float("nan")


def reference_size(root: ET.Element) -> tuple[float, float]:
    """Width and height that percentages of the outermost viewport refer to."""
    rvb = (root.get("viewBox") or "").replace(",", " ").split()
    try:
        return (
            (float(rvb[2]), float(rvb[3]))
            if len(rvb) == 4
            else (
                user_length(root.get("width", "100"), 100),
                user_length(root.get("height", "100"), 100),
            )
        )
    except ValueError:
        return 100.0, 100.0


def _clips_its_viewport(el: ET.Element) -> bool:
    """Whether a nested ``<svg>`` or a ``<symbol>`` clips its content to its viewport:
    ``overflow`` (attribute or style) hidden, scroll or clip, the default for both."""
    value = el.get("overflow")
    for name, v, _ in _inline_declarations(el.get("style")):
        if name == "overflow":
            value = v
    return (value or "hidden").strip().lower() not in ("visible", "auto")


def document_ids(root: ET.Element) -> set:
    """The ids the document uses (for :func:`wrap_in_viewport`, which adds its own)."""
    return {e.get("id") for e in root.iter() if isinstance(e.tag, str) and e.get("id")}


def wrap_in_viewport(root: ET.Element, parent: ET.Element, el: ET.Element, transform: str | None,
                      box: tuple[float, float, float, float] | None, ids: set | None = None) -> ET.Element:
    """Put ``el`` inside a new ``<g>`` (in its place) that carries ``transform`` and, when
    ``box`` is given, a clip path to that rectangle (x, y, width, height, in the new
    group's user space): the viewport of a nested ``<svg>`` or a ``<symbol>``'s ``<use>``.
    ``ids``: the document's ids (:func:`document_ids`), which the clip path's joins."""
    svg = el.tag.startswith("{")
    g = ET.Element(f"{{{SVG_NS}}}g" if svg else "g")
    if transform:
        g.set("transform", transform)
    if box is not None:
        k = len(ids) + 1
        while f"repulsionpak-viewport-{k}" in ids:
            k += 1
        cid = f"repulsionpak-viewport-{k}"
        ids.add(cid)
        clip = ET.SubElement(root, f"{{{SVG_NS}}}clipPath" if svg else "clipPath", {"id": cid})
        ET.SubElement(clip, f"{{{SVG_NS}}}rect" if svg else "rect",
                      {k: repr(float(v)) for k, v in zip(("x", "y", "width", "height"), box)})
        g.set("clip-path", f"url(#{cid})")
    parent.insert(list(parent).index(el), g)
    parent.remove(el)
    g.append(el)
    return g


def nested_svgs_to_groups(root: ET.Element) -> None:
    """Turn nested ``<svg>`` elements into ``<g transform=...>``.

    svgelements leaks a nested svg's ``x``/``y`` attributes into its children (a rect
    without ``x`` would be moved twice), so the viewport is resolved here instead.
    """
    import svgelements as se

    parent = {c: p for p in root.iter() for c in p}
    nested = [e for e in root.iter() if e is not root and _local(e.tag) == "svg"]
    ids = document_ids(root) if nested else set()
    inner_size = {root: reference_size(root)}  # the user space size each viewport makes

    def outer_size(el):
        p = parent.get(el)
        while p is not None and p not in inner_size:
            p = parent.get(p)
        return inner_size[p if p is not None else root]

    for el in nested:  # (outermost first: root.iter() is in document order)
        ref_w, ref_h = outer_size(el)
        x = user_length(el.get("x", "0"), ref_w)
        y = user_length(el.get("y", "0"), ref_h)
        w = user_length(el.get("width", "100%"), ref_w)
        h = user_length(el.get("height", "100%"), ref_h)
        vb = (el.get("viewBox") or "").replace(",", " ").split()
        tf = f"translate({x!r}, {y!r})"
        inner_size[el] = (w, h) if all(math.isfinite(v) and v > 0 for v in (w, h)) else (ref_w, ref_h)
        if len(vb) == 4 and all(math.isfinite(v) for v in (x, y, w, h)):
            try:
                vbx, vby, vbw, vbh = (float(v) for v in vb)
                if vbw > 0 and vbh > 0 and w > 0 and h > 0:
                    inner_size[el] = (vbw, vbh)
                    tf = se.Viewbox.viewbox_transform(
                        x, y, w, h, vbx, vby, vbw, vbh, el.get("preserveAspectRatio")
                    )
            except ValueError:
                pass
        for k in ("x", "y", "width", "height", "viewBox", "preserveAspectRatio"):
            el.attrib.pop(k, None)
        own_tf = el.get("transform")
        clip = _clips_its_viewport(el) and all(math.isfinite(v) for v in (x, y, w, h)) and w > 0 and h > 0
        if clip and el in parent:  # the viewport clips, in the svg's own (transformed) coordinates
            wrap_in_viewport(root, parent[el], el, own_tf, (x, y, w, h), ids)
            el.set("transform", tf)
        else:
            el.set("transform", f"{own_tf} {tf}" if own_tf else tf)
        el.tag = f"{{{SVG_NS}}}g" if el.tag.startswith("{") else "g"
