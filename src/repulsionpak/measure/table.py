"""A packing's measures as a short human-readable table: :func:`format_table`.

What ``repulsionpak evaluate`` prints without ``--json``: one aligned row per measure of
an :func:`repulsionpak.measure.evaluate` result (missing values shown as ``-``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .contact import q_at

__all__ = ["format_table"]


def _fmt(x: Any, nd: int = 4) -> str:
    if x is None:
        return "-"
    if isinstance(x, (int, np.integer)) and not isinstance(x, bool):
        return str(int(x))
    x = float(x)
    if x != 0 and (abs(x) >= 1e5 or abs(x) < 1e-3):
        return f"{x:.3e}"
    return f"{x:.{nd}f}"


def format_table(result: dict) -> str:
    """A short human-readable summary of an :func:`evaluate` result (aligned columns)."""
    g = result.get("gap") or {}
    d = result.get("deformation") or {}
    rows: list[tuple[str, str]] = []
    if "file" in result:
        rows.append(("file", str(result["file"])))
    rows += [
        ("elements", f"{result.get('n_primary', 0)} primary, {result.get('n_secondary', 0)} secondary"),
        ("area fraction", _fmt(result.get("area_fraction"))),
        ("overlap area", _fmt(result.get("overlap_area"))),
        ("outside container", _fmt(result.get("n_outside"))),
        ("gap requested", _fmt(g.get("requested"))),
        ("gap median", _fmt(g.get("median"))),
        ("gap p10 / p90", f"{_fmt(g.get('p10'))} / {_fmt(g.get('p90'))}"),
        ("gap min", _fmt(g.get("min"))),
        ("deformation mean / max", f"{_fmt(d.get('mean'))} / {_fmt(d.get('max'))}"),
    ]
    if "outside_area" in result:
        rows.append(("outside area", _fmt(result.get("outside_area"))))
    e = result.get("edge") or {}
    if e:
        rows.append(("edge distance min", _fmt(e.get("min"))))
        margin = e.get("margin")
        rows.append((f"closer than 0.98 × {_fmt(margin)} to edge" if margin is not None else "closer than the margin",
                     _fmt(e.get("n_below_margin"))))
    dd = result.get("distortion") or {}
    if dd.get("median") is not None:
        rows.append(("distortion median / p95", f"{_fmt(dd.get('median'))} / {_fmt(dd.get('p95'))}"))
        prim = (dd.get("by_kind") or {}).get("primary") or {}
        if prim.get("median") is not None and dd.get("by_kind", {}).get("secondary"):
            rows.append(("  primaries: median / p95 / max",
                         f"{_fmt(prim['median'])} / {_fmt(prim['p95'])} / {_fmt(prim['max'])}"))
    s = result.get("scp") or {}
    if s.get("q"):
        rows.append(("Q_s(0) = 1 - A (raster)", _fmt(s["q"][0])))
    if result.get("scp_at_half_gap") is not None:
        rows.append(("Q_s(gap/2)", _fmt(result["scp_at_half_gap"])))
    if result.get("scp_ratio") is not None:
        rows.append(("Q_s(gap/2) / Q_s(0)", _fmt(result["scp_ratio"])))
    if "area_fraction_primary" in result:
        rows.append(("primaries alone: area fraction", _fmt(result.get("area_fraction_primary"))))
        rows.append(("primaries alone: Q_s(gap/2) / Q_s(0)", _fmt(result.get("scp_ratio_primary"))))
        rows.append(("smallest secondary / median primary (√area)", _fmt(result.get("smallest_secondary_rel"))))
    gap = g.get("requested")
    if gap and s.get("r"):
        for f in (0.25, 0.75, 1.0):
            rows.append((f"Q_s({f:g} gap)", _fmt(q_at(s, f * gap))))
    w = max(len(k) for k, _ in rows)
    head = f"{'metric':<{w}}  value"
    lines = [head, "-" * max(len(head), w + 2 + max(len(v) for _, v in rows))]
    lines += [f"{k:<{w}}  {v}" for k, v in rows]
    return "\n".join(lines)
