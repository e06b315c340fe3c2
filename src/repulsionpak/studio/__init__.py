"""A packing studio in the browser (``repulsionpak studio``): open or paint the container,
choose the elements and the settings, run and steer the packing, export it.

- :mod:`.region`: the painted container (brush strokes united and subtracted with shapely)
- :mod:`.settings`: the settings, their defaults, checks and the equivalent command line
- :mod:`.document`: what the designer edits and the undo/redo stack
- :mod:`.controller`: the live view's controller across runs, changing a running container
- :mod:`.uploads`: what the studio accepts from the browser (names, sizes, messages)
- :mod:`.project`: a project as a zip archive (the files, the settings, the command)
- :mod:`.session`: inputs, edits, the run thread, exports
- :mod:`.server`: the live view's server with the studio's routes
- ``static/``: the page (on top of the live view's script)

See ``docs/studio.md``.
"""

from __future__ import annotations

import sys
import time
import webbrowser
from collections.abc import Callable, Sequence
from pathlib import Path

from ..errors import ParameterError

try:
    from .server import StudioServer
except ImportError as exc:  # pragma: no cover  (aiohttp is the optional extra "live")
    raise ParameterError("the studio needs the aiohttp package: pip install 'repulsionpak[live]' "
                         f"({exc})") from exc
from .session import Session


def open_inputs(session: Session, container: Path | None, elements: Sequence[Path]) -> None:
    """Open the files given on the command line in ``session`` (folders: their
    ``*.svg`` and ``*.path`` files)."""
    if container is not None:
        session.open_container(container.name, _read(container))
    files = []
    for p in elements:
        if p.is_dir():
            files += sorted(q for q in p.iterdir() if q.suffix.lower() in (".svg", ".path"))
        else:
            files.append(p)
    if files:
        session.add_elements([(f.name, _read(f)) for f in files])


def _read(path: Path) -> bytes:
    from ..errors import InputError

    try:
        return path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read the file ({exc.strerror or exc})") from None


def run_studio(container: Path | None = None, elements: Sequence[Path] = (), port: int = 8765,
               open_browser: bool = True, stop: Callable[[], bool] | None = None, out=None) -> None:
    """Serve a studio session until ``stop()`` is true (default: until Ctrl-C).

    Prints the page's URL (with its access token) on a line of its own.
    """
    if not 0 <= int(port) <= 65535:
        raise ParameterError(f"--port must be in 0..65535, got {port}")
    session = Session()
    try:
        open_inputs(session, container, elements)
        server = StudioServer(session, port)
        url = server.start()
        print(url, file=out or sys.stdout, flush=True)
        if open_browser:
            webbrowser.open(url)
        try:
            while not (stop is not None and stop()):
                time.sleep(0.2)
        finally:
            server.stop()
    finally:
        session.close()


__all__ = ["Session", "StudioServer", "open_inputs", "run_studio"]
