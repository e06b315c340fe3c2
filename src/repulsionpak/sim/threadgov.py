"""Choosing, while a run goes, between several numba threads and one.

A simulation iteration is a handful of short parallel loops (about half a millisecond in
all on the heart scene). Each loop ends at a barrier where every thread waits for the
slowest. When another process keeps a core busy, the thread that shares that core is
descheduled for whole time slices (milliseconds), and every barrier waits for it: two
threads then ran 15–100× slower than one. How busy the machine is cannot be known ahead:
a browser, a second packing or a test suite may start at any moment. So the run measures
itself: :class:`ThreadGovernor` times the iterations (the step alone, not the callbacks),
compares the mean of a window of iterations on each thread count, and keeps the faster.

Both builds of every kernel compute the same numbers in the same order
(:mod:`repulsionpak._jit.kernels`), so switching between them changes the speed of a run,
never its packing.
"""

from __future__ import annotations

import time
from collections.abc import Callable

#: iterations whose step times make one measurement of a thread count (at least; the
#: runner makes it a multiple of ``sim.requery_every``, so every window holds as many full
#: neighbour queries)
WINDOW = 16
#: a thread count is abandoned at once when one of its iterations takes more than SPIKE
#: times the other count's mean and twice the other's slowest iteration of its window (a
#: neighbour started, or a probe went badly)
SPIKE = 5.0
#: the first iterations of a run, not measured (they build grids and caches); nor is the
#: first iteration on a thread count the run has not used before (it loads that count's
#: builds of the kernels)
WARM_UP = 4
#: several threads are kept only when their window's mean is below this share of one thread's
GAIN = 0.92
#: iterations on one thread between two probes of several threads (doubled after each
#: failed probe, up to PROBE_MAX; back to PROBE_FIRST after a good one)
PROBE_FIRST = 400
PROBE_MAX = 6400
#: iterations on several threads between two checks of one thread
CHECK_EVERY = 2000
#: one thread's mean step this many times its mean when several threads last lost to it
#: makes a probe of several due at once (the iterations grew costlier as the packing
#: filled, and several threads win on costlier ones)
REPROBE = 1.2


