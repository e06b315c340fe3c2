"""The packing studio (``repulsionpak studio``): the brush region and the edit history, the
settings' checks, the session's run and exports, the server's security with an HTTP and
WebSocket client, and the page driven in Chromium with Playwright (Debian's ``chromium``;
skipped cleanly without it or without Playwright).
"""

from __future__ import annotations

import asyncio
import json
import math
import os
import time
from pathlib import Path

import numpy as np
import pytest
import shapely

aiohttp = pytest.importorskip("aiohttp", reason="the studio needs aiohttp: pip install -e '.[test]'")

import repulsionpak  # noqa: E402
from repulsionpak.errors import ParameterError  # noqa: E402
from repulsionpak.studio import Session  # noqa: E402
from repulsionpak.studio.document import Document, History  # noqa: E402
from repulsionpak.studio.region import Stroke, painted_region, region_svg  # noqa: E402
from repulsionpak.studio.uploads import MAX_FILE_BYTES  # noqa: E402
from repulsionpak.studio.settings import DEFAULTS, coerce, command_line, run_settings  # noqa: E402
from browser_support import (  # noqa: E402
    finish, new_page, page_state, paused_apples, playwright_chromium, unpacked_project, wait)
from browser_support import server, session  # noqa: E402,F401  (fixtures)

EX = Path(repulsionpak.__file__).parent / "examples"


# -- the brush region --------------------------------------------------------------------


def test_stroke_area_is_the_swept_round_brush():
    r = 10.0
    dab = Stroke("paint", ((0.0, 0.0),), r).shape()
    assert dab.area == pytest.approx(math.pi * r * r, rel=0.01)
    line = Stroke("paint", ((0.0, 0.0), (100.0, 0.0), (100.0, 0.0)), r).shape()  # a repeated point
    assert line.area == pytest.approx(2 * r * 100 + math.pi * r * r, rel=0.01)
    assert line.bounds == pytest.approx((-r, -r, 100 + r, r), abs=1e-9)


def test_region_is_the_union_of_paint_minus_erase_in_order():
    base = shapely.box(0, 0, 100, 100)
    paint = Stroke("paint", ((150.0, 50.0), (250.0, 50.0)), 20.0)
    erase = Stroke("erase", ((50.0, 50.0),), 10.0)
    region = painted_region(base, [paint, erase])
    expect = shapely.difference(shapely.union(base, paint.shape()), erase.shape())
    assert region.symmetric_difference(expect).area < 1e-6 * expect.area
    assert isinstance(region, shapely.MultiPolygon) and len(region.geoms) == 2  # two islands
    assert len(region.geoms[0].interiors) + len(region.geoms[1].interiors) == 1  # the erased hole
    # painting over an erased spot fills it again: the order counts
    again = painted_region(base, [erase, Stroke("paint", ((50.0, 50.0),), 12.0)])
    assert again.area == pytest.approx(100 * 100, rel=1e-9)
    # erasing everything leaves an empty region; crumbs under min_area are dropped
    assert painted_region(base, [Stroke("erase", ((50.0, 50.0),), 80.0)]).is_empty
    crumbs = painted_region(None, [Stroke("paint", ((0.0, 0.0),), 0.1)], min_area=1.0)
    assert crumbs.is_empty


def test_region_svg_reads_back_as_the_same_container(tmp_path):
    region = painted_region(None, [Stroke("paint", ((100.0, 100.0), (400.0, 300.0)), 60.0),
                                   Stroke("erase", ((250.0, 200.0),), 20.0)])
    f = tmp_path / "container.svg"
    f.write_text(region_svg(region, (0, 0, 500, 500)))
    c = repulsionpak.load_container(f)
    assert c.region.symmetric_difference(region).area < 1e-4 * region.area
    assert len(c.region.interiors) == 1
    with pytest.raises(ParameterError, match="container is empty"):
        region_svg(shapely.Polygon(), (0, 0, 1, 1))


