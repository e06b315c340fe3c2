"""The result users hold: :class:`Packing`, its measures, its checks and its files.

``repulsionpak pack``, the batch workers, the live view and a notebook all turn a packing
into files through these methods, so :meth:`Packing.save` writes exactly what the
command writes for the same inputs, seed and parameters.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import ParameterError
from .inputs import margin_of
from .params import Params
from .sim.art import skin_polygons
from .sim.model import Model, SimFrame, State
from .threads import worker_threads
from .types import Container, Element, PlacedArt
from .verify import Verification

#: what :meth:`Packing.save` writes, by the file's suffix
SAVE_FORMATS = (".svg", ".pdf", ".png", ".json")


def fit_workers() -> int:
    """Threads for the distortion fits of a report.

    Returns
    -------
    int
        :func:`repulsionpak.threads.worker_threads`: this process's cores, at most 4, and
        at most ``$REPULSIONPAK_THREADS`` (which caps the simulation's threads too).
    """
    return worker_threads()


def invariants(packing: "Packing", metrics: dict) -> dict:
    """End-of-run checks of the promises, on the art as written.

    Parameters
    ----------
    packing : Packing
    metrics : dict
        :func:`repulsionpak.measure.evaluate` of the packing.

    Returns
    -------
    dict
        The final verification's (:mod:`repulsionpak.verify`: overlap, outside, edge margin, gap
        floor), the exact art overlap measured independently by ``evaluate``, the
        elements outside, and ``ok``.
    """
    ver = packing.verification.to_dict() if packing.verification is not None else {}
    art_ok = bool(metrics["overlap_area"] <= 1e-9 * packing.container.area)
    return {
        **ver,
        "art_overlap_area": float(metrics["overlap_area"]),
        "art_overlap_ok": art_ok,
        "elements_outside": int(metrics.get("n_outside", 0)),
        "ok": bool(ver.get("ok", True) and art_ok and not metrics.get("n_outside", 0)),
    }


@dataclass(eq=False)
class Packing:
    """Result of :func:`repulsionpak.pack`: the placed art and everything needed to
    inspect, measure, save or resume it.

    ``params`` are the parameters the stages ran with (the pocket fill's caps included);
    ``asked`` the ones :func:`~repulsionpak.pack` was given, resolved (gap, seed), which
    the report records. ``elements`` and ``secondary`` are the elements given (the
    report's distortion compares the art with them); ``sources`` names the inputs.
    """

    container: Container
    gap: float
    placed: list[PlacedArt]
    templates: list
    model: Model
    state: State
    frame: SimFrame
    params: Params
    iterations: dict[str, int] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)
    stopped_by: dict[str, str] = field(default_factory=dict)
    area_fraction_meshes: float = 0.0
    verification: Verification | None = None
    asked: Params | None = None
    elements: tuple[Element, ...] = ()
    secondary: tuple[Element, ...] = ()
    sources: dict = field(default_factory=dict)
    flow: object | None = None  # the flow field the elements followed (repulsionpak.flow.FlowField)
    #: the primary phase's moves into voids: (element, iteration, kept, iterations it ran)
    #: (repulsionpak.sim.relocate)
    moves: list = field(default_factory=list)
    _cache: dict = field(default_factory=dict, repr=False)

    def __setattr__(self, name: str, value) -> None:
        # measures, checks and SVG text are computed once; a field assigned anew (the
        # live view's removals, the pocket fills while pack() runs) makes them stale
        if not name.startswith("_") and "_cache" in self.__dict__:
            self.__dict__["_cache"].clear()
        object.__setattr__(self, name, value)

    @property
    def partial(self) -> bool:
        """Whether a stop (Ctrl-C, ``should_stop``) ended a stage early."""
        return any(v == "interrupted" for v in self.stopped_by.values())

    @property
    def n_primary(self) -> int:
        """Primary elements in the result (after the verification, which may drop some)."""
        if self.placed or self.verification is not None:
            return sum(1 for p in self.placed if p.kind == "primary")
        return sum(1 for k in self.model.kind if k == "primary")

    @property
    def n_secondary(self) -> int:
        """Secondary elements in the result."""
        if self.placed or self.verification is not None:
            return sum(1 for p in self.placed if p.kind == "secondary")
        return sum(1 for k in self.model.kind if k == "secondary")

    @property
    def margin(self) -> float:
        """The edge margin the packing keeps, container units."""
        return margin_of(self.asked or self.params, self.gap)

    @property
    def container_paint(self) -> str:
        """How the outputs draw the container (``outline``, ``as-drawn``, ``none``)."""
        return self.params.output.container_paint

    def skins(self) -> list[np.ndarray]:
        """The skins' outlines, container units."""
        return skin_polygons(self.model, self.state, self.frame)

    # ------------------------------------------------------------------ measures

    def metrics(self, distortion: bool = True, scp: bool = False) -> dict:
        """The end-of-run measures, as ``repulsionpak pack`` takes them.

        Parameters
        ----------
        distortion : bool
            Also fit each copy to its source art (``distortion``) and measure the
            primaries' Q_s ratio, as a report does; slower.
        scp : bool
            Also the SCP curve Q_s(r) (as ``repulsionpak batch`` ranks its packings).

        Returns
        -------
        dict
            :func:`repulsionpak.measure.evaluate`'s dict, computed once per packing (one
            measured with more serves a call asking for less).
        """
        cache = self._cache.setdefault("metrics", {})
        for (d, s), m in cache.items():
            if d >= distortion and s >= scp:
                return m
        from .measure import evaluate

        m = evaluate(self.container, self.placed, self.gap, with_scp=scp, margin=self.margin,
                     sources=[*self.elements, *self.secondary] if distortion else None,
                     workers=fit_workers(), primary_scp=distortion or scp)
        cache[(bool(distortion), bool(scp))] = m
        return m

    def checks(self, metrics: dict | None = None) -> dict:
        """:func:`invariants` of the packing (the ``invariants`` of its SVG and report),
        from ``metrics`` (default: :meth:`metrics`); computed once per metrics dict."""
        metrics = self.metrics(distortion=False) if metrics is None else metrics
        key = ("checks", id(metrics))
        if key not in self._cache:
            self._cache[key] = (metrics, invariants(self, metrics))  # (holds metrics: its id stays its own)
        return self._cache[key][1]

    def evaluate(self, grid: int = 1000, distortion: bool = False) -> dict:
        """Every measure, as ``repulsionpak evaluate OUT.svg --json`` gives it.

        Parameters
        ----------
        grid : int
            Pixels along the longer side of the SCP raster.
        distortion : bool
            Also fit each copy to its source art (``repulsionpak evaluate --elements``).

        Returns
        -------
        dict
            Area fraction, overlaps, gap statistics, edge distances, SCP Q_s(r) ...
            (see :func:`repulsionpak.measure.evaluate`), measured on the art in memory.
        """
        from .measure import evaluate

        return evaluate(self.container, self.placed, self.gap, grid=grid, margin=self.margin,
                        sources=[*self.elements, *self.secondary] if distortion else None,
                        workers=fit_workers() if distortion else 1)

    def report(self, seconds: dict | None = None, not_written=(), movie: dict | None = None,
               distortion: bool = True) -> dict:
        """The ``--report`` dict of ``repulsionpak pack``.

        Parameters
        ----------
        seconds : dict, optional
            The run's times (default: the stages' own, ``packing.seconds``).
        not_written : sequence of str
            Outputs a stop left out (their names; the report then says so).
        movie : dict, optional
            The movie's entry, when one was written.
        distortion : bool
            False: from the measures without the distortion fit (:meth:`metrics`), its
            entries and ``scp_ratio_primary`` None; every other entry is the same.

        Returns
        -------
        dict
            See :func:`repulsionpak.report.report_dict`.

        Notes
        -----
        ``repulsionpak pack`` without ``--report`` only needs the counts, the area, the
        gaps and the checks for its summary line: ``distortion=False`` spares it a second
        measurement of the art with the fits and the primaries' SCP raster.
        """
        from .report import report_dict

        return report_dict(self, self.metrics(distortion=distortion), seconds=seconds, not_written=not_written,
                           movie=movie)

    # ------------------------------------------------------------------ files

    def paint_warning(self) -> str | None:
        """The warning to give when the container, drawn as-drawn, hides the art
        (:func:`repulsionpak.render.container_paint.hiding_warning`); None otherwise."""
        from .render.container_paint import hiding_warning

        return hiding_warning(self.container, self.placed, self.container_paint)

    def svg_text(self, debug_layers: bool = False, path: str | Path = "<output>") -> str:
        """The packing SVG of ``repulsionpak pack``.

        Parameters
        ----------
        debug_layers : bool
            Add hidden skin outlines.
        path : str or Path
            Only names the output in error messages.

        Returns
        -------
        str
            Root ``data-gap``, ``data-seed``, ``data-iterations``, ``data-area-fraction``,
            the run's metadata (seed, stopping reasons, :meth:`checks`), the container
            drawn as ``params.output.container_paint`` says.
        """
        key = ("svg", bool(debug_layers))
        if key not in self._cache:
            from .render.svg import packing_svg_string

            metrics = self.metrics(distortion=False)
            seed = self.params.seed
            attrs = {"seed": str(seed), "iterations": str(sum(self.iterations.values())),
                     "area-fraction": f"{metrics['area_fraction']:.4f}"}
            meta = {"generator": "repulsionpak", "seed": seed, "partial": self.partial,
                    "stopped_by": self.stopped_by, "invariants": self.checks(metrics)}
            debug = {"skins": self.skins()} if debug_layers else None
            if debug and self.flow is not None:  # the field's arrows, a gap-independent grid
                r = self.container.region
                debug["flow"] = self.flow.arrows(r, max(r.bounds[2] - r.bounds[0], r.bounds[3] - r.bounds[1]) / 30)
            self._cache[key] = packing_svg_string(
                self.container, self.placed, self.gap, attrs=attrs, debug_layers=debug,
                partial=self.partial, metadata=meta, path=path, container_paint=self.container_paint)
        return self._cache[key]

    def png_bytes(self, size_px: int = 1200) -> bytes:
        """The packing as a PNG image (``--png``), ``size_px`` pixels along its longer side."""
        from .render.png import png_bytes

        return png_bytes(self.container, self.placed, size_px, container_paint=self.container_paint,
                         gap=self.gap)

    def save(self, path: str | os.PathLike, debug_layers: bool = False, format: str | None = None) -> Path:
        """Write the packing as ``repulsionpak pack`` writes it, by the file's suffix.

        Parameters
        ----------
        path : str or PathLike
            ``.svg`` (``-o``), ``.pdf`` (``--pdf``; needs ``repulsionpak[pdf]``), ``.png``
            (``--png``) or ``.json`` (``--report``, times included).
        debug_layers : bool
            SVG and PDF: add hidden skin outlines (``--debug-layers``).
        format : str, optional
            ``"svg"``, ``"pdf"``, ``"png"`` or ``"json"`` whatever the suffix.

        Returns
        -------
        Path
            The file written (atomically).
        """
        from .io.files import atomic_write_bytes

        path = Path(path)
        kind = path.suffix.lower() if format is None else "." + format.lower().lstrip(".")
        if kind == ".svg":
            data = self.svg_text(debug_layers, path).encode("utf-8")
        elif kind == ".pdf":
            from .render.pdf import pdf_bytes

            data = pdf_bytes(self.svg_text(debug_layers, path), path)
        elif kind == ".png":
            data = self.png_bytes()
        elif kind == ".json":
            data = (json.dumps(self.report(), indent=2) + "\n").encode("utf-8")
        else:
            raise ParameterError(f"{path}: cannot save a packing as {kind or '(no extension)'!r}; "
                                 f"use one of {', '.join(SAVE_FORMATS)}")
        atomic_write_bytes(path, data)
        return path

    def _repr_svg_(self) -> str:
        return self.svg_text()

    def _repr_png_(self) -> bytes:
        return self.png_bytes(600)


__all__ = ["Packing", "SAVE_FORMATS", "fit_workers", "invariants"]
