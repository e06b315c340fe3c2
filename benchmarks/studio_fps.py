"""Frames per second the studio delivers while a packing runs (issue 44: >= 20 at 300 elements).

A studio session packs the example elements into the example heart with ``--count N``;
once the elements are on the stage, frames are counted for ``--seconds`` at two places:
a WebSocket client (what the server sends) and, with Chromium and Playwright, the page
itself (``window.repulsionpak.frames``: frames drawn into ``#stage``; ``received``: frames
that arrived, the newest of which is drawn at each animation frame), with Chromium's
main-thread times per drawn frame (``Performance.getMetrics``) and the page's own time
writing the paths. The simulation's own iteration rate is printed beside them: a frame is
sent at most once per iteration and at most 60 times a second (``studio.controller.MAX_FPS``).

    python benchmarks/studio_fps.py [--count 300] [--seconds 10] [--no-browser]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import shutil
import threading
import time

import aiohttp

from repulsionpak.studio import Session, StudioServer


async def _count_frames(url: str, seconds: float) -> int:
    n = 0
    async with aiohttp.ClientSession() as s:
        async with s.ws_connect(url) as ws:
            t_end = time.monotonic() + seconds
            while time.monotonic() < t_end:
                try:
                    m = await ws.receive(timeout=max(0.01, t_end - time.monotonic()))
                except asyncio.TimeoutError:
                    break
                if m.type == aiohttp.WSMsgType.BINARY:
                    n += 1
    return n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=300)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-browser", action="store_true")
    args = ap.parse_args()
    session = Session()
    server = StudioServer(session, port=0)
    server.start()
    try:
        session.use_examples("heart", [])
        session.set_setting("count", args.count)
        session.set_setting("seed", args.seed)
        t0 = time.monotonic()
        session.start()
        ctl = session.controller
        while ctl.sim is None:
            if session.error:
                raise SystemExit(session.error)
            time.sleep(0.1)
        m = ctl.sim.model
        print(f"elements {m.n_elements}  vertices {m.n_vertices}  gap {ctl.gap:g}  "
              f"first frame after {time.monotonic() - t0:.1f} s")
        it0, t1 = ctl.sim.state.iteration, time.monotonic()
        ws_frames = _count(lambda: asyncio.run(_count_frames(
            f"ws://127.0.0.1:{server.port}/ws?token={server.token}", args.seconds)))
        dt = time.monotonic() - t1
        its = (ctl.sim.state.iteration - it0) / dt
        print(f"websocket client: {ws_frames / args.seconds:.1f} frames/s   simulation: {its:.1f} iterations/s"
              f"   (phase {ctl.phase}, iteration {ctl.sim.state.iteration})")
        exe = os.environ.get("REPULSIONPAK_CHROMIUM") or shutil.which("chromium")
        if not args.no_browser and exe:
            from playwright.sync_api import sync_playwright

            with sync_playwright() as pw:
                browser = pw.chromium.launch(executable_path=exe, args=["--no-sandbox"])
                page = browser.new_page(viewport={"width": 1280, "height": 800})
                page.goto(server.url)
                page.wait_for_function("window.repulsionpak && window.repulsionpak.frames > 0", timeout=60_000)
                cdp = page.context.new_cdp_session(page)
                cdp.send("Performance.enable")
                m0 = _metrics(cdp)
                it0, f0, t1 = ctl.sim.state.iteration, page.evaluate("window.repulsionpak.frames"), time.monotonic()
                r0 = page.evaluate("window.repulsionpak.received")
                page.wait_for_timeout(args.seconds * 1000)
                f1, dt = page.evaluate("window.repulsionpak.frames"), time.monotonic() - t1
                r1 = page.evaluate("window.repulsionpak.received")
                draw_ms = page.evaluate("window.repulsionpak.drawMs / window.repulsionpak.frames")
                m1 = _metrics(cdp)
                its = (ctl.sim.state.iteration - it0) / dt
                n_groups = page.evaluate("document.querySelectorAll('#stage g.element').length")
                print(f"page (Chromium): {(f1 - f0) / dt:.1f} frames/s drawn"
                      + (f" of {(r1 - r0) / dt:.1f} received" if r1 is not None else "")
                      + f", {n_groups} g.element   "
                      f"simulation: {its:.1f} iterations/s   (phase {ctl.phase})")
                per = max(f1 - f0, 1)
                print("page main thread per drawn frame: " + "  ".join(
                    f"{k} {1000 * (m1[k] - m0[k]) / per:.1f} ms" for k in
                    ("ScriptDuration", "RecalcStyleDuration", "LayoutDuration", "TaskDuration"))
                    + (f"  (writing the paths {draw_ms:.1f} ms)" if draw_ms is not None else ""))
                browser.close()
    finally:
        session.cancel(wait=30)
        server.stop()
        session.close()


def _metrics(cdp) -> dict:
    """Chromium's cumulative main-thread times (seconds) of the page."""
    return {m["name"]: m["value"] for m in cdp.send("Performance.getMetrics")["metrics"]}


def _count(fn):
    out = []
    t = threading.Thread(target=lambda: out.append(fn()))
    t.start()
    t.join()
    return out[0]


if __name__ == "__main__":
    main()
