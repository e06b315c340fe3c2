"""``repulsionpak pack`` from its options to its files: the options resolved into
:class:`~repulsionpak.params.Params`, the outputs checked before any work, the library's
:func:`~repulsionpak.inputs.load_inputs` and :func:`~repulsionpak.pack.pack` run with the
progress display and the stop flags, then :class:`~repulsionpak.packing.Packing`'s writers."""

from __future__ import annotations

import dataclasses
import functools
import json
import os
import secrets
import time
from pathlib import Path

import typer

from ..errors import ConfigError, OutputError, ParameterError, SimulationError
from .progress import _FrameProgress, _Progress, _StopFlag


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

    from ..io.manifest import with_manifest_files

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


def resolve_params(config: Path | None = None, gap: float | None = None, seed: int | None = None,
                   count: int | None = None, max_iterations: int | None = None, margin: float | None = None,
                   pocket_fill: bool = True, container_paint: str | None = None, draft: bool = False):
    """:class:`Params` from ``--config`` with the options ``--gap``, ``--seed``, ``--count``,
    ``--max-iterations``, ``--margin``, ``--no-pocket-fill``, ``--container-paint`` and
    ``--draft`` (:meth:`Params.drafted`, on the config's thresholds) on top, validated;
    errors name the option. The seed and the gap stay None when neither the config nor the
    options give them."""
    from ..params import Params, load_config
    from ..render.container_paint import CONTAINER_PAINTS

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
    if not pocket_fill:  # (validates: after the checks that name their option)
        params = params.without_pocket_fill()
    if draft:
        params = params.drafted()
    return params.validate()


def _warm_up_meanwhile(run):
    """First run: start the warm-up process (a second process compiling the kernels from
    the far end, :mod:`repulsionpak.warmup`) before anything else, so that it compiles while
    the inputs are read, and end it however the run ends (an input error included)."""
    @functools.wraps(run)
    def wrapped(*args, **kwargs):
        from .._jit import prebuilt, warmup
        from ..warmup import WORKLOAD

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
             flow: Path | None = None, draft: bool = False) -> dict:
    """Everything ``repulsionpak pack`` does; returns the report dict (without a ``report``
    file, its distortion entries and ``scp_ratio_primary`` are None: the fit is measured
    only to be written, :meth:`~repulsionpak.Packing.report`). An ``output`` ending
    in ``.pdf`` is written as a vector PDF instead of SVG; ``pdf`` adds a PDF beside it;
    ``movie`` (.gif or .mp4) the simulation as an animation, a frame every ``movie_every``
    iterations (default: adapted to the run's length), ``movie_size`` pixels along the
    frames' longer side. ``live`` (``{"port": N, "open_browser": bool, "paused": bool}``)
    serves the run in the browser and writes the outputs only at Ctrl-C (see
    :mod:`repulsionpak.live`). ``container_paint`` (``outline``, ``as-drawn``, ``none``;
    None: the config's, else ``outline``) is how every output draws the container. ``flow``:
    a guide SVG the elements follow (docs/flow.md). ``draft``: stop the growth sooner
    (:meth:`~repulsionpak.params.Params.drafted`)."""
    from ..pack import pack

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
        from ..render.movie import MovieRecorder, check_movie_output

        check_movie_output(movie)  # before the run: an MP4 without imageio-ffmpeg fails now
        recorder = MovieRecorder(movie, every=movie_every, size_px=movie_size)
    if checkpoint_every < 1:
        raise ParameterError(f"--checkpoint-every must be >= 1, got {checkpoint_every}")
    resumed = None
    if resume is not None:
        from ..checkpoint import load_checkpoint

        resumed = load_checkpoint(resume)
        if seed is None:  # the seed of the interrupted run
            seed = int(next(iter(resumed.values()))["seed"])
    params = resolve_params(config, gap, seed, count, max_iterations, margin, pocket_fill, container_paint, draft)
    if params.seed is None:
        params = dataclasses.replace(params, seed=secrets.randbelow(2**31))
    if fill_holes and pocket_fill:  # --fill-holes: copies go into the holes of the art too
        params = dataclasses.replace(params, secondary=dataclasses.replace(params.secondary, fill_holes=True))
    from ..inputs import load_inputs

    run_in = load_inputs(container, elements, params, secondary or (), controls)
    cont, elems, secs, params = run_in.container, run_in.elements, run_in.secondary, run_in.params
    on_checkpoint = None
    if checkpoint is not None or resume is not None:
        from ..checkpoint import fingerprint, load_checkpoint, save_checkpoint

        from ..io.manifest import with_manifest_files

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
        from .._jit import warmup
        from .._jit.kernels import cache_is_cold

        cold = cache_is_cold()
        if cold:
            typer.echo("compiling the simulation kernels, first run only…", err=True)
        elif warmup.compiles_parallel_only():
            typer.echo("compiling the two-thread simulation kernels in the background "
                       "(later runs use both cores)…", err=True)
        if not cold and report is not None:
            from ..geometry.overlap import is_cold as fit_is_cold

            if fit_is_cold():
                typer.echo("compiling the report's distortion kernels, first run only…", err=True)
    from .._jit import warmup

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
                from ..live import LiveRun

                viewer = LiveRun(cont, params, external_stop=stop, flow=flow, **live)
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
    # without a report file the summary line needs no distortion fit (measured only for the file)
    rep = packing.report(seconds=seconds, not_written=not_written, movie=movie_entry,
                         distortion=report is not None)
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
    from ..io.files import atomic_write_bytes

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
