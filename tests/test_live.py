"""The live view (``repulsionpak pack --live``): server checks with an HTTP/WebSocket client,
then the page driven in Chromium with Playwright, then Ctrl-C and the written SVG.

One real CLI process serves a small scene (8 elements in the example circle) for the
whole module, started ``--paused`` so each step is deterministic. The browser is
Debian's ``chromium`` (Playwright cannot download its own here).
"""

from __future__ import annotations

import asyncio
import os
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

aiohttp = pytest.importorskip("aiohttp", reason="the live view needs aiohttp: pip install -e '.[test]'")

import repulsionpak  # noqa: E402
from repulsionpak.live.protocol import decode_frame, encode_frame, parse_command  # noqa: E402
from browser_support import chromium, new_page  # noqa: E402

PKG = Path(repulsionpak.__file__).parent
EX = PKG / "examples"
SVG_NS = "{http://www.w3.org/2000/svg}"
COUNT = 8


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "repulsionpak.cli", "pack", str(EX / "containers" / "circle.svg"),
            str(EX / "elements" / "apple.svg"), str(EX / "elements" / "fish.svg"),
            "--count", str(COUNT), "--gap", "12", "--seed", "1", *args]


def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(PKG.parent) + os.pathsep + env.get("PYTHONPATH", "")
    return env


class Live:
    def __init__(self, proc, url: str, out: Path):
        self.proc, self.url, self.out = proc, url, out
        self.port = int(url.split(":")[2].split("/")[0])
        self.token = url.split("token=")[1]
        self.base = f"http://127.0.0.1:{self.port}"


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    d = tmp_path_factory.mktemp("live")
    t0 = time.monotonic()
    proc = subprocess.Popen(_cli("-o", str(d / "out.svg"), "--report", str(d / "report.json"),
                                 "--live", "--no-browser", "--port", "0", "--paused", "-q"),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())
    url = proc.stdout.readline().strip()
    if not url.startswith("http://127.0.0.1:"):
        proc.kill()
        pytest.fail(f"no URL printed: {url!r} {proc.stderr.read()}")
    lv = Live(proc, url, d)
    lv.t0 = t0
    yield lv
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()


async def _first_messages(lv: Live, **kw) -> tuple[list[dict], dict]:
    """JSON messages up to and including the first binary frame (decoded)."""
    msgs = []
    async with aiohttp.ClientSession() as s:
        async with s.ws_connect(f"{lv.base}/ws?token={lv.token}", **kw) as ws:
            while True:
                m = await ws.receive(timeout=60)
                if m.type == aiohttp.WSMsgType.BINARY:
                    return msgs, decode_frame(m.data)
                msgs.append(m.json())


async def _ws_status(url: str, **kw) -> int:
    async with aiohttp.ClientSession() as s:
        try:
            async with s.ws_connect(url, **kw):
                return 101
        except aiohttp.WSServerHandshakeError as exc:
            return exc.status


async def _get(url: str, **kw) -> tuple[int, str]:
    async with aiohttp.ClientSession() as s:
        async with s.get(url, **kw) as r:
            return r.status, await r.text()


# -- protocol -----------------------------------------------------------------------


def test_frame_round_trip_and_command_validation():
    pts = np.array([[1.5, -2.25], [1000.125, 3.0], [0.0, 7.5]])
    data = encode_frame(3, 1234, 0.625, pts)
    assert len(data) == 20 + 8 * 3
    f = decode_frame(data)
    assert (f["layout"], f["iteration"]) == (3, 1234)
    assert f["area_fraction"] == pytest.approx(0.625)
    np.testing.assert_allclose(f["points"], pts, rtol=0, atol=1e-4)
    with pytest.raises(ValueError, match="magic"):
        decode_frame(b"XXXX" + data[4:])
    with pytest.raises(ValueError, match="announces 3 points"):
        decode_frame(data[:-8])
    assert parse_command({"cmd": "move", "index": 2, "dx": 1, "dy": -0.5}) == \
        {"cmd": "move", "index": 2, "dx": 1.0, "dy": -0.5}
    assert parse_command({"cmd": "add", "index": 0, "x": 3, "y": 4}) == {"cmd": "add", "index": 0, "x": 3.0, "y": 4.0}
    for bad in ({"cmd": "explode"}, {"cmd": "add", "index": 0, "x": 1}, {"cmd": "move", "index": -1, "dx": 0, "dy": 0},
                {"cmd": "move", "index": 0, "dx": float("nan"), "dy": 0}, {"cmd": "step", "n": 0}, [1]):
        with pytest.raises(ValueError):
            parse_command(bad)


