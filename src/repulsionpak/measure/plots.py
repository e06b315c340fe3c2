"""Plots of the spherical contact probability, as PNG bytes.

:func:`scp_plot_png` overlays Q_s(r) of several packings with the ideal stripes line;
:func:`scp_bands_png` shows the mean ± one standard deviation of groups of packings (the
paper's Fig. 10). They return the PNG's bytes: writing the file is the caller's
(:func:`repulsionpak.io.files.atomic_write_bytes` in the CLI). matplotlib is
imported inside the plotting functions only, so the library imports without it.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError

__all__ = ["scp_plot_png", "scp_bands_png"]


def _scp_of(result: dict) -> dict:
    return result["scp"] if "scp" in result else result


def _gap_of(result: dict) -> float | None:
    g = result.get("gap")
    if isinstance(g, dict):
        return g.get("requested")
    if isinstance(g, (int, float)):
        return float(g)
    return None


def _new_figure():
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 4.5), dpi=120)
    FigureCanvasAgg(fig)
    return fig


def _png(fig) -> bytes:
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def _decorate(ax, gap: float | None, r_hi: float) -> None:
    if gap:
        ax.axvline(0.5 * gap, color="0.4", lw=0.8, ls=":", label=r"$r = d_{gap}/2$")
    ax.set_xlim(0, r_hi if r_hi > 0 else 1)
    ax.set_ylim(bottom=0)
    ax.set_xlabel("r (container units)")
    ax.set_ylabel(r"$Q_s(r)$")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")


def _r_extent(curves: list[tuple[np.ndarray, np.ndarray]], gap: float | None) -> float:
    """x range of a plot: up to where every curve has (nearly) reached 0, >= 1.5 gap."""
    hi = 0.0
    for r, q in curves:
        if len(r) == 0:
            continue
        small = np.flatnonzero(q <= 1e-3 * max(q[0], 1e-12))
        hi = max(hi, float(r[small[0]]) if len(small) else float(r[-1]))
    if gap:
        hi = max(hi * 1.05, 1.5 * gap)
    return hi


def scp_plot_png(results: list[tuple[str, dict]], gap: float | None = None, ideal: bool = True) -> bytes:
    """A PNG plot of Q_s(r) of several packings overlaid.

    Parameters
    ----------
    results : list of (str, dict)
        ``(label, result)``, ``result`` an :func:`~repulsionpak.measure.evaluate` or
        :func:`~repulsionpak.measure.scp` dict.
    gap : float, optional
        Adds a vertical marker at gap/2 (default: the first result's requested gap).
    ideal : bool
        With a gap, also the ideal stripes line from (0, Q_s(0)) to (gap/2, 0) (dashed;
        one per curve in its colour for up to 3 curves, else one at the mean Q_s(0)).

    Returns
    -------
    bytes
        The PNG file's bytes; the caller writes them.

    Raises
    ------
    ParameterError
        When ``results`` is empty.
    ImportError
        When matplotlib is not installed.
    """
    if not results:
        raise ParameterError("scp_plot_png needs at least one result")
    if gap is None:
        gap = next((g for g in (_gap_of(res) for _, res in results) if g), None)
    fig = _new_figure()
    ax = fig.add_subplot(1, 1, 1)
    q0s, curves = [], []
    for k, (label, res) in enumerate(results):
        s = _scp_of(res)
        r = np.asarray(s["r"], dtype=float)
        q = np.asarray(s["q"], dtype=float)
        (line,) = ax.plot(r, q, lw=1.6, label=str(label), color=f"C{k % 10}")
        curves.append((r, q))
        q0s.append(float(q[0]) if len(q) else 0.0)
        if ideal and gap and len(results) <= 3:
            ax.plot([0, 0.5 * gap], [q0s[-1], 0], ls="--", lw=1.0, color=line.get_color(),
                    label=f"ideal stripes ({label})")
    if ideal and gap and len(results) > 3:
        ax.plot([0, 0.5 * gap], [float(np.mean(q0s)), 0], ls="--", lw=1.2, color="k",
                label=r"ideal stripes (mean $Q_s(0)$)")
    ax.set_title("Spherical contact probability")
    _decorate(ax, gap, _r_extent(curves, gap))
    return _png(fig)


def scp_bands_png(groups: dict[str, list[dict]], gap: float | None) -> bytes:
    """A PNG plot of the mean ± one standard deviation of Q_s(r) per group (Fig. 10).

    Parameters
    ----------
    groups : dict of str to list of dict
        A label (e.g. ``"k_e = 10"``) → :func:`~repulsionpak.measure.evaluate` /
        :func:`~repulsionpak.measure.scp` results.
    gap : float or None
        Adds the ideal stripes line at the mean Q_s(0) and a marker at gap/2.

    Returns
    -------
    bytes
        The PNG file's bytes; the caller writes them.

    Raises
    ------
    ParameterError
        When every group is empty.

    Notes
    -----
    Each curve is interpolated onto a common r grid (Q_s held at its last value beyond
    its own r range) before averaging.
    """
    groups = {k: v for k, v in groups.items() if v}
    if not groups:
        raise ParameterError("scp_bands_png needs at least one non-empty group")
    curves = {k: [_scp_of(res) for res in v] for k, v in groups.items()}
    r_top = _r_extent(
        [(np.asarray(s["r"], float), np.asarray(s["q"], float)) for v in curves.values() for s in v], gap
    )
    rr = np.linspace(0.0, r_top if r_top > 0 else 1.0, 301)
    fig = _new_figure()
    ax = fig.add_subplot(1, 1, 1)
    q0s = []
    for k, (label, ss) in enumerate(curves.items()):
        Q = np.array([np.interp(rr, np.asarray(s["r"], float), np.asarray(s["q"], float)) for s in ss])
        mean, std = Q.mean(axis=0), Q.std(axis=0)
        color = f"C{k % 10}"
        ax.fill_between(rr, mean - std, mean + std, color=color, alpha=0.25, lw=0)
        ax.plot(rr, mean, color=color, lw=1.8, label=f"{label} (n={len(ss)})")
        q0s.append(float(mean[0]))
    if gap:
        ax.plot([0, 0.5 * gap], [float(np.mean(q0s)), 0], ls="--", lw=1.2, color="k",
                label=r"ideal stripes (mean $Q_s(0)$)")
    ax.set_title(r"Spherical contact probability (mean $\pm$ std)")
    _decorate(ax, gap, float(rr[-1]))
    return _png(fig)
