"""Bad input gets a clear error: the corpus in ``tests/bad_inputs/`` (table ``cases.toml``)
through the library and through ``repulsionpak pack``.

Library: the documented error class (never a bare ValueError / KeyError / XML error),
naming the file and saying what is wrong. CLI: the documented exit code, one line
``repulsionpak: error: ...`` on stderr naming the file or option, no traceback (unless
``--debug``), and no output file written.
"""

from __future__ import annotations

import os
import random
import shutil
import subprocess
import sys
import time
import tomllib
import warnings
from pathlib import Path

import pytest
import shapely
from typer.testing import CliRunner

from repulsionpak import errors
from repulsionpak.cli import app
from repulsionpak.errors import ConfigError, InputError, RepulsionPakError
from repulsionpak.io import load_container, load_element
from repulsionpak.params import load_config

BAD = Path(__file__).parent / "bad_inputs"
EXAMPLES = Path(__file__).resolve().parents[1] / "src" / "repulsionpak" / "examples"
CIRCLE = EXAMPLES / "containers" / "circle.svg"
APPLE = EXAMPLES / "elements" / "apple.svg"
LEAF = EXAMPLES / "elements" / "leaf.svg"
TINY = ["--count", "3", "--max-iterations", "200", "--gap", "10", "--seed", "1", "-q"]
SECRET = "s3cr3t-passwd-line-do-not-leak"

CASES = tomllib.loads((BAD / "cases.toml").read_text(encoding="utf-8"))["case"]
LOADERS = {"element": load_element, "container": load_container, "config": load_config}


def _random_bytes(n: int = 4096) -> bytes:
    rnd = random.Random(20240601)
    return b"\x00\xff" + bytes(rnd.randrange(256) for _ in range(n))


def _generate(name: str, tmp_path: Path) -> Path:
    """The generated corpus entries (binary data, directories, files naming tmp_path)."""
    p = tmp_path / name
    if name.startswith("folder."):
        p.mkdir()
    elif name.startswith("random."):
        p.write_bytes(_random_bytes())
    elif name == "external_secret.svg":
        secret = tmp_path / "secret.txt"
        secret.write_text(SECRET + "\n")
        p.write_text(
            f'<?xml version="1.0"?>\n<!DOCTYPE svg [<!ENTITY x SYSTEM "file://{secret}">]>\n'
            '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 10 10">'
            '<rect width="5" height="5"/><text>&x;</text></svg>\n'
        )
    elif name == "scribble.svg":  # 3000 random points: ~2 million self-crossings
        rnd = random.Random(7)
        pts = " ".join(f"{rnd.uniform(0, 100):.2f},{rnd.uniform(0, 100):.2f}" for _ in range(3000))
        p.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
                     f'<polygon points="{pts}"/></svg>')
    else:  # pragma: no cover - a typo in cases.toml
        raise AssertionError(f"unknown generated corpus file {name}")
    return p


def _materialize(case: dict, tmp_path: Path) -> Path:
    f = case["file"]
    return _generate(f[1:], tmp_path) if f.startswith("@") else BAD / f


def test_corpus_table_is_complete():
    ids = [c["id"] for c in CASES]
    assert len(ids) == len(set(ids)) >= 30
    for c in CASES:
        assert c["role"] in LOADERS, c
        assert issubclass(getattr(errors, c["error"]), RepulsionPakError), c
        assert c["exit"] == getattr(errors, c["error"]).exit_code, c
        if not c["file"].startswith("@") and not c["file"].startswith("does_not_exist"):
            assert (BAD / c["file"]).is_file(), c


# --------------------------------------------------------------------------- (a) library