def test_controller_moves_pins_removes_and_adds_between_iterations():
    """The controller alone, inside an in-process pack() (no server, no browser)."""
    import dataclasses

    from repulsionpak.io import load_container, load_elements
    from repulsionpak.live import LiveController
    from repulsionpak.pack import pack
    from repulsionpak.params import Params

    cont = load_container(EX / "containers" / "circle.svg")
    elems = load_elements([EX / "elements" / "apple.svg", EX / "elements" / "fish.svg"])
    p = Params(gap=12.0, seed=3)
    # the paper's growth rate: in 200 iterations the added copy grows ~1.2x, near its click point
    p = dataclasses.replace(p, placement=dataclasses.replace(p.placement, count=5),
                            sim=dataclasses.replace(p.sim, max_iterations=200, min_iterations=0, k_growth=0.01),
                            secondary=dataclasses.replace(p.secondary, auto=False))
    ctl = LiveController(cont, 12.0, p.render)
    sent = []
    ctl.publish = lambda kind, payload: sent.append((kind, payload))
    seen = {}

    def on_snapshot(snap):
        ctl.on_snapshot(snap)
        if snap.iteration == 25 and not snap.done:
            m = snap.sim.model
            seen["x0"] = snap.state.x[m.elem_vstart[0]:m.elem_vstart[1]].copy()
            ctl.submit({"cmd": "move", "index": 0, "dx": 10.0, "dy": -5.0})
            ctl.submit({"cmd": "pin", "index": 0, "pinned": True})
            ctl.submit({"cmd": "remove", "index": 1})
            ctl.submit({"cmd": "add", "index": 2, "x": 250.0, "y": 250.0})
            ctl.submit({"cmd": "add", "index": 2, "x": 5.0, "y": 5.0})  # outside: refused

    packing = pack(cont, elems, p, on_snapshot=on_snapshot, should_stop=ctl.should_stop)
    m, x = packing.model, packing.state.x
    assert m.n_elements == 6 and m.template_index[5] == m.template_index[2]
    # moved by (10, -5) container units, then never touched again
    want = seen["x0"] + np.array([10.0, -5.0]) / ctl.unit
    np.testing.assert_allclose(x[m.elem_vstart[0]:m.elem_vstart[1]], want, rtol=0, atol=1e-12)
    # removed: shrunk to 1% about its centre and left out of the art
    r1 = x[m.elem_vstart[1]:m.elem_vstart[2]]
    assert np.ptp(r1, axis=0).max() * ctl.unit < 2.0
    assert len(ctl.drop_removed(packing.placed)) == len(packing.placed) - 1
    # the copy grew from the click point and stayed inside the circle
    c = x[m.elem_vstart[5]:m.elem_vstart[6]] * ctl.unit
    assert np.hypot(*(c.mean(axis=0) - 250)) < 60 and np.hypot(c[:, 0] - 250, c[:, 1] - 250).max() < 230
    # the page's estimates from the last frame against the exact measures of the art the
    # renderer makes of the same state (before the final verification adjusts it)
    from repulsionpak.measure import evaluate
    from repulsionpak.sim.art import placed_art
    from repulsionpak.sim.model import SimFrame

    est = ctl.estimates()
    keep = [e for e in range(m.n_elements) if e != 1]
    art = placed_art(packing.templates, m, packing.state, SimFrame(ctl.unit), elements=keep)
    exact = evaluate(cont, art, 12.0, with_scp=False)
    print("estimate", est, "exact", exact["area_fraction"], exact["gap"]["median"])
    assert est["area_fraction"] == pytest.approx(exact["area_fraction"], rel=0.03)
    assert est["median_gap"] == pytest.approx(exact["gap"]["median"], rel=0.15)
    errors = [pl["message"] for kind, pl in sent if kind == "json" and pl.get("type") == "error"]
    assert errors == ["a copy must be placed inside the container"]
    layouts = [pl for kind, pl in sent if kind == "json" and pl.get("type") == "layout"]
    assert layouts[-1]["pinned"] == [0] and layouts[-1]["removed"] == [1] and len(layouts[-1]["counts"]) == 6


