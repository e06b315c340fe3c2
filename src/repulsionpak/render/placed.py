"""Map a copy's art through its deformed mesh and fit smooth curves to it.

The art's exact source curves are sampled densely in the rest mesh, mapped through the
deformation map (:mod:`.deform`: thin-plate-spline interpolation of the mesh vertices by
default) and fitted with lines, quadratic and cubic Béziers within a tolerance
(:mod:`.fit`). The fitted curves, rounded as written, are what the SVG and PDF hold; each
placed path's ``subpaths`` are a fine flattening of them, so every metric and check sees
exactly what is written.

Everything here works on one copy: a template (:class:`repulsionpak.preprocess.Template`,
read for its ``verts``, ``tris``, ``n_skin``, ``scale``, ``outline`` and ``element``) and
the copy's mesh vertices; the simulation's side, which copies and where their vertices are,
is :mod:`repulsionpak.sim.art`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..params import RenderParams
from ..types import ArtPath, PlacedArt, ShapeSource, transformed_paths
from ..geometry.curves import decimals_for, flatten_subpath, round_curves
from .deform import map_plan
from .fit import fit_subpath

#: written curves are fitted to this share of the tolerance; rounding the coordinates
#: (at most tol/5) and the error between samples use the rest
FIT_SHARE = 0.75
#: the flattening of the written curves used by metrics and checks, × tolerance
FLATTEN_SHARE = 0.1


def similarity_fit(rest: np.ndarray, cur: np.ndarray) -> tuple[float, float]:
    """Best similarity transform (rotation, uniform scale, translation) from ``rest`` to
    ``cur`` (both (n, 2)), least squares. Returns (scale, rms residual)."""
    a = rest - rest.mean(axis=0)
    b = cur - cur.mean(axis=0)
    za = a[:, 0] + 1j * a[:, 1]
    zb = b[:, 0] + 1j * b[:, 1]
    denom = float(np.vdot(za, za).real)
    if denom <= 0:
        return 1.0, 0.0
    c = np.vdot(za, zb) / denom  # complex scale·rotation
    resid = zb - c * za
    return float(abs(c)), float(np.sqrt(np.mean(np.abs(resid) ** 2)))


def deformation(rest: np.ndarray, cur: np.ndarray) -> float:
    """Dimensionless deformation of a mesh: RMS distance of its vertices from the best
    similarity transform of the rest shape, divided by the RMS radius of the deformed mesh
    (0 for a rigid motion plus uniform scaling)."""
    scale, rms = similarity_fit(rest, cur)
    b = cur - cur.mean(axis=0)
    size = float(np.sqrt(np.mean((b ** 2).sum(axis=1))))
    return rms / size if size > 0 else 0.0


def affine_fit(rest: np.ndarray, cur: np.ndarray) -> np.ndarray:
    """Least-squares affine map (3, 3) from ``rest`` (n, 2) to ``cur`` (n, 2)."""
    a = np.column_stack([rest, np.ones(len(rest))])
    ata = a.T @ a
    m = np.eye(3)
    det = float(np.linalg.det(ata)) if len(rest) >= 3 else 0.0
    if not abs(det) > 1e-12 * max(1.0, float(np.abs(ata).max())) ** 3:
        return m  # degenerate rest shape: no usable affine fit
    m[:2, :] = (_inv3(ata) @ (a.T @ cur)).T
    return m


def _inv3(m: np.ndarray) -> np.ndarray:
    """Inverse of a 3 × 3 matrix by cofactors (no LAPACK call per copy)."""
    c = np.array([[m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1], m[0, 2] * m[2, 1] - m[0, 1] * m[2, 2], m[0, 1] * m[1, 2] - m[0, 2] * m[1, 1]],
                  [m[1, 2] * m[2, 0] - m[1, 0] * m[2, 2], m[0, 0] * m[2, 2] - m[0, 2] * m[2, 0], m[0, 2] * m[1, 0] - m[0, 0] * m[1, 2]],
                  [m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0], m[0, 1] * m[2, 0] - m[0, 0] * m[2, 1], m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]]])
    return c / (m[0, 0] * c[0, 0] + m[0, 1] * c[1, 0] + m[0, 2] * c[2, 0])


def _rest_matrix(t) -> np.ndarray:
    """File units of the element -> the template's rest coordinates."""
    s, c = t.scale, t.outline.center
    return np.array([[s, 0.0, -s * c[0]], [0.0, s, -s * c[1]], [0.0, 0.0, 1.0]])


def curve_tolerance(size: float, gap: float | None, params: RenderParams) -> float:
    """Largest distance allowed between written curves and the exact mapped outline:
    ``params.curve_tolerance`` × the copy's size, at most ``params.max_gap_share`` × gap."""
    tol = params.curve_tolerance * max(size, 1e-12)
    if gap is not None and gap > 0:
        tol = min(tol, params.max_gap_share * gap)
    return tol


def refined(art: ArtPath, tol: float | None) -> ArtPath:
    """``art`` as a copy at curve tolerance ``tol`` is written: its exact curves rounded as
    the writer rounds them and flattened at ``FLATTEN_SHARE`` × ``tol``, so that checks and
    metrics see what is written (a source element's own flattening is relative to the
    element's size, up to a few hundredths of a gap off on copies ~50 gaps across). Art
    without curves, or ``tol`` None, is returned as it is."""
    src = art.source
    if tol is None or not tol > 0 or src is None or not src.curves:
        return art
    return written(art, round_curves(src.curves, decimals_for(tol)), tol)


