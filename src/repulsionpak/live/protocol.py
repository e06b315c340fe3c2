"""The live view's wire format (server → page binary frames; JSON messages both ways).

Binary frame (little-endian), one per published iteration::

    0   4s   magic b"RPKF"
    4   u32  layout id (the frame's points follow the layout message of that id)
    8   u32  iteration
    12  f32  area fraction of the meshes
    16  u32  n, number of points
    20  n × (f32 x, f32 y)   every element's skin vertices, element by element, in
                            container units; element i has ``layout.counts[i]`` of them

The float block starts at byte 20 (a multiple of 4), so a page reads it as
``new Float32Array(buffer, 20, 2 * n)`` without copying.

JSON messages from the server carry a ``type``: ``scene`` (container rings and view box,
and how the container is drawn: ``paint`` ``outline`` with ``colour`` and ``width``,
``as-drawn`` with ``markup``, or ``none``; once per connection), ``layout`` (per-element point counts, kinds, pinned/removed flags;
whenever the set of elements changes), ``status`` (iteration, paused, phase, estimated
area fraction and median gap, ``done`` and ``stopped_by`` at the end). Commands from the
page are JSON objects with a ``cmd``: ``pause``, ``resume``, ``step`` (``n``), ``move``
(``index``, ``dx``, ``dy`` in container units), ``pin`` (``index``, ``pinned``),
``remove`` (``index``), ``add`` (``index`` of the element to copy, ``x``, ``y`` in
container units).
"""

from __future__ import annotations

import struct

import numpy as np

MAGIC = b"RPKF"
HEADER = struct.Struct("<4sIIfI")
COMMANDS = ("pause", "resume", "step", "move", "pin", "remove", "add")


def encode_frame(layout_id: int, iteration: int, area_fraction: float, points: np.ndarray) -> bytes:
    """One binary frame of ``points`` ((n, 2), container units)."""
    pts = np.ascontiguousarray(points, dtype="<f4").reshape(-1, 2)
    af = float(area_fraction) if np.isfinite(area_fraction) else 0.0
    return HEADER.pack(MAGIC, int(layout_id), int(iteration), af, len(pts)) + pts.tobytes()


def decode_frame(data: bytes) -> dict:
    """Inverse of :func:`encode_frame`: ``{"layout", "iteration", "area_fraction", "points"}``."""
    if len(data) < HEADER.size:
        raise ValueError(f"frame of {len(data)} bytes is shorter than its {HEADER.size}-byte header")
    magic, layout, it, af, n = HEADER.unpack_from(data)
    if magic != MAGIC:
        raise ValueError(f"not a repulsionpak frame (magic {magic!r})")
    if len(data) != HEADER.size + 8 * n:
        raise ValueError(f"frame announces {n} points but holds {(len(data) - HEADER.size) / 8:g}")
    pts = np.frombuffer(data, dtype="<f4", count=2 * n, offset=HEADER.size).reshape(n, 2)
    return {"layout": layout, "iteration": it, "area_fraction": af, "points": pts}


def parse_command(msg: object) -> dict:
    """Validate a command from a page; raises ``ValueError`` naming what is wrong."""
    if not isinstance(msg, dict) or msg.get("cmd") not in COMMANDS:
        raise ValueError(f"unknown command {msg!r}")
    cmd = msg["cmd"]
    out = {"cmd": cmd}
    if cmd in ("move", "pin", "remove", "add"):
        i = msg.get("index")
        if not isinstance(i, int) or isinstance(i, bool) or i < 0:
            raise ValueError(f"{cmd}: 'index' must be an element index, got {i!r}")
        out["index"] = i
    if cmd in ("move", "add"):
        for k in ("dx", "dy") if cmd == "move" else ("x", "y"):
            v = msg.get(k)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not np.isfinite(v):
                raise ValueError(f"{cmd}: '{k}' must be a finite number, got {v!r}")
            out[k] = float(v)
    if cmd == "pin":
        out["pinned"] = bool(msg.get("pinned", True))
    if cmd == "step":
        n = msg.get("n", 1)
        if not isinstance(n, int) or isinstance(n, bool) or not 1 <= n <= 10000:
            raise ValueError(f"step: 'n' must be an integer in 1..10000, got {n!r}")
        out["n"] = n
    return out


__all__ = ["encode_frame", "decode_frame", "parse_command", "MAGIC", "HEADER"]
