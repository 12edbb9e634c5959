"""Fuzzing in the suite: every gate takes a few hundred mutants cleanly; the limiter holds the hard limits.

`hapticfx bench fuzz` runs 100,000 inputs per gate (docs/benchmarks.md); these runs are small enough for CI.
An input is a hang here after HANG_S, not the benchmark's 1 s: how long an input takes on a busy machine is
the benchmark's figure (its "slowest" column); the suite catches the inputs that never end.
"""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from hapticfx.fuzz.gates import gates
from hapticfx.fuzz.limits import HARD, check_limits, excess
from hapticfx.fuzz.mutate import mutate
from hapticfx.fuzz.runner import fuzz_gate

HANG_S = 20.0


@pytest.mark.parametrize("name", list(gates()))
def test_every_gate_refuses_mutants_in_one_short_line(name):
    r = fuzz_gate(gates()[name], 250, seed=11, time_limit_s=HANG_S)
    assert r.inputs == 250 and (r.tracebacks, r.hangs, r.bad_messages) == (0, 0, 0), r.examples
    assert r.refused > 0 and r.accepted > 0  # both paths ran: the seeds pass, mutants are refused


def test_random_overrides_never_take_the_output_past_the_hard_limits():
    r = check_limits(30, 25, seed=3)
    assert (r.overrides, r.signals, r.violations) == (30, 750, 0), r.worst


def test_the_hard_way_measure_finds_each_kind_of_excess():
    import numpy as np

    haptuator, solenoid = dict(HARD)["haptuator"], dict(HARD)["solenoid"]  # RMS 0.5 over 50 ms; 0.1 s on, 25 % duty
    quiet = np.full(4800, 0.45)
    assert excess(quiet, haptuator, 0.01, 0.01) is None
    assert excess(np.r_[quiet, 1.2], haptuator, 0.01, 0.01) == {"peak": 1.2}
    assert set(excess(np.full(2400, 0.6), haptuator, 0.01, 0.01)) == {"rms"}
    assert set(excess(np.full(150, 0.9), solenoid, 0.01, 0.01)) == {"on_time_s"}  # 150 ms in one pulse
    apart = np.r_[np.full(80, 0.9), np.zeros(10), np.full(80, 0.9)]  # two pulses, or one if 10 ms joins them
    assert excess(apart, solenoid, 0.01, 0.01) is None
    assert excess(apart, solenoid, 0.01, 0.011) == {"on_time_s": 0.16}
    pulses = np.tile(np.r_[np.full(90, 0.9), np.zeros(210)], 34)  # 90 ms on in every 300 ms: 30 % duty
    assert set(excess(pulses, solenoid, 0.01, 0.01)) == {"duty"}


@pytest.mark.parametrize("n, win, chunk", [(50, 7, 5), (50, 50, 3), (1000, 1, 64), (999, 40, 1 << 18)])
def test_the_windowed_rms_in_chunks_equals_the_direct_one(n, win, chunk):
    import numpy as np

    from hapticfx.fuzz.limits import _max_window_mean_square

    x = np.random.default_rng(n).standard_normal(n) * np.linspace(0, 3, n)
    direct = max(float(np.mean(x[i:i + win] ** 2)) for i in range(n - win + 1))
    assert _max_window_mean_square(x, win, chunk=chunk) == pytest.approx(direct, rel=1e-12)


def test_mutants_are_reproducible_and_differ_from_their_seed():
    import numpy as np

    seed = b"name: brick\nobject: concrete-brick\n"
    a = [mutate(seed, np.random.default_rng([1, i])) for i in range(50)]
    assert a == [mutate(seed, np.random.default_rng([1, i])) for i in range(50)]
    assert sum(x != seed for x in a) >= 45


@pytest.mark.parametrize("text, expected", [  # found by the fuzzer: each was a traceback
    ("actuator: {type: wav, path: ~nobody-here/out.wav}", "ok"),
    ("model: {type: data-driven, dataset: 'builtin:" + "x" * 300 + "'}", "no built-in dataset"),
    ("model: {type: data-driven, dataset: '" + "9" * 300 + ":helmet-drops'}", "cannot open (File name too long)"),
    ("model: {type: data-driven, reducer: " + "x" * 300 + "}", "is not a reducer name"),
])
def test_regressions_found_by_the_fuzzer(tmp_path, text, expected):
    from hapticfx.errors import HapticfxError
    from hapticfx.pipeline import Pipeline

    base = {"model": "model: {type: kinetic-energy}", "actuator": "actuator: {type: memory}"}
    base[text.split(":")[0]] = text
    path = tmp_path / "e.yaml"
    path.write_text(f"name: x\nobject: concrete-brick\n{base['model']}\n{base['actuator']}\n")
    if expected == "ok":
        Pipeline.from_effect(path).render()
        return
    with pytest.raises(HapticfxError, match=re.escape(expected)):
        Pipeline.from_effect(path).render()


def _encrypted_flag(npz: bytes) -> bytes:
    """Every central-directory entry of a zip marked as encrypted (general-purpose flag bit 0)."""
    out, at = bytearray(npz), npz.find(b"PK\x01\x02")
    while at >= 0:
        out[at + 8] |= 1
        at = npz.find(b"PK\x01\x02", at + 4)
    return bytes(out)


