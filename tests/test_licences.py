"""Every runtime dependency (direct and transitive) has a licence an MIT project can ship
with, read from the installed packages' metadata (docs/licences.md lists them).

``python tests/test_licences.py`` prints the table for docs/licences.md.
"""

from __future__ import annotations

import re
import tomllib
from importlib import metadata
from pathlib import Path

from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[1]

# copyleft that would bind an MIT-licensed whole, and "no commercial use" licences
FORBIDDEN = re.compile(r"(?<![L])GPL|AGPL|Affero|non[- ]?commercial|noncommercial|"
                       r"commercial use|CC-BY-NC|SSPL|BUSL|Commons Clause", re.IGNORECASE)


def runtime_requirements() -> list[Requirement]:
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())
    return [Requirement(r) for r in data["project"]["dependencies"]]


def licence_of(dist: metadata.Distribution) -> str:
    """License-Expression (PEP 639) if given, else the licence classifiers, else the
    first line of the License field."""
    md = dist.metadata
    if md.get("License-Expression"):
        return md["License-Expression"].strip()
    classifiers = [c.split("::")[-1].strip() for c in md.get_all("Classifier") or []
                   if c.startswith("License ::")]
    if classifiers:
        return " / ".join(classifiers)
    text = (md.get("License") or "").strip()
    return text.splitlines()[0].strip() if text else "UNKNOWN"


def runtime_closure() -> dict[str, tuple[str, str, str]]:
    """{normalised name: (name, version, licence)} of the runtime dependencies and theirs."""
    seen: dict[str, tuple[str, str, str]] = {}
    todo = runtime_requirements()
    while todo:
        req = todo.pop()
        key = re.sub(r"[-_.]+", "-", req.name).lower()
        if key in seen:
            continue
        dist = metadata.distribution(req.name)  # PackageNotFoundError: not installed
        seen[key] = (dist.metadata["Name"], dist.version, licence_of(dist))
        for r in dist.requires or []:
            sub = Requirement(r)
            if sub.marker is None or sub.marker.evaluate({"extra": ""}):
                todo.append(sub)
    return seen


def test_no_runtime_dependency_has_a_copyleft_or_non_commercial_licence():
    closure = runtime_closure()
    assert "pythoncdt" in closure and "numba" in closure
    assert "triangle" not in closure  # non-commercial licence (replaced by pythoncdt)
    bad = {n: lic for n, (_, _, lic) in closure.items() if FORBIDDEN.search(lic) or lic == "UNKNOWN"}
    assert not bad, f"runtime dependencies with a licence that conflicts with MIT: {bad}"


def test_the_filter_catches_what_it_should():
    for lic in ["GPL-3.0-or-later", "AGPL-3.0", "GNU General Public License v3 (GPLv3)",
                "Free for non-commercial use", "CC-BY-NC-4.0"]:
        assert FORBIDDEN.search(lic), lic
    for lic in ["MIT", "BSD-3-Clause", "MPL-2.0 AND BSD-3-Clause AND Apache-2.0 WITH LLVM-exception",
                "Apache Software License", "Python Software Foundation License",
                "LGPL-2.1-or-later"]:
        assert not FORBIDDEN.search(lic), lic


def test_docs_list_every_direct_runtime_dependency():
    # (transitive ones change with the versions pip picks; the licence test covers them)
    text = (ROOT / "docs" / "licences.md").read_text()
    for req in runtime_requirements():
        assert re.search(rf"\|\s*{re.escape(req.name)}\s*\|", text, re.IGNORECASE), req.name


if __name__ == "__main__":
    direct = {re.sub(r"[-_.]+", "-", r.name).lower() for r in runtime_requirements()}
    print("| package | version | licence (from its metadata) | needed by |")
    print("| --- | --- | --- | --- |")
    for key, (name, version, lic) in sorted(runtime_closure().items()):
        print(f"| {name} | {version} | {lic} | {'repulsionpak' if key in direct else 'a dependency'} |")
