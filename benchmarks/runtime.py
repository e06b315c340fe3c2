"""Whole-run timings: against the authors' C++, beside a busy neighbour, and a 1,000-element poster.

    python benchmarks/runtime.py cpp --cpp-dir OUTDIR [--runs 3]
        the paper's heart and nine animals, gap 5.2, default settings, the whole process from
        command to written SVG: `repulsionpak pack` and the authors' C++ (built headless by
        ../shared/anchors/cpp_headless/build.sh OUTDIR SOURCE) alternately, `--runs` each
    python benchmarks/runtime.py neighbour [--runs 2]
        the heart without pockets, a CPU-bound process started one second into the run:
        ms per primary iteration with automatic threads, with one thread and with two
    python benchmarks/runtime.py poster [--png] [--draft] [--config T.toml] [--cpp-dir OUTDIR]
        the shipped example elements, `--count 1000`, in a 2:3 rectangle: wall seconds, peak memory
        (the packing SVG and its report; ``--png`` also renders the PNG preview, ~3 s more);
        with ``--cpp-dir`` the C++ heart just before and after, and the poster scaled to it

Each prints Markdown table rows for docs/benchmarks.md, with the machine.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SHARED = HERE.parent.parent / "shared" / "data"
HEART = SHARED / "containers" / "heart.svg"
ANIMALS = SHARED / "animals"
PACK = [str(Path(sys.executable).parent / "repulsionpak"), "pack"]

sys.path.insert(0, str(HERE))
from bench import machine, poster_container  # noqa: E402  (the same machine line and poster as the other scripts)


def timed(cmd, cwd=None, env=None, during=None) -> tuple[float, float, float, str]:
    """Run ``cmd``; returns (wall s, CPU s of the child, peak RSS MB, stdout).
    ``during(proc)`` is called once the child has started."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if during is not None:
        during(proc)
    out, _ = proc.communicate()
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(map(str, cmd))} failed ({proc.returncode}):\n{out[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, after.ru_maxrss / 1024.0, out


def compiled_bytecode() -> None:
    """Byte-compile the package as ``pip install`` does: with an editable install and
    ``PYTHONDONTWRITEBYTECODE`` set (as on the benchmark machine) every run would compile
    its ~100 modules from source again, about 0.25 s that no installed copy pays."""
    import importlib.util

    spec = importlib.util.find_spec("repulsionpak")
    if spec is None or not spec.submodule_search_locations:
        raise SystemExit("repulsionpak is not installed in this Python: pip install .")
    subprocess.run([sys.executable, "-m", "compileall", "-q", spec.submodule_search_locations[0]], check=True)


def _median(v):
    v = sorted(v)
    return v[len(v) // 2] if len(v) % 2 else 0.5 * (v[len(v) // 2 - 1] + v[len(v) // 2])


def cpp_executable(cpp_dir: Path) -> Path:
    """The headless C++ build in ``cpp_dir`` (``build.sh OUTDIR``), or exit saying how to make it."""
    exe = cpp_dir / "build" / "repulsionpak_headless"
    if not exe.exists():
        raise SystemExit(f"{exe} not found: build it with ../shared/anchors/cpp_headless/build.sh {cpp_dir} SOURCE")
    return exe


def cpp_heart(exe: Path, cpp_dir: Path) -> tuple[float, float, float, int | None]:
    """One run of the authors' C++ on the paper's heart (its defaults, 2 threads): (wall s,
    CPU s, peak RSS MB, iterations)."""
    w, c, m, text = timed([str(exe), "params_linux_det250_a.lua", "--threads", "2", "--fill-every", "250"],
                          cwd=cpp_dir)
    it = re.search(r"iterations:\s*(\d+)", text)
    return w, c, m, int(it.group(1)) if it else None


def bench_cpp(cpp_dir: Path, runs: int = 3) -> None:
    """Ours against the C++ on the heart, alternately, whole processes."""
    exe = cpp_executable(cpp_dir)
    ours, theirs = [], []
    compiled_bytecode()
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(runs):
            out = Path(tmp) / f"heart-{r}.svg"
            w, c, m, _ = timed(PACK + [str(HEART), str(ANIMALS), "--gap", "5.2", "--seed", "1", "-o", str(out)])
            ours.append((w, c, m))
            w2, c2, m2, it = cpp_heart(exe, cpp_dir)
            theirs.append((w2, c2, m2, it))
            print(f"run {r + 1}: ours {w:.2f} s wall ({c:.1f} CPU s), C++ {w2:.2f} s wall ({c2:.1f} CPU s)",
                  file=sys.stderr)
        # the stages, from one more run with a report (not timed: the report measures the packing)
        out = Path(tmp) / "heart-report.svg"
        timed(PACK + [str(HEART), str(ANIMALS), "--gap", "5.2", "--seed", "1", "-o", str(out),
                      "--report", str(out.with_suffix(".json"))])
        rep = json.loads(out.with_suffix(".json").read_text())
    ow, tw = _median([o[0] for o in ours]), _median([t[0] for t in theirs])
    print(f"machine: {machine()}")
    print("| scene | ours wall (CPU) | C++ wall (CPU) | ratio (wall) | ours iterations | C++ iterations |")
    print("|---|---:|---:|---:|---:|---:|")
    print(f"| heart + 9 animals, gap 5.2, default settings, median of {runs} | "
          f"{ow:.2f} s ({_median([o[1] for o in ours]):.1f}) | {tw:.2f} s ({_median([t[1] for t in theirs]):.1f}) | "
          f"{tw / ow:.1f}× | {rep['iterations']['primary']} + {rep['iterations']['secondary']} | {theirs[0][3]} |")
    print("stages (ours, a run with --report): " + ", ".join(f"{k} {v:.2f} s" for k, v in rep["seconds"].items()))


def _busy_after(delay: float):
    """A ``during`` callback: start a CPU-bound process ``delay`` seconds into the run."""
    procs = []

    def during(proc):
        time.sleep(delay)
        procs.append(subprocess.Popen([sys.executable, "-c", "while True: pass"]))
    return during, procs


def bench_neighbour(runs: int = 2) -> None:
    """ms per primary iteration with a busy neighbour from the first second on."""
    modes = {"automatic": {}, "one thread": {"REPULSIONPAK_THREADS": "1"}, "two threads (fixed)": {}}
    rows = {k: [] for k in modes}
    with tempfile.TemporaryDirectory() as tmp:
        cfg = Path(tmp) / "two.toml"
        cfg.write_text("[sim]\nthreads = 2\n")
        for r in range(runs):
            for name, extra in modes.items():
                out = Path(tmp) / f"n-{r}.svg"
                cmd = PACK + [str(HEART), str(ANIMALS), "--gap", "5.2", "--seed", "1", "--no-pocket-fill",
                              "-o", str(out), "--report", str(out.with_suffix(".json")), "--quiet"]
                if name.startswith("two"):
                    cmd += ["--config", str(cfg)]
                env = dict(os.environ, **extra)
                during, procs = _busy_after(1.0)
                try:
                    w, c, m, _ = timed(cmd, env=env, during=during)
                finally:
                    for p in procs:
                        p.kill()
                        p.wait()
                rep = json.loads(out.with_suffix(".json").read_text())
                ms = 1e3 * rep["seconds"]["primary"] / rep["iterations"]["primary"]
                rows[name].append((ms, w))
                print(f"run {r + 1} {name}: {ms:.2f} ms/iteration, {w:.1f} s wall", file=sys.stderr)
    one = _median([x[0] for x in rows["one thread"]])
    print(f"machine: {machine()}")
    print("| threads, busy neighbour from 1 s on | ms / primary iteration | × one thread | wall s |")
    print("|---|---:|---:|---:|")
    for name, v in rows.items():
        ms = _median([x[0] for x in v])
        print(f"| {name} | {ms:.2f} | {ms / one:.2f} | {_median([x[1] for x in v]):.1f} |")


#: the authors' C++ on the heart took this long (wall s) on the machine issue 47 measured
#: it on: the poster's seconds are also given scaled to it
YARDSTICK = 22.5


def bench_poster(count: int = 1000, png: bool = False, config: Path | None = None, draft: bool = False,
                 cpp_dir: Path | None = None) -> None:
    """The shipped examples, ``count`` copies, in a 2:3 rectangle: the packing SVG and the
    report, and with ``png`` the PNG preview too; ``config``: a TOML file of parameters
    (``--config``); ``draft``: packed with ``--draft``; ``cpp_dir``: the authors' C++ build,
    run on the heart just before and just after the poster as a yardstick of the machine's
    speed (it drifts by half within an hour), the poster's seconds then also given scaled to
    :data:`YARDSTICK`."""
    from repulsionpak import examples

    exe = None if cpp_dir is None else cpp_executable(cpp_dir)
    yard = []
    with tempfile.TemporaryDirectory() as tmp:
        rect = poster_container(tmp)
        out = Path(tmp) / "poster-out.svg"
        cmd = PACK + [str(rect), *map(str, examples.element_files()), "--count", str(count), "--seed", "1",
                      "-o", str(out), "--report", str(out.with_suffix(".json")), "--quiet"]
        if png:
            cmd += ["--png", str(out.with_suffix(".png"))]
        if config is not None:
            cmd += ["--config", str(config)]
        if draft:
            cmd += ["--draft"]
        if exe is not None:
            yard.append(cpp_heart(exe, cpp_dir)[0])
        w, c, m, _ = timed(cmd)
        if exe is not None:
            yard.append(cpp_heart(exe, cpp_dir)[0])
        rep = json.loads(out.with_suffix(".json").read_text())
    print(f"machine: {machine()}")
    print("| scene | elements | vertices | iterations | wall s | CPU s | peak RSS MB | area |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    print(f"| {count} shipped examples in a 2:3 rectangle | {rep['n_primary']} + {rep['n_secondary']} | "
          f"{rep['n_vertices']} | {rep['iterations']['primary']} + {rep['iterations']['secondary']} | "
          f"{w:.1f} | {c:.1f} | {m:.0f} | {rep['area_fraction']:.3f} |")
    print("stages: " + ", ".join(f"{k} {v:.1f} s" for k, v in rep["seconds"].items()))
    if yard:
        print(f"the authors' C++ on the heart just before and after: {yard[0]:.1f} s, {yard[1]:.1f} s; "
              f"the poster scaled to a machine where it takes {YARDSTICK:g} s: "
              f"{w * YARDSTICK / (0.5 * (yard[0] + yard[1])):.1f} s")


#: packs the heart in this process and prints the kernels made ready (numba's dispatchers
#: compile or load on a first call with new types) and the seconds that took
_LOADING = """
import sys, time
import numba.core.dispatcher as D
import repulsionpak
from repulsionpak.params import Params
spent = [0.0, 0]
first_call = D.Dispatcher._compile_for_args
def timed(self, *a, **k):
    t = time.perf_counter()
    try:
        return first_call(self, *a, **k)
    finally:
        spent[0] += time.perf_counter() - t
        spent[1] += 1
D.Dispatcher._compile_for_args = timed
repulsionpak.pack(sys.argv[1], [sys.argv[2]], Params(seed=1, gap=5.2))
print(spent[1], spent[0])
"""


def bench_loading(runs: int = 3) -> None:
    """Seconds the run's own calls spent making kernels ready (a first call with new types:
    a load from numba's warm cache) over a default heart run, each run a fresh process. The
    kernels the second thread loads ahead (``_jit.loading.loading_ahead``) and the parallel
    builds loaded at the switch to threads are not first calls and are not counted."""
    compiled_bytecode()
    seconds, kernels = [], 0
    for r in range(runs):
        out = subprocess.run([sys.executable, "-c", _LOADING, str(HEART), str(ANIMALS)], check=True,
                             capture_output=True, text=True).stdout.split()
        kernels, s = int(out[-2]), float(out[-1])
        seconds.append(s)
        print(f"run {r + 1}: {kernels} kernels ready in {s:.3f} s", file=sys.stderr)
    print(f"machine: {machine()}")
    print("| scene | kernels | seconds to make them ready (median; all runs) |")
    print("|---|---:|---|")
    print(f"| heart + 9 animals, gap 5.2, default settings | {kernels} | {_median(seconds):.3f} "
          f"({', '.join(f'{s:.3f}' for s in seconds)}) |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["cpp", "neighbour", "poster", "loading"])
    ap.add_argument("--cpp-dir", type=Path, help="the C++ build folder (build.sh OUTDIR); poster: run the "
                    "C++ heart before and after it, a yardstick of the machine's speed")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--count", type=int, default=1000)
    ap.add_argument("--png", action="store_true", help="poster: also render the PNG preview")
    ap.add_argument("--config", type=Path, help="poster: a TOML file of parameters")
    ap.add_argument("--draft", action="store_true", help="poster: pack it with --draft")
    a = ap.parse_args()
    if a.what == "cpp":
        if a.cpp_dir is None:
            ap.error("cpp needs --cpp-dir")
        bench_cpp(a.cpp_dir.resolve(), a.runs)
    elif a.what == "neighbour":
        bench_neighbour(a.runs)
    elif a.what == "loading":
        bench_loading(a.runs)
    else:
        bench_poster(a.count, a.png, a.config, a.draft, None if a.cpp_dir is None else a.cpp_dir.resolve())


if __name__ == "__main__":
    main()
