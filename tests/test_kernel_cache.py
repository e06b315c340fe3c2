"""Kernels compiled when the package is built (repulsionpak.kernel_cache, setup.py) and
installed at run time (repulsionpak._jit.prebuilt)."""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

PROBE = textwrap.dedent("""\
    from numba import njit


    @njit(cache=True)
    def twice_plus_one(x):
        return 2.0 * x + 1.0
""")


def _python(code: str, cache: Path, path: Path | None = None) -> dict:
    """Run ``code`` in a fresh interpreter with its own numba cache; it prints one JSON line."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    if path is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(path), env.get("PYTHONPATH", "")])
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


CALL = textwrap.dedent("""\
    import json, sys
    from pathlib import Path
    from repulsionpak._jit import prebuilt
    import rpk_probe
    installed = prebuilt.install(Path(sys.argv[1])) if len(sys.argv) > 1 else None
    value = rpk_probe.twice_plus_one(3.0)
    st = rpk_probe.twice_plus_one.stats
    print(json.dumps({"installed": installed, "value": value,
                      "hits": sum(st.cache_hits.values()), "misses": sum(st.cache_misses.values())}))
""")


def _call(tmp: Path, cache: str, shipped: Path | None) -> dict:
    code = CALL.replace("sys.argv[1]", repr(str(shipped))).replace(
        "len(sys.argv) > 1", repr(shipped is not None))
    return _python(code, tmp / cache, tmp / "installed")


@pytest.fixture()
def shipped(tmp_path: Path) -> Path:
    """A one-kernel module compiled in one place (the 'build') and exported, and a copy of
    its source elsewhere with another modification time (the 'installation')."""
    built = tmp_path / "built"
    built.mkdir()
    (built / "rpk_probe.py").write_text(PROBE)
    code = textwrap.dedent("""\
        import json, sys
        from repulsionpak._jit import prebuilt
        import rpk_probe
        rpk_probe.twice_plus_one(1.0)
        print(json.dumps(prebuilt.export(sys.argv[1], modules=["rpk_probe"])))
    """).replace("sys.argv[1]", repr(str(tmp_path / "shipped")))
    assert _python(code, tmp_path / "build-cache", built) == 1
    installed = tmp_path / "installed"
    installed.mkdir()
    (installed / "rpk_probe.py").write_text(PROBE)
    os.utime(installed / "rpk_probe.py", (1_000_000_000, 1_000_000_000))
    return tmp_path / "shipped"


def test_installed_kernels_load_without_compiling(tmp_path, shipped):
    before = _call(tmp_path, "cold", None)  # the control: a fresh cache compiles
    assert (before["hits"], before["misses"]) == (0, 1)
    after = _call(tmp_path, "fresh", shipped)
    assert after["installed"] == 1 and after["value"] == 7.0
    assert (after["hits"], after["misses"]) == (1, 0)
    again = _call(tmp_path, "fresh", shipped)  # the cache has it now: nothing copied twice
    assert again["installed"] == 0 and (again["hits"], again["misses"]) == (1, 0)


def _rewrite_index(shipped: Path, change) -> None:
    index = next((shipped / "rpk_probe").glob("*.nbi"))
    with open(index, "rb") as fh:
        version = pickle.load(fh)
        stamp, overloads = pickle.loads(fh.read())
    version, overloads = change(version, overloads)
    with open(index, "wb") as fh:
        pickle.dump(version, fh, protocol=-1)
        fh.write(pickle.dumps((stamp, overloads), protocol=-1))


def test_kernels_for_another_cpu_are_not_installed(tmp_path, shipped):
    def other_cpu(version, overloads):
        return version, {(k[0], (k[1][0], "some-other-cpu", k[1][2]), k[2]): v for k, v in overloads.items()}

    _rewrite_index(shipped, other_cpu)
    r = _call(tmp_path, "fresh", shipped)
    assert r["installed"] == 0 and (r["hits"], r["misses"]) == (0, 1)


def test_kernels_of_another_numba_are_not_installed(tmp_path, shipped):
    _rewrite_index(shipped, lambda version, overloads: ("0.1.0", overloads))
    r = _call(tmp_path, "fresh", shipped)
    assert r["installed"] == 0 and (r["hits"], r["misses"]) == (0, 1)


def test_damaged_or_missing_kernels_never_fail_a_run(tmp_path, shipped):
    assert _call(tmp_path, "a", tmp_path / "nothing-here")["installed"] == 0
    (shipped / "manifest.json").write_text("{not json")
    assert _call(tmp_path, "b", shipped)["installed"] == 0
    (shipped / "manifest.json").write_text(json.dumps({"rpk_probe": ["rpk_probe.missing-1.py311.nbi"],
                                                       "no_such_module": ["x.nbi"]}))
    r = _call(tmp_path, "c", shipped)
    assert r["installed"] == 0 and r["misses"] == 1
    for index in (shipped / "rpk_probe").glob("*.nbi"):
        index.write_bytes(b"garbage")
    (shipped / "manifest.json").write_text(json.dumps({"rpk_probe": [index.name]}))
    r = _call(tmp_path, "d", shipped)
    assert r["installed"] == 0 and r["value"] == 7.0


def test_build_requirements_match_the_runtime_ones():
    """The build packs the demo (setup.py): what it imports must resolve as at run time."""
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    runtime = set(meta["project"]["dependencies"])
    build = set(meta["build-system"]["requires"]) - {r for r in meta["build-system"]["requires"]
                                                     if r.startswith(("setuptools", "wheel"))}
    assert build <= runtime, build - runtime
    names = {r.split(">")[0].split("=")[0] for r in build}
    assert {"numpy", "numba", "shapely", "svgelements", "pythoncdt"} <= names


def test_the_builds_workload_needs_no_cli_or_picture_packages(tmp_path):
    """The build environment has only the build requirements (no Pillow, matplotlib, typer,
    rich): the library's pack → measure → SVG → read-back path, which the build runs, must
    not import them, or the wheel silently ships no kernels."""
    code = textwrap.dedent("""\
        import importlib.abc, sys
        from pathlib import Path

        class Block(importlib.abc.MetaPathFinder):
            def find_spec(self, name, path=None, target=None):
                if name.split(".")[0] in ("PIL", "matplotlib", "typer", "rich"):
                    raise ImportError(f"{name} is not in the build environment")
                return None

        sys.meta_path.insert(0, Block())
        from repulsionpak import examples
        from repulsionpak.measure import evaluate_file
        from repulsionpak.io import load_container, load_elements
        from repulsionpak.pack import pack
        from repulsionpak.params import params_from_dict

        gap = examples.DEFAULT_GAP
        container = load_container(examples.container_file(examples.DEFAULT_CONTAINER))
        elements = load_elements(examples.element_files()[:3])
        params = params_from_dict({"gap": gap, "seed": 1, "placement": {"count": 4},
                                   "sim": {"max_iterations": 200, "settle_iterations": 10, "threads": 1}})
        packing = pack(container, elements, params)
        packing.metrics(distortion=True)
        svg = packing.save(Path(sys.argv[1]) / "w.svg")
        print(round(evaluate_file(svg, sources=elements)["area_fraction"], 6))
    """)
    env = {**os.environ, "REPULSIONPAK_NO_WARMUP": "1"}
    r = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True,
                       timeout=600, env=env)
    assert r.returncode == 0, r.stderr[-3000:]
    assert 0.0 < float(r.stdout.split()[-1]) < 1.0


@pytest.mark.slow
def test_built_kernels_cover_the_demo_and_its_measurement(tmp_path):
    """What setup.py ships (kernel_cache.build) is every kernel the demo, the distortion
    measurement and the two-thread runs use: after installing it into an empty cache, a
    demo and an ``evaluate --elements`` compile nothing."""
    from repulsionpak import kernel_cache

    shipped = tmp_path / "shipped"
    assert kernel_cache.build(shipped) > 50
    code = textwrap.dedent("""\
        import json, sys
        from pathlib import Path
        from numba.core import event
        from repulsionpak import examples
        from repulsionpak._jit import prebuilt
        from repulsionpak.cli import app

        compiled = []

        class Listener(event.Listener):
            def on_start(self, ev):
                compiled.append(ev.data["dispatcher"].py_func.__qualname__)

            def on_end(self, ev):
                pass

        event.register("numba:compile", Listener())
        installed = prebuilt.install(Path(SHIPPED))
        out = Path(SHIPPED).parent / "demo.svg"
        for args in (["demo", "-q", "-o", str(out)],
                     ["evaluate", str(out), "--elements", str(examples.element_files()[0].parent)]):
            try:
                app(args)
            except SystemExit as exc:
                assert not exc.code, exc.code
        from repulsionpak._jit.kernels import parallel_cached
        print(json.dumps({"installed": installed, "compiled": compiled, "parallel": parallel_cached()}))
    """).replace("SHIPPED", repr(str(shipped)))
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "fresh"), "REPULSIONPAK_NO_WARMUP": "1"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=600, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    r = json.loads(out.stdout.strip().splitlines()[-1])
    assert r["installed"] > 50
    assert r["compiled"] == []
    assert r["parallel"]
