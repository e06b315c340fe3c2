"""Read elements and containers from SVG files (and dispatch ``.path`` files).

Public API
----------
``load_element(path, tolerance=None) -> Element``
``load_elements(paths, tolerance=None) -> list[Element]``
``load_container(path, tolerance=None) -> Container``

Coordinates are the file's *user units*: every nested ``transform`` is applied, the
root's viewBox -> viewport scaling is not (svgelements applies it while parsing; we
multiply every shape's matrix by the inverse of the root viewport matrix).

Hardening: the bytes are parsed first with ``defusedxml`` (no entity declarations, no
external references, plain ``<!DOCTYPE svg PUBLIC ...>`` allowed), the element tree is
checked for depth, ``<use>`` expansion size and path-data size, then handed (re-
serialised, without DTD) to svgelements. Every failure leaves the readers as an
:class:`~repulsionpak.errors.InputError` naming the file.

The helpers :func:`rings_to_region`, :func:`read_input_bytes`, :func:`parse_svg_shapes`
and :func:`flatten_shape` are shared with ``pathfile``, ``svg_write`` and ``png``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import gzip
import io
import itertools
import math
import re
import warnings
import xml.etree.ElementTree as ET
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely

from ..errors import InputError, ParameterError, RepulsionPakError
from ..geometry.outline import (
    THIN_LINE_RELATIVE_THICKNESS,
    THIN_RELATIVE_THICKNESS,
    art_area,
    art_area_problem,
    relative_thickness,
)
from ..types import ArtPath, Container, CurveSubpath, Element, Style
from .svg_clip import (ClipChild, ClipDef, ClipRef, ClipResolver, clip_art, clip_defs, clip_refs,
                       hoist_clip_paths, polygon_rings)
from .svg_image import images_to_rects
from .svg_lengths import resolve_lengths, resolve_transform_origin
from .svg_markers import (MARKABLE, clip_box, drop_marker_attribute, marker_ids, marker_svg, placements,
                          resolve_marker_lengths, resolve_overflow_inherit)
from .svg_pathdata import NUMBER, path_data_error
from .svg_text import text_to_paths
from .svg_use import expand_viewport_uses
from .svg_xml import drop_use_cycles, integer_rgb_colours
from .svg_xml import inline_declarations as _inline_declarations
from .svg_xml import local_name as _local

__all__ = [
    "MAX_FILE_BYTES",
    "MAX_POINTS",
    "load_container",
    "load_element",
    "load_elements",
    "rings_to_region",
]

#: Largest input file accepted (bytes, after gzip decompression for ``.svgz``).
MAX_FILE_BYTES = 128 * 1024 * 1024
#: Largest number of vertices a file may produce after flattening its curves.
MAX_POINTS = 2_000_000
#: Largest element nesting depth of an SVG document.
MAX_DEPTH = 200
#: Largest number of SVG nodes after inlining every ``<use>``.
MAX_EXPANDED_NODES = 500_000
#: Largest total length of path data (``d`` / ``points``) after inlining ``<use>``.
MAX_PATH_DATA_CHARS = 64_000_000
#: Largest absolute coordinate (file user units) accepted: beyond it areas and squared
#: distances lose all precision or overflow (1e300 squared is infinite).
MAX_COORD = 1e15
#: A user-given flattening tolerance is capped at this multiple of the automatic one
#: (1e-3 x bounding-box diagonal): a huge tolerance (e.g. from an absurd gap) would
#: otherwise collapse arcs to chords and a circle to a line.
MAX_TOLERANCE_FACTOR = 10.0

SVG_NS = "http://www.w3.org/2000/svg"
XLINK_NS = "http://www.w3.org/1999/xlink"
_SVG_SUFFIXES = {".svg", ".svgz", ".xml"}
_ELEMENT_SUFFIXES = {".svg", ".svgz", ".path"}

# --------------------------------------------------------------------------- common helpers


def warn(path: str | Path, message: str) -> None:
    """``warnings.warn`` (UserWarning) with the file name in front."""
    warnings.warn(f"{Path(str(path)).name}: {message}", UserWarning, stacklevel=3)


@contextlib.contextmanager
def guard(path: str | Path, what: str = "file"):
    """Turn any unexpected exception raised in the block into an InputError naming ``path``."""
    try:
        yield
    except RepulsionPakError:
        raise
    except RecursionError:
        raise InputError(
            path, f"the {what} is nested too deeply to be read; simplify its structure"
        ) from None
    except MemoryError:
        raise InputError(
            path, f"the {what} is too large to be read into memory; simplify it"
        ) from None
    except Exception as exc:
        text = str(exc).strip()
        detail = (
            f"{type(exc).__name__}: {text.splitlines()[0][:200]}"
            if text
            else type(exc).__name__
        )
        raise InputError(
            path, f"the {what} could not be read ({detail}); check that it is valid"
        ) from exc


def check_tolerance(tolerance: float | None) -> float | None:
    """Validate a user-given flattening tolerance (None = automatic)."""
    if tolerance is None:
        return None
    try:
        tol = float(tolerance)
    except (TypeError, ValueError):
        raise ParameterError(
            f"tolerance must be a positive number, got {tolerance!r}"
        ) from None
    if not math.isfinite(tol) or tol <= 0:
        raise ParameterError(
            f"tolerance must be a positive finite number, got {tolerance!r}"
        )
    return tol


def read_input_bytes(path: str | Path, what: str = "file") -> bytes:
    """Read a whole input file with the checks every reader needs.

    Missing file, directory, unreadable or empty file, or a file larger than
    :data:`MAX_FILE_BYTES` -> InputError. gzip data (``.svgz``) is decompressed under
    the same size bound.
    """
    p = Path(path)
    try:
        exists, is_dir = p.exists(), p.is_dir()
    except (OSError, ValueError) as exc:
        raise InputError(
            p, f"cannot access the {what} ({exc}); check the path"
        ) from None
    if not exists:
        raise InputError(p, f"{what} not found; check the path")
    if is_dir:
        raise InputError(p, "is a directory, not a file; give a file")
    try:
        with open(p, "rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise InputError(
            p,
            f"the {what} cannot be read ({exc.strerror or exc}); check its permissions",
        ) from None
    if len(data) > MAX_FILE_BYTES:
        raise InputError(
            p, f"the {what} is larger than {MAX_FILE_BYTES} bytes; simplify it"
        )
    if data[:2] == b"\x1f\x8b":
        try:
            with gzip.GzipFile(fileobj=io.BytesIO(data)) as gz:
                data = gz.read(MAX_FILE_BYTES + 1)
        except (OSError, EOFError, zlib.error) as exc:
            raise InputError(
                p, f"looks gzip-compressed but cannot be decompressed ({exc})"
            ) from None
        if len(data) > MAX_FILE_BYTES:
            raise InputError(
                p, f"decompresses to more than {MAX_FILE_BYTES} bytes; simplify it"
            )
    if not data.strip():
        raise InputError(
            p, f"the {what} is empty; give an SVG or .path file with geometry"
        )
    return data


def sniff_kind(path: Path, data: bytes) -> str:
    """``"path"`` or ``"svg"``, from the suffix, else from the content."""
    suffix = path.suffix.lower()
    if suffix == ".path":
        return "path"
    if suffix in _SVG_SUFFIXES:
        return "svg"
    head = data[:4096].lstrip(b"\xef\xbb\xbf \t\r\n")
    if head.startswith(b"<"):
        return "svg"
    first = head.split(b"\n", 1)[0].strip()
    if re.fullmatch(rb"[0-9]+", first):
        return "path"
    raise InputError(
        path,
        "is neither an SVG nor a RepulsionPak .path file; give an .svg or .path file",
    )


# --------------------------------------------------------------------------- regions


def _winding_numbers(points: np.ndarray, rings: list[np.ndarray]) -> np.ndarray:
    """Winding number of each point (F, 2) with respect to all closed rings (K_i, 2)."""
    a = np.concatenate(rings, axis=0)
    b = np.concatenate([np.roll(r, -1, axis=0) for r in rings], axis=0)
    w = np.zeros(len(points), dtype=np.int64)
    chunk = max(1, 4_000_000 // max(1, len(a)))
    ax, ay, bx, by = a[None, :, 0], a[None, :, 1], b[None, :, 0], b[None, :, 1]
    for s in range(0, len(points), chunk):
        px = points[s : s + chunk, 0][:, None]
        py = points[s : s + chunk, 1][:, None]
        is_left = (bx - ax) * (py - ay) - (px - ax) * (by - ay)
        up = (ay <= py) & (by > py) & (is_left > 0)
        down = (ay > py) & (by <= py) & (is_left < 0)
        w[s : s + chunk] = up.sum(axis=1) - down.sum(axis=1)
    return w


def polygon_parts(geom) -> shapely.Geometry:
    """The polygonal part of ``geom`` as a Polygon or MultiPolygon (maybe empty)."""
    if geom is None or geom.is_empty:
        return shapely.Polygon()
    if isinstance(geom, (shapely.Polygon, shapely.MultiPolygon)):
        return geom
    parts = [
        g
        for g in shapely.get_parts(geom)
        if isinstance(g, (shapely.Polygon, shapely.MultiPolygon)) and not g.is_empty
    ]
    return shapely.union_all(parts) if parts else shapely.Polygon()


#: Work limits of :func:`rings_to_region` for pathological (heavily self-intersecting) input.
MAX_REGION_FACES = 20_000
MAX_REGION_WORK = 400_000_000


class RegionTooComplex(ValueError):
    """Raised by :func:`rings_to_region` when the outline has too many self-intersections."""


def _count_crossings(rings: list[np.ndarray], limit: int) -> int:
    """Number of intersecting pairs of non-adjacent edges of ``rings``, counted until it
    exceeds ``limit`` (then the partial count is returned). O(n log n + limit): bounds
    the time spent on scribbles before the (quadratic) noding of their linework."""
    a = np.concatenate(rings, axis=0)
    b = np.concatenate([np.roll(r, -1, axis=0) for r in rings], axis=0)
    ring_id = np.concatenate([np.full(len(r), k) for k, r in enumerate(rings)])
    starts = np.cumsum([0] + [len(r) for r in rings])[:-1]
    first, last = starts[ring_id], starts[ring_id] + np.array([len(r) for r in rings])[ring_id] - 1
    with np.errstate(all="ignore"):
        segs = shapely.linestrings(np.stack([a, b], axis=1))
    tree = shapely.STRtree(segs)
    count, chunk = 0, 256
    for s in range(0, len(segs), chunk):
        i, j = tree.query(segs[s : s + chunk], predicate="intersects")
        i = i + s
        keep = i < j
        i, j = i[keep], j[keep]
        adjacent = (ring_id[i] == ring_id[j]) & (
            (j - i == 1) | ((i == first[i]) & (j == last[i]))
        )
        count += int(np.count_nonzero(~adjacent))
        if count > limit:
            break
    return count


def rings_to_region(
    rings: list[np.ndarray], fill_rule: str = "nonzero", path=None
) -> shapely.Geometry:
    """The area an SVG renderer fills for the closed subpaths ``rings`` under ``fill_rule``.

    ``rings``: list of (K_i, 2) arrays, each implicitly closed (no repeated closing
    point); rings with fewer than 3 points are ignored. Exact for nested, overlapping
    and self-intersecting rings: the linework is noded and every face of the
    arrangement is classified by the winding number of an interior point
    (``"nonzero"``: w != 0, ``"evenodd"``: w odd). Returns a valid Polygon or
    MultiPolygon (empty if nothing is filled). Outlines whose arrangement has more
    than :data:`MAX_REGION_FACES` faces raise InputError naming ``path`` (or
    :class:`RegionTooComplex` when ``path`` is None).
    """
    rings = [np.asarray(r, dtype=float) for r in rings if len(r) >= 3]
    if not rings:
        return shapely.Polygon()
    if len(rings) == 1:
        poly = shapely.Polygon(rings[0])
        if poly.is_valid:
            return poly if poly.area > 0 else shapely.Polygon()
    n_edges = sum(len(r) for r in rings)
    if n_edges > 500:  # below, even a scribble nodes in well under a second
        crossings = _count_crossings(rings, MAX_REGION_FACES)
        if crossings > MAX_REGION_FACES:
            msg = f"an outline intersects itself too often (more than {MAX_REGION_FACES} crossings); simplify it"
            if path is not None:
                raise InputError(path, msg)
            raise RegionTooComplex(msg)
    lines = [shapely.LineString(np.vstack([r, r[:1]])) for r in rings]
    noded = shapely.union_all(lines)
    faces = [
        f
        for f in shapely.get_parts(shapely.polygonize(shapely.get_parts(noded)))
        if f.area > 0
    ]
    if len(faces) > MAX_REGION_FACES or len(faces) * n_edges > MAX_REGION_WORK:
        msg = (
            f"an outline intersects itself too often ({len(faces)} faces); simplify it"
        )
        if path is not None:
            raise InputError(path, msg)
        raise RegionTooComplex(msg)
    if not faces:
        return shapely.Polygon()
    faces_arr = np.empty(len(faces), dtype=object)
    faces_arr[:] = faces
    reps = shapely.get_coordinates(shapely.point_on_surface(faces_arr))
    w = _winding_numbers(reps, rings)
    keep = (w != 0) if fill_rule != "evenodd" else (np.abs(w) % 2 == 1)
    if not keep.any():
        return shapely.Polygon()
    region = shapely.union_all(faces_arr[keep])
    if not region.is_valid:
        region = shapely.make_valid(region)
    return polygon_parts(region)


def clean_points(pts: np.ndarray, closed: bool, eps: float) -> np.ndarray:
    """Remove consecutive duplicate points (and, if ``closed``, a repeated closing point)."""
    if len(pts) > 1:
        d = np.abs(np.diff(pts, axis=0)).max(axis=1)
        keep = np.concatenate([[True], d > eps])
        pts = pts[keep]
    if closed and len(pts) > 1 and np.abs(pts[-1] - pts[0]).max() <= eps:
        pts = pts[:-1]
    return pts


def finalize_region(path, region, what: str = "container") -> shapely.Geometry:
    """Validate a container region: polygonal, valid (make_valid + warning), area > 0."""
    region = polygon_parts(region)
    if not region.is_valid:
        warn(
            path,
            f"the {what} outline is not a valid polygon (self-intersections?); repaired with make_valid",
        )
        region = polygon_parts(shapely.make_valid(region))
    if region.is_empty or not region.area > 0:
        raise InputError(
            path,
            f"the {what} has zero area; it needs at least one closed shape enclosing an area",
        )
    if not np.all(np.isfinite(region.bounds)):
        raise InputError(
            path, f"the {what} has non-finite coordinates (NaN or infinity)"
        )
    return region


def check_coordinates(path, values, what: str = "") -> None:
    """InputError naming ``path`` if ``values`` hold NaN/inf or |v| > :data:`MAX_COORD`."""
    a = np.asarray(values, dtype=float)
    if a.size == 0:
        return
    if not np.all(np.isfinite(a)):
        raise InputError(
            path,
            f"has non-finite coordinates (NaN or infinity){what}; check the path data and transforms",
        )
    big = float(np.abs(a).max())
    if big > MAX_COORD:
        raise InputError(
            path,
            f"has coordinates up to {big:.3g}{what}, beyond ±{MAX_COORD:.0e} user units; "
            "scale the drawing down (sizes are relative, any scale packs the same)",
        )


def count_self_crossing(rings) -> int:
    """Number of closed rings (K_i, 2) that cross or touch themselves."""
    n = 0
    for r in rings:
        if len(r) >= 4 and not shapely.LinearRing(r).is_simple:
            n += 1
    return n


def warn_self_crossing(path, n: int, region, what: str = "container") -> None:
    if n:
        parts = len(shapely.get_parts(region)) if not region.is_empty else 0
        warn(
            path,
            f"{n} {what} outline(s) cross themselves (bow-tie); used the area the fill "
            f"rule fills ({parts} region(s)); redraw the outline without crossings if that is not intended",
        )


# --------------------------------------------------------------------------- XML hardening




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


def _href(el: ET.Element) -> str | None:
    return el.get(f"{{{XLINK_NS}}}href") or el.get("href")


def _check_tree(path, root: ET.Element) -> None:
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
            ref = _href(el)
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


def _check_attributes(path, root: ET.Element) -> None:
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


_NON_RENDERED = {"symbol", "mask", "marker"}
_CONTAINERS_OK = {"defs", "clipPath", "pattern"}
#: elements whose children are drawn where they stand (browsers draw no shape inside any
#: other element: not in <metadata>, a gradient, an unknown or another namespace's element,
#: nor Inkscape's flowed text, <flowRoot>, which no browser draws)
_GROUPING = {"svg", "g", "a", "switch"}
_GRAPHICS = {"use", "path", "rect", "circle", "ellipse", "line", "polyline", "polygon", "text", "image"}
#: elements drawn where they stand, or read from the tree elsewhere (text, style sheets)
_DRAWN = _GROUPING | _GRAPHICS | {"style", "foreignObject"} | _NON_RENDERED | _CONTAINERS_OK


def _apply_stylesheets(root: ET.Element, notes: set[str]) -> None:
    """Resolve the CSS cascade of the file's ``<style>`` sheets into each element's
    ``style`` attribute, and drop the sheets.

    Selectors are matched by cssselect2 (type, class, id, attribute, compound,
    descendant, child, sibling and structural selectors, as browsers match them);
    declarations are ordered as CSS orders them: ``!important`` ones first, then the
    element's own ``style``, then the sheets' by specificity and order, all above the
    presentation attributes (``fill="red"``). svgelements, which reads the result, only
    knows single class, id and type selectors and took ``!important`` as part of the value
    (a fill ``#abc !important`` came out black). At-rules (``@media``, ``@import``,
    ``@font-face``) are ignored."""
    sheets = [el for el in root.iter() if _local(el.tag) == "style"]
    inline_marked = [el for el in root.iter() if "!" in (el.get("style") or "")]
    custom = any("var(" in (el.get("style") or "") for el in root.iter()) or any(
        "var(" in "".join(sh.itertext()) for sh in sheets)
    if not sheets and not inline_marked and not custom:
        return
    matcher = None
    if sheets:
        import cssselect2  # noqa: PLC0415  (only files with style sheets need it)
        import tinycss2

        matcher = cssselect2.Matcher()
        for sheet in sheets:
            kind = (sheet.get("type") or "text/css").strip().lower()
            if kind not in ("text/css", ""):
                continue
            for rule in tinycss2.parse_stylesheet("".join(sheet.itertext()), skip_comments=True,
                                                  skip_whitespace=True):
                if rule.type != "qualified-rule":
                    continue
                decls = [(d.lower_name, tinycss2.serialize(d.value).strip(), bool(d.important))
                         for d in tinycss2.parse_declaration_list(rule.content, skip_comments=True,
                                                                  skip_whitespace=True)
                         if d.type == "declaration"]
                try:
                    selectors = cssselect2.compile_selector_list(rule.prelude)
                except cssselect2.SelectorError:
                    notes.add("CSS rule with a selector not understood")
                    continue
                for sel in selectors:
                    if sel.pseudo_element is None:
                        matcher.add_selector(sel, decls)
        parent = {c: p for p in root.iter() for c in p}
        for sheet in sheets:
            if sheet in parent:
                parent[sheet].remove(sheet)
    todo = {id(el): el for el in inline_marked}
    matched: dict[int, list] = {}
    if matcher is not None:
        for w in cssselect2.ElementWrapper.from_xml_root(root).iter_subtree():
            found = matcher.match(w)
            if found:
                matched[id(w.etree_element)] = found
                todo[id(w.etree_element)] = w.etree_element
    for key, el in todo.items():
        normal: dict[str, str] = {}
        important: dict[str, str] = {}
        for _spec, _order, _pseudo, decls in matched.get(key, ()):  # lowest to highest
            for name, value, imp in decls:
                (important if imp else normal)[name] = value
        own = _inline_declarations(el.get("style"))
        final = dict(normal)
        final.update({n: v for n, v, imp in own if not imp})
        final.update(important)
        final.update({n: v for n, v, imp in own if imp})
        if final:
            el.set("style", ";".join(f"{n}:{v}" for n, v in final.items()))
    if custom:
        _substitute_variables(root, notes)


_VAR = re.compile(r"var\(\s*(--[\w-]+)\s*(?:,((?:[^()]|\([^()]*\))*))?\)")


def _substitute_variables(root: ET.Element, notes: set[str]) -> None:
    """CSS custom properties: each element's ``style`` (the cascade resolved) with every
    ``var(--name, fallback)`` replaced by the value the element inherits or sets for
    ``--name`` (else the fallback). A declaration whose variable is defined nowhere is
    dropped with a note (svgelements took the text for a colour: black)."""

    def substitute(value: str, env: dict) -> str | None:
        for _ in range(32):  # nested var() and variables defined by others; a cycle gives up
            m = _VAR.search(value)
            if m is None:
                return value
            rep = env.get(m[1].lower())
            if rep is None:
                if m[2] is None:
                    return None
                rep = m[2].strip()
            value = value[:m.start()] + rep + value[m.end():]
        return None

    stack = [(root, {})]
    while stack:
        el, env = stack.pop()
        decls = _inline_declarations(el.get("style"))
        if any(n.startswith("--") for n, _, _ in decls):
            env = dict(env)
            for n, v, _ in decls:
                if n.startswith("--"):
                    r = substitute(v, env)
                    if r is None:
                        env.pop(n, None)
                    else:
                        env[n] = r
        if any(n.startswith("--") or "var(" in v for n, v, _ in decls):
            kept = []
            for n, v, imp in decls:
                if n.startswith("--"):
                    continue
                if "var(" in v:
                    r = substitute(v, env)
                    if r is None:
                        notes.add(f"CSS {n}: {v} with an undefined variable (ignored)")
                        continue
                    v = r
                kept.append(f"{n}:{v}" + (" !important" if imp else ""))
            el.set("style", ";".join(kept))
        stack.extend((c, env) for c in el if isinstance(c.tag, str))


def _styled(el: ET.Element, prop: str) -> bool:
    """Whether ``el``'s inline style sets the property ``prop`` (CSS outranks attributes)."""
    return any(name == prop for name, _, _ in _inline_declarations(el.get("style")))


