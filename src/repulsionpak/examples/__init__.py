"""Example data shipped with repulsionpak: elements, secondary elements and containers.

All files are original artwork made for this project and released under its MIT licence
(see ``README.md`` in this folder). They are plain SVG 1.1 files::

    examples/
        elements/     primary elements (animals, fruit, a leaf, an exclamation mark ...)
        secondary/    small simple fillers (dot, star, heart)
        containers/   regions to fill, user units of about 0..500

Typical use::

    from repulsionpak import examples
    elements = examples.element_files()
    container = examples.container_file()          # the default container
    gap = examples.DEFAULT_GAP                     # in that container's user units
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from repulsionpak.errors import ParameterError

__all__ = [
    "DEFAULT_CONTAINER",
    "DEFAULT_GAP",
    "examples_dir",
    "element_files",
    "secondary_files",
    "container_files",
    "container_names",
    "container_file",
]

#: Stem of the container used when none is given (``containers/heart.svg``).
DEFAULT_CONTAINER = "heart"

#: A gap that suits the default container, in its user units: the heart spans
#: about 456 x 434 units of a 500-unit viewBox, so 5 units is about 1 % of its size.
DEFAULT_GAP = 5.0


def examples_dir() -> Path:
    """The folder holding the example data (``.../repulsionpak/examples``)."""
    res = resources.files("repulsionpak") / "examples"
    if isinstance(res, Path):
        return res
    # Not a plain directory on disk (unusual loaders): fall back to this module's folder.
    return Path(__file__).resolve().parent


def _svgs(sub: str) -> list[Path]:
    return sorted((examples_dir() / sub).glob("*.svg"))


def element_files() -> list[Path]:
    """The primary example elements, sorted by file name."""
    return _svgs("elements")


def secondary_files() -> list[Path]:
    """The small secondary (filler) elements, sorted by file name."""
    return _svgs("secondary")


def container_files() -> list[Path]:
    """All example containers, sorted by file name."""
    return _svgs("containers")


def container_names() -> list[str]:
    """Stems of the example containers, e.g. ``["circle", "cloud", ...]``."""
    return [p.stem for p in container_files()]


def container_file(name: str = DEFAULT_CONTAINER) -> Path:
    """The example container called ``name`` (a stem such as ``"heart"``; ``".svg"`` optional).

    Raises :class:`~repulsionpak.errors.ParameterError` naming the available containers
    when there is no such file.
    """
    stem = name[:-4] if name.lower().endswith(".svg") else name
    path = examples_dir() / "containers" / f"{stem}.svg"
    if not path.is_file():
        raise ParameterError(
            f"no example container named {name!r}; available: {', '.join(container_names())}"
        )
    return path
