"""Render a packing SVG to a small PNG for the docs: 560 px, 128-colour palette.

    python docs/examples/controls/small_png.py OUT.svg docs/images/NAME.png
"""

import io
import sys

from PIL import Image

from repulsionpak.io import read_packing_svg
from repulsionpak.render.png import png_bytes

svg, png = sys.argv[1:3]
container, placed, _ = read_packing_svg(svg)
data = png_bytes(container, placed, 560, "white", True, path=png)
Image.open(io.BytesIO(data)).convert("RGB").quantize(128, dither=Image.Dither.NONE).save(png, optimize=True)
