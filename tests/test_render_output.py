"""What a packing writes: the container as drawn, smooth curves, styles, PDF, rasters."""

from __future__ import annotations

import importlib.util
import io
import re
import xml.etree.ElementTree as ET
import zlib

import numpy as np
import pytest
import shapely

from curve_scenes import BADGE, CONTAINER, write_scene
from repulsionpak.io import load_container, load_element, read_packing_svg
from repulsionpak.preprocess import build_template, outline_of
from repulsionpak.render import render_copy, similarity_fit, written_geometry
from repulsionpak.render.quality import kink_stats
from repulsionpak.render.svg import packing_svg_string
from repulsionpak.types import PlacedArt

NS = "{http://www.w3.org/2000/svg}"


@pytest.fixture(scope="module")
def packing(tmp_path_factory):
    """A small packing of discs, squares and badges in a circle drawn as <circle>."""
    from repulsionpak import Params, load_elements, pack
    from repulsionpak.params import PlacementParams
    from repulsionpak.render.svg import write_packing_svg

    d = tmp_path_factory.mktemp("pack")
    cont, files = write_scene(d / "in", "mixed")
    files = [f for f in files if not f.name.startswith("letter")]
    out, pdf = d / "out.svg", d / "out.pdf"
    c = load_container(cont)
    p = pack(c, load_elements(files), Params(seed=2, placement=PlacementParams(count=9)))
    write_packing_svg(out, c, p.placed, p.gap)
    write_packing_svg(d / "out_as_drawn.svg", c, p.placed, p.gap, container_paint="as-drawn")
    if importlib.util.find_spec("cairosvg") is not None:
        from repulsionpak.render.pdf import write_packing_pdf

        write_packing_pdf(pdf, c, p.placed, p.gap)
    rep = {"n_primary": p.n_primary, "n_secondary": p.n_secondary}
    return {"container": cont, "svg": out, "svg_as_drawn": d / "out_as_drawn.svg", "pdf": pdf,
            "report": rep, "packing": p}


def _raster_resvg(svg: str, width: int) -> np.ndarray:
    resvg = pytest.importorskip("resvg_py")
    from PIL import Image

    png = resvg.svg_to_bytes(svg_string=svg, width=width, background="#ffffff")
    return np.asarray(Image.open(io.BytesIO(bytes(png))).convert("RGB"), dtype=float)


def _raster_cairo(svg: str, width: int) -> np.ndarray:
    cairosvg = pytest.importorskip("cairosvg")
    from PIL import Image

    png = cairosvg.svg2png(bytestring=svg.encode(), output_width=width, background_color="#ffffff")
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=float)


# --------------------------------------------------------------------------- container


def test_container_group_holds_the_container_as_drawn(packing):
    """With container_paint="as-drawn" the container's own markup is written."""
    root = ET.parse(packing["svg_as_drawn"]).getroot()
    group = next(g for g in root.iter(f"{NS}g") if g.get("id") == "container")
    circles = [c for c in group if c.tag == f"{NS}circle"]
    assert len(circles) == 1
    c = circles[0]
    assert (c.get("cx"), c.get("cy"), c.get("r")) == ("0", "0", "380")
    assert c.get("id") == "frame" and c.get("stroke") == "#222222" and c.get("stroke-width") == "3"
    assert c.get("transform") == "matrix(1 0 0 1 400 400)"  # the composed group transform
    # the outline the output draws is the input's: distance zero
    from repulsionpak.io.svg_shapes import parse_svg_shapes
    from repulsionpak.io.svg_source import segments_to_curves

    def drawn(path, in_container_group):
        doc = parse_svg_shapes(path, path.read_bytes())
        shapes = [s for s in doc.shapes if s.style.visible
                  and any(g.get("id") == "container" for g in s.groups) == in_container_group]
        return [c.ctrl for s in shapes for c in segments_to_curves(s.segments, s.matrix)]

    a, b = drawn(packing["container"], False), drawn(packing["svg_as_drawn"], True)
    assert len(a) == len(b) == 1 and a[0].shape == b[0].shape
    assert np.abs(a[0] - b[0]).max() < 1e-12  # same curves: distance zero
    cout, placed, info = read_packing_svg(packing["svg_as_drawn"])
    ring = np.asarray(cout.paths[0].subpaths[0])
    assert np.abs(np.hypot(ring[:, 0] - 400, ring[:, 1] - 400) - 380).max() < 1e-9
    # the internal outline layer is invisible
    region = [p for p in group if p.get("class") == "container-region"]
    assert region and region[0].get("fill") == "none" and region[0].get("stroke") == "none"