def test_a_dragged_element_knows_at_once_what_it_was_dropped_into():
    """A drag is no velocity-capped step: the refresh between full queries follows only
    small moves, so the move command queries the contacts anew. An element dropped onto
    another has its skin vertices inside the other's mesh flagged before the next step."""
    import dataclasses

    import shapely

    from repulsionpak.io import load_container, load_elements
    from repulsionpak.live import LiveController
    from repulsionpak.pack import pack
    from repulsionpak.params import Params

    cont = load_container(EX / "containers" / "circle.svg")
    elems = load_elements([EX / "elements" / "apple.svg", EX / "elements" / "fish.svg"])
    p = Params(gap=12.0, seed=3)
    p = dataclasses.replace(p, placement=dataclasses.replace(p.placement, count=5),
                            sim=dataclasses.replace(p.sim, max_iterations=80, min_iterations=0),
                            secondary=dataclasses.replace(p.secondary, auto=False))
    ctl = LiveController(cont, 12.0, p.render)
    ctl.publish = lambda kind, payload: None
    seen = {}

    def on_snapshot(snap):
        if snap.iteration == 50 and not snap.done:  # iteration 50: between two full queries
            m, st = snap.sim.model, snap.state
            skin = [st.x[m.elem_vstart[e]:m.elem_vstart[e] + m.elem_nskin[e]] for e in (0, 1)]
            dx, dy = (skin[1].mean(axis=0) - skin[0].mean(axis=0)) * ctl.unit
            ctl.on_snapshot(snap)
            ctl.submit({"cmd": "move", "index": 0, "dx": float(dx), "dy": float(dy)})
            ctl.should_stop()  # the runner's call between two iterations applies the command
            dropped = st.x[m.elem_vstart[0]:m.elem_vstart[0] + m.elem_nskin[0]]
            other = shapely.Polygon(skin[1])
            seen["truth"] = shapely.contains_xy(other, dropped[:, 0], dropped[:, 1])
            seen["flags"] = st.inside[m.elem_vstart[0]:m.elem_vstart[0] + m.elem_nskin[0]].copy()
        else:
            ctl.on_snapshot(snap)

    pack(cont, elems, p, on_snapshot=on_snapshot, should_stop=ctl.should_stop)
    truth, flags = seen["truth"], seen["flags"]
    assert truth.sum() >= 10  # the drop really overlaps
    # flagged where the skin polygon says so (a vertex on the other's skin may go either way)
    assert (truth == flags).mean() >= 0.95 and flags[truth].mean() >= 0.95


def test_added_copy_keeps_its_sources_designer_controls():
    """A copy of a stiff, upright element (issue 12's controls) is stiff and upright too."""
    import dataclasses

    from repulsionpak.types import ElementControls
    from repulsionpak.io import load_container, load_elements
    from repulsionpak.live import LiveController
    from repulsionpak.pack import pack
    from repulsionpak.params import Params

    cont = load_container(EX / "containers" / "circle.svg")
    ctrl = ElementControls(rotation="fixed", stiffness=3.0)
    elems = [dataclasses.replace(e, controls=ctrl)
             for e in load_elements([EX / "elements" / "apple.svg", EX / "elements" / "fish.svg"])]
    p = Params(gap=12.0, seed=3)
    p = dataclasses.replace(p, placement=dataclasses.replace(p.placement, count=4),
                            sim=dataclasses.replace(p.sim, max_iterations=150, min_iterations=0),
                            secondary=dataclasses.replace(p.secondary, auto=False))
    ctl = LiveController(cont, 12.0, p.render)

    def on_snapshot(snap):
        ctl.on_snapshot(snap)
        if snap.iteration == 25 and not snap.done:
            ctl.submit({"cmd": "add", "index": 1, "x": 250.0, "y": 250.0})

    packing = pack(cont, elems, p, on_snapshot=on_snapshot, should_stop=ctl.should_stop)
    m = packing.model
    assert m.n_elements == 5 and m.controls[4] == m.controls[1] == ctrl
    assert m.stiffness[4] == m.stiffness[1] == 3.0 and m.bend_limit[4] == m.bend_limit[1]
    assert m.rot_on[4] and m.rot_lo[4] <= 0 <= m.rot_hi[4]
    assert len(m.rot_on) == len(m.rigid) == len(m.pinned) == 5