@pytest.mark.parametrize("case", CASES, ids=[c["id"] for c in CASES])
def test_library_raises_the_documented_error(case, tmp_path):
    path = _materialize(case, tmp_path)
    cls = getattr(errors, case["error"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            LOADERS[case["role"]](path)
        except RepulsionPakError as exc:
            err = exc
        else:
            pytest.fail(f"{case['id']}: no error raised")
    # exactly the documented class (a subclass would have another exit code)
    assert type(err) is cls, (type(err), err)
    msg = str(err)
    assert path.name in msg, msg
    assert case["fragment"] in msg, msg
    assert "\n" not in msg, msg
    assert SECRET not in msg
    if isinstance(err, InputError):
        assert err.path is not None and Path(err.path).name == path.name
    if "warns" in case:
        texts = [str(w.message) for w in caught if issubclass(w.category, UserWarning)]
        assert any(case["warns"] in t and path.name in t for t in texts), texts


# --------------------------------------------------------------------------- (b) CLI


def _pack_args(role: str, bad: Path, out: Path) -> list[str]:
    if role == "element":
        files = [str(CIRCLE), str(bad)]
    elif role == "container":
        files = [str(bad), str(APPLE)]
    else:
        files = [str(CIRCLE), str(APPLE), "--config", str(bad)]
    return ["pack", *files, "-o", str(out), "--report", str(out.with_suffix(".json")),
            "--png", str(out.with_suffix(".png")), *TINY]


def _check_one_error_line(result, *fragments: str) -> str:
    text = result.stderr
    assert "Traceback" not in text and "Traceback" not in result.stdout, text
    lines = [ln for ln in text.splitlines() if ln.startswith("repulsionpak: error:")]
    assert len(lines) == 1, text
    for frag in fragments:
        assert frag in lines[0], (frag, lines[0])
    return lines[0]


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("case", CASES, ids=[c["id"] for c in CASES])
def test_cli_reports_one_error_line_and_writes_nothing(case, tmp_path):
    path = _materialize(case, tmp_path)
    outdir = tmp_path / "out"
    outdir.mkdir()
    res = CliRunner().invoke(app, _pack_args(case["role"], path, outdir / "packing.svg"))
    assert isinstance(res.exception, SystemExit), repr(res.exception)
    assert res.exit_code == case["exit"], res.stderr
    line = _check_one_error_line(res, path.name, case["fragment"])
    assert SECRET not in res.stderr + res.stdout, line
    assert list(outdir.iterdir()) == []


@pytest.mark.parametrize(
    "options, code, fragment",
    [
        (["--gap", "0"], 3, "--gap must be a positive number"),
        (["--gap", "-5"], 3, "--gap must be a positive number"),
        (["--gap", "nan"], 3, "--gap must be a positive number"),
        (["--gap", "inf"], 3, "gap must be a positive number"),
        (["--gap", "1e9"], 3, "gap (1e+09) is absurdly large"),
        (["--gap", "300"], 3, "is absurdly large"),
        (["--count", "0"], 3, "--count must be >= 1"),
        (["--seed", "-1"], 3, "--seed must be >= 0"),
        (["--max-iterations", "0"], 3, "--max-iterations must be >= 1"),
        (["--margin", "1e6"], 3, "edge margin (1e+06) leaves no room in the container"),
        # the circle is 460 units across: a 0.05 gap needs ~66 million vertices (it used to
        # try: ~460,000 elements placed for minutes, deaf to SIGTERM); a 1e-9 gap stopped
        # in the container's flattening with a message about points
        (["--gap", "0.05"], 3, "is too fine: its meshes would need about 66,"),
        (["--gap", "1e-9"], 3, "use a gap of at least 0.4"),
    ],
    ids=["gap0", "gap-neg", "gap-nan", "gap-inf", "gap-1e9", "gap-300", "count0", "seed-neg",
         "maxit0", "margin-1e6", "gap-too-fine", "gap-1e-9"],
)
def test_cli_bad_options(tmp_path, options, code, fragment):
    out = tmp_path / "o.svg"
    args = ["pack", str(CIRCLE), str(APPLE), "-o", str(out), "--count", "3",
            "--max-iterations", "200", "-q", *options]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == code, res.stderr
    _check_one_error_line(res, fragment)
    assert not out.exists()


@pytest.fixture
def inputs(tmp_path):
    """Copies of a container and an element (outputs may be pointed at them)."""
    d = tmp_path / "in"
    d.mkdir()
    return shutil.copy(CIRCLE, d / "circle.svg"), shutil.copy(APPLE, d / "apple.svg")


@pytest.mark.parametrize("target", ["element", "container", "png", "report"])
def test_cli_output_equal_to_an_input_is_refused(inputs, target):
    cont, elem = map(Path, inputs)
    before = {p: p.read_bytes() for p in (cont, elem)}
    victim = cont if target == "container" else elem
    opt = {"png": "--png", "report": "--report"}.get(target, "-o")
    out = ["-o", str(victim.parent / "out.svg")] if opt != "-o" else []
    res = CliRunner().invoke(app, ["pack", str(cont), str(elem), *out, opt, str(victim), *TINY])
    assert res.exit_code == 5, res.stderr
    _check_one_error_line(res, "refusing to overwrite the input", victim.name)
    assert {p: p.read_bytes() for p in (cont, elem)} == before
    assert sorted(p.name for p in victim.parent.iterdir()) == ["apple.svg", "circle.svg"]


def test_cli_output_equal_to_an_element_directory_file_is_refused(inputs):
    cont, elem = map(Path, inputs)
    res = CliRunner().invoke(app, ["pack", str(cont), str(elem.parent), "-o", str(elem), *TINY])
    assert res.exit_code == 5
    _check_one_error_line(res, "refusing to overwrite")
    assert elem.read_bytes() == APPLE.read_bytes()


@pytest.mark.parametrize("where", ["missing_dir", "is_dir"])
def test_cli_unwritable_output(tmp_path, where):
    out = tmp_path / "no" / "such" / "dir" / "o.svg" if where == "missing_dir" else tmp_path
    res = CliRunner().invoke(app, ["pack", str(CIRCLE), str(APPLE), "-o", str(out), *TINY])
    assert res.exit_code == 5, res.stderr
    _check_one_error_line(res, "does not exist" if where == "missing_dir" else "is a directory")
    assert not (tmp_path / "no").exists()


@pytest.mark.parametrize("second", ["--png", "--report", "--pdf"])
def test_cli_two_outputs_with_one_name_are_refused(tmp_path, second):
    """-o o.svg --png o.svg wrote the SVG, then the picture over it (exit 0)."""
    out = tmp_path / "o.svg"
    res = CliRunner().invoke(app, ["pack", str(CIRCLE), str(APPLE), "-o", str(out), second, str(out), *TINY])
    assert res.exit_code == 5, res.stderr
    _check_one_error_line(res, "named for two outputs")
    assert list(tmp_path.iterdir()) == []


def test_cli_picture_as_the_output_svg_is_refused(tmp_path):
    """-o x.png wrote SVG text into a .png; `demo -o d.png` wrote the SVG, then its
    picture over it."""
    res = CliRunner().invoke(app, ["pack", str(CIRCLE), str(APPLE), "-o", str(tmp_path / "x.png"), *TINY])
    assert res.exit_code == 3, res.stderr
    _check_one_error_line(res, "the output is an SVG", "--png x.png")
    res = CliRunner().invoke(app, ["demo", "-o", str(tmp_path / "d.png"), "-q"])
    assert res.exit_code == 3, res.stderr
    _check_one_error_line(res, "the output is an SVG")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
def test_cli_output_in_a_directory_that_cannot_be_written_is_refused_before_the_run(tmp_path):
    """An output nobody can create was found only after the whole packing (exit 5, and the
    SVG written but not the report)."""
    if os.geteuid() != 0:
        locked = tmp_path / "locked"
        locked.mkdir()
        locked.chmod(0o500)
    elif Path("/sys/kernel").is_dir():
        locked = Path("/sys/kernel")  # not even root creates files in sysfs
    else:
        pytest.skip("root, and no sysfs: no directory it cannot write in")
    out = tmp_path / "o.svg"
    res = CliRunner().invoke(app, ["pack", str(CIRCLE), str(APPLE), "-o", str(out),
                                   "--report", str(locked / "r.json"), *TINY])
    assert res.exit_code == 5, res.stderr
    _check_one_error_line(res, "cannot write in", str(locked))
    assert not out.exists()


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_cli_bad_secondary_and_empty_element_directory(tmp_path):
    out = tmp_path / "o.svg"
    res = CliRunner().invoke(app, ["pack", str(CIRCLE), str(APPLE), "--secondary",
                                   str(BAD / "text_only.svg"), "-o", str(out), *TINY])
    assert res.exit_code == 2, res.stderr
    _check_one_error_line(res, "text_only.svg", "has no visible geometry")
    empty = tmp_path / "no_elements"
    empty.mkdir()
    res = CliRunner().invoke(app, ["pack", str(CIRCLE), str(empty), "-o", str(out), *TINY])
    assert res.exit_code == 2, res.stderr
    _check_one_error_line(res, "no_elements", "contains no .svg or .path element file")
    assert not out.exists()


def test_cli_evaluate_bad_inputs(tmp_path):
    for bad, frag in [(BAD / "not_xml.svg", "not well-formed XML"),
                      (tmp_path / "missing.svg", "not found"),
                      (APPLE, "not a packing")]:
        res = CliRunner().invoke(app, ["evaluate", str(bad), "--plot", str(tmp_path / "p.png")])
        assert res.exit_code == 2, res.stderr
        _check_one_error_line(res, bad.name, frag)
    assert not (tmp_path / "p.png").exists()


def test_pathological_inputs_are_time_bounded(tmp_path):
    """Quadratic traps: a scribble container (noding ~2 million crossings took minutes)
    and a .path file declaring 10**9 regions (the colour lookup looped over all of them)."""
    t0 = time.perf_counter()
    with pytest.raises(InputError, match="scribble.svg: an outline intersects itself too often"):
        load_container(_generate("scribble.svg", tmp_path))
    many = tmp_path / "many_regions.path"
    many.write_text("1000000000\n0 1 0 0 0 10 0 10 10\n")
    assert load_element(many).paths[0].style.fill == "#ffffff"
    assert load_container(many).area == pytest.approx(50.0)
    assert time.perf_counter() - t0 < 10.0


# --------------------------------------------------------------------------- empty elements fail fast


def test_zero_area_element_fails_fast_through_the_process(tmp_path):
    """Issue 10: two arcs retracing each other used to run 20,000 iterations (105 s) and
    place nothing. Now: exit 2 naming the file, before any simulation. The real time
    (interpreter start and imports included) is well under a second on a quiet
    machine; the bound here only allows for CI noise."""
    bad = BAD / "zero_area_arcs.svg"
    out = tmp_path / "o.svg"
    t0 = time.perf_counter()
    res = _run(["pack", str(CIRCLE), str(bad), "-o", str(out)], tmp_path)  # default options
    wall = time.perf_counter() - t0
    assert res.returncode == 2, res.stderr
    assert res.stderr.splitlines() == [
        f"repulsionpak: error: {bad}: has (almost) zero area: its shapes enclose 2.73e-14 "
        "square units in a 20 × 9.98 bounding box (e.g. a path that retraces itself, or a "
        "zero-width shape); an element needs a filled or stroked area"]
    assert not out.exists()
    assert wall < 10.0
    t0 = time.perf_counter()
    with pytest.raises(InputError, match=r"zero_area_arcs\.svg: has \(almost\) zero area"):
        load_element(bad)
    assert time.perf_counter() - t0 < 1.0


def test_zero_area_element_built_in_code_is_refused_by_pack():
    """The library API checks too (preprocess), before placing or simulating anything."""
    import numpy as np

    from repulsionpak import Params, pack
    from repulsionpak.types import ArtPath, Element, Style

    t = np.linspace(0.0, np.pi, 50)
    arc = np.c_[10 - 10 * np.cos(t), -10 * np.sin(t)]
    there_and_back = np.vstack([arc, arc[-2:0:-1] + [0.0, 1e-9]])  # encloses ~3e-8
    flat = Element("flat", "flat-in-code", (ArtPath((there_and_back,), (True,), Style()),))
    t0 = time.perf_counter()
    with pytest.raises(InputError, match=r"flat-in-code: has \(almost\) zero area"):
        pack(load_container(CIRCLE), [load_element(APPLE), flat], Params(gap=10, seed=1))
    assert time.perf_counter() - t0 < 10.0


def test_extremely_thin_element_warns(tmp_path):
    hair = tmp_path / "hair.svg"
    hair.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
                    '<path d="M10,10 L90,90" stroke="#000" stroke-width="0.001"/></svg>')
    with pytest.warns(UserWarning, match=r"hair\.svg: the art is extremely thin \(mean thickness 8\.8e-06"):
        el = load_element(hair)
    assert el.paths[0].style.stroke_width == pytest.approx(0.001)
    line = tmp_path / "line.svg"  # a 0.5-unit stroke on a 113-unit line: copies interlock
    line.write_text(hair.read_text().replace('stroke-width="0.001"', 'stroke-width="0.5"'))
    with pytest.warns(UserWarning, match=r"line\.svg: the art is thin line work \(mean thickness 4\.4e-03"):
        load_element(line)
    thin = tmp_path / "thin.svg"  # a 1-unit one is fine
    thin.write_text(hair.read_text().replace('stroke-width="0.001"', 'stroke-width="1"'))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_element(thin)


# --------------------------------------------------------------------------- not errors


@pytest.mark.slow
def test_element_much_larger_than_the_container_packs(tmp_path):
    """Sizes are relative: a 100000-unit element in a 500-unit container is fine."""
    out = tmp_path / "big.svg"
    big = BAD / "ok_element_larger_than_container.svg"
    assert load_element(big).paths
    res = CliRunner().invoke(app, ["pack", str(CIRCLE), str(big), str(LEAF), "-o", str(out), *TINY])
    assert res.exit_code == 0, res.stderr
    assert out.stat().st_size > 500


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_bowtie_container_is_repaired_with_a_warning(tmp_path):
    """A self-crossing outline is filled as SVG does (nonzero: both lobes), with a warning."""
    bow = BAD / "container_bowtie.svg"
    with pytest.warns(UserWarning, match=r"container_bowtie\.svg: 1 container outline\(s\) cross themselves"):
        c = load_container(bow)
    assert c.region.is_valid
    assert c.area == pytest.approx(3200.0)
    assert len(shapely.get_parts(c.region)) == 2
    out = tmp_path / "bow.svg"
    res = CliRunner().invoke(app, ["pack", str(bow), str(APPLE), "-o", str(out),
                                   "--count", "3", "--max-iterations", "200", "--seed", "1", "-q"])
    assert res.exit_code == 0, res.stderr
    assert out.exists()


def test_a_run_warns_about_its_container_once():
    """Without a gap the container is read twice (for the default gap, then at the gap's
    tolerance): only the read the run uses warns, so a file's problem is told once."""
    from repulsionpak.inputs import run_container
    from repulsionpak.params import Params

    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        cont, params = run_container(BAD / "container_bowtie.svg", Params())
    told = [str(w.message) for w in seen if "cross themselves" in str(w.message)]
    assert len(told) == 1, told
    assert params.gap > 0 and cont.tolerance == pytest.approx(params.gap * 0.001)


@pytest.mark.parametrize("kind", ["image", "filter"])
@pytest.mark.parametrize("loader", [load_element, load_container])
def test_unsupported_content_is_skipped_with_a_warning(tmp_path, kind, loader):
    extra = {
        "image": '<image href="photo.png" width="50" height="50"/>',
        "filter": '<defs><filter id="f"><feGaussianBlur stdDeviation="2"/></filter></defs>'
                  '<circle cx="70" cy="70" r="5" filter="url(#f)"/>',
    }[kind]
    p = tmp_path / f"with_{kind}.svg"
    p.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
                 f'<rect x="10" y="10" width="40" height="40" fill="#123456"/>{extra}</svg>')
    with pytest.warns(UserWarning, match=rf"with_{kind}\.svg: skipped unsupported content: .*{kind}"):
        got = loader(p)
    if loader is load_element:
        assert got.paths[0].style.fill == "#123456"
    else:
        assert got.area >= 1600.0


