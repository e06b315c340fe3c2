"""Flow scenes (docs/flow.md): elongated elements following guide strokes, measured on the
output art.

Each scene packs a container with elements drawn here (ellipses, fish, leaves) along a
guide drawn here (a spiral, waves, spokes, an S), writes the packing, evaluates it as
``repulsionpak evaluate`` does, and measures the angle between each copy's axis and the
field at its centroid (:func:`repulsionpak.flow.alignment_angles`).

    python benchmarks/flow_scenes.py OUTDIR [--scene NAME ...] [--seed N] [--count N] [--png] [--inputs-only]
        [--bend]

prints one JSON line per scene: the alignment of the primaries and of all copies (median,
p90, max, degrees), the curvature match of the primaries' art with the streamlines
(:func:`curvature_stats`), the gap statistics relative to the gap, overlap, distortion
and the promises. ``--bend`` sets ``flow_bend`` on every element (outputs ``NAME-bend.*``).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

W = 1000.0  # containers are 1000 units wide


def _svg(body: str, w: float = W, h: float = W) -> str:
    return (f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {w:g} {h:g}" width="{w:g}" '
            f'height="{h:g}">\n{body}\n</svg>\n')


def _d(points: np.ndarray, closed: bool = False) -> str:
    s = "M " + " L ".join(f"{x:.2f} {y:.2f}" for x, y in points)
    return s + (" Z" if closed else "")


# -- elements (drawn facing +x: their axis is 0) ------------------------------------------

def ellipse_svg() -> str:
    return _svg('<ellipse cx="60" cy="20" rx="60" ry="20" fill="#4a7fb5"/>'
                '<ellipse cx="60" cy="20" rx="40" ry="8" fill="#a8c8e8"/>', 120, 40)


def fish_svg() -> str:
    t = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    body = np.column_stack([70 + 50 * np.cos(t), 25 + 20 * np.sin(t)])
    tail = np.array([[22, 25], [0, 8], [6, 25], [0, 42]])
    return _svg(f'<path d="{_d(tail, True)}" fill="#e8743b"/><path d="{_d(body, True)}" fill="#f4a259"/>'
                '<circle cx="100" cy="20" r="4" fill="#223"/>', 120, 50)


def leaf_svg() -> str:
    t = np.linspace(0, 1, 40)
    x = 20 + 100 * t
    top = np.column_stack([x, 25 - 22 * np.sin(np.pi * t) ** 0.8])
    bot = np.column_stack([x[::-1], 25 + 22 * np.sin(np.pi * t[::-1]) ** 0.8])
    stem = np.array([[0, 23], [22, 23], [22, 27], [0, 27]])
    return _svg(f'<path d="{_d(stem, True)}" fill="#3d6b35"/><path d="{_d(np.vstack([top, bot]), True)}" '
                'fill="#7bb661"/><path d="M 22 25 L 115 25" stroke="#3d6b35" stroke-width="2" fill="none"/>',
                125, 50)


def eel_svg() -> str:
    t = np.linspace(0, 2 * np.pi, 80, endpoint=False)
    body = np.column_stack([95 + 75 * np.cos(t), 20 + 11 * np.sin(t)])
    tail = np.array([[30, 20], [0, 4], [10, 20], [0, 36]])
    fin = np.array([[60, 12], [90, 2], [125, 11]])
    return _svg(f'<path d="{_d(tail, True)}" fill="#2a9d8f"/><path d="{_d(fin, True)}" fill="#2a9d8f"/>'
                f'<path d="{_d(body, True)}" fill="#8ecae6"/><circle cx="155" cy="17" r="3" fill="#223"/>',
                170, 40)


ELEMENTS = {"ellipse": ellipse_svg, "fish": fish_svg, "leaf": leaf_svg, "eel": eel_svg}


# -- containers and guides ------------------------------------------------------------

def disc_svg() -> str:
    return _svg('<circle cx="500" cy="500" r="480" fill="none" stroke="black"/>')


def band_svg() -> str:
    return _svg('<rect x="0" y="0" width="1000" height="500" fill="none" stroke="black"/>', W, 500)


def square_svg() -> str:
    return _svg('<rect x="10" y="10" width="980" height="980" fill="none" stroke="black"/>')


def spiral_guides() -> str:
    t = np.linspace(0.0, 5.5 * np.pi, 400)
    r = 40 + 440 * t / t[-1]
    pts = np.column_stack([500 + r * np.cos(t), 500 + r * np.sin(t)])
    return _svg(f'<path d="{_d(pts)}" fill="none" stroke="black"/>')


def waves_guides() -> str:
    paths = []
    for y0 in (60, 250, 440):
        x = np.linspace(-20, 1020, 200)
        pts = np.column_stack([x, y0 + 50 * np.sin(2 * np.pi * x / 500)])
        paths.append(f'<path d="{_d(pts)}" fill="none" stroke="black"/>')
    return _svg("\n".join(paths), W, 500)


def radial_guides() -> str:
    paths = []
    for k in range(12):
        a = 2 * np.pi * k / 12
        pts = np.array([[500 + 80 * math.cos(a), 500 + 80 * math.sin(a)],
                        [500 + 490 * math.cos(a), 500 + 490 * math.sin(a)]])
        paths.append(f'<path d="{_d(pts)}" fill="none" stroke="black"/>')
    return _svg("\n".join(paths))


def s_guides() -> str:
    t = np.linspace(0, 1, 300)
    # an S: the upper bowl counter-clockwise on screen, then the lower one clockwise
    a1 = np.pi * (0.1 + 1.4 * t[:150] / t[149])
    up = np.column_stack([500 + 300 * np.cos(-a1 + np.pi * 1.5 + np.pi), 280 + 260 * np.sin(-a1 + np.pi * 1.5 + np.pi)])
    a2 = np.pi * (1.4 * t[:150] / t[149])
    lo = np.column_stack([500 + 300 * np.cos(-np.pi / 2 + a2), 720 + 260 * np.sin(-np.pi / 2 + a2)])
    return _svg(f'<path d="{_d(np.vstack([up, lo]))}" fill="none" stroke="black"/>')


SCENES = {
    "spiral": (disc_svg, spiral_guides, ["fish", "leaf"]),
    "waves": (band_svg, waves_guides, ["fish", "ellipse"]),
    "radial": (disc_svg, radial_guides, ["leaf", "ellipse"]),
    "s": (square_svg, s_guides, ["ellipse", "fish", "leaf"]),
    "school": (disc_svg, spiral_guides, ["fish", "eel"]),
}


#: scenes whose elements have a directed axis (manifest ``axis``): a school swims one way
SCENE_AXIS = {"school": 0.0}


def write_scene(name: str, outdir: Path) -> tuple[Path, Path, list[Path]]:
    """Write scene ``name``'s container, guides and elements into ``outdir``."""
    container, guides, elems = SCENES[name]
    outdir.mkdir(parents=True, exist_ok=True)
    c = outdir / f"{name}-container.svg"
    c.write_text(container())
    g = outdir / f"{name}-guides.svg"
    g.write_text(guides())
    files = []
    for e in elems:
        f = outdir / f"{e}.svg"
        f.write_text(ELEMENTS[e]())
        files.append(f)
    return c, g, files


