"""Frame rate of the live view: run `repulsionpak pack --live --no-browser` on the paper's
heart scene and count the binary frames a WebSocket client receives while each phase runs.

    python benchmarks/live_fps.py [--data ../shared/data] [--seed 1]

Prints one line per phase (frames/s, longest gap, bytes/frame, iterations/s) and the
run's own phase times (report ``seconds``, to compare with the same command without
``--live``); the output goes to a temporary directory and the server is stopped with
SIGINT at the end.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import aiohttp

from repulsionpak.live.protocol import decode_frame


async def watch(url: str) -> dict:
    token = url.split("token=")[1]
    port = url.split(":")[2].split("/")[0]
    phase, per = "preparing", {}
    async with aiohttp.ClientSession() as s:
        async with s.ws_connect(f"http://127.0.0.1:{port}/ws?token={token}", max_msg_size=0) as ws:
            while True:
                m = await ws.receive(timeout=600)
                t = time.perf_counter()
                if m.type == aiohttp.WSMsgType.BINARY:
                    f = decode_frame(m.data)
                    per.setdefault(phase, []).append((t, f["iteration"], len(m.data)))
                elif m.type == aiohttp.WSMsgType.TEXT:
                    d = json.loads(m.data)
                    if d.get("type") == "status":
                        if d.get("done"):
                            return per
                        phase = d["phase"]
                else:
                    return per


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", default=str(Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    data = Path(a.data)
    with tempfile.TemporaryDirectory() as tmp:
        proc = subprocess.Popen([sys.executable, "-m", "repulsionpak.cli", "pack",
                                 str(data / "containers" / "heart.svg"), str(data / "animals"),
                                 "--gap", "5.2", "--seed", str(a.seed), "-o", f"{tmp}/out.svg",
                                 "--report", f"{tmp}/report.json",
                                 "--live", "--no-browser", "--port", "0", "-q"],
                                stdout=subprocess.PIPE, text=True)
        url = proc.stdout.readline().strip()
        try:
            per = asyncio.run(watch(url))
        finally:
            proc.send_signal(signal.SIGINT)
            proc.wait(timeout=300)
        seconds = json.loads(Path(f"{tmp}/report.json").read_text())["seconds"]
    for ph, fr in per.items():
        if len(fr) < 2:
            continue
        dt = fr[-1][0] - fr[0][0]
        gaps = [b[0] - a[0] for a, b in zip(fr, fr[1:])]
        print(f"{ph}: {len(fr)} frames in {dt:.1f} s = {(len(fr) - 1) / dt:.1f} fps "
              f"(longest gap {max(gaps) * 1000:.0f} ms); iterations {fr[0][1]}..{fr[-1][1]} "
              f"({(fr[-1][1] - fr[0][1]) / dt:.0f} it/s); {fr[-1][2]} bytes/frame")
    print("phase seconds: " + ", ".join(f"{k} {seconds[k]:.1f}" for k in ("preprocess", "primary", "secondary")
                                        if k in seconds))


if __name__ == "__main__":
    main()
