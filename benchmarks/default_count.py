"""The default count: every suite scene with its count left out, at several ``element_size``.

Without ``--count`` a packing has container area / (``placement.element_size`` × gap)²
primaries. This packs every scene of a suite at its own gap and seed but with the count
left to that estimate, once per element size, measures it as ``benchmarks/contract.py``
does (:func:`scenes.measure`, the seven promises) and prints one line per
scene and size, then a summary per size (the table in docs/quality.md, "The default
count").

    python benchmarks/default_count.py --sizes 12,15 --jobs 2                 # main suite
    python benchmarks/default_count.py --suite holdout --sizes 12,15 --jobs 2
    python benchmarks/default_count.py --sizes 15 --only stars-band --json out.json

Nothing here writes into the repository (scenes and packings go to ``--workdir``, a
temporary directory by default).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import contract  # noqa: E402  (benchmarks/contract.py: the suites' own measuring code)


def _suite(name: str):
    import scenes

    return scenes.suite() if name == "main" else scenes.holdout_suite()


def run_one(task: tuple[str, str, float, str]) -> dict:
    """Pack one scene with the default count at one element size; its numbers."""
    suite, name, size, workdir = task
    import scenes

    scene = {s.name: s for s in _suite(suite)}[name]
    base = Path(workdir) / f"es{size:g}"
    base.mkdir(parents=True, exist_ok=True)
    config = base / f"{name}.toml"
    config.write_text(f"[placement]\nelement_size = {size!r}\n")
    run = scenes.run_scene(scene, base, config=config, estimate_count=True)
    r = contract._summary(scene, run, None, run["seconds"])
    return {"scene": name, "element_size": size, "n_primary": run["report"]["n_primary"],
            "n_secondary": run["report"]["n_secondary"], "area": r["area_fraction"], "scp_ratio": r["scp_ratio"],
            "gap_median": r["gap_median_rel"], "gap_p10": r["gap_p10_rel"],
            "broken": [k for k, ok in contract.promise_status(r).items() if ok is False],
            "seconds": run["seconds"]}


def summary(rows: list[dict], sizes: list[float]) -> list[str]:
    """One line per element size; scenes that gain against the first size."""
    by = {(r["scene"], r["element_size"]): r for r in rows}
    names = sorted({r["scene"] for r in rows})
    lines = []
    for size in sizes:
        rs = [by[(n, size)] for n in names]
        line = (f"element_size {size:g}: primaries {sum(r['n_primary'] for r in rs)}, "
                f"mean area {statistics.mean(r['area'] for r in rs):.4f}, "
                f"largest Q_s ratio {max(r['scp_ratio'] for r in rs):.3f}, "
                f"median gaps {min(r['gap_median'] for r in rs):.3f}-{max(r['gap_median'] for r in rs):.3f}, "
                f"lowest p10 {min(r['gap_p10'] for r in rs):.3f}, "
                f"promises broken {sum(len(r['broken']) for r in rs)}, "
                f"seconds {sum(r['seconds'] for r in rs):.0f}")
        if size != sizes[0]:
            gain = {n: by[(n, size)]["area"] - by[(n, sizes[0])]["area"] for n in names}
            line += (f"; more area than at {sizes[0]:g} on {sum(g > 0 for g in gain.values())}/{len(names)}"
                     f" (less: {', '.join(f'{n} {g:+.3f}' for n, g in gain.items() if g <= 0) or 'none'})")
        lines.append(line)
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--suite", choices=["main", "holdout"], default="main")
    ap.add_argument("--sizes", default="12,15", help="comma-separated element sizes (× gap)")
    ap.add_argument("--only", action="append", help="run only this scene (repeatable)")
    ap.add_argument("--jobs", type=int, default=1, help="scenes packed at the same time (processes)")
    ap.add_argument("--workdir", help="keep the scenes and packings here")
    ap.add_argument("--json", help="write every run's numbers here")
    args = ap.parse_args()
    sizes = [float(x) for x in args.sizes.split(",")]
    if not sizes or any(s <= 0 for s in sizes):
        ap.error("--sizes: positive numbers, e.g. 12,15")
    names = [s.name for s in _suite(args.suite)]
    if args.only:
        unknown = sorted(set(args.only) - set(names))
        if unknown:
            ap.error(f"not in the {args.suite} suite: {', '.join(unknown)}")
        names = [n for n in names if n in args.only]
    workdir = args.workdir or tempfile.mkdtemp(prefix="default-count-")
    tasks = [(args.suite, n, s, workdir) for n in names for s in sizes]
    if args.jobs > 1:
        with multiprocessing.get_context("spawn").Pool(args.jobs, initializer=contract._init_worker) as pool:
            rows = pool.map(run_one, tasks, chunksize=1)
    else:
        rows = [run_one(t) for t in tasks]
    for r in rows:
        print(f"{r['scene']:30s} element_size {r['element_size']:5g}  {r['n_primary']:4d} + {r['n_secondary']:4d}"
              f"  area {r['area']:.4f}  Q_s ratio {r['scp_ratio']:.3f}  gap {r['gap_median']:.3f}/{r['gap_p10']:.3f}"
              f"  {r['seconds']:5.1f} s  {'broken: ' + ', '.join(r['broken']) if r['broken'] else ''}")
    for line in summary(rows, sizes):
        print(line)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