def run_scene(name: str, outdir: Path, seed: int = 1, count: int | None = None, png: bool = False,
              bend: bool = False) -> dict:
    import dataclasses

    from repulsionpak import load_container, load_elements, pack
    from repulsionpak.flow import alignment_angles, field_from_guides, load_guides
    from repulsionpak.measure import check_promises, evaluate_file
    from repulsionpak.params import Params, PlacementParams
    from repulsionpak.types import ElementControls

    c, g, files = write_scene(name, outdir)
    container = load_container(c)
    elements = load_elements(files)
    axis = SCENE_AXIS.get(name)
    if bend or axis is not None:
        elements = [dataclasses.replace(e, controls=ElementControls(axis=axis, flow_bend=bend)) for e in elements]
    field = field_from_guides(load_guides(g), container.region.bounds)
    params = Params(seed=seed, placement=PlacementParams(count=count))
    packing = pack(container, elements, params, flow=field)
    tag = f"{name}-bend" if bend else name
    out = outdir / f"{tag}.svg"
    packing.save(out)
    if png:
        (outdir / f"{tag}.png").write_bytes(packing.png_bytes(900))
    primaries = [p for p in packing.placed if p.kind == "primary"]
    prim = alignment_angles(primaries, elements, field)
    every = alignment_angles(packing.placed, elements, field)
    ev = evaluate_file(out, sources=elements)
    ev["promises"] = check_promises(ev, {e.source: _category(e) for e in elements},
                                    sources=[p.source for p in packing.placed])
    return {"scene": tag, "primary": prim.to_dict(), "all": every.to_dict(),
            "curvature": curvature_stats(primaries, elements, field, params), "evaluate": _brief(ev),
            "straightened": len(packing.verification.straightened)}