def _auto(value: str | None) -> bool:
    return value is None or value.strip().lower() in ("", "auto")


def _negative_length(value) -> bool:
    m = re.match(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)", str(value)) if value is not None else None
    return bool(m) and float(m.group(1)) < 0


_GEOMETRY_ATTRS = ("x", "y", "width", "height", "cx", "cy", "r", "rx", "ry", "x1", "y1", "x2", "y2")


def _shape_sizes(root: ET.Element) -> None:
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


def _circle_percentages(el: ET.Element, size: tuple[float, float]) -> None:
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
                    _length(child.get("width", "100%"), size[0]), _length(child.get("height", "100%"), size[1]))
            except ValueError:
                inner = size
            _circle_percentages(child, inner if all(math.isfinite(v) and v > 0 for v in inner) else size)
            continue
        r = child.get("r")
        if name == "circle" and r is not None and r.strip().endswith("%"):
            try:
                share = float(r.strip()[:-1]) / 100.0
            except ValueError:
                share = float("nan")
            if math.isfinite(share):
                child.set("r", repr(share * math.sqrt((size[0] ** 2 + size[1] ** 2) / 2.0)))
        _circle_percentages(child, size)


def _sanitize(path, root: ET.Element, notes: set[str]) -> None:
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
        elif name == "use" and (_href(el) or "#").strip()[:1] != "#":
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
    _nested_svgs_to_groups(root)
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


