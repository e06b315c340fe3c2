"""Reproducible timings of repulsionpak (not part of the test run).

    python benchmarks/bench.py iteration [--plot docs/images/bench-scaling.png]  # ms/iteration vs vertices
    python benchmarks/bench.py threads              # ms/iteration on one thread and on every core
    python benchmarks/bench.py kernels              # where an iteration of 1,000 elements goes
    python benchmarks/bench.py preprocess           # preprocessing time per element
    python benchmarks/bench.py heart                # whole `repulsionpak pack` on ../shared/data, animals only (5 runs)
    python benchmarks/bench.py pockets              # the default command: pockets filled with small animals
    python benchmarks/bench.py secondary            # the same with secondary cats (seeding time)
    python benchmarks/bench.py mesh                 # skin mesh quality (angles, counts)
    python benchmarks/bench.py firstrun             # `repulsionpak demo` with an empty kernel cache, twice
    python benchmarks/bench.py freshinstall         # the README's `pip install . && repulsionpak demo` in a new venv
    python benchmarks/bench.py controls             # heart scene: free vs --rotation fixed vs --rigid (docs/controls.md)
    python benchmarks/bench.py pockets-many         # one detailed element (every shipped example on a sheet)
                                                    #   in a circle: the pocket fill's time and peak memory
    python benchmarks/bench.py copies               # the stages after the simulation, per-copy work on
                                                    #   one thread and on several (300 shipped elements)
    python benchmarks/bench.py placing              # blue noise for 1,000 points and a copy's paths
                                                    #   moved under one map, against the plain loops
    python benchmarks/bench.py poster-primary [--config T.toml]   # the 1,000-element poster's primary
                                                    #   simulation alone: iterations, seconds, mesh area
    python benchmarks/bench.py all

Fixed seeds; results are printed as Markdown table rows for docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import shapely

HERE = Path(__file__).resolve().parent
SHARED = HERE.parent.parent / "shared" / "data"


def machine() -> str:
    import os

    cpu = platform.processor() or platform.machine()
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}"


def _square_scene(count: int):
    """A Simulator of ``count`` example-library elements in a square (about 91 vertices per
    element at gap 5 with the default element size)."""
    import dataclasses

    from repulsionpak import examples
    from repulsionpak.io import load_elements
    from repulsionpak.pack import prepare
    from repulsionpak.sim.phase import typical_size
    from repulsionpak.params import Params
    from repulsionpak.sim.model import SimFrame, build_model
    from repulsionpak.sim.runner import Simulator
    from repulsionpak.types import Container

    elements = load_elements(examples.element_files())
    side = 60.0 * np.sqrt(count)
    region = shapely.box(0, 0, side, side)
    params = Params(gap=5.0, seed=1)
    params = dataclasses.replace(params, placement=dataclasses.replace(params.placement, count=count))
    rng = np.random.default_rng(1)
    templates, placement, gap = prepare(Container("bench", region), elements, params, rng)
    frame = SimFrame.for_region(region)
    rs = frame.to_sim(region)
    size = typical_size(templates, placement.template_index) / frame.unit
    model, state = build_model(templates, placement, frame, rs,
                               cell_size=max(params.sim.cell_size * size, 3 * gap / frame.unit),
                               gap=gap / frame.unit)
    return Simulator(model, state, params.sim), model, state, params


def bench_iteration(targets=(1500, 12000, 50000, 100000), warmup=2500, steps=100,
                    plot: str | None = None) -> None:
    """ms per simulation iteration on square containers filled with the example library,
    measured after ``warmup`` iterations (elements grown, neighbours in contact)."""
    from repulsionpak._jit.kernels import set_threads

    print("| vertices | elements | threads | ms/iteration | peak RSS so far (MB) |")
    print("| ---: | ---: | ---: | ---: | ---: |")
    rows = []
    for target in targets:
        sim, model, _, _ = _square_scene(max(4, int(target / 91)))
        set_threads(sim.thread_range()[1])  # the most an automatic run may use (an idle machine: all)
        for _ in range(warmup):  # grow them a while so neighbours interact, then time
            sim.step()
        t0 = time.perf_counter()
        for _ in range(steps):
            sim.step()
        ms = (time.perf_counter() - t0) / steps * 1e3
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(f"| {model.n_vertices} | {model.n_elements} | {sim.thread_range()[1]} | {ms:.2f} | {rss:.0f} |", flush=True)
        rows.append((model.n_vertices, ms))
    if plot:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        fig = Figure(figsize=(5, 3.4))
        FigureCanvasAgg(fig)
        ax = fig.add_subplot()
        v, ms = np.array(rows).T
        ax.plot(v / 1e3, ms, "o-", label="repulsionpak")
        ax.axhline(30, color="grey", ls="--", lw=0.8, label="target at 100k")
        ax.set_xlabel("vertices (thousands)")
        ax.set_ylabel("ms / iteration")
        ax.set_title(machine(), fontsize=8)
        ax.legend()
        fig.tight_layout()
        fig.savefig(plot, dpi=120)


def bench_threads(counts=(4, 8, 16, 33, 130), warmup=600, steps=300) -> None:
    """ms per iteration on one thread and on every core (the parallel builds; compiled
    here if not cached), alternately, best of two, after ``warmup`` iterations: where
    ``sim.parallel_threshold`` should lie."""
    import numba

    from repulsionpak._jit.kernels import set_threads
    from repulsionpak.sim.runner import Simulator

    n = numba.config.NUMBA_NUM_THREADS
    print(f"| vertices | elements | 1 thread, ms | {n} threads, ms | speed-up |")
    print("| ---: | ---: | ---: | ---: | ---: |")
    for count in counts:
        _, model, state, params = _square_scene(count)
        best = {}
        for th in (1, n, 1, n):
            sim = Simulator(model, state.copy(), params.sim)
            set_threads(th)
            for _ in range(warmup):
                sim.step()
            t0 = time.perf_counter()
            for _ in range(steps):
                sim.step()
            ms = (time.perf_counter() - t0) / steps * 1e3
            best[th] = min(best.get(th, np.inf), ms)
        print(f"| {model.n_vertices} | {model.n_elements} | {best[1]:.3f} | {best[n]:.3f} | "
              f"{best[1] / best[n]:.2f} |", flush=True)
    set_threads(1)


def bench_kernels(count=1000, warmup=2500, steps=100) -> None:
    """Where an iteration of a large packing goes: ``count`` example elements in a square,
    after ``warmup`` iterations, ``steps`` real iterations on one thread and on every core
    with each part of :meth:`Simulator.step` timed as it runs (the force terms, the contact
    query and its cheap follow-up, the constraints, growth, the self-intersection
    relaxation, the Euler step, the areas)."""
    import numba

    from repulsionpak._jit.kernels import set_threads
    from repulsionpak.sim import runner

    sim, model, _, _ = _square_scene(count)
    n = numba.config.NUMBA_NUM_THREADS
    set_threads(n)
    for _ in range(warmup):
        sim.step()
    spent: dict[str, float] = {}

    def timed(name, f):
        def wrapper(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return f(*args, **kwargs)
            finally:
                spent[name] = spent.get(name, 0.0) + time.perf_counter() - t0
        return wrapper

    names = {"find_contacts": "contact query (full, grids rebuilt)",
             "follow_contacts": "contact update (between full queries)",
             "euler_step": "Euler step", "relax_self_intersections": "self-intersection relaxation",
             "skin_areas": "areas"}
    for fn, label in names.items():
        setattr(runner, fn, timed(label, getattr(runner, fn)))
    sim.terms = tuple(timed(f"force: {type(t).__name__}", t) for t in sim.terms)
    for meth, label in (("_constrain", "constraints (inside, skin width, bends, controls)"),
                        ("_grow", "growth"), ("_growth_rates", "growth rates")):
        setattr(sim, meth, timed(label, getattr(sim, meth)))
    rows = {}
    for th in (n, 1):
        set_threads(th)
        for _ in range(5):  # (the other build's first call)
            sim.step()
        spent.clear()
        t0 = time.perf_counter()
        for _ in range(steps):
            sim.step()
        rows[th] = {"the whole iteration": time.perf_counter() - t0, **spent}
    set_threads(1)
    print(f"{model.n_elements} elements, {model.n_vertices} vertices, after {warmup} iterations; "
          f"ms per iteration")
    print(f"| part | {n} threads | 1 thread |")
    print("| --- | ---: | ---: |")
    for name in sorted(rows[n], key=lambda k: -rows[n][k]):
        print(f"| {name} | {rows[n][name] / steps * 1e3:.2f} | {rows[1].get(name, 0.0) / steps * 1e3:.2f} |")


def bench_preprocess() -> None:
    from repulsionpak import examples
    from repulsionpak.io import load_elements
    from repulsionpak.preprocess import build_template, outline_of

    elements = load_elements(examples.element_files())
    t0 = time.perf_counter()
    n = 0
    for e in elements:
        o = outline_of(e)
        scale = 60.0 / np.sqrt(o.area)
        build_template(o, scale, 5.0)
        n += 1
    dt = (time.perf_counter() - t0) / n
    print(f"preprocess: {dt * 1e3:.1f} ms per element ({n} elements, gap 5, ~60 units across)")


def bench_heart(runs: int = 5, secondary: bool = False, pockets: bool = False) -> None:
    """Whole ``repulsionpak pack`` processes on the paper's heart scene (the kernels are
    compiled by a first, untimed run if the cache is cold, and the two-thread builds by a
    warm-up); min / median / max wall time."""
    import json

    if not SHARED.exists():
        print("heart: ../shared/data not found, skipped")
        return
    cmd = ["repulsionpak", "pack", str(SHARED / "containers" / "heart.svg"), str(SHARED / "animals"),
           "-o", "/tmp/bench-heart.svg", "--gap", "5.2", "--seed", "1", "--report", "/tmp/bench-heart.json", "-q"]
    if secondary:
        cmd += ["--secondary", str(SHARED / "secondary" / "small_cat.svg")]
    elif not pockets:  # the animals alone, as the paper's Fig. 3d (comparable with the C++)
        cmd += ["--no-pocket-fill"]
    subprocess.run(cmd, check=True)  # warm the kernel cache
    # and compile what later runs use too: the simulation's two-thread builds (a few runs
    # would otherwise compile them in the background, one thread each meanwhile)
    subprocess.run([sys.executable, "-m", "repulsionpak.warmup"], check=True)
    walls = []
    for k in range(runs):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True)
        walls.append(time.perf_counter() - t0)
        rep = json.loads(Path("/tmp/bench-heart.json").read_text())
        its = rep["iterations"]["primary"]
        sec = rep["seconds"]
        extra = (f", {rep['n_secondary']} secondaries, {rep['iterations']['secondary']} secondary "
                 f"iterations, seeding {sec.get('seeding', 0.0):.2f} s") if secondary else ""
        print(f"heart run {k + 1}: wall {walls[-1]:.2f} s, in-process {sec['total']:.2f} s, {its} "
              f"iterations, {sec['primary'] / its * 1e3:.2f} ms/iteration, area fraction "
              f"{rep['area_fraction']:.3f}, {rep['n_vertices']} vertices{extra}", flush=True)
    print(f"heart wall time: min {min(walls):.2f} s, median {float(np.median(walls)):.2f} s, "
          f"max {max(walls):.2f} s over {runs} runs")


def _sheet_svg() -> str:
    """One element made of every shipped example element on a 4 × 3 sheet inside a
    stroked frame: art of many parts and points (about what a line of text is), whose
    frame's inside is a hole. As the only primary in a circle it leaves one large pocket
    around it, which the pocket fill fills with copies of the whole sheet."""
    from repulsionpak import examples

    cells = []
    for k, f in enumerate(examples.element_files()):
        body = f.read_text(encoding="utf-8")
        body = body[body.index("<svg"):]
        x, y = 100 * (k % 4) + 10, 100 * (k // 4) + 10
        cells.append(body.replace("<svg ", f'<svg x="{x}" y="{y}" ', 1).replace('width="100"', 'width="90"', 1)
                     .replace('height="100"', 'height="90"', 1))
    return ('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 400 300" width="400" height="300">'
            '<rect x="3" y="3" width="394" height="294" fill="none" stroke="#264653" stroke-width="4"/>'
            + "".join(cells) + "</svg>")


def bench_pockets_many(seed: int = 1) -> None:
    """The pocket fill on a scene of many pockets: the sheet of :func:`_sheet_svg` as the
    only primary (``--count 1``) in the shipped circle, pocket copies of the sheet itself
    (default: the automatic fill with its size floor; ``--secondary``: the same sheet as
    the designer's secondary, no floor; with ``--fill-holes`` the frames' insides too).
    Prints per case the pocket fill's seconds (secondary phase + leftover + holes) against
    the primary simulation's, the copies placed, the whole run's wall time and the
    process's peak memory."""
    import json
    import tempfile

    from repulsionpak import examples

    tmp = Path(tempfile.mkdtemp(prefix="bench-pockets-many-"))
    sheet = tmp / "sheet.svg"
    sheet.write_text(_sheet_svg(), encoding="utf-8")
    circle = examples.container_file("circle")
    base = ["repulsionpak", "pack", str(circle), str(sheet), "--count", "1", "--seed", str(seed), "-q",
            "-o", str(tmp / "out.svg"), "--report", str(tmp / "report.json")]
    cases = {"automatic (size floor)": [], "--secondary sheet": ["--secondary", str(sheet)],
             "--secondary sheet --fill-holes": ["--secondary", str(sheet), "--fill-holes"]}
    probe = ("import resource, subprocess, sys; r = subprocess.run(sys.argv[1:]).returncode; "
             "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); sys.exit(r)")
    subprocess.run(base, check=True)  # warm the kernel cache
    print("| case | copies | primary s | pocket fill s (phase + leftover + holes) | fill / primary | "
          "run s (wall) | peak MB |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for name, extra in cases.items():
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-c", probe, *base, *extra], check=True, capture_output=True,
                             text=True)
        wall = time.perf_counter() - t0
        peak = int(out.stdout.split()[-1]) / 1024
        rep = json.loads((tmp / "report.json").read_text())
        sec = rep["seconds"]
        fill = sec.get("secondary", 0.0) + sec.get("leftover", 0.0) + sec.get("holes", 0.0)
        print(f"| {name} | {rep['n_secondary']} | {sec['primary']:.2f} | {fill:.2f} | "
              f"{fill / max(sec['primary'], 1e-9):.2f} | {wall:.1f} | {peak:.0f} |", flush=True)