def test_text_in_a_container_is_geometry(tmp_path):
    """Text is drawn as glyph outlines (tests/test_io_text.py), in a container too: lettering
    can be filled. (It was skipped with a warning.)"""
    p = tmp_path / "lettering.svg"
    p.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 300 200">'
                 '<text x="150" y="170" font-family="DejaVu Sans" font-weight="bold" font-size="200" '
                 'text-anchor="middle" fill="none" stroke="#000">R</text></svg>')
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        c = load_container(p)
    assert 5000 < c.area < 0.6 * 300 * 200
    assert sum(len(g.interiors) for g in shapely.get_parts(c.region)) == 1  # the R's counter


def test_unit_checks_on_api_arguments(tmp_path):
    """Bad API arguments are ParameterErrors, not TypeErrors."""
    with pytest.raises(errors.ParameterError, match="tolerance"):
        load_element(APPLE, tolerance=-1)
    with pytest.raises(errors.ParameterError, match="tolerance"):
        load_container(CIRCLE, tolerance="fine")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="config path"):
        load_config(str(tmp_path / "a\0b.toml"))


# --------------------------------------------------------------------------- real process


def _cli() -> list[str]:
    exe = Path(sys.executable).with_name("repulsionpak")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "repulsionpak.cli"]


def _run(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONWARNINGS="default", COLUMNS="200")
    return subprocess.run(_cli() + args, cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=120)


