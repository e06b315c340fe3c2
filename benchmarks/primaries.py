"""Primaries alone: packings without pocket copies (``--no-pocket-fill``), measured from
their reports (not part of the test run).

    python benchmarks/primaries.py [--jobs 2] [--seeds 1 2] [--config C.toml]

Fourteen scenes by default: the shipped example elements, 20 in the shipped circle, cloud
and heart and 40 in the heart; the paper's nine animals (``../shared/data``, skipped when
absent), 25 in the shipped circle and 12 and 20 (the default count) in the paper's heart at
gap 5.2; each with seeds 1 and 2. ``--config`` passes a TOML file to every run (to compare a
setting against the defaults). Prints one Markdown row per run, then the means: art area,
Q_s(gap/2)/Q_s(0), median and p10 gap over the asked gap, the smallest edge distance over
the gap, the distortion p95 and the seconds.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
SHARED = HERE.parent.parent / "shared" / "data"
PACK = [str(Path(sys.executable).parent / "repulsionpak"), "pack"]


def scenes(seeds) -> list[tuple[str, list[str]]]:
    """(name, arguments of ``repulsionpak pack`` before ``-o``) of every run."""
    from repulsionpak import examples

    ex = examples.examples_dir()
    shipped = [str(f) for f in examples.element_files()]
    out = []
    for s in seeds:
        for c in ("circle", "cloud", "heart"):
            out.append((f"shipped-20-{c}-{s}", [str(ex / "containers" / f"{c}.svg"), *shipped,
                                                "--count", "20", "--seed", str(s)]))
        out.append((f"shipped-40-heart-{s}", [str(ex / "containers" / "heart.svg"), *shipped,
                                              "--count", "40", "--seed", str(s)]))
        if SHARED.exists():
            animals = str(SHARED / "animals")
            heart = str(SHARED / "containers" / "heart.svg")
            out.append((f"animals-25-circle-{s}", [str(ex / "containers" / "circle.svg"), animals,
                                                   "--count", "25", "--seed", str(s)]))
            out.append((f"animals-12-heart-{s}", [heart, animals, "--gap", "5.2", "--count", "12", "--seed", str(s)]))
            out.append((f"animals-20-heart-{s}", [heart, animals, "--gap", "5.2", "--seed", str(s)]))
    return out


def run(name: str, args: list[str], tmp: Path, config: str | None) -> dict:
    out = tmp / f"{name}.svg"
    cmd = PACK + args + ["-o", str(out), "--report", str(out.with_suffix(".json")), "--no-pocket-fill", "-q"]
    if config:
        cmd += ["--config", config]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    r = json.loads(out.with_suffix(".json").read_text())
    g = r["gap_stats"]
    return {"scene": name, "area": r["area_fraction_primary"], "q": r["scp_ratio_primary"],
            "median": g["median"] / r["gap"], "p10": g["p10"] / r["gap"], "edge": r["edge"]["min"] / r["gap"],
            "d95": r["distortion"]["p95"], "seconds": r["seconds"]["total"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--config", help="a TOML file given to every run")
    a = ap.parse_args()
    sys.path.insert(0, str(HERE))
    from bench import machine

    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(a.jobs) as pool:
        rows = list(pool.map(lambda sc: run(sc[0], sc[1], Path(tmp), a.config), scenes(a.seeds)))
    print(f"machine: {machine()}")
    print("| scene | art area | Q_s ratio | median gap / gap | p10 / gap | edge / gap | distortion p95 | seconds |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in rows:
        print(f"| {r['scene']} | {r['area']:.4f} | {r['q']:.3f} | {r['median']:.3f} | {r['p10']:.3f} | "
              f"{r['edge']:.3f} | {r['d95']:.3f} | {r['seconds']:.1f} |")
    n = len(rows)
    print(f"| **mean of {n}** | **{sum(r['area'] for r in rows) / n:.4f}** | {sum(r['q'] for r in rows) / n:.3f} | "
          f"min {min(r['median'] for r in rows):.3f} | min {min(r['p10'] for r in rows):.3f} | "
          f"min {min(r['edge'] for r in rows):.3f} | max {max(r['d95'] for r in rows):.3f} | "
          f"{sum(r['seconds'] for r in rows):.1f} |")


if __name__ == "__main__":
    main()
