"""Input/output: SVG and ``.path`` readers, packing SVG writer/reader, PNG preview."""

from .pathfile import container_from_pathfile, element_from_pathfile, parse_pathfile
from .svg_read import load_container, load_element, load_elements, rings_to_region
from .svg_write import read_packing_svg
from ..render.png import render_png  # noqa: E402  (the writers live in render/)
from ..render.svg import write_packing_svg  # noqa: E402

__all__ = [
    "container_from_pathfile",
    "element_from_pathfile",
    "load_container",
    "load_element",
    "load_elements",
    "parse_pathfile",
    "read_packing_svg",
    "render_png",
    "rings_to_region",
    "write_packing_svg",
]
