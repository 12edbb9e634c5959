"""`hapticfx export` and `hapticfx play|render|validate FILE.haptic|.ahap|...`, as a user runs them."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hapticfx.actuators.files import read_wav, write_wav
from hapticfx.cli import main

REPO = Path(__file__).resolve().parents[1]
BRICK = REPO / "effects" / "falling_brick_kinetic.yaml"


def hfx(capsys, *args) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as done:
        main([str(a) for a in args])
    out = capsys.readouterr()
    return done.value.code, out.out, out.err


@pytest.mark.parametrize("fmt, suffix", [("haptic", ".haptic"), ("ahap", ".ahap"), ("android", ".android.json"),
                                         ("hjif", ".hjif")])
def test_export_then_validate_and_render(tmp_path, capsys, fmt, suffix):
    out = tmp_path / f"brick{suffix}"
    code, text, err = hfx(capsys, "export", BRICK, "--format", fmt, "--out", out, "--velocity", "4.2")
    assert code == 0, err
    assert f"wrote {out}" in text and "concrete-brick at 4.20 m/s" in text
    assert hfx(capsys, "validate", out)[0] == 0
    wav = tmp_path / "brick.wav"
    code, text, err = hfx(capsys, "render", out, "--out", wav)
    assert code == 0, err
    rate, data = read_wav(wav)
    assert rate == 48000 and 0.01 < np.max(np.abs(data)) <= 1.0
    code, _, err = hfx(capsys, "export", BRICK, "--format", fmt, "--out", out)
    assert code == 2 and "exists; use --force" in err


def test_a_velocity_for_a_haptic_file_played_as_recorded_is_refused_not_ignored(tmp_path, capsys):
    """`render b.ahap --velocity 3` said "at 3.00 m/s" and played the file as recorded."""
    ahap = tmp_path / "b.ahap"
    assert hfx(capsys, "export", str(BRICK), "--format", "ahap", "--out", str(ahap))[0] == 0
    for command in ("render", "play"):
        args = [command, str(ahap), "--velocity", "3"] + (["-o", str(tmp_path / "b.csv")] if command == "render" else
                                                          ["--device", "memory"])
        code, _, err = hfx(capsys, *args)
        assert code == 2 and err.count("\n") == 1 and "plays as recorded at any velocity" in err, (command, err)
    assert not (tmp_path / "b.csv").exists()


def test_an_output_named_for_another_format_is_refused(tmp_path, capsys):
    """`--format ahap --out b.wav` wrote AHAP JSON into a file that players and `validate` take for a WAV."""
    code, _, err = hfx(capsys, "export", str(BRICK), "--format", "ahap", "--out", str(tmp_path / "b.wav"))
    assert code == 2 and err.count("\n") == 1 and "ahap files are named *.ahap" in err and "--out b.ahap" in err
    assert not (tmp_path / "b.wav").exists()


def test_export_a_folder_over_a_velocity_range(tmp_path, capsys):
    code, text, err = hfx(capsys, "export", BRICK, "--format", "haptic", "--out", tmp_path / "set",
                          "--velocities", "2:4:0.5")
    assert code == 0, err
    files = sorted(p.name for p in (tmp_path / "set").iterdir())
    assert files == [f"falling-brick-kinetic-{v:.2f}mps.haptic" for v in (2.0, 2.5, 3.0, 3.5, 4.0)]
    peaks = [max(p["amplitude"] for p in json.loads((tmp_path / "set" / f).read_text())
                 ["signals"]["continuous"]["envelopes"]["amplitude"]) for f in files]
    assert peaks == sorted(peaks) and peaks[0] < peaks[-1]  # faster drops, stronger files
    assert "[5/5]" in text



def test_an_effects_name_stays_inside_the_export_folder(tmp_path, capsys, write_effect):
    effect = write_effect(BRICK.read_text().replace("name: falling-brick-kinetic", "name: x/../../escaped"))
    code, _, err = hfx(capsys, "export", effect, "--format", "haptic", "--out", tmp_path / "set", "--velocities", "3,4")
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / "set").iterdir()) == ["x-..-..-escaped-3.00mps.haptic",
                                                                    "x-..-..-escaped-4.00mps.haptic"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["effect.yaml", "set"]


def test_a_velocity_the_model_refuses_leaves_no_part_of_the_batch(tmp_path, capsys, write_effect, tiny_dataset):
    """`outside: refuse` and a velocity beyond the recorded ones, last in the list: no file, no folder; and with
    --force an earlier batch is left as it was."""
    effect = write_effect({"name": "dd", "object": "concrete-brick", "velocity_mps": 3.0, "actuator": {"type": "memory"},
                           "model": {"type": "data-driven", "dataset": str(tiny_dataset), "outside": "refuse"}})
    args = ("export", effect, "--format", "ahap", "--out", tmp_path / "set", "--velocities")
    code, text, err = hfx(capsys, *args, "2.5,3,3.5,6")
    assert code == 2 and err.count("\n") == 1 and "6" in err and text == "", err
    assert not (tmp_path / "set").exists()
    assert hfx(capsys, *args, "2.5,3")[0] == 0
    (tmp_path / "set" / "dd-3.00mps.ahap").write_text("mine")
    before = {p.name: p.read_bytes() for p in (tmp_path / "set").iterdir()}
    code, _, err = hfx(capsys, *args, "3,2.5,6", "--force")
    assert code == 2, err
    assert {p.name: p.read_bytes() for p in (tmp_path / "set").iterdir()} == before


@pytest.mark.parametrize("velocities, said", [
    ("1:inf:1", "asks for inf files; at most 1000"), ("0:1e308:1e-308", "asks for inf files"),
    ("3,abc", "expected LO:HI:STEP"), ("5:1:1", "expected LO:HI:STEP"), ("1:2:nan", "expected LO:HI:STEP"),
    (",", "of 1 to 1000 velocities"), ("3,nan", "velocity must be finite"), ("-1:1:1", "velocity must be >= 0.0"),
])
def test_a_bad_velocity_range_is_refused_before_the_folder_is_made(tmp_path, capsys, velocities, said):
    code, _, err = hfx(capsys, "export", BRICK, "--format", "ahap", "--out", tmp_path / "set", "--velocities", velocities)
    assert code == 2 and err.startswith(f"hapticfx: error: --velocities {velocities!r}") and said in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "set").exists()

def test_export_a_wav_file(tmp_path, capsys):
    t = np.arange(9600) / 48000
    wav = tmp_path / "knock.wav"
    write_wav(wav, np.vstack([0.5 * np.exp(-t / 0.03) * np.sin(2 * np.pi * 90 * t)] * 2), 48000)
    out = tmp_path / "knock.haptic"
    code, text, err = hfx(capsys, "export", wav, "--format", "haptic", "--out", out)
    assert code == 0, err
    doc = json.loads(out.read_text())
    assert doc["metadata"]["source"] == "knock.wav"
    peak = max(p["amplitude"] for p in doc["signals"]["continuous"]["envelopes"]["amplitude"])
    assert 0.35 < peak <= 0.5



def _wav_bytes(fmt: bytes, payload: bytes) -> bytes:
    body = b"WAVE" + b"fmt " + struct.pack("<I", len(fmt)) + fmt + b"data" + struct.pack("<I", len(payload)) + payload
    return b"RIFF" + struct.pack("<I", len(body)) + body


def _fmt(tag=1, channels=1, rate=48000, bits=16) -> bytes:
    return struct.pack("<HHIIHH", tag, channels, rate, rate * channels * bits // 8, channels * bits // 8, bits)


@pytest.mark.parametrize("damage, said", [
    (lambda good: good[:30000], "truncated: the 'data' chunk needs a file of 144074 bytes, this one has 30000"),
    (lambda good: _wav_bytes(_fmt(), b"\x01\x02\x03"), "data: 3 bytes, expected a whole number of 2-byte frames"),
    (lambda good: _wav_bytes(_fmt(channels=2), b"\x01\x02" * 101), "data: 202 bytes, expected a whole number of 4-byte"),
    (lambda good: _wav_bytes(_fmt(channels=0), b"\x01\x02" * 100), "fmt: channels is 0, expected at least 1"),
    (lambda good: _wav_bytes(_fmt()[:12], b"\x01\x02" * 100), "fmt: a chunk of 12 bytes, expected at least 16"),
    (lambda good: _wav_bytes(_fmt(rate=0), b"\x01\x02" * 100), "fmt: sample rate is 0, expected at least 1"),
    (lambda good: _wav_bytes(_fmt(), b""), "data: no samples, expected at least one frame"),
    (lambda good: _wav_bytes(_fmt(tag=3, bits=32), np.full(100, np.nan, "<f4").tobytes()),
     "data: 100 sample(s) NaN or infinite, expected finite"),
])
def test_a_damaged_wav_file_is_one_line_naming_it_and_what_was_wrong(tmp_path, capsys, damage, said):
    good = tmp_path / "good.wav"
    write_wav(good, 0.5 * np.sin(np.arange(48000) / 10), 48000)  # 24-bit: 144000 bytes of samples
    bad = tmp_path / "bad.wav"
    bad.write_bytes(damage(good.read_bytes()))
    code, _, err = hfx(capsys, "export", bad, "--format", "ahap", "--out", tmp_path / "x.ahap")
    assert code == 2 and err.startswith(f"hapticfx: error: {bad}: ") and said in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x.ahap").exists()

@pytest.mark.parametrize("edit, where, rule", [
    (lambda env: env["amplitude"][1].update(amplitude=1.3), "amplitude[1].amplitude", "amplitude within 0.0-1.0"),
    (lambda env: env["amplitude"].reverse(), "amplitude[1].time", "non-decreasing time order"),
    (lambda env: env.update(amplitude=env["amplitude"][:1]), "envelopes.amplitude", "at least two amplitude breakpoints"),
])
def test_a_bad_file_is_one_line_exit_2_naming_file_path_and_rule(tmp_path, capsys, edit, where, rule):
    out = tmp_path / "b.haptic"
    assert hfx(capsys, "export", BRICK, "--format", "haptic", "--out", out)[0] == 0
    doc = json.loads(out.read_text())
    edit(doc["signals"]["continuous"]["envelopes"])
    out.write_text(json.dumps(doc))
    for command in (["validate", out], ["render", out, "--out", tmp_path / "x.wav"]):
        code, text, err = hfx(capsys, *command)
        assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
        assert str(out) in err and where in err and rule in err
    assert not (tmp_path / "x.wav").exists()


def test_missing_signals_is_refused(tmp_path, capsys):
    bad = tmp_path / "empty.haptic"
    bad.write_text('{"version": {"major": 1, "minor": 0, "patch": 0}, "metadata": {}}')
    code, _, err = hfx(capsys, "validate", bad)
    assert code == 2 and "$: required key 'signals' is missing" in err


def test_an_effect_whose_model_is_a_haptic_file_goes_through_the_limiter(tmp_path, capsys, write_effect):
    loud = tmp_path / "loud.haptic"
    loud.write_text(json.dumps({"version": {"major": 1, "minor": 0, "patch": 0}, "metadata": {}, "signals": {
        "continuous": {"envelopes": {"amplitude": [{"time": 0.0, "amplitude": 1.0}, {"time": 0.3, "amplitude": 1.0}],
                                     "frequency": []}}}}))
    effect = write_effect(f"name: loud\nobject: anything\nvelocity_mps: 2.0\nmodel: {{type: haptic-file, file: loud.haptic, "
                          "reference_velocity_mps: 4.0}\nactuator: {type: memory, gain: 1.0, limits: {peak: 0.3}}\n")
    from hapticfx.pipeline import Pipeline

    delivery = Pipeline.from_effect(effect).render()
    assert np.max(np.abs(delivery.profile.samples)) == pytest.approx(0.5, abs=0.01)  # 2 of 4 m/s: half strength
    assert np.max(np.abs(delivery.output.samples)) <= 0.3 + 1e-9 and delivery.limiter.peak_events > 0


def test_an_ahap_audio_event_is_said_in_one_line(tmp_path, capsys):
    ahap = tmp_path / "mixed.ahap"
    ahap.write_text('{"Pattern": [{"Event": {"EventType": "HapticTransient", "Time": 0.0}},'
                    '{"Event": {"EventType": "AudioCustom", "Time": 0.1, "EventWaveformPath": "x.wav"},},]}')
    code, text, err = hfx(capsys, "render", ahap, "--out", tmp_path / "m.wav")
    assert code == 0 and err.count("warning") == 1 and "AudioCustom" in err and "left out" in err


def test_exporting_and_rendering_a_haptic_file_imports_no_torch_or_sound_device(tmp_path):
    probe = f"""
import sys
from hapticfx.cli import main
for args in (["export", {str(BRICK)!r}, "--format", "haptic", "--out", {str(tmp_path / 'b.haptic')!r}],
             ["render", {str(tmp_path / 'b.haptic')!r}, "--out", {str(tmp_path / 'b.wav')!r}]):
    try:
        main(args)
    except SystemExit as e:
        assert e.code == 0, e.code
print([m for m in ("torch", "sounddevice", "serial") if m in sys.modules])
"""
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().splitlines()[-1] == "[]"
