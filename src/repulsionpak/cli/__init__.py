"""Command line: ``repulsionpak pack | evaluate | batch | demo | studio | params ...``.

The CLI only wires the library together: parse the options, show progress, turn errors
into exit codes. Errors of our own classes become one line on stderr and an exit code
(see :data:`EXIT_CODES`); ``--debug`` shows the traceback instead.

Notes
-----
The commands are here; :mod:`.run` takes ``pack`` from its options to its files (the
library owns every policy: :func:`repulsionpak.inputs.load_inputs`,
:class:`repulsionpak.packing.Packing`), :mod:`.progress` holds the progress bars and
signal handling.
"""

from __future__ import annotations

import contextlib
import json
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from ..errors import ParameterError, RepulsionPakError
from .progress import _BatchProgress, _Progress, _StopFlag, _sigterm_as_interrupt
from .run import _check_outputs, _exit_if_interrupted, _movie_line, _summary, resolve_params, run_pack

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


DebugOpt = Annotated[bool, typer.Option("--debug", help="Show Python tracebacks on errors.")]
# options shared by `pack` and `batch`
ContainerArg = Annotated[Path, typer.Argument(help="Container: SVG or .path file; every closed path is a region.")]
ElementsArg = Annotated[list[Path], typer.Argument(help="Element files (SVG or .path) or directories of them.")]
SecondaryOpt = Annotated[Optional[list[Path]], typer.Option("--secondary", help="A secondary element file or directory; repeat the option for more.")]
GapOpt = Annotated[Optional[float], typer.Option(help="Gap between elements' art, container units (default: 1% of its size, at most 4% of its width).")]
ConfigOpt = Annotated[Optional[Path], typer.Option(help="TOML file of parameters (see `repulsionpak params`).")]
CountOpt = Annotated[Optional[int], typer.Option(help="Number of primary elements (default: from container area and gap).")]
MaxIterationsOpt = Annotated[Optional[int], typer.Option(help="Upper bound on the growing iterations of each phase; the settling ones (sim.settle_iterations, default 100) follow.")]
QuietOpt = Annotated[bool, typer.Option("-q", "--quiet", help="No progress display or summary.")]
MarginOpt = Annotated[Optional[float], typer.Option(help="Smallest distance from any art to the container's edge (default: gap/2).")]
DraftOpt = Annotated[bool, typer.Option(
    "--draft", help="A quicker, slightly looser packing to try a composition: both growth phases stop "
    "at 4x their convergence threshold (the suite's scenes: a third fewer iterations, 0.004 less art "
    "area; every promise still checked). Scenes of over 25,000 mesh vertices already stop early.")]
RotationOpt = Annotated[Optional[str], typer.Option(help="Default rotation of the elements: free, fixed[:ANGLE], limited:DEG or upright[:DEG] (see docs/controls.md).")]
RigidOpt = Annotated[bool, typer.Option("--rigid", help="Elements never deform (rigid bodies).")]
StiffnessOpt = Annotated[Optional[float], typer.Option(help="Multiplier of the spring constants of the elements.")]
NoPocketFillOpt = Annotated[bool, typer.Option("--no-pocket-fill", help="Without --secondary, leave the pockets empty (default: fill them with small copies of the elements); the primaries then fill the voids themselves: the most cramped are moved into the largest voids, elements grow up to 2x their planned size, and they repel each other more strongly.")]
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
    draft: DraftOpt = False,
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
        from ..controls import cli_controls

        rep = run_pack(container, elements, output, secondary, gap, seed, config, report, png,
                       count, max_iterations, progress=not quiet, debug_layers=debug_layers,
                       checkpoint=checkpoint, checkpoint_every=checkpoint_every, resume=resume,
                       margin=margin, pocket_fill=not no_pocket_fill, fill_holes=fill_holes, pdf=pdf,
                       movie=movie, movie_every=movie_every, movie_size=movie_size,
                       controls=cli_controls(rotation, rigid, stiffness),
                       live={"port": port, "open_browser": not no_browser, "paused": paused} if live else None,
                       container_paint=container_paint, flow=flow, draft=draft)
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
    from ..io.files import atomic_write_bytes
    from ..measure import evaluate_file, format_table, scp_plot_png
    from ..packing import fit_workers

    with _errors():
        if gap is not None and not gap > 0:
            raise ParameterError(f"--gap must be a positive number, got {gap:g}")
        if margin is not None and not margin >= 0:
            raise ParameterError(f"--margin must be a number >= 0, got {margin:g}")
        if plot is not None:
            _check_outputs([plot], packings)
        sources = None
        if elements:
            from ..io import load_elements
            from ..measure import source_geometries

            sources = source_geometries(load_elements(elements))
            from ..geometry.overlap import is_cold as fit_is_cold
            from .._jit.prebuilt import install

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
    draft: DraftOpt = False,
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
    from ..batch import run_batch
    from ..controls import cli_controls

    with _errors():
        base = resolve_params(config, gap, None, count, max_iterations, margin, not no_pocket_fill,
                              container_paint, draft)
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
    from .. import examples

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
        from ..studio import run_studio

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
        from ..inkscape.install import install

        for path in install(dir, dry_run=dry_run):
            typer.echo(str(path))


