"""Make docs/images/studio.png: the studio in Chromium (Playwright) with the example heart,
a painted lobe beside it, a flow guide, the example elements and a finished run.

    python docs/make_studio_screenshot.py [--out docs/images/studio.png]

Needs Playwright and Debian's ``chromium`` (or REPULSIONPAK_CHROMIUM).
"""

from __future__ import annotations

import argparse
import os
import shutil
from pathlib import Path

from playwright.sync_api import sync_playwright

from repulsionpak.studio import Session, StudioServer


def _drag(page, x0: float, y0: float, dx: float, rise: float, steps: int) -> None:
    """Press at (x0, y0) and drag up and to the right, ``steps`` moves of (dx, -rise) px."""
    page.mouse.move(x0, y0)
    page.mouse.down()
    for k in range(1, steps + 1):
        page.mouse.move(x0 + dx * k, y0 - rise * k)
    page.mouse.up()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "images" / "studio.png")
    args = ap.parse_args()
    exe = os.environ.get("REPULSIONPAK_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"
    session = Session()
    server = StudioServer(session, port=0)
    server.start()
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=exe, args=["--no-sandbox"])
            page = browser.new_page(viewport={"width": 1280, "height": 1000}, device_scale_factor=1)
            page.goto(server.url)
            page.wait_for_function("window.repulsionpakStudio.state !== null")
            page.select_option("#example-container", "heart")
            page.wait_for_function("window.repulsionpakStudio.state.container === 'heart.svg'")
            page.click("#example-elements")
            page.wait_for_function("window.repulsionpakStudio.state.elements.length > 0")
            for sel, value in (("#gap", "5"), ("#seed", "4")):
                page.fill(sel, value)
                page.dispatch_event(sel, "change")
            page.wait_for_function("window.repulsionpakStudio.state.settings.seed === 4")
            # a lobe painted onto the heart's right side
            page.click("#brush")
            page.fill("#brush-size", "90")
            page.dispatch_event("#brush-size", "input")
            box = page.locator("#stage").bounding_box()
            _drag(page, box["x"] + box["width"] * 0.66, box["y"] + box["height"] * 0.25, 12, 6, 12)
            page.wait_for_function("window.repulsionpakStudio.state.painted && window.repulsionpakStudio.busy === 0")
            page.click("#brush")
            # a flow guide across the heart, left to right and rising
            page.click("#guide")
            _drag(page, box["x"] + box["width"] * 0.3, box["y"] + box["height"] * 0.75, 18, 9, 20)
            page.wait_for_function("window.repulsionpakStudio.state.guides.length === 1 && "
                                   "window.repulsionpakStudio.busy === 0")
            page.click("#guide")
            page.click("#start")
            page.wait_for_function("window.repulsionpak.status.done === true", timeout=600_000)
            page.click("#stage g.element >> nth=5")
            page.wait_for_timeout(500)
            args.out.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(args.out))
            browser.close()
    finally:
        server.stop()
        session.close()
    print(args.out)


if __name__ == "__main__":
    main()
