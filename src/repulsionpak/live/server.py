"""The live view's web server: aiohttp on 127.0.0.1, in a thread of its own.

Routes (all but the static files need ``?token=`` — the random token printed in the URL):

- ``GET /``            the page (``static/index.html``)
- ``GET /app.js``, ``GET /style.css``   its script and style
- ``GET /packing.svg`` the current packing in the output format (the final one once done)
- ``GET /ws``          WebSocket: binary frames and JSON messages (see ``protocol.py``)

A request whose ``Host`` is not this loopback address (DNS rebinding) and a WebSocket
whose ``Origin`` is not this page's are refused with 403.
"""

from __future__ import annotations

import asyncio
import json
import secrets
import threading
from importlib import resources

from aiohttp import WSMsgType, web

from ..errors import RepulsionPakError
from .controller import LiveController
from .protocol import parse_command

HOST = "127.0.0.1"
STATIC = {"app.js": "text/javascript", "style.css": "text/css"}


class LiveServerError(RepulsionPakError):
    """The live view's server cannot start (e.g. the port is taken)."""

    exit_code = 2


class _Client:
    """One connected page: the newest frame waits in a one-slot mailbox, so a slow tab
    skips frames instead of queueing them."""

    def __init__(self, ws: web.WebSocketResponse):
        self.ws = ws
        self.frame: bytes | None = None
        self.wake = asyncio.Event()
        self.messages: list[str] = []