@pytest.mark.parametrize("msg, words", [
    ({"mode": "smear", "points": [[0, 0]], "radius": 1}, "stroke mode"),
    ({"mode": "paint", "points": [[0, 0]], "radius": -1}, "brush radius"),
    ({"mode": "paint", "points": [], "radius": 1}, "at least one point"),
    ({"mode": "paint", "points": [[0, float("nan")]], "radius": 1}, "finite numbers"),
    ({"mode": "paint", "points": [[0, 0, 0]], "radius": 1}, "pairs"),
])
def test_bad_strokes_are_refused_with_a_message(msg, words):
    with pytest.raises(ParameterError, match=words):
        Stroke.parse(msg)


# -- history -------------------------------------------------------------------------------


def test_history_undo_redo_and_a_new_edit_drops_the_redo_side():
    h = History()
    d0 = h.doc
    d1 = d0.with_settings(gap=3.0)
    d2 = d1.with_settings(count=5)
    h.push("gap", d1)
    h.push("count", d2)
    assert h.undo().label == "count" and h.doc is d1
    assert h.undo().label == "gap" and h.doc is d0
    assert h.undo() is None and h.doc is d0
    assert h.redo().after is d1 and h.doc is d1
    d3 = d1.with_settings(seed=7)
    h.push("seed", d3)
    assert h.redo() is None and h.doc is d3  # "count" is gone
    assert h.state() == {"can_undo": True, "can_redo": False, "undo_label": "seed", "redo_label": None}


# -- settings ------------------------------------------------------------------------------


def test_settings_defaults_and_messages_are_the_libraries():
    p, controls = run_settings(DEFAULTS)
    assert p == repulsionpak.Params().validate() and controls is None
    for name, value, words in [("gap", "-2", "--gap: gap must be a positive number"),
                               ("count", "0", "--count: placement.count must be >= 1"),
                               ("stiffness", "0", "--stiffness"),
                               ("rotation", "limited:x", "--rotation limited: 'x' is not a number")]:
        with pytest.raises(ParameterError, match=words):
            run_settings(dict(DEFAULTS, **{name: coerce(name, value)}))
    with pytest.raises(ParameterError, match="--count must be a whole number"):
        coerce("count", "2.5")
    p, controls = run_settings(dict(DEFAULTS, gap=4.0, count=30, seed=9, rotation="limited:15",
                                    rigid=True, pocket_fill=False))
    assert (p.gap, p.seed, p.placement.count, p.secondary.auto) == (4.0, 9, 30, False)
    assert (controls.rotation, controls.max_rotation, controls.rigid) == ("limited", 15.0, True)
    cmd = command_line(dict(DEFAULTS, gap=4.0, seed=9, rotation="fixed:90", stiffness=2.5, pocket_fill=False),
                       "my heart.svg", ["elements/a.svg"])
    assert cmd == ("repulsionpak pack 'my heart.svg' elements/a.svg -o packing.svg --gap 4 --seed 9 "
                   "--rotation fixed:90 --stiffness 2.5 --no-pocket-fill")


# -- the session ---------------------------------------------------------------------------


def test_session_paints_undoes_and_redoes_the_region(session):
    assert session.state()["region_area"] == 0.0
    stroke = {"mode": "paint", "points": [[200, 500], [800, 500]], "radius": 150}
    st = session.stroke(stroke)
    want = 2 * 150 * 600 + math.pi * 150 ** 2
    assert st["region_area"] == pytest.approx(want, rel=0.01) and st["painted"]
    st = session.stroke({"mode": "erase", "points": [[500, 500]], "radius": 50})
    assert st["region_area"] == pytest.approx(want - math.pi * 50 ** 2, rel=0.01)
    # the painted region is the run's container file, read by the library's reader
    f = session.container_file(session.doc)
    assert f.name == "container.svg" and f.path.is_relative_to(session.dir)
    assert repulsionpak.load_container(f.path).area == pytest.approx(st["region_area"], rel=1e-3)
    assert session.undo()["region_area"] == pytest.approx(want, rel=0.01)
    assert session.undo()["region_area"] == 0.0
    assert session.redo()["region_area"] == pytest.approx(want, rel=0.01)
    assert session.state()["history"]["can_redo"]