# -- server ---------------------------------------------------------------------------


def test_token_host_and_origin_checks(live):
    ws = f"ws://127.0.0.1:{live.port}/ws"
    assert asyncio.run(_ws_status(f"{ws}?token=wrong")) == 403
    assert asyncio.run(_ws_status(ws)) == 403
    good = f"{ws}?token={live.token}"
    assert asyncio.run(_ws_status(good, origin="http://evil.example")) == 403
    assert asyncio.run(_ws_status(good, origin=f"http://127.0.0.1:{live.port}")) == 101
    assert asyncio.run(_get(f"{live.base}/?token=nope"))[0] == 403
    assert asyncio.run(_get(f"{live.base}/packing.svg"))[0] == 403
    # DNS rebinding: a foreign Host name is refused even with the token
    assert asyncio.run(_get(live.url, headers={"Host": f"evil.example:{live.port}"}))[0] == 403
    status, page = asyncio.run(_get(live.url))
    assert status == 200 and 'id="stage"' in page


def test_binary_frame_holds_every_skin_inside_the_container(live):
    msgs, frame = asyncio.run(_first_messages(live))
    types = [m["type"] for m in msgs]
    assert types[:3] == ["scene", "layout", "status"]
    # (a page that connects while the scene is prepared gets the layout when the run starts)
    layout = [m for m in msgs if m["type"] == "layout"][-1]
    status = [m for m in msgs if m["type"] == "status"][-1]
    assert status["paused"] is True and status["phase"] == "primary"
    assert len(layout["counts"]) == COUNT and layout["kinds"] == ["primary"] * COUNT
    assert frame["layout"] == layout["id"]
    assert frame["iteration"] == 25  # --paused stops at the first snapshot
    pts = frame["points"]
    assert len(pts) == sum(layout["counts"])
    # the example circle: centre (250, 250), radius 230; the boundary force is soft while
    # the meshes grow, so a skin may poke out by less than the gap (12)
    assert np.isfinite(pts).all()
    r = np.hypot(pts[:, 0] - 250, pts[:, 1] - 250)
    assert r.max() < 230 + 12
    ends = np.cumsum(layout["counts"])
    centres = np.array([pts[a:b].mean(axis=0) for a, b in zip(ends - layout["counts"], ends)])
    assert (np.hypot(centres[:, 0] - 250, centres[:, 1] - 250) < 230).all()


def test_packing_svg_while_running_is_the_output_format(live):
    status, text = asyncio.run(_get(f"{live.base}/packing.svg?token={live.token}"))
    assert status == 200
    root = ET.fromstring(text.encode())
    assert root.get("data-gap") == "12.0" and root.get("data-partial") == "true"
    assert root.find(f"{SVG_NS}g[@id='container']") is not None
    els = root.find(f"{SVG_NS}g[@id='elements']").findall(f"{SVG_NS}g")
    assert len(els) == COUNT and all("element" in e.get("class") for e in els)
    assert {e.get("data-source") for e in els} == {"apple.svg", "fish.svg"}


def test_busy_port_is_a_clear_error(live, tmp_path):
    r = subprocess.run(_cli("-o", str(tmp_path / "x.svg"), "--live", "--no-browser",
                            "--port", str(live.port), "-q"),
                       capture_output=True, text=True, env=_env(), timeout=60)
    assert r.returncode == 2, r.stderr
    assert f"127.0.0.1:{live.port}" in r.stderr and "--port" in r.stderr
    assert not (tmp_path / "x.svg").exists()


