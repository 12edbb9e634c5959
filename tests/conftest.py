"""Shared fixtures: a small dataset written with the real writer, effect files on disk."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from hapticfx.data.dataset import DatasetWriter
from hapticfx.objects import PAPER_OBJECTS
from hapticfx.registry import reset_registry
from hfx_testdata import VELOCITIES, tiny_profiles


@pytest.fixture
def tiny_dataset(tmp_path) -> Path:
    out = tmp_path / "tiny-ds"
    with DatasetWriter(out, name="tiny", rate_hz=1000.0, n_samples=500) as w:
        info = PAPER_OBJECTS["concrete-brick"]
        w.add_object(info, velocities_mps=list(VELOCITIES))
        w.write_bank("max-min", info.id, VELOCITIES, tiny_profiles(VELOCITIES))
    return out


@pytest.fixture
def write_effect(tmp_path):
    """Write an effect mapping (or raw text) to a YAML file and return its path."""

    def write(content, name="effect.yaml") -> Path:
        path = tmp_path / name
        path.write_text(content if isinstance(content, str) else yaml.safe_dump(content, sort_keys=False))
        return path

    return write


@pytest.fixture(autouse=True)
def _fresh_registry():
    reset_registry()
    yield
    reset_registry()