def written(art: ArtPath, curves: tuple, tol: float) -> ArtPath:
    """``art`` with ``curves`` (its curves already rounded as the writer rounds them at
    ``tol``: :func:`~repulsionpak.geometry.curves.round_curves`) as its source and their
    flattening at ``FLATTEN_SHARE`` × ``tol`` as its subpaths (:func:`refined`'s last
    step); ``art`` itself when no curve flattens to two points or more.

    Notes
    -----
    Apart from :func:`refined` so that a caller rounding the curves of many copies in one
    array (the dents: :mod:`repulsionpak.verify.dents`) makes the same path to the bit.
    """
    flat = tuple(flatten_subpath(c, FLATTEN_SHARE * tol) for c in curves)
    keep = [i for i, f in enumerate(flat) if len(f) >= 2]
    if not keep:
        return art
    return ArtPath(tuple(flat[i] for i in keep), tuple(curves[i].closed for i in keep), art.style,
                   source=dataclasses.replace(art.source, curves=tuple(curves[i] for i in keep)))


def render_copy(t, verts: np.ndarray, gap: float | None = None,
                params: RenderParams = RenderParams()) -> tuple[list[ArtPath], float]:
    """The written art of one copy of template ``t`` whose mesh vertices are ``verts``
    (container units); returns (paths, tolerance used)."""
    plan = map_plan(t, params.smooth_map, params.samples, params.smoothing)
    q, g = plan.apply(verts)
    size = float(np.hypot(*np.ptp(q, axis=0))) if len(q) else 0.0
    tol = curve_tolerance(size, gap, params)
    to_copy = affine_fit(t.verts, verts) @ _rest_matrix(t)
    paths = []
    for art, subs, starts in zip(t.element.paths, plan.curves, plan.seg_start):
        curves = []
        for sub, st in zip(subs, starts):
            c = fit_subpath(sub.order, st, sub.closed, q, g, plan.t, FIT_SHARE * tol,
                            params.angle_tolerance)
            if c is not None:
                curves.append(c)
        if not curves:
            continue
        src = art.source
        written = ShapeSource(
            curves=tuple(curves),
            tag="path",
            matrix=to_copy @ (src.matrix if src is not None else np.eye(3)),
            fill_paint=src.fill_paint if src is not None else None,
            stroke_paint=src.stroke_paint if src is not None else None,
            local_bbox=src.local_bbox if src is not None else None,
            id=src.id if src is not None else None,
        )
        path = refined(ArtPath((), (), art.style, source=written), tol)
        if path.subpaths:
            paths.append(path)
    return paths, tol


def placed_copy(t, verts: np.ndarray, kind: str, gap: float | None = None,
                params: RenderParams = RenderParams()) -> PlacedArt:
    """The deformed art of one copy of template ``t`` whose mesh vertices are ``verts``
    (container units), as smooth curves (see the module docstring).

    Parameters
    ----------
    t : Template
        The copy's template.
    verts : (n, 2) array
        The copy's mesh vertices in container units.
    kind : str
        ``primary`` or ``secondary``, carried into the result.
    gap : float, optional
        The packing's gap: the curve tolerance is at most ``params.max_gap_share`` of it.
    params : RenderParams
        Curve fitting and the deformation map.

    Returns
    -------
    PlacedArt
        The written paths, with the copy's stroke scale, deformation, similarity frame and
        curve tolerance.
    """
    paths, tol = render_copy(t, verts, gap, params)
    scale, _ = similarity_fit(t.verts, verts)
    return PlacedArt(t.element.source, kind, tuple(paths),
                     stroke_scale=t.scale * scale, deformation=deformation(t.verts, verts),
                     paint_servers=dict(t.element.paint_servers),
                     frame=similarity_matrix(t.verts, verts), tolerance=tol)


def similarity_matrix(rest: np.ndarray, cur: np.ndarray) -> np.ndarray:
    """(3, 3) least-squares similarity (rotation, uniform scale, translation) ``rest`` -> ``cur``."""
    a, b = rest.mean(axis=0), cur.mean(axis=0)
    za = (rest - a) @ np.array([1.0, 1j])
    zb = (cur - b) @ np.array([1.0, 1j])
    den = float(np.vdot(za, za).real)
    c = complex(np.vdot(za, zb) / den) if den > 0 else 1.0 + 0j
    m = np.array([[c.real, -c.imag, 0.0], [c.imag, c.real, 0.0], [0.0, 0.0, 1.0]])
    m[:2, 2] = b - m[:2, :2] @ a
    return m


def rest_copy(t, kind: str) -> PlacedArt:
    """Template ``t``'s art undeformed, in its template's frame (centred, at the template's
    scale), with its curves: the shape a copy should keep. ``frame`` is the identity.

    Parameters
    ----------
    t : Template
        The copy's template.
    kind : str
        ``primary`` or ``secondary``, carried into the result.

    Returns
    -------
    PlacedArt
        The art at rest, deformation 0.
    """
    c, k = t.outline.center, t.scale
    paths = transformed_paths(t.element.paths, lambda p: (np.asarray(p) - c) * k)
    return PlacedArt(t.element.source, kind, paths, stroke_scale=t.scale, deformation=0.0,
                     paint_servers=dict(t.element.paint_servers), frame=np.eye(3))


def is_convex(template, solidity: float = 0.9) -> bool:
    """True when the template's art covers at least ``solidity`` of its convex hull."""
    g = template.outline.geometry
    hull = g.convex_hull.area
    return hull > 0 and g.area >= solidity * hull
