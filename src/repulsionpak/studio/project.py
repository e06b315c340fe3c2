"""A studio project as a zip archive: the container file, ``elements/*``, ``secondary/*``
and ``project.toml`` (the files, every setting, the equivalent command).

Reading one is as careful as reading an upload: the archive and each file are size
bounded, only the files the manifest names are read (by their exact names in the archive,
never extracted to disk under them), and every setting is checked as the page checks it.
"""

from __future__ import annotations

import io
import json
import tomllib
import zipfile
from dataclasses import dataclass, field

from ..errors import ParameterError
from ..types import ElementControls
from .guides import GUIDES_NAME, MAX_GUIDES, parse_guide
from .settings import DEFAULTS, coerce, coerce_element, element_manifest, run_settings
from .uploads import MAX_ELEMENTS, MAX_PROJECT_BYTES, UploadTooLarge, check_size

#: the manifest's name in the archive
PROJECT_MANIFEST = "project.toml"
FIELDS = ("elements", "secondary")


@dataclass(frozen=True)
class ProjectFiles:
    """What a project holds: checked ``settings`` (every key of
    :data:`repulsionpak.studio.settings.DEFAULTS`), and (name in the archive, bytes) of
    the container (None: none saved) and of each element and secondary element, and each
    element's weight."""

    settings: dict
    container: tuple[str, bytes] | None = None
    elements: list[tuple[str, bytes]] = field(default_factory=list)
    secondary: list[tuple[str, bytes]] = field(default_factory=list)
    weights: list[float] = field(default_factory=list)  # of the elements
    own: list[dict] = field(default_factory=list)  # each element's own settings
    guides: list[tuple] = field(default_factory=list)  # flow guides (polylines)


def write_project(doc, container, command: str | None, manifest: str | None = None, guides=None) -> bytes:
    """The zip of ``doc`` (a :class:`~.document.Document`).

    Parameters
    ----------
    doc : Document
    container : InputFile or None
        The container file a run reads (the painted region's, when painted).
    command : str or None
        The ``repulsionpak pack`` command, recorded in the manifest.
    manifest : str or None
        The name of an element manifest to write beside them (the elements' weights, for
        the command line); None: none.
    guides : Path or None
        The guide SVG of the document's flow guides (``--flow``), written as
        ``guides.svg``; the strokes themselves go to ``project.toml`` (``guides``).

    Returns
    -------
    bytes
        The archive: ``container.name`` at its top, ``elements/NAME``, ``secondary/NAME``,
        ``project.toml`` with ``[studio]`` (format, the files, the command) and ``[settings]``
        (those set; missing ones are chosen by the run).
    """
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        lines = ["# a repulsionpak studio project: `repulsionpak studio` opens it (Open project)",
                 "[studio]", "format = 1"]
        if container is not None:
            zf.write(container.path, container.name)
            lines.append(f"container = {json.dumps(container.name)}")
        for name in FIELDS:
            files = getattr(doc, name)
            names = [f"{name}/{e.name}" for e in files]
            for e, n in zip(files, names):
                zf.write(e.path, n)
            lines.append(f"{name} = [{', '.join(json.dumps(n) for n in names)}]")
        lines.append(f"weights = [{', '.join(json.dumps(e.weight) for e in doc.elements)}]")
        lines.append("own = [" + ", ".join("{" + ", ".join(f"{k} = {json.dumps(v)}" for k, v in e.own) + "}"
                                           for e in doc.elements) + "]")
        if manifest:
            zf.writestr(manifest, element_manifest([(f"elements/{e.name}", e.weight, e.own)
                                                    for e in doc.elements]))
        if guides is not None:
            zf.write(guides, GUIDES_NAME)
            lines.append("guides = [" + ", ".join(
                "[" + ", ".join(f"[{x!r}, {y!r}]" for x, y in g) + "]" for g in doc.guides) + "]")
        if command:
            lines.append(f"command = {json.dumps(command)}")
        lines += ["", "[settings]  # missing: chosen by the run (auto gap and count, random seed)"]
        lines += [f"{k} = {json.dumps(v)}" for k, v in doc.settings_dict.items() if v is not None]
        zf.writestr(PROJECT_MANIFEST, "\n".join(lines) + "\n")
    return buf.getvalue()


def read_project(data: bytes) -> ProjectFiles:
    """The files and settings of a project archive made by :func:`write_project`.

    Raises
    ------
    UploadTooLarge
        The archive, its unpacked contents or one of its files is over the limits.
    ParameterError
        Not a zip, no or a bad manifest, a named file missing, a bad setting (the
        command line's message).
    """
    check_size("project", len(data), MAX_PROJECT_BYTES)
    try:
        zf = zipfile.ZipFile(io.BytesIO(data))
    except zipfile.BadZipFile:
        raise ParameterError("the project is not a zip archive (save one with Save project)") from None
    with zf:
        infos = {i.filename: i for i in zf.infolist()}
        if sum(i.file_size for i in infos.values()) > MAX_PROJECT_BYTES:
            raise UploadTooLarge(f"the project unpacks to more than {MAX_PROJECT_BYTES / 2**20:.0f} MB")

        def read(name: object) -> tuple[str, bytes]:
            if not isinstance(name, str) or name not in infos:
                raise ParameterError(f"the project names {name!r} but does not hold it")
            check_size(name, infos[name].file_size)
            with zf.open(infos[name]) as f:  # (bounded: a lying header cannot make it more)
                content = f.read(infos[name].file_size + 1)
            check_size(name, len(content))
            return name, content

        try:
            manifest = tomllib.loads(read(PROJECT_MANIFEST)[1].decode("utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise ParameterError(f"{PROJECT_MANIFEST}: not a valid TOML file ({exc})") from None
        studio = manifest.get("studio", {})
        settings = dict(DEFAULTS)
        for k, v in manifest.get("settings", {}).items():
            settings[k] = coerce(k, v)
        run_settings(settings)
        out = {}
        for name in FIELDS:
            names = studio.get(name, [])
            if not isinstance(names, list) or len(names) > MAX_ELEMENTS:
                raise ParameterError(f"{PROJECT_MANIFEST}: '{name}' must be a list of at most "
                                     f"{MAX_ELEMENTS} file names")
            out[name] = [read(n) for n in names]
        container = read(studio["container"]) if studio.get("container") else None
        weights = studio.get("weights", [1.0] * len(out["elements"]))
        if (not isinstance(weights, list) or len(weights) != len(out["elements"])
                or not all(isinstance(w, (int, float)) and not isinstance(w, bool) for w in weights)):
            raise ParameterError(f"{PROJECT_MANIFEST}: 'weights' must be a number per element")
        for w in weights:
            ElementControls(weight=float(w))  # its check and message
        own = studio.get("own", [{}] * len(out["elements"]))
        if not isinstance(own, list) or len(own) != len(out["elements"]) or not all(isinstance(o, dict) for o in own):
            raise ParameterError(f"{PROJECT_MANIFEST}: 'own' must be a table of settings per element")
        own = [{k: v for k, v in ((k, coerce_element(k, v)) for k, v in o.items()) if v is not None} for o in own]
        guides = studio.get("guides", [])
        if not isinstance(guides, list) or len(guides) > MAX_GUIDES:
            raise ParameterError(f"{PROJECT_MANIFEST}: 'guides' must be a list of at most {MAX_GUIDES} strokes")
        guides = [parse_guide({"points": g}) for g in guides]
        return ProjectFiles(settings, container, out["elements"], out["secondary"], [float(w) for w in weights], own,
                            guides)


__all__ = ["PROJECT_MANIFEST", "ProjectFiles", "read_project", "write_project"]
