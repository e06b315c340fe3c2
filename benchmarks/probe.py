"""Random scenes beyond both suites: look for a broken promise where nobody looked yet.

Each scene combines the suites' own element kinds (plus glyphs, most of which neither
suite uses, and the probe kinds of :mod:`scenes` no suite uses: a bullseye
with a disc in its hole, three separate dots, a spiral, a comb, a lightning bolt, stroked
line art) with one of their containers (or a crescent, a cross, a target with a disc in
its ring), a gap of 0.5–3 % of the container, 5–100
primaries and a drawing scale of 0.01×–100×, all drawn from ``--seed``; each is packed
and measured exactly as ``benchmarks/contract.py`` does (``scenes.run_scene``, then the
seven promises). This is how 5-pointed stars at a 0.5 % gap (Q_s(gap/2)/Q_s(0)
0.46–0.48, fixed by the smaller pockets' fill, docs/algorithm.md) were found.

    python benchmarks/probe.py --count 12 --seed 7 --jobs 2 [--json out.json]
    python benchmarks/probe.py --seed 5 --gaps 0.005 --counts 5,10   # one corner

Prints one line per scene (promises broken, if any) and exits 1 when any scene broke one.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import json
import multiprocessing
import random
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import contract  # noqa: E402  (benchmarks/contract.py: the suite's own measuring code)

EXTRA_GLYPHS = "AbEFhkPtwZ?#5"


def random_scenes(count: int, seed: int, gaps=None, counts=None):
    """``count`` random scenes (names ``rp<seed>-<i>``, packing seeds 1000 + i); ``gaps``
    and ``counts``, when given, replace the lists the gap and the number of primaries are
    drawn from (to search one corner, e.g. few primaries at a fine gap)."""
    from scenes import CONTAINER_KINDS, ELEMENT_KINDS, Scene

    rnd = random.Random(seed)
    kinds = list(ELEMENT_KINDS) + [f"glyph-{c}" for c in EXTRA_GLYPHS]
    out = []
    for i in range(count):
        els = tuple(rnd.sample(kinds, rnd.choice([1, 1, 2, 3, 5])))
        container = rnd.choice(CONTAINER_KINDS)
        gap = rnd.choice(gaps or [0.005, 0.008, 0.01, 0.015, 0.02, 0.03])
        if counts:
            n = rnd.choice(counts)
        else:
            n = rnd.choice([5, 10, 25, 40, 60, 100]) if gap < 0.02 else rnd.choice([5, 10, 20, 30])
        scale = rnd.choice([0.01, 0.1, 1, 1, 1, 10, 100])
        out.append(Scene(f"rp{seed}-{i}", container, els, gap=gap, count=n, seed=1000 + i, scale=scale))
    return out


def run_one(scene, workdir: str) -> dict:
    """Pack and measure one scene (in a worker process) as the suites do; never raises."""
    return contract.measure_scene(scene, workdir)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=12, help="number of random scenes")
    ap.add_argument("--seed", type=int, default=7, help="seed of the scene draw")
    ap.add_argument("--jobs", type=int, default=1, help="scenes packed at the same time (processes)")
    ap.add_argument("--workdir", type=Path, default=None, help="keep the scenes and packings here")
    ap.add_argument("--json", type=Path, default=None, help="write every scene's numbers here")
    ap.add_argument("--gaps", default=None, help="comma-separated gaps (fractions of the container) to draw from")
    ap.add_argument("--counts", default=None, help="comma-separated numbers of primaries to draw from")
    args = ap.parse_args(argv)
    if args.count < 1 or args.jobs < 1:
        ap.error("--count and --jobs must be at least 1")
    import tempfile

    tmp = None
    if args.workdir is None:
        tmp = tempfile.TemporaryDirectory(prefix="repulsionpak-probe-")
        workdir = tmp.name
    else:
        args.workdir.mkdir(parents=True, exist_ok=True)
        workdir = str(args.workdir)
    try:
        gaps = [float(g) for g in args.gaps.split(",")] if args.gaps else None
        counts = [int(c) for c in args.counts.split(",")] if args.counts else None
    except ValueError:
        ap.error("--gaps takes numbers and --counts whole numbers, separated by commas")
    chosen = random_scenes(args.count, args.seed, gaps, counts)
    results, broken = [], 0
    ctx = multiprocessing.get_context("spawn")
    with cf.ProcessPoolExecutor(args.jobs, mp_context=ctx, initializer=contract._init_worker) as pool:
        futures = {pool.submit(run_one, s, workdir): s for s in chosen}
        for f in cf.as_completed(futures):
            s, r = futures[f], f.result()
            results.append(r)
            bad = [k for k, v in contract.promise_status(r).items() if v is False]
            if r.get("error"):
                bad.append("error")
            broken += bool(bad)
            line = (f"{s.name}: {s.container}, {'+'.join(s.elements)}, gap {s.gap:g}, {s.count} primaries, "
                    f"scale {s.scale:g}")
            if r.get("error"):
                print(f"{line}: ERROR {r['error'].splitlines()[0]}", flush=True)
            else:
                print(f"{line}: Q_s ratio {r['scp_ratio']:.3f}, median gap {r['gap_median_rel']:.2f}, "
                      f"p10 {r['gap_p10_rel']:.2f}, distortion p95 {r['distortion_p95']:.3f}"
                      + (f"  BROKEN: {', '.join(bad)}" if bad else ""), flush=True)
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=1, default=str))
    print(f"{len(chosen) - broken}/{len(chosen)} scenes keep every promise")
    if tmp is not None:
        tmp.cleanup()
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
