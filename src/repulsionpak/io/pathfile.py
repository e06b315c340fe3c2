"""Read the original RepulsionPak ``.path`` format (see ``data/README.md``).

::

    <num_regions>
    foreground_color_rgb <region> r,g,b r,g,b ...     (stroke per type-0 path, -1,-1,-1 = none)
    background_color_rgb <region> r,g,b r,g,b ...     (fill per type-0 path)
    foreground_color <region> i i ...                 (older files: palette indices, -1 = none)
    background_color <region> i i ...
    <region> <is_closed> <path_type> x0 y0 x1 y1 ...  (one polyline per line)

Parsing is strict: a malformed line gives an InputError with the file and line number.
Records with fewer than two points are skipped (as RepulsionPak does).

Public API: :func:`parse_pathfile`, :func:`element_from_pathfile`,
:func:`container_from_pathfile` (``load_element`` / ``load_container`` dispatch here).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely

from ..errors import InputError
from ..types import ArtPath, Container, Element, Style
from .files import MAX_POINTS, check_coordinates, warn
from .regions import clean_points, count_self_crossing, finalize_region, rings_to_region, warn_self_crossing

__all__ = [
    "PALETTE",
    "PathFile",
    "PathRecord",
    "container_from_pathfile",
    "element_from_pathfile",
    "parse_pathfile",
]

BOUNDARY, DETAIL, FOCAL, FIELD, SEED, STREAM, SKELETON, HOLE = range(8)
#: Palette of the older ``foreground_color`` / ``background_color`` lines (index -> RGB).
PALETTE = {
    0: (190, 221, 244),
    1: (58, 162, 219),
    2: (57, 139, 203),
    3: (255, 0, 0),
    4: (244, 124, 32),
    5: (242, 128, 170),
    6: (157, 156, 158),
    7: (0, 0, 0),
    8: (255, 255, 255),
}
#: RepulsionPak draws the foreground colour as a stroke of this width.
STROKE_WIDTH = 0.5
DEFAULT_STROKE = "#000000"
DEFAULT_FILL = "#ffffff"


@dataclass
class PathRecord:
    region: int
    closed_flag: bool
    path_type: int
    points: np.ndarray  # (K, 2) as in the file
    line: int  # 1-based line number


@dataclass
class PathFile:
    num_regions: int
    records: list[PathRecord]
    #: region -> list of '#rrggbb' | None, one per type-0 path of that region, in order
    stroke_colours: dict[int, list] = field(default_factory=dict)
    fill_colours: dict[int, list] = field(default_factory=dict)


def _hex(rgb) -> str:
    r, g, b = (int(c) for c in rgb)
    return f"#{r:02x}{g:02x}{b:02x}"


def _int(path, lineno: int, token: str, what: str) -> int:
    try:
        return int(token)
    except ValueError:
        raise InputError(
            path,
            f"line {lineno}: {what} must be an integer, got {token[:40]!r}; fix or remove the line",
        ) from None


def parse_pathfile(path: str | Path, data: bytes | str) -> PathFile:
    """Parse ``.path`` content strictly. ``path`` is used in error messages only."""
    if isinstance(data, bytes):
        if b"\x00" in data:
            raise InputError(
                path, "is a binary file, not a RepulsionPak .path text file"
            )
        try:
            text = data.decode("utf-8-sig")
        except UnicodeDecodeError:
            raise InputError(
                path, "is not a UTF-8/ASCII text file; a .path file is plain text"
            ) from None
    else:
        text = data
    lines = text.splitlines()
    if not lines or not lines[0].strip():
        raise InputError(
            path,
            "line 1: expected the number of regions; the file is empty or starts with a blank line",
        )
    first = lines[0].split()
    if len(first) != 1:
        raise InputError(
            path,
            f"line 1: expected the number of regions (one integer), got {lines[0][:60]!r}",
        )
    num_regions = _int(path, 1, first[0], "the number of regions")
    if num_regions < 1:
        raise InputError(
            path, f"line 1: the number of regions must be >= 1, got {num_regions}"
        )

    pf = PathFile(num_regions, [])
    total = 0

    def region_index(lineno: int, token: str) -> int:
        r = _int(path, lineno, token, "the region index")
        if not 0 <= r < num_regions:
            raise InputError(
                path,
                f"line {lineno}: region {r} is out of range (the file declares {num_regions} region(s))",
            )
        return r

    for i, raw in enumerate(lines[1:], start=2):
        tokens = raw.split()
        if not tokens:
            continue
        head = tokens[0]
        if head in ("foreground_color_rgb", "background_color_rgb"):
            if len(tokens) < 2:
                raise InputError(path, f"line {i}: '{head}' needs a region index")
            r = region_index(i, tokens[1])
            cols = []
            for tok in tokens[2:]:
                parts = tok.split(",")
                if len(parts) != 3:
                    raise InputError(
                        path,
                        f"line {i}: colour {tok[:40]!r} must be 'r,g,b' (or -1,-1,-1 for none)",
                    )
                rgb = [_int(path, i, c, "a colour component") for c in parts]
                if all(c == -1 for c in rgb):
                    cols.append(None)
                elif all(0 <= c <= 255 for c in rgb):
                    cols.append(_hex(rgb))
                else:
                    raise InputError(
                        path, f"line {i}: colour {tok!r} has components outside 0..255"
                    )
            (pf.stroke_colours if head.startswith("fore") else pf.fill_colours)[r] = (
                cols
            )
            continue
        if head in ("foreground_color", "background_color"):
            if len(tokens) < 2:
                raise InputError(path, f"line {i}: '{head}' needs a region index")
            r = region_index(i, tokens[1])
            cols = []
            for tok in tokens[2:]:
                k = _int(path, i, tok, "a palette index")
                if k == -1:
                    cols.append(None)
                elif k in PALETTE:
                    cols.append(_hex(PALETTE[k]))
                else:
                    raise InputError(
                        path, f"line {i}: palette index {k} is not one of -1..8"
                    )
            (pf.stroke_colours if head.startswith("fore") else pf.fill_colours)[r] = (
                cols
            )
            continue
        if len(tokens) < 3:
            raise InputError(
                path,
                f"line {i}: a path record needs '<region> <is_closed> <path_type> x0 y0 ...', got {raw[:60]!r}",
            )
        r = region_index(i, tokens[0])
        flag = _int(path, i, tokens[1], "the closed flag")
        if flag not in (0, 1):
            raise InputError(
                path, f"line {i}: the closed flag must be 0 or 1, got {flag}"
            )
        ptype = _int(path, i, tokens[2], "the path type")
        if not 0 <= ptype <= 7:
            raise InputError(path, f"line {i}: path type {ptype} is not one of 0..7")
        coords = tokens[3:]
        if len(coords) % 2:
            raise InputError(
                path,
                f"line {i}: odd number of coordinates ({len(coords)}); every point needs x and y",
            )
        try:
            pts = np.array([float(c) for c in coords], dtype=float).reshape(-1, 2)
        except ValueError:
            bad = next((c for c in coords if not _is_float(c)), "?")
            raise InputError(path, f"line {i}: {bad[:40]!r} is not a number") from None
        if not np.all(np.isfinite(pts)):
            raise InputError(path, f"line {i}: non-finite coordinate (NaN or infinity)")
        check_coordinates(path, pts, f" on line {i}")
        total += len(pts)
        if total > MAX_POINTS:
            raise InputError(
                path, f"has more than {MAX_POINTS} points; simplify the file"
            )
        if len(pts) < 2:
            continue
        pf.records.append(PathRecord(r, bool(flag), ptype, pts, i))
    return pf


def _is_float(tok: str) -> bool:
    try:
        float(tok)
    except ValueError:
        return False
    return True


def _styles(pf: PathFile, path) -> dict[int, Style]:
    """Style of every type-0 record (keyed by id(record)) from the colour lines."""
    out: dict[int, Style] = {}
    short = False
    by_region: dict[int, list[PathRecord]] = {}
    for rec in pf.records:  # only regions that have records (num_regions may be huge)
        if rec.path_type == BOUNDARY:
            by_region.setdefault(rec.region, []).append(rec)
    for region, bounds in sorted(by_region.items()):
        has_lines = region in pf.stroke_colours or region in pf.fill_colours
        strokes = pf.stroke_colours.get(region)
        fills = pf.fill_colours.get(region)
        for k, rec in enumerate(bounds):
            if has_lines:
                if (strokes is not None and k >= len(strokes)) or (
                    fills is not None and k >= len(fills)
                ):
                    short = True
                stroke = (
                    strokes[k]
                    if strokes is not None and k < len(strokes)
                    else DEFAULT_STROKE
                )
                fill = (
                    fills[k] if fills is not None and k < len(fills) else DEFAULT_FILL
                )
            else:
                stroke, fill = DEFAULT_STROKE, DEFAULT_FILL
            out[id(rec)] = Style(fill=fill, stroke=stroke, stroke_width=STROKE_WIDTH)
    if short:
        warn(
            path,
            "a colour line has fewer entries than boundary paths; the others use stroke black, fill white",
        )
    return out


def _default_style() -> Style:
    return Style(fill=DEFAULT_FILL, stroke=DEFAULT_STROKE, stroke_width=STROKE_WIDTH)


def element_from_pathfile(path: str | Path, data: bytes | str) -> Element:
    """Element from a ``.path`` file: region-0 boundary (0) and focal (2) paths.

    A path is closed when its flag is 1 or its last point repeats its first (the
    repeated point is dropped). Paint order is the reverse of file order.
    """
    p = Path(str(path))
    pf = parse_pathfile(p, data)
    styles = _styles(pf, p)
    arts = []
    for rec in pf.records:
        if rec.region != 0 or rec.path_type not in (BOUNDARY, FOCAL):
            continue
        style = styles.get(id(rec), _default_style())
        if not style.visible:
            continue
        pts = rec.points
        scale = float(np.abs(pts).max()) if len(pts) else 1.0
        eps = 1e-12 * max(scale, 1.0)
        closed = rec.closed_flag or bool(np.abs(pts[-1] - pts[0]).max() <= eps)
        pts = clean_points(pts.copy(), closed, eps)
        if len(pts) < 2:
            continue
        arts.append(ArtPath((pts,), (closed,), style))
    if not arts:
        raise InputError(
            p,
            "has no visible region-0 boundary or focal path; an element needs at least one",
        )
    arts.reverse()
    return Element(name=p.stem, source=p.name, paths=tuple(arts))


def container_from_pathfile(
    path: str | Path, data: bytes | str, tolerance: float | None = None
) -> Container:
    """Container from a ``.path`` file: type-0 paths of every region are outer
    boundaries (always closed), type-7 paths are holes (subtracted)."""
    p = Path(str(path))
    pf = parse_pathfile(p, data)
    styles = _styles(pf, p)
    recs = [r for r in pf.records if r.path_type in (BOUNDARY, HOLE)]
    if any(r.path_type == FOCAL for r in pf.records):
        warn(
            p, "focal paths (type 2) of a container are not supported and were ignored"
        )
    if not recs:
        raise InputError(
            p,
            "has no boundary path (type 0); a container needs at least one closed outline",
        )
    allpts = np.concatenate([r.points for r in recs])
    if tolerance is None:
        span = allpts.max(axis=0) - allpts.min(axis=0)
        diag = float(np.hypot(*span))
        tolerance = 1e-3 * diag if diag > 0 and math.isfinite(diag) else 1e-9
    outer, holes, arts = [], [], []
    n_crossing = 0
    for rec in recs:
        pts = clean_points(rec.points.copy(), True, tolerance * 1e-6)
        if len(pts) >= 2 and float(np.hypot(*(pts[-1] - pts[0]))) <= tolerance:
            pts = pts[:-1]
        if len(pts) < 3:
            continue
        geom = rings_to_region([pts], "nonzero", p)
        n_crossing += count_self_crossing([pts])
        (holes if rec.path_type == HOLE else outer).append(geom)
        arts.append(ArtPath((pts,), (True,), styles.get(id(rec), _default_style())))
    if not outer:
        raise InputError(
            p,
            "has no usable boundary path (type 0 with at least 3 points); a container needs an outline",
        )
    region = shapely.union_all(outer)
    if holes:
        region = region.difference(shapely.union_all(holes))
    region = finalize_region(p, region)
    warn_self_crossing(p, n_crossing, region)
    arts.reverse()
    return Container(source=p.name, region=region, paths=tuple(arts), svg_root={})
