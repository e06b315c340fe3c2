"""Procedural containers whose room is uneven: archipelagos, long thin bands, country-like
outlines (issue 41's yardstick for "size follows the space").

Everything is generated from a seed as plain SVG text (no downloaded map art): smooth
random blobs (a radius that varies smoothly with the angle) scattered without touching
for an archipelago, a sine-shaped band a few percent of its length wide, and one large
blob with blob-shaped peninsulas and a few satellite islands for a country. The frame is
1000 units wide; the gap of the acceptance scenes is a share of that width.
"""

from __future__ import annotations

import math

import numpy as np
import shapely

__all__ = ["blob", "archipelago", "band", "country", "container_svg", "REGION_KINDS"]


def blob(center, radius: float, rng: np.random.Generator, roughness: float = 0.25,
         n: int = 160, elongation: float = 1.0, angle: float | None = None) -> np.ndarray:
    """A smooth random closed outline, (n, 2): radius(θ) = radius · (1 + Σ_k a_k cos(kθ + φ_k)),
    k = 2..6, amplitudes ~ roughness / k, then stretched by ``elongation`` along ``angle``."""
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    r = np.ones(n)
    for k in range(2, 7):
        r += rng.uniform(0.3, 1.0) * roughness / k * np.cos(k * t + rng.uniform(0, 2 * np.pi))
    r = radius * np.maximum(r, 0.35)
    p = np.column_stack([r * np.cos(t) * elongation, r * np.sin(t)])
    a = rng.uniform(0, np.pi) if angle is None else angle
    c, s = math.cos(a), math.sin(a)
    return p @ np.array([[c, s], [-s, c]]) + np.asarray(center, float)


def archipelago(rng: np.random.Generator, n_islands: int | None = None, width: float = 1000.0,
                height: float = 700.0) -> list[np.ndarray]:
    """8-20 blob islands of very different sizes (radii log-uniform over a factor ~6), some
    elongated, none touching another (a channel of at least 1.5 % of the width)."""
    n_islands = int(rng.integers(8, 21)) if n_islands is None else n_islands
    radii = np.sort(np.exp(rng.uniform(np.log(25.0), np.log(150.0), n_islands)))[::-1]
    placed: list[shapely.Polygon] = []
    out = []
    for r in radii:
        for _ in range(400):
            e = rng.uniform(1.0, 2.2)
            c = rng.uniform([r * e, r * e], [width - r * e, height - r * e])
            p = blob(c, r, rng, elongation=e)
            poly = shapely.Polygon(p)
            if not poly.is_valid or not poly.within(shapely.box(5, 5, width - 5, height - 5)):
                continue
            if all(poly.distance(q) > 0.015 * width for q in placed):
                placed.append(poly)
                out.append(p)
                break
    return out


def band(width: float = 1000.0, thickness: float = 90.0, waves: float = 1.5, amplitude: float = 150.0,
         n: int = 240) -> list[np.ndarray]:
    """A long sine-shaped band ``thickness`` wide with round ends: one region."""
    x = np.linspace(thickness, width - thickness, n)
    y = amplitude * np.sin(2 * np.pi * waves * (x - x[0]) / (x[-1] - x[0])) + amplitude + thickness
    line = shapely.LineString(np.column_stack([x, y]))
    poly = line.buffer(0.5 * thickness, quad_segs=16)
    return [np.asarray(poly.exterior.coords)[:-1]]


def country(rng: np.random.Generator, width: float = 1000.0) -> list[np.ndarray]:
    """A large rough blob with three to five thin peninsulas and two to four small islands
    off its coast, fitted into a ``width`` × 0.86·``width`` frame: a mainland whose width
    varies several-fold."""
    c = np.array([0.5 * width, 0.42 * width])
    R = 0.22 * width
    body = shapely.Polygon(blob(c, R, rng, roughness=0.45, n=240))
    for _ in range(int(rng.integers(3, 6))):
        a = rng.uniform(0, 2 * np.pi)
        d = np.array([math.cos(a), math.sin(a)])
        w, e = rng.uniform(0.03, 0.05) * width, rng.uniform(3.0, 5.0)
        arm = blob(c + d * (0.8 * R + 0.8 * w * e), w, rng, roughness=0.15, elongation=e, angle=-a)
        body = body.union(shapely.Polygon(arm).buffer(0))
    body = body.buffer(0.01 * width).buffer(-0.01 * width)  # round the joints
    if body.geom_type != "Polygon":
        body = max(shapely.get_parts(body), key=lambda g: g.area)
    taken = [body]
    for _ in range(int(rng.integers(2, 5))):
        for _ in range(200):
            r = rng.uniform(0.02, 0.05) * width
            q = c + rng.uniform(-0.6, 0.6, 2) * width
            poly = shapely.Polygon(blob(q, r, rng, elongation=rng.uniform(1.0, 1.8)))
            if poly.is_valid and all(poly.distance(t) > 0.02 * width for t in taken):
                taken.append(poly)
                break
    minx, miny, maxx, maxy = shapely.MultiPolygon(taken).bounds
    f = min((0.98 * width) / (maxx - minx), (0.84 * width) / (maxy - miny))
    return [(np.asarray(t.exterior.coords)[:-1] - [minx, miny]) * f + 0.01 * width for t in taken]


REGION_KINDS = ("archipelago", "band", "country")


def container_svg(kind: str, seed: int = 1) -> str:
    """The SVG text of a ``kind`` container (one of :data:`REGION_KINDS`) drawn from ``seed``:
    one evenodd path, one subpath per region, in a 1000-unit-wide frame."""
    rng = np.random.default_rng(seed)
    if kind == "archipelago":
        parts, h = archipelago(rng), 700.0
    elif kind == "band":
        parts, h = band(), 480.0
    elif kind == "country":
        parts, h = country(rng), 860.0
    else:
        raise ValueError(f"unknown region container kind {kind!r}; one of {', '.join(REGION_KINDS)}")
    d = " ".join("M " + " L ".join(f"{x:.2f},{y:.2f}" for x, y in p) + " Z" for p in parts)
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="1000" height="{h:g}" viewBox="0 0 1000 {h:g}">'
            f'<path fill="#ccc" fill-rule="evenodd" d="{d}"/></svg>\n')