# --------------------------------------------------------------------------- curves


def test_art_is_written_as_curves(packing):
    root = ET.parse(packing["svg"]).getroot()
    ds = [p.get("d") for g in root.iter(f"{NS}g") if "element" in (g.get("class") or "")
          for p in g.iter(f"{NS}path")]
    assert ds
    cmds = "".join(re.findall(r"[A-Za-z]", "".join(ds)))
    curved = sum(cmds.count(k) for k in "cCqQ")
    assert curved > 0.5 * sum(cmds.count(k) for k in "cCqQlLhHvV")


def test_written_curves_do_not_overlap_and_stay_inside(packing):
    cont, placed, info = read_packing_svg(packing["svg"])  # the curves as written, re-flattened
    geoms = written_geometry(placed)
    assert len(geoms) == packing["report"]["n_primary"] + packing["report"]["n_secondary"]
    tree = shapely.STRtree(geoms)
    a, b = tree.query(geoms, predicate="intersects")
    overlap = sum(shapely.intersection(geoms[i], geoms[j]).area for i, j in zip(a, b) if i < j)
    assert overlap == 0.0
    outside = sum(shapely.difference(g, cont.region).area for g in geoms)
    assert outside <= 1e-9 * cont.area
    # neighbours keep a real gap between their written art
    d = [shapely.distance(geoms[i], geoms[j]) for i, j in zip(*tree.query(geoms, predicate="dwithin",
                                                                          distance=info["gap"])) if i < j]
    assert min(d, default=info["gap"]) > 0.2 * info["gap"]


def test_disc_copies_are_smooth(packing):
    """Disc copies as written have no kink, and bend no more than the exact smooth map:
    the turning angle (400 samples) jumps by at most 2°, or — where the simulation
    crumpled the mesh and the exact map itself bends sharply — by at most 1° more than
    the exact map's."""
    import svgelements as se

    from repulsionpak.io.svg_source import segments_to_curves
    from repulsionpak.sim.art import element_vertices
    from repulsionpak.render.quality import exact_outlines

    p = packing["packing"]
    root = ET.parse(packing["svg"]).getroot()
    groups = [g for g in root.iter(f"{NS}g") if "element" in (g.get("class") or "")]
    discs = [e for e in range(p.model.n_elements) if p.templates[p.model.template_index[e]].element.name == "disc"]
    assert discs and not (p.verification and p.verification.dropped)
    # the written group of a simulated copy: the one whose art is centred on its mesh (pocket
    # copies below the size floor are left out of the output, so the order does not tell)
    written = [se.Path(next(g.iter(f"{NS}path")).get("d")) for g in groups]
    centres = np.array([[(b[0] + b[2]) / 2, (b[1] + b[3]) / 2] for b in (w.bbox() for w in written)])
    checked = 0
    for e in discs:
        verts = element_vertices(p.model, p.state, e) * p.frame.unit
        k = int(np.argmin(np.linalg.norm(centres - verts.mean(axis=0), axis=1)))
        if np.linalg.norm(centres[k] - verts.mean(axis=0)) > 0.25 * np.ptp(verts, axis=0).max():
            continue  # not written: a pocket copy the size floor left out
        sub = segments_to_curves(list(written[k]))[0]  # the curve as written
        jump = kink_stats(sub, 400)[1]
        t = p.templates[p.model.template_index[e]]
        exact = exact_outlines(t, verts, per_segment=256)
        if e in (p.verification.straightened if p.verification else []):
            continue
        assert jump <= max(2.0, kink_stats(exact[0][0][:-1], 400)[1] + 1.0)
        assert kink_stats(sub, 4000)[0] <= max(2.0, kink_stats(exact[0][0][:-1], 4000)[0] + 0.5)
        checked += 1
    assert checked >= len([e for e in discs if e < p.n_primary]) > 0


