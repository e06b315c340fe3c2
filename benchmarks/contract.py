"""The packer's promises measured on the scene suite (not part of the test run).

    python benchmarks/contract.py                 # all scenes -> docs/quality.md, docs/quality.json,
                                                  #   docs/images/quality-*.png
    python benchmarks/contract.py --jobs 2        # two scenes at a time (one numba thread each)
    python benchmarks/contract.py --fast          # the tests' fast subset, table on stdout only
    python benchmarks/contract.py --only rings-circle --only bars-square   # chosen scenes, stdout only
    python benchmarks/contract.py --only NAME --out-dir /tmp/q   # ... and write the files there
    python benchmarks/contract.py --suite holdout --jobs 2       # the held-out scenes, stdout only
    python benchmarks/contract.py --suite holdout --out-dir /tmp/h   # ... files (and pictures of every
                                                  #   scene) in /tmp/h; never docs/
    python benchmarks/contract.py --reseed 1000 --jobs 2   # the same scenes, every seed + 1000
                                                  #   (robustness; never docs/)

Every scene of :func:`scenes.suite` is written to a scratch directory,
packed through ``repulsionpak pack``'s own code path (:func:`repulsionpak.cli.run_pack`),
read back from its output SVG and measured with :func:`scenes.measure`
(exact polygon geometry on the final art; nothing from the simulation's internals).
The exit code is 0 when the run completed, whatever the promises say (the table says
which hold); 1 when a scene could not be packed at all.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import json
import multiprocessing
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT / "src"))  # measure this checkout's code, whatever is installed
#: scenes drawn in docs/quality.md (when they are run)
PICTURES = ("convex-circle", "stars-circle", "thin-circle", "holed-band", "letters-holed", "mixed-circle-120")

#: sections of docs/quality.md written by other benchmarks, kept when the page is regenerated
KEPT_SECTIONS = ("The size floor and the Q_s promise", "Output curves", "Area at the gap actually produced")

PROMISES = ("gap_median", "gap_p10", "overlap", "outside", "edge_margin", "distortion", "scp_ratio")


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}"


def git_revision() -> str:
    try:
        rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no",
                                "--", "src", "benchmarks"],  # the code measured, not the docs written
                               capture_output=True, text=True, check=True).stdout.strip()
        return rev + ("+dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


# --------------------------------------------------------------------------- one scene


def _summary(scene, run: dict | None, error: str | None, seconds: float) -> dict:
    """A JSON-safe summary of one scene's run (no per-element lists but the key ones)."""
    out = {
        "name": scene.name, "category": scene.category, "tags": list(scene.tags),
        "container": scene.container, "elements": list(scene.elements), "scale": scene.scale,
        "gap_fraction": scene.gap, "gap": scene.gap_units, "count": scene.count, "seed": scene.seed,
        "seconds": seconds, "error": error,
    }
    if run is None:
        return out
    m, rep = run["metrics"], run["report"]
    g, e, d = m["gap"], m["edge"], m["distortion"]
    gap = scene.gap_units
    out.update({
        "n_elements": m["n_elements"], "iterations": rep["iterations"], "stopped_by": rep["stopped_by"],
        "pack_seconds": rep["seconds"],
        "area_fraction": m["area_fraction"],
        "gap_median": g["median"], "gap_p10": g["p10"], "gap_p90": g["p90"],
        "gap_median_rel": None if g["median"] is None else g["median"] / gap,
        "gap_p10_rel": None if g["p10"] is None else g["p10"] / gap,
        "overlap_area": m["overlap_area"], "overlap_rel": m["overlap_area"] / m["container_area"],
        "outside_area": m["outside_area"], "outside_rel": m["outside_area"] / m["container_area"],
        "container_area": m["container_area"],
        "edge_min": e["min"], "edge_min_rel": None if e["min"] is None else e["min"] / gap,
        "edge_n_below_margin": e["n_below_margin"], "margin": e["margin"],
        "distortion_median": d["median"], "distortion_p95": d["p95"], "distortion_max": d["max"],
        "distortion_primary": (d.get("by_kind") or {}).get("primary"),
        "scp_q0": m["scp"]["q0"] if m.get("scp") else None,
        "scp_at_half_gap": m["scp_at_half_gap"], "scp_ratio": m["scp_ratio"],
        "n_primary": m["n_primary"], "n_secondary": m["n_secondary"],
        "area_fraction_primary": m.get("area_fraction_primary"), "scp_ratio_primary": m.get("scp_ratio_primary"),
        "smallest_secondary_rel": m.get("smallest_secondary_rel"),
        "scp_pixel_size": m["scp"]["pixel_size"] if m.get("scp") else None,
        "promises": m["promises"],
        "per_element": {"source": m["sources"], "gap": g["values"], "edge": e["values"],
                        "distortion": d["values"]},
    })
    return out


