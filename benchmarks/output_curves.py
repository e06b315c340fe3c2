"""Output curves before and after: curve share, bytes per copy, kinks, deviation, time.

    PYTHONPATH=src python benchmarks/output_curves.py [--scenes discs squares letters badges examples]

Packs each scene once (fixed seed) and renders its final meshes twice:

* **before**: the previous renderer — the reader's flattened polylines mapped vertex by
  vertex with the per-triangle barycentric map, written as ``M x y L x y ...`` with 4
  decimals;
* **after**: the ``render`` package — the source curves mapped densely through the smooth
  (thin-plate-spline) map and fitted with lines, quadratic and cubic Béziers.

Prints one Markdown table row per scene for docs/quality.md ("Output curves").
"""

from __future__ import annotations

import argparse
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

from curve_scenes import write_scene  # noqa: E402

from repulsionpak import examples, load_container, load_elements, pack  # noqa: E402
from repulsionpak.geometry.mesh import apply_binding  # noqa: E402
from repulsionpak.params import Params, PlacementParams  # noqa: E402
from repulsionpak.render import render_copy  # noqa: E402
from repulsionpak.sim.art import element_vertices, placed_art  # noqa: E402
from repulsionpak.render.deform import tps_weights  # noqa: E402
from repulsionpak.render.quality import (curve_share, deviation, exact_outlines,  # noqa: E402
                                         kink_stats)
from repulsionpak.render.svg import _art_path_xml, _attrs, _path_d, _style_attrs  # noqa: E402


def _source_bytes(files) -> dict[str, int]:
    """Markup of each element file's shapes (namespace stripped), by element name."""
    out = {}
    for f in files:
        root = ET.parse(f).getroot()
        n = 0
        for e in root.iter():
            tag = e.tag.rsplit("}", 1)[-1]
            if tag in ("path", "circle", "ellipse", "rect", "polygon", "polyline", "line", "use"):
                n += len(ET.tostring(e, encoding="unicode").replace("ns0:", "").replace(
                    ' xmlns:ns0="http://www.w3.org/2000/svg"', "").strip())
        out[Path(f).stem] = n
    return out


def _legacy_bytes(t, verts) -> tuple[int, list]:
    pts = apply_binding(verts, t.tris, t.art_tri, t.art_bary)
    total, k, polys = 0, 0, []
    for art in t.element.paths:
        subs = []
        for sp in art.subpaths:
            subs.append(pts[k:k + len(sp)])
            k += len(sp)
        d = _path_d(subs, art.closed)
        total += len(f"<path{_attrs(_style_attrs(art.style, 1.0))} d=\"{d}\"/>")
        polys.append((subs, art.closed))
    return total, polys


def scene(name: str, workdir: Path):
    if name == "examples":
        cont = examples.container_file("heart")
        files = examples.element_files()
        params = Params(gap=examples.DEFAULT_GAP, seed=1)
    else:
        cont, files = write_scene(workdir / name, name)
        params = Params(seed=1, placement=PlacementParams(count={"letters": 30}.get(name, 20)))
    c = load_container(cont)
    els = load_elements(files)
    t0 = time.perf_counter()
    p = pack(c, els, params)
    return p, files, time.perf_counter() - t0


