"""Fixtures of the neural plugin's tests: a synthetic dataset and a tiny trained checkpoint."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from neural_testkit import tiny_config  # noqa: E402
from neural_synthetic import write_synthetic  # noqa: E402


@pytest.fixture(scope="session")
def syn_dataset(tmp_path_factory) -> Path:
    """Two objects, the paper's 12 velocities, 100-sample damped sinusoids."""
    return write_synthetic(tmp_path_factory.mktemp("data") / "synthetic")


@pytest.fixture(scope="session")
def drop_dataset(tmp_path_factory) -> Path:
    """One toy object with raw drops: 6 velocities x 4 drops of 500 samples (not physics)."""
    from hapticfx.data.build import build_dataset
    from hapticfx.data.toy import toy_recordings
    from hapticfx.objects import PAPER_OBJECTS

    rec = toy_recordings(PAPER_OBJECTS["wood-beam"], [2.4, 2.8, 3.1, 3.4, 3.7, 4.0], drops=4, seed=3)
    return build_dataset(tmp_path_factory.mktemp("drops") / "toy-drops", [rec], name="toy-drops", rate_hz=1000.0,
                         sensor={}, provenance={"generator": "hapticfx.data.toy (tests)"})


@pytest.fixture(scope="session")
def trained(tmp_path_factory, syn_dataset) -> Path:
    """A tiny convbilstm checkpoint trained for a few steps on the synthetic dataset."""
    from hapticfx_neural.config import load_config
    from hapticfx_neural.run import train_from_config

    tmp = tmp_path_factory.mktemp("ck")
    _, path = train_from_config(load_config(tiny_config(tmp, syn_dataset)), progress=False)
    return path
