"""The studio's per-element settings, folders and manifests through the inputs, undo of an
added copy, and flow guides: the session without a browser, and the page in Chromium with
Playwright (Debian's ``chromium``; skipped cleanly without it or without Playwright).
"""

from __future__ import annotations

import io
import os
import shutil
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("aiohttp", reason="the studio needs aiohttp: pip install -e '.[test]'")

import repulsionpak  # noqa: E402
from repulsionpak.errors import ParameterError  # noqa: E402
from repulsionpak.flow.align import copy_rotations  # noqa: E402
from repulsionpak.studio import Session, StudioServer  # noqa: E402

EX = Path(repulsionpak.__file__).parent / "examples"


def _wait(cond, timeout: float = 120.0, poll: float = 0.1):
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        v = cond()
        if v:
            return v
        time.sleep(poll)
    raise AssertionError(f"timed out after {timeout} s")


def _finish(session: Session, timeout: float = 240.0) -> None:
    _wait(lambda: session._thread is not None and not session._thread.is_alive(), timeout)  # noqa: SLF001
    assert session.error is None, session.error


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


@pytest.fixture
def session():
    s = Session()
    yield s
    s.close()


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
    _finish(session)
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
    zipfile.ZipFile(io.BytesIO(session.project_zip())).extractall(proj)
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


def _chromium() -> str | None:
    for p in (os.environ.get("REPULSIONPAK_CHROMIUM"), shutil.which("chromium"),
              shutil.which("chromium-browser"), "/usr/bin/chromium"):
        if p and Path(p).exists():
            return p
    return None


def _browser():
    exe = _chromium()
    if exe is None:
        pytest.skip("no Chromium found: install it with `apt-get install chromium` (or set REPULSIONPAK_CHROMIUM)")
    sync_api = pytest.importorskip("playwright.sync_api", reason="pip install playwright")
    return sync_api, exe


@pytest.fixture
def server():
    s = Session()
    srv = StudioServer(s, port=0)
    srv.start()
    yield srv
    srv.stop()
    s.close()


@pytest.fixture
def page(server):
    sync_api, exe = _browser()
    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        try:
            pg = browser.new_page(viewport={"width": 1300, "height": 850}, accept_downloads=True)
            errors: list[str] = []
            pg.on("pageerror", lambda e: errors.append(str(e)))
            pg.goto(server.url)
            pg.wait_for_function("window.repulsionpakStudio.state !== null")
            yield pg
            assert not errors, errors
        finally:
            browser.close()


def _state(page) -> dict:
    return page.evaluate("window.repulsionpakStudio.state")


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
    assert _state(page)["own"] == [{"rigid": True}, {"rotation": "fixed:45"}]
    assert page.eval_on_selector("#element-list li:nth-child(1) input.own-stiffness", "e => e.value") == ""
    assert "elements.toml" in page.text_content("#command")
    # the controls show the document after a re-render (undo of the rigid one)
    page.click("#undo")
    page.wait_for_function("window.repulsionpakStudio.state.own[0].rigid === undefined")
    assert page.eval_on_selector(fish + "select.own-rotation", "e => e.value") == "fixed"
    assert page.eval_on_selector(fish + "input.own-angle", "e => e.value") == "45"
    assert page.eval_on_selector("#element-list li:nth-child(1) select.own-rigid", "e => e.value") == ""
