"""The Inkscape extension (repulsionpak.inkscape): the effect run through inkex on documents as
Inkscape writes them, its packing read back and measured, its errors, its reproducibility,
the installer, and one run through the real ``inkscape`` command (skipped without it)."""

from __future__ import annotations

import io
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest


def _inkscape_inkex_dir() -> str | None:
    """The folder holding the inkex that comes with Inkscape (Debian's package puts it in
    /usr/share/inkscape/extensions), when this environment has no inkex of its own: inkex
    from PyPI needs PyGObject, which builds from source, so the test extra does without it."""
    import importlib.util

    if importlib.util.find_spec("inkex") is not None:
        return None
    for folder in ("/usr/share/inkscape/extensions", "/usr/local/share/inkscape/extensions"):
        if (Path(folder) / "inkex" / "__init__.py").exists():
            return folder
    return None


INKSCAPE_INKEX = _inkscape_inkex_dir()
if INKSCAPE_INKEX:
    sys.path.append(INKSCAPE_INKEX)
inkex = pytest.importorskip("inkex")

from lxml import etree  # noqa: E402  (inkex brings lxml)

from repulsionpak import evaluate, read_packing_svg  # noqa: E402
from repulsionpak.inkscape import ENTRY_NAME, INX_NAME  # noqa: E402
from repulsionpak.inkscape.effect import PackIntoShape  # noqa: E402
from repulsionpak.inkscape.install import default_dir, install  # noqa: E402
from repulsionpak.inkscape.standalone import is_closed_shape  # noqa: E402

FIXTURES = Path(__file__).parent / "fixtures" / "inkscape"
HEART = FIXTURES / "heart_mm.svg"      # mm document, layers with transforms, a gradient, a clone
SCALED = FIXTURES / "scaled_viewbox.svg"  # 4 user units per mm, shapes in scaled groups
NS = {"svg": "http://www.w3.org/2000/svg", "inkscape": "http://www.inkscape.org/namespaces/inkscape"}
LABEL = "{http://www.inkscape.org/namespaces/inkscape}label"
GROUPMODE = "{http://www.inkscape.org/namespaces/inkscape}groupmode"


def run_effect(args: list[str], document: Path, capsys=None) -> tuple[int, bytes, str]:
    """(exit status, output document, stderr) of the effect run as Inkscape runs it."""
    out = io.BytesIO()
    status = 0
    try:
        PackIntoShape().run([*args, str(document)], output=out)
    except SystemExit as exc:
        status = exc.code if isinstance(exc.code, int) else 1
    err = capsys.readouterr().err if capsys is not None else ""
    return status, out.getvalue(), err


def packing_layers(root) -> list:
    return [g for g in root if g.tag == f"{{{NS['svg']}}}g" and g.get(GROUPMODE) == "layer"
            and g.get(LABEL) == "Packing"]


def read_back(doc: bytes, container_id: str, gap_uu: float, tmp_path: Path):
    """The Packing layer's copies with the original container as a packing SVG (root
    user units), read with the library's reader and measured with its evaluate()."""
    svg = inkex.load_svg(io.BytesIO(doc)).getroot()
    (layer,) = packing_layers(svg)
    node = svg.getElementById(container_id)
    outline = node.path.transform(node.composed_transform())
    tr = layer.composed_transform()
    vb = svg.get_viewbox()
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="{vb[0]} {vb[1]} {vb[2]} {vb[3]}" '
             f'data-gap="{gap_uu!r}"><g id="container"><path d="{outline}"/></g>',
             f'<g id="elements" transform="{tr}">']
    groups = [g for g in layer.iter() if "element" in (g.get("class") or "").split()]
    parts += [etree.tostring(g).decode() for g in groups]
    parts.append("</g></svg>")
    path = tmp_path / "readback.svg"
    path.write_text("".join(parts))
    container, placed, _ = read_packing_svg(path)
    assert len(placed) == len(groups) > 0
    return evaluate(container, placed, gap_uu, grid=400, with_scp=False), layer


def originals(doc: bytes) -> dict[str, bytes]:
    """Every element with an id outside the Packing layers, serialised as inkex reads it
    (inkex rewrites a transform attribute in its own spelling when it loads a document)."""
    root = inkex.load_svg(io.BytesIO(doc)).getroot()
    skip = {e.get("id") for lay in packing_layers(root) for e in lay.iter() if isinstance(e.tag, str)}
    return {e.get("id"): etree.tostring(e, with_tail=False) for e in root.iter()
            if isinstance(e.tag, str) and e.get("id") and e.get("id") not in skip and e is not root}


