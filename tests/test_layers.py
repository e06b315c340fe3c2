"""The package's layers only point down (DESIGN.md, "Layout: layers that only point down").

Three checks on the import graph that grimp builds from the source (every import
statement, those inside functions and under ``TYPE_CHECKING`` included):

- the layers contract in ``.importlinter``, run by import-linter's own command;
- no import cycle at all between modules, siblings of one layer included (the contract
  lets siblings joined by ``:`` import each other, this test refuses it both ways);
- every module directly under ``repulsionpak`` has its place in the contract, so a new
  module cannot slip past it.
"""

from __future__ import annotations

import configparser
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

grimp = pytest.importorskip("grimp")
pytest.importorskip("importlinter")

ROOT = Path(__file__).resolve().parents[1]
CONTRACT = ROOT / ".importlinter"
PACKAGE = "repulsionpak"


def _graph():
    return grimp.build_graph(PACKAGE, cache_dir=None)


def _layers() -> list[list[str]]:
    """The contract's layers, top first, each a list of module names under the package."""
    cfg = configparser.ConfigParser()
    cfg.read(CONTRACT)
    raw = cfg["importlinter:contract:layers"]["layers"]
    layers = []
    for line in raw.strip().splitlines():
        names = [n.strip() for n in line.replace(":", "|").split("|")]
        layers.append([n for n in names if n])
    return layers


def strongly_connected(edges: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components of a directed graph (iterative), those of more
    than one node: each is a set of modules that import each other, directly or not."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = 0
    for start in sorted(edges):
        if start in index:
            continue
        work = [(start, iter(sorted(edges[start])))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(edges.get(w, ())))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    x = stack.pop()
                    on_stack.discard(x)
                    comp.append(x)
                    if x == v:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))
    return out


def test_strongly_connected_finds_cycles_and_only_cycles():
    """The cycle finder itself: a 3-cycle with a tail and a separate pair are found, a
    chain and a self-contained diamond are not."""
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set(), "p": {"q"}, "q": {"p"},
             "w": {"x", "y"}, "x": {"z"}, "y": {"z"}, "z": set()}
    assert sorted(strongly_connected(edges)) == [["a", "b", "c"], ["p", "q"]]
    assert strongly_connected({"a": {"b"}, "b": {"c"}, "c": set()}) == []


def test_the_layers_contract_holds():
    """import-linter's layers contract (``.importlinter``): no module imports a layer
    above its own, nor an independent sibling."""
    exe = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) or shutil.which("lint-imports")
    assert exe is not None, "lint-imports not installed (pip install -e '.[test]')"
    res = subprocess.run([exe, "--config", str(CONTRACT), "--no-cache"], cwd=ROOT, capture_output=True, text=True)
    text = res.stdout + res.stderr
    report = text[text.find("Broken contracts"):] if "Broken contracts" in text else text[-3000:]
    assert res.returncode == 0, report
    assert "1 kept, 0 broken" in text, text[-2000:]


def test_no_import_cycles_counting_imports_inside_functions():
    """No two modules import each other, directly or through others, counting every
    import statement (grimp's graph holds those inside functions too)."""
    g = _graph()
    edges = {m: set(g.find_modules_directly_imported_by(m)) for m in g.modules}
    cycles = strongly_connected(edges)
    lines = []
    for comp in cycles:
        members = set(comp)
        lines.append(f"{len(comp)} modules: " + ", ".join(comp))
        for m in comp:
            for i in sorted(edges[m] & members):
                d = g.get_import_details(importer=m, imported=i)
                at = ", ".join(f"l.{x['line_number']}" for x in d[:3])
                lines.append(f"    {m} -> {i} ({at})")
    assert not cycles, "import cycles:\n" + "\n".join(lines)


def test_every_module_has_a_layer():
    """Every module and subpackage directly under ``repulsionpak`` is named in the
    contract: a new one has to be given its layer."""
    named = {n for layer in _layers() for n in layer}
    g = _graph()
    children = {m.split(".")[1] for m in g.modules if m.count(".") >= 1}
    assert children - named == set(), f"not in .importlinter's layers: {sorted(children - named)}"
    assert named - children == set(), f"named in .importlinter but not in the package: {sorted(named - children)}"


def test_the_contract_follows_design_md():
    """The contract's order is DESIGN.md's: entry points over pack over the stages over
    render/measure over geometry/io over the plain data, with the numba layer at the
    bottom."""
    order = {n: i for i, layer in enumerate(_layers()) for n in layer}
    chain = ["cli", "live", "pack", "placement", "render", "io", "geometry", "types", "errors", "_jit"]
    assert [order[a] < order[b] for a, b in zip(chain, chain[1:])] == [True] * (len(chain) - 1)
    stages = ["placement", "sim", "secondary", "holes", "verify"]
    assert len({order[s] for s in stages}) == 1
    assert order["render"] == order["measure"]
    assert order["batch"] == order["live"] == order["studio"]
