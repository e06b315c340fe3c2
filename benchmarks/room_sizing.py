"""Size follows the space (issue 41 part 2): primaries only, with and without
``placement.follow_room``, on procedurally drawn uneven containers and the suite's
two-region scenes.

    python benchmarks/room_sizing.py                       # every scene, seeds 1-3, both policies
    python benchmarks/room_sizing.py --scenes archipelago --seeds 1-3 --elements animals
    python benchmarks/room_sizing.py --scenes thin-two     # a suite scene (its own gap, count, seed)

Region scenes (``region_scenes``: archipelago, band, country; container seed =
packing seed) are packed at a gap of 1.5 % of the container's width (1000 units: gap 15),
default count, with the paper's animals (``../shared/data/animals``; ``--elements
examples`` for the shipped library). Every run is ``repulsionpak pack ... --no-pocket-fill``
(primaries only) through :func:`repulsionpak.cli.run_pack`, measured with
``repulsionpak evaluate`` on the written SVG. Prints a markdown table. One run at a time, on one
numba thread (``REPULSIONPAK_THREADS=1`` unless set): the A/B comparisons are then exact.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from importlib import resources
from pathlib import Path

from region_scenes import REGION_KINDS, container_svg
from scenes import suite, write_suite

ANIMALS = Path(__file__).resolve().parents[2] / "shared" / "data" / "animals"


def seeds_of(text: str) -> list[int]:
    a, _, b = text.partition("-")
    return list(range(int(a), int(b or a) + 1))


def run(container: Path, elements: list[Path], gap: float, seed: int, count: int | None, follow: bool,
        work: Path) -> dict:
    tag = f"{container.stem}-{seed}-{'room' if follow else 'paper'}"
    cfg = work / f"{tag}.toml"
    cfg.write_text(f"[placement]\nfollow_room = {'true' if follow else 'false'}\n")
    out = work / f"{tag}.svg"
    cmd = ["repulsionpak", "pack", str(container), *map(str, elements), "--gap", f"{gap:g}", "--seed", str(seed),
           "--no-pocket-fill", "--config", str(cfg), "-o", str(out), "--report", str(work / f"{tag}.json"),
           "--quiet"]
    if count is not None:
        cmd += ["--count", str(count)]
    env = dict(os.environ, REPULSIONPAK_THREADS=os.environ.get("REPULSIONPAK_THREADS", "1"))
    subprocess.run(["nice", "-n", "10", *cmd], check=False, env=env)
    ev = json.loads(subprocess.run(["repulsionpak", "evaluate", str(out), "--json"], capture_output=True,
                                   text=True, check=True).stdout)
    rep = json.loads((work / f"{tag}.json").read_text())
    return {"n": ev["n_primary"], "area": ev["area_fraction"], "q": ev["scp_ratio"],
            "median": ev["gap"]["median"] / gap, "p10": ev["gap"]["p10"] / gap,
            "edge": ev["edge"]["min"] / gap, "overlap": ev["overlap_area"],
            "dist": rep["distortion"]["p95"], "s": rep["seconds"]["total"]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", action="append", help="archipelago|band|country|a suite scene name (repeatable)")
    ap.add_argument("--seeds", default="1-3")
    ap.add_argument("--elements", choices=("animals", "examples"), default="animals")
    ap.add_argument("--policies", default="paper,room")
    args = ap.parse_args(argv)
    names = args.scenes or [*REGION_KINDS, "thin-two", "letters-two-x100", "convex-two-300"]
    els = [ANIMALS] if args.elements == "animals" else [Path(str(resources.files("repulsionpak.examples")
                                                                  / "elements"))]
    by_name = {s.name: s for s in suite()}
    print("| scene | seed | policy | primaries | art area | Q_s(gap/2)/Q_s(0) | median gap/gap | p10 | "
          "min edge/gap | overlap | distortion p95 | seconds |")
    print("| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for name in names:
            for seed in seeds_of(args.seeds):
                if name in REGION_KINDS:
                    c = work / f"{name}{seed}.svg"
                    c.write_text(container_svg(name, seed))
                    jobs = (c, els, 15.0, seed, None)
                elif name in by_name:
                    sc = by_name[name]
                    if seed != seeds_of(args.seeds)[0]:
                        continue
                    files = write_suite([sc], work / name)[0]
                    jobs = (files.container, list(files.elements), files.gap, sc.seed, sc.count)
                else:
                    print(f"unknown scene {name}", file=sys.stderr)
                    return 2
                for pol in args.policies.split(","):
                    r = run(*jobs, follow=(pol == "room"), work=work)
                    print(f"| {name} | {jobs[3]} | {pol} | {r['n']} | {r['area']:.3f} | {r['q']:.3f} | "
                          f"{r['median']:.2f} | {r['p10']:.2f} | {r['edge']:.3f} | {r['overlap']:.2g} | "
                          f"{r['dist']:.3f} | {r['s']:.1f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
