"""The first run's background warm-up compiles exactly the kernels a packing uses."""

import dataclasses
import os
import subprocess
import sys
import textwrap

import pytest

from repulsionpak import examples

# a small packing (simulation, verification, rendering) in a fresh process: prints the
# repulsionpak kernels it had to compile
PACK = textwrap.dedent("""
    import sys
    from numba.core import event
    compiled = []
    class L(event.Listener):
        def on_start(self, ev):
            f = ev.data["dispatcher"].py_func
            compiled.append(f.__module__ + "." + f.__name__)
        def on_end(self, ev):
            pass
    event.register("numba:compile", L())
    from repulsionpak import examples
    from repulsionpak._jit.warmup import is_cold
    from repulsionpak.io import load_container, load_elements
    from repulsionpak.pack import pack
    from repulsionpak.params import params_from_dict
    from repulsionpak.warmup import WORKLOAD
    cold = is_cold(WORKLOAD)
    cont = load_container(examples.container_file(examples.DEFAULT_CONTAINER))
    elems = load_elements(examples.element_files()[:3])
    params = params_from_dict({"gap": examples.DEFAULT_GAP, "seed": 3,
                               "placement": {"count": 6}, "sim": {"max_iterations": 150}})
    p = pack(cont, elems, params)
    assert p.placed
    print("COLD", cold)
    print("COMPILED", sorted({c for c in compiled if c.startswith("repulsionpak.")}))
""")


def _run(args, cache):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    return subprocess.run([sys.executable, *args], env=env, capture_output=True, text=True,
                          check=True).stdout


def _compiled(out: str) -> list[str]:
    line = next(ln for ln in out.splitlines() if ln.startswith("COMPILED"))
    return eval(line.split(" ", 1)[1])  # noqa: S307  (our own printed list)


@pytest.mark.slow
def test_packing_after_warm_up_compiles_no_kernel(tmp_path):
    cache = tmp_path / "cache"
    _run(["-m", "repulsionpak.warmup"], cache)
    out = _run(["-c", PACK], cache)
    assert "COLD False" in out
    assert _compiled(out) == [], out


def test_specialisations_cover_the_simulation_kernels():
    from repulsionpak import warmup
    from repulsionpak._jit import kernels

    calls = warmup.simulation_specialisations()
    names = [d.py_func.__name__ for d, _ in calls]
    assert len(names) == len(set(names))  # one specialisation each
    # every force of Eq. 1 and the integrator, in the order one iteration calls them
    order = ["contact_query", "repulsion_force", "edge_force", "boundary_force", "overlap_force",
             "euler_step", "grow", "skin_areas", "contact_update", "project_inside"]
    assert [n for n in names if n in order] == order
    serial = {k.serial for k in kernels.KERNELS}
    assert sum(d in serial for d, _ in calls) >= 8
    # recording ran the plain Python functions: the real kernels are back in place
    from repulsionpak.sim import contacts, forces, runner
    assert contacts.contact_query is forces.contact_query
    assert type(runner.grow).__name__ == "CPUDispatcher"


def test_start_does_nothing_when_cached(monkeypatch):
    from repulsionpak._jit import warmup
    from repulsionpak.warmup import WORKLOAD

    warmup.warm_up(WORKLOAD, parallel=False)  # compiles or loads in this process: the cache now holds the kernels
    assert not warmup.is_cold(WORKLOAD)
    monkeypatch.setattr(warmup, "parallel_missing", lambda: False)  # (their ~13 s compile: see below)
    assert warmup.start(WORKLOAD) is None
    warmup.stop(None)
    warmup.wait()  # nothing running: returns at once


def test_start_can_be_turned_off(monkeypatch):
    from repulsionpak._jit import warmup
    from repulsionpak.warmup import WORKLOAD

    monkeypatch.setattr(warmup, "is_cold", lambda w: True)
    monkeypatch.setattr(warmup, "_spare_cores", lambda: 1)
    monkeypatch.setenv("REPULSIONPAK_NO_WARMUP", "1")
    assert warmup.start(WORKLOAD) is None


def test_shipped_signatures_are_current():
    """The data file the warm-up starts from holds exactly what a recording run records
    now: regenerate with ``python -m repulsionpak.warmup --write-signatures`` when this fails."""
    import json

    from repulsionpak import warmup
    from repulsionpak._jit.signatures import SIGNATURES, encode, load_signatures

    shipped = json.loads(SIGNATURES.read_text(encoding="utf-8"))["kernels"]
    recorded = encode(warmup.simulation_specialisations())
    assert shipped == recorded, "stale: python -m repulsionpak.warmup --write-signatures"
    loaded = load_signatures()
    assert loaded == warmup.simulation_specialisations()
    names = [d.py_func.__name__ for d, _ in loaded]
    assert names[:2] == ["_greedy_chords", "squared_edt"]  # preprocessing first
    assert "contact_query" in names and "window_change" in names