def layer_geometry(layer) -> list[str]:
    """The drawing of a Packing layer without its ids (for comparing two runs)."""
    return [el.get("d") for el in layer.iter() if isinstance(el.tag, str) and el.get("d")]


# -- the effect on Inkscape documents --------------------------------------------------------
def test_mm_document_packs_into_a_new_layer(tmp_path, capsys):
    """mm document (viewBox 1 unit = 1 mm), the container and a flower group in a translated
    layer, a gradient-filled leaf and a clone of it in another layer: the output is the
    input plus one Packing layer whose copies do not overlap and keep the gap (in mm)."""
    status, doc, err = run_effect(["--id=heart", "--id=flower", "--id=leaf", "--id=leafclone",
                                   "--gap=3", "--count=5", "--seed=1"], HEART, capsys)
    assert status == 0 and err == ""  # a successful effect prints nothing (Inkscape shows stderr)
    assert originals(doc) == originals(HEART.read_bytes())  # the originals untouched
    m, layer = read_back(doc, "heart", 3.0, tmp_path)
    assert layer.getparent().tag == f"{{{NS['svg']}}}svg"  # a top-level layer
    assert layer.get("data-rp-seed") == "1" and layer.get("data-rp-gap") == "3"
    assert layer.get("data-rp-container") == "heart"
    assert layer.get("data-rp-elements") == "flower leaf leafclone"
    assert m["n_primary"] == 5 and m["n_secondary"] >= 1  # pockets filled by default
    assert m["overlap_area"] <= 1e-6 * 170 * 135
    assert m["n_outside"] == 0
    assert 0.9 <= m["gap"]["median"] / 3.0 <= 1.1, m["gap"]
    sources = {g.get("data-source") for g in layer.iter() if g.get("data-source")}
    assert sources <= {"flower", "leaf", "leafclone"} and "flower" in sources
    # the gradient travels with the copies: every url() reference points into the layer
    ids = {e.get("id") for e in layer.iter() if e.get("id")}
    refs = [v for e in layer.iter() for v in e.attrib.values() if "url(#" in v]
    assert refs and all(v.split("url(#")[1].split(")")[0] in ids for v in refs)


def test_viewbox_scale_and_group_transforms(tmp_path, capsys):
    """A document of 4 user units per mm: the gap given in mm is 4× in user units, and
    the container (an ellipse in a scaled group) is read through its group's transform."""
    status, doc, err = run_effect(["--id=oval", "--id=square", "--id=star", "--gap=2", "--count=6",
                                   "--seed=3", "--pocket_fill=false"], SCALED, capsys)
    assert status == 0 and err == ""
    m, layer = read_back(doc, "oval", 8.0, tmp_path)
    assert float(layer.get("data-rp-gap-used")) == pytest.approx(2.0)
    assert m["n_primary"] == 6 and m["n_secondary"] == 0
    assert m["overlap_area"] <= 1e-6 * 352 * 272
    assert m["n_outside"] == 0
    assert 0.9 <= m["gap"]["median"] / 8.0 <= 1.1, m["gap"]
    # the copies fill the ellipse (x 24..376, y 23..295 in user units), not its group's frame
    container, placed, _ = read_packing_svg(tmp_path / "readback.svg")
    minx, miny, maxx, maxy = container.bounds
    assert (minx, miny, maxx, maxy) == pytest.approx((24, 23, 376, 295), abs=0.5)


def test_same_seed_same_packing_and_rerun_on_the_layer(tmp_path, capsys):
    """The same seed gives the same layer; running again with the Packing layer selected
    makes it again in place; with New seed, another packing with the seed recorded."""
    args = ["--id=oval", "--id=square", "--id=star", "--gap=2", "--count=4", "--seed=7", "--pocket_fill=false"]
    s1, doc1, _ = run_effect(args, SCALED, capsys)
    s2, doc2, _ = run_effect(args, SCALED, capsys)
    assert s1 == s2 == 0
    lay1, lay2 = (packing_layers(etree.fromstring(d))[0] for d in (doc1, doc2))
    assert layer_geometry(lay1) == layer_geometry(lay2) and layer_geometry(lay1)
    assert lay1.get("data-rp-gap") == "2" and lay1.get("data-rp-seed") == "7"
    first = tmp_path / "first.svg"
    first.write_bytes(doc1)
    s3, doc3, err = run_effect([f"--id={lay1.get('id')}", "--seed=99"], first, capsys)  # dialog seed ignored
    assert s3 == 0 and err == "" and doc3 == b""  # the same packing: inkex writes nothing, nothing changed
    emptied = etree.fromstring(doc1)
    lay = packing_layers(emptied)[0]
    for c in list(lay):
        lay.remove(c)
    (tmp_path / "emptied.svg").write_bytes(etree.tostring(emptied))
    s3, doc3, err = run_effect([f"--id={lay1.get('id')}"], tmp_path / "emptied.svg", capsys)
    assert s3 == 0 and err == ""
    (lay3,) = packing_layers(etree.fromstring(doc3))
    assert lay3.get("id") == lay1.get("id") and layer_geometry(lay3) == layer_geometry(lay1)
    child = next(e for e in lay1.iter() if "element" in (e.get("class") or "").split())
    s4, doc4, _ = run_effect([f"--id={child.get('id')}", "--reseed=true"], first, capsys)
    assert s4 == 0
    (lay4,) = packing_layers(etree.fromstring(doc4))
    assert lay4.get("data-rp-seed") != "7" and layer_geometry(lay4) != layer_geometry(lay1)
    assert originals(doc4) == originals(doc1)


