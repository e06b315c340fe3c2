"""Kernels compiled when the package is built, so that the first run loads them.

numba compiles a kernel the first time a process calls it and caches the machine code on
disk (``cache=True``): a fresh install spends ~20 CPU seconds compiling during its first
packing (:mod:`repulsionpak.warmup` splits that over two cores, it still costs about 5 s of
wall time), and its first report another ~8 s for the distortion kernels. Building the
package (``pip install .`` builds a wheel on the machine it installs on) therefore does
the same work once — packs the demo, measures it with the distortion fit and compiles the
two-thread builds of the simulation kernels — with ``NUMBA_CACHE_DIR`` in a temporary
folder, and ships numba's cache files in ``repulsionpak/_kernels`` (:func:`build`, run by
``setup.py``; ``REPULSIONPAK_PREBUILD=0`` skips it, for a wheel meant for other machines).

At run time :func:`install` copies those entries into the cache numba uses for each kernel
(beside the installed sources, or wherever ``NUMBA_CACHE_DIR`` points), the first time a
process packs or measures, and only the entries that cache lacks for this numba version
and this CPU (numba's own cache key holds the CPU name
and features and a hash of the kernel's bytecode), stamped with the installed source file
(numba checks that stamp when it loads an entry). A wheel built elsewhere, or for another
numba, installs nothing and the first run compiles as before; so do the few kernels of
options the demo does not use (the designer controls, ``k_shape``, a container with
thousands of corners), on their first use. Nothing here ever fails a
run: any surprise (numba's private cache API changed, a read-only folder) leaves the
kernels to be compiled as usual.
"""

from __future__ import annotations

import importlib
import json
import os
import pickle
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

__all__ = ["PREBUILT", "build", "export", "install", "cache_files"]

#: where a built package keeps its compiled kernels (absent in a source checkout)
PREBUILT = Path(__file__).with_name("_kernels")
_MANIFEST = "manifest.json"
#: whether :func:`install` ran in this process
_installed = False


def _dispatchers(module) -> list:
    """The disk-cached numba dispatchers defined in ``module`` (not those it imports): plain
    ``@njit(cache=True)`` kernels, and both builds of
    :func:`repulsionpak.sim.kernels.parallel_kernel` kernels."""
    from .sim.kernels import Kernel

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
    ``repulsionpak`` module loaded in this process) to ``dest``, with a manifest naming the
    module of each index file. Returns the number of entries copied."""
    dest = Path(dest)
    if dest.exists():
        shutil.rmtree(dest)
    dest.mkdir(parents=True)
    names = modules if modules is not None else sorted(
        m for m in sys.modules if m == "repulsionpak" or m.startswith("repulsionpak."))
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
    (0 without shipped kernels, or when the cache has them all)."""
    global _installed
    if _installed:
        return 0
    _installed = True
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


# -- at build time ----------------------------------------------------------------------

def _started(args: list[str], env: dict, cwd: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, *args], env=env, cwd=cwd, text=True,
                            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def _finished(proc: subprocess.Popen) -> str:
    """Wait for ``proc``; its standard output, or a RuntimeError with its error output."""
    out, err = proc.communicate()
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, proc.args[1:]))} exited with {proc.returncode}:\n"
                           f"{err[-3000:]}")
    return out


def _workload(folder: Path) -> None:
    """What ``repulsionpak demo`` and ``repulsionpak evaluate --elements`` on its result
    compile, through the library (the build environment has no typer, rich or matplotlib):
    the packing with the warm-up process beside it (:func:`repulsionpak.warmup.start`, which
    goes on with the two-thread builds), the measurement with the distortion fit, the SVG,
    and the file read back and measured with the SCP. ``tests/test_kernel_cache.py`` checks
    that the CLI's demo and evaluate compile nothing after installing what this compiled."""
    from . import examples, warmup
    from .measure import evaluate, evaluate_file
    from .io import load_container, load_elements
    from .pack import CONTAINER_TOLERANCE, margin_of, pack
    from .packing_output import invariants, packing_svg_text
    from .params import Params

    proc = warmup.start()
    try:
        gap = examples.DEFAULT_GAP
        container = load_container(examples.container_file(examples.DEFAULT_CONTAINER),
                                   tolerance=CONTAINER_TOLERANCE * gap)
        elements = load_elements(examples.element_files())
        secondary = load_elements(examples.secondary_files())
        params = Params(gap=gap, seed=1)
        packing = pack(container, elements, params, secondary=secondary)
        sources = [*elements, *secondary]
        metrics = evaluate(container, packing.placed, gap, with_scp=False, margin=margin_of(params, gap),
                           sources=sources)
        svg = Path(folder) / "demo.svg"
        svg.write_text(packing_svg_text(packing, metrics, invariants(packing, metrics), path=svg),
                       encoding="utf-8")
        evaluate_file(svg, sources=sources)
        if proc is not None:
            proc.wait()  # the two-thread builds
    finally:
        warmup.stop(proc)


def _export_all(dest: Path) -> int:
    """:func:`export` of every module of the package that imports here (build's last step,
    in a process whose ``NUMBA_CACHE_DIR`` holds what the workload compiled)."""
    import pkgutil

    from . import __path__ as package_path

    for m in pkgutil.walk_packages(package_path, "repulsionpak.", onerror=lambda name: None):
        try:
            importlib.import_module(m.name)
        except Exception:  # noqa: BLE001  (a module needing an optional dependency: the live view)
            pass
    return export(dest)


def build(dest: Path) -> int:
    """Compile the kernels a packing, its report and its two-thread runs use
    (:func:`_workload`; then the warm-up's two-thread builds, for a machine without a
    spare core) into a temporary numba cache and :func:`export` them to ``dest``. Run by
    ``setup.py`` on the package's build folder (``PYTHONPATH``); returns the number of
    entries."""
    work = tempfile.mkdtemp(prefix="repulsionpak-prebuild-")
    try:
        env = {**os.environ, "NUMBA_CACHE_DIR": os.path.join(work, "numba"),
               "PYTHONDONTWRITEBYTECODE": "1"}
        env.pop("REPULSIONPAK_NO_WARMUP", None)
        _finished(_started(["-m", "repulsionpak.kernel_cache", "workload", work], env, work))
        _finished(_started(["-m", "repulsionpak.warmup", "--parallel"], env, work))
        out = _finished(_started(["-m", "repulsionpak.kernel_cache", "export", str(dest)], env, work))
        return int(out.strip().splitlines()[-1])
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "build":
        print(f"{build(Path(sys.argv[2]))} compiled kernels written to {sys.argv[2]}")
    elif len(sys.argv) == 3 and sys.argv[1] == "workload":  # (build's first step)
        _workload(Path(sys.argv[2]))
    elif len(sys.argv) == 3 and sys.argv[1] == "export":  # (build's last step)
        print(_export_all(Path(sys.argv[2])))
    else:
        sys.exit("usage: python -m repulsionpak.kernel_cache build DEST")
