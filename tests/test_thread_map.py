"""Per-copy work shared over threads (:func:`repulsionpak.threads.thread_map`): the same
results in the same order on any number of threads, the thread cap obeyed, and copies'
art computed side by side rather than in turns."""

from __future__ import annotations

import threading
import warnings
import time
from pathlib import Path

import pytest

import repulsionpak as rp
from repulsionpak import examples
from repulsionpak import threads as th
from repulsionpak.types import PlacedArt, computed_once

E = Path(examples.__file__).parent


def _ident(x):
    time.sleep(0.005)  # (releases the GIL: the other worker takes the next item meanwhile)
    return x * x, threading.get_ident()


def test_results_come_in_the_order_of_the_items_from_several_threads():
    out = th.thread_map(_ident, range(40), workers=2)
    assert [v for v, _ in out] == [i * i for i in range(40)]
    assert len({t for _, t in out}) == 2


def test_short_lists_and_one_worker_run_in_the_calling_thread():
    me = threading.get_ident()
    assert {t for _, t in th.thread_map(_ident, range(th.MIN_ITEMS - 1), workers=4)} == {me}
    assert {t for _, t in th.thread_map(_ident, range(40), workers=1)} == {me}
    assert th.thread_map(_ident, [], workers=4) == []


def test_the_thread_cap_keeps_the_work_on_the_calling_thread(monkeypatch):
    monkeypatch.setenv(th.THREADS_ENV, "1")
    assert {t for _, t in th.thread_map(_ident, range(40))} == {threading.get_ident()}


def test_the_first_error_in_item_order_is_raised():
    def fail(i):
        time.sleep(0.001 * (20 - i))  # the later items fail first in time
        if i in (5, 9):
            raise ValueError(f"item {i}")
        return i

    with pytest.raises(ValueError, match="item 5"):
        th.thread_map(fail, range(20), workers=2)


def test_values_computed_once_are_computed_side_by_side_for_different_instances():
    """functools.cached_property of Python 3.11 locks one attribute of all instances: two
    copies' art would wait for each other (here: the barrier would time out)."""
    meet = threading.Barrier(2, timeout=5)

    class Box:
        calls = 0

        @computed_once
        def value(self):
            Box.calls += 1
            meet.wait()  # both threads inside at once, or a BrokenBarrierError
            return id(self)

    boxes = [Box(), Box()]
    got = [None, None]
    workers = [threading.Thread(target=lambda k=k: got.__setitem__(k, boxes[k].value)) for k in range(2)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    assert got == [id(b) for b in boxes]
    assert [b.value for b in boxes] == got and Box.calls == 2  # kept: not computed again


def test_placed_art_keeps_its_art_in_the_instance(monkeypatch):
    import repulsionpak.types as types

    calls = []
    monkeypatch.setattr(types, "art_area", lambda paths, scale: calls.append(1) or f"art of {len(paths)}")
    p = PlacedArt(source="a", kind="primary", paths=())
    assert p.art == p.art == "art of 0" and len(calls) == 1
    assert p.__dict__["art"] == "art of 0"


@pytest.mark.parametrize("container", ["circle"])
def test_a_packing_is_the_same_on_one_thread_and_on_several(monkeypatch, container):
    """The art is mapped, measured and straightened on threads: the written SVG and the
    verification's numbers do not depend on how many."""
    els = [str(E / "elements" / f"{n}.svg") for n in ("apple", "fish", "leaf", "mouse")]
    params = rp.Params().with_(seed=2, placement__count=12, sim__max_iterations=300)
    texts, reports = [], []
    for workers in (1, 3):
        monkeypatch.setattr(th, "MOST_WORKERS", workers)
        p = rp.pack(str(E / "containers" / f"{container}.svg"), els, params)
        texts.append(p.svg_text())
        reports.append({k: v for k, v in p.report().items() if k not in ("seconds", "params")})
    assert texts[0] == texts[1]
    assert reports[0] == reports[1]
    assert reports[0]["n_primary"] >= 10


def test_warnings_given_after_the_threads_are_still_heard():
    """catch_warnings swaps process-wide state (shapely enters it on every is_valid): a
    thread that entered it second and leaves last puts the first one's "ignore" back, and
    the verification's "element dropped" warnings were lost. Items 0 and 1 do exactly
    that, on the two workers."""
    in0, in1, out0 = threading.Event(), threading.Event(), threading.Event()

    def quiet(i):
        if i == 0:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                in0.set()
                assert in1.wait(5)
            out0.set()
        elif i == 1:
            assert in0.wait(5)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                in1.set()
                assert out0.wait(5)
        return i

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert th.thread_map(quiet, range(th.MIN_ITEMS), workers=2) == list(range(th.MIN_ITEMS))
        warnings.warn("still heard", UserWarning)
    assert [str(w.message) for w in caught] == ["still heard"]