class ThreadGovernor:
    """Decide after each iteration whether the next one runs on ``n`` threads or on one.

    Parameters
    ----------
    n : int
        The most threads the run may use; with ``n <= 1`` the governor never switches.
    start : int
        The thread count the run starts on (``n`` or 1).
    window : int, optional
        Iterations in one measurement (:data:`WINDOW`).
    clock : callable, optional
        Seconds as a float; ``time.perf_counter`` by default (tests pass a fake clock).

    Notes
    -----
    The run starts on ``start`` threads (one, for an automatic run: a count that turns out
    slow then costs a single iteration, see below) and, after :data:`WARM_UP` iterations
    that are not measured, measures a window, then measures the other count (its first
    iteration, which loads that count's kernels, not counted)
    for a window, and keeps the faster. On several threads it checks one thread every
    :data:`CHECK_EVERY` iterations, and sooner when a window of them is no faster than
    one thread's last (a fresh window of one thread then decides: the iterations of a
    run grow costlier as it fills, so only windows measured side by side compare); on
    one thread it probes several threads after
    :data:`PROBE_FIRST` iterations, waiting twice as long after each probe that lost, so a
    machine that stays busy costs at most one slow iteration per few thousand; and at once
    when one thread's window mean has grown :data:`REPROBE` times since several threads
    last lost to it: the first probe runs on the cheapest iterations of the run, where
    handing work over costs more than splitting it saves, and its verdict no longer holds
    once the packing has filled (the iteration cost is bounded, so this adds a few probes
    a run). A single
    iteration more than :data:`SPIKE` times slower than the other count's mean ends the
    current count's window at once: with a neighbour hogging a core, two threads take
    tens of milliseconds an iteration, and waiting for a whole window would cost more
    than the run gains.
    """

    def __init__(self, n: int, start: int | None = None, window: int = WINDOW,
                 clock: Callable[[], float] = time.perf_counter):
        self.n = max(1, int(n))
        self.window = max(2, int(window))
        self.current = self.n if start is None else max(1, min(int(start), self.n))
        self.clock = clock
        self.mean: dict[int, float] = {}  # thread count -> mean step seconds of its last window
        self.peak: dict[int, float] = {}  # thread count -> slowest step of that window
        self._times: list[float] = []
        self._t0 = None
        self._since_switch = 0
        self._probe_gap = PROBE_FIRST
        self._probing = False
        self._warming = True
        self._used = {self.current}  # thread counts that have run an iteration
        self._lost_at: float | None = None  # one thread's mean when several last lost to it

    @property
    def active(self) -> bool:
        return self.n > 1

    def begin(self) -> None:
        """Call right before the step being timed."""
        self._t0 = self.clock()

    def end(self) -> int | None:
        """Call right after the step. Returns the thread count to switch to, or None."""
        if not self.active or self._t0 is None:
            return None
        dt = self.clock() - self._t0
        self._t0 = None
        if self.current not in self._used:
            # the first iteration on this count loaded its builds of the kernels (tens of
            # milliseconds, once per run): neither a measurement nor a spike
            self._used.add(self.current)
            return None
        self._times.append(dt)
        self._since_switch += 1
        other = 1 if self.current > 1 else self.n
        ref = self.mean.get(other)
        if self._warming:  # the first iterations build caches and grids: not representative
            if len(self._times) >= WARM_UP:
                self._warming = False
                self._times.clear()
            return None
        if ref is not None and dt > max(SPIKE * ref, 2.0 * self.peak[other]):
            # one iteration far slower than the other count: leave now (the neighbour
            # appeared, or the probe is hopeless); the window so far is this count's mean
            self._record()
            return self._switch(other, failed=True)
        if len(self._times) < self.window:
            if self.current == 1 and not self._probing and 1 in self.mean and self.n in self.mean \
                    and self._since_switch >= self._probe_gap:
                return self._switch(self.n, probe=True)
            if self.current > 1 and 1 in self.mean and self._since_switch >= CHECK_EVERY:
                return self._switch(1, probe=True)
            return None
        self._record()
        if other not in self.mean:  # the first measurement of the other count
            return self._switch(other, probe=True)
        if self._probing:
            self._probing = False
            faster = self.n if self.mean[self.n] < GAIN * self.mean[1] else 1
            if faster != self.current:
                return self._switch(faster, failed=faster == 1)
            # one thread won its check: several threads lost, as after a probe of them
            if faster == 1:
                self._threads_lost()
            else:
                self._probe_gap = PROBE_FIRST
            return None
        if self.current == 1 and self._lost_at is not None and self.mean[1] > REPROBE * self._lost_at:
            return self._switch(self.n, probe=True)
        if self.current > 1 and self.mean[self.n] >= self.mean[1]:
            # no faster than one thread was when last measured: measure one thread again
            # now, and keep the faster of two windows side by side (iterations grow
            # costlier as the packing fills, so an old window of one thread is no
            # reference: compared with one from the first iterations, a poster's two
            # threads, 1.8x faster, fell back to one for ~500 iterations)
            return self._switch(1, probe=True)
        return None

    def _record(self) -> None:
        self.mean[self.current] = sum(self._times) / len(self._times)
        self.peak[self.current] = max(self._times)
        self._times.clear()

    def _threads_lost(self) -> None:
        """Several threads lost to one: the next probe of them waits twice as long, or
        until one thread's mean has grown :data:`REPROBE` times."""
        self._probe_gap = min(2 * self._probe_gap, PROBE_MAX)
        self._lost_at = self.mean.get(1)

    def _switch(self, to: int, probe: bool = False, failed: bool = False) -> int:
        if failed and to == 1:
            self._threads_lost()
        self._probing = probe
        self.current = to
        self._times.clear()
        self._since_switch = 0
        return to


__all__ = ["ThreadGovernor", "WINDOW", "SPIKE", "GAIN", "PROBE_FIRST", "PROBE_MAX", "CHECK_EVERY", "REPROBE",
           "WARM_UP"]