def test_process_error_line_and_debug_traceback(tmp_path):
    out = tmp_path / "o.svg"
    base = ["pack", str(CIRCLE), str(BAD / "truncated.svg"), "-o", str(out), *TINY]
    plain = _run(base, tmp_path)
    assert plain.returncode == 2
    assert plain.stderr.splitlines() == [
        f"repulsionpak: error: {BAD / 'truncated.svg'}: is not well-formed XML at line 3, "
        "column 2 (unclosed token); the file may be truncated or not an SVG"]
    debug = _run(base + ["--debug"], tmp_path)
    assert debug.returncode != 0
    assert "Traceback (most recent call last)" in debug.stderr
    assert "InputError" in debug.stderr and "truncated.svg" in debug.stderr
    assert not out.exists()


def test_process_warnings_are_one_line_each(tmp_path):
    res = _run(["pack", str(CIRCLE), str(BAD / "text_only.svg"), "-o", str(tmp_path / "o.svg"),
                *TINY], tmp_path)
    assert res.returncode == 2
    lines = res.stderr.splitlines()
    assert all(ln.startswith("repulsionpak: ") for ln in lines), lines
    assert sum(ln.startswith("repulsionpak: error:") for ln in lines) == 1


def test_process_unparsable_option_value(tmp_path):
    res = _run(["pack", str(CIRCLE), str(APPLE), "-o", str(tmp_path / "o.svg"), "--gap", "five"],
               tmp_path)
    assert res.returncode == 3, res.stderr
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("repulsionpak: error:") and "--gap" in lines[0]


