"""The safety probe's sound-card cases (issue 31), each once: floods into the real null sink, what reached
it recorded from its monitor (parec) and measured in the sink's own time, every sample against the peak and
every 50 ms window against the RMS that applies (within the monitor's 16-bit step). ``hapticfx bench
safety`` runs them five times each, with longer floods."""

from __future__ import annotations

import pytest

from hapticfx_soundcard.bench import safety as probe

pytestmark = pytest.mark.soundserver


def check(v, *, outputs: int | None = 1):
    assert v.held, v
    assert v.peak > 0.5 * v.peak_limit, v  # the impacts did come through, loud enough for the limits to act
    if outputs is not None:
        assert v.note.startswith(f"{outputs} output(s)"), v.note


def test_late_writes_into_the_queue_keep_the_limits(soundserver):
    """Case 1: 300 impacts 2 ms apart, peak 0.3 / RMS 0.2, through the default mode (the queue at the server);
    it reached RMS 0.212-0.226 with 111-148 late writes per run."""
    check(probe.queued_flood())


def test_a_portaudio_stream_keeps_the_limits(soundserver):
    """Held before and after. Around an underrun PulseAudio cut up to 104 frames out of the stream and joined
    the rest without silence, which brought a window to 0.2001-0.2012 in 7 of 66 runs beside a CPU hog; the
    limiters now leave room for a 3 ms cut in every window (mixer.SPLICE_S), underflows or not."""
    check(probe.portaudio_flood(150))


@pytest.mark.parametrize("case", ["helmet-and-channel-0", "default-and-sink-name", "pulse-and-default",
                                  "own-actuators", "queued-and-portaudio-scene"])
def test_one_output_under_two_names_is_one_output_with_one_limiter(soundserver, case):
    """Case 2: the sum reached 0.595-0.600 against 0.3 through two limiters; stats() now lists one output."""
    check(probe.SOUNDCARD_CASES[case]())


def test_two_engines_in_one_process_share_the_outputs_limiter(soundserver):
    check(probe.two_engines(150))


def test_a_queued_and_a_portaudio_actuator_on_one_channel_are_refused(soundserver):
    """Outside an engine (which makes them one output), the second is refused with a clear error."""
    v = probe.queued_and_portaudio()
    assert v.refused and "already plays that output and channel" in v.refused and "`queue`" in v.refused, v


def test_an_effects_own_limits_hold_under_a_scene_actuator(soundserver):
    """Case 3: limits {peak: 0.2} played at 0.7955 under a scene actuator."""
    check(probe.routed_effect_limits(40))


@pytest.mark.parametrize("rate", [8000, 44100])
def test_an_actuator_at_another_rate_is_not_resampled_after_the_limiter(soundserver, rate):
    """Case 5: 8000 and 44100 Hz on a 48 kHz sink peaked at 0.3299 and 0.3006 against 0.3."""
    check(probe.other_rate(rate, 40))


def test_an_osc_flood_into_serve_keeps_the_hard_limits(soundserver):
    """Case 1: `hapticfx serve scenes/earthquake_room.yaml` flooded over UDP reached RMS 0.7158 against 0.7."""
    check(probe.osc_flood(2.0), outputs=None)
