"""Guide strokes: every path of a guide SVG, flattened to a polyline in the direction it
is drawn (its direction is the direction of travel)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..errors import InputError


def load_guides(path: str | Path) -> list[np.ndarray]:
    """The guide strokes of an SVG file.

    Parameters
    ----------
    path : path
        An SVG file in the container's user units (draw the guides on a copy of the
        container's file). Every visible path, line, polyline and shape (one with a
        stroke or a fill, as the element reader sees it) is a guide.

    Returns
    -------
    list of (K, 2) float arrays
        One polyline per subpath, K >= 2, in drawing order (closed shapes end where they
        begin).

    Raises
    ------
    InputError
        The file cannot be read as SVG, or holds no stroke of two distinct points.

    Notes
    -----
    The file is read with the project's SVG reader (:func:`repulsionpak.io.load_element`),
    so transforms, units, ``<use>`` and basic shapes behave as for elements; the reader's
    warning about thin line work is meant for elements and is silenced here.
    """
    from ..io import load_element  # noqa: PLC0415

    path = Path(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            element = load_element(path)
        except InputError as exc:
            if "no visible geometry" in exc.problem:
                raise InputError(path, "the flow guides hold no visible path: draw at least one stroke "
                                 "(a path with a stroke or a fill)") from None
            raise InputError(path, f"cannot read the flow guides: {exc.problem}") from None
    strokes: list[np.ndarray] = []
    for art in element.paths:
        for sub, closed in zip(art.subpaths, art.closed):
            pts = np.asarray(sub, dtype=float)
            if closed and len(pts) > 2 and not np.allclose(pts[0], pts[-1]):
                pts = np.vstack([pts, pts[:1]])
            keep = np.r_[True, np.hypot(*np.diff(pts, axis=0).T) > 0]
            pts = pts[keep]
            if len(pts) >= 2:
                strokes.append(pts)
    if not strokes:
        raise InputError(path, "the flow guides hold no stroke: draw at least one path of two distinct points")
    return strokes


__all__ = ["load_guides"]
