"""The core alone (no plugin loaded: ``HAPTICFX_PLUGINS=""``) renders, exports and validates the shipped effects
whose model and interpolator are the core's.

The sound-card actuators' specs live in the core (hapticfx.actuators.known); only playing on a sound card needs
hapticfx-soundcard, and ``play`` then says what to install and writes the impact to files, as on a machine with
no sound device. The default falling effects use ensemble-warp and render with the core alone; the
ConvBiLSTM's (``falling_*_convbilstm.yaml``), whose table ships with hapticfx-neural (``scripts/install.sh``
installs it, without torch), say in one line without that plugin what to install.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BRICK = ROOT / "effects" / "falling_brick.yaml"
NETWORK_BRICK = ROOT / "effects" / "falling_brick_convbilstm.yaml"


def hapticfx(*args, cwd, plugins=""):
    env = {**os.environ, "HAPTICFX_PLUGINS": plugins}
    env.pop("PULSE_SERVER", None)
    env.pop("XDG_RUNTIME_DIR", None)
    return subprocess.run([sys.executable, "-m", "hapticfx", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, env=env)


def test_the_core_alone_renders_a_shipped_effect_as_the_plugin_would(tmp_path):
    alone = hapticfx("render", BRICK, "--out", "alone.wav", cwd=tmp_path)
    assert alone.returncode == 0, alone.stderr
    with_plugin = hapticfx("render", BRICK, "--out", "plugin.wav", cwd=tmp_path, plugins="soundcard")
    assert with_plugin.returncode == 0, with_plugin.stderr
    assert (tmp_path / "alone.wav").read_bytes() == (tmp_path / "plugin.wav").read_bytes()


def test_the_core_alone_exports_validates_and_plays_a_haptic_file_to_files(tmp_path):
    r = hapticfx("export", BRICK, "--format", "haptic", "--out", "brick.haptic", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r = hapticfx("validate", "brick.haptic", BRICK, cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    r = hapticfx("play", "brick.haptic", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "vibro-transducer plays through hapticfx-soundcard, which is not installed" in r.stdout
    assert len(r.stdout.splitlines()) == 1 and "Traceback" not in r.stderr
    assert sorted(p.suffix for p in tmp_path.glob("hapticfx-*")) == [".png", ".wav"]


def test_the_network_effect_without_the_neural_plugin_is_one_line_and_writes_nothing(tmp_path):
    r = hapticfx("render", NETWORK_BRICK, "--out", "x.wav", cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert r.stderr.strip().splitlines() == [
        f"hapticfx: error: {NETWORK_BRICK}: model.interpolator: unknown interpolator 'convbilstm'; it comes with "
        f"hapticfx-neural: pip install {ROOT / 'plugins' / 'hapticfx-neural'}; installed: ensemble, ensemble-warp, "
        "linear"]
    assert not list(tmp_path.iterdir())


def test_a_sound_card_option_without_the_plugin_is_one_line(tmp_path):
    effect = tmp_path / "e.yaml"
    effect.write_text(BRICK.read_text().replace("  gain: 0.8\n", "  gain: 0.8\n  queue: 0\n"))
    r = hapticfx("render", effect, "--out", "x.wav", cwd=tmp_path)
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1 and "queue" in r.stderr, r.stderr
    assert not (tmp_path / "x.wav").exists()


@pytest.mark.parametrize("name", ["vibro-transducer", "haptuator"])
def test_the_plugin_takes_its_spec_from_the_core(name):
    pytest.importorskip("hapticfx_soundcard")
    from hapticfx.actuators.known import KNOWN, spec_only
    from hapticfx.registry import get_registry

    plugin = get_registry().get("actuator", name).resolve()()
    assert plugin.spec == KNOWN[name].spec() == spec_only(name)().spec
