"""repulsionpak — deformation-driven element packing with repulsion forces.

An implementation of RepulsionPak (Saputra, Kaplan, Asente, Graphics Interface 2018):
fill a container shape with deformable copies of vector elements, SVG in, SVG out.

>>> from repulsionpak import load_container, load_elements, pack, Params
>>> packing = pack(load_container("heart.svg"), load_elements(["animals/"]), Params(gap=5.2, seed=1))
>>> packing.save("out.svg")       # what `repulsionpak pack ... --gap 5.2 --seed 1` writes
>>> packing.report()["area_fraction"]
"""

import sys as _sys
import types as _types


def _quiet_interrupt_while_importing() -> None:
    """The ``repulsionpak`` command imports this package and its command line (typer)
    before its ``main()`` can catch Ctrl-C; an interrupt in that window ends the
    command with one line, as later ones do, instead of a traceback (exit status 130 as
    before: Python re-raises SIGINT after reporting it). Only in the command's process."""
    import os

    if not _sys.argv or os.path.basename(_sys.argv[0]) not in ("repulsionpak", "repulsionpak.exe"):
        return
    previous = _sys.excepthook

    def report(kind, value, tb):
        if issubclass(kind, KeyboardInterrupt):
            _sys.stderr.write("repulsionpak: interrupted\n")
        else:
            previous(kind, value, tb)

    _sys.excepthook = report


_quiet_interrupt_while_importing()

#: where each public name lives: imported on first use (PEP 562), so that a command
#: imports only the modules it runs (``repulsionpak params`` no simulation, ``pack`` no
#: PNG writer unless it writes a picture)
_EXPORTS = {
    **dict.fromkeys(("ConfigError", "DivergedError", "InputError", "OutputError", "ParameterError",
                     "RepulsionPakError", "SimulationError"), "errors"),
    **dict.fromkeys(("load_container", "load_element", "load_elements", "read_packing_svg"), "io"),
    "render_png": "render.png",
    "write_packing_svg": "render.svg",
    "pack": "pack",
    "Packing": "packing",
    **dict.fromkeys(("Params", "load_config"), "params"),
    **dict.fromkeys(("ArtPath", "Container", "Element", "PlacedArt", "Style"), "types"),
    "evaluate": "measure",
}


def __getattr__(name: str):
    """A public name (:data:`_EXPORTS`) or a submodule, imported on first access.

    Raises
    ------
    AttributeError
        For any other name.
    """
    import importlib

    if name.startswith("__"):  # a protocol probe (__wrapped__, __path__ ...), not a name of ours
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    home = _EXPORTS.get(name)
    if home is not None:
        value = getattr(importlib.import_module(f".{home}", __name__), name)
        globals()[name] = value  # later accesses skip this function
        return value
    try:
        return importlib.import_module(f".{name}", __name__)
    except ModuleNotFoundError as exc:
        if exc.name != f"{__name__}.{name}":
            raise
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})


class _Package(_types.ModuleType):
    """This package's module type: importing a submodule binds it on the package, so the
    submodule :mod:`repulsionpak.pack` would hide the function :func:`pack` once imported.
    A public name keeps its object, as ``from .pack import pack`` at the top of this file
    kept it."""

    def __setattr__(self, name: str, value) -> None:
        if (isinstance(value, _types.ModuleType) and _EXPORTS.get(name) == name
                and value.__name__ == f"{__name__}.{name}"):
            value = getattr(value, name)
        super().__setattr__(name, value)


_sys.modules[__name__].__class__ = _Package


__version__ = "0.1.0"

__all__ = [
    "ArtPath", "ConfigError", "Container", "DivergedError", "Element", "InputError", "OutputError",
    "Packing", "ParameterError", "Params", "PlacedArt", "RepulsionPakError", "SimulationError",
    "Style", "evaluate", "load_config", "load_container", "load_element", "load_elements", "pack",
    "read_packing_svg", "render_png", "write_packing_svg",
]
