"""What a finished packing turns into: its end-of-run checks and its SVG text.

Shared by ``repulsionpak pack`` (which writes the text to a file) and the batch workers
(which return it to the client), so a batch job's SVG is byte-identical to the one
``repulsionpak pack`` writes with the same inputs, options and seed.
"""

from __future__ import annotations

from pathlib import Path

from .render.svg import packing_svg_string


def invariants(packing, metrics: dict) -> dict:
    """End-of-run checks of the promises, on the art as written (never silently ignored):
    the final verification (``verify.py``: overlap, outside, edge margin, gap floor) and the
    exact overlap area measured independently by ``evaluate``."""
    ver = packing.verification.to_dict() if packing.verification is not None else {}
    art_ok = bool(metrics["overlap_area"] <= 1e-9 * packing.container.area)
    return {
        **ver,
        "art_overlap_area": float(metrics["overlap_area"]),
        "art_overlap_ok": art_ok,
        "elements_outside": int(metrics.get("n_outside", 0)),
        "ok": bool(ver.get("ok", True) and art_ok and not metrics.get("n_outside", 0)),
    }


def packing_svg_text(packing, metrics: dict, checks: dict, debug_layers: bool = False,
                     path: str | Path = "<output>") -> str:
    """The packing SVG of ``repulsionpak pack``: root ``data-seed``, ``data-iterations``
    and ``data-area-fraction``, the run's metadata (seed, stopping reasons, ``checks``
    from :func:`invariants`) and, with ``debug_layers``, hidden skin outlines.

    The container is drawn as ``packing.params.output.container_paint`` says.
    ``path`` only names the output in error messages.
    """
    seed = packing.params.seed
    attrs = {"seed": str(seed), "iterations": str(sum(packing.iterations.values())),
             "area-fraction": f"{metrics['area_fraction']:.4f}"}
    meta = {"generator": "repulsionpak", "seed": seed, "partial": packing.partial,
            "stopped_by": packing.stopped_by, "invariants": checks}
    debug = {"skins": packing.skins()} if debug_layers else None
    return packing_svg_string(packing.container, packing.placed, packing.gap, attrs=attrs,
                              debug_layers=debug, partial=packing.partial, metadata=meta, path=path,
                              container_paint=container_paint_of(packing))


def container_paint_of(packing) -> str:
    """How ``packing``'s outputs draw its container (its parameters' ``output`` section)."""
    return packing.params.output.container_paint


def paint_warning(packing) -> str | None:
    """The warning to give when the container, drawn as-drawn, hides the art (see
    :func:`repulsionpak.render.container_paint.hiding_warning`); None otherwise."""
    from .render.container_paint import hiding_warning

    return hiding_warning(packing.container, packing.placed, container_paint_of(packing))


__all__ = ["container_paint_of", "invariants", "packing_svg_text", "paint_warning"]
