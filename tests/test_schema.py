"""The published JSON Schema: valid, up to date, and in agreement with the validator."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import jsonschema
import pytest
import yaml

from hapticfx.effect import check_effect, load_effect
from hapticfx.errors import EffectError

REPO = Path(__file__).resolve().parents[1]
PUBLISHED = REPO / "hapticfx" / "schema" / "effect.schema.json"
FIRST_PARTY = "soundcard,solenoid,neural"
EFFECTS = sorted((REPO / "effects").rglob("*.yaml"))


@pytest.fixture(scope="module")
def validator():
    schema = json.loads(PUBLISHED.read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def test_published_schema_is_up_to_date():
    r = subprocess.run([sys.executable, "-m", "hapticfx", "schema"], capture_output=True, text=True,
                       env={**os.environ, "HAPTICFX_PLUGINS": FIRST_PARTY}, check=True)
    assert json.loads(r.stdout) == json.loads(PUBLISHED.read_text()), (
        "regenerate: HAPTICFX_PLUGINS=soundcard,solenoid,neural hapticfx schema --out hapticfx/schema/effect.schema.json"
    )


@pytest.mark.parametrize("path", EFFECTS, ids=[str(p.relative_to(REPO)) for p in EFFECTS])
def test_shipped_effects_pass_schema_and_validator(validator, path):
    assert not list(validator.iter_errors(yaml.safe_load(path.read_text())))
    check_effect(load_effect(path))


@pytest.mark.parametrize("change", [
    lambda e: e["model"].__setitem__("interpolater", "linear"),
    lambda e: e["actuator"].__setitem__("gain", 2),
    lambda e: e.__setitem__("velocity_mps", -3),
    lambda e: e["actuator"].__setitem__("limits", {"peak": 1.5}),
    lambda e: e["model"].__setitem__("outside", "wrap"),
])
def test_schema_and_validator_agree_on_bad_files(validator, tmp_path, change):
    effect = yaml.safe_load((REPO / "effects" / "falling_brick.yaml").read_text())
    change(effect)
    assert list(validator.iter_errors(effect))
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(effect))
    with pytest.raises(EffectError):
        check_effect(load_effect(path))