def test_session_inputs_are_read_by_the_hardened_reader(session):
    with pytest.raises(repulsionpak.InputError) as exc:
        session.add_elements([("broken.svg", b"<svg xmlns='http://www.w3.org/2000/svg'><path d='M 0 0'/>")])
    assert "broken.svg" in str(exc.value) and str(session.dir) not in str(exc.value)
    with pytest.raises(ParameterError, match="expected .svg or .path"):
        session.add_elements([("notes.txt", b"hello")])
    with pytest.raises(ParameterError, match="accepts files of up to 5 MB"):
        session.open_container("big.svg", b" " * (MAX_FILE_BYTES + 1))
    # a name is only a name: nothing is written outside the session's folder
    st = session.add_elements([("../../evil/apple.svg", (EX / "elements" / "apple.svg").read_bytes())])
    assert st["elements"] == ["apple.svg"]
    assert session.doc.elements[0].path.resolve().is_relative_to(session.dir.resolve())
    assert session.doc == Document(elements=session.doc.elements)  # the failed ones left no trace


def test_export_equals_what_pack_writes_and_the_project_reopens(session, tmp_path):
    session.use_examples("circle", ["apple", "fish"])
    session.add_elements([("star.svg", (EX / "secondary" / "star.svg").read_bytes())], secondary=True)
    for k, v in (("count", "8"), ("gap", "12"), ("seed", "1")):
        session.set_setting(k, v)
    session.start()
    finish(session)
    svg = session.export("svg")
    assert 'class="element secondary" data-source="star.svg"' in svg.decode()
    # the project: the files, the settings and the command that makes the same bytes
    proj = tmp_path / "proj"
    unpacked_project(session, proj)
    cmd = session.command()
    assert cmd == ("repulsionpak pack circle.svg elements/apple.svg elements/fish.svg -o packing.svg "
                   "--secondary secondary/star.svg --gap 12 --seed 1 --count 8")
    from typer.testing import CliRunner

    from repulsionpak.cli import app

    cwd = os.getcwd()
    try:
        os.chdir(proj)
        res = CliRunner().invoke(app, cmd.split()[1:] + ["-q"])
    finally:
        os.chdir(cwd)
    assert res.exit_code == 0, res.output
    assert (proj / "packing.svg").read_bytes() == svg
    assert session.export("png")[:8] == b"\x89PNG\r\n\x1a\n"
    # reopened in a new session: the same document
    other = Session()
    try:
        st = other.open_project(session.project_zip())
        assert st["container"] == "circle.svg" and st["elements"] == ["apple.svg", "fish.svg"]
        assert st["secondary"] == ["star.svg"]
        assert st["settings"] == session.doc.settings_dict and other.command() == cmd
    finally:
        other.close()


