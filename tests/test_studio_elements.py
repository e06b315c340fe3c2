"""The studio's per-element settings, folders and manifests through the inputs, undo of an
added copy, and flow guides: the session without a browser, and the page in Chromium with
Playwright (Debian's ``chromium``; skipped cleanly without it or without Playwright).
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("aiohttp", reason="the studio needs aiohttp: pip install -e '.[test]'")

import repulsionpak  # noqa: E402
from repulsionpak.errors import ParameterError  # noqa: E402
from repulsionpak.flow.align import copy_rotations  # noqa: E402
from repulsionpak.studio import Session  # noqa: E402
from browser_support import (  # noqa: E402
    finish, new_page, page_state, paused_apples, playwright_chromium, unpacked_project, wait)
from browser_support import server, session  # noqa: E402,F401  (fixtures)

EX = Path(repulsionpak.__file__).parent / "examples"


def _cli_in(folder: Path, cmd: str) -> None:
    from typer.testing import CliRunner

    from repulsionpak.cli import app

    cwd = os.getcwd()
    try:
        os.chdir(folder)
        res = CliRunner().invoke(app, cmd.split()[1:] + ["-q"])
    finally:
        os.chdir(cwd)
    assert res.exit_code == 0, res.output


def test_an_elements_own_rotation_reaches_the_command_the_run_and_the_project(session, tmp_path):
    """fish fixed at 30°: every fish copy of the export is at 30° (measured on the art), the
    apples turn freely; the command reads the elements through a manifest holding the
    fish's keys, and run in the unpacked project it writes the same bytes."""
    session.use_examples("circle", ["apple", "fish"])
    with pytest.raises(ParameterError, match="max_rotation must be between 0 and 180"):
        session.set_element(1, "rotation", "limited:400")
    with pytest.raises(ParameterError, match="stiffness must be > 0"):
        session.set_element(1, "stiffness", "-1")
    assert session.state()["own"] == [{}, {}]
    session.set_element(1, "rotation", "fixed:30")
    session.set_element(0, "stiffness", "0.5")
    assert session.state()["own"] == [{"stiffness": 0.5}, {"rotation": "fixed:30"}]
    for k, v in (("count", "10"), ("gap", "12"), ("seed", "3")):
        session.set_setting(k, v)
    assert session.command() == "repulsionpak pack circle.svg elements.toml -o packing.svg --gap 12 --seed 3 --count 10"
    session.start()
    finish(session)
    svg = session.export("svg")
    out = tmp_path / "studio.svg"
    out.write_bytes(svg)
    _, placed, _ = repulsionpak.read_packing_svg(out)
    els = repulsionpak.load_elements([EX / "elements" / "apple.svg", EX / "elements" / "fish.svg"])
    rots, _, which = copy_rotations([p for p in placed if p.kind == "primary"], els)
    fish = np.array([r for r, e in zip(rots, which) if e.source == "fish.svg"])
    apple = np.array([r for r, e in zip(rots, which) if e.source == "apple.svg"])
    assert len(fish) >= 3 and len(apple) >= 3
    d = np.abs(np.mod(fish - 30.0 + 180.0, 360.0) - 180.0)
    assert d.max() < 3.0, fish
    assert np.ptp(apple) > 20.0, apple  # free: the apples did turn
    proj = tmp_path / "proj"
    unpacked_project(session, proj)
    manifest = (proj / "elements.toml").read_text()
    assert 'file = "elements/fish.svg"\nrotation = "fixed"\nangle = 30' in manifest
    assert 'file = "elements/apple.svg"\nstiffness = 0.5' in manifest
    _cli_in(proj, session.command())
    assert (proj / "packing.svg").read_bytes() == svg
    # undo takes the setting back; a reopened project has it
    other = Session()
    try:
        assert other.open_project(session.project_zip())["own"] == [{"stiffness": 0.5}, {"rotation": "fixed:30"}]
    finally:
        other.close()
    for _ in range(4):  # the seed, the count, the gap, the apple's stiffness
        session.undo()
    assert session.state()["own"] == [{}, {"rotation": "fixed:30"}]
    session.set_element(1, "rotation", "")
    assert session.command() == "repulsionpak pack circle.svg elements/apple.svg elements/fish.svg -o packing.svg"


