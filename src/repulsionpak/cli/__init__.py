"""Command line: ``repulsionpak pack | evaluate | demo | params``.

The CLI only wires the library together: read inputs, call :func:`repulsionpak.pack.pack`,
write outputs. Errors of our own classes become one line on stderr and an exit code
(see :data:`EXIT_CODES`); ``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import json
import os
import secrets
import signal
import sys
import time
from pathlib import Path
from typing import Annotated, Optional

import typer

from .errors import ConfigError, OutputError, ParameterError, RepulsionPakError, SimulationError

EXIT_CODES = {
    0: "success",
    1: "other error of repulsionpak",
    2: "bad input file (missing, malformed, no usable geometry)",
    3: "bad parameter or config file",
    4: "the simulation failed (diverged)",
    5: "an output cannot be written",
    6: "the packing was written but breaks a promise (overlap, outside, edge margin or gap; see the report)",
    130: "interrupted (a partial result was written if an output was requested)",
}

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Fill a container shape with deformable copies of vector elements "
                       "(RepulsionPak). SVG in, SVG out.")

_DEBUG = False


def _fail(exc: BaseException) -> None:
    if _DEBUG:
        raise exc
    typer.echo(f"repulsionpak: error: {exc}", err=True)
    raise typer.Exit(getattr(exc, "exit_code", 1))


@contextlib.contextmanager
def _errors():
    try:
        yield
    except RepulsionPakError as exc:
        _fail(exc)
    except KeyboardInterrupt:  # typer would turn it into a silent exit 130
        typer.echo("repulsionpak: interrupted", err=True)
        raise typer.Exit(130) from None


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve()
    except OSError:
        return False


#: suffixes of raster pictures: not an output SVG (its picture is --png)
_RASTER = (".png", ".jpg", ".jpeg", ".gif", ".webp", ".bmp", ".tif", ".tiff")


def _check_outputs(outputs: list[Path | None], inputs: list[Path]) -> None:
    """Refuse, before any work, outputs that would overwrite an input (a file a manifest
    names included) or another output, or that cannot be written (a missing directory, one
    without write permission)."""
    import tempfile

    from .io.manifest import with_manifest_files

    inputs = with_manifest_files(inputs)
    seen: list[Path] = []
    for out in outputs:
        if out is None:
            continue
        for inp in inputs:
            if _same_file(out, inp) or (inp.is_dir() and _same_file(out.parent, inp) and out.suffix in (".svg", ".path")):
                raise OutputError(f"{out}: refusing to overwrite the input {inp}; choose another output path")
        if any(_same_file(out, other) for other in seen):
            raise OutputError(f"{out}: named for two outputs (e.g. -o and --png); give each its own file")
        seen.append(out)
        if not out.parent.exists():
            raise OutputError(f"{out}: the directory {out.parent} does not exist")
        if out.is_dir():
            raise OutputError(f"{out}: is a directory, expected a file name")
        try:  # outputs are written atomically: a temporary file beside them, then renamed
            fd, probe = tempfile.mkstemp(dir=out.parent, prefix=".repulsionpak-", suffix=".tmp")
            os.close(fd)
            os.unlink(probe)
        except OSError as e:
            raise OutputError(f"{out}: cannot write in {out.parent} ({e.strerror or e})") from None


class _Progress:
    """Live progress on a terminal (rich), silent when stderr is not a TTY."""

    def __init__(self, enabled: bool, counters: bool = True):
        self.enabled = enabled and sys.stderr.isatty()
        self.counters = counters  # the simulation's iteration, area and element count
        self._live = None
        self._task = None

    def __enter__(self):
        if self.enabled:
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            # the meshes' area (art and the skins around it): the art's own, in the
            # summary, is smaller (0.93 here against 0.79 there read as a failure)
            counters = [TextColumn("it {task.fields[it]:>6}  skins' area {task.fields[area]:.3f}  "
                                   "elements {task.fields[n]}")] if self.counters else []
            self._live = Progress(TextColumn("[bold]{task.fields[phase]}"), BarColumn(), *counters,
                                  TimeElapsedColumn(), transient=True,
                                  console=__import__("rich.console").console.Console(stderr=True))
            self._live.__enter__()
            self._task = self._live.add_task("pack", total=None, phase="start", it=0, area=0.0, n=0)
        return self

    def __call__(self, snap) -> None:
        if self._live is not None:
            self._live.update(self._task, phase=snap.phase, it=snap.iteration,
                              area=snap.area_fraction, n=snap.n_elements)

    def stage(self, name: str) -> None:
        """A stage without snapshots (the art's map, the verification, writing ...): its
        name replaces the phase's, the clock goes on."""
        if self._live is not None:
            self._live.update(self._task, phase=name)

    def __exit__(self, *exc):
        if self._live is not None:
            self._live.__exit__(*exc)


class _FrameProgress:
    """The movie's frames being drawn and encoded (a bar on a terminal, after the
    simulation's bar has gone)."""

    def __init__(self, enabled: bool):
        self.enabled = enabled and sys.stderr.isatty()
        self._live = self._task = None

    def __enter__(self):
        if self.enabled:
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

            self._live = Progress(TextColumn("[bold]movie"), BarColumn(), MofNCompleteColumn(),
                                  TextColumn("frames"), TimeElapsedColumn(), transient=True,
                                  console=Console(stderr=True))
            self._live.__enter__()
            self._task = self._live.add_task("movie", total=None)
        return self

    def __call__(self, done: int, total: int) -> None:
        if self._live is not None:
            self._live.update(self._task, total=total, completed=done)

    def __exit__(self, *exc):
        if self._live is not None:
            self._live.__exit__(*exc)


class _StopFlag:
    """SIGINT/SIGTERM handler: the first signal asks the simulation to stop after the
    current iteration (a partial packing is then written), or, once the simulation is
    over, the verification to end its repair rounds (what still violates is dropped); a
    second one aborts (Ctrl-C twice, or ``kill`` twice). A signal before the simulation
    first asks whether to stop (while the inputs are read, meshed and placed: nothing to
    write yet) aborts at once."""

    def __init__(self):
        self.stop = False
        self.polled = False  # the simulation has started asking
        self._old = {}

    def __enter__(self):
        def handler(signum, frame):
            if self.stop or not self.polled:
                raise KeyboardInterrupt
            self.stop = True

        for sig in (signal.SIGINT, signal.SIGTERM):
            with contextlib.suppress(ValueError):  # not in the main thread
                self._old[sig] = signal.signal(sig, handler)
        return self

    def __call__(self) -> bool:
        self.polled = True
        return self.stop

    def at_stage(self, name: str) -> None:
        """While the art is mapped there is no partial result to stop at (it is what any
        packing needs written): a signal then aborts at once, as before the simulation (a
        first SIGTERM was ignored for minutes on art of 1,000 subpaths). The verification
        polls again: a signal there ends its repair rounds."""
        if name == "mapping the art":
            self.polled = False

    def __exit__(self, *exc):
        for sig, old in self._old.items():
            signal.signal(sig, old)


def resolve_params(config: Path | None = None, gap: float | None = None, seed: int | None = None,
                   count: int | None = None, max_iterations: int | None = None, margin: float | None = None,
                   pocket_fill: bool = True, container_paint: str | None = None):
    """:class:`Params` from ``--config`` with the options ``--gap``, ``--seed``, ``--count``,
    ``--max-iterations``, ``--margin``, ``--no-pocket-fill`` and ``--container-paint`` on
    top, validated; errors name the option. The seed and the gap stay None when neither the
    config nor the options give them."""
    from .params import Params, load_config
    from .render.container_paint import CONTAINER_PAINTS

    params = load_config(config) if config else Params()
    if container_paint is not None:
        if container_paint not in CONTAINER_PAINTS:
            raise ParameterError(f"--container-paint must be one of {', '.join(CONTAINER_PAINTS)}, "
                                 f"got {container_paint!r}")
        params = dataclasses.replace(params, output=dataclasses.replace(params.output,
                                                                        container_paint=container_paint))
    if gap is not None:
        if not gap > 0:
            raise ParameterError(f"--gap must be a positive number, got {gap:g}")
        params = dataclasses.replace(params, gap=gap)
    if seed is not None:
        params = dataclasses.replace(params, seed=seed)
    if not pocket_fill:
        params = dataclasses.replace(params, secondary=dataclasses.replace(
            params.secondary, auto=False, fill_holes=False, fill_leftover=False))
    if margin is not None:
        if not margin >= 0:
            raise ParameterError(f"--margin must be a number >= 0, got {margin:g}")
        params = dataclasses.replace(params, margin=margin)
    for option, value, low in (("--count", count, 1), ("--max-iterations", max_iterations, 1), ("--seed", seed, 0)):
        if value is not None and value < low:  # name the option, not the config key
            raise ParameterError(f"{option} must be >= {low}, got {value}")
    if seed is not None and seed >= 2**64:
        raise ParameterError(f"--seed must be < 2**64, got {seed}")
    if count is not None:
        params = dataclasses.replace(params, placement=dataclasses.replace(params.placement, count=count))
    if max_iterations is not None:
        params = dataclasses.replace(params, sim=dataclasses.replace(params.sim, max_iterations=max_iterations))
    return params.validate()


def _warm_up_meanwhile(run):
    """First run: start the warm-up process (a second process compiling the kernels from
    the far end, :mod:`repulsionpak.warmup`) before anything else, so that it compiles while
    the inputs are read, and end it however the run ends (an input error included)."""
    @functools.wraps(run)
    def wrapped(*args, **kwargs):
        from ._jit import prebuilt, warmup
        from .warmup import WORKLOAD

        prebuilt.install()  # kernels compiled when the package was built: nothing to warm up
        compiling = warmup.start(WORKLOAD)
        try:
            return run(*args, **kwargs)
        finally:
            warmup.stop(compiling)
    return wrapped


@_warm_up_meanwhile
def run_pack(container: Path, elements: list[Path], output: Path, secondary: list[Path] | None = None,
             gap: float | None = None, seed: int | None = None, config: Path | None = None,
             report: Path | None = None, png: Path | None = None, count: int | None = None,
             max_iterations: int | None = None, progress: bool = True, debug_layers: bool = False,
             checkpoint: Path | None = None, checkpoint_every: int = 500, resume: Path | None = None,
             margin: float | None = None, pocket_fill: bool = True, fill_holes: bool = False,
             pdf: Path | None = None,
             movie: Path | None = None, movie_every: int | None = None, movie_size: int = 600,
             controls=None, live: dict | None = None, container_paint: str | None = None,
             flow: Path | None = None) -> dict:
    """Everything ``repulsionpak pack`` does; returns the report dict. An ``output`` ending
    in ``.pdf`` is written as a vector PDF instead of SVG; ``pdf`` adds a PDF beside it;
    ``movie`` (.gif or .mp4) the simulation as an animation, a frame every ``movie_every``
    iterations (default: adapted to the run's length), ``movie_size`` pixels along the
    frames' longer side. ``live`` (``{"port": N, "open_browser": bool, "paused": bool}``)
    serves the run in the browser and writes the outputs only at Ctrl-C (see
    :mod:`repulsionpak.live`). ``container_paint`` (``outline``, ``as-drawn``, ``none``;
    None: the config's, else ``outline``) is how every output draws the container. ``flow``:
    a guide SVG the elements follow (docs/flow.md)."""
    from .pack import pack

    t_start = time.perf_counter()
    if output.suffix.lower() in _RASTER:
        raise ParameterError(f"-o {output}: the output is an SVG (or a PDF: .pdf); "
                             f"write the picture with --png {output.name}" if png is None else
                             f"-o {output}: the output is an SVG (or a PDF: .pdf), not a picture")
    if config is not None and config.is_dir():  # (not an element directory for the outputs' check)
        raise ConfigError(f"{config}: is a directory, expected a TOML file")
    inputs = [container, *elements, *(secondary or [])] + ([config] if config else [])
    _check_outputs([output, report, png, checkpoint, pdf, movie], inputs + ([resume] if resume else []))
    recorder = None
    if movie is None and movie_every is not None:
        raise ParameterError("--movie-every needs --movie OUT.gif|OUT.mp4")
    if movie is not None:
        from .render.movie import MovieRecorder, check_movie_output

        check_movie_output(movie)  # before the run: an MP4 without imageio-ffmpeg fails now
        recorder = MovieRecorder(movie, every=movie_every, size_px=movie_size)
    if checkpoint_every < 1:
        raise ParameterError(f"--checkpoint-every must be >= 1, got {checkpoint_every}")
    resumed = None
    if resume is not None:
        from .checkpoint import load_checkpoint

        resumed = load_checkpoint(resume)
        if seed is None:  # the seed of the interrupted run
            seed = int(next(iter(resumed.values()))["seed"])
    params = resolve_params(config, gap, seed, count, max_iterations, margin, pocket_fill, container_paint)
    if params.seed is None:
        params = dataclasses.replace(params, seed=secrets.randbelow(2**31))
    if fill_holes and pocket_fill:  # --fill-holes: copies go into the holes of the art too
        params = dataclasses.replace(params, secondary=dataclasses.replace(params.secondary, fill_holes=True))
    from .inputs import load_inputs

    run_in = load_inputs(container, elements, params, secondary or (), controls)
    cont, elems, secs, params = run_in.container, run_in.elements, run_in.secondary, run_in.params
    on_checkpoint = None
    if checkpoint is not None or resume is not None:
        from .checkpoint import fingerprint, load_checkpoint, save_checkpoint

        from .io.manifest import with_manifest_files

        files = [container, *_expand(with_manifest_files([*elements, *(secondary or [])])),
                 *([] if flow is None else [flow])]
        # the controls (--rotation, --rigid, --stiffness, the manifests' settings) shape the run too
        # (how the outputs draw the container is no part of the simulation's state)
        run_params = {k: v for k, v in params.to_dict().items() if k != "output"}
        fp = fingerprint(files, dict(run_params, controls=[repr(e.controls) for e in [*elems, *secs]]))
        if resume is not None:
            resumed = load_checkpoint(resume, fp)
        if checkpoint is not None:
            def on_checkpoint(states: dict) -> None:
                save_checkpoint(checkpoint, {k: dict(v, seed=params.seed) for k, v in states.items()}, fp)
    if progress:
        from ._jit import warmup
        from ._jit.kernels import cache_is_cold

        cold = cache_is_cold()
        if cold:
            typer.echo("compiling the simulation kernels, first run only…", err=True)
        elif warmup.compiles_parallel_only():
            typer.echo("compiling the two-thread simulation kernels in the background "
                       "(later runs use both cores)…", err=True)
        if not cold and report is not None:
            from .geometry.overlap import is_cold as fit_is_cold

            if fit_is_cold():
                typer.echo("compiling the report's distortion kernels, first run only…", err=True)
    from ._jit import warmup

    viewer = None
    try:
        with _Progress(progress) as prog, _StopFlag() as stop:
            on_snapshot, snap_kw = prog, {}
            if recorder is not None:
                def on_snapshot(snap):
                    prog(snap)
                    recorder(snap)
                snap_kw = {"snapshot_every": recorder.snapshot_every}
            if live is not None:  # the browser view steers through the two callbacks
                from .live import LiveRun

                viewer = LiveRun(cont, params, external_stop=stop, **live)
                viewer.start()
                on_snapshot = viewer.on_snapshot(on_snapshot)
            packing = pack(cont, elems, params, secondary=secs, on_snapshot=on_snapshot,
                           should_stop=stop if viewer is None else viewer.should_stop,
                           on_checkpoint=on_checkpoint, checkpoint_every=checkpoint_every,
                           resume=resumed, on_stage=lambda name: (prog.stage(name), stop.at_stage(name)),
                           sources=run_in.sources, **snap_kw, **({} if flow is None else {"flow": flow}))
    except BaseException as exc:
        if viewer is not None:
            viewer.close()
        if isinstance(exc, SimulationError):  # the seed reproduces the run (it may have been drawn at random)
            raise type(exc)(f"{exc} (seed {params.seed}: rerun with --seed {params.seed} to reproduce)") from exc
        raise
    finally:
        warmup.stop(warmup.running())  # started by _warm_up_meanwhile; done before rendering
    # the packing is made: from here a first signal ends the run once the SVG and the
    # report are written (the outputs still to come are left out); a second one aborts
    with _StopFlag() as late:
        late.polled = True
        return _write_outputs(packing, late, viewer, t_start, output, report, png, pdf, recorder, progress,
                              debug_layers)


def _write_outputs(packing, late, viewer, t_start, output, report, png, pdf, recorder, progress,
                   debug_layers) -> dict:
    """Evaluate ``packing`` and write its outputs (the second half of :func:`run_pack`).
    After a signal (``late.stop``) only the SVG and the report are still written; the
    report then lists the outputs left out (``not_written``)."""
    if viewer is not None:
        viewer.drop_removed(packing)
    t_eval = time.perf_counter()
    # the stages after the packing take seconds on large scenes: say which one runs
    with _Progress(progress and viewer is None, counters=False) as stages:
        stages.stage("measuring")
        # area, gaps, overlap, edge distances: exact; the distortion fit only for a report
        metrics = packing.metrics(distortion=report is not None)
        stages.stage("writing")
        hiding = packing.paint_warning()
        if hiding is not None:
            import warnings

            warnings.warn(hiding, stacklevel=1)
        text = packing.svg_text(debug_layers=debug_layers, path=output)
        if viewer is not None:  # serve the result until Ctrl-C, then write it
            viewer.finish(packing, metrics, text)
            served = time.perf_counter()
            if not packing.partial:
                with _StopFlag() as again:
                    viewer.wait(again)
            viewer.close()
            served = time.perf_counter() - served  # not part of the run's times in the report
            t_start, t_eval = t_start + served, t_eval + served
        packing.save(output, debug_layers=debug_layers, format="pdf" if output.suffix.lower() == ".pdf" else "svg")
        not_written: list[str] = []
        for extra, kind, stage in ((pdf, "pdf", None), (png, "png", "drawing the picture")):
            if extra is None:
                continue
            if late.stop:
                not_written.append(str(extra))
            else:
                if stage:
                    stages.stage(stage)
                packing.save(extra, debug_layers=debug_layers, format=kind)
    seconds = dict(packing.seconds)
    seconds["render"] = seconds.get("render", 0.0) + (time.perf_counter() - t_eval)
    movie_info = None
    if recorder is not None and not late.stop:
        try:
            with _FrameProgress(progress) as prog:
                def frame_done(done: int, total: int) -> None:
                    if late.stop:  # the film is written atomically: nothing is left behind
                        raise KeyboardInterrupt
                    prog(done, total)

                movie_info = recorder.write(packing, progress=frame_done)
        except (Exception, KeyboardInterrupt):  # noqa: BLE001  (the encoder, sent the same Ctrl-C, may fail first)
            if not late.stop:
                raise
        if movie_info is not None:
            seconds["movie"] = movie_info.render_seconds + recorder.capture_seconds
    if recorder is not None and movie_info is None:
        not_written.append(str(recorder.path))
    seconds["total"] = time.perf_counter() - t_start
    movie_entry = None if movie_info is None else {
        "file": movie_info.path, "frames": movie_info.frames, "fps": movie_info.fps,
        "seconds": movie_info.seconds, "bytes": movie_info.bytes, "every": movie_info.stride}
    rep = packing.report(seconds=seconds, not_written=not_written, movie=movie_entry)
    if report is not None:
        _write_json_atomic(report, rep)
    return rep


def _expand(paths: list[Path]) -> list[Path]:
    """Files of a list of files and directories (as load_elements reads them), sorted."""
    out = []
    for p in paths:
        p = Path(p)
        if p.is_dir():
            out.extend(sorted(f for f in p.iterdir() if f.suffix.lower() in (".svg", ".path", ".svgz")))
        else:
            out.append(p)
    return out


def _write_json_atomic(path: Path, data: dict) -> None:
    from .io.files import atomic_write_bytes

    atomic_write_bytes(path, (json.dumps(data, indent=2) + "\n").encode("utf-8"))


def _summary(rep: dict, output: Path) -> str:
    inv = rep["invariants"]
    ok = inv["ok"]
    median = rep["gap_stats"]["median"]  # None with fewer than two elements
    return (f"{output}: {rep['n_primary']} primary + {rep['n_secondary']} secondary elements, "
            f"area fraction {rep['area_fraction']:.3f}, median gap "
            f"{'-' if median is None else format(median, '.3g')} "
            f"(asked {rep['gap']:.3g}), {sum(rep['iterations'].values())} iterations in "
            f"{rep['seconds']['total']:.1f} s, seed {rep['seed']}"
            + ("" if ok else "  [invariants violated: see the report]")
            + ("  [stopped at max_iterations before it converged]"
               if "max_iterations" in (rep.get("stopped_by") or {}).values() and not rep["partial"] else "")
            + ("  [PARTIAL: interrupted]" if rep["partial"] else ""))


def _exit_if_interrupted(rep: dict, output: Path) -> None:
    """Exit 130 after a Ctrl-C or SIGTERM: the packing was stopped early (written, marked
    partial), or it was complete and outputs after the SVG and the report were left out."""
    if rep.get("not_written"):
        typer.echo(f"repulsionpak: interrupted: {output} is written; not written: "
                   f"{', '.join(rep['not_written'])}", err=True)
        raise typer.Exit(130)
    if rep["partial"]:
        raise typer.Exit(130)


def _movie_line(m: dict) -> str:
    return (f"movie: {m['file']}: {m['frames']} frames, {m['seconds']:.1f} s at {m['fps']:.3g} fps, "
            f"a frame every {m['every']} iterations, {m['bytes'] / 1e6:.2f} MB")


DebugOpt = Annotated[bool, typer.Option("--debug", help="Show Python tracebacks on errors.")]
# options shared by `pack` and `batch`
ContainerArg = Annotated[Path, typer.Argument(help="Container: SVG or .path file; every closed path is a region.")]
ElementsArg = Annotated[list[Path], typer.Argument(help="Element files (SVG or .path) or directories of them.")]
SecondaryOpt = Annotated[Optional[list[Path]], typer.Option("--secondary", help="A secondary element file or directory; repeat the option for more.")]
GapOpt = Annotated[Optional[float], typer.Option(help="Gap between elements' art, container units (default: 1% of its size, at most 4% of its width).")]
ConfigOpt = Annotated[Optional[Path], typer.Option(help="TOML file of parameters (see `repulsionpak params`).")]
CountOpt = Annotated[Optional[int], typer.Option(help="Number of primary elements (default: from container area and gap).")]
MaxIterationsOpt = Annotated[Optional[int], typer.Option(help="Upper bound on the growing iterations of each phase; the settling ones (sim.settle_iterations, default 300) follow.")]
QuietOpt = Annotated[bool, typer.Option("-q", "--quiet", help="No progress display or summary.")]
MarginOpt = Annotated[Optional[float], typer.Option(help="Smallest distance from any art to the container's edge (default: gap/2).")]
RotationOpt = Annotated[Optional[str], typer.Option(help="Default rotation of the elements: free, fixed[:ANGLE], limited:DEG or upright[:DEG] (see docs/controls.md).")]
RigidOpt = Annotated[bool, typer.Option("--rigid", help="Elements never deform (rigid bodies).")]
StiffnessOpt = Annotated[Optional[float], typer.Option(help="Multiplier of the spring constants of the elements.")]
NoPocketFillOpt = Annotated[bool, typer.Option("--no-pocket-fill", help="Without --secondary, leave the pockets empty (default: fill them with small copies of the elements).")]
ContainerPaintOpt = Annotated[Optional[str], typer.Option(
    "--container-paint", metavar="outline|as-drawn|none",
    help="How the outputs draw the container: outline (default: its exact shape as a thin stroke, "
         "never hiding the art), as-drawn (its own fill and stroke, under the art) or none.")]


def _movie_path(value: Optional[Path]) -> Optional[Path]:
    if value is not None and value.suffix.lower() not in (".gif", ".mp4"):
        raise typer.BadParameter(f"{value}: unknown movie format {value.suffix or '(no extension)'!r}; "
                                 "use a file ending in .gif or .mp4")
    return value


MovieOpt = Annotated[Optional[Path], typer.Option(
    "--movie", callback=_movie_path,
    help="Also write the simulation as an animation: OUT.gif (Pillow) or OUT.mp4 (needs "
         "pip install 'repulsionpak\\[mp4]'); about 12 s, then the result held for 2 s.")]
MovieEveryOpt = Annotated[Optional[int], typer.Option(
    "--movie-every", min=1, help="Iterations between movie frames (default: chosen from the run's length).")]
MovieSizeOpt = Annotated[int, typer.Option(
    "--movie-size", min=64, max=4000, help="Longer side of the movie's frames, pixels.")]


@app.command()
def pack(
    container: ContainerArg,
    elements: ElementsArg,
    output: Annotated[Path, typer.Option("-o", "--output", help="Output SVG (or a vector PDF when it ends in .pdf).")],
    secondary: SecondaryOpt = None,
    gap: GapOpt = None,
    seed: Annotated[Optional[int], typer.Option(help="Random seed; the same seed gives a byte-identical result.")] = None,
    margin: MarginOpt = None,
    no_pocket_fill: NoPocketFillOpt = False,
    fill_holes: Annotated[bool, typer.Option(
        "--fill-holes", help="Also put pocket copies in the holes of elements (a ring's middle, a letter's "
        "counter, the inside of a logo); off by default.")] = False,
    config: ConfigOpt = None,
    report: Annotated[Optional[Path], typer.Option(help="Write a JSON report here.")] = None,
    png: Annotated[Optional[Path], typer.Option(help="Also render the packing to this PNG.")] = None,
    pdf: Annotated[Optional[Path], typer.Option(help="Also write the packing as a vector PDF (for print).")] = None,
    count: CountOpt = None,
    max_iterations: MaxIterationsOpt = None,
    debug_layers: Annotated[bool, typer.Option("--debug-layers", help="Add hidden skin layers to the SVG.")] = False,
    checkpoint: Annotated[Optional[Path], typer.Option(help="Save the simulation state to this file periodically.")] = None,
    checkpoint_every: Annotated[int, typer.Option(help="Iterations between checkpoints.")] = 500,
    resume: Annotated[Optional[Path], typer.Option(help="Continue an interrupted run from its checkpoint (same inputs and options).")] = None,
    movie: MovieOpt = None,
    movie_every: MovieEveryOpt = None,
    movie_size: MovieSizeOpt = 600,
    rotation: RotationOpt = None,
    rigid: RigidOpt = False,
    stiffness: StiffnessOpt = None,
    flow: Annotated[Optional[Path], typer.Option(
        "--flow", help="An SVG of guide strokes (in the container's units): the elements turn to follow "
        "the field interpolated from them (see docs/flow.md).")] = None,
    live: Annotated[bool, typer.Option("--live", help="Watch and steer the run in the browser; Ctrl-C writes the outputs.")] = False,
    port: Annotated[int, typer.Option(help="Port of the --live server (127.0.0.1 only).")] = 8765,
    no_browser: Annotated[bool, typer.Option("--no-browser", help="With --live: only print the URL.")] = False,
    paused: Annotated[bool, typer.Option("--paused", help="With --live: pause at the first frame.")] = False,
    container_paint: ContainerPaintOpt = None,
    quiet: QuietOpt = False,
    debug: DebugOpt = False,
) -> None:
    """Pack CONTAINER with deformed copies of ELEMENTS and write OUTPUT (SVG).

    An element argument ending in .toml is an element manifest (controls per element)."""
    global _DEBUG
    _DEBUG = debug
    with _errors():
        from .controls import cli_controls

        rep = run_pack(container, elements, output, secondary, gap, seed, config, report, png,
                       count, max_iterations, progress=not quiet, debug_layers=debug_layers,
                       checkpoint=checkpoint, checkpoint_every=checkpoint_every, resume=resume,
                       margin=margin, pocket_fill=not no_pocket_fill, fill_holes=fill_holes, pdf=pdf,
                       movie=movie, movie_every=movie_every, movie_size=movie_size,
                       controls=cli_controls(rotation, rigid, stiffness),
                       live={"port": port, "open_browser": not no_browser, "paused": paused} if live else None,
                       container_paint=container_paint, flow=flow)
        if not quiet:
            typer.echo(_summary(rep, output), err=True)
            if "movie" in rep:
                typer.echo(_movie_line(rep["movie"]), err=True)
        _exit_if_interrupted(rep, output)
        if not rep["invariants"]["ok"]:
            typer.echo(f"repulsionpak: error: {output}: the packing breaks a promise (see the report's "
                       "'invariants'); it was written for inspection", err=True)
            raise typer.Exit(6)


@app.command()
def evaluate(
    packings: Annotated[list[Path], typer.Argument(help="Packing SVG(s) written by `repulsionpak pack`.")],
    json_out: Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")] = False,
    plot: Annotated[Optional[Path], typer.Option(help="Plot Q_s(r) of all given packings to this PNG.")] = None,
    gap: Annotated[Optional[float], typer.Option(help="Gap to evaluate against (default: the file's data-gap).")] = None,
    margin: Annotated[Optional[float], typer.Option(
        help="Edge margin to check (default: the one the packing was made with, else half the gap).")] = None,
    grid: Annotated[int, typer.Option(help="Pixels along the longer side of the SCP raster.")] = 1000,
    elements: Annotated[Optional[list[Path]], typer.Option(
        "--elements", help="A source element file or directory (matched by data-source; repeat the option for more): "
                           "adds each element's distortion from its source.")] = None,
    debug: DebugOpt = False,
) -> None:
    """Measure packings: area fraction, overlaps, gaps, edge distance, deformation,
    distortion (with --elements), SCP Q_s(r) (sec. 11)."""
    global _DEBUG
    _DEBUG = debug
    from .io.files import atomic_write_bytes
    from .measure import evaluate_file, format_table, scp_plot_png
    from .packing import fit_workers

    with _errors():
        if gap is not None and not gap > 0:
            raise ParameterError(f"--gap must be a positive number, got {gap:g}")
        if margin is not None and not margin >= 0:
            raise ParameterError(f"--margin must be a number >= 0, got {margin:g}")
        if plot is not None:
            _check_outputs([plot], packings)
        sources = None
        if elements:
            from .io import load_elements
            from .measure import source_geometries

            sources = source_geometries(load_elements(elements))
            from .geometry.overlap import is_cold as fit_is_cold
            from ._jit.prebuilt import install

            install()  # the distortion kernels compiled when the package was built, if any

            if fit_is_cold():
                typer.echo("compiling the distortion kernels, first run only…", err=True)
        results = []
        with _Progress(True, counters=False) as prog:  # a large packing takes half a minute
            for p in packings:
                prog.stage(f"measuring {p.name}")
                results.append((p, evaluate_file(p, gap=gap, grid=grid, sources=sources,
                                                 workers=fit_workers(), margin=margin)))
        for p, r in results if sources is not None else ():
            values = (r.get("distortion") or {}).get("values") or []
            if values and all(v is None for v in values):
                typer.echo(f"repulsionpak: warning: {p}: none of its copies comes from the --elements given "
                           "(matched by file name, the copies' data-source): distortion unknown", err=True)
        if json_out:
            data = results[0][1] if len(results) == 1 else {str(p): r for p, r in results}
            typer.echo(json.dumps(data, indent=2))
        else:
            for p, r in results:
                typer.echo(f"== {p}")
                typer.echo(format_table(r))
        if plot is not None:
            atomic_write_bytes(plot, scp_plot_png([(p.stem, r) for p, r in results],
                                                  gap=results[0][1]["gap"]["requested"]))


class _BatchProgress:
    """Progress of a batch: a bar on a terminal, else one line per finished job."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self.tty = enabled and sys.stderr.isatty()
        self._live = None
        self._task = None
        self.n = self.done = self.failed = 0

    def start(self, n_jobs: int, client) -> None:
        self.n = n_jobs
        if not self.enabled:
            return
        workers = client.scheduler_info().get("workers", {})
        typer.echo(f"repulsionpak: {n_jobs} packings on {len(workers)} Dask workers ({client.scheduler.address})",
                   err=True)
        if not workers:
            typer.echo("repulsionpak: no worker yet: start some with `dask worker ADDRESS`", err=True)
        if self.tty:
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, \
                TimeRemainingColumn

            self._live = Progress(TextColumn("[bold]batch"), BarColumn(), MofNCompleteColumn(),
                                  TextColumn("{task.fields[failed]} failed"), TimeElapsedColumn(),
                                  TimeRemainingColumn(), transient=True, console=Console(stderr=True))
            self._live.__enter__()
            self._task = self._live.add_task("batch", total=n_jobs, failed=0)

    def __call__(self, i: int, job, result) -> None:
        self.done += 1
        self.failed += not result.ok
        if self.enabled:
            for w in result.warnings:
                line = f"repulsionpak: warning: {job.name}: {w}"
                if self._live is not None:
                    self._live.console.print(line, markup=False, highlight=False)
                else:
                    typer.echo(line, err=True)
        if self._live is not None:
            self._live.update(self._task, advance=1, failed=self.failed)
        elif self.enabled:
            m = result.metrics or {}
            what = (f"area {m['area_fraction']:.3f}, Q_s(gap/2) {result.scp_half_gap:.4f}"
                    if result.ok and result.scp_half_gap is not None else f"failed: {result.error}")
            typer.echo(f"[{self.done}/{self.n}] {job.name}: {what} ({result.seconds:.1f} s)", err=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self._live is not None:
            self._live.__exit__(*exc)


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """SIGTERM ends a batch like Ctrl-C does (cancel, write what finished, exit 130)."""
    def handler(signum, frame):
        raise KeyboardInterrupt

    try:
        old = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not in the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


@app.command()
def batch(
    container: ContainerArg,
    elements: ElementsArg,
    output: Annotated[Path, typer.Option("-o", "--output", help="Output directory (created if missing).")],
    seeds: Annotated[str, typer.Option(help="Seeds: A-B (inclusive), N, or a comma list of them.")],
    set_: Annotated[Optional[list[str]], typer.Option(
        "--set", help="SECTION.NAME=V1,V2,...: one job per value, combined with every seed and every other "
                      "--set (names as in `repulsionpak params`).")] = None,
    workers: Annotated[Optional[int], typer.Option(help="Worker processes of the local Dask cluster (default: one per core).")] = None,
    scheduler: Annotated[Optional[str], typer.Option(help="Run on this Dask scheduler (tcp://HOST:PORT) instead of a local cluster.")] = None,
    secondary: SecondaryOpt = None,
    gap: GapOpt = None,
    count: CountOpt = None,
    max_iterations: MaxIterationsOpt = None,
    margin: MarginOpt = None,
    no_pocket_fill: NoPocketFillOpt = False,
    config: ConfigOpt = None,
    rotation: RotationOpt = None,
    rigid: RigidOpt = False,
    stiffness: StiffnessOpt = None,
    container_paint: ContainerPaintOpt = None,
    quiet: QuietOpt = False,
    debug: DebugOpt = False,
) -> None:
    """Run one packing per seed × --set value as Dask tasks; write OUTDIR/*.svg, results.csv,
    best.svg (lowest Q_s(gap/2)) and contact-sheet.png."""
    global _DEBUG
    _DEBUG = debug
    from .batch import run_batch
    from .controls import cli_controls

    with _errors():
        base = resolve_params(config, gap, None, count, max_iterations, margin, not no_pocket_fill,
                              container_paint)
        with _BatchProgress(not quiet) as prog, _sigterm_as_interrupt():
            summary = run_batch(container, elements, output, seeds, set_ or [], base, secondary or [],
                                workers=workers, scheduler=scheduler, on_start=prog.start, on_result=prog,
                                controls=cli_controls(rotation, rigid, stiffness))
        n = len(summary.jobs)
        if not quiet:
            best = summary.best
            typer.echo(f"{output}: {summary.n_done} of {n} packings done, {summary.n_failed} failed, in "
                       f"{summary.seconds:.1f} s; "
                       + (f"best {best.name}.svg (Q_s(gap/2) {best.scp_half_gap:.4f}) -> best.svg"
                          if best is not None else "no best.svg (nothing finished)"), err=True)
        if summary.interrupted:
            typer.echo(f"repulsionpak: interrupted: {n - summary.n_done - summary.n_failed} packings cancelled; "
                       "results.csv lists what finished", err=True)
            raise typer.Exit(130)
        if summary.n_failed:
            codes = {r.exit_code for r in summary.results if r is not None and not r.ok}
            code = codes.pop() if summary.n_done == 0 and len(codes) == 1 else 1
            typer.echo(f"repulsionpak: error: {summary.n_failed} of {n} packings failed; see the error column "
                       f"of {output / 'results.csv'}", err=True)
            raise typer.Exit(code)


@app.command()
def demo(
    output: Annotated[Path, typer.Option("-o", "--output", help="Output SVG (a PNG is written beside it).")] = Path("repulsionpak-demo.svg"),
    container: Annotated[str, typer.Option(help="Name of a shipped example container.")] = "",
    seed: Annotated[int, typer.Option(help="Random seed.")] = 1,
    movie: MovieOpt = None,
    movie_every: MovieEveryOpt = None,
    movie_size: MovieSizeOpt = 600,
    container_paint: ContainerPaintOpt = None,
    quiet: Annotated[bool, typer.Option("-q", "--quiet", help="No progress display or summary.")] = False,
    debug: DebugOpt = False,
) -> None:
    """Pack the example library shipped with repulsionpak (SVG + PNG; 5–8 s on two cores; about 12 s the first time where the package was installed without its compiled kernels)."""
    global _DEBUG
    _DEBUG = debug
    from . import examples

    with _errors():
        cfile = examples.container_file(container or examples.DEFAULT_CONTAINER)
        png = output.with_suffix(".png")
        rep = run_pack(cfile, examples.element_files(), output, secondary=examples.secondary_files(),
                       gap=examples.DEFAULT_GAP, seed=seed, png=png, progress=not quiet,
                       movie=movie, movie_every=movie_every, movie_size=movie_size,
                       container_paint=container_paint)
        if not quiet:
            typer.echo(_summary(rep, output), err=True)
            if "not_written" not in rep:
                typer.echo(f"picture: {png}", err=True)
            if "movie" in rep:
                typer.echo(_movie_line(rep["movie"]), err=True)
        _exit_if_interrupted(rep, output)


@app.command()
def studio(
    inputs: Annotated[Optional[list[Path]], typer.Argument(
        help="Optional: the container SVG, then element SVGs or folders, opened in the page.")] = None,
    port: Annotated[int, typer.Option(help="Port of the studio's server (127.0.0.1 only; 0: any free one).")] = 8765,
    no_browser: Annotated[bool, typer.Option("--no-browser", help="Only print the URL.")] = False,
    debug: DebugOpt = False,
) -> None:
    """A packing studio in the browser: open or paint the container, tune, steer, export (see docs/studio.md)."""
    global _DEBUG
    _DEBUG = debug
    with _errors():
        from .studio import run_studio

        inputs = inputs or []
        with _StopFlag() as stop:
            run_studio(inputs[0] if inputs else None, inputs[1:], port=port, open_browser=not no_browser, stop=stop)


@app.command("inkscape-install")
def inkscape_install(
    dir: Annotated[Optional[Path], typer.Option("--dir", help="Extensions folder (default: the user's Inkscape one).")] = None,
    dry_run: Annotated[bool, typer.Option("--dry-run", help="Only print where the files would go.")] = False,
) -> None:
    """Install the Inkscape extension (Extensions > Arrange > Pack into shape; see docs/inkscape.md)."""
    with _errors():
        from .inkscape.install import install

        for path in install(dir, dry_run=dry_run):
            typer.echo(str(path))


@app.command("params")
def params_cmd() -> None:
    """List every parameter with its default, unit and meaning (for --config TOML files)."""
    from .params import describe

    for key, default, unit, doc in describe():
        typer.echo(f"{key:34s} {default!s:>10s}  [{unit}]  {doc}")


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    typer.echo(f"repulsionpak: warning: {message}", err=True)


def main() -> None:
    """Console entry point: one line per warning or error, the documented exit codes."""
    import warnings

    from typer._click.exceptions import ClickException, UsageError  # noqa: PLC0415

    warnings.showwarning = _show_warning
    try:
        rv = app(standalone_mode=False)
    except KeyboardInterrupt:
        typer.echo("repulsionpak: interrupted", err=True)
        sys.exit(130)
    except UsageError as exc:  # unknown option, unparsable value: a bad parameter
        if type(exc).__name__ == "NoArgsIsHelpError":  # help was shown
            sys.exit(0)
        typer.echo(f"repulsionpak: error: {exc.format_message()}", err=True)
        sys.exit(3)
    except ClickException as exc:
        exc.show()
        sys.exit(exc.exit_code)
    sys.exit(rv if isinstance(rv, int) else 0)


if __name__ == "__main__":
    main()
