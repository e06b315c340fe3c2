"""The skin of a finely jagged outline: CPU time and peak memory (docs/benchmarks.md).

A 40,000-point noisy circle (radius alternating 40 / 40.3, scaled by SCALE), offset as a
packing at a gap of 4.6 offsets it (0.6 gap, skin tolerance 0.115). One process per scale,
since the peak RSS only grows:

    for s in 0.05 0.4 0.8 5; do python benchmarks/sawtooth_skin.py $s; done
"""

import resource
import sys
import time

import numpy as np
import shapely

from repulsionpak.geometry.outline import skin_polygon

n = 40000
t = 2 * np.pi * np.arange(n) / n
r = 40 + 0.3 * (np.arange(n) % 2)
for scale in [float(a) for a in sys.argv[1:]] or [0.4]:
    outline = shapely.Polygon(scale * np.c_[r * np.cos(t), r * np.sin(t)])
    t0 = time.process_time()
    skin = skin_polygon(outline, 2.76, detail=0.115)
    print(f"scale {scale}: {time.process_time() - t0:.2f} CPU s, skin {len(skin.exterior.coords)} vertices, "
          f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024} MB", flush=True)
