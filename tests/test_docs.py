"""The documentation: generated reference pages are current, and the mkdocs site builds strictly."""

from __future__ import annotations

import importlib.util
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("gen_reference", ROOT / "docs" / "gen_reference.py")
gen_reference = importlib.util.module_from_spec(spec)
spec.loader.exec_module(gen_reference)


def test_reference_pages_are_up_to_date():
    assert gen_reference.stale() == [], "run: python docs/gen_reference.py"


def test_reference_lists_every_registered_model_and_actuator():
    import json

    schema = json.loads(gen_reference.SCHEMA.read_text())
    page = gen_reference.effect_page(schema)
    for section in ("model", "actuator"):
        for name in schema["properties"][section]["properties"]["type"]["enum"]:
            assert f"### `type: {name}`" in page


def test_params_table_shows_range_default_and_required():
    rows = gen_reference.params_table(
        {"k": {"type": "number", "minimum": 0, "maximum": 2, "default": 1.5, "description": "a | b"},
         "r": {"type": "string"}}, ["r"])
    assert rows[2] == "| `k` | number | 0 <= x <= 2 | `1.5` | a \\| b |"
    assert rows[3] == "| `r` | string |  | required |  |"


def _nav_files(nav) -> list[str]:
    out = []
    for item in nav:
        value = next(iter(item.values())) if isinstance(item, dict) else item
        out += _nav_files(value) if isinstance(value, list) else [value]
    return out


def test_every_nav_page_exists():
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    missing = [p for p in _nav_files(config["nav"]) if not (ROOT / "docs" / p).is_file()]
    assert missing == []


@pytest.mark.skipif(shutil.which("mkdocs") is None and importlib.util.find_spec("mkdocs") is None,
                    reason="mkdocs is not installed (pip install mkdocs)")
def test_mkdocs_build_strict(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert (tmp_path / "site" / "reference" / "effect-file" / "index.html").is_file()


def test_benchmarks_page_is_a_reference_every_table_with_its_command():
    """docs/benchmarks.md: short, no runs by the time of day, and a command above every table."""
    import re

    text = (ROOT / "docs" / "benchmarks.md").read_text()
    lines = text.splitlines()
    assert len(lines) <= 520, f"docs/benchmarks.md has {len(lines)} lines; keep it a reference (about 500)"
    assert not re.findall(r"\b[0-2][0-9]:[0-5][0-9]\b", text), "times of day belong in commit messages"
    section_command = False
    for number, line in enumerate(lines, 1):
        if line.startswith("## ") or line.startswith("### "):
            section_command = False
        if line.startswith("```") or "`hapticfx bench" in line or "`python " in line:
            section_command = True
        starts_table = line.startswith("|") and number > 1 and not lines[number - 2].startswith("|")
        if starts_table and "| command |" not in line and "| target |" not in line:
            assert section_command, f"docs/benchmarks.md:{number}: a table with no command above it in its section"


def test_every_documented_render_command_names_its_output():
    """`hapticfx render` needs --out (docs/families.md showed it without, which stops with "Missing option")."""
    import re

    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    found = [(page.name, line.strip()) for page in pages for line in page.read_text().splitlines()
             if re.match(r"\s*(\$ )?hapticfx render \S", line)]
    assert found
    assert [x for x in found if not re.search(r"(--out|-o) \S", x[1])] == []
