"""The jobs of a batch: ``--seeds`` and ``--set`` parsed strictly into one
:class:`Job` (complete, validated :class:`~repulsionpak.params.Params`) per seed ×
combination of values."""

from __future__ import annotations

import dataclasses
import itertools
import math
import re
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass

from ..errors import ParameterError
from ..params import Params, params_from_dict

#: Upper bound on the number of jobs of one batch (seeds × settings).
MAX_JOBS = 100_000

#: Longer side of a contact-sheet thumbnail, pixels (smaller for big batches, see
#: :func:`thumbnail_size`).
THUMBNAIL_PX = 240

#: Largest width of the contact sheet, pixels.
SHEET_MAX_PX = 8000


def thumbnail_size(n_jobs: int) -> int:
    """Thumbnail side for a contact sheet of ``n_jobs`` tiles (ceil(sqrt(n)) columns):
    :data:`THUMBNAIL_PX`, shrunk so the sheet stays within :data:`SHEET_MAX_PX`."""
    cols = math.ceil(math.sqrt(max(n_jobs, 1)))
    return max(16, min(THUMBNAIL_PX, SHEET_MAX_PX // cols))


@dataclass(frozen=True)
class Job:
    """One packing of a batch.

    ``params`` is complete (seed and gap set, validated); ``setting`` holds the
    ``--set`` values of this job as ``((name as given, value), ...)``; ``name`` is its
    file stem, unique within the batch. ``svg`` / ``thumbnail_px`` / ``scp`` say what the
    worker returns: the SVG text, a thumbnail PNG of that longer side (0: none), the SCP
    curve (needed for ``scp_half_gap``; the raster is the slow part of measuring).
    """

    seed: int
    params: Params
    setting: tuple[tuple[str, object], ...] = ()
    name: str = ""
    svg: bool = True
    thumbnail_px: int = THUMBNAIL_PX
    scp: bool = True


def parse_seeds(text: str, option: str = "--seeds") -> list[int]:
    """``"A-B"`` (inclusive), ``"N"`` or a comma list of both → sorted distinct seeds."""
    seeds: set[int] = set()
    for part in str(text).split(","):
        part = part.strip()
        m = re.fullmatch(r"(\d+)(?:\s*-\s*(\d+))?", part)
        if not m:
            raise ParameterError(f"{option} {text!r}: expected A-B (e.g. 1-8), a seed, or a comma list of them")
        a = int(m.group(1))
        b = int(m.group(2)) if m.group(2) is not None else a
        if b < a:
            raise ParameterError(f"{option} {part!r}: the range is empty (end before start)")
        if b >= 2**63:
            raise ParameterError(f"{option} {part!r}: seeds must be below 2**63")
        if b - a + 1 + len(seeds) > MAX_JOBS:
            raise ParameterError(f"{option} {text!r}: more than {MAX_JOBS} seeds")
        seeds.update(range(a, b + 1))
    return sorted(seeds)


def _parse_value(text: str):
    """A ``--set`` value: a TOML scalar (``10``, ``0.5``, ``1e3``, ``true``) or ``none``;
    anything else stays a string so the strict config check can name the type it wants."""
    if text.lower() in ("none", "null"):
        return None
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except (tomllib.TOMLDecodeError, KeyError):
        return text


def parse_set(spec: str) -> tuple[str, list]:
    """``"SECTION.NAME=V1,V2,..."`` → ``(name, [values])``; errors name ``--set``."""
    name, eq, values = str(spec).partition("=")
    name = name.strip()
    if not eq or not name:
        raise ParameterError(f"--set {spec!r}: expected SECTION.NAME=V1,V2,... (e.g. sim.k_edge=10,250)")
    parts = name.split(".")
    if len(parts) > 2 or not all(re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", p) for p in parts):
        raise ParameterError(f"--set {spec!r}: {name!r} is not a parameter name (SECTION.NAME or a "
                             "top-level name; see `repulsionpak params`)")
    if name == "seed":
        raise ParameterError("--set seed=...: give the seeds with --seeds")
    texts = [v.strip() for v in values.split(",")]
    if any(not t for t in texts):
        raise ParameterError(f"--set {spec!r}: empty value (give V1,V2,... without empty entries)")
    parsed = [_parse_value(t) for t in texts]
    seen: list = []
    for t, v in zip(texts, parsed):
        if any(type(v) is type(w) and v == w for w in seen):
            raise ParameterError(f"--set {name}: the value {t} is given twice")
        seen.append(v)
    return name, parsed


def _as_dict(name: str, value) -> dict:
    section, _, key = name.rpartition(".")
    return {section: {key: value}} if section else {key: value}


def _merge(a: dict, b: dict) -> dict:
    out = dict(a)
    for k, v in b.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def _fmt_value(v) -> str:
    if v is None:
        return "none"
    if isinstance(v, bool):
        return "true" if v else "false"
    text = repr(v) if isinstance(v, float) else str(v)
    return text[:-2] if isinstance(v, float) and text.endswith(".0") else text


def make_jobs(base: Params, seeds: Sequence[int], settings: Sequence[tuple[str, list]] = (),
              thumbnail_px: int = THUMBNAIL_PX) -> list[Job]:
    """One job per seed × combination of setting values (seeds outermost, settings in
    the order given), each with validated parameters.

    Every value goes through :func:`repulsionpak.params.params_from_dict`, so unknown
    names get a "did you mean" and wrong types or ranges a :class:`ParameterError`
    naming ``--set`` before any work starts.
    """
    names = [n for n, _ in settings]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise ParameterError(f"--set {sorted(dup)[0]} is given more than once; list its values in one --set")
    n_combos = math.prod(len(v) for _, v in settings) if settings else 1
    if n_combos * max(len(seeds), 1) > MAX_JOBS:
        raise ParameterError(f"--seeds × --set make {n_combos * len(seeds)} jobs, more than {MAX_JOBS}")
    for name, values in settings:  # each name and value alone first: errors name that --set
        for v in values:
            params_from_dict(_as_dict(name, v), source=f"--set {name}={_fmt_value(v)}", base=base)
    combos = []
    for values in itertools.product(*(v for _, v in settings)):
        pairs = tuple(zip(names, values))
        data: dict = {}
        for n, v in pairs:
            data = _merge(data, _as_dict(n, v))
        where = "--set " + ", ".join(f"{n}={_fmt_value(v)}" for n, v in pairs) if pairs else "parameters"
        combos.append((pairs, params_from_dict(data, source=where, base=base) if pairs else base.validate()))
    width = len(str(max(seeds))) if seeds else 1
    jobs, used = [], set()
    for seed in seeds:
        for pairs, p in combos:
            stem = f"seed-{seed:0{width}d}" + "".join(
                "_" + re.sub(r"[^A-Za-z0-9.+-]", "_", f"{n}-{_fmt_value(v)}") for n, v in pairs)
            name, k = stem, 1
            while name in used:  # two values that read the same once made file-safe
                k += 1
                name = f"{stem}~{k}"
            used.add(name)
            jobs.append(Job(seed=seed, params=dataclasses.replace(p, seed=seed), setting=pairs,
                            name=name, thumbnail_px=thumbnail_px))
    return jobs


__all__ = ["MAX_JOBS", "THUMBNAIL_PX", "Job", "make_jobs", "parse_seeds", "parse_set", "thumbnail_size"]
