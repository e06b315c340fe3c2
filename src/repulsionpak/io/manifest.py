"""The element manifest: a ``.toml`` among the element arguments that names element files
(or folders) and their designer controls (see ``docs/controls.md``)::

    [defaults]              # optional; every key may also appear per element
    rotation = "free"       # "free" | "fixed" | "limited" | "upright"
    angle = 0               # degrees clockwise; fixed orientation / centre when limited
    max_rotation = 20       # degrees either side of angle, when limited
    rigid = false
    stiffness = 1.0
    weight = 1.0

    [[element]]
    file = "logo.svg"       # relative to the manifest
    rigid = true
    weight = 0
    pins = [{x = 400, y = 400, angle = 0, scale = 1.5}]
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from collections.abc import Sequence
from pathlib import Path

from ..errors import InputError, ParameterError
from ..types import Element, ElementControls, Pin
from .load import load_elements

KEYS = ("rotation", "angle", "max_rotation", "rigid", "stiffness", "weight", "axis", "flow", "flow_bend")
PIN_KEYS = ("x", "y", "angle", "scale")
_TYPES = {"rotation": (str,), "angle": (int, float), "max_rotation": (int, float), "rigid": (bool,),
          "stiffness": (int, float), "weight": (int, float), "axis": (int, float), "flow": (str,),
          "flow_bend": (bool,)}


def is_manifest(path) -> bool:
    return Path(path).suffix.lower() == ".toml"


def _check_keys(path, where: str, table: dict, allowed: Sequence[str]) -> None:
    for k in table:
        if k not in allowed:
            import difflib

            close = difflib.get_close_matches(k, allowed, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise InputError(path, f"{where}: unknown key {k!r}{hint}; known keys: {', '.join(allowed)}")


def _value(path, where: str, key: str, v, types) -> object:
    if not isinstance(v, types) or (bool not in types and isinstance(v, bool)):
        want = "true or false" if types == (bool,) else ("a string" if types == (str,) else "a number")
        raise InputError(path, f"{where}: {key} must be {want}, got {v!r}")
    return float(v) if types == (int, float) else v


def _controls(path, where: str, table: dict, base: ElementControls) -> ElementControls:
    kw = {k: _value(path, where, k, table[k], _TYPES[k]) for k in KEYS if k in table}
    try:
        return dataclasses.replace(base, **kw)
    except ParameterError as exc:
        raise InputError(path, f"{where}: {exc}") from None


def _pins(path, where: str, raw) -> tuple[Pin, ...]:
    if not isinstance(raw, list):
        raise InputError(path, f"{where}: pins must be a list of {{x, y, angle, scale}} tables")
    out = []
    for j, p in enumerate(raw):
        w = f"{where}, pin {j + 1}"
        if not isinstance(p, dict):
            raise InputError(path, f"{w}: a pin must be a table {{x = .., y = .., angle = .., scale = ..}}")
        _check_keys(path, w, p, PIN_KEYS)
        for k in ("x", "y"):
            if k not in p:
                raise InputError(path, f"{w}: missing {k}")
        vals = {k: _value(path, w, k, p[k], (int, float)) for k in PIN_KEYS if k in p}
        for k, v in vals.items():
            if not math.isfinite(v):
                raise InputError(path, f"{w}: {k} must be a finite number, got {v!r}")
        if "scale" in vals and not vals["scale"] > 0:
            raise InputError(path, f"{w}: scale must be > 0, got {vals['scale']:g}")
        out.append(Pin(**vals))
    return tuple(out)


def load_manifest(path, base: ElementControls | None = None, tolerance: float | None = None
                  ) -> list[Element]:
    """The elements a manifest names, each with its :class:`ElementControls`; ``base``
    (the CLI shortcuts) is overridden by ``[defaults]``, which each ``[[element]]``
    overrides."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(path, f"cannot read the manifest ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise InputError(path, "the manifest is not UTF-8 text") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(path, f"not valid TOML: {exc}") from None
    _check_keys(path, "manifest", data, ("defaults", "element"))
    defaults = data.get("defaults", {})
    if not isinstance(defaults, dict):
        raise InputError(path, "[defaults] must be a table")
    _check_keys(path, "[defaults]", defaults, KEYS)
    base = _controls(path, "[defaults]", defaults, base or ElementControls())
    entries = data.get("element", [])
    if not isinstance(entries, list) or not entries:
        raise InputError(path, "the manifest names no element: add [[element]] tables with file = \"...\"")
    out: list[Element] = []
    for n, entry in enumerate(entries, 1):
        where = f"[[element]] {n}"
        if not isinstance(entry, dict):
            raise InputError(path, f"{where} must be a table")
        f = entry.get("file")
        if isinstance(f, str) and f:
            where = f"{where} ({f})"
        _check_keys(path, where, entry, ("file", "pins", *KEYS))
        if not isinstance(f, str) or not f:
            raise InputError(path, f"{where}: missing file = \"name.svg\" (a file or folder relative to the manifest)")
        target = (path.parent / f)
        if not target.exists():
            raise InputError(path, f"{where}: {target} does not exist")
        ctrl = _controls(path, where, entry, base)
        if "pins" in entry:
            ctrl = dataclasses.replace(ctrl, pins=_pins(path, where, entry["pins"]))
        elems = load_elements([target], tolerance)
        if ctrl.pins and len(elems) != 1:
            raise InputError(path, f"{where}: pins need a single element file, not a folder of {len(elems)}")
        out.extend(dataclasses.replace(e, controls=ctrl) for e in elems)
    return out


def manifest_files(path) -> list[Path]:
    """The files and folders a manifest names, resolved against it (for the outputs'
    check: none may overwrite them); empty when the manifest cannot be read (loading it
    then says why)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return []
    entries = data.get("element", [])
    if not isinstance(entries, list):
        return []
    return [path.parent / e["file"] for e in entries
            if isinstance(e, dict) and isinstance(e.get("file"), str) and e["file"]]


def with_manifest_files(paths) -> list[Path]:
    """``paths`` followed by the files and folders the manifests among them name."""
    paths = [Path(p) for p in paths]
    return [*paths, *(f for p in paths if is_manifest(p) for f in manifest_files(p))]


def load_element_args(paths, controls: ElementControls | None = None, tolerance: float | None = None
                      ) -> list[Element]:
    """Element arguments as the CLI gets them: files, folders and manifests (``.toml``),
    in order. ``controls`` (the CLI shortcuts) applies to every element; None leaves the
    plain files without controls (the default behaviour)."""
    if isinstance(paths, (str, Path)):
        paths = [paths]
    out: list[Element] = []
    plain: list = []

    def flush():
        if plain:
            els = load_elements(list(plain), tolerance)
            out.extend(els if controls is None else [dataclasses.replace(e, controls=controls) for e in els])
            plain.clear()

    for p in paths:
        if is_manifest(p):
            flush()
            out.extend(load_manifest(p, controls, tolerance))
        else:
            plain.append(p)
    flush()
    if not out:
        return load_elements([], tolerance)  # its error
    return out


__all__ = ["load_manifest", "load_element_args", "is_manifest", "manifest_files", "with_manifest_files"]