# --------------------------------------------------------------------------- containers are geometry


def test_unpainted_container_packs(tmp_path):
    """Issue 10: a container drawn with fill="none" and no stroke was refused ("has no
    closed path"); a container is geometry, not appearance."""
    bare = BAD / "fill_none_stroke_none.svg"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a pure-geometry file gets no warning
        c = load_container(bare)
        assert c.area == pytest.approx(2500.0) and c.bounds == (10.0, 10.0, 60.0, 60.0)
        diamond = load_container(Path(__file__).parent / "fixtures" / "container_unpainted.svg")
    assert diamond.area == pytest.approx(0.5 * 160 * 160 - 20 * 20)  # hole subtracted
    out = tmp_path / "o.svg"
    res = CliRunner().invoke(app, ["pack", str(bare), str(APPLE), "-o", str(out),
                                   "--count", "3", "--max-iterations", "200", "--gap", "1",
                                   "--seed", "1", "-q", "--no-pocket-fill"])
    assert res.exit_code == 0, res.stderr
    from repulsionpak.io import read_packing_svg

    cont, placed, _ = read_packing_svg(out)
    assert cont.area == pytest.approx(2500.0) and len(placed) == 3


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_container_shapes_count_whatever_their_paint_but_not_when_hidden(tmp_path):
    p = tmp_path / "paint.svg"
    p.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
                 '<rect width="10" height="10" fill="none"/>'
                 '<rect x="20" width="10" height="10" fill="#fff" opacity="0"/>'
                 '<rect x="40" width="10" height="10" style="fill-opacity:0;stroke:none"/>'
                 '<rect x="60" width="10" height="10" visibility="hidden"/>'
                 '<rect x="80" width="10" height="10" style="display:none"/></svg>')
    c = load_container(p)
    assert c.area == pytest.approx(300.0) and c.bounds == (0.0, 0.0, 50.0, 10.0)


