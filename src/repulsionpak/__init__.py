"""repulsionpak — deformation-driven element packing with repulsion forces.

An implementation of RepulsionPak (Saputra, Kaplan, Asente, Graphics Interface 2018):
fill a container shape with deformable copies of vector elements, SVG in, SVG out.

>>> from repulsionpak import load_container, load_elements, pack, Params, write_packing_svg
>>> packing = pack(load_container("heart.svg"), load_elements(["animals/"]), Params(gap=5.2, seed=1))
>>> write_packing_svg("out.svg", packing.container, packing.placed, packing.gap)
"""

from .errors import (ConfigError, DivergedError, InputError, OutputError, ParameterError,
                     RepulsionPakError, SimulationError)
from .io import load_container, load_element, load_elements, read_packing_svg, render_png, write_packing_svg
from .pack import Packing, pack
from .params import Params, load_config
from .types import ArtPath, Container, Element, PlacedArt, Style
from .evaluate import evaluate  # noqa: E402  (function; the module stays importable by name)

__version__ = "0.1.0"

__all__ = [
    "ArtPath", "ConfigError", "Container", "DivergedError", "Element", "InputError", "OutputError",
    "Packing", "ParameterError", "Params", "PlacedArt", "RepulsionPakError", "SimulationError",
    "Style", "evaluate", "load_config", "load_container", "load_element", "load_elements", "pack",
    "read_packing_svg", "render_png", "write_packing_svg",
]
