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


@pytest.fixture
def served(tmp_path):
    """A short study's page served on 127.0.0.1 for participant P05, stimuli on memory actuators:
    ``(session, server, player)``."""
    from hapticfx.study.player import StimulusPlayer
    from hapticfx.study.schedule import build_schedule
    from hapticfx.study.server import StudyServer
    from hapticfx.study.session import Session
    from hapticfx.study.spec import load_study
    from study_files import small_study, write_study

    path = write_study(tmp_path, small_study(t0={"break_s": 0.0}))
    study = load_study(path)
    with StimulusPlayer(study, build_schedule(study, "P05"), device="memory", realtime=False) as player:
        session = Session(study, "P05", tmp_path / "results", player, study_text=path.read_bytes())
        with StudyServer(session) as server:
            yield session, server, player
        session.close()


@pytest.fixture(scope="session")
def docs_studies():
    """scripts/docs_studies.py as a module (it regenerates docs/studies.md's simulated results)."""
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "scripts" / "docs_studies.py"
    spec = importlib.util.spec_from_file_location("docs_studies", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def paper_analyses(tmp_path_factory, docs_studies):
    """The paper's two studies simulated (all their participants, memory actuators) and analysed, once per run:
    {"study1": Analysis, "study2": Analysis}."""
    pytest.importorskip("pandas")
    pytest.importorskip("statsmodels")
    return docs_studies.analyses(tmp_path_factory.mktemp("paper-studies"))
