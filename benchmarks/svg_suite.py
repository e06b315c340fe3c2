"""How the SVG reader compares with a browser-grade renderer: the resvg test suite.

Usage::

    python benchmarks/svg_suite.py SUITE_DIR [--jobs N] [--out JSON] [--timeout S] [--only SUBSTR]

``SUITE_DIR`` is resvg's ``crates/resvg/tests`` folder (its ``tests/`` holds each test SVG with
its reference PNG beside it, its ``fonts/`` the fonts the references were drawn with). Get it
from a checkout of github.com/linebender/resvg, e.g.
``git archive HEAD crates/resvg/tests | tar -x -C /tmp/resvg``; never copy it into this repository.

For every test SVG the file is read the way the package reads an element
(:func:`repulsionpak.io.load_element`, warnings recorded), what was read is rasterized at the
reference PNG's size (matplotlib Agg, fills with their fill rule, strokes with their width, caps,
joins and dashes, at their opacity) and its ink mask (alpha >= 1/4) is compared with the
reference's. The suite's image frame (``<rect id="frame">``, in 1,697 files) is taken out of the
file before it is read (kept when a style sheet may paint it) and its pixels out of the comparison,
so that it does not inflate the score.

Score: the *tolerant IoU* ``1 - (|A - dil(B)| + |B - dil(A)|) / |A | B|`` with ``dil`` a one-pixel
dilation: pixels that differ only along an antialiased edge (the renderers place edges a fraction
of a pixel apart) do not count, a shape misplaced, missing or extra by more than one pixel does.

Classes (each file exactly one):

``exact``      score >= ``THRESHOLD`` (and no approximation warning needed to be said);
``warned``     below it, and the reader warned that it approximated (skipped or replaced content);
``silent``     below it without such a warning: a misread nobody is told about;
``refused``    an :class:`~repulsionpak.errors.InputError` (a clear error naming the file);
``blank-ok``   the reference draws nothing (beyond the frame) and neither does the reader
               (refused with "no visible geometry", or drew nothing);
``blank-drawn`` the reference draws nothing and the reader draws something: mostly content
               resvg leaves out on purpose (SVG 2 units it lacks, invalid values browsers
               differ on); counted apart from the misreads;
``skipped``    files resvg's own test list (``gen-tests.py``'s IGNORE) does not render;
``timeout``    the reader took longer than ``--timeout`` seconds;
``crashed``    any other exception (a traceback): must be 0.

Warnings about the art being thin (packing advice, not reading) do not count as approximation
warnings. A file with the score >= THRESHOLD is ``exact`` even when it warned.
"""

from __future__ import annotations

import argparse
import collections
import io
import json
import multiprocessing as mp
import re
import signal
import sys
import tempfile
import time
import traceback
import warnings
from pathlib import Path

import numpy as np

#: tolerant IoU at or above which a file counts as read exactly
THRESHOLD = 0.98
#: alpha (0-1) at and above which a pixel is ink
INK_ALPHA = 0.25
#: files resvg's test list skips (crates/resvg/tests/gen-tests.py)
IGNORE = {
    "filters/feMorphology/huge-radius",
    "structure/svg/negative-size",
    "structure/svg/no-size",
    "structure/svg/zero-size",
    "structure/svg/not-UTF-8-encoding",
    "paint-servers/radialGradient/focal-point-correction",
}
_THIN = ("the art is extremely thin", "the art is thin line work")
_FRAME = re.compile(r"""<rect\b[^>]*\bid\s*=\s*["']frame["'][^>]*/>""", re.DOTALL)
_ATTR = r"""\b{}\s*=\s*["']([^"']*)["']"""


class _Timeout(Exception):
    pass


def _on_alarm(signum, frame):
    raise _Timeout()