def test_weights_go_through_an_element_manifest(session, tmp_path):
    """A weight other than 1 makes the run (and the command line) read the elements through
    a manifest: weight 0 leaves an element out of the free copies."""
    session.use_examples("circle", ["apple", "fish"])
    with pytest.raises(ParameterError, match="weight must be >= 0"):
        session.set_weight(1, "-1")
    session.set_weight(1, "0")
    for k, v in (("count", "6"), ("gap", "12"), ("seed", "2"), ("pocket_fill", False)):
        session.set_setting(k, v)
    assert session.command() == ("repulsionpak pack circle.svg elements.toml -o packing.svg --gap 12 --seed 2 "
                                 "--count 6 --no-pocket-fill")
    session.start()
    finish(session)
    svg = session.export("svg")
    text = svg.decode()
    assert text.count('data-source="apple.svg"') == 6 and 'data-source="fish.svg"' not in text
    proj = tmp_path / "proj"
    unpacked_project(session, proj)
    assert 'file = "elements/fish.svg"\nweight = 0' in (proj / "elements.toml").read_text()
    from typer.testing import CliRunner

    from repulsionpak.cli import app

    cwd = os.getcwd()
    try:
        os.chdir(proj)
        res = CliRunner().invoke(app, session.command().split()[1:] + ["-q"])
    finally:
        os.chdir(cwd)
    assert res.exit_code == 0, res.output
    assert (proj / "packing.svg").read_bytes() == svg
    other = Session()
    try:
        assert other.open_project(session.project_zip())["weights"] == [1.0, 0.0]
    finally:
        other.close()


def test_painting_while_running_changes_the_simulations_container(session):
    """A stroke beside the circle reaches the running simulation: its container field,
    area and the run's Container change, and elements flow into the new room."""
    session.use_examples("circle", ["apple", "fish"])
    for k, v in (("count", "14"), ("gap", "12"), ("seed", "3"), ("pocket_fill", False)):
        session.set_setting(k, v)
    session.start()
    ctl = session.controller
    wait(lambda: ctl.sim is not None and ctl.sim.state.iteration > 150)
    ctl.submit({"cmd": "pause"})
    old_area = ctl.sim.model.container_area
    circle = ctl.container.region
    # a wide band across the right side of the circle and beyond it
    st = session.stroke({"mode": "paint", "points": [[420, 250], [700, 250]], "radius": 120})
    wait(lambda: ctl.sim.model.container_area > 1.2 * old_area, timeout=30)
    assert ctl.container.region.area == pytest.approx(st["region_area"], rel=1e-3)
    f = ctl.sim.model.field
    x, y = np.array([650.0, 250.0]) / ctl.unit  # inside the new room, outside the circle
    i, j = int(round((x - f.ox) / f.h)), int(round((y - f.oy) / f.h))
    assert f.values[j, i] < 0  # inside, for the simulation
    ctl.submit({"cmd": "resume"})
    new_room = shapely.difference(ctl.container.region, circle)

    def entered():
        pts = ctl.last_points
        return pts is not None and int(shapely.contains_xy(new_room, pts[:, 0], pts[:, 1]).sum()) > 20

    wait(entered, timeout=120)
    session.cancel(wait=60)


def test_pins_drags_and_removals_of_a_running_simulation_are_undone(session):
    ctl = paused_apples(session)
    m, st = ctl.sim.model, ctl.sim.state
    a, b = int(m.elem_vstart[2]), int(m.elem_vstart[3])
    x0 = st.x[a:b].copy()
    ctl.submit({"cmd": "move", "index": 2, "dx": 30.0, "dy": -10.0})  # the page's drag
    session.moved(2, 30.0, -10.0)
    wait(lambda: ctl.commands.empty() and abs((st.x[a:b] - x0)[:, 0].mean() * ctl.unit - 30.0) < 1e-6)
    session.pin(2, True)
    wait(lambda: 2 in ctl.pinned)
    assert session.state()["history"]["undo_label"] == "pin element 2"
    session.undo()
    wait(lambda: 2 not in ctl.pinned)
    session.undo()
    wait(lambda: np.abs(st.x[a:b] - x0).max() < 1e-9)  # back where it was (paused: exactly)
    session.redo()
    wait(lambda: abs((st.x[a:b] - x0)[:, 1].mean() * ctl.unit + 10.0) < 1e-6)
    session.redo()
    wait(lambda: 2 in ctl.pinned)
    # a removed element comes back where it was, moving again
    c, d = int(m.elem_vstart[4]), int(m.elem_vstart[5])
    y0 = st.x[c:d].copy()
    session.remove(4)
    wait(lambda: 4 in ctl.removed and np.ptp(st.x[c:d], axis=0).max() < 0.05 * np.ptp(y0, axis=0).max())
    session.undo()
    wait(lambda: 4 not in ctl.removed and np.abs(st.x[c:d] - y0).max() < 1e-9)
    assert ctl.sim.state.moving[4] and 4 not in ctl.layout_message()["removed"]
    session.redo()
    wait(lambda: 4 in ctl.removed)
    session.cancel(wait=60)