def test_unpainted_helper_next_to_a_painted_outline_is_left_out(tmp_path):
    """An icon's invisible bounding square beside its drawn outline is a layout helper
    browsers do not draw: the container is the outline (with a warning)."""
    p = tmp_path / "icon.svg"
    p.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 24 24">'
                 '<path d="M0 0h24v24H0z" fill="none"/><circle cx="12" cy="12" r="8"/></svg>')
    with pytest.warns(UserWarning, match=r"icon\.svg: left out 1 shape\(s\) with neither fill nor stroke"):
        c = load_container(p)
    assert c.area == pytest.approx(3.14159 * 64, rel=1e-2)


def test_too_fine_a_gap_is_refused_before_anything_is_built_unless_the_limit_is_raised():
    import dataclasses
    import time

    from repulsionpak.io import load_container, load_elements
    from repulsionpak.inputs import check_fineness
    from repulsionpak.pack import pack
    from repulsionpak.params import Params

    cont = load_container(CIRCLE)
    params = dataclasses.replace(Params(), gap=0.3)  # ~1.85 million vertices
    t = time.perf_counter()
    with pytest.raises(errors.ParameterError, match=r"too fine.*1,84\d,\d+ vertices.*max_vertices = 1,000,000"):
        pack(cont, load_elements([APPLE]), params)
    assert time.perf_counter() - t < 5
    raised = dataclasses.replace(params, placement=dataclasses.replace(params.placement, max_vertices=2_000_000))
    check_fineness(cont, 0.3, raised)  # the user's choice: no error
    check_fineness(cont, 4.6, Params())  # 1% of the circle: ~7,900 vertices


