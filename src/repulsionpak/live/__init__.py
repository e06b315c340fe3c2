"""Watch and steer a packing in the browser (``repulsionpak pack ... --live``).

- :mod:`.protocol`: the binary frame format and the page's commands
- :mod:`.controller`: the simulation side (a snapshot consumer that applies commands)
- :mod:`.server`: the aiohttp server on 127.0.0.1 (page, WebSocket, ``/packing.svg``)
- ``static/``: the page (HTML, JS, CSS)

See ``docs/live.md``.
"""

from __future__ import annotations

import sys
import time
import webbrowser
from collections.abc import Callable

from ..errors import ParameterError
from .controller import LiveController

try:
    from .server import LiveServer, LiveServerError
except ImportError as exc:  # pragma: no cover  (aiohttp is the optional extra "live")
    raise ParameterError("--live needs the aiohttp package: pip install 'repulsionpak[live]' "
                         f"({exc})") from exc


class LiveRun:
    """What ``repulsionpak pack --live`` adds to a run: start the server, hand its
    callbacks to :func:`repulsionpak.pack.pack`, and keep serving the result until Ctrl-C."""

    def __init__(self, container, params, port: int = 8765, open_browser: bool = True,
                 external_stop: Callable[[], bool] | None = None, token: str | None = None,
                 paused: bool = False, flow=None):
        if not 0 <= int(port) <= 65535:
            raise ParameterError(f"--port must be in 0..65535, got {port}")
        gap = float(params.gap)
        self.controller = LiveController(container, gap, params.render, external_stop=external_stop,
                                         container_paint=params.output.container_paint)
        self.controller.paused = bool(paused)  # from the first frame on
        if flow is not None:  # --flow: the page shows the field's arrows
            from ..flow.hook import run_field

            self.controller.field = run_field(flow, container)
        self.server = LiveServer(self.controller, port, token=token)
        self.open_browser = open_browser

    def start(self, out=None) -> str:
        url = self.server.start()
        print(url, file=out or sys.stdout, flush=True)
        if self.open_browser:
            webbrowser.open(url)
        return url

    def on_snapshot(self, other: Callable | None = None) -> Callable:
        def both(snap):
            if other is not None:
                other(snap)
            self.controller.on_snapshot(snap)
        return both

    @property
    def should_stop(self) -> Callable[[], bool]:
        return self.controller.should_stop

    def drop_removed(self, packing) -> None:
        packing.placed = self.controller.drop_removed(packing.placed)

    def finish(self, packing, metrics: dict, svg_text: str) -> None:
        self.controller.finish(svg_text, dict(packing.stopped_by), metrics["area_fraction"],
                               metrics["gap"]["median"])

    def wait(self, stop: Callable[[], bool], poll: float = 0.2) -> None:
        """Block until ``stop()`` (Ctrl-C) while the server goes on serving."""
        while not stop():
            time.sleep(poll)

    def close(self) -> None:
        self.server.stop()


__all__ = ["LiveRun", "LiveController", "LiveServer", "LiveServerError"]
