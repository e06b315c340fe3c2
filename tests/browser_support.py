"""What the live view's and the studio's tests share: finding Debian's Chromium for
Playwright, waiting on a condition, the studio's session and server fixtures, and its
project files.

Test modules import the fixtures by name (``from browser_support import server, session``),
so pytest finds them there.
"""

from __future__ import annotations

import io
import os
import shutil
import time
import zipfile
from pathlib import Path

import pytest


def chromium() -> str | None:
    """The Chromium executable Playwright drives (it cannot download its own browser
    here): ``REPULSIONPAK_CHROMIUM``, or Debian's ``chromium`` on the PATH."""
    for p in (os.environ.get("REPULSIONPAK_CHROMIUM"), shutil.which("chromium"),
              shutil.which("chromium-browser"), "/usr/bin/chromium"):
        if p and Path(p).exists():
            return p
    return None


def playwright_chromium():
    """(playwright.sync_api, Chromium's path), or skip the test, saying what is missing."""
    exe = chromium()
    if exe is None:
        pytest.skip("no Chromium found: install it with `apt-get install chromium` (or set REPULSIONPAK_CHROMIUM)")
    sync_api = pytest.importorskip("playwright.sync_api", reason="pip install playwright")
    return sync_api, exe


PAGE_TIMEOUT_MS = 120_000  # as wait(): a loaded 2-core CI machine can take tens of seconds


def new_page(browser, **kwargs):
    """``browser.new_page(**kwargs)`` whose waits time out after :data:`PAGE_TIMEOUT_MS`
    (Playwright's own 30 s is too short on a CI machine busy with the rest of the suite)."""
    page = browser.new_page(**kwargs)
    page.set_default_timeout(PAGE_TIMEOUT_MS)
    return page


def wait(cond, timeout: float = 120.0, poll: float = 0.1):
    """``cond()``'s first true value, polled every ``poll`` s; AssertionError after ``timeout`` s."""
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        v = cond()
        if v:
            return v
        time.sleep(poll)
    raise AssertionError(f"timed out after {timeout} s")


def finish(session, timeout: float = 240.0) -> None:
    """Wait for a studio session's run to end, and check it ended without an error."""
    wait(lambda: session._thread is not None and not session._thread.is_alive(), timeout)  # noqa: SLF001
    assert session.error is None, session.error


def unpacked_project(session, folder: Path) -> Path:
    """The studio session's project (:meth:`Session.project_zip`) extracted into ``folder``."""
    zipfile.ZipFile(io.BytesIO(session.project_zip())).extractall(folder)
    return folder


def paused_apples(session):
    """Start ``session`` paused on six apples in the example circle (gap 12, seed 5) and
    return its controller once the run waits at its first frame with no command queued."""
    session.use_examples("circle", ["apple"])
    for k, v in (("count", "6"), ("gap", "12"), ("seed", "5")):
        session.set_setting(k, v)
    session.start(paused=True)
    ctl = session.controller
    wait(lambda: ctl.sim is not None)
    wait(lambda: ctl.paused and ctl.commands.empty())
    return ctl


def page_state(page) -> dict:
    """The studio page's own state object."""
    return page.evaluate("window.repulsionpakStudio.state")


@pytest.fixture
def session():
    from repulsionpak.studio import Session

    s = Session()
    yield s
    s.close()


@pytest.fixture
def server():
    from repulsionpak.studio import Session, StudioServer

    s = Session()
    srv = StudioServer(s, port=0)
    srv.start()
    yield srv
    srv.stop()
    s.close()