RING = ('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 1000 1000"><path fill="none" stroke="#000" '
        'd="M 0,500 A 500,500 0 1 1 1000,500 A 500,500 0 1 1 0,500 Z '
        'M 30,500 A 470,470 0 1 0 970,500 A 470,470 0 1 0 30,500 Z"/></svg>')


@pytest.mark.parametrize("gap", ["30", "20"])
def test_a_container_narrower_than_two_gaps_everywhere_is_refused(tmp_path, gap):
    """A ring 30 units wide at gap 30 (or 20): the elements were placed, every one dropped by
    the verification, and the CLI died in its summary line (exit 1; with -q an empty SVG)."""
    ring = tmp_path / "ring.svg"
    ring.write_text(RING)
    out = tmp_path / "o.svg"
    res = CliRunner().invoke(app, ["pack", str(ring), str(APPLE), "-o", str(out), "--count", "5",
                                   "--gap", gap, "--seed", "1", "-q"])
    assert res.exit_code == 3, res.stderr
    _check_one_error_line(res, "too narrow for a gap of", "widest point is 30 across", "use a gap below 15")
    assert not out.exists()


def test_a_single_element_without_neighbours_is_summarised(tmp_path):
    """No neighbour, no median gap: the summary line said so with a TypeError (exit 1)."""
    out = tmp_path / "one.svg"
    res = CliRunner().invoke(app, ["pack", str(CIRCLE), str(APPLE), "-o", str(out), "--count", "1",
                                   "--no-pocket-fill", "--max-iterations", "200", "--seed", "1"])
    assert res.exit_code == 0, res.stderr
    assert "1 primary + 0 secondary elements" in res.stderr and "median gap - (asked" in res.stderr


def test_counts_are_of_what_the_verification_kept():
    from repulsionpak.packing import Packing
    from repulsionpak.verify import Verification

    class Model:
        kind = ["primary"] * 5

    p = Packing(None, 1.0, [], [], Model(), None, None, None)
    assert p.n_primary == 5  # before the verification: the simulated elements
    p.verification = Verification(True, 0, 0, 0, 0, 0.9, 0.5, None, None, dropped=[(i, "a.svg") for i in range(5)])
    assert (p.n_primary, p.n_secondary) == (0, 0)  # all dropped: none


def test_a_packing_whose_every_element_is_dropped_is_an_error(monkeypatch):
    """The safety net behind the width check: a verification that drops everything ends the
    run with an error naming the cause, not an empty packing that 'keeps every promise'."""
    import dataclasses
    import importlib

    from repulsionpak.io import load_container, load_elements
    from repulsionpak.params import Params

    pack_mod = importlib.import_module("repulsionpak.pack")  # the module, not the function
    real = pack_mod.verify_and_repair

    def drop_all(placed, *args, **kwargs):
        _, v = real(placed, *args, **kwargs)
        return [], dataclasses.replace(v, dropped=[(i, p.source) for i, p in enumerate(placed)])

    monkeypatch.setattr(pack_mod, "verify_and_repair", drop_all)
    params = dataclasses.replace(Params(), gap=20.0, seed=1)
    params = dataclasses.replace(params, placement=dataclasses.replace(params.placement, count=3),
                                 sim=dataclasses.replace(params.sim, max_iterations=50),
                                 secondary=dataclasses.replace(params.secondary, auto=False, fill_holes=False,
                                                               fill_leftover=False))
    with pytest.raises(errors.ParameterError, match="no element fits: the final verification dropped all 3"):
        pack_mod.pack(load_container(CIRCLE), load_elements([APPLE]), params)


@pytest.mark.parametrize("opt", ["-o", "--png"])
def test_a_file_a_manifest_names_is_not_overwritten(tmp_path, opt):
    """`-o logo.svg` beside a manifest naming logo.svg replaced the element with the
    packing (exit 0); the next run then read the packing as the element."""
    d = tmp_path / "in"
    d.mkdir()
    shutil.copy(APPLE, d / "logo.svg")
    (d / "scene.toml").write_text('[[element]]\nfile = "logo.svg"\n')
    before = (d / "logo.svg").read_bytes()
    outs = ["-o", str(d / "logo.svg")] if opt == "-o" else ["-o", str(tmp_path / "o.svg"), "--png", str(d / "logo.svg")]
    res = CliRunner().invoke(app, ["pack", str(CIRCLE), str(d / "scene.toml"), *outs, *TINY])
    assert res.exit_code == 5, res.stderr
    _check_one_error_line(res, "refusing to overwrite the input")
    assert (d / "logo.svg").read_bytes() == before


