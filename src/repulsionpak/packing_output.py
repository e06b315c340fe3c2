"""What a finished packing turns into: its end-of-run checks and its SVG text.

Shared by ``repulsionpak pack`` (which writes the text to a file) and the batch workers
(which return it to the client), so a batch job's SVG is byte-identical to the one
``repulsionpak pack`` writes with the same inputs, options and seed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import shapely

from .io.svg_write import packing_svg_string


def invariants(packing, metrics: dict) -> dict:
    """End-of-run checks of sec. 5's goals, reported (never silently ignored).

    ``metrics`` is an :func:`repulsionpak.evaluate.evaluate` result of the packing
    (``overlap_area`` and ``n_outside`` are used).
    """
    skins = [shapely.Polygon(s) for s in packing.skins()]
    skins = [s if s.is_valid else shapely.make_valid(s) for s in skins]
    tree = shapely.STRtree(skins)
    a, b = tree.query(skins, predicate="intersects")
    pairs = [(i, j) for i, j in zip(a, b) if i < j]
    tol = 0.25 * packing.gap
    worst = 0.0
    for i, j in pairs:
        inter = shapely.intersection(skins[i], skins[j])
        if inter.area > 0:  # depth = diameter of the largest disc inside the overlap
            worst = max(worst, 2.0 * shapely.maximum_inscribed_circle(inter).length)
    x = packing.state.x * packing.frame.unit
    region = packing.container.region
    outside = ~shapely.contains_xy(shapely.buffer(region, tol), x[:, 0], x[:, 1])
    return {
        "skins_overlap_depth": float(worst),
        "skins_overlap_ok": bool(worst <= tol),
        "vertices_outside": int(np.count_nonzero(outside)),
        "vertices_inside_ok": bool(not outside.any()),
        "art_overlap_area": float(metrics["overlap_area"]),
        "art_overlap_ok": bool(metrics["overlap_area"] <= 1e-6 * packing.container.area),
        "elements_outside": int(metrics.get("n_outside", 0)),
        "tolerance": tol,
    }


def packing_svg_text(packing, metrics: dict, checks: dict, debug_layers: bool = False,
                     path: str | Path = "<output>") -> str:
    """The packing SVG of ``repulsionpak pack``: root ``data-seed``, ``data-iterations``
    and ``data-area-fraction``, the run's metadata (seed, stopping reasons, ``checks``
    from :func:`invariants`) and, with ``debug_layers``, hidden skin outlines.

    ``path`` only names the output in error messages.
    """
    seed = packing.params.seed
    attrs = {"seed": str(seed), "iterations": str(sum(packing.iterations.values())),
             "area-fraction": f"{metrics['area_fraction']:.4f}"}
    meta = {"generator": "repulsionpak", "seed": seed, "partial": packing.partial,
            "stopped_by": packing.stopped_by, "invariants": checks}
    debug = {"skins": packing.skins()} if debug_layers else None
    return packing_svg_string(packing.container, packing.placed, packing.gap, attrs=attrs,
                              debug_layers=debug, partial=packing.partial, metadata=meta, path=path)


__all__ = ["invariants", "packing_svg_text"]
