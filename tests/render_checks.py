"""Checks the reader tests share: an element compared with resvg pixel by pixel, and a few
copies of an element packed through the CLI and read back."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import shapely

from repulsionpak.art_area import art_area

CIRCLE = Path(__file__).resolve().parents[1] / "src" / "repulsionpak" / "examples" / "containers" / "circle.svg"


def resvg_mask(path: Path, width: int, height: int, **options) -> np.ndarray:
    """Where resvg draws ``path`` (alpha > 0.5) at ``width`` × ``height`` pixels."""
    import matplotlib.image as mpimg
    import resvg_py

    png = bytes(resvg_py.svg_to_bytes(svg_path=str(path), width=width, height=height, **options))
    return mpimg.imread(io.BytesIO(png), format="png")[..., 3] > 0.5


def our_mask(paths, width: int, height: int, scale: float) -> np.ndarray:
    """Where the art ``paths`` is, sampled at the pixel centres of the same grid."""
    X, Y = np.meshgrid((np.arange(width) + 0.5) / scale, (np.arange(height) + 0.5) / scale)
    return shapely.contains_xy(art_area(paths), X, Y)


def differs_only_along_edges(ref: np.ndarray, ours: np.ndarray) -> tuple[bool, int, int]:
    """(ok, differing pixels, edge pixels of ``ref``): ok when at most half as many pixels
    differ as lie along the reference's edges (anti-aliasing, flattening)."""
    diff = np.count_nonzero(ref ^ ours)
    edge = np.count_nonzero(ref ^ np.roll(ref, 1, 0)) + np.count_nonzero(ref ^ np.roll(ref, 1, 1))
    return diff <= 0.5 * edge, diff, edge


def pack_copies(element: Path, out: Path, count: int, gap: float = 10.0) -> list:
    """``count`` copies of ``element`` packed by ``repulsionpak pack`` in the example circle
    (100 iterations: grown to about twice their placed size, before they jam; seed 1, no
    pocket fill), read back from ``out``."""
    from typer.testing import CliRunner

    from repulsionpak.cli import app
    from repulsionpak.io import read_packing_svg

    res = CliRunner().invoke(app, ["pack", str(CIRCLE), str(element), "-o", str(out), "--count", str(count),
                                   "--max-iterations", "100", "--gap", f"{gap:g}", "--seed", "1", "-q",
                                   "--no-pocket-fill"])
    assert res.exit_code == 0, res.stderr
    return read_packing_svg(out)[1]