# -- the page in Chromium -----------------------------------------------------------------


@pytest.fixture
def page(server):
    sync_api, exe = playwright_chromium()
    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        try:
            pg = new_page(browser, viewport={"width": 1300, "height": 850}, accept_downloads=True)
            errors: list[str] = []
            pg.on("pageerror", lambda e: errors.append(str(e)))
            pg.goto(server.url)
            pg.wait_for_function("window.repulsionpakStudio.state !== null")
            yield pg
            assert not errors, errors
        finally:
            browser.close()


def test_page_sets_an_elements_own_rotation_rigid_and_stiffness(page):
    page.select_option("#example-container", "circle")
    page.wait_for_function("window.repulsionpakStudio.state.container === 'circle.svg'")
    page.set_input_files("#open-elements", [str(EX / "elements" / "apple.svg"), str(EX / "elements" / "fish.svg")])
    page.wait_for_function("window.repulsionpakStudio.state.elements.length === 2")
    fish = "#element-list li:nth-child(2) "
    page.select_option(fish + "select.own-rotation", "fixed")
    page.wait_for_function("window.repulsionpakStudio.state.own[1].rotation === 'fixed'")
    page.fill(fish + "input.own-angle", "45")
    page.dispatch_event(fish + "input.own-angle", "change")
    page.wait_for_function("window.repulsionpakStudio.state.own[1].rotation === 'fixed:45'")
    page.select_option("#element-list li:nth-child(1) select.own-rigid", "true")
    page.wait_for_function("window.repulsionpakStudio.state.own[0].rigid === true")
    page.fill("#element-list li:nth-child(1) input.own-stiffness", "-2")
    page.dispatch_event("#element-list li:nth-child(1) input.own-stiffness", "change")
    page.wait_for_function("document.querySelector('#setting-error').textContent.includes('stiffness must be > 0')")
    assert page_state(page)["own"] == [{"rigid": True}, {"rotation": "fixed:45"}]
    assert page.eval_on_selector("#element-list li:nth-child(1) input.own-stiffness", "e => e.value") == ""
    assert "elements.toml" in page.text_content("#command")
    # the controls show the document after a re-render (undo of the rigid one)
    page.click("#undo")
    page.wait_for_function("window.repulsionpakStudio.state.own[0].rigid === undefined")
    assert page.eval_on_selector(fish + "select.own-rotation", "e => e.value") == "fixed"
    assert page.eval_on_selector(fish + "input.own-angle", "e => e.value") == "45"
    assert page.eval_on_selector("#element-list li:nth-child(1) select.own-rigid", "e => e.value") == ""


# -- folders and manifests through the inputs -----------------------------------------------


def _svg(name: str) -> bytes:
    return (EX / "elements" / name).read_bytes()


def test_a_folder_adds_its_input_files_only(session):
    st = session.add_elements([("animals/apple.svg", _svg("apple.svg")), ("animals/notes.txt", b"hello"),
                               ("animals/sea/fish.svg", _svg("fish.svg")), ("animals/.hidden.svg", b"x")])
    assert st["elements"] == ["apple.svg", "fish.svg"] and st["own"] == [{}, {}]
    assert st["history"]["undo_label"] == "add apple.svg and 1 more"
    with pytest.raises(ParameterError, match="no SVG or .path files"):
        session.add_elements([("empty/notes.txt", b"hello")])
    with pytest.raises(ParameterError, match="at most 1000 at once"):
        session.add_elements([(f"big/{i}.txt", b"") for i in range(1001)])
    st = session.add_elements([("../../escape/leaf.svg", _svg("leaf.svg"))])  # a name is only a name
    assert st["elements"][-1] == "leaf.svg"
    assert session.doc.elements[-1].path.resolve().is_relative_to(session.dir.resolve())
    assert not any(p.name == "escape" for p in session.dir.parent.iterdir())


