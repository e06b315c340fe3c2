"""The simulation side of the studio: the live view's controller, re-armed for every run,
and able to change the container of a running simulation.

:class:`StudioController` is a :class:`repulsionpak.live.LiveController` (frames, drag,
pin, remove, add a copy, pause and step, the current SVG) that outlives runs: the server
holds one for the whole session and :meth:`StudioController.reset` prepares it for the
next run. The ``region`` command swaps the container under a running simulation between
two iterations, in the simulation's thread, as the live view applies every command.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import shapely

from ..live import LiveController
from ..sim.model import SimFrame, container_field, reflex_corners
from ..types import Container


#: frames sent per second at most: above the live view's 30, so that a frame is sent after
#: nearly every iteration of a large scene, whose iterations come unevenly (a full neighbour
#: query every few); a slow page skips frames (the server keeps only the newest)
MAX_FPS = 60.0


class StudioController(LiveController):
    """A :class:`LiveController` for a session of runs.

    Parameters
    ----------
    view_box : sequence of 4 floats
        The canvas (x, y, width, height, container units) the page shows and paints on;
        the scene keeps it whatever the region, so the stage never jumps under the brush.
    """

    def __init__(self, view_box=(0.0, 0.0, 1000.0, 1000.0)):
        self.view_box = [float(v) for v in view_box]
        x, y, w, h = self.view_box
        super().__init__(Container("canvas", shapely.box(x, y, x + w, y + h)), 0.01 * max(w, h))
        self.container = None  # nothing to show until a container is opened or painted
        self.cancelled = False
        self._removed_x: dict[int, object] = {}  # where removed elements were (for undo)
        self.stage = None
        self.phase = "idle"

    def reset(self, container: Container, params, paused: bool = False) -> None:
        """Prepare for a new run of ``container`` with ``params`` (its gap resolved)."""
        layout_id, publish, old = self.layout_id, self.publish, self.commands
        super().__init__(container, params.gap, params.render, external_stop=lambda: self.cancelled,
                         container_paint=params.output.container_paint, max_fps=MAX_FPS)
        self.publish = publish
        while not old.empty():  # requests the last run did not answer
            cmd = old.get_nowait()
            if "future" in cmd and not cmd["future"].done():
                cmd["future"].set_exception(RuntimeError("the run was restarted"))
        self.layout_id = layout_id  # the page tells layouts apart by id: never reuse one
        self.cancelled = False
        self._removed_x = {}
        self._area0 = None  # the run's first container area (simulation units)
        self._room_scale = 1.0  # how far the planned sizes were raised for painted room
        self.stage = "meshing and placing"
        self.paused = bool(paused)
        self.phase = "preparing"
        self.publish("json", self.scene())
        self._status()

    def on_stage(self, name: str) -> None:
        """Told by :func:`repulsionpak.pack` which stage without snapshots begins."""
        self.stage = name

    @property
    def takes_region(self) -> bool:
        """Whether a new region can still reach this run (its primary simulation has not
        ended: the secondary phase, the verification and the pocket fill work on the
        container the primaries were packed in)."""
        return self.stage == "meshing and placing" and self.final_svg is None and not self.cancelled

    def clear(self) -> None:
        """Forget the last run's elements (the pages draw none): a new container file."""
        self.sim, self.final_svg, self.final_status, self.last_frame = None, None, None, None
        self.layout, self.removed, self.pinned = None, set(), set()
        self.phase = "idle"
        self.layout_id += 1
        self.publish("json", dict(self.layout_message(), id=self.layout_id))
        self._status()

    def show(self, container: Container | None) -> None:
        """Between runs: show ``container`` (None: the blank canvas) on the pages."""
        self.container = container
        self.publish("json", self.scene())

    def cancel(self) -> None:
        """End the running simulation at its next iteration (also while paused)."""
        self.cancelled = True
        self.paused = False
        self.commands.put({"cmd": "noop"})

    def scene(self) -> dict:
        """The live view's scene, on the studio's fixed canvas (no container: no rings)."""
        if self.container is None or self.container.region.is_empty:
            return {"type": "scene", "rings": [], "gap": 0.0, "paint": "none", "viewBox": list(self.view_box)}
        msg = super().scene()
        msg["viewBox"] = list(self.view_box)
        return msg

    def should_stop(self) -> bool:
        if self.cancelled:
            return True
        return super().should_stop()

    # -- commands (simulation thread) ------------------------------------------------------
    def _apply(self, cmd: dict) -> None:
        if cmd["cmd"] == "region":
            if self.takes_region:
                self._set_region(cmd["container"])
            else:
                self._error("the run has passed its primary phase: the new region applies when you start again")
            return
        if cmd["cmd"] in ("remove", "unremove") and self._remove_undoable(cmd):
            return
        if cmd["cmd"] == "add":
            self._add_reported(cmd)
            return
        if cmd["cmd"] == "placed":
            try:
                cmd["future"].set_result(self._current_placed())
            except Exception as exc:  # noqa: BLE001  (handed to the requesting thread)
                cmd["future"].set_exception(exc)
            return
        super()._apply(cmd)

    def _add_reported(self, cmd: dict) -> None:
        """The live view's ``add``, its new element's index told through ``cmd["future"]``
        (None: refused); the copy's planned size is raised with the room painted so far."""
        sim = self.sim
        n0 = None if sim is None else sim.model.n_elements
        added = False
        try:
            super()._apply(cmd)
            sim = self.sim
            added = sim is not None and n0 is not None and sim.model.n_elements > n0
            if added and self._room_scale != 1.0:
                sim.model.max_growth[n0:] *= self._room_scale
                sim.max_growth = sim.model.max_growth * sim.params.growth_cap()
        finally:
            if "future" in cmd and not cmd["future"].done():
                cmd["future"].set_result(n0 if added else None)

    def _raise_planned_sizes(self, area: float) -> None:
        """Let the elements grow into painted room: the planned size of every element
        scaled by the square root of the container's area over the run's first area (never
        below 1: erased room does not shrink them), growth and the stopping rule restarted.

        Notes
        -----
        The run sized its elements for its first container (count and gap fixed): with
        more room, the same count fills it at a length scale √(area ratio) larger. Growth
        stops at ``max_growth`` (``repulsionpak.sim``), so without this the new room stays
        empty unless copies are added.
        """
        sim = self.sim
        m = sim.model
        if self._area0 is None:
            self._area0 = float(m.container_area)
        scale = float(np.sqrt(max(1.0, area / self._area0)))
        if scale != self._room_scale:
            m.max_growth = m.max_growth * (scale / self._room_scale)
            self._room_scale = scale
        st = sim.state
        st.settle_left, st.allow_growth = None, True  # a settling run grows again

    def _remove_undoable(self, cmd: dict) -> bool:
        """``remove`` as the live view does it, keeping where the element was;
        ``unremove`` puts it back there, moving again. True when handled here."""
        sim, i = self.sim, cmd["index"]
        if sim is None or i >= sim.model.n_elements or sim.model.frozen[i]:
            return cmd["cmd"] == "unremove"
        a, b = int(sim.model.elem_vstart[i]), int(sim.model.elem_vstart[i + 1])
        if cmd["cmd"] == "remove":
            if i not in self.removed:
                self._removed_x[i] = sim.state.x[a:b].copy()
            return False  # the live view's remove
        if i in self.removed and i in self._removed_x:
            self.removed.discard(i)
            sim.state.x[a:b] = self._removed_x.pop(i)
            sim.state.v[a:b] = 0.0
            sim.set_moving(i, True)
            self.publish("json", self.layout_message())
        return True

    def _set_region(self, new: Container) -> None:
        """Make ``new`` the container of the running simulation: its distance field, reflex
        corners, area and neighbour grid rebuilt as :func:`repulsionpak.sim.model.build_model`
        builds them, the simulator re-made around the same state (stepping state kept, as
        an added copy keeps it), the growth and the stopping rule started again (the elements
        have room to take), and the container the run will verify and write swapped.

        Notes
        -----
        The :class:`Container` object is the one :func:`repulsionpak.pack` was given: it is
        updated in place (it belongs to this run alone), so that the stages after the
        simulation — the art's verification against the edge, the pocket fill, the output —
        use the region the designer sees.
        """
        for f in dataclasses.fields(Container):  # (frozen: the run's own object, see Notes)
            object.__setattr__(self.container, f.name, getattr(new, f.name))
        sim = self.sim
        if sim is not None and sim.phase == "primary" and not new.region.is_empty:
            m = sim.model
            region_sim = SimFrame(self.unit).to_sim(new.region)
            self._raise_planned_sizes(float(region_sim.area))
            minx, miny, maxx, maxy = region_sim.bounds
            m.field = container_field(region_sim, m.gap / 3.0, 0.25 * max(maxx - minx, maxy - miny))
            m.corners = reflex_corners(region_sim)
            m.container_area = float(region_sim.area)
            # the neighbour grid covers the old and the new region (elements outside the
            # new one are pushed back in through the old one's room)
            x = sim.state.x
            lo = np.minimum([minx, miny], x.min(axis=0)) - m.cell_size
            hi = np.maximum([maxx, maxy], x.max(axis=0)) + m.cell_size
            m.grid_origin = (float(lo[0]), float(lo[1]))
            m.grid_extent = (float(hi[0] - lo[0]), float(hi[1] - lo[1]))
            keep = {k: getattr(sim, k) for k in ("dt", "_recoveries")}
            moving = sim.state.moving.copy()
            sim.__init__(m, sim.state, sim.params, sim.phase)
            for k, v in keep.items():
                setattr(sim, k, v)
            for e in np.flatnonzero(~moving):
                sim.set_moving(int(e), False)
            sim.refresh_growth()
            sim.mark_good()  # recovery restores to a state of this model
            sim.state.area_history.clear()  # the stopping rule measures the new room from now
        self.publish("json", self.scene())
        self._publish_frame(force=True)

    def _current_placed(self) -> list:
        from ..sim.art import placed_art
        from ..sim.model import SimFrame

        sim = self.sim
        if sim is None or sim.templates is None:
            raise RuntimeError("the simulation has not started yet")
        keep = [e for e in range(sim.model.n_elements) if e not in self.removed]
        return placed_art(sim.templates, sim.model, sim.state, SimFrame(self.unit), elements=keep,
                          params=self.render_params)


__all__ = ["StudioController"]
