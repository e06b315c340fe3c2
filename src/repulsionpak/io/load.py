"""The public readers: :func:`load_element`, :func:`load_elements`, :func:`load_container`.

Each reads the file with the common checks (:mod:`.files`), tells an SVG from a
RepulsionPak ``.path`` file by suffix or content, and dispatches to :mod:`.svg_element`,
:mod:`.svg_container` or :mod:`.pathfile`; :func:`load_elements` expands directories.

Notes
-----
Every failure leaves these functions as an :class:`~repulsionpak.errors.InputError`
naming the file (:func:`~.files.guard`), never as a deep traceback.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from ..errors import InputError
from ..types import Container, Element
from .files import guard, read_input_bytes, sniff_kind
from .pathfile import container_from_pathfile, element_from_pathfile
from .svg_container import container_from_svg
from .svg_element import check_element_area, element_from_svg
from .svg_flatten import check_tolerance

__all__ = ["load_container", "load_element", "load_elements"]


_ELEMENT_SUFFIXES = {".svg", ".svgz", ".path"}


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
            element = element_from_pathfile(p, data)
        else:
            element = element_from_svg(p, data, tol)
        check_element_area(p, element)
        return element


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
            c = container_from_pathfile(p, data, tol)
        else:
            c = container_from_svg(p, data, tol)
    return dataclasses.replace(c, path=str(path), tolerance=tol)  # a run may re-read it (inputs.py)


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