def run_one(name: str, workdir: str, picture_dir: str | None, reseed: int = 0) -> dict:
    """Pack and measure one scene of the suites by name (in a worker process); never
    raises. ``reseed`` is added to the scene's seed (the same problem, another packing)."""
    import dataclasses

    import scenes

    scene = {s.name: s for s in scenes.suite() + scenes.fast_suite() + scenes.holdout_suite()}[name]
    if reseed:
        scene = dataclasses.replace(scene, seed=scene.seed + reseed)
    return measure_scene(scene, workdir, picture_dir)


def measure_scene(scene, workdir: str, picture_dir: str | None = None) -> dict:
    """Pack and measure ``scene`` (a :class:`scenes.Scene`); never raises: a
    failure is recorded in the summary's ``error``."""
    import scenes
    from repulsionpak.io import read_packing_svg
    from repulsionpak.render.png import render_png

    t0 = time.perf_counter()
    try:
        run = scenes.run_scene(scene, workdir)
    except Exception as exc:  # noqa: BLE001 - a benchmark records every failure
        msg = f"{type(exc).__name__}: {exc}"
        tb = traceback.format_exc(limit=4)
        return _summary(scene, None, msg + "\n" + tb, time.perf_counter() - t0)
    res = _summary(scene, run, None, run["seconds"])
    if picture_dir is not None:
        container, placed, _ = read_packing_svg(run["svg"])
        out = Path(picture_dir) / f"quality-{scene.name}.png"
        render_png(out, container, placed, size_px=700)
        res["picture"] = out.name
    return res


def _init_worker() -> None:
    """Scenes packed side by side share the cores: one thread each (the runs' results do
    not depend on it)."""
    os.environ["REPULSIONPAK_THREADS"] = "1"


# --------------------------------------------------------------------------- report


def _f(x, nd=2) -> str:
    if x is None:
        return "–"
    if isinstance(x, int) or x == 0:
        return str(int(x))
    if x != 0 and (abs(x) < 10 ** -nd or abs(x) >= 1e5):
        return f"{x:.1e}"
    return f"{x:.{nd}f}"


def _mark(ok) -> str:
    return "" if ok is None else (" ✓" if ok else " ✗")


def _distortion_cell(p: dict) -> tuple[str, bool | None]:
    """The distortion p95 of the category furthest over its limit (named when the scene
    mixes categories) and whether every category keeps its limit."""
    cats = {k[len("distortion_"):]: v for k, v in p.items() if k.startswith("distortion_")}
    if not cats:
        return "–", None
    oks = [v["ok"] for v in cats.values() if v["ok"] is not None]
    name, worst = max(cats.items(), key=lambda kv: (kv[1]["value"] or 0) / kv[1]["limit"])
    cell = _f(worst["value"]) + (f" ({name})" if len(cats) > 1 else "")
    return cell, (all(oks) if oks else None)


def _primary_cell(r: dict) -> str:
    """The primaries' own distortion p95 / max (the promise is on all elements; pocket
    copies, small and often undeformed, pull its percentile down)."""
    d = r.get("distortion_primary") or {}
    if d.get("p95") is None:
        return "–"
    return f"{_f(d['p95'])} / {_f(d['max'])}"


def promise_status(r: dict) -> dict[str, bool | None]:
    """PASS (True) / FAIL (False) / unknown (None) per promise of one scene summary."""
    if r.get("error"):
        return dict.fromkeys(PROMISES, False)
    p = r["promises"]
    st = {k: p[k]["ok"] for k in ("gap_median", "gap_p10", "overlap", "outside", "edge_margin", "scp_ratio")}
    st["distortion"] = _distortion_cell(p)[1]
    return st