MANIFEST = b'''[defaults]
stiffness = 0.5

[[element]]
file = "shapes/apple.svg"
weight = 2

[[element]]
file = "shapes/fish.svg"
rotation = "fixed"
angle = 30
rigid = true
'''


def test_a_manifest_adds_the_files_it_names_with_their_settings(session):
    # picked together with its files (no folders): a file of the named file's name stands in
    st = session.add_elements([("elements.toml", MANIFEST), ("apple.svg", _svg("apple.svg")),
                               ("fish.svg", _svg("fish.svg")), ("leaf.svg", _svg("leaf.svg"))])
    assert st["elements"] == ["apple.svg", "fish.svg"]  # leaf.svg is not named
    assert st["weights"] == [2.0, 1.0]
    assert st["own"] == [{"stiffness": 0.5}, {"rigid": True, "rotation": "fixed:30", "stiffness": 0.5}]
    session.use_examples("circle")
    assert session.command() == "repulsionpak pack circle.svg elements.toml -o packing.svg"
    session.undo()
    session.undo()
    assert session.state()["elements"] == []
    # in a folder: the paths are the manifest's
    st = session.add_elements([("scene/elements.toml", MANIFEST), ("scene/shapes/apple.svg", _svg("apple.svg")),
                               ("scene/shapes/fish.svg", _svg("fish.svg"))])
    assert st["elements"] == ["apple.svg", "fish.svg"] and st["weights"] == [2.0, 1.0]


@pytest.mark.parametrize("text, words", [
    (b'[[element]]\nfile = "apple.svg"\npins = [{x = 1, y = 2}]\n', ["elements.toml", "pins", "repulsionpak pack"]),
    (b'[[element]]\nfile = "../apple.svg"\n', ["elements.toml", "not inside the files given"]),
    (b'[[element]]\nfile = "pear.svg"\n', ["elements.toml", "pear.svg", "does not exist"]),
    (b'[[element]]\nfile = "apple.svg"\nrotaton = "fixed"\n', ["elements.toml", "did you mean 'rotation'"]),
    (b'[[element]]\nfile = "apple.svg"\nrotation = "limited"\nangle = 40\n', ["about angle 0 only"]),
])
def test_a_bad_manifest_is_refused_with_pack_s_message(session, text, words):
    with pytest.raises(Exception) as exc:
        session.add_elements([("elements.toml", text), ("apple.svg", _svg("apple.svg"))])
    for w in words:
        assert w in str(exc.value), str(exc.value)
    assert str(session.dir) not in str(exc.value)
    assert session.state()["elements"] == []


def test_page_takes_a_folder_and_a_manifest(page, tmp_path):
    scene = tmp_path / "scene"
    (scene / "shapes").mkdir(parents=True)
    (scene / "elements.toml").write_bytes(MANIFEST)
    for n in ("apple.svg", "fish.svg", "leaf.svg"):
        (scene / "shapes" / n).write_bytes(_svg(n))
    # the manifest and its files through "Add SVGs…"
    page.set_input_files("#open-elements", [str(scene / "elements.toml"), str(scene / "shapes" / "apple.svg"),
                                            str(scene / "shapes" / "fish.svg")])
    # (the state with both elements and their weights: once, under a loaded CI machine, the
    # page's state was read with the two elements but no weights yet)
    page.wait_for_function("window.repulsionpakStudio.state.elements.length === 2"
                           " && window.repulsionpakStudio.state.weights.length === 2")
    st = page_state(page)
    assert st["weights"] == [2.0, 1.0] and st["own"][1]["rotation"] == "fixed:30"
    assert page.eval_on_selector("#element-list li:nth-child(2) select.own-rotation", "e => e.value") == "fixed"
    # a folder through "Add folder…" (webkitdirectory): its own manifest decides
    other = tmp_path / "plain"
    (other / "deep").mkdir(parents=True)
    (other / "leaf.svg").write_bytes(_svg("leaf.svg"))
    (other / "deep" / "snake.svg").write_bytes(_svg("snake.svg"))
    (other / "notes.txt").write_text("not an element")
    page.set_input_files("#open-folder", str(other))
    page.wait_for_function("window.repulsionpakStudio.state.elements.length === 4")
    assert page_state(page)["elements"] == ["apple.svg", "fish.svg", "leaf.svg", "snake.svg"]
    # a dropped folder (DataTransfer of a directory entry is not scriptable): its files, as
    # the page sends them with their relative paths
    st = page.evaluate("""async (texts) => {
        const files = texts.map(([p, t]) => { const f = new File([t], p.split('/').pop(), {type: 'image/svg+xml'});
                                              f.relPath = p; return f; });
        const fd = new FormData();
        for (const f of files) fd.append('file', f, f.relPath);
        const token = new URLSearchParams(location.search).get('token');
        const r = await fetch('/open-elements?token=' + token, {method: 'POST', body: fd});
        return await r.json(); }""", [["drop/bird.svg", _svg("bird.svg").decode()], ["drop/x/readme.md", "# no"]])
    assert st["elements"] == ["apple.svg", "fish.svg", "leaf.svg", "snake.svg", "bird.svg"]


