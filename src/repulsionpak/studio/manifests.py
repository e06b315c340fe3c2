"""Element folders and element manifests (``.toml``) given to the studio's file inputs.

A folder arrives as its files with their paths relative to the chosen folder (the
browser's ``webkitRelativePath``); a manifest arrives with the files it names, in a folder
or picked together with it. :func:`manifest_elements` checks the manifest as
``repulsionpak pack`` does (:func:`repulsionpak.io.manifest.load_manifest`, on a private
copy of the files laid out as uploaded) and turns each file it names into a studio element
with its weight and its own settings (the keys the studio holds per element).
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path, PurePosixPath

from ..errors import ParameterError, RepulsionPakError
from .uploads import INPUT_SUFFIXES, check_size, named_error

#: most files of one folder upload (inputs and others)
MAX_TREE_FILES = 1000
#: manifest keys the studio holds per element (the others are refused with a message)
HELD_KEYS = ("rotation", "angle", "max_rotation", "rigid", "stiffness", "weight", "axis", "flow", "flow_bend")


def relative_path(name: str, strict: bool = True) -> PurePosixPath:
    """An uploaded file's path relative to the chosen folder (control characters
    replaced). ``strict``: raises :class:`ParameterError` for ``..`` or an absolute path,
    which would lead out of the uploaded files (a manifest's ``file``); otherwise such
    parts are dropped (an uploaded file's name is only a name)."""
    text = str(name)
    parts = [p for p in re.split(r"[\\/]", text) if p not in ("", ".")]
    if strict and (".." in parts or text.startswith(("/", "\\")) or re.match(r"^[A-Za-z]:", text)):
        raise ParameterError(f"{name}: not a relative file name inside the files given")
    parts = [p for p in parts if p != ".." and not re.match(r"^[A-Za-z]:$", p)]
    if not parts:
        raise ParameterError(f"{name}: not a file name")
    return PurePosixPath(*(re.sub(r"[\x00-\x1f]", "_", p)[:200] for p in parts))


def _target(base: PurePosixPath, name: str) -> PurePosixPath:
    """A manifest's ``file`` as a relative path of the uploads (``base``: the manifest's folder)."""
    return relative_path(name if str(base) == "." else f"{base}/{name}")


def is_input(path: PurePosixPath) -> bool:
    return path.suffix.lower() in INPUT_SUFFIXES and not path.name.startswith(".")


def _own(where: str, keys: dict) -> tuple[float, dict]:
    """(weight, own settings) of a manifest entry's merged keys."""
    weight = float(keys.get("weight", 1.0))
    own: dict = {}
    rot = keys.get("rotation")
    if rot is not None:
        if rot == "fixed":
            own["rotation"] = f"fixed:{float(keys.get('angle', 0.0)):g}"
        elif rot in ("limited", "upright"):
            if float(keys.get("angle", 0.0)) != 0.0:
                raise ParameterError(f"{where}: the studio holds a {rot} rotation about angle 0 only "
                                     f"(angle = {keys['angle']}); pack this manifest with `repulsionpak pack`")
            own["rotation"] = f"{rot}:{float(keys.get('max_rotation', 20.0)):g}"
        else:
            own["rotation"] = str(rot)
    if "rigid" in keys:
        own["rigid"] = bool(keys["rigid"])
    for k in ("stiffness", "axis"):
        if k in keys:
            own[k] = float(keys[k])
    if "flow" in keys:
        own["flow"] = str(keys["flow"])
    if "flow_bend" in keys:
        own["flow_bend"] = bool(keys["flow_bend"])
    return weight, own


def manifest_elements(folder: Path, manifest: PurePosixPath, uploaded: list[PurePosixPath]
                      ) -> list[tuple[PurePosixPath, float, dict]]:
    """The elements of the manifest ``folder / manifest``, as the studio holds them.

    Parameters
    ----------
    folder : Path
        A private folder holding the uploaded files at their relative paths.
    manifest : PurePosixPath
        The manifest's relative path.
    uploaded : list of PurePosixPath
        The uploaded input files' relative paths.

    Returns
    -------
    list of (PurePosixPath, float, dict)
        Each element file (relative path), its weight and its own settings (keys of
        :data:`repulsionpak.studio.settings.ELEMENT_KEYS`), in the manifest's order.

    Raises
    ------
    RepulsionPakError
        The manifest's own message (``repulsionpak pack``'s), with the uploaded names; a
        key the studio does not hold per element (pins) is refused.

    Notes
    -----
    A file the manifest names is looked up at its path relative to the manifest; a file
    of that name picked together with the manifest (no folders) stands in for it.
    """
    from ..io.manifest import load_manifest

    path = folder / manifest
    shown = str(manifest)
    base = manifest.parent
    uploaded = list(uploaded)
    by_name: dict[str, list[PurePosixPath]] = {}
    for p in uploaded:
        by_name.setdefault(p.name, []).append(p)
    try:
        entries = tomllib.loads(path.read_text(encoding="utf-8")).get("element", [])
    except (tomllib.TOMLDecodeError, UnicodeDecodeError):
        entries = []  # the manifest's reader says what is wrong
    for n, e in enumerate(entries if isinstance(entries, list) else [], 1):
        f = e.get("file") if isinstance(e, dict) else None
        if not isinstance(f, str) or not f:
            continue
        try:  # never a file outside the uploaded ones
            target = _target(base, f)
        except ParameterError:
            raise ParameterError(f"{shown}: [[element]] {n}: file = {f!r} is not inside the files given") from None
        same = by_name.get(target.name, [])  # picked together with the manifest: stands in for it
        if not (folder / target).exists() and len(same) == 1 and target.suffix:
            (folder / target).parent.mkdir(parents=True, exist_ok=True)
            (folder / target).write_bytes((folder / same[0]).read_bytes())
            uploaded.append(target)
    try:
        load_manifest(path)
    except RepulsionPakError as exc:
        raise named_error(named_error(exc, path, shown), folder, ".") from None
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    defaults = data.get("defaults", {})
    out = []
    for n, entry in enumerate(data.get("element", []), 1):
        where = f"{shown}: [[element]] {n} ({entry['file']})"
        keys = dict(defaults, **{k: v for k, v in entry.items() if k != "file"})
        bad = [k for k in keys if k not in HELD_KEYS]
        if bad:
            raise ParameterError(f"{where}: the studio does not hold {', '.join(bad)} per element; "
                                 f"pack this manifest with `repulsionpak pack`")
        weight, own = _own(where, keys)
        target = _target(base, entry["file"])
        if (folder / target).is_dir():
            files = sorted(p for p in uploaded if target in p.parents and is_input(p))
        else:
            files = [target]
        out += [(f, weight, own) for f in files]
    return out


def store_tree(folder: Path, files: list[tuple[str, bytes]]) -> list[PurePosixPath]:
    """Write uploaded ``files`` (relative name, contents) under ``folder`` at their
    relative paths (each size bounded, at most :data:`MAX_TREE_FILES` of them); returns
    the paths in upload order."""
    if len(files) > MAX_TREE_FILES:
        raise ParameterError(f"a folder of {len(files)} files: the studio takes at most {MAX_TREE_FILES} at once")
    out = []
    for name, data in files:
        rel = relative_path(name, strict=False)
        check_size(str(rel), len(data))
        dest = folder / rel
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.write_bytes(data)
        out.append(rel)
    return out


__all__ = ["HELD_KEYS", "MAX_TREE_FILES", "is_input", "manifest_elements", "relative_path", "store_tree"]
