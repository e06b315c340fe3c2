"""The specialisations a packing compiles, as a data file shipped with the package.

A specialisation is a kernel and the numba types of its arguments. The list, in the order
a packing first calls the kernels, is recorded once at development time by the package's
workload (``python -m repulsionpak.warmup --write-signatures``) into
``warmup_signatures.json`` (:data:`SIGNATURES`); the warm-up process and
:func:`repulsionpak._jit.warmup.compile_forward` read it and compile at once instead of
recording again (~2 s of imports and a tiny run before anything compiles).

Notes
-----
The file names each kernel by module and qualified name and lists its parameter names,
so :func:`load_signatures` notices a kernel gone or its parameters renamed (it returns
None and callers fall back to recording). The kernel modules are imported by name from
the file: this layer imports nothing of the package itself.
"""

from __future__ import annotations

import importlib
import json
import re
from pathlib import Path

__all__ = ["SIGNATURES", "load_signatures", "write_signatures", "encode", "parse_type"]

#: the recorded specialisations, beside the package's top-level modules
SIGNATURES = Path(__file__).parent.parent / "warmup_signatures.json"

_ARRAY = re.compile(r"array\((\w+), (\d)d, ([CFA])\)")


def _params(dispatcher) -> list[str]:
    code = dispatcher.py_func.__code__
    return list(code.co_varnames[:code.co_argcount])


def parse_type(text: str):
    """A numba type from its ``str``.

    Parameters
    ----------
    text
        ``array(float64, 2d, C)``, ``int64``, ``float64`` or ``bool``.

    Returns
    -------
    numba.core.types.Type
        ValueError for anything else (the file is then not used).
    """
    from numba.core import types

    m = _ARRAY.fullmatch(text)
    if m:
        return types.Array(parse_type(m[1]), int(m[2]), m[3])
    if text == "bool":
        return types.boolean
    t = getattr(types, text, None)
    if not isinstance(t, (types.Integer, types.Float)):
        raise ValueError(f"unsupported argument type {text!r}")
    return t


def encode(calls: list) -> list[dict]:
    """``[(dispatcher, argument types), ...]`` as the file's entries (kernel, params, args);
    ValueError when a type would not read back."""
    out = []
    for dispatcher, sig in calls:
        f = dispatcher.py_func
        args = [str(t) for t in sig]
        if [parse_type(a) for a in args] != list(sig):
            raise ValueError(f"{f.__qualname__}: argument types {args} do not read back")
        out.append({"kernel": f"{f.__module__}.{f.__qualname__}", "params": _params(dispatcher),
                    "args": args})
    return out


def write_signatures(calls: list, path: Path = SIGNATURES) -> list[dict]:
    """Write the specialisations ``calls`` (``[(dispatcher, argument types), ...]``, in
    the order of first use) to ``path``, one kernel a line; returns the entries."""
    entries = encode(calls)
    about = ("argument types of the kernels a packing calls, in the order of first use; "
             "regenerate: python -m repulsionpak.warmup --write-signatures")
    lines = ",\n  ".join(json.dumps(e) for e in entries)  # one kernel a line
    Path(path).write_text(f'{{"about": {json.dumps(about)},\n "kernels": [\n  {lines}\n ]}}\n',
                          encoding="utf-8")
    return entries


#: :func:`load_signatures`' answers, by file and the file's size and modification time
_loaded: dict[tuple[str, int, int], tuple | None] = {}


def load_signatures(path: Path = SIGNATURES) -> list | None:
    """The specialisations recorded in ``path``.

    Returns
    -------
    list or None
        ``[(dispatcher, argument types), ...]`` (the serial build of a
        :class:`~repulsionpak._jit.kernels.Kernel`); None when the file is missing or does
        not match the kernels (a kernel gone, its parameters changed, a type it cannot read).

    Notes
    -----
    Read once per process while the file stays as it is: a run asks several times (whether
    the parallel builds are cached, at each phase's start and for the warm-up), ~3 ms each.
    """
    try:
        st = Path(path).stat()
    except OSError:
        return None
    key = (str(path), st.st_size, st.st_mtime_ns)
    if key not in _loaded:
        calls = _read(path)
        _loaded[key] = None if calls is None else tuple(calls)
    calls = _loaded[key]
    return None if calls is None else list(calls)


def _read(path: Path) -> list | None:
    """:func:`load_signatures` from the file itself."""
    try:
        entries = json.loads(Path(path).read_text(encoding="utf-8"))["kernels"]
        calls = []
        for e in entries:
            module, name = e["kernel"].rsplit(".", 1)
            target = getattr(importlib.import_module(module), name)
            dispatcher = getattr(target, "serial", target)  # a Kernel or a dispatcher
            if type(dispatcher).__name__ != "CPUDispatcher" or _params(dispatcher) != e["params"]:
                return None
            calls.append((dispatcher, tuple(parse_type(a) for a in e["args"])))
        return calls
    except Exception:  # noqa: BLE001  (any mismatch: record instead)
        return None
