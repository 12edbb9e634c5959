"""`hapticfx study run`: simulated participants through the real chain, and a run killed mid-study that resumes."""

from __future__ import annotations

import json
import math
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hapticfx.cli import main
from study_files import damaged, small_study, write_study


def _cli(*args) -> int:
    with pytest.raises(SystemExit) as exit_:
        main(list(args))
    return exit_.value.code


def _answers(path: Path) -> list[dict]:
    return [r for r in map(json.loads, path.read_text().splitlines()) if r["type"] == "answer"]


def _comparable(answer: dict) -> dict:
    """An answer without its times and session number."""
    drop = {"shown_at", "answered_at", "response_time_s", "session"}
    out = {k: v for k, v in answer.items() if k not in drop}
    out["slots"] = [{k: v for k, v in s.items() if k != "plays"} | {"plays": len(s["plays"])} for s in answer["slots"]]
    return out


@pytest.fixture
def study_file(tmp_path):
    study = small_study(t0={"repetitions": 3, "per_trial": "each"}, t2={"repetitions": 3})
    return write_study(tmp_path, study)


def test_simulated_participants_answer_every_trial(study_file, tmp_path, capsys):
    out = tmp_path / "results"
    assert _cli("study", "run", str(study_file), "--simulate", "--participants", "2", "--device", "memory", "--out", str(out)) == 0
    assert (out / "study.yaml").read_bytes() == study_file.read_bytes()
    for p in ("P01", "P02"):
        records = [json.loads(line) for line in (out / f"{p}.jsonl").read_text().splitlines()]
        assert records[0]["type"] == "session" and records[0]["simulated"] is True and records[-1]["type"] == "done"
        answers = [r for r in records if r["type"] == "answer"]
        assert [a["trial"] for a in answers] == list(range(records[0]["trials"]))
    assert "P02: 36 answers simulated (36/36" in capsys.readouterr().out
    assert _cli("study", "run", str(study_file), "--simulate", "--participant", "P01", "--device", "memory", "--out", str(out)) == 0
    assert "P01: already complete" in capsys.readouterr().out


