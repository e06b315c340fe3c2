"""The README and the reference pages say what the code does.

The README's Python blocks import only names that exist and run on the shipped example data;
every option its shell blocks pass to a command is one that command has; its links and
those of the reference pages lead somewhere; docs/parameters.md is what
``docs/make_parameters.py`` writes from ``params.py``; and the pages stay reference, not a
diary.
"""

from __future__ import annotations

import ast
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
DOCS = ROOT / "docs"
#: pages that are reference only (no dated measurements): checked for diary language and anchors
REFERENCE = [README, DOCS / "cli.md", DOCS / "inputs.md", DOCS / "output.md", DOCS / "parameters.md",
             DOCS / "development.md"]

FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)


def blocks(path: Path, *langs: str) -> list[str]:
    return [m.group(2) for m in FENCE.finditer(path.read_text()) if m.group(1) in langs]


def shell_commands(path: Path) -> list[str]:
    """The ``repulsionpak ...`` command lines of a page's bash blocks, continuations joined."""
    out = []
    for block in blocks(path, "bash", "sh", ""):
        text = block.replace("\\\n", " ")
        for line in text.splitlines():
            line = line.split("#", 1)[0].strip()
            for part in line.split("&&"):
                part = part.strip()
                if part.startswith("repulsionpak "):
                    out.append(part)
    return out


def test_readme_is_short_and_keeps_the_two_commands():
    text = README.read_text()
    assert len(text.splitlines()) <= 170
    assert "pip install . && repulsionpak demo" in text
    assert "pip install -e '.[test]' && pytest" in text


@pytest.fixture(scope="module")
def help_texts() -> dict[str, str]:
    env = dict(os.environ, COLUMNS="250", TERM="dumb", NO_COLOR="1")
    cmds = {c.split()[1] for page in (README, DOCS / "cli.md") for c in shell_commands(page)}
    assert {"pack", "evaluate", "batch"} <= cmds
    out = {}
    for cmd in sorted(cmds):
        r = subprocess.run([sys.executable, "-m", "repulsionpak.cli", cmd, "--help"], env=env,
                           capture_output=True, text=True, timeout=120)
        if r.returncode != 0 or "--help" not in r.stdout:
            r = subprocess.run([shutil.which("repulsionpak") or "repulsionpak", cmd, "--help"], env=env,
                               capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stderr
        out[cmd] = r.stdout
    return out


@pytest.mark.parametrize("page", [README, DOCS / "cli.md"], ids=lambda p: p.name)
def test_command_options_exist(help_texts, page):
    """Every option the page's `repulsionpak ...` command lines use is one of that command's."""
    used = 0
    for line in shell_commands(page):
        cmd = line.split()[1]
        for opt in re.findall(r"(?<![\w-])--[a-z][a-z-]*", line):
            assert re.search(rf"(?<![\w-]){re.escape(opt)}(?![\w-])", help_texts[cmd]), \
                f"{page.name}: `repulsionpak {cmd}` has no option {opt}"
            used += 1
    assert used >= 15  # the check saw the page's examples


def test_readme_python_imports_exist():
    import repulsionpak

    code = blocks(README, "python")
    assert code, "the README has a Python example"
    for src in code:
        tree = ast.parse(src)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module == "repulsionpak":
                for alias in node.names:
                    assert hasattr(repulsionpak, alias.name), f"repulsionpak has no {alias.name}"
        methods = {n.func.attr for n in ast.walk(tree)
                   if isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute)
                   and isinstance(n.func.value, ast.Name) and n.func.value.id == "packing"}
        for name in methods:
            assert callable(getattr(repulsionpak.Packing, name, None)), f"Packing has no method {name}"


def test_readme_inline_options_exist(help_texts):
    """Options named in the README's prose are options of one of its commands."""
    prose = FENCE.sub("", README.read_text())
    every = "\n".join(help_texts.values())
    opts = set(re.findall(r"`[^`]*?(?<![\w-])(--[a-z][a-z-]*)", prose))
    assert len(opts) >= 5
    for opt in opts:
        assert re.search(rf"(?<![\w-]){re.escape(opt)}(?![\w-])", every), f"README names {opt}, no command has it"


@pytest.fixture
def example_dir(tmp_path, monkeypatch):
    """The README's file names, made of the shipped example data."""
    from repulsionpak import examples

    shutil.copy(examples.container_file(), tmp_path / "heart.svg")
    for name, files in (("animals", examples.element_files()), ("dots", examples.secondary_files())):
        (tmp_path / name).mkdir()
        for f in files:
            shutil.copy(f, tmp_path / name / f.name)
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.slow
def test_readme_python_runs(example_dir):
    """The README's Python example runs as written and writes what it says."""
    code = "\n".join(blocks(README, "python"))
    namespace: dict = {}
    exec(compile(code, str(README), "exec"), namespace)
    packing = namespace["packing"]
    assert (example_dir / "out.svg").read_text().startswith("<?xml")
    assert (example_dir / "out.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    report = packing.report()
    assert report["n_primary"] > 5 and report["n_secondary"] > 0
    assert 0.3 < report["area_fraction"] < 0.9
    assert report["params"]["sim"]["k_edge"] == 40


def _anchor(title: str) -> str:
    """GitHub's anchor for a Markdown heading."""
    t = re.sub(r"[`*_]", "", title.strip().lower())
    t = re.sub(r"[^\w\- ]", "", t)
    return t.replace(" ", "-")


def _anchors(path: Path) -> set[str]:
    text = FENCE.sub("", path.read_text())
    return {_anchor(m.group(1)) for m in re.finditer(r"^#+ (.+)$", text, re.M)}


LINK = re.compile(r"\]\(([^)\s]+)\)")


@pytest.mark.parametrize("page", sorted([README, *DOCS.glob("*.md")]), ids=lambda p: p.name)
def test_links_resolve(page):
    """Relative links lead to files that exist; on the reference pages, to headings that exist."""
    for target in LINK.findall(FENCE.sub("", page.read_text())):
        if re.match(r"[a-z]+:", target):
            continue
        file, _, anchor = target.partition("#")
        dest = (page.parent / file).resolve() if file else page
        assert dest.exists(), f"{page.name}: broken link {target}"
        if anchor and page in REFERENCE and dest.suffix == ".md":
            assert anchor in _anchors(dest), f"{page.name}: no heading #{anchor} in {dest.name}"


def test_parameters_page_is_current():
    r = subprocess.run([sys.executable, str(DOCS / "make_parameters.py"), "--check"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr


def test_parameters_page_lists_every_parameter():
    from repulsionpak.params import describe

    text = (DOCS / "parameters.md").read_text()
    for key, *_ in describe():
        assert f"| `{key}` |" in text


MONTH = r"(January|February|March|April|May|June|July|August|September|October|November|December)"
DIARY = re.compile(rf"\b(20\d\d-\d\d-\d\d|{MONTH} \d|until {MONTH}|until \d|used to be|previously|"
                   r"was changed|issue #?\d+|earlier code|the old code)\b", re.I)


@pytest.mark.parametrize("page", REFERENCE, ids=lambda p: p.name)
def test_reference_pages_are_not_a_diary(page):
    """No dates or history on the reference pages (parameters.md: in params.py's field docs)."""
    hits = [line for line in page.read_text().splitlines() if DIARY.search(line)]
    assert not hits, f"{page.name}: {hits}"
