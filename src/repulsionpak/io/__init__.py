"""Input: the SVG and ``.path`` readers, the packing SVG reader, the element manifest.

Reading is ``io``'s; writing a packing (SVG, PDF, PNG) is :mod:`repulsionpak.render`'s,
which imports only the low modules it needs from here (:mod:`.files`, :mod:`.regions`,
:mod:`.svg_viewports`); ``io`` never imports ``render``.

Modules, bottom up: :mod:`.files` (input checks, point budget, atomic writes),
:mod:`.regions` (filled area of closed outlines), :mod:`.svg_xml`, :mod:`.svg_harden`,
:mod:`.svg_css`, :mod:`.svg_viewports`, :mod:`.svg_lengths`, :mod:`.svg_use`,
:mod:`.svg_sanitize`, :mod:`.svg_style`, :mod:`.svg_text`, :mod:`.svg_markers`,
:mod:`.svg_clip`, :mod:`.svg_image`, :mod:`.svg_shapes` (the parse),
:mod:`.svg_flatten`, :mod:`.svg_source`, :mod:`.svg_element`, :mod:`.svg_container`,
:mod:`.pathfile`, :mod:`.load` (the public readers), :mod:`.svg_packing`,
:mod:`.manifest`.
"""

from .load import load_container, load_element, load_elements
from .pathfile import container_from_pathfile, element_from_pathfile, parse_pathfile
from .regions import rings_to_region
from .svg_packing import read_packing_svg

__all__ = [
    "container_from_pathfile",
    "element_from_pathfile",
    "load_container",
    "load_element",
    "load_elements",
    "parse_pathfile",
    "read_packing_svg",
    "rings_to_region",
]
