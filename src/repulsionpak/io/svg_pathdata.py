"""The grammar of SVG path data (``d``): where a path's data stops making sense.

Browsers draw a path up to the first error in its data and ignore the rest (SVG 2,
"Error handling in path data"); svgelements instead skips or reinterprets what it cannot
parse, so a file could pack as a shape its author never saw. :func:`path_data_error`
finds the first error and the point up to which the data is valid, so the reader can
cut the data there and name the problem.

Lenient where browsers are: a comma after a command letter or before the next command
is accepted; an empty ``d`` is no error (it draws nothing).
"""

from __future__ import annotations

import re
from typing import NamedTuple

#: numbers each command takes per segment (repeated groups allowed)
_ARITY = {"m": 2, "l": 2, "h": 1, "v": 1, "c": 6, "s": 4, "q": 4, "t": 2, "a": 7, "z": 0}
#: an SVG number (also of ``points`` lists): "50.5.5" is 50.5 and .5, "1-2" is 1 and -2
NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
_WSP = " \t\r\n\f"
_NUMBER_START = "0123456789+-."
_ARC_ARGS = "rx ry rotation large-arc-flag sweep-flag x y"


class PathDataError(NamedTuple):
    """``valid``: the length of the longest prefix of the data made of whole segments
    (what a browser draws); ``at``: where the error is; ``reason``: what is wrong."""

    valid: int
    at: int
    reason: str


def _skip(d: str, i: int, comma: bool = True) -> int:
    """Past white space and (with ``comma``) at most one comma with white space around it."""
    n = len(d)
    while i < n and d[i] in _WSP:
        i += 1
    if comma and i < n and d[i] == ",":
        i += 1
        while i < n and d[i] in _WSP:
            i += 1
    return i


def _needs(cmd: str) -> str:
    k = _ARITY[cmd.lower()]
    if cmd.lower() == "a":
        return f"an arc ({cmd}) takes 7 values per segment: {_ARC_ARGS}, each flag 0 or 1"
    return f"{cmd} takes {k} number{'s' if k > 1 else ''} per segment"


def path_data_error(d: str) -> PathDataError | None:
    """The first error in the path data ``d``, or None when all of it is valid."""
    n = len(d)
    i = _skip(d, 0, comma=False)
    if i == n:
        return None
    if d[i] not in "Mm":
        return PathDataError(0, i, "path data must start with a move-to (M or m)")
    valid = i
    while i < n:
        cmd = d[i]
        if cmd.lower() not in _ARITY:
            return PathDataError(valid, i, f"{cmd!r} is not a path command or a number")
        k = _ARITY[cmd.lower()]
        i = _skip(d, i + 1)
        if k == 0:
            valid = i
            continue
        groups = 0
        while True:
            start = i
            for j in range(k):
                if cmd in "Aa" and j in (3, 4):  # a flag: one character, no separator needed
                    if i < n and d[i] in "01":
                        i = _skip(d, i + 1)
                        continue
                    return PathDataError(valid, i, _needs(cmd))
                m = NUMBER.match(d, i)
                if m is None:
                    if j == 0 and groups > 0:  # the command's segments end here
                        break
                    return PathDataError(valid, i if j else start, _needs(cmd))
                i = _skip(d, m.end())
            else:
                groups += 1
                valid = i
                if i < n and d[i] in _NUMBER_START:
                    continue  # another segment of the same command
                break
            break
    return None