def curvature_stats(placed, elements, field, params, min_turn: float = 5.0) -> dict:
    """The curvature match of the copies (:func:`repulsionpak.flow.bend.curvature_match`),
    as turnings over each copy's length (degrees): the median |art − streamline|; over
    the copies whose streamline turns ≥ ``min_turn``°: the median relative error
    |κ_art − κ_stream| / |κ_stream|, the same against the capped target (the streamline's
    turning limited to the element's bend cap, :func:`repulsionpak.flow.hook.bend_cap`),
    and the share bent the right way."""
    from repulsionpak.flow.align import element_axis
    from repulsionpak.flow.bend import curvature_match, source_axis
    from repulsionpak.flow.hook import bend_cap

    m = curvature_match(placed, elements, field)
    by = {e.source: e for e in elements}
    caps = {k: bend_cap(e, source_axis(e.controls, element_axis(e)[0]), params) for k, e in by.items()}
    art = np.degrees(m["art"] * m["length"])
    stream = np.degrees(m["stream"] * m["length"])
    cap = np.degrees(np.array([caps[k] for k in m["source"]]))
    target = np.clip(stream, -cap, cap)
    big = np.abs(stream) >= min_turn
    r = lambda v: round(float(v), 3)  # noqa: E731
    return {"n": int(len(art)), "n_turning": int(big.sum()),
            "art_turn_median": r(np.median(np.abs(art))), "stream_turn_median": r(np.median(np.abs(stream))),
            "cap_median": r(np.median(cap)),
            "turn_error_median": r(np.median(np.abs(art - stream))),
            "rel_error_median": r(np.median(np.abs(art - stream)[big] / np.abs(stream[big]))) if big.any() else None,
            "rel_error_capped_median": r(np.median(np.abs(art - target)[big] / np.abs(target[big]))) if big.any() else None,
            "right_sign": r(np.mean(np.sign(art[big]) == np.sign(stream[big]))) if big.any() else None}


def _category(element) -> str:
    """``convex`` for art covering ≥ 0.9 of its hull (the stricter distortion promise),
    else ``spiky``."""
    from repulsionpak.art_area import art_area

    g = art_area(element.paths)
    return "convex" if g.area >= 0.9 * g.convex_hull.area else "spiky"


def _brief(ev: dict) -> dict:
    g = ev["gap"]
    d = ev.get("distortion") or {}
    return {"area_fraction": round(ev["area_fraction"], 4), "overlap_area": ev["overlap_area"],
            "outside": ev["n_outside"], "primaries": ev["n_primary"], "secondaries": ev["n_secondary"],
            "gap_median_rel": round(g["median"] / g["requested"], 3),
            "gap_p10_rel": round(g["p10"] / g["requested"], 3),
            "distortion_p95": None if d.get("p95") is None else round(d["p95"], 4),
            "promises": {k: v.get("ok") if isinstance(v, dict) else v for k, v in ev["promises"].items()}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", type=Path)
    ap.add_argument("--scene", action="append", choices=sorted(SCENES))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--count", type=int, default=None)
    ap.add_argument("--png", action="store_true")
    ap.add_argument("--inputs-only", action="store_true", help="only write the scenes' SVG inputs")
    ap.add_argument("--bend", action="store_true", help="every element bends along the flow (flow_bend)")
    a = ap.parse_args()
    for name in a.scene or list(SCENES):
        if a.inputs_only:
            write_scene(name, a.outdir)
            continue
        print(json.dumps(run_scene(name, a.outdir, a.seed, a.count, a.png, a.bend)), flush=True)


if __name__ == "__main__":
    main()