# -- add copy, undoable; painted room grown into --------------------------------------------


def test_an_added_copy_is_undone_and_redone(session):
    ctl = paused_apples(session)
    n0 = ctl.sim.model.n_elements
    with pytest.raises(ParameterError, match="'x' must be a finite number"):
        session.add_copy(1, float("nan"), 0.0)
    st = session.add_copy(1, 250.0, 250.0)
    assert ctl.sim.model.n_elements == n0 + 1 and st["history"]["undo_label"] == "add a copy of element 1"
    m = ctl.sim.model
    a, b = int(m.elem_vstart[n0]), int(m.elem_vstart[n0 + 1])
    x0 = ctl.sim.state.x[a:b].copy()
    assert np.allclose(x0.mean(axis=0) * ctl.unit, [250.0, 250.0], atol=15.0)  # where it was put
    session.undo()
    wait(lambda: n0 in ctl.removed)
    assert n0 in ctl.layout_message()["removed"]
    session.redo()
    wait(lambda: n0 not in ctl.removed and np.abs(ctl.sim.state.x[a:b] - x0).max() < 1e-9)
    assert ctl.sim.state.moving[n0]
    # a copy outside the container is refused and leaves no history
    st = session.add_copy(1, 5000.0, 5000.0)
    assert ctl.sim.model.n_elements == n0 + 1 and st["history"]["undo_label"] == "add a copy of element 1"
    session.cancel(wait=60)


def test_painted_room_raises_the_planned_sizes(session, monkeypatch):
    """Painting doubles the container: every element's planned size grows by √2 and the
    run, settling or not, grows again (the elements take the room). The run has no pocket
    fill, whose growth cap (2×) is set to the filled runs' 1.3× here: past that cap the
    elements could have grown without the paint."""
    import repulsionpak.params

    monkeypatch.setattr(repulsionpak.params, "MAX_SIZE_UNFILLED", repulsionpak.params.MAX_SIZE_FILLED)
    session.use_examples("circle", ["apple", "fish"])
    for k, v in (("count", "10"), ("gap", "12"), ("seed", "3"), ("pocket_fill", False)):
        session.set_setting(k, v)
    session.start(paused=True)  # stepped to a fixed iteration: the trajectory does not
    ctl = session.controller  # depend on the wall clock
    wait(lambda: ctl.sim is not None and ctl.paused)
    ctl.submit({"cmd": "step", "n": 100})
    wait(lambda: ctl.sim.state.iteration >= 100 and ctl.steps_left == 0 and ctl.commands.empty())
    sim = ctl.sim
    cap0 = sim.max_growth.copy()
    area0 = sim.model.container_area
    growth0 = np.asarray(sim.state.growth).copy()
    st = session.stroke({"mode": "paint", "points": [[420, 250], [720, 250], [720, 700]], "radius": 150})
    wait(lambda: sim.model.container_area > 1.3 * area0, timeout=30)
    ratio = sim.model.container_area / area0
    assert sim.max_growth == pytest.approx(cap0 * np.sqrt(ratio), rel=1e-9)
    assert sim.state.allow_growth and sim.state.settle_left is None
    ctl.submit({"cmd": "resume"})
    wait(lambda: (np.asarray(sim.state.growth) > cap0).any() or not session.running, timeout=240)
    grown = np.asarray(sim.state.growth)
    assert (grown > growth0 + 1e-6).sum() >= 5, (growth0, grown)  # most elements grew again
    assert (grown > cap0).any(), (cap0, grown)  # some past the first planned size
    assert st["region_area"] > 1.3 * ctl.container.region.area / ratio
    session.cancel(wait=60)


