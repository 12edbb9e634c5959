"""A family played the data-driven way: its effect -> `hapticfx data synth` -> a dataset -> an interpolator -> WAV.

Small on purpose (3 velocities x 2 kicks, about a second): docs/families.md runs the bigger example.
"""

from __future__ import annotations

import copy
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from hapticfx.actuators.files import read_wav
from hapticfx.data.dataset import open_dataset
from hapticfx.droprig.receiver import RECEIVERS
from hapticfx.droprig.spec import load_spec
from hapticfx.errors import EffectError
from hapticfx.pipeline import Pipeline
from hapticfx.processing.preprocess import highpass

ROOT = Path(__file__).resolve().parents[1]
KICK = ROOT / "effects" / "families" / "football_kick.yaml"
SPEC = {"name": "kicks", "seed": 5, "drops": 2, "family": str(KICK), "velocities_mps": [10.0, 20.0, 30.0],
        "rig": {"sensor": {"range_g": 500.0, "sensitivity_v_per_g": 0.01}}}


def _write(folder: Path, spec: dict) -> Path:
    path = folder / "spec.yaml"
    path.write_text(yaml.safe_dump(spec))
    return path


def _hfx(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hapticfx", *args], capture_output=True, text=True)


@pytest.fixture(scope="module")
def kicks(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("kicks")
    r = _hfx("data", "synth", str(folder / "kicks"), "--spec", str(_write(folder, SPEC)), "--jobs", "1")
    assert r.returncode == 0, r.stderr
    return folder / "kicks"


def test_the_dataset_holds_the_familys_own_felt_side(kicks):
    """Each recorded profile is the family's physics at that velocity (the boot's side, high-passed as the data
    path does): the same shape and peak, not the helmet's drop."""
    ds = open_dataset(kicks)
    assert ds.objects == ["football"]
    rig = ds.meta["provenance"]["rig"]
    assert rig["strike"]["felt"] == "receiver" and rig["helmet"]["mass"] == RECEIVERS["boot"].mass
    physics = Pipeline.from_effect(KICK, device="memory").model
    info = physics.object_for("football")
    bank = ds.bank("football", "dft321")
    assert bank.velocities.tolist() == SPEC["velocities_mps"]
    for v, recorded in zip(bank.velocities, bank.profiles):
        ref = highpass(physics._profile(info, float(v)), 1000.0)
        ref = np.pad(ref, (0, recorded.size - ref.size))
        corr = np.correlate(recorded, ref, "full") / (np.linalg.norm(recorded) * np.linalg.norm(ref))
        assert corr.max() > 0.97, f"{v} m/s: the recorded kick is not the family's ({corr.max():.3f})"
        assert abs(np.abs(recorded).max() / np.abs(ref).max() - 1.0) < 0.1


def test_an_interpolator_plays_the_family_to_a_wav(kicks, tmp_path):
    effect = yaml.safe_load((ROOT / "examples" / "families" / "football_kick_data.yaml").read_text())
    effect["model"]["dataset"] = str(kicks)
    path = tmp_path / "kick.yaml"
    path.write_text(yaml.safe_dump(effect))
    peaks = {}
    for v in (10.0, 15.0, 30.0):  # recorded, between two recorded, recorded
        out = tmp_path / f"kick-{v:g}.wav"
        r = _hfx("play", str(path), "--velocity", str(v), "--device", f"wav:{out}")
        assert r.returncode == 0, r.stderr
        rate, data = read_wav(out)
        assert rate == 48000 and np.all(np.isfinite(data))
        peaks[v] = float(np.abs(data).max())
    assert 0.0 < peaks[10.0] < peaks[15.0] < peaks[30.0] <= 1.0


def test_the_shipped_family_spec_is_valid():
    spec = load_spec(ROOT / "examples" / "datasets" / "football-kicks.yaml")
    assert [o.id for o in spec.objects] == ["football"] and len(spec.velocities["football"]) >= 8
    assert spec.rig.helmet == RECEIVERS["boot"] and spec.rig.strike.felt == "receiver"
    assert spec.rig.strike.stiffness == 2.3e5 and spec.variation.offset_mm == 5.0


@pytest.mark.parametrize("change, match", [
    (lambda s: s.update(objects=[]), r"objects: a family's effect gives the striker"),
    (lambda s: s["rig"].update(receiver="helmet"), r"rig.receiver: a family's effect names its receiver"),
    (lambda s: s.update(family="nowhere.yaml"), r"family: no effect file"),
    (lambda s: s.update(family=str(ROOT / "effects" / "falling_brick.yaml")), r"family: .*model.type is "
                                                                               r"'data-driven'"),
    (lambda s: s.update(velocities_mps=[10.0, 41.0]), r"velocities_mps: expected a number in \[0.001, 40\]"),
    (lambda s: s.update(velocities_mps=[10.0]), r"velocities_mps: expected a list of at least 2"),
    (lambda s: s.update(variation={"tilt_deg": -1}), r"variation.tilt_deg: expected a number in \[0, 1000\]"),
    (lambda s: s.update(variation={"wobble": 1}), r"variation: unknown key\(s\) wobble"),
])
def test_bad_family_specs_name_the_file_and_key(tmp_path, change, match):
    spec = copy.deepcopy(SPEC)
    change(spec)
    with pytest.raises(EffectError, match=r"spec.yaml: " + match):
        load_spec(_write(tmp_path, spec))