@app.command("params")
def params_cmd() -> None:
    """List every parameter with its default, unit and meaning (for --config TOML files)."""
    from ..params import describe

    for key, default, unit, doc in describe():
        typer.echo(f"{key:34s} {default!s:>10s}  [{unit}]  {doc}")


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    typer.echo(f"repulsionpak: warning: {message}", err=True)


def _no_collection_at_exit() -> None:
    """Exempt every object alive now from the garbage collections of the interpreter's
    shutdown (``gc.freeze``).

    Notes
    -----
    Python collects garbage several times while it shuts down, each time through every
    object left: numba's and llvmlite's hundreds of thousands after a packing, 0.25 s of a
    heart run's exit. Nothing of the command needs them: its files are written and closed,
    the standard streams and the ``atexit`` handlers are still flushed and run; only
    reference cycles stay unfreed, and the operating system takes back the memory at exit.
    For the console entry point alone: a process that goes on would keep that garbage.
    """
    import gc

    gc.freeze()


#: the youngest generation's collection threshold of the command's process (Python's is 700)
GC_THRESHOLD = 10_000


def _fewer_collections() -> None:
    """Collect the youngest generation of garbage every :data:`GC_THRESHOLD` allocations
    of container objects instead of Python's 700 (the older generations' thresholds stay).

    Notes
    -----
    Importing numba and loading the kernels allocates hundreds of thousands of objects
    that live as long as the process, and the library's stages allocate many short-lived
    ones (geometries, tuples, dicts) that reference counting frees without the collector.
    With the default threshold a heart run collected ~270 times, 0.3 CPU s, mostly
    walking objects that were never garbage; with this one ~20 times, 0.05 s. Cycles
    are still collected, a little later. For the console entry point alone, like
    :func:`_no_collection_at_exit`: a library leaves the host's collector alone.
    """
    import gc

    _, g1, g2 = gc.get_threshold()
    gc.set_threshold(GC_THRESHOLD, g1, g2)


def _interrupts_are_not_lost() -> None:
    """Deliver again a Ctrl-C that Python could not raise where it landed.

    Notes
    -----
    A KeyboardInterrupt raised while Python runs a callback it cannot raise from (a weakref
    callback, such as the import system's module locks dropping after every import, or a
    ``__del__``) is printed as "Exception ignored in: ..." with a traceback, and the
    command goes on as if no key had been pressed. Such an interrupt is handed back to the
    main thread (``_thread.interrupt_main``, as if the signal came again), where it ends
    the command as any Ctrl-C does. It is sent from another thread, 10 ms later: sent
    from the hook, it would land in the hook itself, which cannot raise either (and in
    the unlikely case it lands in a callback again, it comes back here). For the console entry
    point alone, like :func:`_fewer_collections`: a library leaves the host's hooks alone.
    """
    import _thread
    import threading

    previous = sys.unraisablehook

    def hook(unraisable) -> None:
        if unraisable.exc_type is not None and issubclass(unraisable.exc_type, KeyboardInterrupt):
            timer = threading.Timer(0.01, _thread.interrupt_main)
            timer.daemon = True
            timer.start()
            return
        previous(unraisable)

    sys.unraisablehook = hook


def main() -> None:
    """Console entry point: one line per warning or error, the documented exit codes."""
    _interrupts_are_not_lost()  # first: the imports below can swallow a Ctrl-C
    import warnings

    from typer._click.exceptions import ClickException, UsageError  # noqa: PLC0415

    _fewer_collections()
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
    finally:
        _no_collection_at_exit()
    sys.exit(rv if isinstance(rv, int) else 0)