def test_opening_another_container_ends_the_run(session):
    session.use_examples("circle", ["apple"])
    for k, v in (("count", "6"), ("gap", "12"), ("seed", "5")):
        session.set_setting(k, v)
    session.start(paused=True)
    ctl = session.controller
    wait(lambda: ctl.sim is not None and ctl.paused)
    layout = ctl.layout_id
    st = session.use_examples("heart")
    assert not st["running"] and ctl.sim is None and ctl.layout_id > layout
    assert ctl.scene()["rings"] and st["container"] == "heart.svg"
    assert ctl.view_box[2] > 400  # the heart's canvas


def test_restart_with_a_new_seed_ends_a_paused_run_at_once(session):
    session.use_examples("circle", ["apple", "fish"])
    for k, v in (("count", "6"), ("gap", "12"), ("seed", "5")):
        session.set_setting(k, v)
    session.start(paused=True)
    ctl = session.controller
    wait(lambda: ctl.sim is not None and ctl.paused)
    old_sim = ctl.sim
    t0 = time.monotonic()
    st = session.start(new_seed=True)
    assert time.monotonic() - t0 < 10.0  # not held up by the paused run
    seed = st["settings"]["seed"]
    assert seed != 5 and str(seed) in session.command()
    finish(session)
    assert ctl.sim is not old_sim and ctl.status()["done"]
    svg = session.export("svg").decode()
    assert f'data-seed="{seed}"' in svg


# -- the server ------------------------------------------------------------------------------


async def _status(method: str, url: str, **kw) -> tuple[int, str]:
    async with aiohttp.ClientSession() as c:
        async with c.request(method, url, **kw) as r:
            return r.status, await r.text()


async def _ws_status(url: str, **kw) -> int:
    async with aiohttp.ClientSession() as c:
        try:
            async with c.ws_connect(url, **kw):
                return 101
        except aiohttp.WSServerHandshakeError as exc:
            return exc.status


def _run(coro):
    return asyncio.run(coro)


def test_server_answers_only_on_loopback_with_the_token(server):
    base = f"http://127.0.0.1:{server.port}"
    assert server.url == f"{base}/?token={server.token}"
    sock = next(iter(server._runner.sites))._server.sockets[0]  # noqa: SLF001
    assert sock.getsockname()[0] == "127.0.0.1"
    t = server.token
    for path in ("/", "/state", "/examples", "/packing.svg", "/export.svg", "/export.png", "/project.zip"):
        assert _run(_status("GET", base + path))[0] == 403, path
        assert _run(_status("GET", f"{base}{path}?token=wrong"))[0] == 403, path
    for path in ("/edit", "/run", "/open-container", "/open-elements", "/open-secondary", "/open-project"):
        assert _run(_status("POST", base + path, json={"op": "undo"}))[0] == 403, path
    assert _run(_status("GET", f"{base}/state?token={t}"))[0] == 200
    # DNS rebinding: a foreign Host is refused even with the token
    assert _run(_status("GET", f"{base}/state?token={t}", headers={"Host": "evil.example:80"}))[0] == 403
    # the WebSocket: token and Origin
    assert _run(_ws_status(f"{base}/ws")) == 403
    assert _run(_ws_status(f"{base}/ws?token={t}", origin="http://evil.example")) == 403
    assert _run(_ws_status(f"{base}/ws?token={t}", origin=base)) == 101
    # a change posted by a page of another origin is refused, the token notwithstanding
    code, _ = _run(_status("POST", f"{base}/edit?token={t}", json={"op": "undo"},
                           headers={"Origin": "http://evil.example"}))
    assert code == 403
    assert _run(_status("POST", f"{base}/edit?token={t}", json={"op": "undo"}, headers={"Origin": base}))[0] == 200