def test_text_and_a_secondary_layer(tmp_path, capsys):
    """Text is an element (its outlines packed); the objects of the layer named in the dialog
    are the pocket elements."""
    status, doc, err = run_effect(["--id=oval", "--id=word", "--id=star", "--gap=2", "--count=4", "--seed=2",
                                   "--pocket_fill=false"], SCALED, capsys)
    assert status == 0 and err == ""
    m, layer = read_back(doc, "oval", 8.0, tmp_path)
    assert m["n_primary"] == 4 and m["overlap_area"] <= 1e-6 * 352 * 272 and m["n_outside"] == 0
    assert "word" in {g.get("data-source") for g in layer.iter() if g.get("data-source")}
    status, doc, err = run_effect(["--id=heart", "--id=flower", "--gap=3", "--count=4", "--seed=1",
                                   "--secondary_layer=Layer 2"], HEART, capsys)
    assert status == 0 and err == ""
    m, layer = read_back(doc, "heart", 3.0, tmp_path)
    kinds = {(g.get("class"), g.get("data-source")) for g in layer.iter() if g.get("data-source")}
    assert kinds == {("element primary", "flower"), ("element secondary", "leafclone")}, kinds
    assert m["overlap_area"] <= 1e-6 * 170 * 135 and m["n_outside"] == 0
    assert layer.get("data-rp-secondary-layer") == "Layer 2"


@pytest.mark.parametrize("draft", [False, True])
def test_same_packing_as_the_command_line(tmp_path, capsys, draft):
    """The objects cut out as standalone files and packed by ``repulsionpak pack`` with the
    same gap, count and seed (and ``--draft`` for the dialog's Draft) give the copies the
    effect puts in the layer."""
    from typer.testing import CliRunner

    from repulsionpak.cli import app
    from repulsionpak.inkscape.standalone import standalone_svg

    status, doc, _ = run_effect(["--id=oval", "--id=square", "--id=star", "--gap=2", "--count=4", "--seed=5",
                                 "--pocket_fill=false", f"--draft={str(draft).lower()}"], SCALED, capsys)
    assert status == 0
    svg = inkex.load_svg(str(SCALED)).getroot()
    files = {}
    for name in ("oval", "square", "star"):
        files[name] = tmp_path / f"{name}.svg"
        files[name].write_bytes(standalone_svg(svg, svg.getElementById(name)))
    out = tmp_path / "cli.svg"
    res = CliRunner().invoke(app, ["pack", str(files["oval"]), str(files["square"]), str(files["star"]), "-o",
                                   str(out), "--gap", "8", "--count", "4", "--seed", "5", "--no-pocket-fill", "-q",
                                   "--report", str(tmp_path / "cli.json"), *(["--draft"] if draft else [])])
    assert res.exit_code == 0, res.output
    cli = [g for g in etree.parse(str(out)).getroot().iter() if "element" in (g.get("class") or "").split()]
    (layer,) = packing_layers(etree.fromstring(doc))
    assert layer.get("data-rp-draft") == str(draft).lower()
    assert layer_geometry(layer) == [el.get("d") for g in cli for el in g.iter() if el.get("d")]
    import json

    from repulsionpak.params import DRAFT_FACTOR, SimParams

    eps = json.loads((tmp_path / "cli.json").read_text())["params"]["sim"]["stop_epsilon"]
    assert eps == pytest.approx(SimParams().stop_epsilon * (DRAFT_FACTOR if draft else 1.0))