@pytest.mark.parametrize("case, expected", [  # found by the 100,000-input run of `bench fuzz dataset`
    ("window", "n_samples 550000 is more than 4 times the recordings' length"),  # was 400 MB of padding
    ("encrypted", "wood-beam.npz: corrupt or unreadable"),  # was a RuntimeError traceback
])
def test_dataset_regressions_found_by_the_fuzzer(tmp_path, case, expected):
    from hapticfx.errors import HapticfxError

    gate = gates()["dataset"]
    seed_json, seed_bank = gate.seeds(tmp_path)
    data = (seed_json.replace(b'    "n_samples": 500,', b'    "n_samples": 550000,', 1) if case == "window"
            else seed_bank[:1] + _encrypted_flag(seed_bank[1:]))
    assert data not in (seed_json, seed_bank)
    with pytest.raises(HapticfxError, match=re.escape(expected)) as err:
        gate.run(data, tmp_path)
    assert "\n" not in str(err.value) and len(str(err.value)) < 300


def test_the_command_reports_counts_and_fails_on_nothing_here():
    r = subprocess.run([sys.executable, "-m", "hapticfx", "bench", "fuzz", "osc", "serial", "limits", "--inputs", "100",
                        "--overrides", "5", "--signals", "5"], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "| osc " in r.stdout and "| limits " in r.stdout and "0 above a hard limit" in r.stdout
    r = subprocess.run([sys.executable, "-m", "hapticfx", "bench", "fuzz", "nope"], capture_output=True, text=True)
    assert r.returncode == 2 and "unknown or uninstalled gate(s) nope" in r.stderr


@pytest.mark.parametrize("name", [name for name, gate in gates().items() if gate.yaml])
def test_values_of_the_wrong_type_anywhere_are_refused_in_one_short_line(name):
    """The type-confusion mutator (lists, mappings, null, booleans, numbers where a name is expected, at
    every key); `hapticfx bench fuzz --mutator types` runs 10,000 per format (docs/benchmarks.md)."""
    r = fuzz_gate(gates()[name], 100, seed=5, mutator="types", time_limit_s=HANG_S)
    assert r.inputs == 100 and (r.tracebacks, r.hangs, r.bad_messages) == (0, 0, 0), r.examples
    assert r.refused > 50 and r.accepted > 0


def test_type_confused_mutants_are_reproducible_yaml_with_one_node_changed():
    import numpy as np
    import yaml

    from hapticfx.fuzz.confuse import confuse
    from hapticfx.fuzz.gates import SCENE_SEEDS

    seed = SCENE_SEEDS[0]
    a = [confuse(seed, np.random.default_rng([2, i])) for i in range(200)]
    assert a == [confuse(seed, np.random.default_rng([2, i])) for i in range(200)]
    trees = [yaml.safe_load(x) for x in a]  # valid YAML, every one
    assert sum(t != yaml.safe_load(seed) for t in trees) >= 190
    # the confusions the project's byte mutator rarely makes: a list where a name was, a non-string key
    assert any(isinstance(t, dict) and isinstance(t.get("effects"), dict)
               and any(isinstance(e, dict) and isinstance(e.get("actuator"), list) for e in t["effects"].values())
               for t in trees)
    assert any(isinstance(t, dict) and any(not isinstance(k, str) for k in t) for t in trees)


@pytest.mark.parametrize("gate, old, new, expected", [  # found by the type-confusion fuzz: each was a traceback
    ("scene", b"    actuator: helmet", b"    actuator: [helmet]", "effects.concrete-brick.actuator: unknown actuator"),
    ("study", b"actuator: vt, factors: {method: physics", b"actuator: {vt: 1}, factors: {method: physics",
     "stimuli.phys.actuator: unknown actuator"),
    ("study", b"    stimuli: [phys, phys-hap, real]", b"    stimuli: [[phys], phys-hap, real]", "unknown stimulus"),
    ("study", b"    pairs: [[phys, real]]", b"    pairs: [[[phys], real]]", "unknown stimulus"),
    ("study", b"    type: rating", b"    type: [rating]", "expected type rating, matching or similarity"),
])
def test_type_confusions_found_by_the_fuzzer(tmp_path, gate, old, new, expected):
    from hapticfx.errors import HapticfxError

    g = gates()[gate]
    seed = g.seeds(tmp_path)[0]
    assert seed.count(old) == 1
    with pytest.raises(HapticfxError, match=re.escape(expected)) as err:
        g.run(seed.replace(old, new), tmp_path)
    assert "\n" not in str(err.value) and len(str(err.value)) < 300


def test_the_command_runs_the_type_confusion_mutator_on_the_yaml_gates():
    r = subprocess.run([sys.executable, "-m", "hapticfx", "bench", "fuzz", "--mutator", "types", "scene", "--inputs",
                        "30"], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.startswith("mutator types, seed 0") and "| scene " in r.stdout
    r = subprocess.run([sys.executable, "-m", "hapticfx", "bench", "fuzz", "--mutator", "types", "osc"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "unknown or uninstalled gate(s) osc for --mutator types" in r.stderr


def test_the_hang_timer_is_disarmed_before_a_refusal_is_looked_at():
    """A refusal that came just inside the time limit was counted while the timer still ran: on a loaded machine
    the timer fired in the handler and ended `bench fuzz` with a traceback. A refusal whose message takes longer
    than the limit to format shows it deterministically."""
    import time

    from hapticfx.errors import HapticfxError
    from hapticfx.fuzz.gates import Gate

    class SlowToTell(HapticfxError):
        def __str__(self):
            time.sleep(0.2)
            return "refused"

    def run(data, work):
        raise SlowToTell("refused")

    r = fuzz_gate(Gate("slow", lambda w: [b"x"], run), 2, time_limit_s=0.05)
    assert (r.refused, r.hangs, r.tracebacks) == (2, 0, 0)
