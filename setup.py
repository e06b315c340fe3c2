"""Build hook: compile the numba kernels into the wheel (see src/repulsionpak/kernel_cache.py).

Everything else about the package is in pyproject.toml. ``pip install .`` builds a wheel on
the machine it installs on; after copying the sources this packs the demo, measures it
and compiles the two-thread kernel builds once (about 25 s on two cores) and ships
numba's cache files, so that the first ``repulsionpak demo`` loads its kernels instead of
compiling them. ``REPULSIONPAK_PREBUILD=0`` skips it (a wheel for other machines: their
CPU would not match the compiled code anyway, and they compile on first use as before).
Editable installs skip it too (numba caches beside the sources there). A failure is
reported and leaves a working package that compiles on first use.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py


class BuildPyWithKernels(build_py):
    def run(self):
        super().run()
        if getattr(self, "editable_mode", False):
            return
        lib = Path(self.build_lib).resolve()
        dest = lib / "repulsionpak" / "_kernels"
        if os.environ.get("REPULSIONPAK_PREBUILD", "1") == "0":
            shutil.rmtree(dest, ignore_errors=True)  # left in the build folder by an earlier build
            return
        path = [str(lib), *filter(None, os.environ.get("PYTHONPATH", "").split(os.pathsep))]
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(path)}  # the package just built
        print("repulsionpak: compiling the numba kernels into the package (about 25 s; "
              "REPULSIONPAK_PREBUILD=0 skips this)", flush=True)
        try:
            subprocess.run([sys.executable, "-m", "repulsionpak.kernel_cache", "build", str(dest)],
                           env=env, check=True, timeout=1800, capture_output=True, text=True)
        except (OSError, subprocess.SubprocessError) as exc:
            detail = getattr(exc, "stderr", None) or ""
            print(f"repulsionpak: warning: kernels not compiled into the package ({exc}); the first "
                  f"run compiles them instead\n{detail[-2000:]}", file=sys.stderr, flush=True)
            shutil.rmtree(dest, ignore_errors=True)


setup(cmdclass={"build_py": BuildPyWithKernels})