def test_controls_reach_the_library(capsys):
    """Rigid copies do not deform; free ones do; without a gap, the library's default."""
    base = ["--id=oval", "--id=square", "--id=star", "--count=4", "--seed=5", "--pocket_fill=false"]
    deformation = {}
    for rigid in ("true", "false"):
        status, doc, err = run_effect([*base, f"--rigid={rigid}", "--rotation=fixed"], SCALED, capsys)
        assert status == 0 and err == ""
        (layer,) = packing_layers(etree.fromstring(doc))
        assert layer.get("data-rp-rigid") == rigid and layer.get("data-rp-rotation") == "fixed"
        # no gap given: the library's default gap (1% of the container's larger side, 352 user units)
        assert layer.get("data-rp-gap") == "auto"
        assert float(layer.get("data-rp-gap-used")) * 4 == pytest.approx(3.52, rel=1e-3)
        deformation[rigid] = max(float(g.get("data-deformation")) for g in layer.iter() if g.get("data-deformation"))
    assert deformation["true"] < 1e-3 < deformation["false"], deformation


def test_the_dialog_offers_every_rotation_of_the_library(capsys):
    """The .inx's rotation choices are the library's, and "upright" reaches the layer."""
    from importlib import resources

    from repulsionpak.types import ROTATIONS

    inx = etree.fromstring((resources.files("repulsionpak.inkscape") / INX_NAME).read_bytes())
    ns = {"i": "http://www.inkscape.org/namespace/inkscape/extension"}
    offered = [o.get("value") for o in inx.iterfind(".//i:param[@name='rotation']/i:option", ns)]
    assert sorted(offered) == sorted(ROTATIONS)
    status, doc, err = run_effect(["--id=oval", "--id=square", "--id=star", "--count=4", "--seed=5",
                                   "--pocket_fill=false", "--rotation=upright", "--max_rotation=10"], SCALED, capsys)
    assert status == 0 and err == ""
    (layer,) = packing_layers(etree.fromstring(doc))
    assert layer.get("data-rp-rotation") == "upright" and float(layer.get("data-rp-max-rotation")) == 10


@pytest.mark.parametrize("args, words", [
    ([], "nothing selected"),
    (["--id=flower", "--id=leafclone"], "no closed shape"),
    (["--id=heart"], "only the container"),
    (["--id=heart", "--id=flower", "--gap=400"], "gap"),
    (["--id=heart", "--id=flower", "--secondary_layer=Nope"], "no layer is labelled 'Nope'"),
])
def test_errors_are_one_line(args, words, capsys):
    """Inkscape shows stderr in a message box: an error is one line, never a traceback,
    and the document is not written."""
    status, doc, err = run_effect(args, HEART, capsys)
    assert status != 0 and doc == b""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("repulsionpak: ") and words in lines[0], lines[0]


def test_closed_shapes():
    make = inkex.PathElement.new
    assert is_closed_shape(make("M 0,0 L 10,0 10,10 Z"))
    assert is_closed_shape(make("M 0,0 h 10 v 10 h -10 z m 2,2 h 5 v 5 z"))  # with a hole
    assert is_closed_shape(make("M 0,0 C 5,5 10,5 10,0 C 5,-5 0,-5 0,0"))  # ends on its start
    assert not is_closed_shape(make("M 0,0 L 10,0 10,10"))
    assert not is_closed_shape(make("M 0,0 L 10,0 10,10 Z M 20,20 L 30,20"))  # one open subpath
    assert is_closed_shape(inkex.Rectangle.new(0, 0, 5, 5))
    assert not is_closed_shape(inkex.Group())


# -- the installer ---------------------------------------------------------------------------------
def test_install_writes_the_inx_and_a_pinned_entry_point(tmp_path):
    inx, entry = install(tmp_path / "ext")
    assert inx == tmp_path / "ext" / INX_NAME and entry == tmp_path / "ext" / ENTRY_NAME
    root = etree.parse(str(inx)).getroot()
    ns = {"i": "http://www.inkscape.org/namespace/inkscape/extension"}
    assert root.findtext("i:id", namespaces=ns) == "org.repulsionpak.pack"
    assert root.find(".//i:command", ns).text == ENTRY_NAME
    params = {p.get("name") for p in root.iterfind(".//i:param", ns)}
    assert {"gap", "count", "seed", "rotation", "rigid", "stiffness", "pocket_fill", "secondary_layer",
            "container_paint"} <= params
    text = entry.read_text()
    assert repr(sys.executable) in text and os.access(entry, os.X_OK)
    # the entry point runs the effect with this Python even when started by another with
    # a foreign PYTHONPATH (Inkscape's own inkex first)
    bad = tmp_path / "inkex"
    bad.mkdir()
    (bad / "__init__.py").write_text("raise ImportError('Inkscape inkex, not ours')\n")
    # (where this environment has no inkex, Inkscape's own serves)
    foreign = str(tmp_path) if INKSCAPE_INKEX is None else INKSCAPE_INKEX
    res = subprocess.run([sys.executable, str(entry), "--id=oval", "--id=square", "--count=2", "--seed=1",
                          "--pocket_fill=false", "--max_rotation=x", str(SCALED)],
                         capture_output=True, text=True, env=dict(os.environ, PYTHONPATH=foreign))
    assert res.returncode != 0 and "max_rotation" in res.stderr and "Inkscape inkex" not in res.stderr