def bench_mesh() -> None:
    """Skin meshes as the packings build them: the shipped examples at the demo's scale
    (heart, gap 5) and the paper's animals at the heart scene's (gap 5.2). Smallest angle
    (over all triangles, and the 1st percentile of the per-triangle smallest angle),
    vertex and triangle counts, triangulation time."""
    from repulsionpak import examples
    from repulsionpak.geometry import triangulate
    from repulsionpak.io import load_container, load_elements
    from repulsionpak.pack import prepare
    from repulsionpak.params import Params

    scenes = [("examples", examples.container_file("heart"), examples.element_files(), 5.0)]
    if SHARED.exists():
        scenes.append(("animals", SHARED / "containers" / "heart.svg",
                       sorted((SHARED / "animals").glob("*.svg")), 5.2))
    print("| skins | elements | min angle | 1st percentile | vertices | boundary | triangles | triangulation ms |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for name, cont, files, gap in scenes:
        spent = [0.0]
        inner = triangulate.triangulate_polygon

        def timed(*a, **k):
            t0 = time.perf_counter()
            out = inner(*a, **k)
            spent[0] += time.perf_counter() - t0
            return out

        import repulsionpak.preprocess as pp
        pp.triangulate_polygon = timed
        try:
            templates, _, _ = prepare(load_container(cont), load_elements(files), Params(gap=gap, seed=1),
                                      np.random.default_rng(1))
        finally:
            pp.triangulate_polygon = inner
        q = np.degrees(np.concatenate([triangulate.min_angles(t.verts, t.tris) for t in templates]))
        nv = sum(len(t.verts) for t in templates)
        nb = sum(t.n_skin for t in templates)
        nt = sum(len(t.tris) for t in templates)
        print(f"| {name} | {len(templates)} | {q.min():.1f}° | {np.percentile(q, 1):.1f}° | {nv} | {nb} | {nt} "
              f"| {spent[0] * 1e3:.0f} |")


#: loaded into the demo's processes by bench_firstrun (a sitecustomize on PYTHONPATH, so the
#: warm-up process has it too): logs every numba compilation (nested ones with their depth)
#: with its CPU time and argument types
_COMPILE_LOGGER = """
import os, sys, time
if os.environ.get("BENCH_COMPILE_LOG"):
    from numba.core import event

    T0 = float(os.environ.get("BENCH_T0", "0"))

    class _Log(event.Listener):
        stack = []

        def on_start(self, ev):
            self.stack.append((time.process_time(), time.time()))

        def on_end(self, ev):
            c0, w0 = self.stack.pop()
            f = ev.data["dispatcher"].py_func
            role = "warm-up" if sys.argv[0].endswith("warmup.py") else "packing"
            with open(os.environ["BENCH_COMPILE_LOG"], "a") as fh:
                fh.write(f"{role}\\t{f.__module__}.{f.__qualname__}\\t{time.process_time() - c0:.3f}"
                         f"\\t{len(self.stack)}\\t{ev.data['args']}\\t{w0 - T0:.3f}\\t{time.time() - T0:.3f}\\n")

    event.register("numba:compile", _Log())
"""


def _compile_summary(log: str) -> str:
    import collections
    import os

    if not os.path.exists(log):
        return "no compilation"
    cpu: dict = collections.defaultdict(float)
    count: dict = collections.Counter()
    per_kernel: dict = collections.Counter()
    sigs: dict = collections.defaultdict(set)
    for line in open(log):
        role, name, sec, depth, args = line.rstrip("\n").split("\t")[:5]
        if "<locals>" not in name:  # numba's own overloads (np.empty ...) are per caller
            sigs[name].add(args)
        if depth != "0":  # nested: counted in its outermost compilation's time
            continue
        cpu[role] += float(sec)
        count[role] += 1
        per_kernel[name] += 1
    # the same kernel in both processes, or one helper for two argument-type tuples
    twice = [n.rsplit(".", 1)[1] for n in sigs if per_kernel[n] > 1 or len(sigs[n]) > 1]
    parts = [f"{role} {cpu[role]:.1f} CPU s ({count[role]} kernels)" for role in ("packing", "warm-up") if count[role]]
    return "compilation: " + ", ".join(parts) + f"; compiled twice: {', '.join(twice) or 'none'}"


def _compile_timeline(log: str, wall: float) -> str:
    """Per process: when its kernels compiled (wall seconds from the command's start), in
    order, outermost compilations only; then when the packing process ended."""
    import os

    if not os.path.exists(log):
        return ""
    rows = []
    for line in open(log):
        f = line.rstrip("\n").split("\t")
        if len(f) >= 7 and f[3] == "0":
            rows.append((float(f[5]), float(f[6]), f[0], f[1].rsplit(".", 1)[1]))
    out = []
    for role in ("packing", "warm-up"):
        mine = sorted(r for r in rows if r[2] == role)
        if mine:
            spans = ", ".join(f"{name} {a:.1f}–{b:.1f}" for a, b, _, name in mine)
            out.append(f"  {role}: {spans}")
    out.append(f"  the command ended at {wall:.1f} s")
    return "\n".join(out)


def bench_firstrun() -> None:
    """``repulsionpak demo`` twice with an empty numba cache (NUMBA_CACHE_DIR in a fresh
    temporary folder): the first run compiles the kernels, the second loads them. Wall
    and CPU time of the whole process (the warm-up process included); then the first run
    again with the warm-up turned off (``REPULSIONPAK_NO_WARMUP=1``). The compilation's CPU
    time per process (numba's ``numba:compile`` events): the packing's is on the critical
    path."""
    import os
    import tempfile

    runs = [("first run (cold cache)", {}), ("second run", {}),
            ("first run without the warm-up process", {"REPULSIONPAK_NO_WARMUP": "1"})]
    walls = []
    with tempfile.TemporaryDirectory() as tmp:
        site = os.path.join(tmp, "site")
        os.makedirs(site)
        with open(os.path.join(site, "sitecustomize.py"), "w") as fh:
            fh.write(_COMPILE_LOGGER)
        path = os.pathsep.join(p for p in (site, os.environ.get("PYTHONPATH")) if p)
        for k, (label, extra) in enumerate(runs):
            cache = os.path.join(tmp, "numba" if k < 2 else "numba-nowarm")
            log = os.path.join(tmp, f"compile{k}.tsv")
            env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=path, BENCH_COMPILE_LOG=log,
                       BENCH_T0=repr(time.time()), **extra)
            load = os.getloadavg()[0]
            t0 = time.perf_counter()
            r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            subprocess.run([sys.executable, "-m", "repulsionpak.cli", "demo", "-o", os.path.join(tmp, "d.svg")],
                           check=True, env=env, stderr=subprocess.DEVNULL)
            r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
            walls.append(time.perf_counter() - t0)
            ratio = f", {walls[-1] / walls[1]:.2f}× the second run" if k != 1 and len(walls) > 1 else ""
            print(f"demo, {label}: wall {walls[-1]:.1f} s, CPU {cpu:.1f} s (load before: {load:.1f})"
                  f"{ratio}; {_compile_summary(log)}", flush=True)
            if k != 1:
                print(_compile_timeline(log, walls[-1]), flush=True)
        print(f"first run ÷ second run: {walls[0] / walls[1]:.2f}", flush=True)


