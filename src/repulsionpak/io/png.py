"""Moved to :mod:`repulsionpak.render.png` (kept importable from here)."""

from ..render.png import contact_sheet_png, png_bytes, render_png

__all__ = ["contact_sheet_png", "png_bytes", "render_png"]
