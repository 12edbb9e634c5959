"""The actuators on a real PulseAudio null sink, recorded back from its monitor."""

import re
import sys
import time
from contextlib import contextmanager

import numpy as np
import pytest
from hapticfx.errors import DeviceError
from hapticfx.params import BuildContext
from hapticfx.signal import Signal

from hapticfx_soundcard.actuator import Haptuator, VibroTransducer
from hapticfx_soundcard.bench.output import LoopbackRecorder

pytestmark = pytest.mark.soundserver
RATE = 48000


def impact(n=2400, f=180.0, amp=0.4, decay=25.0):
    t = np.arange(n) / RATE
    return amp * np.exp(-decay * t) * np.sin(2 * np.pi * f * t) * (1 - np.exp(-t * 2000))


ATTEMPTS = 3
# What these tests check is the signal path, not how often a busy machine starves a stream (that is
# `hapticfx bench output`'s): the streams they record get buffers far longer than the machine's stalls
# under load, so that a recording holds what was played. 5.3 ms blocks keep impacts' onsets apart.
STEADY = dict(queue=0.0, latency=0.25, max_latency=0.0, blocksize=256)
CAPTURE_LATENCY_S = 0.25


def record_while(play, seconds, *actuators):
    """Record the monitor (both channels) around ``play()``, 0.1 s padding before and after.

    A recording in which ``actuators``' stream underflowed or was fed late (a wait between
    two audio callbacks longer than its buffer, which PortAudio does not always report as
    an underflow), or the capture overflowed, may hold a gap, not what was played: it is
    made again, up to ATTEMPTS times (a stall of the machine longer than the buffer,
    docs/benchmarks.md, "Underflows against the machine's own stalls").
    """
    def starved():
        return sum(len(a.underflow_times) + len(a.late_callbacks) for a in actuators)

    for _ in range(ATTEMPTS):
        before = starved()
        with LoopbackRecorder(RATE, latency=CAPTURE_LATENCY_S) as rec:
            time.sleep(0.1)
            play()
            time.sleep(seconds + 0.2 + STEADY["latency"] + CAPTURE_LATENCY_S)  # heard behind both buffers
        if rec.overflows == 0 and starved() == before:
            return np.concatenate(rec.capture.blocks).astype(np.float64)
    pytest.fail(f"the machine starved the stream or the capture in each of {ATTEMPTS} recordings")


def align(captured, reference):
    """``captured`` cut at the lag that best matches ``reference`` (full cross-correlation)."""
    from scipy.signal import correlate

    c = correlate(captured, reference, mode="valid", method="fft")
    lag = int(np.argmax(c))
    return captured[lag:lag + reference.size], lag


def corr(a, b):
    return float(np.corrcoef(a, b)[0, 1])


def test_played_signal_comes_back_unchanged(soundserver):
    sig = impact()
    with VibroTransducer(VibroTransducer.Params(**STEADY), BuildContext(device="default")) as act:
        assert act.spec.rate_hz == RATE
        assert sys.getswitchinterval() <= 0.001  # the Python callback gets the GIL within a block
        cap = record_while(lambda: act.play(Signal(sig, RATE)), sig.size / RATE, act)
        assert act.limiter_report().total == 0
    got, _ = align(cap[:, 0], sig)
    assert corr(got, sig) > 0.999
    level = np.sqrt(np.mean(got ** 2)) / np.sqrt(np.mean(sig ** 2))
    assert level == pytest.approx(1.0, abs=0.01)  # within 0.09 dB
    assert np.max(np.abs(cap[:, 1])) < 1e-3  # the other channel stays silent


