"""What the client of a batch writes: ``OUTDIR/NAME.svg`` per finished job,
``results.csv``, ``best.svg`` and ``contact-sheet.png`` (all atomically)."""

from __future__ import annotations

import contextlib
import csv
import io
from collections.abc import Sequence
from pathlib import Path

from ..errors import OutputError
from ..io.files import atomic_write_bytes
from ..render.png import contact_sheet_png
from .jobs import Job, _fmt_value
from .tasks import JobResult

#: Columns of ``results.csv`` before the one column per ``--set`` name (README, "Many packings").
CSV_COLUMNS = ("seed", "file", "area_fraction", "gap_median", "scp_half_gap", "overlap_area",
               "iterations", "seconds", "error")


def write_svg(outdir: Path, result: JobResult) -> str:
    """Write a finished job's SVG as ``OUTDIR/NAME.svg`` (atomically); returns the file name."""
    fname = f"{result.name}.svg"
    atomic_write_bytes(Path(outdir) / fname, result.svg.encode("utf-8"))
    return fname


def best_result(results: Sequence[JobResult | None]) -> JobResult | None:
    """The finished job with the lowest ``scp_half_gap`` (the first of equals)."""
    ok = [r for r in results if r is not None and r.ok and r.scp_half_gap is not None]
    return min(ok, key=lambda r: r.scp_half_gap) if ok else None


def _num(x, fmt: str = ".6g") -> str:
    return "" if x is None else format(float(x), fmt)


def results_csv(jobs: Sequence[Job], results: Sequence[JobResult | None], set_names: Sequence[str],
                files: dict[int, str]) -> str:
    """The ``results.csv`` text: :data:`CSV_COLUMNS` then one column per ``--set`` name,
    one row per job in job order; jobs that never finished say so in ``error``."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([*CSV_COLUMNS, *set_names])
    for i, job in enumerate(jobs):
        r = results[i]
        setting = dict(job.setting)
        m = (r.metrics if r is not None else None) or {}
        gap = m.get("gap") or {}
        w.writerow([
            job.seed, files.get(i, ""),
            _num(m.get("area_fraction")), _num(gap.get("median")), _num(m.get("scp_at_half_gap")),
            _num(m.get("overlap_area")),
            "" if r is None or not r.iterations else sum(r.iterations.values()),
            "" if r is None else _num(r.seconds, ".3f"),
            "cancelled: the batch was interrupted" if r is None else (r.error or ""),
            *(_fmt_value(setting[n]) for n in set_names),
        ])
    return buf.getvalue()


def _label(job: Job, r: JobResult | None, max_chars: int) -> str:
    parts = [f"seed {job.seed}"] + [f"{n.rpartition('.')[2]}={_fmt_value(v)}" for n, v in job.setting]
    if r is None:
        parts.append("cancelled")
    elif r.exit_code == 6:
        parts.append("promise broken")
    elif not r.ok:
        parts.append("failed")
    elif r.scp_half_gap is not None:
        parts.append(f"Q {r.scp_half_gap:.3f}")
    text = "  ".join(parts)
    return text if len(text) <= max_chars else text[: max(1, max_chars - 1)] + "…"


def write_summary(outdir: Path, jobs: Sequence[Job], results: Sequence[JobResult | None],
                  set_names: Sequence[str], files: dict[int, str], best_svg: str | None) -> JobResult | None:
    """Write ``results.csv``, ``best.svg`` (the lowest ``scp_half_gap``, when any job
    finished) and ``contact-sheet.png`` (one tile per job, in job order; failed and
    cancelled jobs are empty tiles saying so). Returns the best result."""
    outdir = Path(outdir)
    atomic_write_bytes(outdir / "results.csv", results_csv(jobs, results, set_names, files).encode("utf-8"))
    best = best_result(results)
    if best is not None and best_svg is not None:
        atomic_write_bytes(outdir / "best.svg", best_svg.encode("utf-8"))
    tile = max([j.thumbnail_px for j in jobs] + [16])
    max_chars = int(tile / 6.2)
    tiles = [None if r is None else r.thumbnail for r in results]
    labels = [_label(j, r, max_chars) for j, r in zip(jobs, results)]
    atomic_write_bytes(outdir / "contact-sheet.png", contact_sheet_png(tiles, labels, tile))
    return best



def check_outdir(outdir: Path, inputs: Sequence[Path], elements: Sequence[Path] = ()) -> None:
    """Refuse an output directory that is a file or that holds the inputs' own SVGs
    (an element directory would read the packings back as elements next time; so would
    the folder of an element file given on its own, ``elements``)."""
    outdir = Path(outdir)
    if outdir.exists() and not outdir.is_dir():
        raise OutputError(f"{outdir}: exists and is not a directory; -o names the output directory")
    for inp in map(Path, elements):
        with contextlib.suppress(OSError):
            if (inp.is_file() and inp.suffix.lower() in (".svg", ".svgz", ".path")
                    and inp.parent.resolve() == outdir.resolve()):
                raise OutputError(f"{outdir}: holds the element {inp.name}; the packings written there would "
                                  "be read as elements by a run given that folder: choose another output directory")
    for inp in map(Path, inputs):
        with contextlib.suppress(OSError):
            if inp.is_dir() and inp.resolve() == outdir.resolve():
                raise OutputError(f"{outdir}: is the input directory {inp}; choose another output directory")
            if inp.is_file() and inp.parent.resolve() == outdir.resolve() and (
                    inp.name in ("best.svg", "results.csv", "contact-sheet.png") or inp.name.startswith("seed-")):
                raise OutputError(f"{outdir}: would overwrite the input {inp}; choose another output directory")


__all__ = ["CSV_COLUMNS", "best_result", "check_outdir", "results_csv", "write_summary", "write_svg"]