def test_cli_inkscape_install(tmp_path):
    """``repulsionpak inkscape-install --dir DIR`` writes both files and prints their paths;
    ``--dry-run`` only prints them."""
    from typer.testing import CliRunner

    from repulsionpak.cli import app

    res = CliRunner().invoke(app, ["inkscape-install", "--dir", str(tmp_path / "a"), "--dry-run"])
    assert res.exit_code == 0 and not (tmp_path / "a").exists()
    assert res.output.split() == [str(tmp_path / "a" / INX_NAME), str(tmp_path / "a" / ENTRY_NAME)]
    res = CliRunner().invoke(app, ["inkscape-install", "--dir", str(tmp_path / "b")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "b" / INX_NAME).read_text().startswith("<?xml")
    assert "repulsionpak.inkscape" in (tmp_path / "b" / ENTRY_NAME).read_text()


def test_default_dirs(tmp_path):
    home = tmp_path
    assert default_dir("linux", {}, home) == home / ".config" / "inkscape" / "extensions"
    assert default_dir("linux", {"XDG_CONFIG_HOME": "/x"}, home) == Path("/x/inkscape/extensions")
    assert default_dir("win32", {"APPDATA": "C:/Users/a/AppData/Roaming"}, home) == \
        Path("C:/Users/a/AppData/Roaming") / "inkscape" / "extensions"
    assert default_dir("darwin", {}, home) == (home / "Library" / "Application Support" / "org.inkscape.Inkscape"
                                               / "config" / "inkscape" / "extensions")


# -- the real Inkscape ------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.skipif(not (shutil.which("inkscape") and shutil.which("xvfb-run")),
                    reason="needs the inkscape command and xvfb-run (apt-get install inkscape xvfb)")
def test_real_inkscape_runs_the_installed_extension(tmp_path):
    """Inkscape 1.2 registers extension effects as actions only with a display, runs them in
    batch mode with --batch-process, and takes their parameters from preferences.xml."""
    home = tmp_path / "home"
    ext = home / ".config" / "inkscape" / "extensions"
    install(ext)
    (ext.parent / "preferences.xml").write_text(
        '<?xml version="1.0" encoding="UTF-8" standalone="no"?>\n<inkscape version="1">\n'
        '  <group id="extensions" org.repulsionpak.pack.gap="3" org.repulsionpak.pack.count="4"\n'
        '         org.repulsionpak.pack.seed="2" org.repulsionpak.pack.pocket_fill="false" />\n</inkscape>\n')
    src, out = tmp_path / "in.svg", tmp_path / "out.svg"
    shutil.copy(HEART, src)
    actions = f"select-by-id:heart,flower,leaf;org.repulsionpak.pack.noprefs;export-filename:{out};export-do"
    env = dict(os.environ, HOME=str(home))
    env.pop("XDG_CONFIG_HOME", None)
    res = subprocess.run(["xvfb-run", "-a", "inkscape", "--batch-process", f"--actions={actions}", str(src)],
                         capture_output=True, text=True, env=env, timeout=900)
    assert res.returncode == 0 and out.exists(), res.stderr[-2000:]
    doc = out.read_bytes()
    m, layer = read_back(doc, "heart", 3.0, tmp_path)
    assert layer.get("data-rp-seed") == "2" and layer.get("data-rp-elements") == "flower leaf"
    assert m["n_primary"] == 4 and m["overlap_area"] <= 1e-6 * 170 * 135 and m["n_outside"] == 0
    assert 0.9 <= m["gap"]["median"] / 3.0 <= 1.1, m["gap"]
    # the same packing as the effect run through inkex directly
    status, direct, _ = run_effect(["--id=heart", "--id=flower", "--id=leaf", "--gap=3", "--count=4",
                                    "--seed=2", "--pocket_fill=false"], HEART)
    assert status == 0
    assert layer_geometry(layer) == layer_geometry(packing_layers(etree.fromstring(direct))[0])
