"""Objects of an Inkscape document as standalone SVG files the library's readers take.

The readers (``repulsionpak.load_container`` / ``load_element``) read files; an object
inside a document depends on its ancestors (their transforms, inherited styles, the
document's stylesheet) and on the defs it references (gradients, clip paths, markers,
clones' originals). :func:`standalone_svg` cuts one object out with all of that made
explicit, in the document's root user units.
"""

from __future__ import annotations

import copy
import re

import inkex
from lxml import etree

SVG_NS = "http://www.w3.org/2000/svg"
XLINK_HREF = "{http://www.w3.org/1999/xlink}href"
INKSCAPE_NS = "http://www.inkscape.org/namespaces/inkscape"
SODIPODI_NS = "http://sodipodi.sourceforge.net/DTD/sodipodi-0.dtd"

_URL = re.compile(r"url\(\s*['\"]?#([^'\")\s]+)['\"]?\s*\)")
_CLOSED_TAGS = {"rect", "circle", "ellipse", "polygon"}


def local_name(node) -> str:
    """The tag without its namespace (``path``, ``g``, ...); '' for comments."""
    tag = node.tag
    return etree.QName(tag).localname if isinstance(tag, str) else ""


def is_closed_shape(node) -> bool:
    """True for a rectangle, circle, ellipse, polygon, or a path every subpath of which is
    closed (``z``, or its last point on its first).

    Parameters
    ----------
    node : inkex.BaseElement

    Returns
    -------
    bool
        Groups, clones, text, lines and polylines are never containers.
    """
    name = local_name(node)
    if name in _CLOSED_TAGS:
        return True
    if name != "path":
        return False
    try:
        subpaths = inkex.Path(node.get("d", "")).to_superpath()
    except Exception:  # unparsable path data: not a container
        return False
    if not subpaths:
        return False
    for sub in subpaths:  # a closed subpath ends on its first point (z adds that point)
        if len(sub) < 3 or not _meets(tuple(sub[0][1]), tuple(sub[-1][1])):
            return False
    return True


def _meets(a, b, tol: float = 1e-4) -> bool:
    return a is not None and b is not None and abs(a[0] - b[0]) <= tol and abs(a[1] - b[1]) <= tol


def referenced_ids(node) -> list[str]:
    """Ids the subtree of ``node`` references (``url(#id)`` in any attribute or style,
    ``href="#id"``), in document order, without repeats."""
    seen: dict[str, None] = {}
    for el in node.iter():
        if not isinstance(el.tag, str):
            continue
        for key, value in el.attrib.items():
            if key in (XLINK_HREF, "href") and value.startswith("#"):
                seen.setdefault(value[1:], None)
            for m in _URL.finditer(value):
                seen.setdefault(m.group(1), None)
    return list(seen)


def defs_closure(svg, node) -> list:
    """Copies of every element ``node`` needs by reference, followed transitively
    (a gradient's ``href`` chain, a clone of a clone), each with its styles resolved."""
    out, done = [], set()
    todo = referenced_ids(node)
    own = {el.get("id") for el in node.iter() if isinstance(el.tag, str) and el.get("id")}
    while todo:
        ref = todo.pop(0)
        if ref in done or ref in own:
            continue
        done.add(ref)
        target = svg.getElementById(ref)
        if target is None:
            continue
        out.append(resolved_copy(target))
        todo.extend(r for r in referenced_ids(target) if r not in done)
    return out


def resolved_copy(node):
    """A deep copy of ``node`` whose every element carries its specified style (the
    document's stylesheet, presentation attributes and inheritance from ancestors
    resolved) in its ``style`` attribute, so the copy draws the same outside the document."""
    dup = copy.deepcopy(node)
    for orig, el in zip(node.iter(), dup.iter()):
        if not isinstance(orig.tag, str) or not isinstance(orig, inkex.BaseElement):
            continue
        if local_name(orig) in ("defs", "title", "desc", "metadata", "style"):
            continue
        try:
            style = orig.specified_style()
        except Exception:  # an element inkex cannot style (foreign markup): keep as written
            continue
        text = str(style)
        if text:
            el.set("style", text)
    return dup


def standalone_svg(svg, node, viewbox=None) -> bytes:
    """``node`` alone as an SVG document in the root's user units.

    Parameters
    ----------
    svg : inkex.SvgDocumentElement
        The document ``node`` belongs to.
    node : inkex.BaseElement
        A shape, group, text or clone.
    viewbox : tuple of 4 floats, optional
        The new document's viewBox (default: the document's), 1 unit = 1 user unit of
        the document's root.

    Returns
    -------
    bytes
        ``<svg>`` with the defs ``node`` references and one ``<g>`` carrying the composed
        transform of ``node``'s parent, around a copy of ``node`` with resolved styles.

    Notes
    -----
    The composed transform is the one from the node's parent up to the root, not the
    viewBox scale: the library works in the root's user units, as the new layer is drawn.
    """
    vb = list(viewbox or svg.get_viewbox() or (0, 0, 0, 0))
    if not vb[2] or not vb[3]:
        vb = [0.0, 0.0, 1000.0, 1000.0]
    root = etree.Element(f"{{{SVG_NS}}}svg", nsmap={None: SVG_NS, "xlink": "http://www.w3.org/1999/xlink"})
    root.set("viewBox", " ".join(f"{v:.10g}" for v in vb))
    root.set("width", f"{vb[2]:.10g}")
    root.set("height", f"{vb[3]:.10g}")
    needed = defs_closure(svg, node)
    if needed:
        defs = etree.SubElement(root, f"{{{SVG_NS}}}defs")
        for el in needed:
            defs.append(_plain(el))
    wrap = etree.SubElement(root, f"{{{SVG_NS}}}g")
    tr = composed_transform(node.getparent())
    if not tr == inkex.Transform():
        wrap.set("transform", str(tr))
    wrap.append(_plain(resolved_copy(node)))
    return etree.tostring(root, xml_declaration=True, encoding="UTF-8")


def composed_transform(node) -> "inkex.Transform":
    """The transform from ``node``'s user space to the root's (the product of the
    ``transform`` attributes of ``node`` and its ancestors below the root; identity for
    None or the root).

    Notes
    -----
    Read from the attributes, not inkex's ``transform`` property, which writes the
    attribute back in its own spelling: the originals must stay byte for byte.
    """
    tr = inkex.Transform()
    cur = node
    while cur is not None and isinstance(cur.tag, str) and cur.getparent() is not None:
        tr = inkex.Transform(cur.attrib.get("transform") or "") @ tr  # (not .get: inkex wraps it)
        cur = cur.getparent()
    return tr


def _plain(el):
    """``el`` as plain lxml elements (an inkex element class carries a document root)."""
    return etree.fromstring(etree.tostring(el))
