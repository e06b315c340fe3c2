"""``<use>`` of a ``<symbol>`` or an ``<svg>`` resolved into the viewport browsers draw.

A ``<use>`` that references a ``<symbol>`` or an ``<svg>`` establishes a new viewport:
its ``width`` and ``height`` (``100%`` when absent) replace the symbol's or the svg's own
size, the symbol's ``viewBox`` and ``preserveAspectRatio`` fit its content into it, and
the content is clipped to it (``overflow: hidden``, the default for both). svgelements
only translates the content by the use's ``x``, ``y``.

:func:`expand_viewport_uses` rewrites every such use as what it draws, before
svgelements reads the tree::

    <g id=use's id  (the use's other attributes)  transform="(use's transform) translate(x, y)">
      <svg width=... height=... viewBox=... preserveAspectRatio=... overflow=...>
        copies of the symbol's (or svg's) children, without their ids
      </svg>
    </g>

The nested ``<svg>`` is then resolved as any nested svg is (viewport transform and
clip, percentages of its parent viewport). A ``<symbol>``'s ``transform`` is ignored (SVG
1.1, as resvg; SVG 2 adds it).
"""

from __future__ import annotations

import copy
import xml.etree.ElementTree as ET

__all__ = ["expand_viewport_uses"]

_XLINK = "{http://www.w3.org/1999/xlink}href"
#: elements copied in all, past which further uses are left to svgelements
MAX_COPIED = 200_000
_USE_OWN = {"x", "y", "width", "height", "href", _XLINK, "transform"}


def _local(tag) -> str:
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) else ""


def _href(el: ET.Element) -> str | None:
    v = el.get(_XLINK) or el.get("href")
    return v.strip() if v else None


def _number_or_zero(value: str | None) -> str:
    return (value or "0").strip() or "0"


def expand_viewport_uses(root: ET.Element) -> int:
    """Replace, in place, every ``<use>`` of a ``<symbol>`` or an ``<svg>`` by a group
    holding a nested ``<svg>`` viewport with a copy of the content (see the module
    docstring). Cycles must have been removed before. Returns the number of uses
    expanded."""
    count, copied = 0, 0
    while True:
        ids = {e.get("id"): e for e in root.iter() if isinstance(e.tag, str) and e.get("id")}
        parent = {c: p for p in root.iter() for c in p}
        todo = []
        for use in root.iter():
            if _local(use.tag) != "use" or use not in parent:
                continue
            ref = _href(use)
            target = ids.get(ref[1:]) if ref and ref.startswith("#") else None
            if target is not None and _local(target.tag) in ("symbol", "svg") and target is not root:
                todo.append((use, target))
        if not todo:
            return count
        done_any = False
        for use, target in todo:
            inside = any(a is use for a in target.iter())
            if inside:  # a use inside what it draws: a cycle (left to the cycle check)
                continue
            size = sum(1 for _ in target.iter())
            if copied + size > MAX_COPIED:
                return count
            copied += size
            _expand(use, target, parent[use])
            count += 1
            done_any = True
        if not done_any:
            return count


def _expand(use: ET.Element, target: ET.Element, holder: ET.Element) -> None:
    ns = use.tag[:use.tag.index("}") + 1] if use.tag.startswith("{") else ""
    g = ET.Element(ns + "g", {k: v for k, v in use.attrib.items() if k not in _USE_OWN})
    tf = f"translate({_number_or_zero(use.get('x'))}, {_number_or_zero(use.get('y'))})"
    g.set("transform", f"{use.get('transform')} {tf}" if use.get("transform") else tf)
    g.tail = use.tail
    svg = ET.SubElement(g, ns + "svg")
    if _local(target.tag) == "symbol":
        for k, v in target.attrib.items():
            if k not in ("id", "transform", "x", "y", "width", "height"):
                svg.set(k, v)
        for k in ("x", "y"):  # SVG 2: a symbol's own position
            if target.get(k) is not None:
                svg.set(k, target.get(k))
    else:
        for k, v in target.attrib.items():
            if k != "id":
                svg.set(k, v)
    for k in ("width", "height"):  # the use's size wins, then the target's, then 100 %
        v = use.get(k) or target.get(k)
        if v is not None:
            svg.set(k, v)
    for child in target:
        c = copy.deepcopy(child)
        for e in c.iter():
            if isinstance(e.tag, str):
                e.attrib.pop("id", None)
        svg.append(c)
    i = list(holder).index(use)
    holder.remove(use)
    holder.insert(i, g)
