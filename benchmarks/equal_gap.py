"""Issue 10, item 4: the art area of the current code at the gap an older version actually produced.

An older version asked for gap g left a median art-to-art distance m < g (its skins
were squeezed and allowed to overlap). Its area fraction is only comparable with the
current code's at the same *produced* gap: this script packs each scene with the old
version at g, measures m on the art, packs it again with the current code asking for m,
and prints both (markdown table).

    git worktree add /tmp/old 26bc07e --detach          # the code issue 10 was filed against
    python -m venv --system-site-packages /tmp/oldvenv && /tmp/oldvenv/bin/pip install triangle
    python benchmarks/equal_gap.py --old-src /tmp/old/src --old-python /tmp/oldvenv/bin/python \\
        --out-dir /tmp/equal-gap heart convex-circle stars-circle ...

``heart`` is the paper's scene (../shared/data, gap 5.2, seed 1); other names are scenes of
:func:`scenes.suite` or :func:`scenes.holdout_suite`. Nothing here
writes into the repository.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import scenes
from repulsionpak import pack
from repulsionpak.measure import evaluate_file
from repulsionpak.io import load_elements
from repulsionpak.params import Params

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def old_pack(args, container, elements, out, gap, seed, count) -> float:
    """Run the old version's CLI; returns its wall time."""
    cmd = [args.old_python, "-c", "from repulsionpak.cli import app; app()", "pack", str(container),
           *map(str, elements), "-o", str(out), "--gap", repr(gap), "--seed", str(seed), "-q"]
    if count:
        cmd += ["--count", str(count)]
    env = dict(os.environ, PYTHONPATH=str(args.old_src), REPULSIONPAK_NO_WARMUP="1")
    t = time.perf_counter()
    r = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"old version failed ({r.returncode}): {r.stderr[-400:]}")
    return time.perf_counter() - t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="+", help="'heart' or names from scenes.suite() or "
                    "holdout_suite()")
    ap.add_argument("--old-src", type=Path, required=True, help="src/ folder of the old checkout")
    ap.add_argument("--old-python", default=sys.executable, help="Python with the old version's dependencies")
    ap.add_argument("--out-dir", type=Path, required=True)
    args = ap.parse_args(argv)
    suite = {s.name: s for s in scenes.suite() + scenes.holdout_suite()}
    print("| scene | asked gap | old: median gap / asked | old: area | old: art overlap | "
          "new, asked the old median: median / asked | new: area | new: art overlap |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for name in args.scenes:
        wd = args.out_dir / name
        wd.mkdir(parents=True, exist_ok=True)
        if name == "heart":
            cont, elems, gap, seed, count = (SHARED / "containers" / "heart.svg", [SHARED / "animals"], 5.2, 1, None)
            sources = load_elements(elems)

            def measure(svg, g):
                return evaluate_file(svg, gap=g, grid=600, sources=sources)
        else:
            s = suite[name]
            files = s.write(wd)
            cont, elems, gap, seed, count = files.container, list(files.elements), files.gap, s.seed, s.count

            def measure(svg, g, files=files):
                return scenes.measure(files, svg)
        old_pack(args, cont, elems, wd / "old.svg", gap, seed, count)
        old = measure(wd / "old.svg", gap)
        m = old["gap"]["median"]
        if not m > 0.05 * gap:  # half the old copies (nearly) touch or overlap a neighbour: no gap to ask for
            print(f"| {name} | {gap:.4g} | {m / gap:.3f} | {old['area_fraction']:.3f} | "
                  f"{old['overlap_area']:.3g} | — | — | — |", flush=True)
            continue
        params = Params().with_(gap=m, seed=seed)
        if count is not None:
            params = params.with_(placement__count=count)
        pack(cont, elems, params).save(wd / "new.svg")  # the bytes `repulsionpak pack` writes
        new = measure(wd / "new.svg", m)
        (wd / "result.json").write_text(json.dumps({"scene": name, "gap": gap, "old": old, "new": new},
                                                   indent=1, default=str))
        print(f"| {name} | {gap:.4g} | {m / gap:.3f} | {old['area_fraction']:.3f} | {old['overlap_area']:.3g} | "
              f"{new['gap']['median'] / m:.3f} | {new['area_fraction']:.3f} | {new['overlap_area']:.3g} |",
              flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