def test_evaluate_reads_the_curves(packing):
    from repulsionpak.measure import evaluate_file

    from repulsionpak.measure import evaluate

    p = packing["packing"]
    r = evaluate_file(packing["svg"])
    # the container as evaluate_file reads it (the run flattened it finer, to gap/1000)
    direct = evaluate(load_container(packing["container"]), p.placed, p.gap, with_scp=False)
    assert r["n_primary"] == packing["report"]["n_primary"]
    assert abs(r["area_fraction"] - direct["area_fraction"]) < 1e-3  # curves re-flattened on reading
    assert r["overlap_area"] == 0.0


# --------------------------------------------------------------------------- styles


def _badge_copy(tmp_path, angle=0.5, scale=1.7, shift=(120.0, 90.0)):
    f = tmp_path / "badge.svg"
    f.write_text(BADGE)
    el = load_element(f)
    t = build_template(outline_of(el), 1.0, 4.0)
    c, s = np.cos(angle) * scale, np.sin(angle) * scale
    sim = np.array([[c, -s, shift[0]], [s, c, shift[1]], [0, 0, 1]])
    verts = t.verts @ sim[:2, :2].T + sim[:2, 2]
    paths, _ = render_copy(t, verts, 4.0)
    k, _ = similarity_fit(t.verts, verts)
    pa = PlacedArt(el.source, "primary", tuple(paths), stroke_scale=t.scale * k,
                   paint_servers=dict(el.paint_servers))
    rest = np.array([[t.scale, 0, -t.scale * t.outline.center[0]],
                     [0, t.scale, -t.scale * t.outline.center[1]], [0, 0, 1]])
    return pa, sim @ rest


def test_styles_survive_a_copy(tmp_path):
    """A copy that is only moved, turned and scaled renders like the source under the same
    transform: gradients (both units), a pattern, strokes (scaled), <use>."""
    pa, m = _badge_copy(tmp_path)
    cont = load_container(_write(tmp_path, "c.svg", CONTAINER))
    out = packing_svg_string(cont, [pa], 4.0)
    out = out.replace('viewBox="0 0 800 800"', 'viewBox="0 0 400 400"').replace(
        'width="800" height="800"', 'width="400" height="400"')
    out = re.sub(r'<g id="container".*?</g>', "", out, flags=re.S)
    src_body = BADGE.split(">", 1)[1].rsplit("</svg>", 1)[0]
    tf = "matrix(" + " ".join(f"{v:.10g}" for v in (m[0, 0], m[1, 0], m[0, 1], m[1, 1], m[0, 2], m[1, 2])) + ")"
    ref = ('<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" '
           f'width="400" height="400" viewBox="0 0 400 400"><g transform="{tf}">{src_body}</g></svg>')
    a, b = _raster_resvg(out, 400), _raster_resvg(ref, 400)
    diff = np.abs(a - b).max(axis=2)
    assert diff.mean() < 1.0  # out of 255: only anti-aliasing differs
    assert (diff > 60).mean() < 0.01
    assert (np.abs(a - 255).max(axis=2) > 30).mean() > 0.1  # the copy was drawn at all
    assert "gradientTransform" in out and "patternTransform" in out and "<use" not in out


def _write(tmp_path, name, text):
    f = tmp_path / name
    f.write_text(text)
    return f


def test_ids_are_unique_per_copy_and_references_resolve(tmp_path):
    pa1, _ = _badge_copy(tmp_path)
    pa2, _ = _badge_copy(tmp_path, angle=-1.0, shift=(500, 500))
    cont = load_container(_write(tmp_path, "c.svg", CONTAINER))
    out = packing_svg_string(cont, [pa1, pa2], 4.0)
    root = ET.fromstring(out)
    ids = [e.get("id") for e in root.iter() if e.get("id")]
    assert len(ids) == len(set(ids))
    refs = set(re.findall(r"url\(#([^)]+)\)", out)) | set(re.findall(r'href="#([^"]+)"', out))
    assert refs and refs <= set(ids)
    assert any(i.startswith("body-e1") for i in ids) and any(i.startswith("body-e2") for i in ids)