def bench_freshinstall(prebuild: bool = True) -> None:
    """The README's first command in a new virtual environment: ``pip install <checkout>``
    (a clean clone of HEAD: the committed code), then ``repulsionpak demo`` twice. With
    ``prebuild`` the install compiles the kernels into the package
    (src/repulsionpak/kernel_cache.py); without, ``REPULSIONPAK_PREBUILD=0``."""
    import os
    import shutil
    import tempfile

    root = Path(tempfile.mkdtemp(prefix="repulsionpak-fresh-"))
    try:
        src = root / "clone"
        subprocess.run(["git", "clone", "-q", str(HERE.parent), str(src)], check=True)
        subprocess.run([sys.executable, "-m", "venv", str(root / "venv")], check=True)
        bindir = root / "venv" / "bin"
        env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "NUMBA_CACHE_DIR")}
        env["REPULSIONPAK_PREBUILD"] = "1" if prebuild else "0"
        t = time.perf_counter()
        subprocess.run([str(bindir / "pip"), "install", "-q", str(src)], check=True, env=env, cwd=root,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        install = time.perf_counter() - t
        runs = []
        for k in (1, 2):
            t = time.perf_counter()
            subprocess.run([str(bindir / "repulsionpak"), "demo", "-q", "-o", str(root / f"demo{k}.svg")],
                           check=True, env=env, cwd=root)
            runs.append(time.perf_counter() - t)
        same = (root / "demo1.svg").read_bytes() == (root / "demo2.svg").read_bytes()
        label = "kernels compiled at install" if prebuild else "REPULSIONPAK_PREBUILD=0"
        print(f"fresh venv, {label}: pip install {install:.1f} s, first demo {runs[0]:.1f} s, "
              f"second {runs[1]:.1f} s (outputs {'identical' if same else 'DIFFER'})")
    finally:
        shutil.rmtree(root, ignore_errors=True)


def bench_controls(seeds=(1, 2, 3)) -> None:
    """The heart scene (animals, no pocket fill) packed in-process with every element free,
    fixed upright (``--rotation fixed``) and rigid (``--rigid``): simulation seconds,
    iterations, ms/iteration and the whole pack()'s CPU time (robust on a shared
    machine), median over ``seeds``; the slowdown is relative to free (issue 12 asks for
    at most 20%)."""
    import dataclasses

    from repulsionpak.controls import cli_controls
    from repulsionpak.io import load_container, load_elements
    from repulsionpak.pack import pack
    from repulsionpak.params import Params

    if not SHARED.exists():
        print("controls: ../shared/data not found, skipped")
        return
    cont = load_container(SHARED / "containers" / "heart.svg", tolerance=0.052)
    plain = load_elements([SHARED / "animals"])
    base = Params(gap=5.2)
    base = dataclasses.replace(base, secondary=dataclasses.replace(base.secondary, auto=False))
    warm = dataclasses.replace(base, seed=0, sim=dataclasses.replace(base.sim, max_iterations=30))
    cases = {"free": None, "fixed": cli_controls("fixed"), "rigid": cli_controls(None, True),
             "fixed + rigid": cli_controls("fixed", True)}
    runs = {name: ([], [], []) for name in cases}
    for name, c in cases.items():  # kernels compiled outside the timing
        pack(cont, plain[:2] if c is None else [dataclasses.replace(e, controls=c) for e in plain[:2]], warm)
    for sd in seeds:  # interleaved: a busy machine slows every case alike
        for name, c in cases.items():
            els = plain if c is None else [dataclasses.replace(e, controls=c) for e in plain]
            t0 = time.process_time()
            r = pack(cont, els, dataclasses.replace(base, seed=sd))
            runs[name][0].append(r.iterations["primary"])
            runs[name][1].append(r.seconds["primary"])
            runs[name][2].append(time.process_time() - t0)
    print("| case | iterations | simulation s (wall) | ms/iteration (wall) | pack() CPU s | slowdown vs free (CPU) |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    ref = None
    for name, (its, sim, tot) in runs.items():
        it, sm, tt = (float(np.median(v)) for v in (its, sim, tot))
        ms = float(np.median(np.array(sim) / np.array(its))) * 1e3
        ref = tt if ref is None else ref
        print(f"| {name} | {it:.0f} | {sm:.2f} | {ms:.3f} | {tt:.2f} | {100 * (tt / ref - 1):+.0f}% |", flush=True)


def poster_container(folder: Path) -> Path:
    """Write the poster benchmarks' container, a 1000 x 1500 rectangle, into ``folder``;
    returns its path."""
    rect = Path(folder) / "poster.svg"
    rect.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 1000 1500">'
                    '<rect width="1000" height="1500"/></svg>')
    return rect


def bench_copies(count: int = 300, runs: int = 3) -> None:
    """The stages after the simulation with the per-copy work on one thread and on the
    threads :func:`repulsionpak.threads.thread_map` takes (``count`` shipped elements in a
    1000 x 1500 rectangle, default settings, in this process), alternately; the packing is
    checked to be the same."""
    import hashlib
    import tempfile

    import repulsionpak as rp
    from repulsionpak import examples
    from repulsionpak import threads as th
    from repulsionpak.params import Params

    default = th.MOST_WORKERS
    rows: dict[str, list] = {"one thread": [], f"{th.worker_threads()} threads": []}
    with tempfile.TemporaryDirectory() as tmp:
        rect = poster_container(tmp)
        for _ in range(runs):
            for name, workers in zip(rows, (1, default)):
                th.MOST_WORKERS = workers
                try:
                    p = rp.pack(str(rect), [str(f) for f in examples.element_files()],
                                Params(seed=1).with_(placement__count=count))
                finally:
                    th.MOST_WORKERS = default
                digest = hashlib.sha256(p.svg_text().encode()).hexdigest()[:12]
                rows[name].append((p.seconds, digest))
                print(f"{name}: " + ", ".join(f"{k} {v:.2f}" for k, v in p.seconds.items()) + f", svg {digest}",
                      file=sys.stderr, flush=True)
    digests = {d for v in rows.values() for _, d in v}
    print(f"{count} shipped elements in a 1000 x 1500 rectangle, median of {runs} alternated runs; "
          f"{'the same SVG on every run' if len(digests) == 1 else 'DIFFERENT SVGs: ' + ', '.join(digests)}")
    print("| per-copy work | mapping the art (render) s | verify s | total in-process s |")
    print("| --- | ---: | ---: | ---: |")
    for name, v in rows.items():
        med = {k: float(np.median([s[k] for s, _ in v])) for k in ("render", "verify", "total")}
        print(f"| {name} | {med['render']:.2f} | {med['verify']:.2f} | {med['total']:.2f} |")


def bench_svg(count: int = 300, runs: int = 3) -> None:
    """Writing the packing SVG (``render.svg.packing_svg_string``) of ``count`` shipped
    elements in a 1000 x 1500 rectangle, with the path data written by the kernel
    (``geometry.curves.path_data``) and by the reference writer, one segment at a time in
    Python (``curves._path_data_py``); best of ``runs``, the same text required."""
    import tempfile

    import repulsionpak as rp
    import repulsionpak.render.svg as svg
    from repulsionpak import examples
    from repulsionpak.geometry import curves
    from repulsionpak.params import Params

    with tempfile.TemporaryDirectory() as tmp:
        rect = poster_container(tmp)
        p = rp.pack(str(rect), [str(f) for f in examples.element_files()], Params(seed=1).with_(placement__count=count))

    def best(writer):
        svg.path_data = writer
        try:
            times = []
            for _ in range(runs):
                t0 = time.perf_counter()
                text = svg.packing_svg_string(p.container, p.placed, p.gap)
                times.append(time.perf_counter() - t0)
            return min(times), text
        finally:
            svg.path_data = curves.path_data

    kernel, a = best(curves.path_data)
    python, b = best(lambda c, decimals=4, relative=True: curves._path_data_py(c, decimals, relative))
    if a != b:
        raise SystemExit("the two writers wrote different SVGs")
    print(f"{len(p.placed)} copies ({count} primaries) in a 1000 x 1500 rectangle, {len(a):,} characters, "
          f"best of {runs}")
    print("| path data written | seconds to write the SVG |")
    print("| --- | ---: |")
    print(f"| one segment at a time in Python (reference) | {python:.3f} |")
    print(f"| one kernel call per path | {kernel:.3f} |")


def _best_of(f, runs: int) -> float:
    """The least of ``runs`` timings of ``f()``, seconds."""
    best = np.inf
    for _ in range(runs):
        t = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t)
    return best


