"""The studio's web server: the live view's server (token, Host and Origin checks, the
WebSocket of frames and steering commands) with the studio's routes added.

Routes beyond the live view's (every one needs ``?token=``; a POST from a page of another
origin is refused with 403):

- ``GET /state``                the document as the page shows it (JSON)
- ``GET /examples``             the shipped example containers and elements
- ``POST /open-container``      multipart, one file: the container
- ``POST /open-elements``       multipart, files: element files added
- ``POST /open-secondary``      multipart, files: secondary element files added
- ``POST /open-project``        multipart, one zip: a saved project
- ``POST /edit``                JSON ``{"op": ...}``: ``stroke``, ``setting``, ``weight``, ``element``
  (an element's own ``key``: rotation, rigid, stiffness), ``pin``, ``remove``, ``moved``, ``add`` (a copy), ``guide`` (a flow guide), ``clear-guides``, ``undo``, ``redo``, ``examples``, ``remove-element``
- ``POST /run``                 JSON ``{"action": "start" | "restart"}``
- ``GET /export.svg``, ``/export.pdf``, ``/export.png``, ``/project.zip``   downloads
- ``GET /packing.svg``          the current packing (as ``/export.svg``)

Errors of the inputs or settings answer 400 (413 for a file over the size limit) with
``{"error": message}``, the message the command line would give.
"""

from __future__ import annotations

import asyncio
import json
from importlib import resources

from aiohttp import web

from ..errors import RepulsionPakError
from ..live.server import HOST, LiveServer, STATIC as LIVE_STATIC
from .session import Session
from .uploads import MAX_FILE_BYTES, MAX_PROJECT_BYTES, UploadTooLarge

STATIC = {"studio.js": "text/javascript", "studio.css": "text/css"}
EXPORTS = {"svg": ("image/svg+xml", "packing.svg"), "pdf": ("application/pdf", "packing.pdf"),
           "png": ("image/png", "packing.png")}