def test_server_upload_limits_and_messages(server):
    base = f"http://127.0.0.1:{server.port}"
    t = server.token

    def form(name: str, data: bytes):
        fd = aiohttp.FormData()
        fd.add_field("file", data, filename=name, content_type="image/svg+xml")
        return fd

    code, text = _run(_status("POST", f"{base}/open-elements?token={t}",
                              data=form("huge.svg", b"<svg>" + b" " * (MAX_FILE_BYTES + 10))))
    assert code == 413 and "huge.svg: the file is larger than 5 MB" in json.loads(text)["error"]
    code, text = _run(_status("POST", f"{base}/open-container?token={t}", data=form("c.svg", b"<svg")))
    assert code == 400 and json.loads(text)["error"].startswith("c.svg")
    code, text = _run(_status("POST", f"{base}/edit?token={t}", json={"op": "setting", "name": "gap", "value": "-1"}))
    assert code == 400 and json.loads(text)["error"] == "--gap: gap must be a positive number, got -1.0"
    code, text = _run(_status("POST", f"{base}/open-elements?token={t}",
                              data=form("apple.svg", (EX / "elements" / "apple.svg").read_bytes())))
    assert code == 200 and json.loads(text)["elements"] == ["apple.svg"]
    code, text = _run(_status("GET", f"{base}/export.svg?token={t}"))
    assert code == 400 and "start a run first" in json.loads(text)["error"]


# -- the page in a real browser ------------------------------------------------------------------


def test_page_paint_fill_setting_pin_export(server, tmp_path):
    sync_api, exe = playwright_chromium()
    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        try:
            _drive(browser, server, tmp_path)
        finally:
            browser.close()