# -- flow guides ------------------------------------------------------------------------------


def test_guides_reach_the_command_the_run_and_the_project(session, tmp_path):
    """A guide drawn left to right: the command gets --flow guides.svg, the copies of the
    export lie along it (angles measured on the art against the field), and the command run
    in the unpacked project writes the same bytes."""
    from repulsionpak.flow import alignment_angles, field_from_guides, load_guides

    session.use_examples("circle", ["fish", "leaf"])
    with pytest.raises(ParameterError, match="two distinct points"):
        session.guide({"points": [[10, 10], [10, 10]]})
    st = session.guide({"points": [[60, 400], [250, 300], [440, 200]]})
    assert st["history"]["undo_label"] == "guide" and st["guides"][0][0] == [60.0, 400.0]
    assert st["field"].count("M") > 100  # the field's arrows: shaft and head each
    for k, v in (("count", "12"), ("gap", "12"), ("seed", "4"), ("pocket_fill", False)):
        session.set_setting(k, v)
    assert session.command() == ("repulsionpak pack circle.svg elements/fish.svg elements/leaf.svg -o packing.svg "
                                 "--flow guides.svg --gap 12 --seed 4 --count 12 --no-pocket-fill")
    session.start()
    finish(session)
    svg = session.export("svg")
    proj = tmp_path / "proj"
    unpacked_project(session, proj)
    _cli_in(proj, session.command())
    assert (proj / "packing.svg").read_bytes() == svg
    container, placed, _ = repulsionpak.read_packing_svg(proj / "packing.svg")
    field = field_from_guides(load_guides(proj / "guides.svg"), container.region.bounds)
    els = repulsionpak.load_elements([EX / "elements" / "fish.svg", EX / "elements" / "leaf.svg"])
    stats = alignment_angles([p for p in placed if p.kind == "primary"], els, field)
    assert len(stats.angles) >= 10
    assert np.median(stats.angles) < 6.0 and np.percentile(stats.angles, 90) < 12.0, stats.angles
    other = Session()
    try:
        assert other.open_project(session.project_zip())["guides"] == st["guides"]
        assert other.command() == session.command()
    finally:
        other.close()
    session.clear_guides()
    assert "--flow" not in session.command() and session.state()["field"] == ""
    session.undo()
    assert session.state()["guides"] == st["guides"]


def test_live_view_scene_carries_the_field_of_flow(tmp_path):
    """``pack --live --flow G.svg``: the page's scene holds the field's arrows, each
    pointing along the guide (a straight guide: every arrow's shaft is parallel to it)."""
    import re

    from repulsionpak.live import LiveRun
    from repulsionpak.params import Params
    from repulsionpak.studio.guides import guides_svg

    cont = repulsionpak.load_container(EX / "containers" / "circle.svg")
    g = tmp_path / "g.svg"
    g.write_text(guides_svg([((40.0, 400.0), (460.0, 100.0))], (0, 0, 500, 500)))
    run = LiveRun(cont, Params(gap=12.0), port=0, open_browser=False, flow=g)
    d = run.controller.scene()["field"]
    shafts = re.findall(r"M([-\d.]+) ([-\d.]+)L([-\d.]+) ([-\d.]+)M", d)
    assert len(shafts) > 300
    v = np.array([[float(c) - float(a), float(dd) - float(b)] for a, b, c, dd in shafts])
    ang = np.degrees(np.arctan2(v[:, 1], v[:, 0]))
    want = np.degrees(np.arctan2(-300.0, 420.0))
    assert np.abs(ang - want).max() < 1.0
    assert "field" not in LiveRun(cont, Params(gap=12.0), port=0, open_browser=False).controller.scene()


