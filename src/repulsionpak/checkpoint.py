"""Checkpoint files: the simulation's :class:`~repulsionpak.sim.model.State` saved during a run, to resume it.

A checkpoint holds, per phase ("primary", "secondary"), the phase's state as
:meth:`repulsionpak.sim.model.State.saved` gives it (through
:meth:`repulsionpak.sim.runner.Simulator.snapshot_state`, which adds the phase's label),
plus a fingerprint of the inputs and parameters; the :class:`~repulsionpak.sim.model.Model`
is rebuilt from the same inputs and seed (preprocessing and placement are deterministic),
so the files stay small.
"""

from __future__ import annotations

import hashlib
import io
import json
import zipfile
from pathlib import Path

import numpy as np

from .errors import InputError
from .io.files import atomic_write_bytes

FORMAT = "repulsionpak-checkpoint-1"
_ARRAYS = ("x", "v", "n_grow", "area_history")
# the contact state of the vertices inside a mesh (absent from older checkpoints)
_OPTIONAL = ("inside_idx", "inside_nb_count", "inside_nb_elem", "inside_nb_seg")


def fingerprint(files: list[Path], params: dict) -> str:
    """SHA-256 of the input files' bytes and the resolved parameters."""
    h = hashlib.sha256()
    for f in files:
        h.update(str(Path(f).name).encode())
        h.update(Path(f).read_bytes() if Path(f).is_file() else b"")
    h.update(json.dumps(params, sort_keys=True, default=str).encode())
    return h.hexdigest()


def save_checkpoint(path: str | Path, states: dict, fp: str) -> None:
    """Write ``states`` ({phase: State.saved() dict, with the phase's label}) atomically to ``path``."""
    arrays, meta = {}, {"format": FORMAT, "fingerprint": fp, "phases": {}}
    for phase, st in states.items():
        if st is None:
            continue
        for k in _ARRAYS + _OPTIONAL:
            if k in st:
                arrays[f"{phase}.{k}"] = np.asarray(st[k])
        meta["phases"][phase] = {k: v for k, v in st.items() if k not in _ARRAYS + _OPTIONAL}
    buf = io.BytesIO()
    np.savez_compressed(buf, meta=np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8), **arrays)
    atomic_write_bytes(path, buf.getvalue())


def load_checkpoint(path: str | Path, fp: str | None = None) -> dict:
    """Read a checkpoint; with ``fp`` check that it belongs to the same inputs/parameters."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(bytes(z["meta"]).decode())
            data = {k: z[k] for k in z.files if k != "meta"}
    except FileNotFoundError:
        raise InputError(path, "no such checkpoint file") from None
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(path, f"not a repulsionpak checkpoint ({type(exc).__name__})") from None
    if meta.get("format") != FORMAT:
        raise InputError(path, "not a repulsionpak checkpoint (unknown format)")
    if fp is not None and meta.get("fingerprint") != fp:
        raise InputError(path, "the checkpoint was made with other inputs or parameters; resume with "
                         "exactly the same files and options (seed included) as the interrupted run")
    out = {}
    for phase, m in meta["phases"].items():
        st = dict(m)
        for k in _ARRAYS:
            st[k] = data[f"{phase}.{k}"]
        for k in _OPTIONAL:
            if f"{phase}.{k}" in data:
                st[k] = data[f"{phase}.{k}"]
        out[phase] = st
    return out