def _drive(browser, server, tmp_path):
    page = new_page(browser, viewport={"width": 1300, "height": 850}, accept_downloads=True)
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(server.url)
    page.wait_for_function("window.repulsionpakStudio.state !== null")
    # elements through the file input
    page.set_input_files("#open-elements", [str(EX / "elements" / "apple.svg"), str(EX / "elements" / "fish.svg")])
    page.wait_for_function("window.repulsionpakStudio.state.elements.length === 2")
    # a setting refused with the CLI's message, then good ones
    page.fill("#gap", "-3")
    page.dispatch_event("#gap", "change")
    page.wait_for_function("document.querySelector('#setting-error').textContent.includes('--gap')")
    assert "gap must be a positive number" in page.text_content("#setting-error")
    for sel, value in (("#gap", "14"), ("#count", "10"), ("#seed", "2")):
        page.fill(sel, value)
        page.dispatch_event(sel, "change")
    page.wait_for_function("window.repulsionpakStudio.state.settings.seed === 2 && "
                           "window.repulsionpakStudio.state.settings.gap === 14")
    assert page.text_content("#setting-error") == ""
    # paint the container on the blank canvas with the mouse: two wide strokes
    page.click("#brush")
    page.fill("#brush-size", "150")
    page.dispatch_event("#brush-size", "input")
    box = page.locator("#stage").bounding_box()
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    for dy in (-60, 60):
        page.mouse.move(cx - 160, cy + dy)
        page.mouse.down()
        for k in range(1, 17):
            page.mouse.move(cx - 160 + 20 * k, cy + dy)
        page.mouse.up()
    page.wait_for_function("window.repulsionpakStudio.state.history.undo_label === 'paint' && "
                           "window.repulsionpakStudio.state.region.length > 0 && "
                           "window.repulsionpakStudio.busy === 0")
    st = page_state(page)
    region = shapely.Polygon(st["region"][0])
    assert len(st["region"]) == 1 and region.area > 0  # the two strokes overlap: one blob
    assert "container.svg" in page.text_content("#command") and "--gap 14" in page.text_content("#command")
    page.click("#brush")  # brush off
    # run: the elements fill the painted region
    page.click("#start")
    page.wait_for_function("document.querySelectorAll('#stage g.element').length >= 10", timeout=120_000)
    # the first frame (iteration 0) may be drawn before the next one's number arrives
    page.wait_for_function("Number(document.querySelector('#iteration').textContent) > 0", timeout=60_000)
    # pin an element while it runs
    g = page.locator("#stage g.element").first
    idx = g.get_attribute("data-index")
    page.evaluate("""(i) => { const g = document.querySelector(`#stage g.element[data-index="${i}"]`);
        const r = g.getBoundingClientRect();
        g.firstChild.dispatchEvent(new PointerEvent('pointerdown', {bubbles: true, clientX: r.x + r.width / 2,
            clientY: r.y + r.height / 2, pointerId: 1}));
        document.querySelector('#stage').dispatchEvent(new PointerEvent('pointerup', {bubbles: true, pointerId: 1})); }""",
                  idx)
    page.click("#pin")
    page.wait_for_selector(f'#stage g.element[data-index="{idx}"][data-pinned="true"]', timeout=30_000)
    # the pin shows in the next frame; the history in the next state message
    page.wait_for_function(f"window.repulsionpakStudio.state.history.undo_label === 'pin element {idx}'",
                           timeout=30_000)
    page.wait_for_function("window.repulsionpak.status.done === true", timeout=300_000)
    page.wait_for_function("window.repulsionpakStudio.state.finished === true")
    # export through the page's link and measure it
    with page.expect_download() as dl:
        page.click("#export-svg")
    out = tmp_path / "studio.svg"
    dl.value.save_as(out)
    container, placed, info = repulsionpak.read_packing_svg(out)
    assert container.region.symmetric_difference(region).area < 0.01 * region.area  # the painted region
    gap = 14.0
    m = repulsionpak.evaluate(container, placed, gap, with_scp=False)
    assert m["overlap_area"] <= 1e-9 * container.area
    assert 0.9 <= m["gap"]["median"] / gap <= 1.1, m["gap"]
    centres = np.array([np.concatenate([s for p in a.paths for s in p.subpaths]).mean(axis=0) for a in placed])
    assert shapely.contains_xy(region, centres[:, 0], centres[:, 1]).all()  # they filled the region
    n_primary = sum(1 for a in placed if a.kind == "primary")
    assert n_primary >= 8
    # the other downloads
    for sel, magic in (("#export-png", b"\x89PNG"), ("#export-pdf", b"%PDF"), ("#save-project", b"PK")):
        with page.expect_download() as dl:
            page.click(sel)
        assert Path(dl.value.path()).read_bytes()[:len(magic)] == magic, sel
    assert not errors, errors
    page.close()


