"""Moved to :mod:`repulsionpak.render.png` (kept importable from here)."""

from ..render.png import render_png

__all__ = ["render_png"]