# -- the page in Chromium ---------------------------------------------------------------


def _bbox(page, i: int) -> list[float]:
    return page.evaluate(f"""() => {{ const b = document.querySelector('#stage .element[data-index="{i}"] path').getBBox();
                               return [b.x, b.y, b.width, b.height]; }}""")


def _d(page, i: int) -> str:
    return page.get_attribute(f'#stage .element[data-index="{i}"] path', "d")


def test_browser_pause_step_drag_pin_remove_add_download(live, tmp_path):
    exe = chromium()
    if exe is None:
        pytest.skip("no Chromium found: install it with `apt-get install chromium` "
                    "(or set REPULSIONPAK_CHROMIUM)")
    sync_api = pytest.importorskip("playwright.sync_api", reason="pip install playwright")
    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        try:
            _drive(browser, live, tmp_path)
        finally:
            browser.close()
    # Ctrl-C writes -o and --report and exits cleanly
    time.sleep(1.0)
    t_int = time.monotonic()
    live.proc.send_signal(signal.SIGINT)
    assert live.proc.wait(timeout=60) == 0, live.proc.stderr.read()
    out = (live.out / "out.svg").read_bytes()
    assert out == (tmp_path / "download.svg").read_bytes()
    import json

    rep = json.loads((live.out / "report.json").read_text())
    assert rep["n_primary"] == COUNT  # one removed, one added in the page
    assert rep["invariants"]["ok"]
    # the time the result was served (from "Converged" to Ctrl-C) is not in the run's times
    assert rep["seconds"]["total"] < (t_int - live.t0) - (t_int - _drive.t_done) + 0.5
    # the pinned element's art lies where it was pinned (inside its pinned skin)
    from repulsionpak.io import read_packing_svg

    _, placed, _ = read_packing_svg(live.out / "out.svg")
    x, y, w, h = _drive.pinned_box
    centres = [np.concatenate([s for p in a.paths for s in p.subpaths]).mean(axis=0)
               for a in placed if a.kind == "primary"]
    inside = [c for c in centres if x < c[0] < x + w and y < c[1] < y + h]
    assert len(inside) == 1, (centres, _drive.pinned_box)


