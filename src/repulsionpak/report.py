"""What a packing's report holds (``repulsionpak pack --report``, :meth:`Packing.report`)."""

from __future__ import annotations

from .inputs import margin_of


def report_dict(packing, metrics: dict, seconds: dict | None = None, not_written=(),
                movie: dict | None = None) -> dict:
    """The report of a packing, a JSON-serialisable dict.

    Parameters
    ----------
    packing : Packing
    metrics : dict
        :meth:`Packing.metrics` with the distortion.
    seconds : dict, optional
        The run's times (default: ``packing.seconds``, the stages' own).
    not_written : sequence of str
        Outputs a stop left out: listed as ``not_written``, and ``stopped_by`` gains
        ``"outputs": "interrupted"``.
    movie : dict, optional
        The movie written (file, frames, fps, seconds, bytes, every).

    Returns
    -------
    dict
        ``n_primary``, ``n_secondary``, ``n_vertices``, ``iterations``, ``seconds``,
        ``area_fraction``, ``overlap_area``, ``gap``, ``gap_stats``, ``seed``,
        ``outside_area``, ``edge``, ``distortion``, the primaries' own measures,
        ``moves`` (kept and undone moves into voids), ``partial``, ``stopped_by``,
        ``invariants``, ``inputs`` and ``params`` (as resolved for the run: its gap and
        margin).
    """
    params, g = packing.asked or packing.params, packing.gap
    rep = {
        "n_primary": packing.n_primary, "n_secondary": packing.n_secondary,
        "n_vertices": int(packing.model.n_vertices),
        "iterations": dict(packing.iterations),
        "seconds": dict(packing.seconds) if seconds is None else seconds,
        "area_fraction": metrics["area_fraction"], "overlap_area": metrics["overlap_area"],
        "gap": g, "gap_stats": metrics["gap"], "seed": params.seed,
        "outside_area": metrics["outside_area"], "edge": metrics["edge"],
        "distortion": metrics["distortion"],
        # the primaries without the pocket copies, and the smallest copy (evaluate())
        **{k: metrics[k] for k in ("area_fraction_primary", "scp_ratio_primary", "median_primary_size",
                                   "smallest_secondary_rel")},
        # the primaries moved into voids where the run converged (sim.relocations)
        # (an undone move's iterations are not in ``iterations``: the run went on from before it)
        "moves": {"kept": sum(1 for m in packing.moves if m[2]),
                  "undone": sum(1 for m in packing.moves if not m[2]),
                  "undone_iterations": sum(m[3] for m in packing.moves if not m[2])},
        "partial": packing.partial,
        "stopped_by": dict(packing.stopped_by, **({"outputs": "interrupted"} if not_written else {})),
        "invariants": packing.checks(metrics),
        "inputs": {k: packing.sources.get(k, default) for k, default in
                   (("container", packing.container.source), ("elements", []), ("secondary", []))},
        "params": dict(params.to_dict(), gap=g, margin=margin_of(params, g)),
    }
    if movie is not None:
        rep["movie"] = movie
    if not_written:
        rep["not_written"] = list(not_written)
    return rep


__all__ = ["report_dict"]
