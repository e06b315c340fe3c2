"""Kernels compiled when the package is built, so that the first run loads them.

numba compiles a kernel the first time a process calls it and caches the machine code on
disk (``cache=True``): a fresh install spends ~20 CPU seconds compiling during its first
packing (the warm-up process, :mod:`repulsionpak.warmup`, splits that over two cores, it
still costs about 5 s of wall time), and its first report another ~8 s for the distortion
kernels. Building the package (``pip install .`` builds a wheel on the machine it
installs on) therefore does the same work once — packs the demo, measures it with the
distortion fit and compiles the two-thread builds of the simulation kernels — with
``NUMBA_CACHE_DIR`` in a temporary folder, and ships numba's cache files in
``repulsionpak/_kernels`` (:func:`build`, run by ``setup.py``; ``REPULSIONPAK_PREBUILD=0``
skips it, for a wheel meant for other machines). At run time
:func:`repulsionpak._jit.prebuilt.install` copies them into numba's cache.

Notes
-----
This module is the build's entry (``python -m repulsionpak.kernel_cache build DEST``): it
needs the whole library (the demo's workload), so it sits at the top, beside the CLI; the
cache mechanics it drives are in :mod:`repulsionpak._jit.prebuilt`.
"""

from __future__ import annotations

import importlib
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from ._jit.prebuilt import export

__all__ = ["build"]


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
    the packing with the warm-up process beside it (:func:`repulsionpak._jit.warmup.start`,
    which goes on with the two-thread builds), the measurement with the distortion fit, the SVG,
    and the file read back and measured with the SCP. ``tests/test_kernel_cache.py`` checks
    that the CLI's demo and evaluate compile nothing after installing what this compiled."""
    from . import examples
    from ._jit import warmup
    from .measure import evaluate_file
    from .pack import pack
    from .params import Params
    from .warmup import WORKLOAD

    proc = warmup.start(WORKLOAD)
    try:
        packing = pack(examples.container_file(examples.DEFAULT_CONTAINER), examples.element_files(),
                       Params(gap=examples.DEFAULT_GAP, seed=1), secondary=examples.secondary_files())
        packing.metrics(distortion=True)  # the report's measures
        svg = packing.save(Path(folder) / "demo.svg")
        evaluate_file(svg, sources=[*packing.elements, *packing.secondary])
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
        if m.name.rsplit(".", 1)[-1] == "__main__":
            continue  # an entry script (``python -m repulsionpak.cli``): importing it runs it
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
