"""The promises a packing keeps, checked on an evaluation: :func:`check_promises`.

Gap median and 10th percentile, zero overlap, nothing outside, the edge margin, the
distortion's 95th percentile per element category and Q_s(gap/2)/Q_s(0), each against a
limit of :class:`ContractLimits` (dimensionless: relative to the gap or the container's
area), measured on the art alone by :func:`repulsionpak.measure.evaluate`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["ContractLimits", "check_promises", "limits_dict"]


@dataclass(frozen=True)
class ContractLimits:
    """The promises (all dimensionless, relative to the gap or the container)."""

    gap_median_low: float = 0.9  # × gap: lowest allowed median nearest-neighbour art distance
    gap_median_high: float = 1.1  # × gap: highest allowed median
    gap_p10: float = 0.8  # × gap: lowest allowed 10th percentile
    overlap: float = 1e-6  # × container area: largest allowed total art–art overlap
    outside: float = 1e-6  # × container area: largest allowed art area outside the container
    margin: float = 0.5  # × gap: the art's promised distance from the container's edge
    margin_tolerance: float = 0.98  # an element fails the margin when closer than this × margin
    distortion_convex: float = 0.08  # largest p95 distortion of convex elements
    distortion_other: float = 0.15  # largest p95 distortion of spiky, thin, holed and letter elements
    scp_ratio: float = 0.45  # largest Q_s(gap/2) / Q_s(0)

    def distortion_limit(self, category: str) -> float:
        return self.distortion_convex if category == "convex" else self.distortion_other


def check_promises(result: Mapping, categories: Mapping[str, str] | None = None,
                   limits: ContractLimits = ContractLimits(),
                   sources: Sequence[str] | None = None) -> dict:
    """The promises on an :func:`repulsionpak.measure.evaluate` result.

    ``categories`` maps a ``data-source`` name to its category (``convex`` /
    ``spiky`` / ``thin`` / ``holed`` / ``letter``); ``sources[i]`` is element i's
    ``data-source`` (needed for per-category distortion; without them every element
    counts as non-convex). Returns ``{promise: {"ok": bool | None, "value": ..., "limit":
    ...}}`` for ``gap_median``, ``gap_p10``, ``overlap``, ``outside``, ``edge_margin``,
    ``distortion`` (one entry per category present) and ``scp_ratio``, plus ``"all"``:
    True when every promise that could be measured holds. ``ok`` is ``None`` when the
    metric is missing (e.g. no SCP computed, fewer than two elements).
    """
    gap = float(result["gap"]["requested"])
    area = float(result["container_area"])
    out: dict = {}

    def put(name, value, ok, limit):
        out[name] = {"ok": None if ok is None else bool(ok), "value": value, "limit": limit}

    med, p10 = result["gap"].get("median"), result["gap"].get("p10")
    put("gap_median", None if med is None else med / gap,
        None if med is None else limits.gap_median_low <= med / gap <= limits.gap_median_high,
        [limits.gap_median_low, limits.gap_median_high])
    put("gap_p10", None if p10 is None else p10 / gap,
        None if p10 is None else p10 / gap >= limits.gap_p10, limits.gap_p10)
    ov = float(result["overlap_area"]) / area
    put("overlap", ov, ov <= limits.overlap, limits.overlap)
    oa = result.get("outside_area")
    put("outside", None if oa is None else oa / area, None if oa is None else oa / area <= limits.outside,
        limits.outside)
    edge = result.get("edge") or {}
    emin = edge.get("min")
    put("edge_margin", None if emin is None else emin / (limits.margin * gap),
        None if emin is None else emin >= limits.margin_tolerance * limits.margin * gap,
        limits.margin_tolerance)
    dist = (result.get("distortion") or {}).get("values") or []
    groups: dict[str, list[float]] = {}
    for i, d in enumerate(dist):
        if d is None:
            continue
        name = sources[i] if sources is not None else None
        cat = (categories or {}).get(name, "other") if name is not None else "other"
        groups.setdefault(cat, []).append(float(d))
    for cat, vals in sorted(groups.items()):
        p95 = float(np.percentile(vals, 95))
        lim = limits.distortion_limit(cat)
        put(f"distortion_{cat}", p95, p95 <= lim, lim)
    ratio = result.get("scp_ratio")
    put("scp_ratio", ratio, None if ratio is None else ratio <= limits.scp_ratio, limits.scp_ratio)
    known = [v["ok"] for v in out.values() if v["ok"] is not None]
    out["all"] = bool(known) and all(known)
    return out


def limits_dict(limits: ContractLimits = ContractLimits()) -> dict:
    """The limits as a plain dict (for reports)."""
    return asdict(limits)
