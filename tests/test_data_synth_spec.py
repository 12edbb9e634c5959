"""`hapticfx data synth --spec`: other objects, a velocity list per object, another helmet and sensor."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from hapticfx.data.dataset import open_dataset
from hapticfx.droprig.spec import load_spec
from hapticfx.errors import EffectError

SPEC = {
    "name": "mini-rig", "seed": 3, "drops": 2,
    "rig": {"helmet": {"mass": 2.8, "modes": [{"hz": 150.0, "zeta": 0.04, "mass": 1.3, "order": 1,
                                               "lateral": 0.04, "vertical": 0.06}]},
            "sensor": {"range_g": 6.0, "bias_g": [0.0, 0.01, -0.01]}},
    "objects": [
        {"id": "tile", "name": "Tile", "mass_kg": 0.12, "dimensions_mm": [100, 100, 8], "material": "ceramic",
         "velocities_mps": [2.0, 2.7, 3.5]},
        {"id": "mallet", "mass_kg": 0.25, "dimensions_mm": [60, 40, 40], "material": "rubber",
         "velocities_mps": [2.2, 3.1]},
    ],
}


def _write(tmp_path: Path, spec) -> Path:
    path = tmp_path / "spec.yaml"
    path.write_text(yaml.safe_dump(spec))
    return path


def test_the_shipped_second_rig_spec_is_valid():
    spec = load_spec(Path(__file__).parent.parent / "examples" / "datasets" / "second-rig.yaml")
    assert len(spec.objects) == 4 and len({len(v) for v in spec.velocities.values()}) > 1
    assert spec.rig.helmet.modes[0].hz == 152.0 and spec.rig.sensor.range_g == 6.0


def test_a_spec_simulates_its_own_objects_and_velocities(tmp_path):
    out = tmp_path / "mini"
    r = subprocess.run([sys.executable, "-m", "hapticfx", "data", "synth", str(out), "--spec",
                        str(_write(tmp_path, SPEC)), "--jobs", "1"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    ds = open_dataset(out)
    assert ds.name == "mini-rig" and sorted(ds.objects) == ["mallet", "tile"]
    assert ds.bank("tile", "max-min").velocities.tolist() == [2.0, 2.7, 3.5]
    assert ds.bank("mallet", "max-min").velocities.tolist() == [2.2, 3.1]
    assert ds.raw("tile")[1].shape[:2] == (3, 2)
    rig = ds.meta["provenance"]["rig"]
    assert rig["helmet"]["mass"] == 2.8 and rig["sensor"]["range_g"] == 6.0
    assert ds.meta["provenance"]["materials"]["tile"]["name"] == "ceramic"


@pytest.mark.parametrize("change, match", [
    (lambda s: s.update(colour="red"), r"spec: unknown key\(s\) colour"),
    (lambda s: s["objects"][0].update(material="cheese"), r"objects\[0\].material: unknown material 'cheese'"),
    (lambda s: s["objects"][1].update(velocities_mps=[2.0]), r"objects\[1\].velocities_mps: expected a list of at least 2"),
    (lambda s: s["objects"][1].update(velocities_mps=[2.0, "fast"]), r"objects\[1\].velocities_mps: expected a number"),
    (lambda s: s["objects"][1].update(id="tile"), r"objects\[1\].id: object 'tile' is listed twice"),
    (lambda s: s["objects"][0].update(mass_kg=-1), r"objects\[0\].mass_kg: expected a number in"),
    (lambda s: s["rig"]["helmet"].update(colour=1), r"rig.helmet: unknown key\(s\) colour"),
    (lambda s: s["rig"]["helmet"]["modes"][0].pop("hz"), r"rig.helmet.modes\[0\]: missing key\(s\) hz"),
    (lambda s: s["rig"]["sensor"].update(bias_g=[0.0]), r"rig.sensor.bias_g: expected a list of 3 numbers"),
    (lambda s: s["rig"]["sensor"].update(bits=14.5), r"rig.sensor.bits: expected an integer"),
    (lambda s: s.update(drops=0), r"drops: expected an integer in \[1, 1000\]"),
    (lambda s: s["rig"].update(receiver="anvil"), r"rig.receiver: unknown receiver 'anvil'; shipped: helmet, tabletop"),
])
def test_bad_specs_name_the_file_and_key(tmp_path, change, match):
    import copy

    spec = copy.deepcopy(SPEC)
    change(spec)
    with pytest.raises(EffectError, match=r"spec.yaml: " + match):
        load_spec(_write(tmp_path, spec))


def test_spec_and_object_options_do_not_mix(tmp_path):
    r = subprocess.run([sys.executable, "-m", "hapticfx", "data", "synth", str(tmp_path / "x"), "--spec",
                        str(_write(tmp_path, SPEC)), "--seed", "3"], capture_output=True, text=True)
    assert r.returncode == 2 and "--spec gives the objects, velocities and seed" in r.stderr
    assert not (tmp_path / "x").exists()


def test_drops_replaces_the_spec_count_and_the_dataset_says_so(tmp_path):
    # the same rig and objects recorded more times (a dense set to measure what a method could reach)
    out = tmp_path / "dense"
    r = subprocess.run([sys.executable, "-m", "hapticfx", "data", "synth", str(out), "--spec",
                        str(_write(tmp_path, SPEC)), "--drops", "3", "--jobs", "1"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    ds = open_dataset(out)
    assert ds.raw("tile")[1].shape[:2] == (3, 3) and ds.raw("mallet")[1].shape[:2] == (2, 3)
    assert ds.meta["provenance"]["command"].endswith("--drops 3")


def test_a_spec_names_a_shipped_receiver_the_same_the_contact_model_uses(tmp_path):
    import copy

    from hapticfx.droprig.receiver import RECEIVERS

    spec = copy.deepcopy(SPEC)
    spec["rig"] = {"receiver": "tabletop", "helmet": {"mass": 7.0}}
    rig = load_spec(_write(tmp_path, spec)).rig
    assert rig.helmet.modes == RECEIVERS["tabletop"].modes and rig.helmet.mass == 7.0