def test_a_curve_fit_looser_than_a_twentieth_of_the_gap_is_refused(tmp_path):
    """render.max_gap_share 0.5 (accepted before) let the written curves stray half a gap
    and the checks' flattening drift from the file: 14 of 159 copies under 0.9 gap in the
    written SVG while the report said every promise held."""
    cfg = tmp_path / "loose.toml"
    cfg.write_text("[render]\ncurve_tolerance = 0.05\nmax_gap_share = 0.5\n")
    res = CliRunner().invoke(app, ["pack", str(CIRCLE), str(APPLE), "-o", str(tmp_path / "o.svg"),
                                   "--config", str(cfg), *TINY])
    assert res.exit_code == 3
    _check_one_error_line(res, "render.max_gap_share must be in (0, 0.05]")


def test_small_option_and_reading_messages(tmp_path):
    """Errors name their option, carry the usual prefix, and say what is wrong."""
    r = CliRunner().invoke(app, ["pack", str(CIRCLE), str(APPLE), "-o", str(tmp_path / "o.svg"),
                                 "--movie-every", "10", *TINY])
    assert r.exit_code == 3  # was ignored
    _check_one_error_line(r, "--movie-every needs --movie")
    empty = tmp_path / "empty_container.svg"
    empty.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 10 10"><g id="container"/>'
                     '<g id="elements"/></svg>')
    r = CliRunner().invoke(app, ["evaluate", str(empty)])
    assert r.exit_code == 2
    _check_one_error_line(r, 'its <g id="container"> draws nothing')  # was "has no <g id=...>"


def test_a_packing_that_breaks_a_promise_is_written_with_exit_6(tmp_path, monkeypatch):
    from repulsionpak import packing as packing_module

    real = packing_module.invariants

    def broken(packing, metrics):
        return dict(real(packing, metrics), ok=False, overlap_ok=False)

    monkeypatch.setattr(packing_module, "invariants", broken)
    out = tmp_path / "o.svg"
    r = CliRunner().invoke(app, ["pack", str(CIRCLE), str(APPLE), "-o", str(out), *TINY])
    assert r.exit_code == 6 and out.exists()
    line = _check_one_error_line(r, "the packing breaks a promise")
    assert line.startswith("repulsionpak: error: ")  # it lacked the prefix


@pytest.mark.parametrize("vb", ["0 0 -100 100", "0 0 100", "0 0 abc 100"])
def test_an_invalid_root_viewbox_is_ignored_as_browsers_do(tmp_path, vb):
    """SVG: a negative size or a malformed list invalidates the viewBox, which browsers then
    ignore (a zero size disables rendering: refused, in the bad-input corpus)."""
    p = tmp_path / "c.svg"
    p.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" width="200" height="100" viewBox="{vb}">'
                 '<rect x="10" y="10" width="100" height="50"/></svg>')
    with pytest.warns(UserWarning, match=r"invalid root viewBox=.*ignored, as browsers do"):
        c = load_container(p)
    assert c.bounds == pytest.approx((10, 10, 110, 60))  # user units = px: no viewBox scaling
    out = tmp_path / "o.svg"
    from repulsionpak.render.svg import write_packing_svg
    write_packing_svg(out, c, [], 2.0)
    import xml.etree.ElementTree as ET
    root = ET.parse(out).getroot()
    assert root.get("viewBox") is None and root.get("width") == "200"  # the output does not carry it


@pytest.mark.parametrize("options, code, fragments", [
    (["--stiffness", "0"], 3, ["--stiffness: stiffness must be > 0"]),
    (["--rotation", "limited:-5"], 3, ["--rotation: max_rotation must be between 0 and 180"]),
    (["--seed", str(2**64)], 3, ["--seed must be < 2**64"]),
    (["--config", "."], 3, [": is a directory, expected a TOML file"]),
])
def test_cli_errors_name_the_option(tmp_path, monkeypatch, options, code, fragments):
    """The messages named a manifest key (max_rotation), nothing (--stiffness 0, a huge
    --seed), or the output check ("refusing to overwrite the input .", exit 5) for a
    config directory."""
    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(app, ["pack", str(CIRCLE), str(APPLE), "-o", "o.svg", *TINY, *options])
    assert res.exit_code == code, res.stderr
    _check_one_error_line(res, *fragments)
    assert not (tmp_path / "o.svg").exists()
