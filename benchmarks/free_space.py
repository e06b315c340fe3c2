"""Where a packing's negative space is: could more art fit, or only bent art?

Reads packings written by ``repulsionpak pack`` (their art as written, flattened as
``repulsionpak evaluate`` does) and splits the container's area into

* the art,
* the *rings*: the band within half a gap of some art (two neighbours a gap apart share
  it exactly; no packing at that gap can use it),
* the margin band (within half a gap of the container's edge, where the margin keeps
  the art out),
* the *free space*: the rest, where neighbours stand more than a gap apart.

For the free space it prints the *clearance* distribution: the distance from a point of
it to the nearest ring, margin band or art-free edge, in gaps (a grid of ``--grid``
points per side). One more element of size s needs clearance above s/2; free space that
is all thin slivers (clearance well under a gap) can only be closed by bending the
neighbours into it, not by adding art.

    python benchmarks/free_space.py heart.svg --container ../shared/data/containers/heart.svg

(``--container`` re-reads the container from its own file, finely flattened, as the
contract's measurements do; without it, from the packing.) Nothing is written.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
import shapely

from repulsionpak.io import load_container
from repulsionpak.io import read_packing_svg


def free_space(svg: str, container: str | None = None, grid: int = 400) -> dict:
    cont, placed, info = read_packing_svg(svg)
    gap = info["gap"]
    if gap is None:
        raise SystemExit(f"{svg}: no data-gap; not a packing written by repulsionpak")
    if container:
        cont = load_container(container, tolerance=gap / 2000)
    region = cont.region
    area = region.area
    arts = [p.art for p in placed if not p.art.is_empty]
    art = sum(a.area for a in arts)
    half = 0.5 * gap
    covered = shapely.union_all([a.buffer(half) for a in arts])
    inner = region.buffer(-half)  # the margin band is outside this
    free = inner.difference(covered)
    # clearance of free points: distance to the free space's boundary (rings, margin band)
    x0, y0, x1, y1 = region.bounds
    xs, ys = np.linspace(x0, x1, grid), np.linspace(y0, y1, grid)
    pts = shapely.points(*(c.ravel() for c in np.meshgrid(xs, ys)))
    inside = shapely.contains(free, pts)
    clearance = shapely.distance(pts[inside], shapely.boundary(free)) / gap
    cuts = (0.25, 0.5, 1.0, 2.0)
    return {
        "file": svg, "elements": len(arts), "gap": gap,
        "art": art / area,
        "rings": (covered.intersection(region).area - art) / area,
        "margin_band": region.difference(inner).difference(covered).area / area,
        "free": free.area / area,
        "clearance_max": float(clearance.max(initial=0.0)),
        "clearance_above": {c: float(np.mean(clearance > c)) if len(clearance) else 0.0 for c in cuts},
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("packings", nargs="+", help="packing SVGs written by repulsionpak pack")
    ap.add_argument("--container", help="the container file, re-read finely flattened")
    ap.add_argument("--grid", type=int, default=400, help="clearance sample points per side")
    a = ap.parse_args()
    print("| packing | elements | art | half-gap rings | margin band | free | free with clearance "
          "> 0.25 / 0.5 / 1 / 2 gaps | largest clearance (gaps) |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | --- | ---: |")
    for svg in a.packings:
        r = free_space(svg, a.container, a.grid)
        above = " / ".join(f"{100 * v:.0f}%" for v in r["clearance_above"].values())
        print(f"| {svg} | {r['elements']} | {r['art']:.3f} | {r['rings']:.3f} | {r['margin_band']:.3f} | "
              f"{r['free']:.3f} | {above} | {r['clearance_max']:.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
