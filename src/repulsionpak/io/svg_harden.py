"""XML hardening of an SVG file before anything else reads it.

Owns :func:`parse_xml_hardened` (defusedxml: no entity declarations, no external
references; a plain ``<!DOCTYPE svg PUBLIC ...>`` and Illustrator's plain text entities
allowed), :func:`check_tree` (nesting depth, ``<use>`` expansion size and path-data size:
use-bombs and huge files) and :func:`check_attributes` (invalid transforms refused, invalid
path data and point lists cut where browsers stop drawing them).

Notes
-----
Every failure is an :class:`~repulsionpak.errors.InputError` naming the file: svgelements,
which reads the tree afterwards, would otherwise crash or loop on such input.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

from ..errors import InputError
from .files import warn
from .svg_pathdata import NUMBER, path_data_error
from .svg_xml import SVG_NS, href
from .svg_xml import local_name as _local

__all__ = ["MAX_DEPTH", "MAX_EXPANDED_NODES", "MAX_PATH_DATA_CHARS", "check_attributes", "check_tree",
           "parse_xml_hardened"]


#: Largest element nesting depth of an SVG document.
MAX_DEPTH = 200
#: Largest number of SVG nodes after inlining every ``<use>``.
MAX_EXPANDED_NODES = 500_000
#: Largest total length of path data (``d`` / ``points``) after inlining ``<use>``.
MAX_PATH_DATA_CHARS = 64_000_000
_DOCTYPE = re.compile(rb"<!DOCTYPE\b[^\[>]*\[(?P<subset>.*?)\]\s*>", re.DOTALL)
_ENTITY = re.compile(rb"""<!ENTITY\s+(?P<name>[A-Za-z_][\w.\-]*)\s+(?P<q>["'])(?P<value>[^"'&%<]*)(?P=q)\s*>""")
_SUBSET_REST = re.compile(rb"\s*(<!--.*?-->\s*)*", re.DOTALL)
#: at most this many entities, each at most this long, are expanded (see below)
MAX_ENTITIES, MAX_ENTITY_CHARS = 256, 4096


def _expand_plain_entities(data: bytes) -> bytes | None:
    """``data`` with the internal DTD's plain text entities expanded and the DOCTYPE
    removed, or None when the DTD holds anything else.

    Adobe Illustrator writes ``<!DOCTYPE svg [<!ENTITY ns_ai "http://ns.adobe.com/...">
    ...]>`` and uses the entities in namespace declarations. Such entities (a literal
    value without references, quotes or markup) cannot nest, so they cannot explode;
    external, parameter or nested entities stay refused, and so does a document whose
    expansion would grow past four times its size."""
    m = _DOCTYPE.search(data)
    if m is None:
        return None
    subset = m.group("subset")
    entities = {}
    pos = 0
    for e in _ENTITY.finditer(subset):
        if _SUBSET_REST.fullmatch(subset, pos, e.start()) is None:
            return None  # something other than plain entities and comments
        if len(e.group("value")) > MAX_ENTITY_CHARS:
            return None
        entities[e.group("name")] = e.group("value")
        pos = e.end()
    if not entities or len(entities) > MAX_ENTITIES or _SUBSET_REST.fullmatch(subset, pos) is None:
        return None
    body = data[:m.start()] + data[m.end():]
    out = re.sub(rb"&([A-Za-z_][\w.\-]*);", lambda r: entities.get(r.group(1), r.group(0)), body)
    return out if len(out) <= 4 * len(data) + 65536 else None


def parse_xml_hardened(path: str | Path, data: bytes) -> ET.Element:
    """Parse ``data`` with defusedxml; any problem -> InputError naming ``path``.

    Entities are refused, except plain text ones in the internal DTD (as Illustrator
    writes them), which are expanded first (:func:`_expand_plain_entities`)."""
    import defusedxml.ElementTree as DET
    from defusedxml import DTDForbidden, EntitiesForbidden, ExternalReferenceForbidden

    try:
        try:
            root = DET.fromstring(
                data, forbid_dtd=False, forbid_entities=True, forbid_external=True
            )
        except EntitiesForbidden:
            plain = _expand_plain_entities(data)
            if plain is None:
                raise
            root = DET.fromstring(
                plain, forbid_dtd=False, forbid_entities=True, forbid_external=True
            )
    except EntitiesForbidden:
        raise InputError(
            path,
            "declares XML entities, which are not allowed (possible entity-expansion attack); remove the <!ENTITY> declarations",
        ) from None
    except (ExternalReferenceForbidden, DTDForbidden):
        raise InputError(
            path,
            "references external XML resources, which are not allowed; remove them",
        ) from None
    except ET.ParseError as exc:
        pos = getattr(exc, "position", None)
        where = f" at line {pos[0]}, column {pos[1]}" if pos else ""
        reason = re.sub(r":\s*line \d+, column \d+\s*$", "", str(exc))
        raise InputError(
            path,
            f"is not well-formed XML{where} ({reason}); the file may be truncated or not an SVG",
        ) from None
    except (ValueError, UnicodeError, TypeError) as exc:
        raise InputError(path, f"is not readable XML ({exc}); check the file") from None
    if _local(root.tag) != "svg":
        raise InputError(
            path,
            f"root element is <{_local(root.tag) or root.tag}>, not <svg>; give an SVG file",
        )
    if root.tag.startswith("{") and not root.tag.startswith("{" + SVG_NS + "}"):
        ns = root.tag[1:].split("}", 1)[0]
        raise InputError(
            path,
            f"root <svg> is in namespace {ns!r}, not the SVG namespace {SVG_NS!r}; give an SVG file",
        )
    return root


def check_tree(path, root: ET.Element) -> None:
    """Bound depth, ``<use>`` expansion and path-data size (use-bombs, huge files)."""
    ids: dict[str, ET.Element] = {}
    stack = [(root, 1)]
    while stack:
        el, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise InputError(
                path,
                f"elements are nested more than {MAX_DEPTH} levels deep; flatten the groups",
            )
        i = el.get("id")
        if i is not None and i not in ids:
            ids[i] = el
        stack.extend((c, depth + 1) for c in el)

    memo: dict[int, tuple[int, int]] = {}
    visiting: set[int] = set()

    def cost(el: ET.Element, level: int) -> tuple[int, int]:
        key = id(el)
        if key in memo:
            return memo[key]
        if key in visiting:
            raise InputError(
                path,
                "a <use> element references itself (directly or through its ancestors); remove the cycle",
            )
        if level > 4 * MAX_DEPTH:
            raise InputError(
                path, "<use> references are chained too deeply; simplify the file"
            )
        visiting.add(key)
        nodes = 1
        chars = len(el.get("d") or "") + len(el.get("points") or "")
        for c in el:
            n, ch = cost(c, level + 1)
            nodes += n
            chars += ch
        if _local(el.tag) == "use":
            ref = href(el)
            if ref and ref.startswith("#") and ref[1:] in ids:
                n, ch = cost(ids[ref[1:]], level + 1)
                nodes += n
                chars += ch
        visiting.discard(key)
        if nodes > MAX_EXPANDED_NODES:
            raise InputError(
                path,
                f"expands to more than {MAX_EXPANDED_NODES} elements once <use> references are inlined; simplify it",
            )
        if chars > MAX_PATH_DATA_CHARS:
            raise InputError(
                path,
                f"has more than {MAX_PATH_DATA_CHARS} characters of path data; simplify it",
            )
        memo[key] = (nodes, chars)
        return nodes, chars

    cost(root, 0)


_BAD_POINTS_CHARS = re.compile(r"[^0-9eE.,+\-\s]")


def check_attributes(path, root: ET.Element) -> None:
    """Reject unparseable ``transform`` attributes (svgelements would crash on them with
    an IndexError); cut path data (``d``) and point lists (``points``) after their last
    whole segment or pair before an error, as browsers draw them, with one warning naming
    the first error (:mod:`.svg_pathdata`); point lists are rewritten with their numbers
    read as browsers read them."""
    import svgelements as se

    bad_data = None
    n_bad = 0
    for el in root.iter():
        tf = el.get("transform")
        if tf is not None and tf.strip():
            try:
                se.Matrix(tf)
            except Exception:
                raise InputError(
                    path,
                    f"<{_local(el.tag)}> has an invalid transform {tf[:80]!r}; "
                    "fix or remove the transform attribute",
                ) from None
        d = el.get("d")
        err = path_data_error(d) if d else None
        if err is not None:
            # drawn up to the error, as browsers do (svgelements would skip or reinterpret
            # what follows): cut the data after its last whole segment
            el.set("d", d[: err.valid])
            n_bad += 1
            if bad_data is None:
                bad_data = (_local(el.tag), "d", d[err.valid : max(err.at, err.valid) + 20].strip(), f" ({err.reason})")
        v = el.get("points")
        if v:
            # read the numbers as browsers do (svgelements reads "50.5.5" as one number, not
            # 50.5 and .5) up to the first invalid character, and draw whole pairs only
            m = _BAD_POINTS_CHARS.search(v)
            nums = NUMBER.findall(v if m is None else v[: m.start()])
            if m is not None or len(nums) % 2:
                n_bad += 1
                if bad_data is None:
                    bad_data = ((_local(el.tag), "points", v[max(0, m.start() - 10) : m.start() + 20], "")
                                if m is not None else
                                (_local(el.tag), "points", v.strip()[-20:],
                                 " (an odd number of coordinates: the last one has no partner)"))
            el.set("points", " ".join(f"{a},{b}" for a, b in zip(nums[0::2], nums[1::2])))
    if bad_data is not None:
        tag, attr, near, reason = bad_data
        more = f" (and {n_bad - 1} more shape{'s' if n_bad > 2 else ''})" if n_bad > 1 else ""
        warn(
            path,
            f"<{tag}> {attr}=... has invalid data near {near!r}{reason}{more}; "
            "the shape is drawn up to the error (as browsers do)",
        )