def _setup_fonts(suite: Path) -> None:
    """Give matplotlib the suite's fonts, with the generic families its references used."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import font_manager

    fonts = suite / "fonts"
    if fonts.is_dir():
        for f in sorted(fonts.iterdir()):
            if f.suffix.lower() in (".ttf", ".otf"):
                try:
                    font_manager.fontManager.addfont(str(f))
                except Exception:  # noqa: BLE001  (a font matplotlib cannot read: left out)
                    pass
    rc = matplotlib.rcParams
    rc["font.serif"] = ["Noto Serif"] + list(rc["font.serif"])
    rc["font.sans-serif"] = ["Noto Sans"] + list(rc["font.sans-serif"])
    rc["font.monospace"] = ["Noto Mono"] + list(rc["font.monospace"])
    rc["font.cursive"] = ["Yellowtail"] + list(rc["font.cursive"])
    rc["font.fantasy"] = ["Sedgwick Ave Display"] + list(rc["font.fantasy"])


def _page_map(text: str, png_w: int):
    """(apply, k): ``apply(points)`` maps element coordinates to reference pixels,
    ``apply.user(points)`` the file's user units (they differ where the root stretches)."""
    import svgelements as se

    m = re.search(r"<svg\b[^>]*>", text)
    tag = m.group(0) if m else "<svg>"

    def attr(name):
        a = re.search(_ATTR.format(name), tag)
        return a.group(1) if a else None

    vb = attr("viewBox")
    vbv = None
    if vb:
        try:
            vbv = [float(v) for v in re.split(r"[\s,]+", vb.strip()) if v]
        except ValueError:
            vbv = None
        if vbv is None or len(vbv) != 4 or min(vbv[2:]) <= 0:
            vbv, vb = None, None

    def size(name, i):
        v = attr(name)
        if v and "%" not in v:
            try:
                return float(se.Length(v).value())
            except Exception:  # noqa: BLE001
                pass
        return vbv[2 + i] if vbv else 100.0

    w, h = size("width", 0), size("height", 1)
    parts = [f'width="{w}"', f'height="{h}"']
    if vb:
        parts.append(f'viewBox="{vb}"')
    par = attr("preserveAspectRatio")
    if par:
        parts.append(f'preserveAspectRatio="{par}"')
    doc = se.SVG.parse(io.BytesIO(f'<svg xmlns="http://www.w3.org/2000/svg" {" ".join(parts)}/>'.encode()))
    root_tf = attr("transform") or ""
    vbt = doc.viewbox_transform if doc.viewbox is not None else ""
    V = se.Matrix(f"{root_tf} {vbt}".strip())
    Vn = np.array([[V.a, V.c, V.e], [V.b, V.d, V.f], [0, 0, 1.0]])
    s = abs(V.a * V.d - V.b * V.c) ** 0.5
    L = np.eye(3)
    if s > 0:
        lin = Vn[:2, :2] / s
        if np.abs(lin - np.eye(2)).max() > 1e-12:
            L[:2, :2] = lin
    M = Vn @ np.linalg.inv(L)
    k = png_w / w if w > 0 else 1.0
    M = np.diag([k, k, 1.0]) @ M
    scale = abs(np.linalg.det(M[:2, :2])) ** 0.5

    def apply(p):
        p = np.asarray(p, dtype=float)
        return p @ M[:2, :2].T + M[:2, 2]

    U = np.diag([k, k, 1.0]) @ Vn  # the file's user units (not the element's) -> pixels

    def apply_user(p):
        p = np.asarray(p, dtype=float)
        return p @ U[:2, :2].T + U[:2, 2]

    apply.user = apply_user
    return apply, scale


