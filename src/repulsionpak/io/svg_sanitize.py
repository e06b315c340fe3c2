"""What an SVG file draws: the tree cut down to it before svgelements reads it.

Owns :func:`sanitize` (non-rendered containers -- ``<symbol>``, ``<mask>``, ``<marker>``
outside ``<defs>``, shapes inside elements browsers do not draw into, Inkscape's
``<flowRoot>`` -- moved into ``<defs>``; ``<foreignObject>`` and the alternatives a
``<switch>`` does not draw dropped; nested viewports made groups) and
:func:`shape_sizes` (the sizes SVG 2 gives circles, ellipses and rects with a missing or
``auto`` attribute, and no drawing for those without one).

Notes
-----
svgelements would draw the children of any element and give a missing size the value 1;
each decision here is noted for the file's one warning on unsupported content.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

from .svg_viewports import nested_svgs_to_groups
from .svg_xml import SVG_NS, href
from .svg_xml import inline_declarations as _inline_declarations
from .svg_xml import local_name as _local

__all__ = ["sanitize", "shape_sizes"]


_NON_RENDERED = {"symbol", "mask", "marker"}
_CONTAINERS_OK = {"defs", "clipPath", "pattern"}
#: elements whose children are drawn where they stand (browsers draw no shape inside any
#: other element: not in <metadata>, a gradient, an unknown or another namespace's element,
#: nor Inkscape's flowed text, <flowRoot>, which no browser draws)
_GROUPING = {"svg", "g", "a", "switch"}
_GRAPHICS = {"use", "path", "rect", "circle", "ellipse", "line", "polyline", "polygon", "text", "image"}
#: elements drawn where they stand, or read from the tree elsewhere (text, style sheets)
_DRAWN = _GROUPING | _GRAPHICS | {"style", "foreignObject"} | _NON_RENDERED | _CONTAINERS_OK


def _styled(el: ET.Element, prop: str) -> bool:
    """Whether ``el``'s inline style sets the property ``prop`` (CSS outranks attributes)."""
    return any(name == prop for name, _, _ in _inline_declarations(el.get("style")))


def _auto(value: str | None) -> bool:
    return value is None or value.strip().lower() in ("", "auto")


def _negative_length(value) -> bool:
    m = re.match(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)", str(value)) if value is not None else None
    return bool(m) and float(m.group(1)) < 0


_GEOMETRY_ATTRS = ("x", "y", "width", "height", "cx", "cy", "r", "rx", "ry", "x1", "y1", "x2", "y2")


def shape_sizes(root: ET.Element) -> None:
    """Give circles, ellipses and rects the sizes SVG 2 gives them where an attribute is
    missing: an ellipse's ``rx`` or ``ry`` left out (or ``auto``) takes the other's value,
    as does a rect's corner radius, and a circle without ``r``, an ellipse without either radius or a rect without
    ``width`` or ``height`` is not drawn (as in browsers). svgelements drew them with a
    size of 1 instead: ``<ellipse rx="20"/>``, a circle in a browser, packed as a 40 × 2
    sliver."""
    for el in root.iter():
        if not isinstance(el.tag, str):
            continue
        name = _local(el.tag)
        for k in _GEOMETRY_ATTRS:  # not properties: "inherit" is invalid, and a group has none
            v = el.get(k)  # (svgelements passed a <g x="20"> on to the shapes inside)
            if v is not None and (v.strip().lower() == "inherit" or name in ("g", "a", "switch", "defs")):
                del el.attrib[k]
        if name == "circle" and el.get("r") is None and not _styled(el, "r"):
            el.set("r", "0")
        elif name == "ellipse" and not (_styled(el, "rx") or _styled(el, "ry")):
            # a negative radius is an error: the property falls back to auto (SVG 2); both
            rx, ry = el.get("rx"), el.get("ry")  # negative: not drawn (said by _negative_size)
            if _negative_length(rx) != _negative_length(ry):
                rx, ry = (None if _negative_length(v) else v for v in (rx, ry))
            if _auto(rx) and _auto(ry):
                el.set("rx", "0")
                el.set("ry", "0")
            elif _auto(rx):
                el.set("rx", ry)
            elif _auto(ry):
                el.set("ry", rx)
        elif name == "rect":
            for k in ("width", "height"):
                if _auto(el.get(k)) and not _styled(el, k):
                    el.set(k, "0")
            for k in ("rx", "ry"):  # left out, a corner radius takes the other's (svgelements
                if el.get(k) is not None and _auto(el.get(k)):  # does so); "auto" it read as 0
                    del el.attrib[k]


def sanitize(path, root: ET.Element, notes: set[str]) -> None:
    """Make the tree safe for svgelements: move non-rendered containers into ``<defs>``
    (svgelements would otherwise draw their children), drop ``foreignObject``."""
    parent = {c: p for p in root.iter() for c in p}
    to_move, to_drop = [], []

    def inside_defs(el):
        p = parent.get(el)
        while p is not None:
            if _local(p.tag) in _CONTAINERS_OK:
                return True
            p = parent.get(p)
        return False

    quiet = set()  # alternatives a <switch> does not draw: dropped without a note
    for el in root.iter():
        name = _local(el.tag)
        if name in _NON_RENDERED and not inside_defs(el):
            to_move.append(el)
        elif (el is not root and isinstance(el.tag, str) and parent.get(el) is not None
              and _local(parent[el].tag) in _GROUPING and not inside_defs(el)
              and (name not in _DRAWN or (el.tag.startswith("{") and not el.tag.startswith(f"{{{SVG_NS}}}")))):
            # never drawn: kept (its ids may be referenced) where nothing is drawn
            if any(isinstance(d.tag, str) and _local(d.tag) in _GRAPHICS for d in el.iter()):
                notes.add("Inkscape flowed text <flowRoot> (not drawn, as in browsers: convert it to text)"
                          if name == "flowRoot" else f"shapes inside <{name}> (not drawn, as in browsers)")
                to_move.append(el)
        elif name == "foreignObject":
            to_drop.append(el)
        elif name == "use" and (href(el) or "#").strip()[:1] != "#":
            notes.add("<use> of another file (not drawn)")
        elif name == "switch":
            # a <switch> draws its first child whose conditions hold; we support no
            # extension (Illustrator puts its private data first, under requiredExtensions)
            kids = [c for c in el if isinstance(c.tag, str)]
            first = next((c for c in kids if c.get("requiredExtensions") is None
                          and c.tag.startswith(f"{{{SVG_NS}}}") == el.tag.startswith(f"{{{SVG_NS}}}")
                          and _local(c.tag) in _GROUPING | _GRAPHICS | {"foreignObject"}), None)
            for c in kids:
                if c is not first:
                    to_drop.append(c)
                    quiet.add(c)
    for el in to_drop:
        p = parent.get(el)
        if p is not None and el in list(p):
            p.remove(el)
            if el not in quiet:
                notes.add("foreignObject")
    nested_svgs_to_groups(root)
    if to_move:
        defs = ET.SubElement(root, f"{{{SVG_NS}}}defs")
        for el in to_move:
            p = parent.get(el)
            # a moved element may live inside another moved element: only move the outermost
            anc, nested = p, False
            while anc is not None:
                if anc in to_move:
                    nested = True
                    break
                anc = parent.get(anc)
            if p is not None and not nested:
                p.remove(el)
                defs.append(el)
