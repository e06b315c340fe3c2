"""Numbers as the writers print them: fixed point, no trailing zeros, no ``-0``."""

from __future__ import annotations

__all__ = ["format_number"]


def format_number(x: float, decimals: int = 4) -> str:
    """Fixed-point with up to ``decimals`` decimals, no trailing zeros, no ``-0``."""
    s = f"{float(x):.{decimals}f}"
    if "." in s:
        s = s.rstrip("0").rstrip(".")
    if s in ("-0", "", "-"):
        s = "0"
    return s