def _raster(W: int, H: int, draw) -> np.ndarray:
    """Alpha (H, W) of what ``draw(ax)`` puts on a transparent W x H pixel canvas."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(W / 100, H / 100), dpi=100)
    canvas = FigureCanvasAgg(fig)
    fig.patch.set_alpha(0.0)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_axis_off()
    ax.patch.set_visible(False)
    ax.set_xlim(0, W)
    ax.set_ylim(H, 0)
    draw(ax)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., 3].astype(float) / 255.0


def _draw_element(ax, element, apply, scale) -> None:
    from matplotlib.patches import PathPatch
    from matplotlib.path import Path as MPath
    from repulsionpak.art_area import _stroke_geometry
    from repulsionpak.io.regions import rings_to_region
    import shapely

    pt = 72.0 / 100.0  # points per pixel
    for art in element.paths:
        st = art.style
        subs = [apply(p) for p in art.subpaths]

        def fill():
            if st.fill is None or st.opacity * st.fill_opacity <= 0:
                return
            rings = [r for r in subs if len(r) >= 3]
            if not rings:
                return
            try:
                region = rings_to_region(rings, st.fill_rule)
            except Exception:  # noqa: BLE001
                return
            polygons(region, st.opacity * st.fill_opacity)

        def polygons(region, alpha):
            for poly in shapely.get_parts(region):
                if poly.is_empty or not isinstance(poly, shapely.Polygon):
                    continue
                ext = [np.asarray(poly.exterior.coords)] + [np.asarray(r.coords) for r in poly.interiors]
                verts = np.concatenate(ext)
                codes = np.concatenate([[MPath.MOVETO] + [MPath.LINETO] * (len(r) - 2) + [MPath.CLOSEPOLY]
                                        for r in ext])
                ax.add_artist(PathPatch(MPath(verts, codes), facecolor=(0, 0, 0, alpha),
                                        edgecolor="none", linewidth=0))

        def stroke():
            width = st.stroke_width * scale
            if st.stroke is None or st.opacity * st.stroke_opacity <= 0 or width <= 0:
                return
            dots = any(len(q) and np.ptp(np.asarray(q), axis=0).max() == 0 for q in art.subpaths)
            if not st.stroke_dasharray and (width >= 3 or dots):
                # the package's own stroke area: its miter limit (matplotlib has none) and the dots
                # of round or square caps on zero-length subpaths (thinner strokes stay with
                # matplotlib, whose hairlines reach the ink threshold as a browser's do)
                area = _stroke_geometry(art, st.stroke_width)
                mapped = shapely.transform(area, lambda xy: apply(xy))
                polygons(mapped, st.opacity * st.stroke_opacity)
                return
            verts, codes = [], []
            for pts, closed in zip(subs, art.closed):
                if len(pts) < 2:
                    continue
                verts.append(pts)
                c = [MPath.MOVETO] + [MPath.LINETO] * (len(pts) - 1)
                if closed:
                    verts.append(pts[:1])
                    c.append(MPath.CLOSEPOLY)
                codes.extend(c)
            if not verts:
                return
            dash = "solid"
            if st.stroke_dasharray:
                dash = (st.stroke_dashoffset * scale / width, [d * scale / width for d in st.stroke_dasharray])
            ax.add_artist(PathPatch(
                MPath(np.concatenate(verts), codes), facecolor="none",
                edgecolor=(0, 0, 0, st.opacity * st.stroke_opacity), linewidth=width * pt,
                capstyle={"butt": "butt", "round": "round", "square": "projecting"}.get(st.stroke_linecap, "butt"),
                joinstyle={"miter": "miter", "round": "round", "bevel": "bevel"}.get(st.stroke_linejoin, "miter"),
                linestyle=dash))

        order = st.paint_order.split() if st.paint_order != "normal" else ["fill", "stroke"]
        for part in order:
            {"fill": fill, "stroke": stroke}.get(part, lambda: None)()


def _frame_mask(frame_tag: str | None, apply, scale, W, H) -> np.ndarray:
    """Pixels of the suite's image frame (its stroke grown by 2 px), excluded from the score."""
    if not frame_tag:
        return np.zeros((H, W), bool)
    from matplotlib.patches import Polygon

    def num(name, default):
        a = re.search(_ATTR.format(name), frame_tag)
        try:
            return float(a.group(1)) if a else default
        except ValueError:
            return default

    x, y, w, h = num("x", 0), num("y", 0), num("width", 0), num("height", 0)
    sw = num("stroke-width", 1.0)
    pts = apply.user(np.array([[x, y], [x + w, y], [x + w, y + h], [x, y + h]]))  # (in user units)
    lw = (sw * scale + 4.0) * 0.72
    return _raster(W, H, lambda ax: ax.add_artist(
        Polygon(pts, closed=True, facecolor="none", edgecolor="k", linewidth=lw))) > 0


def _dilate(m: np.ndarray) -> np.ndarray:
    out = m.copy()
    out[1:, :] |= m[:-1, :]
    out[:-1, :] |= m[1:, :]
    o2 = out.copy()
    o2[:, 1:] |= out[:, :-1]
    o2[:, :-1] |= out[:, 1:]
    return o2


def score(a: np.ndarray, b: np.ndarray) -> float:
    """Tolerant IoU of two boolean masks (1.0 when both are empty)."""
    union = int((a | b).sum())
    if union == 0:
        return 1.0
    miss = int((a & ~_dilate(b)).sum()) + int((b & ~_dilate(a)).sum())
    return max(0.0, 1.0 - miss / union)


def _init(suite: str, timeout: float) -> None:
    global _SUITE, _TIMEOUT
    _SUITE, _TIMEOUT = Path(suite), timeout
    warnings.simplefilter("ignore")
    _setup_fonts(_SUITE)
    signal.signal(signal.SIGALRM, _on_alarm)