class LiveServer:
    #: largest request body (bytes); a server built on this one may take more
    client_max_size = 1 << 20

    def __init__(self, controller: LiveController, port: int = 8765, token: str | None = None,
                 estimate_every: float = 1.0):
        self.controller = controller
        self.port = int(port)
        self.token = token or secrets.token_urlsafe(16)
        self.estimate_every = estimate_every
        self.clients: set[_Client] = set()
        self.loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._runner: web.AppRunner | None = None
        self._started = threading.Event()
        self._error: BaseException | None = None
        self._stop: asyncio.Event | None = None
        controller.publish = self.publish

    @property
    def url(self) -> str:
        return f"http://{HOST}:{self.port}/?token={self.token}"

    # -- lifecycle ------------------------------------------------------------------
    def start(self) -> str:
        """Start serving in a daemon thread; returns the URL. Raises
        :class:`LiveServerError` when the port is taken."""
        self._thread = threading.Thread(target=self._main, name="repulsionpak-live", daemon=True)
        self._thread.start()
        self._started.wait()
        if self._error is not None:
            raise self._error
        return self.url

    def stop(self) -> None:
        """Close every connection and the server (nothing to do if it never started)."""
        if self._thread is None or not self._thread.is_alive() or self.loop is None or self._stop is None:
            return
        try:
            self.loop.call_soon_threadsafe(self._stop.set)
        except RuntimeError:  # the loop closed meanwhile
            return
        self._thread.join(timeout=10)

    def _main(self) -> None:
        loop = asyncio.new_event_loop()
        self.loop = loop
        asyncio.set_event_loop(loop)
        try:
            loop.run_until_complete(self._serve())
        finally:
            loop.close()

    async def _serve(self) -> None:
        self._stop = asyncio.Event()
        app = web.Application(client_max_size=self.client_max_size)
        app.router.add_get("/", self._index)
        app.router.add_get("/packing.svg", self._packing)
        app.router.add_get("/ws", self._ws)
        app.router.add_get("/favicon.ico", lambda request: web.Response(status=204))
        for name in STATIC:
            app.router.add_get(f"/{name}", self._static)
        self.add_routes(app)
        self._runner = web.AppRunner(app, handle_signals=False, access_log=None)
        await self._runner.setup()
        site = web.TCPSite(self._runner, HOST, self.port, reuse_address=False)
        try:
            await site.start()
        except OSError as exc:
            self._error = LiveServerError(
                f"cannot serve the live view on {HOST}:{self.port}: {exc.strerror or exc} "
                "(is another `repulsionpak pack --live` running? choose another --port)")
            await self._runner.cleanup()
            self._started.set()
            return
        if self.port == 0:
            self.port = site._server.sockets[0].getsockname()[1]  # noqa: SLF001
        self._started.set()
        estimator = asyncio.ensure_future(self._estimate_loop())
        await self._stop.wait()
        estimator.cancel()
        for c in list(self.clients):
            await c.ws.close()
        await self._runner.cleanup()

    def add_routes(self, app: web.Application) -> None:
        """More routes of a server built on this one (the studio's); none here."""

    # -- publishing (called from the simulation thread) --------------------------------
    def publish(self, kind: str, payload) -> None:
        loop = self.loop
        if loop is None or loop.is_closed():
            return
        try:
            loop.call_soon_threadsafe(self._deliver, kind, payload)
        except RuntimeError:  # the loop closed meanwhile
            pass

    def _deliver(self, kind: str, payload) -> None:
        text = None if kind == "frame" else json.dumps(payload)
        for c in self.clients:
            if kind == "frame":
                c.frame = payload
            else:
                c.messages.append(text)
            c.wake.set()

    async def _estimate_loop(self) -> None:
        """Area fraction and median gap for the pages, every ``estimate_every`` seconds
        or 5x the time an estimate takes (≤ 20% of a core on big scenes)."""
        last, pause = None, self.estimate_every
        while True:
            await asyncio.sleep(pause)
            frame = self.controller.last_frame
            if not self.clients or frame is None or frame is last:
                continue
            last = frame
            t0 = self.loop.time()
            try:
                est = await asyncio.to_thread(self.controller.estimates)
            except Exception:  # noqa: BLE001  (an estimate is never worth stopping for)
                continue
            pause = max(self.estimate_every, 5 * (self.loop.time() - t0))
            # an estimate begun before the run ended must not follow its final status (the
            # page showed "0.644 (est.)" after "Converged"; the test failed once in ~10)
            if est and self.controller.final_status is None:
                self._deliver("json", dict(self.controller.status(), **est))

    # -- HTTP ---------------------------------------------------------------------------
    def _check(self, request: web.Request, token: bool = True) -> None:
        host = request.headers.get("Host", "")
        if host not in (f"{HOST}:{self.port}", f"localhost:{self.port}"):
            raise web.HTTPForbidden(text=f"wrong Host {host!r}: the live view answers only on {HOST}")
        if token and not secrets.compare_digest(request.query.get("token", ""), self.token):
            raise web.HTTPForbidden(text="missing or wrong access token (use the URL printed by repulsionpak)")

    async def _index(self, request: web.Request) -> web.Response:
        self._check(request)
        return web.Response(text=_static_text("index.html"), content_type="text/html",
                            headers={"Cache-Control": "no-store"})

    async def _static(self, request: web.Request) -> web.Response:
        self._check(request, token=False)
        name = request.path.lstrip("/")
        return web.Response(text=_static_text(name), content_type=STATIC[name])

    async def _packing(self, request: web.Request) -> web.Response:
        self._check(request)
        try:
            text = await asyncio.to_thread(self.controller.render_svg)
        except RuntimeError as exc:
            raise web.HTTPServiceUnavailable(text=str(exc)) from exc
        return web.Response(text=text, content_type="image/svg+xml", headers={
            "Content-Disposition": 'attachment; filename="packing.svg"', "Cache-Control": "no-store"})

    async def _ws(self, request: web.Request) -> web.WebSocketResponse:
        self._check(request)
        origin = request.headers.get("Origin")
        if origin is not None and origin not in (f"http://{HOST}:{self.port}", f"http://localhost:{self.port}"):
            raise web.HTTPForbidden(text=f"WebSocket from a foreign origin {origin!r} refused")
        # no per-message deflate: on loopback it only costs time (a 300-element frame of
        # 290 kB took the event loop longer to compress than the simulation took to step)
        ws = web.WebSocketResponse(heartbeat=30, max_msg_size=1 << 16, compress=False)
        await ws.prepare(request)
        client = _Client(ws)
        ctl = self.controller
        client.messages += [json.dumps(ctl.scene()), json.dumps(ctl.layout_message()), json.dumps(ctl.status())]
        client.frame = ctl.last_frame
        client.wake.set()
        self.clients.add(client)
        sender = asyncio.ensure_future(self._send_loop(client))
        try:
            async for msg in ws:
                if msg.type != WSMsgType.TEXT:
                    continue
                try:
                    cmd = parse_command(json.loads(msg.data))
                except ValueError as exc:
                    await ws.send_json({"type": "error", "message": str(exc)})
                    continue
                if ctl.final_svg is None:
                    ctl.submit(cmd)
        finally:
            self.clients.discard(client)
            sender.cancel()
        return ws

    async def _send_loop(self, client: _Client) -> None:
        ws = client.ws
        try:
            while not ws.closed:
                await client.wake.wait()
                client.wake.clear()
                while client.messages:
                    await ws.send_str(client.messages.pop(0))
                frame, client.frame = client.frame, None
                if frame is not None:
                    await ws.send_bytes(frame)
        except (ConnectionError, RuntimeError):
            pass  # the tab went away: the run goes on


def _static_text(name: str) -> str:
    return resources.files("repulsionpak.live").joinpath("static", name).read_text(encoding="utf-8")


__all__ = ["LiveServer", "LiveServerError", "HOST"]