def bench_placing(count: int = 1000, runs: int = 5) -> None:
    """Two steps every copy takes, against the plain loops they replace (the same output,
    checked): blue noise for the poster's ``count`` points in its 1000 x 1500 rectangle
    (``placement.blue_noise``: farthest-point sampling of 30 candidates a point), and one
    copy's paths moved under one affine map (``types.transformed_paths``: its map probed
    once, not once per path), over the shipped examples."""
    from repulsionpak import examples
    from repulsionpak.io import load_element
    from repulsionpak.placement import blue_noise
    from repulsionpak.types import transformed_paths

    region = shapely.box(0, 0, 1000, 1500)

    def plain_blue_noise(seed):  # the candidates blue_noise draws, then the loop it replaced
        rng = np.random.default_rng(seed)
        want = count * 30
        m = int(want / 1.0 * 1.2) + 16
        cand = np.column_stack([rng.uniform(0, 1000, m), rng.uniform(0, 1500, m)])
        cand = cand[shapely.contains_xy(region, cand[:, 0], cand[:, 1])][:want]
        chosen = [int(rng.integers(len(cand)))]
        d2 = ((cand - cand[chosen[0]]) ** 2).sum(axis=1)
        for _ in range(count - 1):
            chosen.append(int(np.argmax(d2)))
            d2 = np.minimum(d2, ((cand - cand[chosen[-1]]) ** 2).sum(axis=1))
        return cand[chosen]

    same = np.array_equal(blue_noise(region, count, np.random.default_rng(1)), plain_blue_noise(1))
    new = _best_of(lambda: blue_noise(region, count, np.random.default_rng(1)), runs)
    old = _best_of(lambda: plain_blue_noise(1), runs)
    print(f"| blue noise, {count} points (best of {runs}) | {old:.3f} s | {new:.3f} s | "
          f"{'same points' if same else 'DIFFERENT points'} |")

    arts = [load_element(f).paths for f in examples.element_files()]
    c = np.array([3.0, -2.0])

    def fn(pts):
        return (np.asarray(pts) - c) * 0.37 + [10.0, 20.0]

    together = [transformed_paths(paths, fn) for paths in arts]
    alone = [tuple(a.transformed(fn) for a in paths) for paths in arts]
    same = all(np.array_equal(p, q) for x, y in zip(together, alone) for a, b in zip(x, y)
               for p, q in zip(a.subpaths, b.subpaths))
    reps = 50
    new = _best_of(lambda: [transformed_paths(paths, fn) for _ in range(reps) for paths in arts], runs)
    old = _best_of(lambda: [tuple(a.transformed(fn) for a in paths) for _ in range(reps) for paths in arts], runs)
    n = reps * len(arts)
    print(f"| a copy's paths under one map ({sum(len(a) for a in arts) / len(arts):.0f} paths a copy, "
          f"ms a copy, best of {runs}) | {1e3 * old / n:.3f} | {1e3 * new / n:.3f} | "
          f"{'same paths' if same else 'DIFFERENT paths'} |")


