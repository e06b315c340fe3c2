"""A detailed line-art logo as the container: the time of each stage (docs/benchmarks.md).

Simple Icons' Gutenberg mark (54 thin-stroked regions, 45,000 boundary segments at a run's
flattening) holding six Material Design icons, default settings: the default gap follows
the strokes' width, so the run packs about 1,000 primaries and 2,000 pocket copies, and
nearly every grid point and every element lies near the container's edge::

    python benchmarks/detailed_container.py                 # the installed repulsionpak
    python benchmarks/detailed_container.py --runs 2 --out /tmp/gutenberg

The art comes from the pinned npm packages of ``benchmarks/realworld.py`` (downloaded once
into its cache, ``~/.cache/repulsionpak-realworld``; never committed). Prints one Markdown
row: wall time, the report's seconds per stage, the elements and the peak memory.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import realworld  # noqa: E402

ICONS = ("music-accidental-double-sharp", "spider-outline", "shape-oval-plus", "power-plug-battery",
         "generator-stationary", "image")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", type=Path, help="keep the packings here (default: a temporary folder)")
    ap.add_argument("--cache", type=Path, default=Path.home() / ".cache" / "repulsionpak-realworld")
    a = ap.parse_args(argv)
    container = realworld.package_dir(a.cache, "simple") / "package" / "icons" / "gutenberg.svg"
    mdi = realworld.package_dir(a.cache, "mdi") / "package" / "svg"
    elements = [str(mdi / f"{n}.svg") for n in ICONS]
    out = a.out or Path(tempfile.mkdtemp())
    out.mkdir(parents=True, exist_ok=True)
    print("| run | wall s | preprocess | primary | secondary | verify | render | leftover | elements | peak RSS |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for k in range(a.runs):
        svg, rep = out / f"gutenberg{k}.svg", out / f"gutenberg{k}.json"
        cmd = [sys.executable, "-m", "repulsionpak.cli", "pack", str(container), *elements, "-o", str(svg),
               "--report", str(rep), "--seed", str(a.seed), "-q"]
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, stderr=subprocess.DEVNULL)
        wall = time.perf_counter() - t0
        peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        r = json.loads(rep.read_text())
        s = r["seconds"]
        print(f"| {k + 1} | {wall:.1f} | {s['preprocess']:.1f} | {s['primary']:.1f} | {s.get('secondary', 0):.1f} "
              f"| {s['verify']:.1f} | {s['render']:.1f} | {s.get('leftover', 0):.1f} "
              f"| {r['n_primary']:,} + {r['n_secondary']:,} | {peak:.0f} MB |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