def table(results: list[dict]) -> str:
    head = ("| scene | category | container | scale | n (primaries + copies) | gap | median gap/gap | p10 gap/gap | "
            "overlap | outside | min edge/gap (n < margin) | distortion p95 | primaries alone: p95 / max | "
            "Q_s(gap/2)/Q_s(0) | area fraction | primaries alone: area / Q_s ratio | smallest copy / median primary | "
            "seconds | promises kept |")
    lines = [head, "|" + " --- |" * 3 + " ---: |" * 16]
    for r in results:
        if r.get("error"):
            first = r["error"].splitlines()[0].replace("|", "\\|")
            lines.append(f"| {r['name']} | {r['category']} | {r['container']} | {r['scale']:g} | {r['count']} | "
                         f"{r['gap']:g} | error: {first} | | | | | | | | | | | {r['seconds']:.1f} | 0/{len(PROMISES)} |")
            continue
        p = r["promises"]
        st = promise_status(r)
        dcell, dok = _distortion_cell(p)
        kept = sum(1 for v in st.values() if v)
        lines.append(
            f"| {r['name']} | {r['category']} | {r['container']} | {r['scale']:g} | {_counts(r)} | "
            f"{r['gap']:g} | {_f(r['gap_median_rel'])}{_mark(st['gap_median'])} | "
            f"{_f(r['gap_p10_rel'])}{_mark(st['gap_p10'])} | {_f(r['overlap_rel'], 6)}{_mark(st['overlap'])} | "
            f"{_f(r['outside_rel'], 6)}{_mark(st['outside'])} | "
            f"{_f(r['edge_min_rel'])} ({r['edge_n_below_margin']}){_mark(st['edge_margin'])} | "
            f"{dcell}{_mark(dok)} | {_primary_cell(r)} | {_f(r['scp_ratio'])}{_mark(st['scp_ratio'])} | "
            f"{_f(r['area_fraction'])} | {_f(r.get('area_fraction_primary'))} / {_f(r.get('scp_ratio_primary'))} | "
            f"{_f(r.get('smallest_secondary_rel'))} | {r['seconds']:.1f} | {kept}/{len(PROMISES)} |")
    return "\n".join(lines)


def _counts(r: dict) -> str:
    """``P + S`` primaries and pocket copies (the element count alone in summaries of
    runs made before evaluate() counted them apart)."""
    if r.get("n_primary") is None:
        return str(r["n_elements"])
    return f"{r['n_primary']} + {r['n_secondary']}"


def totals(results: list[dict]) -> str:
    n = len(results)
    rows = ["| promise | scenes kept |", "| --- | ---: |"]
    for k in PROMISES:
        kept = sum(1 for r in results if promise_status(r)[k])
        rows.append(f"| {k.replace('_', ' ')} | {kept}/{n} |")
    allk = sum(1 for r in results if all(promise_status(r).values()))
    rows.append(f"| **all** | **{allk}/{n}** |")
    return "\n".join(rows)


