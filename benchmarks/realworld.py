"""Real-world scenes: icon sets, emoji, brand marks and country outlines nobody on the project drew.

Downloads pinned npm packages (``npm pack NAME@VERSION``) into a cache outside the
repository (``--cache``, default ``~/.cache/repulsionpak-realworld``; the art is never
committed), builds the scenes' container and element files there, packs each with the
``repulsionpak`` command line, measures it with ``repulsionpak evaluate --json``, and writes
``docs/gallery.md`` with a table of the numbers and one small picture per scene under
``docs/images/gallery/``::

    python benchmarks/realworld.py                     # every scene, about 10 minutes on one core
    python benchmarks/realworld.py --scenes fa-tree,japan --no-docs

Needs ``npm`` on the PATH (only to download) and the project installed.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import re
import subprocess
import sys
import tarfile
import time
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

#: name -> (npm package, pinned version, licence of the art)
PACKAGES = {
    "fa": ("@fortawesome/fontawesome-free", "7.3.1", "CC BY 4.0 (icons)"),
    "mdi": ("@mdi/svg", "7.4.47", "Apache-2.0"),
    "tabler": ("@tabler/icons", "3.52.0", "MIT"),
    "phosphor": ("@phosphor-icons/core", "2.1.1", "MIT"),
    "simple": ("simple-icons", "16.37.0", "CC0-1.0"),
    "twemoji": ("@twemoji/svg", "15.0.0", "CC BY 4.0 (graphics; package MIT)"),
    "world": ("@svg-maps/world", "2.0.0", "CC BY 4.0"),
}

#: a letter drawn as glyph outlines (DejaVu ships with matplotlib: the same on every machine)
LETTER = ('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 300 330">'
          '<text x="20" y="300" font-family="DejaVu Sans" font-weight="bold" font-size="400">R</text></svg>')


@dataclass(frozen=True)
class Scene:
    name: str
    what: str  # one line for the table
    container: str  # "pkg:path", "world:ID" or "letter"
    elements: tuple[str, ...]
    count: int = 14
    options: tuple[str, ...] = field(default=())


def _fa(n):
    return f"fa:package/svgs/solid/{n}.svg"


def _mdi(n):
    return f"mdi:package/svg/{n}.svg"


def _tabler(n):
    return f"tabler:package/icons/outline/{n}.svg"


def _ph(n):
    return f"phosphor:package/assets/regular/{n}.svg"


def _tw(code):
    return f"twemoji:package/{code}.svg"


def _brand(n):
    return f"simple:package/icons/{n}.svg"


SCENES = (
    Scene("fa-tree", "Font Awesome tree (overflows its viewBox) of fruit and leaves, all currentColor",
          _fa("tree"), tuple(_fa(n) for n in ("apple-whole", "leaf", "seedling", "lemon", "carrot"))),
    Scene("fa-heart", "Font Awesome heart of animals (filled icons)",
          _fa("heart"), tuple(_fa(n) for n in ("cat", "dog", "fish", "dove", "horse"))),
    Scene("mdi-cloud", "Material Design cloud of weather icons",
          _mdi("cloud"), tuple(_mdi(n) for n in ("weather-sunny", "weather-lightning", "umbrella", "snowflake"))),
    Scene("tabler-heart", "Tabler heart (stroke-only outline) of stroke-only icons",
          _tabler("heart"), tuple(_tabler(n) for n in ("star", "moon", "sun", "bolt"))),
    Scene("phosphor-house", "Phosphor house (an outline with a door) of Phosphor icons",
          _ph("house"), tuple(_ph(n) for n in ("tree", "flower", "bird", "cat"))),
    Scene("emoji-apple", "Twemoji apple of multi-colour fruit emoji",
          _tw("1f34e"), tuple(_tw(c) for c in ("1f352", "1f353", "1f34b", "1f347", "1f350"))),
    Scene("emoji-red-circle", "Twemoji red circle of red apples (the as-drawn warning's case)",
          _tw("1f534"), (_tw("1f34e"),)),
    Scene("emoji-red-circle-as-drawn", "The same with --container-paint as-drawn: the apples vanish, and the "
          "run warns", _tw("1f534"), (_tw("1f34e"),), options=("--container-paint", "as-drawn")),
    Scene("brands-github", "Simple Icons GitHub mark of brand marks in their brand colours",
          _brand("github"), tuple(_brand(n) for n in ("python", "rust", "javascript", "docker", "linux"))),
    Scene("indonesia", "Indonesia (an archipelago) of sea emoji",
          "world:id", tuple(_tw(c) for c in ("1f420", "1f422", "1f334", "1f41a")), count=20),
    Scene("japan", "Japan (islands) of Japanese emoji",
          "world:jp", tuple(_tw(c) for c in ("1f338", "1f363", "1f5fb", "1f38f")), count=16),
    Scene("greece", "Greece (a peninsula and islands) of Greek emoji",
          "world:gr", tuple(_tw(c) for c in ("1f3db", "1fad2", "1f419", "26f5")), count=16),
    Scene("chile", "Chile (long and narrow) of chili peppers and grapes",
          "world:cl", (_tw("1f336"), _tw("1f347")), count=12),
    Scene("letter-r", "The letter R (DejaVu Sans Bold) of Tabler stroke icons",
          "letter", tuple(_tabler(n) for n in ("pencil", "brush", "palette", "ruler"))),
)


#: what a designer sees in the pictures (checked by looking at each; qualitative, so it
#: holds for reruns of the same code)
NOTES = [
    "* **Container paint.** Every scene but the last of the red circles draws the container as its outline (the default): the icon",
    "  sets that paint container and elements in `currentColor` (Font Awesome, Material Design,",
    "  Tabler, Phosphor) pack as black silhouettes that stay recognisable (cats, dogs, fish, doves,",
    "  umbrellas, snowflakes) instead of a black shape. `emoji-red-circle-as-drawn` shows what",
    "  `--container-paint as-drawn` gives on Twemoji's red circle: the red apples vanish into it,",
    "  only stems and leaves show, and the run warns (above) with the options that change it.",
    "* **Frame.** Font Awesome's tree reaches from y = -32 to 544 in its `0 0 448 512` viewBox: the",
    "  output's viewBox grows to hold the tip and the trunk, and the copies packed there are drawn.",
    "  Twemoji's circle touches its viewBox: the frame grows by the outline's width, so the outline",
    "  is not cut.",
    "* **Islands.** Islands too small for the smallest copy stay empty (dozens around Indonesia,",
    "  Japan's and Greece's small islands, Chile's southern fjords); the big islands get few large",
    "  copies (Borneo two fish) while thin arms (Sulawesi, the Peloponnese's fingers) get many",
    "  small ones: how archipelagos are sized is the element-size work's, not the output's.",
    "* **Chile** on this map includes Easter Island and the Juan Fernández Islands far to the west:",
    "  the frame holds them, so the mainland is a thin strip at the right of a wide picture.",
    "* **Outlined icons.** Phosphor's regular house is drawn as a band (the icon's ink): the packing",
    "  fills the band with small copies, not the house's inside (its `fill` weight would).",
    "* **Tabler** icons carry an invisible 24 x 24 helper square (`fill` and `stroke` none) beside",
    "  the drawn outline, which the reader leaves out of the container (with a warning), and their",
    "  heart's outline ends 0.006 from its start without a `z`, which counts as closed (ends within",
    "  1/1000 of the outline's size): the container files are used as the package ships them.",
]


# --------------------------------------------------------------------------- downloads


def package_dir(cache: Path, key: str) -> Path:
    """The unpacked pinned package ``key`` of :data:`PACKAGES`, downloaded once with npm."""
    name, version, _ = PACKAGES[key]
    out = cache / f"{key}-{version}"
    if (out / "package" / "package.json").is_file():
        return out
    cache.mkdir(parents=True, exist_ok=True)
    tgz = cache / (name.lstrip("@").replace("/", "-") + f"-{version}.tgz")
    if not tgz.is_file():
        subprocess.run(["npm", "pack", f"{name}@{version}", "--silent"], cwd=cache, check=True,
                       stdout=subprocess.DEVNULL)
    with tarfile.open(tgz) as tf:
        tf.extractall(out, filter="data")
    return out


def _brand_colours(cache: Path) -> dict[str, str]:
    data = json.loads((package_dir(cache, "simple") / "package" / "data" / "simple-icons.json").read_text())
    return {d["slug"]: "#" + d["hex"] for d in data}


def _source(cache: Path, spec: str, work: Path) -> Path:
    """The SVG file of a ``pkg:path`` spec, as the scene uses it (brand marks get their
    brand colour, the map's countries a tight viewBox)."""
    if spec == "letter":
        f = work / "letter-r.svg"
        f.write_text(LETTER)
        return f
    key, _, rel = spec.partition(":")
    if key == "world":
        return _country(cache, rel, work)
    src = package_dir(cache, key) / rel
    if key == "simple":
        slug = src.stem
        text = src.read_text()
        text = text.replace("<path ", f'<path fill="{_brand_colours(cache).get(slug, "#000000")}" ', 1)
        f = work / f"{slug}.svg"
        f.write_text(text)
        return f
    return src


def _country(cache: Path, iso: str, work: Path) -> Path:
    """One country of the world map, in a file whose viewBox holds it with a 3 % margin."""
    import svgelements as se

    text = (package_dir(cache, "world") / "package" / "world.svg").read_text()
    m = re.search(r'<path\s+d="([^"]+)"\s+aria-label="([^"]+)"\s+id="' + re.escape(iso) + '"', text)
    if m is None:
        raise SystemExit(f"world map: no country {iso!r}")
    d, label = m.group(1), m.group(2)
    x0, y0, x1, y1 = se.Path(d).bbox()
    mg = 0.03 * max(x1 - x0, y1 - y0)
    vb = f"{x0 - mg:.3f} {y0 - mg:.3f} {x1 - x0 + 2 * mg:.3f} {y1 - y0 + 2 * mg:.3f}"
    f = work / f"{label.lower().replace(' ', '-')}.svg"
    f.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="{vb}"><path d="{d}"/></svg>')
    return f


# --------------------------------------------------------------------------- runs


def _small_png(src: Path, dst: Path, size_px: int, limit: int = 150_000) -> int:
    """A copy of a PNG at most ``size_px`` on its longer side, as a palette image when that
    keeps it under ``limit`` bytes."""
    from PIL import Image

    img = Image.open(src).convert("RGB")
    img.thumbnail((size_px, size_px), Image.Resampling.LANCZOS)
    buf = io.BytesIO()
    img.save(buf, "PNG", optimize=True)
    data = buf.getvalue()
    if len(data) > limit:
        for colours in (256, 128, 64):
            buf = io.BytesIO()
            img.quantize(colours, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE).save(
                buf, "PNG", optimize=True)
            data = buf.getvalue()
            if len(data) <= limit:
                break
    dst.write_bytes(data)
    return len(data)


def run_scene(scene: Scene, cache: Path, out: Path, seed: int, reuse: bool = False) -> dict:
    work = out / scene.name
    work.mkdir(parents=True, exist_ok=True)
    done = work / "result.json"
    if reuse and done.is_file():
        return json.loads(done.read_text())
    row = _run(scene, cache, work, seed)
    done.write_text(json.dumps(row))
    return row


def _run(scene: Scene, cache: Path, work: Path, seed: int) -> dict:
    container = _source(cache, scene.container, work)
    elements = [_source(cache, e, work) for e in scene.elements]
    svg, png, rep = work / "packing.svg", work / "packing.png", work / "report.json"
    exe = [sys.executable, "-m", "repulsionpak.cli"]
    cmd = [*exe, "pack", str(container), *map(str, elements), "-o", str(svg), "--png", str(png),
           "--report", str(rep), "--seed", str(seed), "--count", str(scene.count), "-q", *scene.options]
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env=dict(os.environ, REPULSIONPAK_THREADS="1"))
    seconds = time.perf_counter() - t0
    warnings = [ln for ln in r.stderr.splitlines() if "warning" in ln]
    if r.returncode not in (0, 6):
        return {"scene": scene.name, "error": (r.stderr.strip().splitlines() or ["?"])[-1], "seconds": seconds}
    report = json.loads(rep.read_text())
    ev = subprocess.run([*exe, "evaluate", str(svg), "--json"], capture_output=True, text=True, check=True)
    m = json.loads(ev.stdout)
    gap = m["gap"]
    r_grid, q = m["scp"]["r"], m["scp"]["q"]
    half = min(range(len(r_grid)), key=lambda i: abs(r_grid[i] - 0.5 * gap["requested"]))
    return {
        "scene": scene.name, "what": scene.what, "exit": r.returncode,
        "n_primary": report["n_primary"], "n_secondary": report["n_secondary"],
        "area_fraction": m["area_fraction"], "overlap_area": m["overlap_area"],
        "gap": report["gap"], "gap_median": gap["median"], "gap_p10": gap["p10"],
        "scp_ratio": q[half] / q[0] if q[0] > 0 else None,
        "distortion_p95": (report.get("distortion") or {}).get("p95"),
        "promises_ok": report["invariants"]["ok"], "seconds": seconds,
        "warnings": warnings, "png": str(png),  # as `pack --png` wrote it: the SVG's frame and paint
    }