def measure(name: str, workdir: Path) -> dict:
    p, files, seconds = scene(name, workdir)
    src = _source_bytes(files)
    m = p.model
    t0 = time.perf_counter()
    placed_art(p.templates, m, p.state, p.frame)  # includes building the per-template plans
    t_first = time.perf_counter() - t0
    t0 = time.perf_counter()
    placed_art(p.templates, m, p.state, p.frame)
    t_again = time.perf_counter() - t0
    rows = {"before": [], "after": []}
    kinks = {"before": [], "after": []}
    devs, dev_pl = [], []
    for e in range(m.n_elements):
        t = p.templates[m.template_index[e]]
        verts = element_vertices(m, p.state, e) * p.frame.unit
        name_e = t.element.name
        # before
        nb, polys = _legacy_bytes(t, verts)
        segs_b = sum(len(s) - (0 if cl else 1) for subs, closed in polys for s, cl in zip(subs, closed))
        rows["before"].append((nb / src[name_e], 0, segs_b))
        # after
        paths, tol = render_copy(t, verts, p.gap)
        na = sum(len(_art_path_xml(a, 1.0, "")) for a in paths)
        cs = curve_share(paths)
        rows["after"].append((na / src[name_e], cs[0], cs[1]))
        devs.append(deviation(paths, exact_outlines(t, verts), tol) / tol)
        # distance between the smooth and the barycentric map at the art's vertices
        art = (np.concatenate([s for a in t.element.paths for s in a.subpaths]) - t.outline.center) * t.scale
        W, _ = tps_weights(t.verts, art)
        dev_pl.append(float(np.abs(W @ verts - apply_binding(verts, t.tris, t.art_tri, t.art_bary)).max()) / p.gap)
        if name_e == "disc":  # (jump at 400 samples, largest turn at 4000 samples)
            w = paths[0].source.curves[0]
            ex = exact_outlines(t, verts, per_segment=256)[0][0][:-1]
            kinks["after"].append((kink_stats(w)[1], kink_stats(w, 4000)[0], kink_stats(ex)[1]))
            kinks["before"].append((kink_stats(polys[0][0][0])[1], kink_stats(polys[0][0][0], 4000)[0], 0))
    out = {"scene": name, "copies": m.n_elements, "primaries": sum(k == "primary" for k in m.kind), "pack_s": seconds, "render_first_s": t_first,
           "render_s": t_again, "dev_over_tol": max(devs), "smooth_vs_pl_over_gap": max(dev_pl)}
    for k in ("before", "after"):
        r = np.array(rows[k])
        out[f"{k}_bytes_ratio"] = float(r[:, 0].mean())
        out[f"{k}_bytes_ratio_max"] = float(r[:, 0].max())
        prim = np.array([kd == "primary" for kd in m.kind])
        out[f"{k}_bytes_ratio_primary"] = float(r[prim, 0].mean())
        out[f"{k}_curve_share"] = float(r[:, 1].sum() / r[:, 2].sum())
        out[f"{k}_kink"] = np.max(kinks[k], axis=0) if kinks[k] else None
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scenes", nargs="*", default=["discs", "squares", "letters", "badges", "examples"])
    ap.add_argument("--workdir", default="/tmp/repulsionpak-output-curves")
    args = ap.parse_args()
    print("| scene | copies | curve share before → after | bytes/copy ÷ source before → after (max) | primaries only, after "
          "| disc: turning jump, 400 samples, before → after (exact map) | disc: largest turn, 4000 samples, "
          "before → after | deviation ÷ tolerance | smooth − barycentric map ÷ gap | render s (first / again) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for s in args.scenes:
        r = measure(s, Path(args.workdir))
        r["copies"] = f"{r['copies']} ({r['primaries']} primary)"
        if r["after_kink"] is None:
            kink = "— | —"
        else:
            b, a = r["before_kink"], r["after_kink"]
            kink = f"{b[0]:.1f}° → {a[0]:.2f}° ({a[2]:.2f}°) | {b[1]:.1f}° → {a[1]:.2f}°"
        print(f"| {s} | {r['copies']} | {r['before_curve_share']:.0%} → {r['after_curve_share']:.0%} "
              f"| {r['before_bytes_ratio']:.2f} → {r['after_bytes_ratio']:.2f} ({r['after_bytes_ratio_max']:.2f}) | {r['after_bytes_ratio_primary']:.2f} "
              f"| {kink} | {r['dev_over_tol']:.2f} | {r['smooth_vs_pl_over_gap']:.3f} "
              f"| {r['render_first_s']:.2f} / {r['render_s']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