def run_one(rel: str) -> dict:
    """Classify one test file (``rel``: its path under tests/, without .svg)."""
    from PIL import Image
    from repulsionpak.errors import InputError
    from repulsionpak.io import load_element

    svg = _SUITE / "tests" / (rel + ".svg")
    out = {"file": rel, "folder": rel.rsplit("/", 1)[0]}
    if rel in IGNORE:
        out["class"] = "skipped"
        return out
    ref_img = Image.open(svg.with_suffix(".png")).convert("RGBA")
    W, H = ref_img.size
    ref = np.asarray(ref_img)[..., 3].astype(float) / 255.0 >= INK_ALPHA
    raw = svg.read_bytes()
    text = raw.decode("utf-8", "replace")
    fm = _FRAME.search(text)
    frame_tag = fm.group(0) if fm else None
    if fm and "<style" not in text:  # (a style sheet may paint the frame: then it is read too)
        raw = _FRAME.sub("", text, count=1).encode("utf-8")
    t0 = time.process_time()
    signal.alarm(int(_TIMEOUT))
    element, error, said = None, None, []
    try:
        with tempfile.TemporaryDirectory() as tmp:
            # as deep as in the suite, beside its resources/: relative image links still resolve
            p = Path(tmp) / "tests" / rel
            p = p.with_name(svg.name)
            p.parent.mkdir(parents=True)
            (Path(tmp) / "resources").symlink_to(_SUITE / "resources")
            p.write_bytes(raw)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    element = load_element(p)
                except InputError as exc:
                    error = str(exc)
            said = [str(w.message) for w in caught if issubclass(w.category, UserWarning)]
        apply, scale = _page_map(text, W)
        excl = _frame_mask(frame_tag, apply, scale, W, H)
        mine = np.zeros_like(ref)
        if element is not None:
            mine = _raster(W, H, lambda ax: _draw_element(ax, element, apply, scale)) >= INK_ALPHA
        signal.alarm(0)
    except _Timeout:
        out.update({"class": "timeout", "seconds": _TIMEOUT, "ref_ink": int(ref.sum())})
        return out
    except Exception:  # noqa: BLE001
        signal.alarm(0)
        out.update({"class": "crashed", "traceback": traceback.format_exc()[-2000:]})
        return out
    approx = [s for s in said if not any(t in s for t in _THIN)]
    ref_m, mine_m = ref & ~excl, mine & ~excl
    out["seconds"] = round(time.process_time() - t0, 3)
    out["warnings"] = approx
    out["ref_ink"] = int(ref_m.sum())
    if error is not None:
        out["error"] = error
        blank = out["ref_ink"] == 0
        out["class"] = "blank-ok" if blank else "refused"
        return out
    out["score"] = round(score(ref_m, mine_m), 4)
    out["ink"] = int(mine_m.sum())
    out["class"] = classify(out)
    return out


def classify(r: dict) -> str:
    """The class of one result (see the module docstring)."""
    if r.get("class") in ("skipped", "timeout", "crashed"):
        return r["class"]
    if "error" in r:
        return "blank-ok" if r["ref_ink"] == 0 else "refused"
    if r["ref_ink"] == 0:
        return "blank-ok" if r["score"] >= THRESHOLD else "blank-drawn"
    if r["score"] >= THRESHOLD:
        return "exact"
    return "warned" if r["warnings"] else "silent"


CLASSES = ("exact", "blank-ok", "blank-drawn", "warned", "silent", "refused", "skipped", "timeout", "crashed")


def table(results: list[dict]) -> str:
    """The markdown tables of docs/svg-support.md."""
    n = collections.Counter(r["class"] for r in results)
    lines = ["| class | files |", "| --- | ---: |"]
    lines += [f"| {c} | {n.get(c, 0)} |" for c in CLASSES]
    lines.append(f"| **total** | {len(results)} |")
    scores = [r["score"] for r in results if r["class"] == "exact" and not r.get("warnings")]
    if scores:
        lines.append("")
        lines.append(f"Median score of the files read exactly without a warning: {np.median(scores):.4f}.")
    for cls in ("silent", "refused", "blank-drawn", "warned"):
        groups = collections.Counter(r["folder"] for r in results if r["class"] == cls)
        if not groups:
            continue
        lines += ["", f"**{cls}** by folder:", "", "| folder | files |", "| --- | ---: |"]
        lines += [f"| {g} | {k} |" for g, k in sorted(groups.items(), key=lambda t: (-t[1], t[0]))]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("suite", type=Path, help="resvg's crates/resvg/tests folder")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", type=Path, default=None, help="write every file's result as JSON")
    ap.add_argument("--timeout", type=float, default=20.0, help="seconds per file")
    ap.add_argument("--only", default=None, help="only files whose path contains this")
    ap.add_argument("--table", type=Path, default=None,
                    help="print the table of a JSON written by --out (classes recomputed), run nothing")
    args = ap.parse_args(argv)
    if args.table:
        results = json.loads(args.table.read_text())
        for r in results:
            r["class"] = classify(r)
        print(table(results))
        return 0
    tests = args.suite / "tests"
    if not tests.is_dir():
        ap.error(f"{tests} is not a folder: give resvg's crates/resvg/tests")
    files = sorted(str(p.relative_to(tests).with_suffix("")) for p in tests.rglob("*.svg"))
    if args.only:
        files = [f for f in files if args.only in f]
    t0 = time.time()
    if args.jobs > 1:
        with mp.Pool(args.jobs, _init, (str(args.suite), args.timeout), maxtasksperchild=100) as pool:
            results = pool.map(run_one, files, chunksize=8)
    else:
        _init(str(args.suite), args.timeout)
        results = [run_one(f) for f in files]
    if args.out:
        args.out.write_text(json.dumps(results, indent=1))
    print(table(results))
    print(f"\n{len(files)} files in {time.time() - t0:.0f} s", file=sys.stderr)
    return 1 if any(r["class"] == "crashed" for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