def _drive(browser, live: Live, tmp_path: Path) -> None:
    page = new_page(browser, viewport={"width": 900, "height": 800}, accept_downloads=True)
    page.goto(live.url)
    page.wait_for_function(f"document.querySelectorAll('#stage .element').length === {COUNT}")
    page.wait_for_function("document.querySelector('#iteration').textContent === '25'")
    assert page.get_attribute("#pause", "data-paused") == "true"
    assert page.inner_text("#pause") == "Resume"
    # single step
    page.click("#step")
    page.wait_for_function("document.querySelector('#iteration').textContent === '26'")
    time.sleep(0.3)
    assert page.inner_text("#iteration") == "26"  # still paused after the step

    # drag element 0 by 60 px to the right while paused
    before = _bbox(page, 0)
    scale = page.evaluate("document.querySelector('#stage').getScreenCTM().a")  # px per unit
    box = page.locator('#stage .element[data-index="0"] path').bounding_box()
    cx, cy = round(box["x"] + box["width"] / 2), round(box["y"] + box["height"] / 2)
    page.mouse.move(cx, cy)
    page.mouse.down()
    for k in range(1, 7):
        page.mouse.move(cx + 10 * k, cy)
        page.wait_for_timeout(30)
    page.mouse.up()
    want = before[0] + 60 / scale
    for _ in range(100):  # the frame with the moved element arrives
        after = _bbox(page, 0)
        if abs(after[0] - want) < 1:
            break
        page.wait_for_timeout(50)
    assert after[0] - before[0] == pytest.approx(60 / scale, abs=1)  # 60 px, within 1.5 px
    # the width unchanged: the page writes coordinates to 0.01 (toFixed(2)), so a moved
    # outline's two extreme coordinates may round apart by one last digit
    assert after[1] == pytest.approx(before[1], abs=0.5) and after[2] == pytest.approx(before[2], abs=0.011)
    assert page.inner_text("#iteration") == "26"  # the drag did not advance the run

    # pin the dragged (selected) element; remove element 1
    assert "selected" in page.get_attribute('#stage .element[data-index="0"]', "class")
    page.click("#pin")
    page.wait_for_selector('#stage .element[data-index="0"][data-pinned="true"]', state="attached")
    assert page.inner_text("#pin") == "Unpin"
    page.locator('#stage .element[data-index="1"] path').click()
    page.click("#remove")
    page.wait_for_selector('#stage .element.removed[data-index="1"]', state="attached")

    # add a copy of element 2 in the emptiest spot of the circle (farthest from every skin's box)
    spot = page.evaluate("""() => {
        const boxes = [...document.querySelectorAll('#stage .element:not(.removed) path')].map((p) => p.getBBox());
        let best = null, far = -1;
        for (let x = 40; x <= 460; x += 5) for (let y = 40; y <= 460; y += 5) {
          if (Math.hypot(x - 250, y - 250) > 200) continue;
          let d = 1e9;
          for (const b of boxes) d = Math.min(d, Math.hypot(Math.max(b.x - x, 0, x - b.x - b.width),
                                                            Math.max(b.y - y, 0, y - b.y - b.height)));
          if (d > far) { far = d; best = [x, y]; }
        }
        const m = document.querySelector('#stage').getScreenCTM();
        return [best[0], best[1], m.a * best[0] + m.e, m.d * best[1] + m.f];
    }""")
    page.locator('#stage .element[data-index="2"] path').click()
    page.click("#add-copy")
    page.mouse.click(spot[2], spot[3])
    page.wait_for_function(f"document.querySelectorAll('#stage .element').length === {COUNT + 1}")
    lay = page.evaluate("window.repulsionpak.layout")
    assert lay["template"][COUNT] == lay["template"][2] and lay["kinds"][COUNT] == "primary"
    new_box = _bbox(page, COUNT)  # the copy starts at its placement size, centred on the click
    assert new_box[0] + new_box[2] / 2 == pytest.approx(spot[0], abs=0.2 * new_box[2])
    assert new_box[1] + new_box[3] / 2 == pytest.approx(spot[1], abs=0.2 * new_box[3])
    assert page.inner_text("#iteration") == "26"

    # a second tab sees the same run
    other = new_page(browser)
    other.goto(live.url)
    other.wait_for_function("document.querySelector('#iteration').textContent === '26'")
    assert other.locator("#stage .element.pinned").count() == 1
    assert other.locator("#stage .element.removed").count() == 1

    # resume: the run goes on, the pinned element neither moves nor grows
    pinned_d = _d(page, 0)
    _drive.pinned_box = _bbox(page, 0)
    page.click("#pause")
    page.wait_for_function("Number(document.querySelector('#iteration').textContent) > 300", timeout=30000)
    assert _d(page, 0) == pinned_d
    other.close()  # closing a tab does not disturb the run
    page.wait_for_function("document.querySelector('#message').textContent.includes('Ctrl-C')", timeout=60000)
    _drive.t_done = time.monotonic()
    msg = page.inner_text("#message")
    assert msg.startswith("Converged"), msg
    af = float(page.inner_text("#area-fraction"))
    assert 0.3 < af < 0.9
    assert page.is_disabled("#pause")

    with page.expect_download() as dl:
        page.click("#download-svg")
    dl.value.save_as(tmp_path / "download.svg")
    root = ET.parse(tmp_path / "download.svg").getroot()
    prim = [g for g in root.iter(f"{SVG_NS}g") if "primary" in (g.get("class") or "").split()]
    assert len(prim) == COUNT  # one removed, one added
    with page.expect_download() as dl:
        page.click("#download-png")
    png = Path(dl.value.path()).read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    w, h = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
    assert w == h and 1000 <= w <= 2000  # the square container at up to 2000 px