class StudioServer(LiveServer):
    """Serve ``session`` on 127.0.0.1:``port`` (0: any free port)."""

    client_max_size = MAX_PROJECT_BYTES + (1 << 20)

    def __init__(self, session: Session, port: int = 8765, token: str | None = None):
        super().__init__(session.controller, port, token=token)
        self.session = session

    def add_routes(self, app: web.Application) -> None:
        for name in STATIC:
            app.router.add_get(f"/{name}", self._studio_static)
        app.router.add_get("/state", self._state)
        app.router.add_get("/examples", self._examples)
        app.router.add_post("/open-container", self._open_container)
        app.router.add_post("/open-elements", self._open_elements)
        app.router.add_post("/open-secondary", self._open_secondary)
        app.router.add_post("/open-project", self._open_project)
        app.router.add_post("/edit", self._edit)
        app.router.add_post("/run", self._run)
        for kind in EXPORTS:
            app.router.add_get(f"/export.{kind}", self._export)
        app.router.add_get("/project.zip", self._project)

    # -- checks ----------------------------------------------------------------------------
    def _check_post(self, request: web.Request) -> None:
        """The live view's checks (Host, token) and, for a change, the page's own Origin
        (a page of another site could otherwise post to the loopback server)."""
        self._check(request)
        origin = request.headers.get("Origin")
        if origin is not None and origin not in (f"http://{HOST}:{self.port}", f"http://localhost:{self.port}"):
            raise web.HTTPForbidden(text=f"request from a foreign origin {origin!r} refused")

    async def _call(self, fn, *args):
        """Run a session call in a worker thread; its errors become 400/413 JSON answers."""
        try:
            return await asyncio.to_thread(fn, *args)
        except UploadTooLarge as exc:
            raise web.HTTPRequestEntityTooLarge(max_size=MAX_FILE_BYTES, actual_size=0, text=json.dumps(
                {"error": str(exc)}), content_type="application/json") from None
        except RepulsionPakError as exc:
            raise web.HTTPBadRequest(text=json.dumps({"error": str(exc)}), content_type="application/json") from None

    async def _files(self, request: web.Request, limit: int = MAX_FILE_BYTES) -> list[tuple[str, bytes]]:
        """The files of a multipart upload, each refused past ``limit`` bytes as it arrives,
        all of them together past the project limit (a folder)."""
        try:
            reader = await request.multipart()
        except (AssertionError, ValueError, KeyError):
            raise web.HTTPBadRequest(text=json.dumps({"error": "expected a file upload (multipart/form-data)"}),
                                     content_type="application/json") from None
        out, total = [], 0
        while (part := await reader.next()) is not None:
            if not getattr(part, "filename", None):
                continue
            buf = bytearray()
            while chunk := await part.read_chunk(1 << 16):
                buf += chunk
                total += len(chunk)
                if total > MAX_PROJECT_BYTES:
                    msg = (f"the upload is larger than {MAX_PROJECT_BYTES / 2**20:.0f} MB, the most the studio "
                           f"accepts at once")
                    raise web.HTTPRequestEntityTooLarge(max_size=MAX_PROJECT_BYTES, actual_size=total,
                                                        text=json.dumps({"error": msg}),
                                                        content_type="application/json")
                if len(buf) > limit:
                    msg = (f"{part.filename}: the file is larger than {limit / 2**20:.0f} MB, "
                           f"the most the studio accepts")
                    raise web.HTTPRequestEntityTooLarge(max_size=limit, actual_size=len(buf), text=json.dumps(
                        {"error": msg}), content_type="application/json")
            out.append((part.filename, bytes(buf)))
        if not out:
            raise web.HTTPBadRequest(text=json.dumps({"error": "no file in the upload"}),
                                     content_type="application/json")
        return out

    # -- routes ------------------------------------------------------------------------------
    async def _index(self, request: web.Request) -> web.Response:
        self._check(request)
        return web.Response(text=_static_text("index.html"), content_type="text/html",
                            headers={"Cache-Control": "no-store"})

    async def _static(self, request: web.Request) -> web.Response:
        self._check(request, token=False)  # the live view's app.js and style.css
        name = request.path.lstrip("/")
        text = resources.files("repulsionpak.live").joinpath("static", name).read_text(encoding="utf-8")
        return web.Response(text=text, content_type=LIVE_STATIC[name])

    async def _studio_static(self, request: web.Request) -> web.Response:
        self._check(request, token=False)
        name = request.path.lstrip("/")
        return web.Response(text=_static_text(name), content_type=STATIC[name])

    async def _state(self, request: web.Request) -> web.Response:
        self._check(request)
        return web.json_response(await self._call(self.session.state))

    async def _examples(self, request: web.Request) -> web.Response:
        self._check(request)
        from .. import examples

        return web.json_response({"containers": examples.container_names(),
                                  "elements": [p.stem for p in examples.element_files()]})

    async def _open_container(self, request: web.Request) -> web.Response:
        self._check_post(request)
        files = await self._files(request)
        name, data = files[0]
        return web.json_response(await self._call(self.session.open_container, name, data))

    async def _open_elements(self, request: web.Request) -> web.Response:
        self._check_post(request)
        files = await self._files(request)
        return web.json_response(await self._call(self.session.add_elements, files))

    async def _open_secondary(self, request: web.Request) -> web.Response:
        self._check_post(request)
        files = await self._files(request)
        return web.json_response(await self._call(self.session.add_elements, files, True))

    async def _open_project(self, request: web.Request) -> web.Response:
        self._check_post(request)
        files = await self._files(request, limit=MAX_PROJECT_BYTES)
        return web.json_response(await self._call(self.session.open_project, files[0][1]))

    async def _json(self, request: web.Request) -> dict:
        try:
            msg = await request.json()
        except (ValueError, UnicodeDecodeError):
            msg = None
        if not isinstance(msg, dict):
            raise web.HTTPBadRequest(text=json.dumps({"error": "expected a JSON object"}),
                                     content_type="application/json")
        return msg

    async def _edit(self, request: web.Request) -> web.Response:
        self._check_post(request)
        msg = await self._json(request)
        s = self.session
        op = msg.get("op")
        calls = {
            "stroke": lambda: s.stroke(msg.get("stroke")),
            "setting": lambda: s.set_setting(str(msg.get("name")), msg.get("value")),
            "pin": lambda: s.pin(_index(msg), bool(msg.get("pinned", True))),
            "remove": lambda: s.remove(_index(msg)),
            "weight": lambda: s.set_weight(_index(msg), msg.get("value")),
            "element": lambda: s.set_element(_index(msg), str(msg.get("key")), msg.get("value")),
            "moved": lambda: s.moved(_index(msg), _number(msg, "dx"), _number(msg, "dy")),
            "add": lambda: s.add_copy(_index(msg), _number(msg, "x"), _number(msg, "y")),
            "guide": lambda: s.guide(msg.get("guide")),
            "clear-guides": s.clear_guides,
            "undo": s.undo,
            "redo": s.redo,
            "examples": lambda: s.use_examples(msg.get("container"), msg.get("elements")),
            "remove-element": lambda: s.remove_element(_index(msg), bool(msg.get("secondary", False))),
        }
        if op not in calls:
            raise web.HTTPBadRequest(text=json.dumps({"error": f"unknown edit {op!r}"}),
                                     content_type="application/json")
        return web.json_response(await self._call(calls[op]))

    async def _run(self, request: web.Request) -> web.Response:
        self._check_post(request)
        msg = await self._json(request)
        action = msg.get("action")
        if action not in ("start", "restart"):
            raise web.HTTPBadRequest(text=json.dumps({"error": f"unknown action {action!r}"}),
                                     content_type="application/json")
        return web.json_response(await self._call(
            self.session.start, action == "restart", bool(msg.get("paused", False))))

    async def _export(self, request: web.Request) -> web.Response:
        self._check(request)
        kind = request.path.rsplit(".", 1)[-1]
        try:
            data = await self._call(self.session.export, kind)
        except RuntimeError as exc:
            raise web.HTTPServiceUnavailable(text=str(exc)) from exc
        ctype, name = EXPORTS[kind]
        return web.Response(body=data, content_type=ctype, headers={
            "Content-Disposition": f'attachment; filename="{name}"', "Cache-Control": "no-store"})

    async def _packing(self, request: web.Request) -> web.Response:
        return await self._export(request.clone(rel_url=f"/export.svg?{request.query_string}"))

    async def _project(self, request: web.Request) -> web.Response:
        self._check(request)
        data = await self._call(self.session.project_zip)
        return web.Response(body=data, content_type="application/zip", headers={
            "Content-Disposition": 'attachment; filename="packing-project.zip"', "Cache-Control": "no-store"})


def _index(msg: dict) -> int:
    from ..errors import ParameterError

    i = msg.get("index")
    if not isinstance(i, int) or isinstance(i, bool) or i < 0:
        raise ParameterError(f"'index' must be an element index, got {i!r}")
    return i


def _number(msg: dict, key: str) -> float:
    import math

    from ..errors import ParameterError

    v = msg.get(key)
    if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
        raise ParameterError(f"'{key}' must be a finite number, got {v!r}")
    return float(v)


def _static_text(name: str) -> str:
    return resources.files("repulsionpak.studio").joinpath("static", name).read_text(encoding="utf-8")


__all__ = ["StudioServer"]
