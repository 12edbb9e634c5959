"""docs/plugin-guide.md: its ```python blocks run, in order, in one namespace, in a
scratch directory (each block's own asserts check what the guide claims), and its
```toml block is a valid pyproject with the hapticfx entry-point group."""

from __future__ import annotations

import re
import sys
import tomllib
import types
from pathlib import Path

import pytest

GUIDE = Path(__file__).resolve().parents[1] / "docs" / "plugin-guide.md"
FENCE = re.compile(r"^```(\w+)\n(.*?)^```", re.M | re.S)


def blocks(language: str) -> list[str]:
    return [code for lang, code in FENCE.findall(GUIDE.read_text()) if lang == language]


def test_guide_has_its_examples():
    assert len(blocks("python")) >= 8


def test_python_blocks_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    module = types.ModuleType("plugin_guide_example")
    monkeypatch.setitem(sys.modules, module.__name__, module)
    for number, code in enumerate(blocks("python"), 1):
        try:
            exec(compile(code, f"{GUIDE.name} python block {number}", "exec"), module.__dict__)
        except Exception as exc:
            pytest.fail(f"{GUIDE.name}: python block {number} failed: {type(exc).__name__}: {exc}\n{code}")


def test_toml_block_declares_an_entry_point():
    (toml,) = blocks("toml")
    project = tomllib.loads(toml)["project"]
    assert project["entry-points"]["hapticfx"] == {"peakmeter": "hapticfx_peakmeter.plugin"}
    assert "hapticfx>=0.1" in project["dependencies"]
