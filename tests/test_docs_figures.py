"""Deterministic figures printed in the docs match what their command computes today.

A table of docs/benchmarks.md that a command computes without timing (the reducers' Table 4 analogue on the
built-in drops) is recomputed here and compared, cell by cell, at the precision the page prints; so are the
simulated studies' reports and figures in docs/studies.md (scripts/docs_studies.py regenerates them). When the
computation changes, this test fails until the page shows the command's new output.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _table_after(text: str, header: str) -> dict[str, list[str]]:
    lines = text[text.index(header):].splitlines()
    rows = {}
    for line in lines[2:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip("|").split("|")]
        rows[cells[0]] = cells[1:]
    return rows


def test_the_reducer_table_in_benchmarks_md_is_what_bench_reducers_computes():
    from hapticfx.bench.reducers import score
    from hapticfx.data.dataset import open_dataset
    from hapticfx.registry import get_registry

    text = (ROOT / "docs" / "benchmarks.md").read_text()
    documented = _table_after(text, "| object | drops | DFT321 spectral | DFT321 temporal | max-min spectral |")
    reg = get_registry()
    reducers = {name: reg.create("reducer", name) for name in ("dft321", "max-min")}
    computed = {s.object: [str(s.n_drops)] + [f"{s.mean[r, m]:.3f}" for r in reducers for m in ("spectral", "temporal")]
                for s in score(open_dataset("builtin:helmet-drops"), reducers)}
    assert documented == computed, ("docs/benchmarks.md's reducer table differs from `hapticfx bench reducers`; "
                                    "paste the command's table into the page")
    assert all(re.fullmatch(r"\d\.\d{3}", v) for row in computed.values() for v in row[1:])


@pytest.mark.slow  # simulates the paper's two studies in full: about 15 s of CPU, shared with test_study_plots.py
def test_docs_studies_md_shows_what_the_study_commands_compute(paper_analyses, docs_studies):
    """The report excerpts in docs/studies.md are the simulated studies' reports, cell for cell, and each study
    figure there was drawn from the numbers computed now (its PNG carries their SHA-256)."""
    assert docs_studies.differences(paper_analyses) == [], "run `python scripts/docs_studies.py` and commit the result"
    shown = docs_studies.documented_blocks((ROOT / "docs" / "studies.md").read_text())
    assert set(shown) == {"study1-report", "study2-report"} and all("simulated participants" in b for b in shown.values())
