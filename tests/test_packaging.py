"""Every distribution (core, plugins, the example plugin) carries its licence, readme and metadata."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PROJECTS = sorted(p.parent for p in [ROOT / "pyproject.toml", *ROOT.glob("plugins/*/pyproject.toml"),
                                     *ROOT.glob("examples/*/pyproject.toml")])


@pytest.mark.parametrize("project", PROJECTS, ids=lambda p: p.name)
def test_distribution_metadata_is_complete(project):
    meta = tomllib.loads((project / "pyproject.toml").read_text())["project"]
    assert meta["license"] == "MIT" and meta["license-files"] == ["LICENSE"]
    assert (project / "LICENSE").read_text() == (ROOT / "LICENSE").read_text()
    assert (project / meta["readme"]).is_file()
    assert meta["keywords"] and meta["classifiers"] and meta["authors"] and meta["description"]
    assert not any(c.startswith("License ::") for c in meta["classifiers"])  # PEP 639: the expression says it


def test_no_stray_files_in_the_repository_root():
    import subprocess

    tracked = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    top = sorted({p.split("/")[0] for p in tracked if "/" not in p})
    assert top == [".gitignore", "LICENSE", "README.md", "mkdocs.yml", "pyproject.toml"], top


def test_every_core_dependency_is_imported_by_the_core():
    """python-osc was a core dependency that only tests and examples used (the OSC decoder is hapticfx's own)."""
    import re

    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    modules = {"pyyaml": "yaml", "python-osc": "pythonosc"}
    source = "\n".join(p.read_text() for p in (ROOT / "hapticfx").rglob("*.py"))
    for requirement in meta["dependencies"]:
        name = re.match(r"[A-Za-z0-9_.-]+", requirement).group(0).lower()
        module = modules.get(name, name.replace("-", "_"))
        assert re.search(rf"^\s*(import|from) {module}\b", source, re.M), f"{name} is not imported by hapticfx"
    assert any(r.startswith("python-osc") for r in meta["optional-dependencies"]["test"])
