"""Vector PDF of a packing, for print: the packing SVG converted by cairo.

The PDF holds the same drawing as the SVG (:func:`~repulsionpak.render.svg.packing_svg_string`):
the container as drawn and every copy's art as Bézier path operators, gradients and
patterns included, at the size the SVG declares (its ``width``/``height``, in CSS pixels
of 1/96 inch; a drawing without units is taken as pixels).
"""

from __future__ import annotations

from pathlib import Path

from ..errors import OutputError
from ..io.files import atomic_write_bytes
from ..types import Container, PlacedArt
from .svg import packing_svg_string

__all__ = ["pdf_bytes", "write_packing_pdf"]


def _cairosvg(path):
    try:
        import cairosvg  # noqa: PLC0415
    except (ImportError, OSError) as exc:  # OSError: the cairo library itself is missing
        raise OutputError(
            f"{path}: PDF output needs the cairosvg package and the cairo library "
            f"(pip install 'repulsionpak[pdf]'; Debian: apt-get install libcairo2): {exc}"
        ) from None
    return cairosvg


def pdf_bytes(svg_text: str, path: str | Path = "<output>") -> bytes:
    """A vector PDF of an SVG document (string)."""
    cairosvg = _cairosvg(path)
    try:
        return cairosvg.svg2pdf(bytestring=svg_text.encode("utf-8"))
    except Exception as exc:  # cairo errors are plain exceptions
        raise OutputError(f"{path}: the PDF could not be made ({type(exc).__name__}: {exc})") from None


def write_packing_pdf(path: str | Path, container: Container, placed: list[PlacedArt], gap: float,
                      **svg_options) -> None:
    """Write the packing as a vector PDF (atomically). ``svg_options`` are those of
    :func:`~repulsionpak.render.svg.packing_svg_string` (attrs, metadata, ...)."""
    svg = packing_svg_string(container, placed, gap, path=path, **svg_options)
    atomic_write_bytes(path, pdf_bytes(svg, path))