def test_overlapping_impacts_add_up_in_one_stream(soundserver):
    # a sounds 0.25 s: b, played 20 ms after it, starts while it sounds although the long buffer's
    # callbacks come in bursts (tens of ms apart)
    a, b = impact(n=RATE // 4, f=120.0, amp=0.3, decay=8.0), impact(n=1800, f=330.0, amp=0.25)
    with VibroTransducer(VibroTransducer.Params(**STEADY), BuildContext()) as act:
        def both():
            act.play(Signal(a, RATE))
            time.sleep(0.02)  # b starts while a still sounds
            act.play(Signal(b, RATE))
        cap = record_while(both, 0.1, act)[:, 0]
    _, lag_a = align(cap, a)
    # Each impact's onset, from a correlation against the residual:
    rest = cap.copy()
    rest[lag_a:lag_a + a.size] -= a
    _, lag_b = align(rest, b)
    # the long buffer's callbacks come in bursts: b may be mixed in from a's own block on
    assert 0 <= lag_b - lag_a < a.size, "b must start while a is still sounding"
    ref = np.zeros(cap.size)
    ref[lag_a:lag_a + a.size] += a
    ref[lag_b:lag_b + b.size] += b
    span = slice(lag_a, max(lag_a + a.size, lag_b + b.size))
    assert corr(cap[span], ref[span]) > 0.999
    assert np.max(np.abs(cap[span] - ref[span])) < 0.01


def test_two_actuators_share_a_device_one_channel_each(soundserver):
    a, b = impact(f=150.0), impact(f=400.0, amp=0.2)
    vib = VibroTransducer(VibroTransducer.Params(**STEADY), BuildContext(device="default", channel=0))
    hap = Haptuator(Haptuator.Params(**STEADY), BuildContext(device="default", channel=1))
    with vib, hap:
        assert vib._stream is hap._stream  # one stream per device
        cap = record_while(lambda: (vib.play(Signal(a, RATE)), hap.play(Signal(b, RATE))), a.size / RATE, vib)
    got_a, _ = align(cap[:, 0], a)
    got_b, _ = align(cap[:, 1], b)
    assert corr(got_a, a) > 0.999
    assert corr(got_b, b) > 0.999


def test_a_signal_at_another_rate_is_resampled(soundserver):
    sig1k = impact(n=200, f=80.0)
    with VibroTransducer(VibroTransducer.Params(**STEADY), BuildContext()) as act:
        cap = record_while(lambda: act.play(Signal(sig1k, 1000.0)), 0.25, act)[:, 0]
    from hapticfx.shaping import resample

    ref = resample(Signal(sig1k, 1000.0), RATE).samples
    got, _ = align(cap, ref)
    assert corr(got, ref) > 0.999


def test_drain_waits_until_heard_and_close_drains(soundserver):
    sig = impact(n=RATE // 2)  # 0.5 s
    with VibroTransducer(VibroTransducer.Params(queue=0.0), BuildContext()) as act:
        t = time.monotonic()
        act.play(Signal(sig, RATE))
        queued = time.monotonic() - t
        act.drain(timeout=3.0)
        waited = time.monotonic() - t
    # play() does not block on the device (it would take the signal's 0.5 s; the margin is the machine's load)
    assert queued < 0.25
    assert waited >= 0.5  # not before it was heard; had it not ended, drain(timeout=3.0) would have raised


def test_device_by_name_and_index(soundserver):
    from hapticfx_soundcard.devices import output_devices

    pulse = next(d for d in output_devices() if d.name == "pulse")
    for device in ("pulse", pulse.index, str(pulse.index)):
        with VibroTransducer(VibroTransducer.Params(queue=0.0), BuildContext(device=device)) as act:
            act.play(Signal(impact(n=480), RATE))
            act.drain(timeout=2.0)


def test_unknown_device_is_a_clear_error(soundserver):
    act = VibroTransducer(VibroTransducer.Params(queue=0.0), BuildContext(device="no-such-card"))
    with pytest.raises(DeviceError, match=r"no sound output device matches 'no-such-card'; outputs: .*pulse"):
        act.open()
    with pytest.raises(DeviceError, match="index 99"):
        VibroTransducer(VibroTransducer.Params(queue=0.0), BuildContext(device=99)).open()
    with pytest.raises(DeviceError, match="channel 40 does not exist"):
        VibroTransducer(VibroTransducer.Params(queue=0.0), BuildContext(channel=40)).open()


def test_a_device_playing_into_a_pulseaudio_sink_runs_at_the_sinks_rate(soundserver):
    """ALSA's `default` plays into the server's null sink (48 kHz): the stream runs at the sink's rate, whatever
    was asked, so the server resamples nothing after the limiter (issue 31, case 5)."""
    act = VibroTransducer(VibroTransducer.Params(queue=0.0, rate_hz=44100), BuildContext())
    assert act.spec.rate_hz == 44100  # known before the device is touched
    with act:
        assert act.spec.rate_hz == 48000 and "runs at 48000 Hz" in act.note
        act.play(Signal(impact(n=480), 44100.0))  # resampled to the stream rate, then mixed and limited
        act.drain(timeout=2.0)


def test_one_channel_twice_shares_its_limiter_with_the_strictest_limits(soundserver):
    """Two actuators on one device and channel (two effects, two engines) play through one stream, whose one
    limiter on that channel holds the stricter limits of the two (the haptuator's RMS 0.5) on their sum."""
    with VibroTransducer(VibroTransducer.Params(queue=0.0), BuildContext(channel=0)) as a, \
            Haptuator(Haptuator.Params(queue=0.0, rate_hz=44100), BuildContext(channel=0)) as b:
        assert a._stream is b._stream and b.spec.rate_hz == a.spec.rate_hz
        limiter = a._stream.mixer._limiters[0]
        assert sorted(c.rms for c in limiter.limits.constraints()) == [0.5, 0.7]
    assert a.output_key() == b.output_key()


def test_a_plain_actuator_leaving_a_shared_channel_leaves_the_stricter_limits_on_it(soundserver):
    """The stricter limits (peak 0.2, carried in `also`) compare equal to the plain ones: the leaving actuator's
    were looked up by `==`, so the stricter entry was removed and the channel's limiter went back to peak 1."""
    a = VibroTransducer(VibroTransducer.Params(queue=0.0), BuildContext(channel=0))
    a.limits = a.spec.limits.strictest(a.spec.limits.lowered(peak=0.2, source="effect quiet"))
    with a:
        with VibroTransducer(VibroTransducer.Params(queue=0.0), BuildContext(channel=0)) as b:
            assert a._stream is b._stream and a.limits == b.limits
        assert a._stream.mixer._limiters[0]._peak == 0.2


def test_a_device_name_that_matches_no_output_beside_others_is_an_error_not_a_file(soundserver, tmp_path):
    """A typo in an effect's device (or an index that does not exist) was taken for a machine without sound
    outputs: `play` wrote the impact to a file and exited 0."""
    import subprocess
    from pathlib import Path

    effect = (Path(__file__).resolve().parents[3] / "effects" / "falling_brick.yaml").read_text()
    for device in ("no-such-card", "99"):
        path = tmp_path / "typo.yaml"
        path.write_text(effect.replace("device: default", f"device: '{device}'"))
        done = subprocess.run([sys.executable, "-m", "hapticfx", "play", str(path)], cwd=tmp_path,
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
        assert "no sound output device" in done.stderr and "pulse" in done.stderr
        assert not list(tmp_path.glob("hapticfx-*"))


def test_play_before_open_is_an_error(soundserver):
    with pytest.raises(DeviceError, match="not open"):
        Haptuator().play(Signal(np.zeros(10), RATE))


@pytest.mark.parametrize("effect", ["falling_brick.yaml"])
def test_an_effect_played_through_the_pipeline_is_heard_as_rendered(soundserver, effect):
    from pathlib import Path

    from hapticfx.pipeline import Pipeline

    path = Path(__file__).resolve().parents[3] / "effects" / effect
    pipeline = Pipeline.from_effect(path)
    deliveries = []
    with pipeline:
        assert pipeline.actuator.name == "vibro-transducer"
        cap = record_while(lambda: deliveries.append(pipeline.impact(velocity=3.8)), 0.5, pipeline.actuator)[:, 0]
    sent = deliveries[-1].output.samples  # the recording kept is the last one made
    assert deliveries[-1].output.rate_hz == RATE
    got, _ = align(cap, sent)
    assert corr(got, sent) > 0.999
    assert np.sqrt(np.mean(got ** 2)) / np.sqrt(np.mean(sent ** 2)) == pytest.approx(1.0, abs=0.01)


def test_effects_sharing_a_sound_card_are_limited_on_their_mix(soundserver, tmp_path):
    from pathlib import Path

    from hapticfx.engine import Engine

    effects = Path(__file__).resolve().parents[3] / "effects"
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"""name: shared
actuators:
  helmet: {{type: vibro-transducer, device: default, limits: {{peak: 0.3}}}}
effects:
  brick: {{effect: {str(effects / 'falling_brick.yaml')!r}, actuator: helmet}}
  pulse: {{effect: {str(effects / 'falling_brick_kinetic.yaml')!r}, actuator: helmet}}
""")
    played = []
    with LoopbackRecorder(RATE) as rec:
        with Engine(scene, on_played=played.append) as engine:
            (out,) = engine._outputs.values()
            assert out.actuator.limits_mix and out.limiter is None  # the mixer limits the sum, not the engine
            time.sleep(0.1)
            for _ in range(3):  # each impact within 0.3 on its own, the six together far above it
                engine.impact("brick", 5.2)
                engine.impact("pulse", 7.0)
            time.sleep(0.8)
            report = out.actuator.limiter_report()
    x = np.concatenate(rec.capture.blocks)[:, 0]
    assert all(p.signal.peak <= 0.3 + 1e-12 for p in played) and len(played) == 6
    assert 0.25 < np.max(np.abs(x)) <= 0.3 + 1e-6
    assert report.peak_events > 0


@pytest.mark.parametrize("setting, frozen", [(None, True), ("0", False)])
def test_opening_a_stream_takes_the_heap_out_of_full_collections(soundserver, setting, frozen):
    import os
    import subprocess

    code = ("import gc\nfrom hapticfx_soundcard.actuator import VibroTransducer\n"
            "before = gc.get_freeze_count()\n"
            "with VibroTransducer():\n    print(before, gc.get_freeze_count())\n")
    env = {k: v for k, v in os.environ.items() if k != "HAPTICFX_GC_FREEZE"}
    if setting is not None:
        env["HAPTICFX_GC_FREEZE"] = setting
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60)
    before, after = map(int, done.stdout.split())
    assert before == 0 and (after > 1000) == frozen and (after == 0) == (not frozen)


# The stop tests start a PortAudio stream at 50 ms, a buffer that a loaded machine's own stalls do not
# empty, and stop this process for 300 ms, which it cannot hold: the underflow they see is their own.
START_LATENCY_S = 0.05
STOP_S = 0.3


@contextmanager
def settled_transducer(params, caplog=None):
    """A vibro-transducer on the default device, 0.5 s past its stream's start, that has not underflowed
    since then: a test that stops this process must see its own underflow first. Where the machine's own
    stall came first (docs/benchmarks.md), the actuator is opened again (and ``caplog`` cleared), up to
    ATTEMPTS times."""
    from hapticfx_soundcard.stream import START_S

    for _ in range(ATTEMPTS):
        opened = time.monotonic()
        with VibroTransducer(params, BuildContext(device="default")) as act:
            time.sleep(0.5)
            if not act.buffer_changes and not any(t > opened + START_S for t in act.underflow_times):
                yield act
                return
        if caplog is not None:
            caplog.clear()
    pytest.fail(f"the machine starved the stream before the test's own stop in each of {ATTEMPTS} attempts")


def stop_this_process_until_an_underflow(act, seconds=STOP_S):
    """Stop this whole process (SIGSTOP, from a child) for ``seconds``, longer than the stream's
    buffer: what a host taking the CPU away does. Returns when the stop began."""
    import os
    import subprocess

    before = act.underflows
    t0 = time.monotonic()
    # PortAudio learns of the server's underrun from ALSA's pulse plugin, which let 1 of 40 such stops in a
    # row pass unreported (no ALSA "underrun occurred" either); a stop that shows none is made again.
    for _ in range(3):
        subprocess.run(["sh", "-c", f"kill -STOP {os.getpid()}; sleep {seconds}; kill -CONT {os.getpid()}"],
                       check=True)
        time.sleep(0.3)
        if act.underflows > before:
            break
    return t0


def test_a_stream_left_unfed_longer_than_its_buffer_counts_times_and_tells_the_underflow(soundserver, caplog):
    """What ``bench output`` reports of a stop; the user is told once, with the remedy; an underflow
    as the stream starts is not a gap and is not told. ``max_latency: 0`` keeps the buffer."""
    with settled_transducer(VibroTransducer.Params(queue=0.0, latency=START_LATENCY_S, max_latency=0.0),
                            caplog) as act:
        assert 0.001 < act.output_latency_s < 0.1
        before, times_before, buffer = act.underflows, act.underflow_times, act.output_latency_s
        t0 = stop_this_process_until_an_underflow(act)
        new = act.underflow_times[len(times_before):]
        gaps = [gap for t, gap in act.late_callbacks if t > t0]  # on the stream's own clock, whatever is reported
        assert gaps and 0.1 < max(gaps) < 1.0
        assert act.underflows > before
        assert len(new) == act.underflows - before
        assert all(t0 + 0.05 < t < time.monotonic() for t in new)
        time.sleep(0.2)
        assert act.buffer_changes == () and act.output_latency_s == buffer
    # one line at once; any more within 10 s (a busy host adds its own) are counted in one line at close
    told = [r.getMessage() for r in caplog.records if "gaps in the sound" in r.getMessage()]
    assert 1 <= len(told) <= 2, told
    waited = re.search(r"the longest wait between two audio callbacks was ([0-9.]+) ms", told[0])
    assert waited and 100 < float(waited.group(1)) < 1000, told[0]  # the stop, which a buffer would have to hold
    assert "default" in told[0] and "latency: 0.03" in told[0] and " ms and was not refilled" in told[0]
    assert all(line.endswith("more like it, not logged)") for line in told[1:])


@pytest.mark.parametrize("max_latency", [0.12, 0.2])
def test_after_an_underflow_the_buffer_is_lengthened_up_to_max_latency_and_still_plays(soundserver, caplog,
                                                                                        max_latency):
    """The 300 ms stop asks for more than either cap (1.5 x 300 ms): the stream is reopened at the cap (at least twice
    the 50 ms it had), is told of once, and what is played after comes back unchanged."""
    with settled_transducer(VibroTransducer.Params(queue=0.0, latency=START_LATENCY_S, max_latency=max_latency),
                            caplog) as act:
        was = act.output_latency_s
        t0 = stop_this_process_until_an_underflow(act)
        time.sleep(0.3)
        assert len(act.buffer_changes) == 1, act.buffer_changes
        when, before, after = act.buffer_changes[0]
        assert t0 < when < time.monotonic() and before == was
        assert after == pytest.approx(max_latency, rel=0.05) == act.output_latency_s
        sig = impact()
        got = record_while(lambda: act.play(Signal(sig, RATE)), 0.2, act)
    aligned, _ = align(got[:, 0], sig)
    assert corr(aligned, sig) > 0.99
    told = [r.getMessage() for r in caplog.records if "gaps in the sound" in r.getMessage()]
    assert f"lengthening it to {max_latency * 1e3:.1f} ms (max_latency: {max_latency:g})" in told[0]
    grown = [r.getMessage() for r in caplog.records if "buffer lengthened" in r.getMessage()]
    assert grown == [f"sound output 'default': buffer lengthened from {was * 1e3:.1f} to {after * 1e3:.1f} ms "
                     "after underflows"]


def test_a_longer_buffer_waits_until_nothing_sounds(soundserver):
    """Reopening drops what the old stream held: an impact sounding at the stop is not cut by the switch."""
    with settled_transducer(VibroTransducer.Params(queue=0.0, latency=START_LATENCY_S, max_latency=0.2)) as act:
        played = time.monotonic()  # before the call: the earliest the sound can start, however long play() takes
        act.play(Signal(np.full(int(0.8 * RATE), 0.1), RATE))
        time.sleep(0.1)
        stop_this_process_until_an_underflow(act)
        act.drain()
        time.sleep(0.2)
        changes = act.buffer_changes
    assert len(changes) == 1
    # it sounded 0.8 s, plus the 300 ms stop (the switch at the stop would come 0.4 s after play()); the
    # old buffer's own 50 ms after the mixer went quiet is not asserted: the host fills it in bursts
    assert changes[0][0] > played + 0.8 + STOP_S
