"""The simulation side of the live view: a consumer of runner snapshots that also steers.

:class:`LiveController` plugs into :func:`repulsionpak.pack.pack` through its two
callbacks and nothing else: ``on_snapshot`` tells it which simulator is running (a
snapshot carries it), ``should_stop`` — called by the runner after every iteration — is
where it publishes frames, applies the page's commands (drag, pin, remove, add) and blocks
while the run is paused. Everything that touches the simulation state therefore happens
in the simulation's own thread, between two iterations.
"""

from __future__ import annotations

import queue
import time
from collections.abc import Callable
from concurrent.futures import Future

import numpy as np
import shapely

from ..geometry.mesh import apply_binding
from ..sim.model import SimFrame
from .protocol import encode_frame

REMOVED_SCALE = 0.01  # a removed element shrinks to this share of its size, pinned


class LiveController:
    """State shared between the running simulation and the server.

    ``publish(kind, payload)`` (set by the server) is called from the simulation thread
    with ``("frame", bytes)`` or ``("json", dict)``; it must be thread-safe and cheap.
    ``external_stop()`` (Ctrl-C) ends the run, also while paused.
    """

    def __init__(self, container, gap: float, render_params=None,
                 max_fps: float = 30.0, external_stop: Callable[[], bool] | None = None,
                 container_paint: str = "outline"):
        from ..render.container_paint import check_paint

        self.container = container
        self.gap = float(gap)
        self.container_paint = check_paint(container_paint)
        self.render_params = render_params
        self.unit = SimFrame.for_region(container.region).unit
        self.min_interval = 1.0 / max_fps
        self.external_stop = external_stop or (lambda: False)
        self.publish: Callable[[str, object], None] = lambda kind, payload: None
        self.commands: queue.Queue = queue.Queue()
        self.sim = None
        self.phase = "preparing"
        self.paused = False
        self.steps_left = 0
        self.layout_id = 0
        self.layout: dict | None = None
        self.removed: set[int] = set()
        self.pinned: set[int] = set()
        self.last_frame: bytes | None = None
        self.last_points: np.ndarray | None = None
        self._est_input: tuple | None = None  # what estimates() works on (a consistent copy)
        self._skin_idx = np.zeros(0, np.int64)
        self._last_sent = 0.0
        self._last_iteration = -1
        self.frames_sent = 0
        self.final_svg: str | None = None
        self.final_status: dict | None = None
        self.field = None  # the flow field the elements follow (a FlowField), shown as arrows

    # -- called by the runner (simulation thread) -------------------------------------
    def on_snapshot(self, snap) -> None:
        if snap.sim is not None and snap.sim is not self.sim:
            self._bind(snap.sim, snap.phase)
        if snap.done:
            self._publish_frame(force=True)

    def should_stop(self) -> bool:
        self._apply_commands()
        # the iteration a pause stops at is always shown
        self._publish_frame(force=self.paused and self._last_iteration != self._iteration())
        # (a pause takes effect once the first snapshot told which simulator runs)
        while self.paused and self.sim is not None and self.steps_left == 0 and not self.external_stop():
            try:
                cmd = self.commands.get(timeout=0.1)
            except queue.Empty:
                continue
            self._apply(cmd)
            self._apply_commands()
            self._publish_frame(force=True)
        if self.steps_left > 0:
            self.steps_left -= 1
        return bool(self.external_stop())

    # -- called by the server (any thread) ---------------------------------------------
    def submit(self, cmd: dict) -> None:
        """Queue a parsed command; pause/resume/step take effect at once."""
        c = cmd["cmd"]
        if c in ("pause", "resume"):
            self.paused = c == "pause"
            self.steps_left = 0
            self._status()
            self.commands.put({"cmd": "noop"})  # wake the pause loop
        elif c == "step":
            self.paused = True
            self.commands.put(cmd)
        else:
            self.commands.put(cmd)

    def render_svg(self, timeout: float = 120.0) -> str:
        """The current packing in the output format (the final one once the run ended)."""
        if self.final_svg is not None:
            return self.final_svg
        fut: Future = Future()
        self.commands.put({"cmd": "svg", "future": fut})
        t_end = time.monotonic() + timeout
        while True:  # answered between two iterations, or by finish()
            try:
                return fut.result(timeout=0.5)
            except TimeoutError:
                if self.final_svg is not None:  # the run ended just after the request
                    return self.final_svg
                if time.monotonic() > t_end:
                    raise RuntimeError(f"the simulation did not answer within {timeout:g} s") from None

    def status(self) -> dict:
        st = {"type": "status", "phase": self.phase, "paused": self.paused,
              "iteration": int(self.sim.state.iteration) if self.sim is not None else 0,
              "done": self.final_svg is not None}
        if self.final_status is not None:
            st.update(self.final_status)
        return st

    def scene(self) -> dict:
        """Container rings and view box (container units) for the page, and how to draw
        the container (``paint``, as the outputs do): ``outline`` with its ``colour`` and
        ``width`` (container units), ``as-drawn`` with ``markup`` (the output's container
        group), or ``none``; with a flow field, ``field``: its arrows as one path's ``d``."""
        from ..render.container_paint import outline_colour, outline_width

        rings = []
        for poly in getattr(self.container.region, "geoms", [self.container.region]):
            rings.append(np.round(np.asarray(poly.exterior.coords)[:-1], 3).tolist())
            rings += [np.round(np.asarray(r.coords)[:-1], 3).tolist() for r in poly.interiors]
        minx, miny, maxx, maxy = self.container.bounds
        pad = 0.02 * max(maxx - minx, maxy - miny)
        paint = {"paint": self.container_paint}
        if self.container_paint == "outline":
            paint.update(colour=outline_colour(self.container),
                         width=outline_width(self.container, self.gap))
        elif self.container_paint == "as-drawn":
            from ..render.svg import container_lines

            paint["markup"] = "\n".join(container_lines(self.container, "as-drawn", 0.0, indent=""))
        field = {}
        if self.field is not None:  # the flow field's arrows (live/field_layer.py)
            from .field_layer import field_path

            field = {"field": field_path(self.field, self.container.region)}
        return {"type": "scene", "rings": rings, "gap": self.gap, **paint, **field,
                "viewBox": [minx - pad, miny - pad, maxx - minx + 2 * pad, maxy - miny + 2 * pad]}

    def estimates(self) -> dict:
        """Area fraction and median gap of the art, estimated from the latest published
        state: every art vertex mapped through its mesh triangle (barycentric, as the
        preprocessing bound it), closed subpaths as polygons, open ones as lines (stroke
        widths and the final curve fit left out); the exact values once the run ended."""
        if self.final_status is not None or self._est_input is None:
            return {}
        x, vstart, tindex, templates, removed = self._est_input
        if templates is None:
            return {}
        filled, shapes = [], []
        for e in range(len(tindex)):
            if e in removed:
                continue
            t = templates[int(tindex[e])]
            v = x[vstart[e]:vstart[e + 1]] * self.unit
            art = apply_binding(v, t.tris, t.art_tri, t.art_bary)
            polys, parts, k = [], [], 0
            for path in t.element.paths:
                for sub, closed in zip(path.subpaths, path.closed):
                    pts = art[k:k + len(sub)]
                    k += len(sub)
                    if closed and len(pts) >= 3:
                        polys.append(shapely.Polygon(pts))
                    elif len(pts) >= 2:
                        parts.append(shapely.LineString(pts))
            area = shapely.union_all(shapely.make_valid(polys)) if polys else shapely.Polygon()
            filled.append(area)
            shapes.append(shapely.union_all([area, *parts]) if parts else area)
        if not shapes:
            return {}
        from ..measure import gap_statistics

        covered = shapely.intersection(shapely.union_all(filled), self.container.region)
        # distances on outlines simplified by 2% of the gap (5x faster on the heart scene)
        near = shapely.simplify(shapes, 0.02 * self.gap)
        return {"area_fraction": float(covered.area) / self.container.area,
                "median_gap": gap_statistics(near)["median"], "estimated": True}

    def finish(self, svg_text: str, stopped_by: dict, area_fraction: float, median_gap) -> None:
        """The run is over: serve ``svg_text`` from now on and tell the pages."""
        self.final_status = {"stopped_by": stopped_by, "area_fraction": float(area_fraction),
                             "median_gap": None if median_gap is None else float(median_gap),
                             "estimated": False, "converged": all(
                                 v in ("converged", "no_pockets") for v in stopped_by.values())}
        self.final_svg = svg_text
        self.paused = False
        self.phase = "done"
        while True:  # answer download requests that arrived after the last iteration
            try:
                cmd = self.commands.get_nowait()
            except queue.Empty:
                break
            if cmd["cmd"] == "svg":
                cmd["future"].set_result(svg_text)
        self._status()

    def drop_removed(self, placed: list) -> list:
        """``placed`` without the removed elements (shrunk to specks, see :meth:`_apply`)."""
        if not self.removed or not placed:
            return placed
        ext = []
        for p in placed:
            b = [s for path in p.paths for s in path.subpaths if len(s)]
            pts = np.concatenate(b) if b else np.zeros((1, 2))
            ext.append(float(np.ptp(pts, axis=0).max()))
        # the specks: at most as many as were removed, the smallest, each far below the rest
        # of its kind (a removed primary against the primaries: the many small pocket copies
        # added after the run would pull a median of all elements down to a speck's size)
        kinds = [getattr(p, "kind", "primary") for p in placed]
        med = {k: float(np.median([e for e, kk in zip(ext, kinds) if kk == k])) for k in set(kinds)}
        specks = {int(i) for i in np.argsort(ext, kind="stable")[:len(self.removed)]
                  if ext[i] <= 5 * REMOVED_SCALE * med[kinds[i]]}
        return [p for i, p in enumerate(placed) if i not in specks]

    # -- internals (simulation thread) -------------------------------------------------
    def _bind(self, sim, phase: str) -> None:
        m = sim.model
        self.sim, self.phase = sim, phase
        starts = m.elem_vstart[:-1].astype(np.int64)
        counts = m.elem_nskin.astype(np.int64)
        self._skin_idx = np.concatenate([np.arange(s, s + c) for s, c in zip(starts, counts)]) \
            if len(counts) else np.zeros(0, np.int64)
        for i in self.pinned:
            if i < m.n_elements:
                sim.set_moving(i, False)
        for i in self.removed:
            if i < m.n_elements:
                sim.set_moving(i, False)
        self.layout_id += 1
        self.layout = {"type": "layout", "id": self.layout_id, "counts": counts.tolist(),
                       "kinds": list(m.kind), "template": m.template_index.astype(int).tolist(),
                       "frozen": [bool(f) for f in m.frozen]}
        self.publish("json", self.layout_message())
        self._status()
        self._publish_frame(force=True)

    def layout_message(self) -> dict:
        lay = dict(self.layout or {"type": "layout", "id": 0, "counts": [], "kinds": [],
                                   "template": [], "frozen": []})
        lay["pinned"] = sorted(self.pinned)
        lay["removed"] = sorted(self.removed)
        return lay

    def _status(self) -> None:
        self.publish("json", self.status())

    def _publish_frame(self, force: bool = False) -> None:
        if self.sim is None:
            return
        now = time.perf_counter()
        if not force and now - self._last_sent < self.min_interval:
            return
        self._last_sent = now
        st = self.sim.state
        self._last_iteration = st.iteration
        pts = st.x[self._skin_idx] * self.unit
        a = float(self.sim.state.areas.sum() / self.sim.model.container_area)  # all meshes
        data = encode_frame(self.layout_id, st.iteration, a, pts)
        self.last_frame, self.last_points = data, pts
        m = self.sim.model  # (add-copy replaces these arrays, it never mutates them)
        self._est_input = (st.x.copy(), m.elem_vstart, m.template_index, self.sim.templates,
                           frozenset(self.removed))
        self.frames_sent += 1
        self.publish("frame", data)

    def _iteration(self) -> int:
        return -1 if self.sim is None else int(self.sim.state.iteration)

    def _apply_commands(self) -> None:
        while True:
            try:
                cmd = self.commands.get_nowait()
            except queue.Empty:
                return
            self._apply(cmd)
            self._publish_frame(force=True)

    def _apply(self, cmd: dict) -> None:
        c = cmd["cmd"]
        sim = self.sim
        if c == "svg":
            try:
                cmd["future"].set_result(self._current_svg())
            except Exception as exc:  # noqa: BLE001  (handed to the requesting thread)
                cmd["future"].set_exception(exc)
            return
        if c == "step":
            self.steps_left += cmd["n"]
            self._status()
            return
        if sim is None or c == "noop" or cmd.get("index", 0) >= sim.model.n_elements:
            return
        if sim.relocator is not None:  # the designer's edits end the automatic moves
            sim.relocator.stop(sim)
        if c == "add":
            self._add_copy(cmd["index"], cmd["x"], cmd["y"])
            return
        i = cmd["index"]
        m, st = sim.model, sim.state
        a, b = int(m.elem_vstart[i]), int(m.elem_vstart[i + 1])
        if c == "move" and not m.frozen[i]:
            st.x[a:b, 0] += cmd["dx"] / self.unit
            st.x[a:b, 1] += cmd["dy"] / self.unit
            st.v[a:b] = 0.0
            # a drag is no velocity-capped step: its contacts are found anew, as after a
            # relocation (the refresh between queries only follows small moves)
            sim.update_contacts(full=True)
        elif c == "pin" and not m.frozen[i] and i not in self.removed:
            (self.pinned.add if cmd["pinned"] else self.pinned.discard)(i)
            sim.set_moving(i, not cmd["pinned"])
            st.v[a:b] = 0.0
            self.publish("json", self.layout_message())
        elif c == "remove" and not m.frozen[i] and i not in self.removed:
            self.removed.add(i)
            self.pinned.discard(i)
            sim.set_moving(i, False)
            c0 = st.x[a:b].mean(axis=0)
            st.x[a:b] = c0 + REMOVED_SCALE * (st.x[a:b] - c0)
            st.v[a:b] = 0.0
            self.publish("json", self.layout_message())

    def _add_copy(self, src: int, x: float, y: float) -> None:
        """Append a copy of element ``src`` at (x, y) (container units), at the size every
        element started from, unrotated, growing from now on.

        The model and state are rebuilt with the running ones as base (as the secondary
        phase appends its elements) and swapped into the *same* objects, so the runner's
        loop and :func:`repulsionpak.pack.pack` see the new element; the simulator's
        buffers are re-made for the new size with its stepping state (time step, settle
        countdown, pins) kept."""
        import dataclasses

        from ..placement import Placement
        from ..sim.model import Model, build_model

        sim = self.sim
        m, st = sim.model, sim.state
        if m.frozen[src] or src in self.removed or sim.templates is None:
            self._error(f"element {src} cannot be copied in this phase")
            return
        if not self.container.region.contains(shapely.Point(x, y)):
            self._error("a copy must be placed inside the container")
            return
        n0, m0 = m.n_vertices, m.n_elements
        region_sim = SimFrame(self.unit).to_sim(self.container.region)
        shrink = 1.0 / float(m.max_growth[src])  # the size it was placed at
        pl = Placement(np.array([m.template_index[src]]), np.array([[x, y]], float), np.zeros(1), np.array([shrink]))
        new_m, new_st = build_model(sim.templates, pl, SimFrame(self.unit), region_sim,
                                    cell_size=m.cell_size, gap=m.gap, kinds=[m.kind[src]],
                                    base=(m, st))
        if m.rot_on is not None:  # designer controls: the copy gets its source's
            from ..controls import setup_model

            setup_model(new_m, [m.controls[src]], np.zeros(1), base=m)
        # what build_model takes from the current state but must stay as it was
        new_m.x_rest[:n0] = m.x_rest
        new_m.stiffness[:m0] = m.stiffness
        new_m.stiffness[m0] = m.stiffness[src]
        new_m.bend_limit[m0] = m.bend_limit[src]
        new_m.inset_extra = m.inset_extra
        new_st.v[:n0] = st.v
        for f in dataclasses.fields(Model):
            setattr(m, f.name, getattr(new_m, f.name))
        st.x, st.v, st.n_grow = new_st.x, new_st.v, new_st.n_grow
        keep = {k: getattr(st, k) for k in ("settle_left", "stopped_by", "allow_growth")}
        dt, recoveries = sim.dt, sim._recoveries  # noqa: SLF001
        moving = st.moving.copy()
        sim.__init__(m, st, sim.params, sim.phase)  # (new run arrays for the new size)
        for k, v in keep.items():
            setattr(st, k, v)
        sim.dt, sim._recoveries = dt, recoveries  # noqa: SLF001
        for e in np.flatnonzero(~moving[:m0]):
            sim.set_moving(int(e), False)
        sim.refresh_growth()
        sim.mark_good()  # recovery restores to a state of this size
        self._bind(sim, sim.phase)

    def _error(self, message: str) -> None:
        self.publish("json", {"type": "error", "message": message})

    def _current_svg(self) -> str:
        from ..sim.art import placed_art
        from ..render.svg import packing_svg_string

        sim = self.sim
        if sim is None or sim.templates is None:
            raise RuntimeError("the simulation has not started yet")
        frame = SimFrame(self.unit)
        keep = [e for e in range(sim.model.n_elements) if e not in self.removed]
        placed = placed_art(sim.templates, sim.model, sim.state, frame, elements=keep,
                            params=self.render_params)
        return packing_svg_string(self.container, placed, self.gap,
                                  attrs={"iteration": str(sim.state.iteration)}, partial=True,
                                  metadata={"generator": "repulsionpak live view", "phase": self.phase},
                                  container_paint=self.container_paint)


__all__ = ["LiveController"]
