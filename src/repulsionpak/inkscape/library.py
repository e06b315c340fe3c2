"""The one place the extension calls the packing library.

The effect hands over standalone SVG documents (bytes) and a :class:`Request`; this module
writes them to a temporary folder, reads them with the library's own readers, packs them
with :func:`repulsionpak.pack` and returns the packing as the SVG ``repulsionpak pack``
writes. Everything it imports comes from the package's top level (and, for the designer
controls, :mod:`repulsionpak.types`), so the extension gets the library's packing and
policy for the same inputs and seed.
"""

from __future__ import annotations

import dataclasses
import re
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Request:
    """One packing as the dialog asks for it, in the document's root user units.

    gap: None for the library's default gap. count: None for the library's default count.
    rotation: "free" | "fixed" | "limited" | "upright"; max_rotation: degrees either
    side, when limited or upright. rigid, stiffness: the element
    controls. pocket_fill: False leaves the pockets empty (``--no-pocket-fill``).
    container_paint: "outline" | "as-drawn" | "none". draft: a quicker, slightly looser
    packing (``--draft``).
    """

    seed: int
    gap: float | None = None
    count: int | None = None
    rotation: str = "free"
    max_rotation: float = 20.0
    rigid: bool = False
    stiffness: float = 1.0
    pocket_fill: bool = True
    container_paint: str = "none"
    draft: bool = False


class PackError(Exception):
    """A packing the library refused, with its one-line message (file names replaced by
    the objects they came from)."""


def rotations() -> tuple[str, ...]:
    """The rotation choices of the library (and of the dialog)."""
    from repulsionpak.types import ROTATIONS  # noqa: PLC0415

    return tuple(ROTATIONS)


def _controls(req: Request):
    """The element controls of ``req`` (None: the defaults, the paper's packing)."""
    from repulsionpak.types import ElementControls  # noqa: PLC0415

    kw: dict = {"rotation": req.rotation, "rigid": bool(req.rigid), "stiffness": float(req.stiffness)}
    if req.rotation in ("limited", "upright"):
        kw["max_rotation"] = float(req.max_rotation)
    ctrl = ElementControls(**kw)
    return None if ctrl.is_default else ctrl


def _params(req: Request):
    """:class:`repulsionpak.Params` of ``req``, as ``repulsionpak pack`` builds them from
    its options (``--gap``, ``--seed``, ``--count``, ``--no-pocket-fill``, ``--container-paint``,
    ``--draft``)."""
    from repulsionpak import Params  # noqa: PLC0415

    p = Params()
    rep = dataclasses.replace
    p = rep(p, seed=int(req.seed))
    if req.gap is not None:
        p = rep(p, gap=float(req.gap))
    if req.count is not None:
        p = rep(p, placement=rep(p.placement, count=int(req.count)))
    if not req.pocket_fill:
        p = p.without_pocket_fill()
    p = rep(p, output=rep(p.output, container_paint=req.container_paint))
    return p.drafted() if req.draft else p.validate()


def _file_name(key: str) -> str:
    """A file name for the object ``key`` (its id), safe on every file system."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", key)[:80] or "object"


def pack_documents(container: tuple[str, bytes], elements: list[tuple[str, bytes]],
                   secondary: list[tuple[str, bytes]], req: Request) -> tuple[bytes, dict]:
    """Pack standalone SVG documents and return the packing SVG.

    Parameters
    ----------
    container : (id, svg bytes)
        The container shape alone.
    elements, secondary : list of (id, svg bytes)
        One standalone document per element (secondary: the pocket elements; may be empty).
    req : Request

    Returns
    -------
    svg : bytes
        The packing as ``repulsionpak pack`` writes it (``g#container``,
        ``g#elements > g.element``), in the container document's user units; each
        element group's ``data-source`` is the id of the object it copies.
    info : dict
        ``gap`` (the gap used, user units), ``seed``, ``n_primary``, ``n_secondary``.

    Raises
    ------
    PackError
        Any input or parameter the library refuses, as one line naming the object.
    """
    import repulsionpak as rp  # noqa: PLC0415

    with tempfile.TemporaryDirectory(prefix="repulsionpak-inkscape-") as tmp:
        folder = Path(tmp)
        names: dict[str, str] = {}

        def write(sub: str, key: str, data: bytes) -> Path:
            d = folder / sub
            d.mkdir(exist_ok=True)
            name = _file_name(key)
            path = d / f"{name}.svg"
            k = 1
            while path.exists():
                k += 1
                path = d / f"{name}-{k}.svg"
            path.write_bytes(data)
            names[path.name] = key
            return path

        cpath = write("container", container[0], container[1])
        epaths = [write("elements", k, d) for k, d in elements]
        spaths = [write("secondary", k, d) for k, d in secondary]
        out = folder / "packing.svg"
        try:
            with warnings.catch_warnings():  # anything on stderr opens a dialog in Inkscape
                warnings.simplefilter("ignore")
                params = _params(req)
                ctrl = _controls(req)
                cont = rp.load_container(cpath)
                elems = rp.load_elements(epaths)
                secs = rp.load_elements(spaths) if spaths else []
                if ctrl is not None:
                    elems = [dataclasses.replace(e, controls=ctrl) for e in elems]
                    secs = [dataclasses.replace(e, controls=ctrl) for e in secs]
                packing = rp.pack(cont, elems, params, secondary=secs)
                if hasattr(packing, "save"):  # the library's writer, exactly as the CLI's
                    packing.save(out)
                else:
                    rp.write_packing_svg(out, packing.container, packing.placed, packing.gap,
                                         attrs={"seed": str(packing.params.seed)},
                                         container_paint=req.container_paint)
        except rp.RepulsionPakError as exc:
            raise PackError(_one_line(str(exc), folder, names)) from None
        data = out.read_bytes()
        for fname, key in names.items():  # data-source="path12.svg" -> the object's id
            data = data.replace(f'data-source="{fname}"'.encode(), f'data-source="{_attr(key)}"'.encode())
        info = {"gap": float(packing.gap), "seed": int(packing.params.seed),
                "n_primary": int(packing.n_primary), "n_secondary": int(packing.n_secondary)}
        return data, info


def _attr(text: str) -> str:
    return text.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")


def _one_line(message: str, folder: Path, names: dict[str, str]) -> str:
    """The library's message with the temporary files named by the objects they hold."""
    for sub in ("container", "elements", "secondary"):
        for fname, key in names.items():
            message = message.replace(str(folder / sub / fname), f"object {key}")
    message = message.replace(str(folder), "")
    return " ".join(message.split())
