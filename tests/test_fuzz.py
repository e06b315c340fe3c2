"""Fuzz the readers and the config loader: whatever the input, only repulsionpak's own
errors (RepulsionPakError subclasses) may escape; warnings are fine.

Inputs: random bytes, mutated copies of the shipped example SVGs and of the bad-input
corpus, random ``.path`` text, random TOML-ish dicts and random TOML text.
"""

from __future__ import annotations

import copy
import math
import os
import time
import warnings
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from repulsionpak.errors import ConfigError, InputError, RepulsionPakError
from repulsionpak.io import load_container, load_element
from repulsionpak.io.pathfile import container_from_pathfile, element_from_pathfile, parse_pathfile
from repulsionpak.params import _SECTIONS, Params, load_config, params_from_dict

EXAMPLES = Path(__file__).resolve().parents[1] / "src" / "repulsionpak" / "examples"
BAD = Path(__file__).parent / "bad_inputs"
SEEDS = [
    (EXAMPLES / "elements" / "apple.svg").read_bytes(),
    (EXAMPLES / "elements" / "donut.svg").read_bytes(),
    (EXAMPLES / "containers" / "heart.svg").read_bytes(),
    (EXAMPLES / "containers" / "frame.svg").read_bytes(),
    (BAD / "container_bowtie.svg").read_bytes(),
    (BAD / "display_none.svg").read_bytes(),
]
#: Largest time one example may take (pathological inputs must be bounded).
SLOW = 5.0

