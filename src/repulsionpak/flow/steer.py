"""The flow in the simulation: each aligning copy's rotation window follows the field at
its centroid.

The designer controls' rotation limits (:mod:`repulsionpak.sim.controls`) clamp each
element's rotation, relative to its placed rest shape, to ``[rot_lo, rot_hi]``. A copy
that aligns gets a window centred on its target orientation at its *current* centroid
(:func:`repulsionpak.flow.align.flow_targets`); :meth:`FlowSteer.update` moves the windows
before every projection, so a copy that slides along a curved flow turns with it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .align import flow_targets


@dataclass
class FlowSteer:
    """Per copy: ``index`` (the aligning elements of the model), ``offset`` (target =
    field angle + offset, radians), ``half`` (half-width of the window, radians) and
    ``rest`` (the rest shape's orientation, radians); ``unit`` maps simulation units to
    the field's container units."""

    field: object
    index: np.ndarray
    offset: np.ndarray
    half: np.ndarray
    rest: np.ndarray
    unit: float
    bend: object | None = None  # repulsionpak.flow.bend.FlowBend: copies that bend along the flow

    @staticmethod
    def for_copies(field, positions: np.ndarray, angles: np.ndarray, ctrls, axes: np.ndarray,
                   tolerance: float, unit: float) -> "FlowSteer":
        """The steering of copies placed at ``positions`` (container units) and
        ``angles`` (radians) with controls ``ctrls`` and axes ``axes`` (radians)."""
        on, centre, half = flow_targets(field, positions, ctrls, axes, tolerance)
        theta = field.angle(positions) if len(positions) else np.zeros(0)
        idx = np.flatnonzero(on)
        return FlowSteer(field, idx, (centre - theta)[idx], half[idx], np.asarray(angles, float)[idx], unit)

    def windows(self, centroids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) relative to the rest shapes for copies at ``centroids`` (container
        units, one per aligning copy), the target's turn kept within ±π of the rest."""
        target = self.field.angle(centroids) + self.offset - self.rest
        target = np.mod(target + np.pi, 2 * np.pi) - np.pi
        return target - self.half, target + self.half

    def update(self, x: np.ndarray, model) -> None:
        """Move the rotation windows of the aligning copies to the field at their
        centroids (``x``: the vertices, simulation units); the bending copies' rest shapes
        follow the streamlines through them (:class:`~repulsionpak.flow.bend.FlowBend`)."""
        if self.bend is not None:
            self.bend.update(x, model)
        if not len(self.index):
            return
        vs = model.elem_vstart
        sums = np.add.reduceat(x, vs[:-1], axis=0)
        cnt = np.diff(vs)[:, None]
        cent = (sums[self.index] / cnt[self.index]) * self.unit
        lo, hi = self.windows(cent)
        model.rot_lo[self.index] = lo
        model.rot_hi[self.index] = hi
        model.rot_on[self.index] = True


__all__ = ["FlowSteer"]