def test_studio_command_prints_the_url_and_opens_its_files(tmp_path):
    """``repulsionpak studio CONTAINER ELEMENTS --port 0 --no-browser``: the URL on a line of
    its own, the files opened in the session, a clean exit at Ctrl-C."""
    import signal
    import subprocess
    import sys

    env = dict(os.environ, PYTHONPATH=str(EX.parent.parent) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-m", "repulsionpak.cli", "studio", str(EX / "containers" / "circle.svg"),
                             str(EX / "elements"), "--port", "0", "--no-browser"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        url = proc.stdout.readline().rstrip("\n")
        assert url.startswith("http://127.0.0.1:") and "/?token=" in url, (url, proc.stderr.read())
        code, text = _run(_status("GET", url.replace("/?token=", "/state?token=")))
        st = json.loads(text)
        assert code == 200 and st["container"] == "circle.svg"
        assert st["elements"] == sorted(p.name for p in (EX / "elements").glob("*.svg"))
        assert st["command"].startswith("repulsionpak pack circle.svg elements/apple.svg ")
    finally:
        proc.send_signal(signal.SIGINT)
        rc = proc.wait(timeout=30)
    assert rc == 0, proc.stderr.read()


#: drops a file (name, text) on the page's element ``sel``, as a file manager would
_DROP = """([sel, name, text]) => { const dt = new DataTransfer();
    dt.items.add(new File([text], name, {type: 'image/svg+xml'}));
    document.querySelector(sel).dispatchEvent(new DragEvent('drop', {bubbles: true, dataTransfer: dt})); }"""


def test_page_keeps_an_edit_over_an_older_state_poll(server):
    """The page polls the state (on load, and when the run's status changes). A poll the
    server answered before an edit but whose answer arrives after the edit's (a busy
    machine) must not put the page back to the document before the edit: the page kept
    showing no elements after a drop once, and a test waiting for them timed out."""
    sync_api, exe = playwright_chromium()
    circle = (EX / "containers" / "circle.svg").read_text()
    held = []

    def is_poll(url: str) -> bool:
        return "/state?" in url

    def hold(route):  # every poll is answered at once but its answer held back
        held.append((route, route.fetch()))

    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        try:
            page = new_page(browser)
            page.route(is_poll, hold)
            page.goto(server.url)
            for _ in range(600):  # the load's poll, answered and held
                if held:
                    break
                page.wait_for_timeout(50)
            older = len(held)
            assert older and json.loads(held[0][1].text())["container"] is None
            page.evaluate(_DROP, ["#container-name", "circle.svg", circle])
            page.wait_for_function("window.repulsionpakStudio.state !== null && "
                                   "window.repulsionpakStudio.state.container === 'circle.svg'")
            for route, answer in held[:older]:  # the answers from before the drop arrive now
                route.fulfill(response=answer)
            page.wait_for_timeout(1000)
            assert page_state(page)["container"] == "circle.svg"
        finally:
            browser.close()


def test_page_drop_files_and_undo(server):
    """Files dropped on the container's section open the container, elsewhere add elements;
    Undo and Redo in the page walk the history."""
    sync_api, exe = playwright_chromium()
    circle = (EX / "containers" / "circle.svg").read_text()
    apple = (EX / "elements" / "apple.svg").read_text()
    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        try:
            page = new_page(browser)
            page.goto(server.url)
            page.wait_for_function("window.repulsionpakStudio.state !== null")
            page.evaluate(_DROP, ["#container-name", "circle.svg", circle])
            page.wait_for_function("window.repulsionpakStudio.state.container === 'circle.svg'")
            page.evaluate(_DROP, ["#stage", "apple.svg", apple])
            page.wait_for_function("window.repulsionpakStudio.state.elements.join() === 'apple.svg'")
            st = page_state(page)
            assert st["region_area"] == pytest.approx(
                repulsionpak.load_container(EX / "containers" / "circle.svg").area, rel=1e-6)
            assert st["command"] == "repulsionpak pack circle.svg elements/apple.svg -o packing.svg"
            page.fill("#element-list input.weight", "2.5")
            page.dispatch_event("#element-list input.weight", "change")
            page.wait_for_function("window.repulsionpakStudio.state.weights[0] === 2.5")
            assert "elements.toml" in page.text_content("#command")
            page.click("#undo")
            page.wait_for_function("window.repulsionpakStudio.state.weights[0] === 1")
            page.click("#undo")
            page.wait_for_function("window.repulsionpakStudio.state.elements.length === 0")
            page.click("#undo")
            page.wait_for_function("window.repulsionpakStudio.state.container === null")
            assert page.is_disabled("#undo") and not page.is_disabled("#redo")
            page.click("#redo")
            page.wait_for_function("window.repulsionpakStudio.state.container === 'circle.svg'")
        finally:
            browser.close()