def test_page_guide_drawn_with_the_mouse_aligns_the_copies_and_add_copy_undoes(page, tmp_path):
    from repulsionpak.flow import alignment_angles, field_from_guides

    page.select_option("#example-container", "circle")
    page.wait_for_function("window.repulsionpakStudio.state.container === 'circle.svg'")
    page.set_input_files("#open-elements", [str(EX / "elements" / "fish.svg"), str(EX / "elements" / "leaf.svg")])
    page.wait_for_function("window.repulsionpakStudio.state.elements.length === 2")
    assert page.locator("#element-list select.own-flow").count() == 0  # no guides: no flow keys
    for sel, value in (("#gap", "12"), ("#count", "12"), ("#seed", "4")):
        page.fill(sel, value)
        page.dispatch_event(sel, "change")
    page.wait_for_function("window.repulsionpakStudio.state.settings.seed === 4")
    # a guide from lower left to upper right, dragged with the mouse
    page.click("#guide")
    ctm = page.evaluate("(() => { const m = document.querySelector('#stage').getScreenCTM();"
                        " return [m.a, m.d, m.e, m.f]; })()")

    def screen(x, y):
        return ctm[0] * x + ctm[2], ctm[1] * y + ctm[3]

    page.mouse.move(*screen(60, 400))
    page.mouse.down()
    for k in range(1, 21):
        page.mouse.move(*screen(60 + 19 * k, 400 - 10 * k))
    page.mouse.up()
    page.wait_for_function("window.repulsionpakStudio.state.guides.length === 1 && window.repulsionpakStudio.busy === 0")
    guide = np.array(page_state(page)["guides"][0])
    assert np.abs(guide[0] - [60, 400]).max() < 2 and np.abs(guide[-1] - [440, 200]).max() < 2
    assert "--flow guides.svg" in page.text_content("#command")
    assert page.locator("#guide-layer path").count() == 1
    assert page.locator("#element-list select.own-flow").count() == 2  # the flow keys, with guides
    assert page.get_attribute("#field-layer path.field", "d").count("M") > 100
    assert page.is_visible("#field-layer path.field")
    page.uncheck("#show-field")
    assert not page.is_visible("#field-layer path.field")
    page.check("#show-field")
    page.click("#guide")  # guide tool off
    # run; add a copy while it is paused, undo and redo it
    page.click("#start")
    page.wait_for_function("document.querySelectorAll('#stage g.element').length === 12", timeout=120_000)
    page.click("#pause")
    page.wait_for_function("window.repulsionpak.status.paused === true")
    page.locator('#stage g.element[data-index="3"] path').click()
    page.click("#add-copy")
    page.mouse.click(*screen(250, 250))
    page.wait_for_function("document.querySelectorAll('#stage g.element').length === 13")
    page.wait_for_function("window.repulsionpakStudio.state.history.undo_label === 'add a copy of element 3'")
    page.click("#undo")
    page.wait_for_selector('#stage g.element[data-index="12"].removed', state="attached")
    page.click("#redo")
    page.wait_for_selector('#stage g.element[data-index="12"]:not(.removed)', state="attached")
    page.click("#pause")  # resume
    page.wait_for_function("window.repulsionpak.status.done === true", timeout=300_000)
    page.wait_for_function("window.repulsionpakStudio.state.finished === true")
    with page.expect_download() as dl:
        page.click("#export-svg")
    out = tmp_path / "studio.svg"
    dl.value.save_as(out)
    container, placed, _ = repulsionpak.read_packing_svg(out)
    primary = [p for p in placed if p.kind == "primary"]
    assert len(primary) == 13  # the added copy is in the packing
    field = field_from_guides([guide], container.region.bounds)
    els = repulsionpak.load_elements([EX / "elements" / "fish.svg", EX / "elements" / "leaf.svg"])
    stats = alignment_angles(primary, els, field)
    assert stats.median < 8.0 and stats.p90 < 20.0, stats.angles


