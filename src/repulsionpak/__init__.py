"""repulsionpak — deformation-driven element packing with repulsion forces.

An implementation of RepulsionPak (Saputra, Kaplan, Asente, Graphics Interface 2018):
fill a container shape with deformable copies of vector elements, SVG in, SVG out.

>>> from repulsionpak import load_container, load_elements, pack, Params
>>> packing = pack(load_container("heart.svg"), load_elements(["animals/"]), Params(gap=5.2, seed=1))
>>> packing.save("out.svg")       # what `repulsionpak pack ... --gap 5.2 --seed 1` writes
>>> packing.report()["area_fraction"]
"""

import sys as _sys


def _quiet_interrupt_while_importing() -> None:
    """The ``repulsionpak`` command imports this package (numpy, numba, shapely: about half a
    second) before its ``main()`` can catch Ctrl-C; an interrupt in that window ends the
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

from .errors import (ConfigError, DivergedError, InputError, OutputError, ParameterError,  # noqa: E402
                     RepulsionPakError, SimulationError)
from .io import load_container, load_element, load_elements, read_packing_svg  # noqa: E402
from .render.png import render_png  # noqa: E402
from .render.svg import write_packing_svg  # noqa: E402
from .pack import pack  # noqa: E402
from .packing import Packing  # noqa: E402
from .params import Params, load_config  # noqa: E402
from .types import ArtPath, Container, Element, PlacedArt, Style  # noqa: E402
from .measure import evaluate  # noqa: E402

__version__ = "0.1.0"

__all__ = [
    "ArtPath", "ConfigError", "Container", "DivergedError", "Element", "InputError", "OutputError",
    "Packing", "ParameterError", "Params", "PlacedArt", "RepulsionPakError", "SimulationError",
    "Style", "evaluate", "load_config", "load_container", "load_element", "load_elements", "pack",
    "read_packing_svg", "render_png", "write_packing_svg",
]
