"""The safety probe's cases that need no sound server (issue 31): third-party actuators registered at run
time, effect limits under a scene's actuator, the host's limiter at the rate an actuator agrees to, and the
held cases (a shared memory output, many threads). What reached the output is measured in its own time:
every sample against the peak, every 50 ms window against the RMS. The sound-card cases are in
plugins/hapticfx-soundcard/tests/test_safety_soundcard.py."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hapticfx.conformance import PROBE_LIMITS, PROBES, check_mix_limiter
from hapticfx.engine import Engine
from hapticfx.fuzz import probe
from hapticfx.fuzz.thirdparty import LyingMixer, ThirdParty
from hapticfx.interfaces import SafetyLimits
from hapticfx.sumbound import SumBound
from hapticfx.testing import assert_mix_limiter


def test_an_actuator_that_declares_limits_mix_and_limits_nothing_gets_the_hosts_bound():
    """Case 6: it summed overlapping impacts to 5.1 against 0.9 here (22.7 in the issue) before."""
    v = probe.lying_mixer(150)
    assert v.held, v
    assert v.peak > 0.3  # the impacts did come through


def test_the_same_actuator_under_a_plain_pipeline_gets_the_bound_too():
    v = probe.lying_mixer_pipeline(60)
    assert v.held, v
    assert v.peak > 0.3


def test_a_mixing_actuator_on_the_sessions_timeline_gets_the_bound_in_that_time():
    """The host's bound counted overlap by arrival, the actuator placed impacts by their time: six impacts with
    one `at`, 0.3 s apart, summed to 3.0 against a peak of 0.9 there."""
    v = probe.timeline_mixer()
    assert v.held, v
    assert v.peak > 0.3


def test_the_hosts_bound_checks_an_impact_placed_earlier_against_those_near_it_and_silences_one_too_far_back():
    bound = SumBound(SafetyLimits(peak=1.0, rms=1.0), 1000.0)
    pulse = np.ones(50)
    assert bound.process(pulse, at_s=1.0).max() == 1.0
    assert bound.process(pulse, at_s=0.8).max() == 0.0  # within reach of the first, out of order: no room left
    assert bound.process(pulse, at_s=1.0 + 2.5).max() == 1.0  # far enough after
    assert bound.process(pulse, at_s=0.0).max() == 0.0  # more than the horizon behind the latest
    assert any("silenced" in a for a in bound.report().acted)


def test_a_subclass_that_replaces_how_a_checked_actuator_plays_is_not_trusted_with_its_mix(caplog):
    """It inherited the WAV actuator's mix_probe and passing verdict: the host attached no limiter, and twenty
    impacts at one instant summed to 4.1 against a peak of 1."""
    v = probe.wav_remixer()
    assert v.held, v
    assert v.peak > 0.3
    assert "WavRemixer declares limits_mix and inherits the mix_probe of _FileActuator, but replaces" in caplog.text


def test_an_actuator_whose_rate_changes_after_open_is_refused_before_anything_plays_at_it():
    """The impact was shaped at the new rate and limited at the old: 50 ms windows reached RMS 0.64 against 0.3."""
    import yaml

    from hapticfx.effect import effect_from_mapping
    from hapticfx.errors import PluginError
    from hapticfx.pipeline import Pipeline

    effect = effect_from_mapping(yaml.safe_load(f"{{name: b, object: concrete-brick, model: {probe.LOUD}, "
                                                "actuator: {type: rate-shifter, gain: 1.0}}"),
                                 source="probe.yaml", base_dir=Path("."))
    with Pipeline(effect, registry=probe.registry_with(ThirdParty())) as pipeline:
        pipeline.impact()
        played = pipeline.actuator.timeline().size
        with pytest.raises(PluginError, match="changed its rate from 48000 Hz to 8000 Hz after open"):
            pipeline.impact()
        assert pipeline.actuator.timeline().size == played


def test_an_actuator_that_lowers_its_rate_in_open_is_limited_at_that_rate():
    """Case 6: a limiter left at 48 kHz let 50 ms windows at 8 kHz reach RMS 0.88 against 0.5."""
    v = probe.rate_dropper(30)
    assert v.held, v
    assert v.rms > 0.4 and v.note == "runs at 8000 Hz"


def test_a_wav_output_holds_the_limit_in_the_files_own_time():
    """Case 4 (the file outputs keep the limit in the file's time): overlapping impacts summed in the file."""
    v = probe.wav_flood(150)
    assert v.held, v
    assert v.peak > 0.5


@pytest.mark.parametrize("threads", [1, 8])
def test_a_shared_memory_output_holds_under_a_flood(threads):
    """Held before and after: impacts of four effects on one memory output, back to back as it keeps them."""
    v = probe.shared_memory(800, threads=threads)
    assert v.held, v


def test_a_mixer_that_does_not_limit_fails_the_conformance_check_and_one_that_does_passes():
    class Unlimited:
        """Sums what it is given, limits nothing."""

        @classmethod
        def mix_probe(cls, limits, rate_hz):
            class Probe:
                out = np.zeros(int(rate_hz * 2))

                def play(self, samples, at_frame):
                    self.out[at_frame:at_frame + samples.size] += samples

                def output(self, frames):
                    return self.out[:frames]
            return Probe()

    class Bounded(Unlimited):
        """Sums through the host's bound: it holds."""

        @classmethod
        def mix_probe(cls, limits, rate_hz):
            inner, bound = Unlimited.mix_probe(limits, rate_hz), SumBound(limits, rate_hz)

            class Probe:
                def play(self, samples, at_frame):
                    inner.play(bound.process(samples, at_s=at_frame / rate_hz), at_frame)

                def output(self, frames):
                    return inner.output(frames)
            return Probe()

    class Fixed(Unlimited):
        """Limits its sum to the first probe's limits, whatever it is given."""

        @classmethod
        def mix_probe(cls, limits, rate_hz):
            return Bounded.mix_probe(PROBE_LIMITS, rate_hz)

    problems = check_mix_limiter(Unlimited)
    assert any("over the limit" in p for p in problems) and any("windows" in p for p in problems)
    assert not check_mix_limiter(Fixed) and check_mix_limiter(Fixed, limits=PROBES[1])
    with pytest.raises(AssertionError, match="Fixed"):
        assert_mix_limiter(Fixed, seeds=(0,))
    assert "has no mix_probe" in check_mix_limiter(LyingMixer)[0]
    assert_mix_limiter(Bounded)
    with pytest.raises(AssertionError, match="Unlimited"):
        assert_mix_limiter(Unlimited, seeds=(0,))


def scene(tmp_path, *, scene_limits="", effect_limits="{peak: 0.2}"):
    path = tmp_path / "scene.yaml"
    loud = probe.LOUD
    path.write_text(f"""
name: routed
actuators:
  helmet: {{type: memory, rate_hz: 8000{scene_limits}}}
effects:
  brick: {{actuator: helmet, inline: {{name: brick, object: concrete-brick, model: {loud},
           actuator: {{type: vibro-transducer, limits: {effect_limits}}}}}}}
  plate: {{actuator: helmet, inline: {{name: plate, object: steel-plate, model: {loud}, actuator: {{type: memory}}}}}}
engine: {{queue_size: 64}}
""")
    return path


@pytest.mark.parametrize("scene_limits", ["", ", limits: {peak: 0.5}"])
def test_an_effects_own_limits_hold_wherever_a_scene_routes_it_and_stats_say_which_acted(tmp_path, scene_limits,
                                                                                        caplog):
    """Case 3: an effect with limits {peak: 0.2} routed to a scene's shared actuator played at 0.7955; a scene
    may lower a limit, never raise it (its peak 0.5 does not lift the effect's 0.2)."""
    with Engine(scene(tmp_path, scene_limits=scene_limits)) as engine:
        for _ in range(5):
            engine.impact("brick", 5.0)
        stats = engine.close()
    played = engine._outputs["actuators.helmet"].actuator.played
    assert max(float(np.abs(s.samples).max()) for s in played) <= 0.2
    out = stats["outputs"]["actuators.helmet"]
    assert out["limits"]["peak"] == {"value": 0.2, "set_by": f"effect {tmp_path / 'scene.yaml'} (effects.brick.inline)"}
    assert any(a.startswith("peak 0.2 set by effect") for a in out["limits_acted"])
    assert "the safety limit acted: peak 0.2 set by effect" in caplog.text


def test_a_scene_lowers_a_limit_for_every_effect_it_routes(tmp_path):
    with Engine(scene(tmp_path, scene_limits=", limits: {peak: 0.1}", effect_limits="{rms: 0.5}")) as engine:
        engine.impact("plate", 5.0)
        stats = engine.close()
    played = engine._outputs["actuators.helmet"].actuator.played
    assert float(np.abs(played[0].samples).max()) <= 0.1
    assert stats["outputs"]["actuators.helmet"]["limits"]["peak"]["set_by"].startswith("scene ")


@pytest.mark.parametrize("first", ["plain", "strict"])
def test_an_effects_own_limits_hold_on_a_shared_outputs_sum_whichever_entry_comes_first(first):
    """With the plain effect listed first, eight impacts of the strict one at one instant summed to peak 1.0 and
    RMS 0.70 in the file: its limits compared equal to the plain effect's (``==`` ignores what they carry in
    ``also``) and the output's limiter dropped them."""
    v = probe.strict_beside_plain(first)
    assert v.held, v
    assert v.rms > 0.09  # the impacts came through, up to its RMS limit


def test_strictest_limits_keep_a_stricter_limit_carried_by_equal_looking_limits():
    hard = SafetyLimits(source="actuator")
    carried = hard.strictest(hard.lowered(peak=0.2, source="effect"))
    assert carried == hard  # the same values of its own: only what it carries differs
    assert min(c.peak for c in hard.strictest(carried).constraints()) == 0.2
    assert hard.strictest(hard) is hard and carried.strictest(hard) is carried


def test_strictest_limits_hold_every_window_of_each():
    a = SafetyLimits(peak=1.0, rms=0.7, source="a")
    b = SafetyLimits(peak=0.5, rms=0.9, rms_window_s=0.01, source="b")
    both = a.strictest(b)
    assert {(c.rms, c.rms_window_s) for c in both.constraints()} == {(0.7, 0.05), (0.9, 0.01)}
    assert both.describe()["peak"] == {"value": 0.5, "set_by": "b"}
    assert a.strictest(a) is a


def test_the_hosts_verdict_is_computed_once_per_version_of_the_code(tmp_path, monkeypatch):
    from hapticfx import conformance
    from hapticfx.actuators.virtual import WavActuator

    monkeypatch.setenv("HAPTICFX_CACHE", str(tmp_path))
    calls = []
    real = conformance.check_mix_limiter
    monkeypatch.setattr(conformance, "check_mix_limiter", lambda cls, **kw: calls.append(cls) or real(cls, **kw))
    actuator = WavActuator.__new__(WavActuator)
    for _ in range(2):
        monkeypatch.setattr(conformance, "_verdicts", {})  # a new process
        assert conformance.limits_own_mix(actuator)
    owner = WavActuator.__mro__[1]  # the class whose mix_probe it uses (checked once for WAV and CSV)
    assert calls == [owner] * len(conformance.PROBES)  # under each probe's limits; the second process read them
    monkeypatch.setattr(conformance, "fingerprint", lambda cls: "other code")
    monkeypatch.setattr(conformance, "_verdicts", {})
    assert conformance.limits_own_mix(actuator) and calls == [owner] * 2 * len(conformance.PROBES)


def test_a_class_without_a_source_file_is_checked_and_not_remembered(tmp_path, monkeypatch):
    """Defined in a REPL, a notebook or `python -c`: no file to fingerprint (it raised AttributeError)."""
    import sys
    import types

    from hapticfx import conformance
    from hapticfx.actuators.virtual import WavActuator

    monkeypatch.setenv("HAPTICFX_CACHE", str(tmp_path))
    module = types.ModuleType("fx_no_file")  # no __file__, as __main__ in a REPL
    monkeypatch.setitem(sys.modules, "fx_no_file", module)
    owner = type("Repl", (WavActuator,), {"__module__": "fx_no_file", "mix_probe": WavActuator.mix_probe})
    assert conformance.fingerprint(owner) is None
    assert conformance.limits_own_mix(owner.__new__(owner)) and not (tmp_path / "conformance.json").exists()


def test_a_single_module_plugin_is_fingerprinted_by_its_own_file(tmp_path, monkeypatch):
    """Not every file in the folder it sits in (site-packages: sixteen thousand)."""
    import sys
    import types

    from hapticfx import conformance

    (tmp_path / "fx_single.py").write_text("x = 1\n")
    (tmp_path / "neighbour.py").write_text("y = 1\n")
    module = types.ModuleType("fx_single")
    module.__file__ = str(tmp_path / "fx_single.py")
    monkeypatch.setitem(sys.modules, "fx_single", module)
    cls = type("Single", (), {"__module__": "fx_single"})
    before = conformance.fingerprint(cls)
    (tmp_path / "neighbour.py").write_text("y = 2\n")
    assert conformance.fingerprint(cls) == before
    (tmp_path / "fx_single.py").write_text("x = 2\n")
    assert conformance.fingerprint(cls) != before