INTRO = """\
# Quality: the packing's promises, measured on a scene suite

Generated by `python benchmarks/contract.py`; do not edit by hand.
`python benchmarks/contract.py --jobs 2` runs the {n_scenes} scenes of
`suite()` of `benchmarks/scenes.py` two at a time and rewrites this page, `docs/quality.json`
(every number below and each element's values) and the pictures
`docs/images/quality-*.png`; `--only NAME` / `--fast` run a few scenes and print the table.
The tests (`tests/test_contract.py`) pack the four scenes of `scenes.fast_suite()` and
check the same promises.

## The scenes

Plain shapes made by `benchmarks/scenes.py` as SVG (squares, discs, triangles, hexagons,
5- and 8-pointed stars, 5:1 bars, crosses, crescents, rings) and DejaVu Sans glyphs
(A B O R S g &, shipped with matplotlib, drawn as compound evenodd paths, so counters
are holes), grouped as **convex**, **spiky**, **thin**, **holed** and **letter**
elements; containers: a circle (`<circle>`), a square, a sharp 5-pointed star, a curved
band (a 240° annular sector drawn with arcs), a square with a round hole and two
separate regions in one file. Gaps from 0.5 % to 3 % of the container's larger side,
drawing scales from 0.01× to 100× (container and elements scaled together: a 10-unit to
a 100 000-unit container), 5 to 300 elements. Every scene has a fixed seed and count.

## The metrics

All are measured on the **output SVG** read back from disk, against the scene's own
container file (re-read with curves flattened to gap/2000, i.e. the true outline, not the
polygon the simulation used) and the source element files — never on the simulation's
meshes. Lengths are divided by the requested gap.

| column | definition | promise |
| --- | --- | --- |
| median gap/gap, p10 gap/gap | per element, the exact polygon distance from its art to the nearest other element's art; median and 10th percentile over the elements | median in [0.9, 1.1], p10 ≥ 0.8 |
| overlap | Σ over element pairs of the area of their art's intersection (each element's art united first), / container area | ≤ 1e-6 |
| outside | area of art outside the container, / container area | ≤ 1e-6 |
| min edge/gap (n < margin) | the smallest distance from any element's art to the container's boundary, and how many elements are closer than 0.98 × margin (margin = gap/2) | min ≥ 0.98 × 0.5 |
| distortion p95 | per element, area(best similar copy of its source △ its art) / its art's area: the source is centred on the copy's centroid, scaled to the same area, the rotation searched on a 7.5° grid and refined to 0.01°, then angle, scale and translation refined together; 95th percentile per element category (a scene mixing categories shows the one furthest over its limit) | ≤ 0.08 convex, ≤ 0.15 spiky, thin, holed, letter |
| primaries alone: p95 / max | the same distortion over the primary elements only (the promise counts every element; pocket copies are small and often undeformed, so the primaries' own percentile is the higher one) | (reported) |
| Q_s(gap/2)/Q_s(0) | the spherical contact probability of the negative space (paper sec. 11) at r = gap/2 over its value at 0, by raster with ≥ 10 pixels per gap (`repulsionpak.measure.scp`); 0 for ideal stripes of width gap | ≤ 0.45 |
| area fraction | art inside the container / container area | (reported) |
| seconds | wall time of the packing (read inputs, pack, write SVG) | (reported) |

✓ / ✗ mark a kept / broken promise. `repulsionpak evaluate OUT.svg --elements DIR --json`
reports the same `edge`, `outside_area` and `distortion` entries for any packing, and
`repulsionpak pack ... --report R.json` includes them.
"""


def markdown(results: list[dict], meta: dict, pictures: list[dict]) -> str:
    parts = [INTRO.format(n_scenes=len(results)),
             f"## Results\n\nCode {meta['revision']}; {meta['machine']}; "
             f"`{meta['command']}` ({meta['jobs']} job(s), {meta['wall_seconds']:.0f} s wall in all).\n",
             totals(results), "", table(results), ""]
    if pictures:
        parts.append("## Pictures\n")
        for r in pictures:
            st = promise_status(r)
            kept = sum(1 for v in st.values() if v)
            parts.append(f"**{r['name']}** ({r['n_elements']} elements, gap {r['gap']:g}, "
                         f"{kept}/{len(PROMISES)} promises kept)\n\n"
                         f"![{r['name']}](images/{r['picture']})\n")
    return "\n".join(parts) + "\n"