def test_ids_of_use_clones_are_written_once(tmp_path):
    """The shapes a <use> clones carry the id of what they clone: the output writes each
    id once (two copies of it were invalid XML ids, which Inkscape renamed)."""
    el_file = _write(tmp_path, "e.svg", '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 60 20">'
                     '<path id="tri" d="M0 0 L20 0 L0 10 Z"/><use href="#tri" x="30"/></svg>')
    el = load_element(el_file)
    t = build_template(outline_of(el), 1.0, 2.0)
    pas = [PlacedArt(el.source, "primary", tuple(render_copy(t, t.verts + shift, 2.0)[0]))
           for shift in ((100.0, 100.0), (300.0, 300.0))]
    cont = load_container(_write(tmp_path, "c.svg", '<svg xmlns="http://www.w3.org/2000/svg" '
                                 'viewBox="0 0 800 800"><rect id="box" width="400" height="800"/>'
                                 '<use href="#box" x="400"/></svg>'))
    root = ET.fromstring(packing_svg_string(cont, pas, 2.0, container_paint="as-drawn"))
    ids = [e.get("id") for e in root.iter() if e.get("id")]
    assert len(ids) == len(set(ids))
    assert {"box", "tri-e1", "tri-e2"} <= set(ids)
    assert len(root.findall(".//{http://www.w3.org/2000/svg}path")) >= 4 + 1  # every shape is written


# --------------------------------------------------------------------------- renderers, PDF


def test_two_renderers_agree_on_the_output(packing):
    svg = packing["svg"].read_text()
    a, b = _raster_cairo(svg, 500), _raster_resvg(svg, 500)
    assert a.shape == b.shape
    diff = np.abs(a - b).max(axis=2)
    assert diff.mean() < 1.5
    assert (diff > 80).mean() < 0.005
    assert (np.abs(a - 255).max(axis=2) > 30).mean() > 0.2  # there is a drawing


def test_pdf_is_vector(packing):
    data = packing["pdf"].read_bytes()
    assert data.startswith(b"%PDF")
    streams = re.findall(rb"stream\r?\n(.*?)\r?\nendstream", data, re.S)
    text = b""
    for s in streams:
        try:
            text += zlib.decompress(s)
        except zlib.error:
            text += s
    assert len(re.findall(rb"[\d.\-]+ [\d.\-]+ [\d.\-]+ [\d.\-]+ [\d.\-]+ [\d.\-]+ c\b", text)) > 100
    assert b"/Subtype /Image" not in data and b"/Subtype/Image" not in data


def test_cli_writes_pdf_for_a_pdf_output(tmp_path):
    pytest.importorskip("cairosvg")
    from typer.testing import CliRunner

    from repulsionpak.cli import app

    cont, files = write_scene(tmp_path / "in", "discs")
    out = tmp_path / "disc.pdf"
    res = CliRunner().invoke(app, ["pack", str(cont), str(files[0]), "-o", str(out), "--count", "3",
                                   "--max-iterations", "200", "--seed", "1", "-q"])
    assert res.exit_code == 0, res.output
    assert out.read_bytes().startswith(b"%PDF")


def test_svg_escaping_is_the_standard_librarys():
    """The SVG writer's ``escape`` and ``quoteattr`` give what ``xml.sax.saxutils``'s give
    (written out there to spare every run the import of ``urllib.request``)."""
    import itertools
    from xml.sax import saxutils

    from repulsionpak.render import svg

    alphabet = ["a", "&", "<", ">", '"', "'", "\n", "\r", "\t", "é", " ", "&amp;"]
    for n in range(4):
        for chars in itertools.product(alphabet, repeat=n):
            s = "".join(chars)
            assert svg.escape(s) == saxutils.escape(s)
            assert svg.quoteattr(s) == saxutils.quoteattr(s)