def test_pack_live_flow_serves_the_field(tmp_path):
    """``repulsionpak pack ... --live --flow G.svg``: the page's scene over the WebSocket
    carries the field's arrows."""
    import asyncio
    import json
    import signal
    import subprocess
    import sys

    import aiohttp

    from repulsionpak.studio.guides import guides_svg

    g = tmp_path / "g.svg"
    g.write_text(guides_svg([((40.0, 250.0), (460.0, 250.0))], (0, 0, 500, 500)))
    env = dict(os.environ, PYTHONPATH=str(EX.parent.parent) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-m", "repulsionpak.cli", "pack", str(EX / "containers" / "circle.svg"),
                             str(EX / "elements" / "fish.svg"), "--count", "6", "--gap", "20", "--seed", "1",
                             "--flow", str(g), "-o", str(tmp_path / "out.svg"), "--live", "--no-browser",
                             "--port", "0", "--paused", "-q"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        url = proc.stdout.readline().strip()
        assert url.startswith("http://127.0.0.1:"), proc.stderr.read()

        async def scene():
            async with aiohttp.ClientSession() as c:
                async with c.ws_connect(url.replace("http://", "ws://").replace("/?token=", "/ws?token=")) as ws:
                    for _ in range(20):
                        m = await ws.receive(timeout=60)
                        if m.type == aiohttp.WSMsgType.TEXT and json.loads(m.data).get("type") == "scene":
                            return json.loads(m.data)
            return None

        msg = asyncio.run(scene())
        assert msg is not None and msg["field"].count("M") > 300
        # a horizontal guide: every shaft is horizontal, left to right
        first = msg["field"].split("M")[1]
        (x0, y0), (x1, y1) = (tuple(map(float, p.split())) for p in first.split("L"))
        assert x1 > x0 and abs(y1 - y0) < 1e-6 * abs(x1 - x0) + 0.011
    finally:
        proc.send_signal(signal.SIGINT)
        rc = proc.wait(timeout=60)
    assert rc in (0, 130), proc.stderr.read()


def test_an_elements_own_flow_keys(session, tmp_path):
    """flow = "ignore" keeps a fixed-rotation element at its angle while the other follows
    the guide; the keys reach the manifest the command reads."""
    from repulsionpak.flow import alignment_angles, field_from_guides, load_guides

    session.use_examples("circle", ["fish", "leaf"])
    session.guide({"points": [[60, 250], [440, 250]]})
    with pytest.raises(ParameterError, match="flow must be one of align, ignore"):
        session.set_element(0, "flow", "sideways")
    session.set_element(0, "flow", "ignore")
    session.set_element(0, "rotation", "fixed:90")
    session.set_element(1, "axis", "0")
    for k, v in (("count", "10"), ("gap", "12"), ("seed", "4"), ("pocket_fill", False)):
        session.set_setting(k, v)
    session.start()
    finish(session)
    proj = tmp_path / "proj"
    unpacked_project(session, proj)
    manifest = (proj / "elements.toml").read_text()
    assert 'file = "elements/fish.svg"\nflow = "ignore"\nrotation = "fixed"\nangle = 90' in manifest
    assert 'file = "elements/leaf.svg"\naxis = 0' in manifest
    _cli_in(proj, session.command())
    assert (proj / "packing.svg").read_bytes() == session.export("svg")
    _, placed, _ = repulsionpak.read_packing_svg(proj / "packing.svg")
    from repulsionpak.io.manifest import load_manifest

    els = load_manifest(proj / "elements.toml")
    rots, _, which = copy_rotations([p for p in placed if p.kind == "primary"], els)
    fish = np.array([r for r, e in zip(rots, which) if e.source == "fish.svg"])
    assert len(fish) >= 3 and np.abs(np.mod(fish - 90.0 + 180.0, 360.0) - 180.0).max() < 3.0, fish
    container = repulsionpak.load_container(proj / "circle.svg")
    field = field_from_guides(load_guides(proj / "guides.svg"), container.region.bounds)
    leaves = alignment_angles([p for p in placed if p.source == "leaf.svg" and p.kind == "primary"], els, field)
    assert len(leaves.angles) >= 3 and leaves.median < 8.0, leaves.angles