def test_signatures_are_read_again_only_when_the_file_changes(tmp_path):
    import json
    import os

    from repulsionpak._jit.signatures import SIGNATURES, load_signatures

    path = tmp_path / "signatures.json"
    data = json.loads(SIGNATURES.read_text(encoding="utf-8"))
    path.write_text(json.dumps(data), encoding="utf-8")
    first = load_signatures(path)
    assert first and load_signatures(path) == first
    load_signatures(path).clear()  # each answer is the caller's own list
    assert load_signatures(path) == first
    data["kernels"][0]["params"][0] = "renamed"
    path.write_text(json.dumps(data), encoding="utf-8")
    st = path.stat()
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))  # (a coarse clock: another time)
    assert load_signatures(path) is None
    path.unlink()
    assert load_signatures(path) is None


def test_stale_signatures_fall_back_to_recording(tmp_path, monkeypatch):
    import json

    from numba.core import types

    from repulsionpak._jit import signatures, warmup
    from repulsionpak._jit.signatures import SIGNATURES, load_signatures
    from repulsionpak.warmup import WORKLOAD

    data = json.loads(SIGNATURES.read_text(encoding="utf-8"))
    assert load_signatures(tmp_path / "missing.json") is None
    renamed = json.loads(json.dumps(data))
    renamed["kernels"][0]["params"][0] = "renamed"  # a kernel's parameters changed
    gone = json.loads(json.dumps(data))
    gone["kernels"][1]["kernel"] = "repulsionpak.geometry.edt.no_such_kernel"
    odd = json.loads(json.dumps(data))
    odd["kernels"][0]["args"][0] = "list(float64)"  # a type the file format does not hold
    for k, bad in enumerate([renamed, gone, odd]):
        path = tmp_path / f"bad{k}.json"
        path.write_text(json.dumps(bad), encoding="utf-8")
        assert load_signatures(path) is None
    good = tmp_path / "good.json"
    good.write_text(json.dumps(data), encoding="utf-8")
    calls = load_signatures(good)
    assert calls[1][1] == (types.Array(types.boolean, 2, "C"),)  # squared_edt(mask)
    # the warm-up uses the file when it matches, and records when it does not
    recording = dataclasses.replace(WORKLOAD, record=lambda: ["recorded"])
    assert warmup.specialisations(recording) == load_signatures()
    monkeypatch.setattr(signatures, "SIGNATURES", tmp_path / "bad0.json")
    monkeypatch.setattr(load_signatures, "__defaults__", (tmp_path / "bad0.json",))
    assert warmup.specialisations(recording) == ["recorded"]


def test_cli_starts_the_warm_up_first_and_stops_it_on_an_input_error(tmp_path, monkeypatch):
    from repulsionpak._jit import warmup
    from repulsionpak.cli import run_pack
    from repulsionpak.errors import RepulsionPakError
    from repulsionpak.warmup import WORKLOAD

    events = []

    class Fake:
        pass

    proc = Fake()
    monkeypatch.setattr(warmup, "start", lambda w: events.append(("start", w)) or proc)
    monkeypatch.setattr(warmup, "stop", lambda p: events.append(("stop", p)))
    with pytest.raises((RepulsionPakError, OSError)):
        run_pack(tmp_path / "missing.svg", [examples.element_files()[0]], tmp_path / "out.svg",
                 progress=False)
    assert events == [("start", WORKLOAD), ("stop", proc)]


def test_wait_compiles_the_small_render_kernels_the_warm_up_has_not_claimed(tmp_path, monkeypatch):
    from repulsionpak._jit import warmup
    from repulsionpak.warmup import WORKLOAD

    class Running:
        def poll(self):
            return None

        def wait(self, timeout=None):
            calls.append("waited")

    calls = []
    monkeypatch.setattr(warmup, "_current", Running())
    render = dict(WORKLOAD.render, _warm_tps=lambda: calls.append("tps"),
                  _warm_flatten=lambda: calls.append("flatten"), _warm_path_data=lambda: calls.append("path"))
    monkeypatch.setattr(warmup, "_workload", dataclasses.replace(WORKLOAD, render=tuple(render.items())))
    monkeypatch.setattr(warmup, "_claims", str(tmp_path))
    checks = []

    def cached(d):  # the warm-up finishes the render kernels after a few polls
        checks.append(d)
        return len(checks) > 6

    monkeypatch.setattr(warmup, "is_cached", cached)
    warmup.wait()  # the warm-up still compiles the curve fitter
    # in the order the renderer calls them; then until the render kernels are cached, not
    # until the warm-up ends (it goes on with the parallel builds: it never ends here)
    assert calls == ["tps", "flatten", "path"]
    assert len(checks) >= 7
    assert sorted(p.name for p in tmp_path.iterdir()) == ["_warm_flatten", "_warm_path_data", "_warm_tps"]
    calls.clear()
    (tmp_path / "_warm_tps").unlink()
    warmup.wait()  # the warm-up claimed _flatten (it works from the other end): tps only
    assert calls == ["tps"]


