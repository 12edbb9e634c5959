"""Output files: PCM WAV that every tool reads, nothing partial on failure, no silent overwrite."""

from __future__ import annotations

import subprocess
import sys
import wave

import numpy as np
import pytest

from hapticfx.actuators.files import WavWriter, check_overwrite, read_wav, write_wav, written_by_hapticfx
from hapticfx.errors import DeviceError, HapticfxError

KE = """name: brick-ke
object: concrete-brick
model: {type: kinetic-energy}
actuator: {type: wav, path: %s%s}
"""


def hfx(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "hapticfx", *map(str, args)], capture_output=True, text=True, cwd=cwd)


def test_an_effect_cannot_silently_replace_a_file_it_did_not_write(tmp_path):
    victim = tmp_path / "notes.wav"
    victim.write_text("my notes")
    effect = tmp_path / "e.yaml"
    effect.write_text(KE % (victim, ""))
    r = hfx("play", effect)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "notes.wav: exists and was not written by hapticfx; use actuator.overwrite: true" in r.stderr
    assert victim.read_text() == "my notes"
    effect.write_text(KE % (victim, ", overwrite: true"))
    assert hfx("play", effect).returncode == 0
    assert written_by_hapticfx(victim)
    effect.write_text(KE % (victim, ""))
    assert hfx("play", effect).returncode == 0  # its own output is replaced


def test_command_line_outputs_need_force_for_foreign_files(tmp_path):
    effect = tmp_path / "e.yaml"
    effect.write_text(KE % (tmp_path / "x.wav", ""))
    for out in ("r.wav", "r.png", "r.csv"):
        (tmp_path / out).write_text("keep me")
        r = hfx("render", effect, "--out", tmp_path / out)
        assert r.returncode == 2 and f"{out}: exists and was not written by hapticfx; use --force" in r.stderr
        assert (tmp_path / out).read_text() == "keep me"
        assert hfx("render", effect, "--out", tmp_path / out, "--force").returncode == 0
    assert written_by_hapticfx(tmp_path / "r.wav") and written_by_hapticfx(tmp_path / "r.png")
    (tmp_path / "p.wav").write_text("keep me")
    r = hfx("play", effect, "--device", f"wav:{tmp_path / 'p.wav'}")
    assert r.returncode == 2 and (tmp_path / "p.wav").read_text() == "keep me"


def test_a_failed_write_leaves_no_partial_file(tmp_path, monkeypatch):
    """Disk full while streaming (simulated: the file object raises ENOSPC, as a full disk does)."""
    writer = WavWriter(tmp_path / "a.wav", 1000)
    writer.write(np.zeros(100))

    def full(data):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(writer._file, "write", full)
    with pytest.raises(DeviceError, match=r"a.wav: cannot write: No space left on device"):
        writer.write(np.zeros(100))
    assert list(tmp_path.iterdir()) == []


def test_pcm_wav_is_read_by_the_standard_library(tmp_path):
    x = np.sin(np.linspace(0, 20, 4800))
    path = write_wav(tmp_path / "a.wav", x, 48000)
    with wave.open(str(path)) as w:
        assert (w.getnchannels(), w.getsampwidth(), w.getframerate(), w.getnframes()) == (1, 3, 48000, 4800)
    rate, y = read_wav(path)
    assert rate == 48000 and np.max(np.abs(y[0] - x)) < 2e-7
    with pytest.raises(HapticfxError, match="not a WAV file"):
        read_wav(tmp_path.joinpath("b.wav")) if (tmp_path / "b.wav").write_text("nope") else None
    check_overwrite(tmp_path / "nothing-here.wav", force=False)


def _with_file_size_limit(limit: int, *args, cwd=None):
    """Run hapticfx with every file capped at ``limit`` bytes (RLIMIT_FSIZE): writes past it fail with EFBIG,
    a real OS error as a full disk gives, without needing a full disk."""
    code = ("import resource, signal, sys; signal.signal(signal.SIGXFSZ, signal.SIG_IGN); "
            f"resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, {limit})); "
            "from hapticfx.cli import main; main(sys.argv[1:])")
    return subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True, cwd=cwd)


def test_a_write_the_machine_refuses_is_one_line_and_leaves_nothing(tmp_path):
    effect = tmp_path / "e.yaml"
    effect.write_text(KE % (tmp_path / "x.wav", ""))
    for out in ("r.wav", "r.png", "r.csv"):
        r = _with_file_size_limit(2000, "render", effect, "--out", tmp_path / out)
        assert r.returncode == 2, (out, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"hapticfx: error: {tmp_path / out}: "), r.stderr
        assert lines[0].endswith("File too large"), r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["e.yaml"]