def _length(value, relative: float) -> float:
    import svgelements as se

    v = se.Length(value).value(relative_length=relative, ppi=96.0)
    return float(v) if isinstance(v, (int, float)) else float("nan")


def _reference_size(root: ET.Element) -> tuple[float, float]:
    """Width and height that percentages of the outermost viewport refer to."""
    rvb = (root.get("viewBox") or "").replace(",", " ").split()
    try:
        return (
            (float(rvb[2]), float(rvb[3]))
            if len(rvb) == 4
            else (
                _length(root.get("width", "100"), 100),
                _length(root.get("height", "100"), 100),
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


def _document_ids(root: ET.Element) -> set:
    """The ids the document uses (for :func:`_wrap_in_viewport`, which adds its own)."""
    return {e.get("id") for e in root.iter() if isinstance(e.tag, str) and e.get("id")}


def _wrap_in_viewport(root: ET.Element, parent: ET.Element, el: ET.Element, transform: str | None,
                      box: tuple[float, float, float, float] | None, ids: set | None = None) -> ET.Element:
    """Put ``el`` inside a new ``<g>`` (in its place) that carries ``transform`` and, when
    ``box`` is given, a clip path to that rectangle (x, y, width, height, in the new
    group's user space): the viewport of a nested ``<svg>`` or a ``<symbol>``'s ``<use>``.
    ``ids``: the document's ids (:func:`_document_ids`), which the clip path's joins."""
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


def _nested_svgs_to_groups(root: ET.Element) -> None:
    """Turn nested ``<svg>`` elements into ``<g transform=...>``.

    svgelements leaks a nested svg's ``x``/``y`` attributes into its children (a rect
    without ``x`` would be moved twice), so the viewport is resolved here instead.
    """
    import svgelements as se

    parent = {c: p for p in root.iter() for c in p}
    nested = [e for e in root.iter() if e is not root and _local(e.tag) == "svg"]
    ids = _document_ids(root) if nested else set()
    inner_size = {root: _reference_size(root)}  # the user space size each viewport makes

    def outer_size(el):
        p = parent.get(el)
        while p is not None and p not in inner_size:
            p = parent.get(p)
        return inner_size[p if p is not None else root]

    for el in nested:  # (outermost first: root.iter() is in document order)
        ref_w, ref_h = outer_size(el)
        x = _length(el.get("x", "0"), ref_w)
        y = _length(el.get("y", "0"), ref_h)
        w = _length(el.get("width", "100%"), ref_w)
        h = _length(el.get("height", "100%"), ref_h)
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
            _wrap_in_viewport(root, parent[el], el, own_tf, (x, y, w, h), ids)
            el.set("transform", tf)
        else:
            el.set("transform", f"{own_tf} {tf}" if own_tf else tf)
        el.tag = f"{{{SVG_NS}}}g" if el.tag.startswith("{") else "g"


class _Servers(dict):
    """id -> the colour a paint server's outline is drawn with (``dict``), and in
    ``approx`` id -> what the packing approximates of that server's paint."""

    approx: dict


def _gradient_colours(root: ET.Element) -> dict[str, str]:
    """id -> colour of the first stop of each gradient (following href templates).

    Patterns and gradients with translucent stops are listed in the result's ``approx``:
    they are written back as they are, but the packing sees the painted shape as solid."""
    grads = {
        el.get("id"): el
        for el in root.iter()
        if _local(el.tag) in ("linearGradient", "radialGradient") and el.get("id")
    }
    out = _Servers()
    out.approx = {}
    for gid, start in grads.items():
        el, seen = start, set()
        while el is not None and id(el) not in seen:
            seen.add(id(el))
            stops = [s for s in el if _local(s.tag) == "stop"]
            if stops:
                if any(_translucent_stop(st) for st in stops):
                    out.approx[gid] = "gradient with translucent stops (kept; packed as a solid shape)"
                s = stops[0]
                colour = s.get("stop-color")
                m = re.search(r"stop-color\s*:\s*([^;]+)", s.get("style") or "")
                if m:
                    colour = m.group(1).strip()
                out[gid] = colour or "black"
                break
            ref = _href(el)
            el = grads.get(ref[1:]) if ref and ref.startswith("#") else None
    for el in root.iter():  # patterns: the first plain fill of their content, else grey
        if _local(el.tag) == "pattern" and el.get("id") and el.get("id") not in out:
            colour = "#808080"
            for c in el.iter():
                f = c.get("fill")
                if c is not el and f and not f.strip().startswith("url(") and f.strip() != "none":
                    colour = f.strip()
                    break
            out[el.get("id")] = colour
            out.approx[el.get("id")] = "pattern paint (kept; packed as a solid shape)"
    return out


def _translucent_stop(stop: ET.Element) -> bool:
    """Whether a gradient ``<stop>`` paints with an alpha below 1."""
    decls = {k: v for k, v, _ in _inline_declarations(stop.get("style"))}
    op = decls.get("stop-opacity", stop.get("stop-opacity"))
    colour = str(decls.get("stop-color", stop.get("stop-color")) or "").strip().lower()
    if op is not None and _float_attr(op.strip().rstrip("%"), 1.0) * (0.01 if op.strip().endswith("%") else 1) < 1:
        return True
    return colour == "transparent" or colour.startswith(("rgba", "hsla")) or "/" in colour


# --------------------------------------------------------------------------- svgelements layer


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


def _float_attr(value, default: float) -> float:
    if value is None:
        return default
    s = str(value).strip()
    try:
        v = float(s[:-1]) / 100.0 if s.endswith("%") else float(s)
    except ValueError:
        return default
    return v if math.isfinite(v) else default


def _clamp01(v: float) -> float:
    return min(1.0, max(0.0, v))


def _is_hole(attrs: dict) -> bool:
    cls = str(attrs.get("class") or "").lower()
    if re.search(r"(^|[\s_-])holes?($|[\s_-])", cls):
        return True
    if str(attrs.get("id") or "").lower().startswith("hole"):
        return True
    return str(attrs.get("data-path-type") or "").strip() == "7"


def _paint(raw, gradients: dict[str, str], notes: set[str]) -> tuple[str | None, float]:
    """SVG paint string -> ('#rrggbb' | None, alpha)."""
    from svgelements import Color

    if raw is None:
        return None, 1.0
    s = str(raw).strip()
    if not s or s.lower() == "none":
        return None, 1.0
    if s.lower().startswith("url("):
        m = re.match(r"url\(\s*['\"]?\s*#([^)'\"\s]+)\s*['\"]?\s*\)\s*(.*)$", s, re.IGNORECASE)
        fallback = m.group(2).strip() if m else ""
        if m and m.group(1) in gradients:  # kept in the output; the outline uses a colour
            s = gradients[m.group(1)]
            approx = getattr(gradients, "approx", {}).get(m.group(1))
            if approx:
                notes.add(approx)
        elif fallback:
            s = fallback
        else:
            notes.add("pattern or unresolved paint server (not painted)")
            return None, 1.0
        if s.lower() == "none":
            return None, 1.0
    if s.lower() == "transparent":  # paints nothing, like none
        return None, 1.0
    c = Color(_comma_colour(s))
    if c.value is None:
        return None, 1.0
    return c.hexrgb.lower(), c.alpha / 255.0


_SPACE_COLOUR = re.compile(
    r"(rgb|hsl)a?\(\s*([^\s,()/]+)\s+([^\s,()/]+)\s+([^\s,()/]+)\s*(?:/\s*([^\s,()/]+)\s*)?\)",
    re.IGNORECASE)


def _comma_colour(s: str) -> str:
    """CSS Color 4's ``rgb(255 0 0 / 50%)`` (and ``hsl``) in the comma form svgelements
    reads (``rgba(255,0,0,0.5)``); any other string unchanged."""
    m = _SPACE_COLOUR.fullmatch(s.strip())
    if m is None:
        return s
    fn, a, b, c, alpha = m.groups()
    a = a[:-3] if fn.lower() == "hsl" and a.lower().endswith("deg") else a
    if alpha is None:
        return f"{fn.lower()}({a},{b},{c})"
    if alpha.endswith("%"):
        try:
            alpha = repr(float(alpha[:-1]) / 100.0)
        except ValueError:
            return s
    return f"{fn.lower()}a({a},{b},{c},{alpha})"


def _stroke_width(shape) -> float:
    """A shape's ``stroke-width`` in its own coordinates (1 when unset or unreadable, 0
    when negative or not finite)."""
    sw = shape.stroke_width if shape.stroke_width is not None else 1.0
    try:
        sw = float(sw)
    except (TypeError, ValueError):
        return 1.0
    return sw if math.isfinite(sw) and sw >= 0 else 0.0


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


def _context_paint(raw, context: tuple) -> str | None:
    """``raw`` with ``context-fill``/``context-stroke`` replaced by the context element's
    paint (``context``: its resolved fill and stroke strings; ``none`` without one, as
    browsers paint it)."""
    key = str(raw).strip().lower() if raw is not None else ""
    if key == "context-fill":
        return context[0] or "none"
    if key == "context-stroke":
        return context[1] or "none"
    return raw


def _style_of(
    shape, opacity: float, det_scale: float, vp_scale: float, gradients, notes, context: tuple = (None, None)
) -> Style:
    """The :class:`Style` of an svgelements shape; ``context``: the fill and stroke (paint
    strings) ``context-fill`` and ``context-stroke`` stand for (of the ``<use>`` the shape
    is drawn by)."""
    values = shape.values
    fill, fill_alpha = _paint(_context_paint(values.get("fill", "black"), context), gradients, notes)
    stroke, stroke_alpha = _paint(_context_paint(values.get("stroke", "none"), context), gradients, notes)
    sw = _stroke_width(shape)
    if "non-scaling-stroke" in str(values.get("vector-effect", "")):  # lengths in the viewport's units
        to_user = (lambda v: v / vp_scale) if vp_scale > 0 else (lambda v: v)
    else:
        to_user = lambda v: v * det_scale  # noqa: E731
    sw = to_user(sw)
    dashes = tuple(to_user(d) for d in _dasharray(values.get("stroke-dasharray")))
    offset = to_user(_float_attr(values.get("stroke-dashoffset"), 0.0)) if dashes else 0.0
    limit = _float_attr(values.get("stroke-miterlimit"), 4.0)
    cap = str(values.get("stroke-linecap", "butt")).strip().lower()
    join = str(values.get("stroke-linejoin", "miter")).strip().lower()
    rule = str(values.get("fill-rule", "nonzero")).strip().lower()
    vis = str(values.get("visibility", "visible")).strip().lower()
    if vis in ("hidden", "collapse"):
        opacity = 0.0
    return Style(
        fill=fill,
        stroke=stroke,
        stroke_width=sw,
        opacity=_clamp01(opacity),
        fill_opacity=_clamp01(
            _float_attr(values.get("fill-opacity"), 1.0) * fill_alpha
        ),
        stroke_opacity=_clamp01(
            _float_attr(values.get("stroke-opacity"), 1.0) * stroke_alpha
        ),
        fill_rule="evenodd" if rule == "evenodd" else "nonzero",
        stroke_linecap=cap if cap in ("butt", "round", "square") else "butt",
        stroke_linejoin=join if join in ("miter", "round", "bevel") else "miter",
        stroke_miterlimit=limit if math.isfinite(limit) and limit >= 1.0 else 4.0,
        stroke_dasharray=dashes,
        stroke_dashoffset=offset if math.isfinite(offset) else 0.0,
        paint_order=_paint_order(values.get("paint-order")),
    )


def _paint_order(raw) -> str:
    """``paint-order`` normalised: "normal", or the order of fill, stroke and markers as
    given (the missing ones follow in their normal order), e.g. "stroke fill markers"."""
    words = [w for w in str(raw or "").strip().lower().split() if w in ("fill", "stroke", "markers")]
    if not words:
        return "normal"
    seen = list(dict.fromkeys(words))
    order = seen + [w for w in ("fill", "stroke", "markers") if w not in seen]
    return "normal" if order == ["fill", "stroke", "markers"] else " ".join(order)


def _dasharray(raw) -> tuple[float, ...]:
    """``stroke-dasharray`` as lengths (an odd list repeated, as SVG does); () for
    ``none``, percentages, and invalid lists (negative or non-finite values, all zero),
    which SVG draws solid."""
    if raw is None:
        return ()
    text = str(raw).strip().lower()
    if text in ("", "none", "inherit") or "%" in text:
        return ()
    try:
        vals = [float(re.sub(r"(px)$", "", v)) for v in re.split(r"[\s,]+", text) if v]
    except ValueError:
        return ()
    if not vals or any(not math.isfinite(v) or v < 0 for v in vals) or sum(vals) <= 0:
        return ()
    return tuple(vals * 2 if len(vals) % 2 else vals)


#: attributes of the root <svg> that map its user units to the page (kept for the output)
ROOT_VIEW_ATTRS = ("width", "height", "viewBox", "preserveAspectRatio", "transform")

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
    if drop_use_cycles(root_xml, _href):
        notes.add("<use> drawing itself (that use skipped, as in browsers)")
    _check_tree(path, root_xml)
    _check_attributes(path, root_xml)
    _apply_stylesheets(root_xml, notes)
    integer_rgb_colours(root_xml)
    expand_viewport_uses(root_xml)  # (before lengths: percentages refer to the new viewports)
    reference = _reference_size(root_xml)
    _circle_percentages(root_xml, reference)  # (before nested viewports become groups)
    drop_marker_attribute(root_xml)
    resolve_overflow_inherit(root_xml)
    for el in root_xml.iter():
        if isinstance(el.tag, str) and _local(el.tag) == "marker":
            resolve_marker_lengths(el, reference)
    resolve_lengths(root_xml, reference)
    resolve_transform_origin(root_xml, reference)
    images = images_to_rects(root_xml, Path(str(path)).parent, _length, reference,
                             lambda b: parse_xml_hardened(path, b))
    if images["raster"]:
        notes.add("raster <image> (packed as the rectangle of its visible pixels, in their mean colour)")
    if images["unread"]:
        notes.add("<image> that could not be read (not drawn)")
    _sanitize(path, root_xml, notes)
    _shape_sizes(root_xml)
    fonts_missing = text_to_paths(root_xml, notes)
    if fonts_missing:
        warn(path, fonts_missing)
    hoist_clip_paths(root_xml)
    gradients = _gradient_colours(root_xml)
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
                op = opacity * _clamp01(_float_attr(attrs.get("opacity"), 1.0))
                style = _style_of(child, op, det_scale, vp_scale, gradients, notes, context)
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
                        paints = tuple(str(_context_paint(child.values.get(k, d), context) or "none")
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
                group_op = _clamp01(_float_attr(attrs.get("opacity"), 1.0))
                op = opacity * group_op
                own_clips = clip_refs(
                    child.values.get("clip-path"),
                    _matrix_to_np(child.transform * inv_viewport),
                    notes,
                )
                inner = layers + ((next(layer_keys), group_op),) if group_op < 1.0 else layers
                inner_context = context
                if isinstance(child, se.Use):  # the context element of context-fill/-stroke
                    inner_context = tuple(_context_paint(child.values.get(k, d), context)
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
        mats = [mat @ t for t in placements(segs, el, kind, _stroke_width(child))]
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
                cst = _style_of(c, op * _clamp01(_float_attr(own(c).get("opacity"), 1.0)), _det_scale(cm),
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
    root_op = _clamp01(_float_attr(root_own.get("opacity"), 1.0))
    walk(doc, root_op, False, (), root_clips, ((0, root_op),) if root_op < 1.0 else ())
    defs = clip_defs(doc, inv_viewport, notes) if any(s.clips for s in shapes) else {}
    defs.update(marker_clips)
    if notes:
        warn(path, "skipped unsupported content: " + ", ".join(sorted(notes)))
    sv = np.linalg.svd(_matrix_to_np(viewport)[:2, :2], compute_uv=False)
    stretch = (float(sv[0]), float(sv[1])) if sv[0] > sv[1] * (1 + 1e-9) else None
    return SvgDocument(shapes, svg_root, root_attrs, metadata_text, defs, xml=root_xml, stretch=stretch)


# --------------------------------------------------------------------------- flattening


class TooManyPoints(InputError):
    """A file flattens to more than its point budget (:class:`PointBudget`)."""


class PointBudget:
    """Counts flattened vertices of one file; :class:`TooManyPoints` past ``limit``."""

    def __init__(self, path, limit: int | None = None):
        self.path, self.used = path, 0
        self.limit = MAX_POINTS if limit is None else limit

    def take(self, n: float) -> int:
        if not math.isfinite(n):
            raise InputError(self.path, "has non-finite coordinates (NaN or infinity)")
        self.used += n
        if self.used > self.limit:
            raise TooManyPoints(
                self.path,
                f"produces more than {self.limit} points after flattening curves; simplify the file or use a larger tolerance",
            )
        return int(n)


def _pt(p) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))


def _control_points(seg) -> list:
    import svgelements as se

    if isinstance(seg, se.Arc):
        c, u, v = (
            np.array(_pt(seg.center)),
            np.array(_pt(seg.prx)) - np.array(_pt(seg.center)),
            np.array(_pt(seg.pry)) - np.array(_pt(seg.center)),
        )
        return [
            _pt(seg.start),
            _pt(seg.end),
            *(c + su * u + sv * v for su in (-1, 1) for sv in (-1, 1)),
        ]
    pts = []
    for name in ("start", "control", "control1", "control2", "end"):
        p = getattr(seg, name, None)
        if p is not None:
            pts.append(_pt(p))
    return pts


def shape_bounds(shapes: list[SvgShape]) -> np.ndarray | None:
    """Cheap bounding box (x0, y0, x1, y1) of shapes from their control points (user units)."""
    boxes = []
    for sh in shapes:
        pts = [p for seg in sh.segments for p in _control_points(seg)]
        if not pts:
            continue
        with np.errstate(all="ignore"):
            a = np.asarray(pts, dtype=float) @ sh.matrix[:2, :2].T + sh.matrix[:2, 2]
        boxes.append(np.concatenate([a.min(axis=0), a.max(axis=0)]))
    if not boxes:
        return None
    b = np.array(boxes)
    return np.concatenate([b[:, :2].min(axis=0), b[:, 2:].max(axis=0)])


def default_tolerance(bounds) -> float:
    """1e-3 x the bounding-box diagonal (a tiny positive number for a degenerate box)."""
    if bounds is None:
        return 1e-9
    diag = float(np.hypot(bounds[2] - bounds[0], bounds[3] - bounds[1]))
    return 1e-3 * diag if diag > 0 and math.isfinite(diag) else 1e-9


def flattening_tolerance(shapes: list[SvgShape], tolerance: float | None) -> float:
    """The chord tolerance for ``shapes``: the automatic one (1e-3 x bounding-box
    diagonal) when ``tolerance`` is None, else ``tolerance`` capped at
    :data:`MAX_TOLERANCE_FACTOR` x the automatic one (a finer flattening than asked for
    is always acceptable; a coarser one would collapse curves)."""
    auto = default_tolerance(shape_bounds(shapes))
    if tolerance is None:
        return auto
    return min(tolerance, MAX_TOLERANCE_FACTOR * auto) if auto > 1e-9 else tolerance


def flatten_shape(
    path, sh: SvgShape, tol: float, budget: PointBudget
) -> list[tuple[np.ndarray, bool]]:
    """Flatten one shape into (K, 2) polylines in user units with chord error <= ``tol``.

    Béziers are sampled uniformly in t with n = ceil(sqrt(max|B''| / (8 tol))) pieces
    (the interpolation error bound h^2/8 max|B''|), elliptical arcs with
    n = ceil(|sweep| sqrt(K / (8 tol))) with K bounding |B''| of the (transformed) arc.
    Returns [(points, closed)] with consecutive duplicates and repeated closing points
    removed; subpaths with fewer than 2 distinct points are dropped.
    """
    import svgelements as se

    L = sh.matrix[:2, :2]
    t = sh.matrix[:2, 2]
    out: list[tuple[np.ndarray, bool]] = []
    cur: list[np.ndarray] | None = None
    eps = tol * 1e-6

    def flush(closed: bool):
        nonlocal cur
        if cur is None:
            return
        local = np.concatenate(cur, axis=0)
        cur = None
        with np.errstate(all="ignore"):
            pts = local @ L.T + t
        check_coordinates(path, pts)
        pts = clean_points(pts, closed, eps)
        if len(pts) >= 2:
            out.append((pts, closed))

    for seg in sh.segments:
        if isinstance(seg, se.Move):
            flush(False)
            if seg.end is None:
                continue
            cur = [np.array([_pt(seg.end)])]
            budget.take(1)
            continue
        if isinstance(seg, se.Close):
            flush(True)
            continue
        if seg.start is None or seg.end is None:
            continue
        if cur is None:
            cur = [np.array([_pt(seg.start)])]
            budget.take(1)
        if isinstance(seg, se.Linear):
            cur.append(np.array([_pt(seg.end)]))
            budget.take(1)
        elif isinstance(seg, (se.QuadraticBezier, se.CubicBezier)):
            if isinstance(seg, se.QuadraticBezier):
                P = np.array([_pt(seg.start), _pt(seg.control), _pt(seg.end)])
                d = (P[0] - 2 * P[1] + P[2]) @ L.T
                bound = 2.0 * float(np.hypot(*d))
            else:
                P = np.array(
                    [_pt(seg.start), _pt(seg.control1), _pt(seg.control2), _pt(seg.end)]
                )
                d1 = (P[0] - 2 * P[1] + P[2]) @ L.T
                d2 = (P[1] - 2 * P[2] + P[3]) @ L.T
                bound = 6.0 * max(float(np.hypot(*d1)), float(np.hypot(*d2)))
            if not np.all(np.isfinite(P)) or not math.isfinite(bound):
                raise InputError(
                    path,
                    "has non-finite coordinates (NaN or infinity); check the path data",
                )
            n = max(1, math.ceil(math.sqrt(bound / (8.0 * tol)))) if bound > 0 else 1
            n = budget.take(n)
            s = np.linspace(0.0, 1.0, n + 1)[1:, None]
            r = 1.0 - s
            if len(P) == 3:
                pts = r * r * P[0] + 2 * r * s * P[1] + s * s * P[2]
            else:
                pts = (
                    r**3 * P[0]
                    + 3 * r * r * s * P[1]
                    + 3 * r * s * s * P[2]
                    + s**3 * P[3]
                )
            pts[-1] = P[-1]
            cur.append(pts)
        elif isinstance(seg, se.Arc):
            end = np.array([_pt(seg.end)])
            if (
                seg.center is None
                or seg.prx is None
                or seg.pry is None
                or not seg.sweep
            ):
                cur.append(end)
                budget.take(1)
                continue
            c = np.array(_pt(seg.center))
            u = (np.array(_pt(seg.prx)) - c) @ L.T
            v = (np.array(_pt(seg.pry)) - c) @ L.T
            K = math.sqrt(float(u @ u + v @ v))
            sweep = abs(float(seg.sweep))
            if not (math.isfinite(K) and math.isfinite(sweep)):
                raise InputError(
                    path,
                    "has non-finite coordinates (NaN or infinity); check the path data",
                )
            if K == 0 or seg.rx == 0 or seg.ry == 0:
                cur.append(end)
                budget.take(1)
                continue
            n = max(1, math.ceil(sweep * math.sqrt(K / (8.0 * tol))))
            n = budget.take(n)
            pts = np.asarray(
                seg.npoint(np.linspace(0.0, 1.0, n + 1)[1:]), dtype=float
            ).reshape(-1, 2)
            pts[-1] = end[0]
            cur.append(pts)
        else:  # unknown segment type: keep its end point
            cur.append(np.array([_pt(seg.end)]))
            budget.take(1)
    flush(False)
    return out


# --------------------------------------------------------------------------- public API


def shape_source(path, sh: SvgShape):
    """Curve-level data of a shape (see :mod:`.svg_source`); None if it cannot be built."""
    from .svg_source import shape_source as _shape_source

    return _shape_source(path, sh)


def paint_servers(path, xml, arts) -> dict:
    """Self-contained markup of the gradients and patterns ``arts`` are painted with."""
    from .svg_source import paint_servers as _paint_servers

    return _paint_servers(path, xml, arts)


def shape_clipper(path, doc: SvgDocument, tol: float, budget: PointBudget):
    """``clip(shape) -> region | None``: the clip region of a shape of ``doc`` in file
    user units (the intersection of its own and its groups' ``clip-path``), or None when
    nothing clips it. See :mod:`.svg_clip`."""
    if not any(s.clips for s in doc.shapes):
        return lambda sh: None

    def flatten(segments, matrix):
        return flatten_shape(path, SvgShape(segments, matrix, Style(), False, {}), tol, budget)

    resolver = ClipResolver(
        path,
        doc.clip_defs,
        doc.shapes,
        flatten,
        lambda rings, rule: rings_to_region(rings, rule, path),
        lambda message: warn(path, message),
    )
    return lambda sh: resolver.region(sh.clips) if sh.clips else None


def _svg_element(path: Path, data: bytes, tolerance: float | None) -> Element:
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
            f"has no visible geometry ({why}); an element needs at least one visible path",
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
            from ..render.curves import flatten_subpath

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


#: an open subpath of a container whose last point misses its first by at most this share
#: of its size counts as closed: icon sets draw outlines without ``z`` whose ends differ by
#: a rounding (Tabler's heart: 0.006 in 24 units), which a fine gap's tolerance refused
CLOSE_SHARE = 1e-3


def container_from_shapes(
    path,
    shapes: list[SvgShape],
    tol: float,
    budget: PointBudget,
    svg_root: dict,
    clip=None,
    xml=None,
) -> Container:
    """Build a Container from SVG shapes (closed subpaths only; holes subtracted).

    ``clip``: optional ``clip(shape) -> region | None`` (:func:`shape_clipper`); a
    clipped shape counts, and is drawn, as its part inside the region.
    """
    outer, holes, arts = [], [], []
    unpainted: list = []
    n_open = n_crossing = n_clipped_away = 0
    for sh in shapes:
        rings = []
        for pts, closed in flatten_shape(path, sh, tol, budget):
            if not closed:
                ends = float(np.hypot(*(pts[-1] - pts[0])))
                if len(pts) < 3 or ends > max(tol, CLOSE_SHARE * float(np.hypot(*np.ptp(pts, axis=0)))):
                    n_open += 1
                    continue
                if ends <= tol:
                    pts = pts[:-1]
            if len(pts) >= 3:
                rings.append(pts)
        if not rings:
            continue
        geom = rings_to_region(rings, sh.style.fill_rule, path)
        n_crossing += count_self_crossing(rings)
        drawn = [ArtPath(tuple(rings), tuple(True for _ in rings), sh.style, source=shape_source(path, sh))]
        region_clip = clip(sh) if clip is not None else None
        if region_clip is not None:
            geom = polygon_parts(shapely.intersection(geom, region_clip))
            if not polygon_rings(geom):
                n_clipped_away += 1
                continue
            # drawn as browsers draw it: the clipped fill, and the clipped stroke as a filled
            # area (the clipped outline, stroked, drew a line along the cut)
            drawn = clip_art(drawn[0], region_clip)
        (holes if sh.hole else outer).append(geom)
        if not sh.style.visible and not sh.hole:
            unpainted.append(geom)
        arts.extend(drawn)
    if n_open:
        warn(
            path,
            f"ignored {n_open} open subpath(s) of the container (first point != last point); close them with Z to use them",
        )
    if not outer and not holes:  # (the drawn paths may be none: a clip can hide what paints)
        if n_clipped_away:
            raise InputError(
                path,
                "has no closed path left: every closed shape is clipped away by its clip-path",
            )
        raise InputError(
            path, "has no closed path; a container needs at least one closed outline"
        )
    outer = drop_unpainted(path, unpainted, outer)
    region = shapely.union_all(outer) if outer else shapely.Polygon()
    if holes:
        hole_region = shapely.union_all(holes)
        if region.is_empty:
            raise InputError(
                path,
                "has only hole shapes and no outer outline; mark at least one shape as the container",
            )
        if not hole_region.difference(region).area <= 1e-9 * max(
            hole_region.area, 1e-300
        ):
            warn(
                path,
                "a hole shape is not entirely inside the container outline; only its overlap is removed",
            )
        region = region.difference(hole_region)
    region = finalize_region(path, region)
    warn_self_crossing(path, n_crossing, region)
    return Container(
        source=Path(str(path)).name,
        region=region,
        paths=tuple(arts),
        svg_root=dict(svg_root),
        paint_servers=paint_servers(path, xml, arts),
    )


def drop_unpainted(path, unpainted: list, outer: list) -> list:
    """The container's outer shapes without those painted with neither fill nor stroke,
    when some shape is painted.

    Parameters
    ----------
    path : Path
        The container file (for the warning).
    unpainted : list
        The outer shapes' regions that have neither fill nor stroke (identity matters).
    outer : list
        Every outer shape's region.

    Returns
    -------
    list
        ``outer`` less the unpainted regions; all of ``outer`` when nothing is painted (a file
        of bare geometry) or everything is.

    Notes
    -----
    A container is geometry, whatever its paint, but an icon's invisible bounding square
    next to its drawn outline (every Tabler icon has one) is a layout helper browsers do not
    draw: counted, it turned the container into a square. Such helpers are left out, with a
    warning that says how to keep them.
    """
    if not unpainted or len(unpainted) == len(outer):
        return outer
    kept = [g for g in outer if not any(g is u for u in unpainted)]
    warn(
        path,
        f"left out {len(unpainted)} shape(s) with neither fill nor stroke beside the drawn outline "
        "(layout helpers such as an icon's bounding square); give them a fill or stroke to make "
        "them part of the container",
    )
    return kept


def _svg_container(path: Path, data: bytes, tolerance: float | None) -> Container:
    doc = parse_svg_shapes(path, data)
    if doc.stretch is not None:
        warn(path, f"the root's transform or preserveAspectRatio stretches the drawing "
                   f"({doc.stretch[0] / doc.stretch[1]:.3g}:1); the packing is made in its user units, so the "
                   "output, drawn the same way, shows the copies stretched too: give the root a uniform "
                   "mapping (or apply the stretch to the shapes themselves)")
    # a container is geometry, not appearance: fill, stroke and opacity do not matter;
    # display:none (never parsed) and visibility:hidden shapes are left out
    shapes = [s for s in doc.shapes if not s.hidden]
    tol = flattening_tolerance(shapes, tolerance)
    budget = PointBudget(path)
    clip = shape_clipper(path, doc, tol, budget)
    return container_from_shapes(path, shapes, tol, budget, doc.svg_root, clip, doc.xml)


def load_element(path: str | Path, tolerance: float | None = None) -> Element:
    """Load one element (SVG, or RepulsionPak ``.path`` by suffix / content).

    ``tolerance``: largest chord error when flattening curves, in the file's user
    units; None -> 1e-3 x the element's bounding-box diagonal. The element's paths are
    in paint order (first = back). Raises InputError for any unusable file, art
    covering no area included (:func:`check_element_area`).
    """
    tol = check_tolerance(tolerance)
    p = Path(path)
    with guard(p, "element file"):
        data = read_input_bytes(p, "element file")
        if sniff_kind(p, data) == "path":
            from .pathfile import element_from_pathfile

            element = element_from_pathfile(p, data)
        else:
            element = _svg_element(p, data, tol)
        check_element_area(p, element)
        return element


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


def load_container(path: str | Path, tolerance: float | None = None) -> Container:
    """Load the container region (SVG or ``.path``).

    Every closed path counts (an open one whose ends meet within tolerance too),
    whatever its fill, stroke and opacity -- a container is geometry, not appearance
    (``display:none`` and ``visibility:hidden`` shapes do not count) -- clipped by its
    ``clip-path``; each shape's fill-rule decides its holes; shapes are united, except
    shapes marked as holes (class ``hole``, id ``hole...``, ``data-path-type="7"``,
    ``.path`` type 7), which are subtracted. Returns a valid (Multi)Polygon in the file's user units.
    """
    tol = check_tolerance(tolerance)
    p = Path(path)
    with guard(p, "container file"):
        data = read_input_bytes(p, "container file")
        if sniff_kind(p, data) == "path":
            from .pathfile import container_from_pathfile

            return container_from_pathfile(p, data, tol)
        return _svg_container(p, data, tol)


def load_elements(paths, tolerance: float | None = None) -> list[Element]:
    """Load every element file given; directories expand to their ``*.svg``/``*.path``
    files (sorted by name, not recursive). Duplicates are loaded once."""
    check_tolerance(tolerance)
    if isinstance(paths, (str, Path)):
        paths = [paths]
    files: list[Path] = []
    for item in paths:
        p = Path(item)
        if p.is_dir():
            try:
                found = sorted(
                    (
                        c
                        for c in p.iterdir()
                        if c.is_file() and c.suffix.lower() in _ELEMENT_SUFFIXES
                    ),
                    key=lambda c: c.name,
                )
            except OSError as exc:
                raise InputError(
                    p,
                    f"cannot list the directory ({exc.strerror or exc}); check its permissions",
                ) from None
            if not found:
                raise InputError(
                    p,
                    "directory contains no .svg or .path element file; put element files in it or name the files directly",
                )
            files.extend(found)
        else:
            files.append(p)
    if not files:
        raise InputError(
            None,
            "no element file given; give at least one .svg or .path file or a directory of them",
        )
    seen: set[str] = set()
    out = []
    for f in files:
        try:
            key = str(f.resolve())
        except (OSError, RuntimeError):
            key = str(f.absolute())
        if key in seen:
            continue
        seen.add(key)
        out.append(load_element(f, tolerance))
    return out