def test_claims_split_the_kernels_between_the_two_processes(tmp_path, monkeypatch):
    """compile_forward claims kernels in the order of use until it meets one the warm-up
    claimed; the warm-up (reverse order) stops at the first one the packing claimed."""
    from repulsionpak._jit import warmup
    from repulsionpak._jit.signatures import load_signatures
    from repulsionpak.warmup import WORKLOAD

    calls = load_signatures()
    names = [warmup._name(d) for d, _ in calls]
    claims = tmp_path / "claims"
    claims.mkdir()
    for n in names[12:]:  # the warm-up's share so far (its kernels are compiled below)
        (claims / n).touch()

    class Running:
        def poll(self):
            return None

    compiled = []
    monkeypatch.setattr(warmup, "_current", Running())
    monkeypatch.setattr(warmup, "_claims", str(claims))
    monkeypatch.setattr(warmup, "is_cached", lambda d: True)  # the warm-up's kernel is done
    for d, sig in calls:
        monkeypatch.setattr(d, "compile", lambda sig, d=d: compiled.append(warmup._name(d)))
        monkeypatch.setattr(d, "overloads", {})
    warmup.compile_forward(serial=False)  # a run on the parallel builds: not its business
    assert compiled == []
    warmup.compile_forward()
    assert compiled == names[:12]
    assert sorted(p.name for p in claims.iterdir()) == sorted(names)
    compiled.clear()
    warmup.warm_up(WORKLOAD, render=False, parallel=False)  # everything is claimed: the warm-up compiles nothing more
    assert compiled == []


def test_warm_up_compiles_the_parallel_builds_for_the_recorded_types(tmp_path, monkeypatch):
    """The parallel builds get the serial builds' argument types, in the order of use,
    each claimed once (a second warm-up finds them claimed)."""
    from repulsionpak._jit import kernels, warmup
    from repulsionpak._jit.signatures import load_signatures
    from repulsionpak.warmup import WORKLOAD

    builds = {id(k.serial): k for k in kernels.KERNELS}
    calls = [(builds[id(d)], sig) for d, sig in load_signatures() if id(d) in builds]
    assert len(calls) >= 8  # the forces, the neighbour query and update, the relaxation
    compiled = []
    for k, _ in calls:
        monkeypatch.setattr(k.parallel, "compile", lambda sig, k=k: compiled.append((k, sig)))
    monkeypatch.setattr(warmup, "_claims", str(tmp_path))
    warmup.warm_up_parallel(WORKLOAD)
    assert compiled == calls
    compiled.clear()
    warmup.warm_up_parallel(WORKLOAD)
    assert compiled == []


def test_a_later_run_starts_a_warm_up_for_the_missing_parallel_builds(monkeypatch):
    from repulsionpak._jit import warmup
    from repulsionpak.warmup import WORKLOAD

    started = []

    class Proc:
        def poll(self):
            return None

        def terminate(self):
            started.append("terminated")

        def wait(self, timeout=None):
            return 0

    monkeypatch.delenv("REPULSIONPAK_NO_WARMUP", raising=False)
    monkeypatch.setattr(warmup, "_spare_cores", lambda: 1)
    monkeypatch.setattr(warmup, "is_cold", lambda w: False)
    monkeypatch.setattr(warmup.subprocess, "Popen", lambda args, **kw: started.append(args) or Proc())
    monkeypatch.setattr(warmup, "parallel_missing", lambda: False)
    assert warmup.start(WORKLOAD) is None and started == []  # everything cached
    monkeypatch.setattr(warmup, "parallel_missing", lambda: True)
    proc = warmup.start(WORKLOAD)
    assert started[0][-2:] == ["repulsionpak.warmup", "--parallel"]
    assert warmup.compiles_parallel_only()
    warmup.stop(proc)
    assert started[-1] == "terminated" and not warmup.compiles_parallel_only()
    monkeypatch.setattr(warmup, "is_cold", lambda w: True)  # a first run: everything, parallel last
    proc = warmup.start(WORKLOAD)
    assert started[-1][-1] == "repulsionpak.warmup" and not warmup.compiles_parallel_only()
    warmup.stop(proc)