def bench_poster_primary(config: str | None = None, count: int = 1000) -> None:
    """The primary simulation of the 1,000-element poster (``runtime.py poster``) alone, in this
    process: placed and meshed as ``repulsionpak pack`` does, then run to its stop with the
    pockets' parameters (``SimParams.for_run``). ``config``: a TOML file of parameters, as
    ``--config`` takes it. Prints a table row: iterations, seconds, the meshes' area
    fraction at the end, and ms per iteration over the first and the last 500."""
    import tempfile

    from repulsionpak import examples
    from repulsionpak._jit import warmup
    from repulsionpak.inputs import load_inputs
    from repulsionpak.pack import prepare, primary_model
    from repulsionpak.params import load_config, params_from_dict
    from repulsionpak.sim.runner import Simulator

    base = params_from_dict({"seed": 1, "placement": {"count": count}})
    params = base if config is None else load_config(config, base=base)
    with tempfile.TemporaryDirectory() as tmp:
        inp = load_inputs(str(poster_container(Path(tmp))), [str(p) for p in examples.element_files()],
                          params, None)
    params = inp.params
    rng = np.random.default_rng(params.seed)
    templates, placement, gap = prepare(inp.container, inp.elements, params, rng)
    model, state, _ = primary_model(inp.container.region, templates, placement, gap, params)
    sim = Simulator(model, state, params.sim.for_run(True, gap=model.gap), phase="primary")
    warmup.compile_forward(serial=sim.threads() == 1)
    stamps: list[tuple[int, float]] = []
    t0 = time.perf_counter()
    res = sim.run(on_snapshot=lambda s: stamps.append((s.iteration, time.perf_counter())), every=50)
    seconds = time.perf_counter() - t0

    def per_iteration(lo: int, hi: int) -> float:
        got = [(i, t) for i, t in stamps if lo <= i <= hi]
        return 1000.0 * (got[-1][1] - got[0][1]) / max(got[-1][0] - got[0][0], 1) if len(got) > 1 else float("nan")

    n = res.iterations
    print("| config | vertices | iterations | seconds | mesh area | ms/iteration, first 500 | last 500 |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    print(f"| {config or 'defaults'} | {len(state.x):,} | {n:,} | {seconds:.1f} | {res.area_fraction:.4f} | "
          f"{per_iteration(0, 500):.1f} | {per_iteration(n - 500, n):.1f} |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("what", choices=["iteration", "threads", "kernels", "preprocess", "heart", "pockets", "secondary",
                                     "mesh", "firstrun", "freshinstall", "controls", "pockets-many", "copies",
                                     "svg", "placing", "poster-primary", "all"])
    ap.add_argument("--plot", help="iteration: also plot ms/iteration against vertices to this PNG")
    ap.add_argument("--config", help="poster-primary: a TOML file of parameters")
    a = ap.parse_args()
    print(f"machine: {machine()}")
    print(f"date: {time.strftime('%Y-%m-%d')}")
    if a.what in ("preprocess", "all"):
        bench_preprocess()
    if a.what in ("heart", "all"):
        bench_heart()
    if a.what in ("pockets", "all"):  # the default command: pockets filled with small animals
        bench_heart(runs=2, pockets=True)
    if a.what in ("secondary", "all"):
        bench_heart(runs=2, secondary=True)
    if a.what in ("pockets-many", "all"):
        bench_pockets_many()
    if a.what in ("mesh", "all"):
        bench_mesh()
    if a.what in ("firstrun", "all"):
        bench_firstrun()
    if a.what in ("freshinstall", "all"):
        bench_freshinstall()
        bench_freshinstall(prebuild=False)
    if a.what in ("controls", "all"):
        bench_controls()
    if a.what in ("iteration", "all"):
        bench_iteration(plot=a.plot)
    if a.what in ("threads", "all"):
        bench_threads()
    if a.what in ("kernels", "all"):
        bench_kernels()
    if a.what in ("copies", "all"):
        bench_copies()
    if a.what in ("svg", "all"):
        bench_svg()
    if a.what in ("placing", "all"):
        print("| step | plain loop | now | output |")
        print("| --- | ---: | ---: | --- |")
        bench_placing()
    if a.what == "poster-primary":  # (not in "all": runtime.py poster times the whole run)
        bench_poster_primary(a.config)


if __name__ == "__main__":
    sys.exit(main())