#: REPULSIONPAK_FUZZ_EXAMPLES=5000 for a longer campaign.
FUZZ = settings(max_examples=int(os.environ.get("REPULSIONPAK_FUZZ_EXAMPLES", "150")), deadline=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def _only_our_errors(fn, *args, name: str | None = None):
    """Call ``fn``; return its result or the RepulsionPakError it raised (anything else
    fails the test). With ``name``: an error must mention that file name."""
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with np.errstate(all="ignore"):
            try:
                out = fn(*args)
            except RepulsionPakError as exc:
                out = exc
                if name is not None:
                    assert name in str(exc), str(exc)
    assert time.perf_counter() - t0 < SLOW, "pathologically slow input"
    return out


def _load_both(path: Path) -> None:
    for loader in (load_element, load_container):
        res = _only_our_errors(loader, path, name=path.name)
        if isinstance(res, RepulsionPakError):
            assert isinstance(res, InputError), repr(res)
        elif loader is load_container:
            assert res.region.is_valid and res.area > 0 and math.isfinite(res.area)
        else:
            assert res.paths
            assert all(np.all(np.isfinite(s)) for a in res.paths for s in a.subpaths)


# --------------------------------------------------------------------------- SVG bytes

_TOKENS = [b"NaN", b"inf", b"-1e400", b"1e300", b"0", b"-", b"<", b">", b"/>", b'"', b"&x;",
           b"<!ENTITY x 'y'>", b"<!DOCTYPE svg [", b"]>", b'transform="scale(0)"',
           b'transform="matrix(1 2)"', b'transform="rotate(inf)"', b"<use href='#a'/>",
           b'id="a"', b"<g>", b"</g>", b'd="M0 0 A 1e300 1 0 1 1 5 5 Z"', b"\x00", b"\xff",
           b'fill="none"', b'display="none"', b"Z", b"e", b"<text>t</text>", b"<svg>",
           b'viewBox="0 0 0 0"', b'width="-1"', b'fill-rule="evenodd"', b"<![CDATA[", b"]]>"]


@st.composite
def mutated_svg(draw) -> bytes:
    data = bytearray(draw(st.sampled_from(SEEDS)))
    for _ in range(draw(st.integers(1, 6))):
        op = draw(st.sampled_from(["replace", "insert", "delete", "token", "truncate", "dup"]))
        i = draw(st.integers(0, max(0, len(data) - 1)))
        if op == "replace" and data:
            data[i] = draw(st.integers(0, 255))
        elif op == "insert":
            data[i:i] = bytes([draw(st.integers(0, 255))])
        elif op == "delete":
            del data[i : i + draw(st.integers(1, 40))]
        elif op == "token":
            data[i:i] = draw(st.sampled_from(_TOKENS))
        elif op == "truncate":
            del data[i:]
        else:
            j = draw(st.integers(i, min(len(data), i + 200)))
            data[j:j] = data[i:j]
    return bytes(data)


_ATTR_VALUES = st.one_of(
    st.sampled_from(["none", "NaN", "inf", "-1", "0", "1e300", "1e-300", "100%", "-50%", "red",
                     "url(#nope)", "url(#a)", "#a", "evenodd", "hidden", "display:none",
                     "fill:none;stroke:none", "scale(0)", "rotate(90 1e300 0)", "skewX(90)",
                     "matrix(1 0 0 1 0)", "translate(1e300)", "scale(-1 1)", "0 0 0 0",
                     "0 0 -10 10", "M0 0", "M0 0 Z", "M0 0 L 1e16 0 L0 1 Z", "a", ""]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(max_size=10),
)
_ATTR_NAMES = ["d", "points", "transform", "x", "y", "width", "height", "r", "rx", "ry", "cx",
               "cy", "x1", "y1", "x2", "y2", "viewBox", "fill", "stroke", "stroke-width", "style",
               "opacity", "fill-rule", "display", "visibility", "id", "class", "href",
               "preserveAspectRatio", "fill-opacity", "vector-effect", "clip-path"]


@st.composite
def mutated_svg_tree(draw) -> bytes:
    """Well-formed SVG with random attribute values and structure changes (gets past the
    XML parser, unlike byte mutations, to exercise svgelements and the geometry code)."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(draw(st.sampled_from(SEEDS)))
    nodes = list(root.iter())
    for _ in range(draw(st.integers(1, 5))):
        el = draw(st.sampled_from(nodes))
        op = draw(st.sampled_from(["set", "set", "set", "drop", "copy", "tag"]))
        if op == "set":
            el.set(draw(st.sampled_from(_ATTR_NAMES)), draw(_ATTR_VALUES))
        elif op == "drop" and len(el):
            el.remove(el[draw(st.integers(0, len(el) - 1))])
        elif op == "copy" and el is not root:
            el.append(copy.deepcopy(draw(st.sampled_from(nodes[1:]))))
        elif op == "tag" and el is not root:
            el.tag = "{http://www.w3.org/2000/svg}" + draw(st.sampled_from(
                ["g", "use", "symbol", "svg", "rect", "circle", "path", "polygon", "line",
                 "text", "image", "defs", "clipPath", "mask", "pattern", "foreignObject"]))
    return ET.tostring(root)


@FUZZ
@given(data=mutated_svg_tree())
def test_fuzz_mutated_svg_tree(tmp_path, data):
    p = tmp_path / "fuzztree.svg"
    p.write_bytes(data)
    _load_both(p)


@FUZZ
@given(data=st.binary(max_size=2000), suffix=st.sampled_from([".svg", ".path", ".bin", ".svgz"]))
def test_fuzz_random_bytes(tmp_path, data, suffix):
    p = tmp_path / f"fuzzbytes{suffix}"
    p.write_bytes(data)
    _load_both(p)


@FUZZ
@given(data=mutated_svg())
def test_fuzz_mutated_svg(tmp_path, data):
    p = tmp_path / "fuzzmut.svg"
    p.write_bytes(data)
    _load_both(p)


_NUMBER = st.one_of(
    st.integers(-10**6, 10**6).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["1e300", "-1e300", "1e-300", "0", "0.0", "1e15", "1e16"]),
)


@FUZZ
@given(
    coords=st.lists(_NUMBER, min_size=0, max_size=12),
    cmd=st.sampled_from(["M", "L", "C", "Q", "A", "H", "V", "S", "T", "Z", "m", "l", "a"]),
    tf=st.one_of(st.just(""), st.lists(_NUMBER, min_size=0, max_size=7).map(
        lambda v: f' transform="matrix({" ".join(v)})"')),
)
def test_fuzz_numbers_in_svg(tmp_path, coords, cmd, tf):
    """Extreme numbers in path data and transforms: finite geometry or an InputError."""
    d = f"M 10 10 {cmd} {' '.join(coords)} L 50 60 Z"
    p = tmp_path / "fuzznum.svg"
    p.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
                 f'<rect x="1" y="1" width="20" height="20"/><path d="{d}"{tf}/></svg>')
    _load_both(p)


# --------------------------------------------------------------------------- .path text

_PATH_TOKEN = st.one_of(
    st.integers(-3, 9).map(str),
    _NUMBER,
    st.sampled_from(["foreground_color_rgb", "background_color_rgb", "foreground_color",
                     "background_color", "1,2,3", "-1,-1,-1", "256,0,0", "a,b,c", "1,2", "x"]),
    st.text(max_size=5),
)
_PATH_LINE = st.lists(_PATH_TOKEN, max_size=10).map(" ".join)


@FUZZ
@given(
    header=st.one_of(st.integers(-1, 4).map(str), st.integers(0, 10**30).map(str), st.text(max_size=4)),
    lines=st.lists(_PATH_LINE, max_size=8),
    raw=st.text(max_size=200),
    use_raw=st.booleans(),
)
def test_fuzz_pathfile_text(tmp_path, header, lines, raw, use_raw):
    text = raw if use_raw else "\n".join([header, *lines]) + "\n"
    name = "fuzz.path"
    _only_our_errors(parse_pathfile, name, text, name=name)
    _only_our_errors(element_from_pathfile, name, text, name=name)
    _only_our_errors(container_from_pathfile, name, text, None, name=name)
    p = tmp_path / name
    try:
        p.write_text(text, encoding="utf-8", errors="surrogatepass")
    except UnicodeEncodeError:  # pragma: no cover
        return
    _load_both(p)


# --------------------------------------------------------------------------- configs

_KEYS = [f.name for f in fields(Params)] + [f.name for c in _SECTIONS.values() for f in fields(c)]
_SCALAR = st.one_of(
    st.none(), st.booleans(), st.integers(), st.integers(-10**400, 10**400),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=8),
)
_VALUE = st.recursive(_SCALAR, lambda inner: st.one_of(
    st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=6), inner, max_size=3)),
    max_leaves=6)
_KEY = st.one_of(st.sampled_from(_KEYS + list(_SECTIONS)), st.text(max_size=12))
_SECTION = st.dictionaries(_KEY, _VALUE, max_size=5)
_CONFIG = st.dictionaries(
    _KEY, st.one_of(_VALUE, _SECTION), max_size=6
) | st.fixed_dictionaries({}, optional={s: _SECTION for s in _SECTIONS} | {
    "gap": _SCALAR, "seed": _SCALAR})


@FUZZ
@given(data=st.one_of(_CONFIG, _VALUE))
def test_fuzz_params_from_dict(data):
    res = _only_our_errors(params_from_dict, data, "fuzz.toml")
    if isinstance(res, RepulsionPakError):
        assert isinstance(res, ConfigError) and "fuzz.toml" in str(res), repr(res)
    else:
        assert res.validate() is res


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return {"nan": "nan", "inf": "inf", "-inf": "-inf"}.get(repr(v), repr(v))
    if isinstance(v, int):
        return str(v)
    return '"' + str(v).replace("\\", "\\\\").replace('"', '\\"') + '"'


_TOML_LINE = st.one_of(
    st.builds(lambda k, v: f"{k} = {_toml_value(v)}", st.sampled_from(_KEYS + ["gapp", "k_edg"]),
              st.one_of(st.booleans(), st.integers(-10**30, 10**30),
                        st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=6))),
    st.sampled_from([f"[{s}]" for s in _SECTIONS] + ["[sim", "[[sim]]", "[x.y]", "a = [1,", "=",
                                                     'k = """', "# comment", "", "\ufeff"]),
    st.text(max_size=20),
)


@FUZZ
@given(lines=st.lists(_TOML_LINE, max_size=10), raw=st.binary(max_size=100), use_raw=st.booleans())
def test_fuzz_load_config(tmp_path, lines, raw, use_raw):
    p = tmp_path / "fuzzcfg.toml"
    if use_raw:
        p.write_bytes(raw)
    else:
        p.write_text("\n".join(lines) + "\n", encoding="utf-8", errors="surrogatepass")
    res = _only_our_errors(load_config, p, name="fuzzcfg.toml")
    if isinstance(res, RepulsionPakError):
        assert isinstance(res, ConfigError), repr(res)


@pytest.mark.parametrize("text", ["a = " + "[" * 3000, "x = " + "{a = " * 3000, "\ufeffgap = 2.0\n"])
def test_pathological_toml(tmp_path, text):
    p = tmp_path / "deep.toml"
    p.write_text(text, encoding="utf-8")
    res = _only_our_errors(load_config, p, name="deep.toml")
    if not isinstance(res, RepulsionPakError):
        assert res.gap == 2.0  # a UTF-8 byte order mark is accepted
