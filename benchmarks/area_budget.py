"""Where a packing's art area goes between the simulation and the output (issue 41).

The simulation ends with meshes that cover some share of the container; the art mapped
through them covers less (the skins' band and the elements' bays); the verification then
bends contacts apart (``verify.dent``) and moves, shrinks or drops what still breaks a
promise. This script packs the paper's heart with the animals (or any container and
elements given), without pocket copies, and prints, per seed, the area fraction after each
of those stages and the elements the repair shrank::

    python benchmarks/area_budget.py --seeds 1 2 3            # heart, 30 animals, gap 5.2
    python benchmarks/area_budget.py --container C.svg --elements DIR --gap G --count N

It watches the stages by wrapping ``repulsionpak.pack``'s own references to
``placed_art`` and ``verify_and_repair`` (the packing itself is unchanged). Nothing is
written into the repository.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path

import numpy as np

import repulsionpak
from repulsionpak.params import Params

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def budget(container, elements, gap: float, count: int, seed: int) -> dict:
    """One packing's area fractions: meshes, mapped art, after the dents, output."""
    pack_module = importlib.import_module("repulsionpak.pack")
    seen: dict = {}
    placed_art, verify = pack_module.placed_art, pack_module.verify_and_repair

    def watch_placed(templates, model, state, frame, elements=None, params=None):
        seen["meshes"] = float(state.areas.sum()) * frame.unit ** 2
        out = placed_art(templates, model, state, frame, elements=elements, params=params)
        seen["mapped"] = sum(q.art.area for q in out)
        return out

    def watch_verify(placed, *args, **kwargs):
        seen["dented"] = sum(q.art.area for q in placed)
        out = verify(placed, *args, **kwargs)
        seen["shrunk"] = sorted(s for s in out[1].shrunk.values() if s < 0.999)
        return out

    pack_module.placed_art, pack_module.verify_and_repair = watch_placed, watch_verify
    try:
        params = Params(gap=gap, seed=seed).with_(placement__count=count, secondary__auto=False)
        packing = repulsionpak.pack(container, elements, params)
    finally:
        pack_module.placed_art, pack_module.verify_and_repair = placed_art, verify
    area = packing.container.region.area
    return {"seed": seed, "meshes": seen["meshes"] / area, "mapped": seen["mapped"] / area,
            "dented": seen["dented"] / area, "output": sum(q.art.area for q in packing.placed) / area,
            "shrunk": seen["shrunk"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--container", type=Path, default=SHARED / "containers" / "heart.svg")
    ap.add_argument("--elements", type=Path, default=SHARED / "animals")
    ap.add_argument("--gap", type=float, default=5.2)
    ap.add_argument("--count", type=int, default=30)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    a = ap.parse_args()
    if not a.container.exists() or not a.elements.exists():
        sys.exit(f"{a.container} or {a.elements} not found (the paper's data lives in ../shared/data)")
    rows = [budget(a.container, [a.elements], a.gap, a.count, s) for s in a.seeds]
    print("| seed | meshes | art mapped | after the dents | output | shrunk by the repair (scale) |")
    print("| ---: | ---: | ---: | ---: | ---: | --- |")
    for r in rows:
        shrunk = ", ".join(f"{s:.3f}" for s in r["shrunk"]) or "none"
        print(f"| {r['seed']} | {r['meshes']:.4f} | {r['mapped']:.4f} | {r['dented']:.4f} | {r['output']:.4f} | "
              f"{len(r['shrunk'])}: {shrunk} |")
    keys = ("meshes", "mapped", "dented", "output")
    print("| mean | " + " | ".join(f"{np.mean([r[k] for r in rows]):.4f}" for k in keys) + " | |")


if __name__ == "__main__":
    main()
