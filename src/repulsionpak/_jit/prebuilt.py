"""Install numba cache entries compiled when the package was built.

numba compiles a kernel the first time a process calls it and caches the machine code on
disk (``cache=True``). Building the package (``pip install .`` builds a wheel on the
machine it installs on) runs the package's workload once with ``NUMBA_CACHE_DIR`` in a
temporary folder (``repulsionpak.kernel_cache.build``, run by ``setup.py``) and ships
numba's cache files, exported by :func:`export`, in ``repulsionpak/_kernels``
(:data:`PREBUILT`).

At run time :func:`install` copies those entries into the cache numba uses for each kernel
(beside the installed sources, or wherever ``NUMBA_CACHE_DIR`` points), the first time a
process packs or measures, and only the entries that cache lacks for this numba version
and this CPU (numba's own cache key holds the CPU name and features and a hash of the
kernel's bytecode), stamped with the installed source file (numba checks that stamp when
it loads an entry).

Notes
-----
A wheel built elsewhere, or for another numba, installs nothing and the first run
compiles as before; so do the few kernels the build's workload does not call, on their
first use. Nothing here ever fails a run: any surprise (numba's private cache API
changed, a read-only folder) leaves the kernels to be compiled as usual.
"""

from __future__ import annotations

import importlib
import json
import pickle
import shutil
import sys
from pathlib import Path

from .kernels import Kernel
from .loading import install as lean_loading

__all__ = ["PREBUILT", "export", "install", "cache_files"]

#: where a built package keeps its compiled kernels (absent in a source checkout)
PREBUILT = Path(__file__).parent.parent / "_kernels"
_MANIFEST = "manifest.json"
#: the package whose modules :func:`export` copies by default
_PACKAGE = __name__.split(".")[0]
#: whether :func:`install` ran in this process
_installed = False


def _dispatchers(module) -> list:
    """The disk-cached numba dispatchers defined in ``module`` (not those it imports): plain
    ``@njit(cache=True)`` kernels, and both builds of
    :func:`repulsionpak._jit.kernels.parallel_kernel` kernels."""
    found = []
    for value in vars(module).values():
        if getattr(getattr(value, "py_func", None), "__module__", None) != module.__name__:
            continue
        if isinstance(value, Kernel):
            found += [value.serial, value.parallel]
        elif type(value).__name__ == "CPUDispatcher":
            found.append(value)
    return [d for d in found if type(getattr(d, "_cache", None)).__name__ == "FunctionCache"]


def cache_files(dispatcher):
    """numba's cache-file object of a disk-cached dispatcher (its index and data files)."""
    return dispatcher._cache._cache_file


def export(dest: Path, modules: list[str] | None = None) -> int:
    """Copy the cache entries of every disk-cached kernel of ``modules`` (default: every
    module of this package loaded in this process) to ``dest``, with a manifest naming the
    module of each index file. Returns the number of entries copied."""
    dest = Path(dest)
    if dest.exists():
        shutil.rmtree(dest)
    dest.mkdir(parents=True)
    names = modules if modules is not None else sorted(
        m for m in sys.modules if m == _PACKAGE or m.startswith(_PACKAGE + "."))
    manifest: dict[str, list[str]] = {}
    count = 0
    for name in names:
        module = sys.modules.get(name) or importlib.import_module(name)
        for d in _dispatchers(module):
            files = cache_files(d)
            overloads = files._load_index()
            if not overloads:
                continue
            folder = dest / name
            folder.mkdir(exist_ok=True)
            shutil.copyfile(files._index_path, folder / files._index_name)
            for data_name in overloads.values():
                shutil.copyfile(files._data_path(data_name), folder / data_name)
            manifest.setdefault(name, []).append(files._index_name)
            count += len(overloads)
    (dest / _MANIFEST).write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n",
                                  encoding="utf-8")
    return count


def _magic_tuple():
    from numba.core.registry import cpu_target

    return cpu_target.target_context.codegen().magic_tuple()


def install(source: Path = PREBUILT) -> int:
    """Copy the shipped cache entries (see the module docstring) that numba's cache lacks
    for this machine into it; once per process. Returns the number of entries copied
    (0 without shipped kernels, or when the cache has them all).

    Also loads this package's kernels the lean way from now on
    (:func:`repulsionpak._jit.loading.install`): callers run this before a packing's or a
    measure's first kernel, which is when both must be in place."""
    global _installed
    if _installed:
        return 0
    _installed = True
    lean_loading()
    try:
        manifest = json.loads((Path(source) / _MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return 0  # a source checkout, or a package built with REPULSIONPAK_PREBUILD=0
    try:
        return _install(Path(source), manifest)
    except Exception:  # noqa: BLE001  (numba's private cache API: compile as usual instead)
        return 0


def _install(source: Path, manifest: dict) -> int:
    import numba

    magic = _magic_tuple()
    copied = 0
    for name, index_names in manifest.items():
        try:
            module = importlib.import_module(name)
        except ImportError:
            continue
        by_index = {cache_files(d)._index_name: d for d in _dispatchers(module)}
        for index_name in index_names:
            d = by_index.get(index_name)
            if d is None:
                continue  # the kernel moved (another line): its code is not what was built
            with open(source / name / index_name, "rb") as fh:
                if pickle.load(fh) != numba.__version__:
                    continue
                _stamp, shipped = pickle.loads(fh.read())
            files = cache_files(d)
            current = files._load_index()
            missing = {k: v for k, v in shipped.items() if k not in current and k[1] == magic}
            if not missing:
                continue
            used = set(current.values())
            number = 0
            for key, data_name in missing.items():
                number += 1
                while files._data_name(number) in used:
                    number += 1
                target = files._data_name(number)
                with files._open_for_write(files._data_path(target)) as out:
                    out.write((source / name / data_name).read_bytes())
                current[key] = target
                used.add(target)
            files._save_index(current)  # stamped with this installation's source file
            copied += len(missing)
    return copied