# --------------------------------------------------------------------------- main


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", action="append", default=[], help="run only this scene (repeatable)")
    ap.add_argument("--fast", action="store_true", help="run the tests' fast subset")
    ap.add_argument("--suite", choices=("main", "holdout"), default="main",
                    help="main: scenes.suite() (default; a full run rewrites docs/quality.md); holdout: "
                         "scenes.holdout_suite(), never tuned on (never writes docs/; files only with --out-dir)")
    ap.add_argument("--jobs", type=int, default=1, help="scenes packed at the same time (processes)")
    ap.add_argument("--out-dir", type=Path, default=None,
                    help="where quality.md / quality.json / images go (default: docs/ for a full run; "
                         "none for --only / --fast)")
    ap.add_argument("--workdir", type=Path, default=None, help="keep the scenes and packings here")
    ap.add_argument("--reseed", type=int, default=0,
                    help="add this to every scene's seed: the same problems, other packings (a robustness "
                         "check; never writes docs/)")
    args = ap.parse_args(argv)

    import scenes
    from repulsionpak.io.files import atomic_write_bytes

    every = {s.name: s for s in scenes.suite() + scenes.fast_suite() + scenes.holdout_suite()}
    if args.only:
        unknown = [n for n in args.only if n not in every]
        if unknown:
            ap.error(f"unknown scene(s) {', '.join(unknown)}; known: {', '.join(every)}")
        chosen = [every[n] for n in args.only]
    elif args.fast:
        chosen = scenes.fast_suite()
    elif args.suite == "holdout":
        chosen = scenes.holdout_suite()
    else:
        chosen = scenes.suite()
    if args.jobs < 1:
        ap.error("--jobs must be >= 1")
    partial = bool(args.only or args.fast or args.suite != "main" or args.reseed)
    out_dir = args.out_dir if args.out_dir is not None else (None if partial else ROOT / "docs")
    if (args.suite == "holdout" or args.reseed) and out_dir is not None \
            and out_dir.resolve() == (ROOT / "docs").resolve():
        ap.error("--suite holdout never writes docs/, nor does --reseed (the published numbers are the "
                 "main suite's at its own seeds); give another --out-dir")
    pic_dir = None
    if out_dir is not None:
        pic_dir = out_dir / "images"
        pic_dir.mkdir(parents=True, exist_ok=True)

    tmp = None
    if args.workdir is None:
        tmp = tempfile.TemporaryDirectory(prefix="repulsionpak-contract-")
        workdir = Path(tmp.name)
    else:
        workdir = args.workdir
        workdir.mkdir(parents=True, exist_ok=True)

    revision = git_revision()
    t0 = time.perf_counter()
    results: dict[str, dict] = {}
    jobs = [(s.name, str(workdir), str(pic_dir) if (pic_dir and s.name in PICTURES) or (pic_dir and partial)
             else None, args.reseed) for s in chosen]

    def done(r: dict) -> None:
        results[r["name"]] = r
        status = "ERROR " + r["error"].splitlines()[0] if r.get("error") else \
            f"{sum(1 for v in promise_status(r).values() if v)}/{len(PROMISES)} promises kept"
        print(f"[{len(results)}/{len(jobs)}] {r['name']}: {r['seconds']:.1f} s, {status}", file=sys.stderr,
              flush=True)

    if args.jobs == 1:
        for job in jobs:
            done(run_one(*job))
    else:  # one numba thread per worker (_init_worker): the workers already share the cores
        ctx = multiprocessing.get_context("spawn")
        with cf.ProcessPoolExecutor(args.jobs, mp_context=ctx, initializer=_init_worker) as pool:
            futs = [pool.submit(run_one, *job) for job in jobs]
            for f in cf.as_completed(futs):
                done(f.result())
    wall = time.perf_counter() - t0
    ordered = [results[s.name] for s in chosen]
    meta = {"revision": revision, "date": time.strftime("%Y-%m-%d"), "machine": machine(),
            "command": "python benchmarks/contract.py" + (f" --jobs {args.jobs}" if args.jobs > 1 else "")
            + (f" --suite {args.suite}" if args.suite != "main" else "")
            + "".join(f" --only {n}" for n in args.only) + (" --fast" if args.fast else "")
            + (f" --reseed {args.reseed}" if args.reseed else ""),
            "jobs": args.jobs, "wall_seconds": wall}
    print(totals(ordered))
    print()
    print(table(ordered))
    if out_dir is not None:
        from repulsionpak.measure import limits_dict

        pics = [r for r in ordered if r.get("picture")]
        page = markdown(ordered, meta, pics)
        old = out_dir / "quality.md"
        if old.exists():  # sections other benchmarks own (output_curves.py, equal_gap.py) are kept
            text = old.read_text()
            for title in KEPT_SECTIONS:
                m = re.search(rf"^## {re.escape(title)}\n.*?(?=^## |\Z)", text, re.S | re.M)
                if m:
                    page = page.rstrip("\n") + "\n\n" + m.group(0).rstrip("\n") + "\n"
        atomic_write_bytes(out_dir / "quality.md", page.encode())
        data = {"meta": meta, "limits": limits_dict(), "scenes": ordered}
        atomic_write_bytes(out_dir / "quality.json", (json.dumps(data, indent=1) + "\n").encode())
        print(f"\nwrote {out_dir / 'quality.md'}, {out_dir / 'quality.json'} and {len(pics)} picture(s)",
              file=sys.stderr)
    if tmp is not None:
        tmp.cleanup()
    return 1 if any(r.get("error") for r in ordered) else 0


if __name__ == "__main__":
    sys.exit(main())