def test_killed_run_resumes_without_losing_or_repeating_an_answer(study_file, tmp_path):
    killed, whole = tmp_path / "killed", tmp_path / "whole"
    cmd = [sys.executable, "-m", "hapticfx", "study", "run", str(study_file), "--participant", "P03", "--simulate",
           "--device", "memory"]
    proc = subprocess.Popen(cmd + ["--out", str(killed), "--pace", "0.05"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    results = killed / "P03.jsonl"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (results.exists() and len(_answers(results)) >= 8):
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait(10)
    before = results.read_bytes()
    n_before = len(_answers(results))
    assert 8 <= n_before < 36, n_before
    with open(results, "ab") as f:  # a crash in the middle of writing a line
        f.write(b'{"type": "answer", "trial": 99')
    subprocess.run(cmd + ["--out", str(killed)], check=True, capture_output=True, timeout=120)
    subprocess.run(cmd + ["--out", str(whole)], check=True, capture_output=True, timeout=120)

    after = results.read_bytes()
    assert after.startswith(before)  # nothing written before the kill changed
    resumed = _answers(results)
    assert [a["trial"] for a in resumed] == list(range(36))  # every trial once, in order
    assert {a["session"] for a in resumed[:n_before]} == {1} and {a["session"] for a in resumed[n_before:]} == {2}
    sessions = [json.loads(line) for line in after.splitlines() if b'"session"' in line and b'"type": "session"' in line]
    assert [s["resumed"] for s in sessions] == [False, True] and sessions[1]["discarded_bytes"] == 30
    # the interrupted participant answered exactly as one who was never interrupted
    assert [_comparable(a) for a in resumed] == [_comparable(a) for a in _answers(whole / "P03.jsonl")]


def test_resuming_with_a_changed_study_is_refused(study_file, tmp_path, capsys):
    out = tmp_path / "results"
    assert _cli("study", "run", str(study_file), "--simulate", "--participant", "P01", "--device", "memory", "--out", str(out)) == 0
    study_file.write_text(study_file.read_text().replace("seed: 11", "seed: 12"))
    assert _cli("study", "run", str(study_file), "--simulate", "--participant", "P01", "--device", "memory", "--out", str(out)) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"hapticfx: error: {out}: holds results of another study file ({out / 'study.yaml'} differs); choose another --out folder"


def test_user_errors_are_one_line_with_exit_2(study_file, tmp_path, capsys):
    assert _cli("study", "run", str(study_file), "--device", "memory") == 2
    assert capsys.readouterr().err.strip() == "hapticfx: error: --participant is required (a simulated run may give --participants N instead)"
    assert _cli("study", "run", str(study_file), "--participant", "Pxx", "--simulate", "--device", "memory",
                "--out", str(tmp_path / "r")) == 2
    assert "participant id 'Pxx' has no number" in capsys.readouterr().err
    bad = write_study(tmp_path, {**small_study(), "tasks": "none"}, name="bad.yaml")
    assert _cli("study", "check", str(bad)) == 2
    assert capsys.readouterr().err.strip() == f"hapticfx: error: {bad}: tasks: expected a non-empty list of tasks, got 'none'"
    assert not (tmp_path / "r").exists() or not list((tmp_path / "r").glob("*.jsonl"))


def test_check_summarises_the_schedule(study_file, capsys):
    assert _cli("study", "check", str(study_file), "--participant", "P02", "--trials") == 0
    out = capsys.readouterr().out
    assert "realism (rating): 4 conditions, 24 trials + 1 practice, 25 impacts, order latin-square" in out
    assert "(correct " in out and os.linesep in out


@pytest.mark.parametrize("pace", ["nan", "inf", "1e300", "61"])
def test_a_bad_pace_is_refused_before_anything_is_written(study_file, tmp_path, capsys, pace):
    out = tmp_path / "r"
    assert _cli("study", "run", str(study_file), "--simulate", "--participants", "1", "--device", "memory",
                "--out", str(out), "--pace", pace) == 2
    err = capsys.readouterr().err
    assert "--pace" in err and "Traceback" not in err and not out.exists(), err
    if math.isfinite(float(pace)):
        assert err == f"hapticfx: error: --pace: expected seconds between answers in [0, 60], got {float(pace):g}\n"


@pytest.mark.parametrize("how", ["random bytes", "a list line", "a rating of 1e9"])
def test_resuming_a_damaged_results_file_is_one_line_and_changes_nothing(study_file, tmp_path, capsys, how):
    out = tmp_path / "results"
    run = ("study", "run", str(study_file), "--simulate", "--participant", "P01", "--device", "memory", "--out", str(out))
    assert _cli(*run) == 0
    results = out / "P01.jsonl"
    expected = damaged(results, how)
    before = results.read_bytes()
    capsys.readouterr()
    assert _cli(*run) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"hapticfx: error: {results}: {expected}") and err.count("\n") == 1, err
    assert results.read_bytes() == before


def test_a_wav_output_that_cannot_be_written_is_refused_before_the_session_starts(study_file, tmp_path, capsys):
    (tmp_path / "a-file").write_text("not a folder")
    wav, out = tmp_path / "a-file" / "x.wav", tmp_path / "r"
    assert _cli("study", "run", str(study_file), "--simulate", "--participant", "P01", "--device", f"wav:{wav}",
                "--out", str(out)) == 2
    assert capsys.readouterr().err == \
        f"hapticfx: error: {wav}: cannot write in {wav.parent} (Not a directory)\n"
    assert not out.exists()


def test_a_file_the_user_wrote_at_a_wav_output_is_replaced_only_with_force(study_file, tmp_path, capsys):
    """The engine refuses to replace a file hapticfx did not write; `study run` had no --force to say it may."""
    wav, out = tmp_path / "x.wav", tmp_path / "r"
    wav.write_text("precious")
    run = ("study", "run", str(study_file), "--simulate", "--participant", "P01", "--device", f"wav:{wav}",
           "--out", str(out))
    assert _cli(*run) == 2
    err = capsys.readouterr().err
    assert "exists and was not written by hapticfx" in err and err.count("\n") == 1, err
    assert wav.read_text() == "precious"
    assert _cli(*run, "--force") == 0
    assert wav.read_bytes()[:4] == b"RIFF"


def test_a_port_in_use_is_refused_naming_it_before_anything_is_written(study_file, tmp_path, capsys):
    out = tmp_path / "r"
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        assert _cli("study", "run", str(study_file), "--participant", "P01", "--device", "memory", "--out", str(out),
                    "--port", str(port)) == 2
    assert capsys.readouterr().err == (f"hapticfx: error: cannot serve the participant's page on 127.0.0.1:{port}: "
                                       "Address already in use; choose another with --port (0: any free port)\n")
    assert not out.exists()
