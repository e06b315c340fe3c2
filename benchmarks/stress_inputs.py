"""Inputs of the stress scenes in docs/benchmarks.md (a scale probe's cliffs), written to OUTDIR:

    python benchmarks/stress_inputs.py /tmp/stress
    repulsionpak pack /tmp/stress/c_jagged5000.svg /tmp/stress/lib20 --seed 1 -o o.svg --report o.json

* ``lib20/e000.svg`` … ``e019.svg``: smooth random blobs (cubic Béziers), one colour each;
* ``c_jagged5000.svg``: a disc of radius 400 edged with 2,500 fine teeth (grass, fur, torn
  paper: 2,500 reflex corners);
* ``huge_d.svg``: an element outlined by 40,000 points, a circle whose radius alternates
  40 / 40.3 (a noisy trace whose teeth are real detail at the written tolerance);
* ``c_strip20.svg`` and ``bar50.svg``: a 20:1 strip container and a 50:1 bar;
* ``dots100.svg``: one element of 10 × 10 dots (100 subpaths); ``letters100.svg``: one
  element of 100 letters (``<text>``, A–Z in DejaVu Sans, 10 × 10).
"""

from __future__ import annotations

import math
import random
import sys
from pathlib import Path


def svg(w, h, body) -> str:
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}">\n'
            f'{body}\n</svg>\n')


def polygon_d(pts) -> str:
    return "M" + " L".join(f"{x:.4f},{y:.4f}" for x, y in pts) + " Z"


def blob_d(rng: random.Random, cx: float, cy: float, r: float, n: int) -> str:
    """A smooth closed blob through n jittered points (Catmull-Rom as cubic Béziers)."""
    ph = [rng.uniform(0, 6.28) for _ in range(3)]  # (the third is unused)
    pts = []
    for i in range(n):
        a = 2 * math.pi * i / n
        rr = r * (1 + 0.3 * (0.5 * math.sin(2 * a + ph[0]) + 0.3 * math.sin(3 * a + ph[1])
                             + rng.uniform(-0.2, 0.2)))
        pts.append((cx + rr * math.cos(a), cy + rr * math.sin(a)))
    d = f"M{pts[0][0]:.4f},{pts[0][1]:.4f}"
    for i in range(n):
        p0, p1, p2, p3 = pts[i - 1], pts[i], pts[(i + 1) % n], pts[(i + 2) % n]
        c1 = (p1[0] + (p2[0] - p0[0]) / 6, p1[1] + (p2[1] - p0[1]) / 6)
        c2 = (p2[0] - (p3[0] - p1[0]) / 6, p2[1] - (p3[1] - p1[1]) / 6)
        d += f" C{c1[0]:.4f},{c1[1]:.4f} {c2[0]:.4f},{c2[1]:.4f} {p2[0]:.4f},{p2[1]:.4f}"
    return d + " Z"


def main(out: Path) -> None:
    (out / "lib20").mkdir(parents=True, exist_ok=True)
    for i in range(20):
        rng = random.Random(i)
        colour = "#%06x" % rng.randrange(0x1000000)
        d = blob_d(rng, 50, 50, 35, rng.randint(5, 9))
        (out / "lib20" / f"e{i:03d}.svg").write_text(svg(100, 100, f'<path fill="{colour}" d="{d}"/>'))
    n = 5000
    teeth = [(500 + (400 + 15 * (2 * (i % 2) - 1) * (1 + math.sin(0.37 * i))) * math.cos(2 * math.pi * i / n),
              500 + (400 + 15 * (2 * (i % 2) - 1) * (1 + math.sin(0.37 * i))) * math.sin(2 * math.pi * i / n))
             for i in range(n)]
    (out / "c_jagged5000.svg").write_text(svg(1000, 1000, f'<path d="{polygon_d(teeth)}"/>'))
    n = 40000
    saw = [(50 + (40 + 0.3 * (i % 2)) * math.cos(2 * math.pi * i / n),
            50 + (40 + 0.3 * (i % 2)) * math.sin(2 * math.pi * i / n)) for i in range(n)]
    (out / "huge_d.svg").write_text(svg(100, 100, f'<path fill="#399" d="{polygon_d(saw)}"/>'))
    (out / "c_strip20.svg").write_text(svg(2000, 100, '<rect x="0" y="0" width="2000" height="100"/>'))
    (out / "bar50.svg").write_text(svg(500, 10, '<rect x="0" y="0" width="500" height="10" fill="#963"/>'))
    dots = "".join(f'<circle cx="{(i % 10 + .5) * 10:.3f}" cy="{(i // 10 + .5) * 10:.3f}" r="3"/>' for i in range(100))
    (out / "dots100.svg").write_text(svg(100, 100, f'<g fill="#336">{dots}</g>'))
    text = "".join(f'<text x="{(i % 10) * 10:.3f}" y="{(i // 10 + 1) * 10:.3f}" font-size="10.000" '
                   f'font-family="DejaVu Sans">{chr(65 + i % 26)}</text>' for i in range(100))
    (out / "letters100.svg").write_text(svg(100, 100, f'<g fill="#633">{text}</g>'))
    print(f"wrote the stress inputs to {out}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(Path(sys.argv[1]))
