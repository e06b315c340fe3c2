"""Test set-up: the scene suites and studies live in ``benchmarks/`` (they are not part of
the library), so that folder goes on ``sys.path`` for the tests that build their scenes
(``import scenes``, ``import region_scenes``, ``import deformation_study``)."""

import sys
from pathlib import Path

_BENCHMARKS = str(Path(__file__).resolve().parents[1] / "benchmarks")
if _BENCHMARKS not in sys.path:
    sys.path.append(_BENCHMARKS)
