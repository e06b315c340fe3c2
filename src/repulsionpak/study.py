"""The paper's deformation study (sec. 11, Fig. 10): how the spring strength k_e changes
the evenness of the negative space, measured by the spherical contact probability."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np

from .evaluate import evaluate
from .pack import pack
from .params import Params
from .types import Container, Element


def deformation_study(container: Container, elements: Sequence[Element], gap: float,
                      k_values: Sequence[float] = (10.0, 250.0, 1000.0), runs: int = 10,
                      count_range: tuple[int, int] = (23, 27), seed: int = 0, base: Params = Params(),
                      on_run: Callable[[float, int, dict], None] | None = None) -> dict:
    """Pack ``runs`` random packings per spring strength k_e and measure each.

    As in the paper: every packing uses a random count of primary elements in
    ``count_range`` and no secondary elements; run i of every k_e uses the same seed, so
    the groups differ only by k_e (k_e is in the paper's units, like the defaults).

    Returns ``{"gap": gap, "groups": {"k_e=10": [evaluate() result, ...], ...},
    "summary": {label: {"area_fraction": mean, "scp_ratio": mean, "scp_ratio_std": std,
    "deformation": mean}}}``.
    """
    if runs < 1:
        raise ValueError("runs must be >= 1")
    groups: dict[str, list[dict]] = {}
    for k_e in k_values:
        label = f"k_e={k_e:g}"
        groups[label] = []
        for i in range(runs):
            rng = np.random.default_rng([seed, i])
            count = int(rng.integers(count_range[0], count_range[1] + 1))
            p = dataclasses.replace(
                base, gap=gap, seed=int(rng.integers(2**31)),
                sim=dataclasses.replace(base.sim, k_edge=float(k_e)),
                placement=dataclasses.replace(base.placement, count=count))
            packing = pack(container, elements, p)
            result = evaluate(container, packing.placed, gap)
            result["iterations"] = packing.iterations["primary"]
            groups[label].append(result)
            if on_run is not None:
                on_run(k_e, i, result)
    summary = {}
    for label, res in groups.items():
        ratios = np.array([r["scp_ratio"] for r in res], dtype=float)
        summary[label] = {
            "area_fraction": float(np.mean([r["area_fraction"] for r in res])),
            "scp_ratio": float(np.mean(ratios)), "scp_ratio_std": float(np.std(ratios)),
            "deformation": float(np.mean([r["deformation"]["mean"] or 0.0 for r in res])),
            "overlap_area": float(np.max([r["overlap_area"] for r in res])),
        }
    return {"gap": gap, "groups": groups, "summary": summary}