def _fmt(x, f=".3f"):
    return "–" if x is None else format(x, f)


def write_gallery(rows: list[dict], images: Path, doc: Path, command: str, size_px: int) -> None:
    images.mkdir(parents=True, exist_ok=True)
    lines = [
        "# Gallery: real-world art",
        "",
        "Icon sets, emoji, brand marks and country outlines that nobody on the project drew, packed",
        "with the defaults (the container drawn as its outline) and a moderate `--count`. Made by",
        "",
        "```bash",
        command,
        "```",
        "",
        "which downloads the pinned npm packages below into a cache outside the repository (the art",
        "is not committed), packs every scene with `repulsionpak pack --seed 1 --count N`, measures",
        "it with `repulsionpak evaluate --json`, and draws the pictures (the SVG's frame).",
        "",
        "| scene | what | primary + secondary | area | median gap / asked (p10) | Q_s(gap/2)/Q_s(0) "
        "| distortion p95 | promises | s |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['scene']} | failed: {r['error']} | | | | | | | {r['seconds']:.0f} |")
            continue
        lines.append(
            f"| {r['scene']} | {r['what']} | {r['n_primary']} + {r['n_secondary']} | {_fmt(r['area_fraction'])} "
            f"| {_fmt(r['gap_median'] / r['gap'] if r['gap_median'] else None, '.2f')} "
            f"({_fmt(r['gap_p10'] / r['gap'] if r['gap_p10'] else None, '.2f')}) | {_fmt(r['scp_ratio'])} "
            f"| {_fmt(r['distortion_p95'])} | {'kept' if r['promises_ok'] else 'BROKEN'} | {r['seconds']:.0f} |")
    lines += ["", "Gap columns are shares of the asked gap (the default: 1 % of the container's larger side).",
              "Warnings the runs printed, if any:", ""]
    for r in rows:
        for w in r.get("warnings", []):
            lines.append(f"* {r['scene']}: `{' '.join(w.split())[:420]}`")
    lines += ["", "## What the pictures show", "", *NOTES, "", "## Pictures", ""]
    for r in rows:
        if "error" in r:
            continue
        dst = images / f"{r['scene']}.png"
        kb = _small_png(Path(r["png"]).with_name("packing.png"), dst, size_px) / 1000
        rel = os.path.relpath(dst, doc.parent)
        lines += [f"### {r['scene']}", "", f"![{r['scene']}]({rel})", "",
                  f"*{r['what']}: {r['n_primary']} + {r['n_secondary']} copies, area {_fmt(r['area_fraction'])}"
                  f" ({kb:.0f} KB picture).*", ""]
    lines += ["## Sources and licences", "", "| package | version | licence of the art |", "| --- | --- | --- |"]
    for name, version, lic in PACKAGES.values():
        lines.append(f"| [{name}](https://www.npmjs.com/package/{name}) | {version} | {lic} |")
    lines += ["", "Font Awesome Free icons by Fonticons, Inc.; Twemoji graphics by Twitter, Inc. and other",
              "contributors; the world map by svg-maps (CC BY 4.0): the pictures above are packings of them.",
              "Simple Icons are CC0 (the brands themselves are their owners' trademarks). The letter is",
              "DejaVu Sans Bold, drawn from the `<text>` of an SVG.", ""]
    doc.write_text("\n".join(lines))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cache", type=Path, default=Path.home() / ".cache" / "repulsionpak-realworld")
    ap.add_argument("--out", type=Path, default=None, help="work directory (default: CACHE/runs)")
    ap.add_argument("--scenes", default="", help="comma list of scene names (default: all)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--size", type=int, default=480, help="longer side of the gallery pictures, px")
    ap.add_argument("--no-docs", action="store_true", help="do not write docs/gallery.md and its pictures")
    ap.add_argument("--reuse", action="store_true", help="keep the results of scenes already run in --out")
    args = ap.parse_args(argv)
    wanted = [s for s in args.scenes.split(",") if s]
    scenes = [s for s in SCENES if not wanted or s.name in wanted]
    if wanted and len(scenes) != len(wanted):
        raise SystemExit(f"unknown scene in {wanted}; known: {', '.join(s.name for s in SCENES)}")
    out = args.out or args.cache / "runs"
    rows = []
    for s in scenes:
        r = run_scene(s, args.cache, out, args.seed, reuse=args.reuse)
        rows.append(r)
        print(json.dumps({k: v for k, v in r.items() if k not in ("png", "what")}), flush=True)
    (out / "results.json").write_text(json.dumps(rows, indent=1))
    if not args.no_docs:
        cmd = "python benchmarks/realworld.py" + (f" --scenes {args.scenes}" if wanted else "")
        write_gallery(rows, REPO / "docs" / "images" / "gallery", REPO / "docs" / "gallery.md", cmd, args.size)
    return 0


if __name__ == "__main__":
    sys.exit(main())
