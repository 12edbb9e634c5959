"""Platform haptic files: write then read for every format, every validation rule, the specs' own examples."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hapticfx.formats import ExportOptions, HapticFileError, all_formats, format_for, format_named
from hapticfx.formats.analysis import analyse, envelope, reduce_breakpoints
from hapticfx.formats.device import PRESETS, device_named
from hapticfx.formats.haptic import HapticFormat
from hapticfx.signal import Signal

QUEST = PRESETS["quest"]
RATE = 8000.0


def impact(rate=48000.0, f=120.0, duration=0.4, peak=0.6, decay_s=0.06):
    """A decaying sine with a sharp onset at 10 ms: what a rendered impact looks like."""
    t = np.arange(int(duration * rate)) / rate
    x = peak * np.exp(-(t - 0.01) / decay_s) * np.sin(2 * np.pi * f * (t - 0.01))
    return Signal(np.where(t >= 0.01, x, 0.0), rate)


def write_read(fmt, tmp_path, signal, **options):
    path = tmp_path / f"x{fmt.suffixes[0]}"
    fmt.write(path, signal, ExportOptions(device=QUEST, **options))
    return path, fmt.read(path, QUEST, rate_hz=signal.rate_hz)


@pytest.mark.parametrize("name", ["haptic", "ahap", "android", "hjif"])
def test_write_then_read_keeps_the_envelope_and_frequency(tmp_path, name):
    fmt = format_named(name)
    x = impact()
    path, decoded = write_read(fmt, tmp_path, x, transients=False)
    y = decoded.signal.samples[: len(x.samples)]
    y = np.pad(y, (0, len(x.samples) - len(y)))
    e1, e2 = envelope(x.samples, x.rate_hz), envelope(y, x.rate_hz)
    assert np.sqrt(np.mean((e1 - e2) ** 2)) / e1.max() < 0.05
    spec = lambda s: np.fft.rfftfreq(1 << 16, 1 / x.rate_hz)[np.argmax(np.abs(np.fft.rfft(s, 1 << 16)))]
    if "frequency" in fmt.holds or name == "ahap":  # AHAP: through sharpness, on the same device
        assert spec(y) == pytest.approx(spec(x.samples), rel=0.05)
    assert format_for(path).name == name and decoded.notes == ()


@pytest.mark.parametrize("name", ["haptic", "ahap", "android", "hjif"])
def test_a_signal_loud_from_its_first_sample_is_loud_from_the_start(tmp_path, name):
    """Android's envelope builder starts at amplitude 0: the first breakpoint's level was dropped, and a steady
    0.3 sine read back as a ramp from silence (RMS 0.012 over the first 50 ms instead of 0.21)."""
    rate = 48000.0
    x = Signal(0.3 * np.sin(2 * np.pi * 150 * np.arange(int(0.5 * rate)) / rate), rate)
    _, decoded = write_read(format_named(name), tmp_path, x, transients=False)
    y = decoded.signal.samples
    assert np.sqrt(np.mean(y[:int(0.05 * rate)] ** 2)) == pytest.approx(0.3 / np.sqrt(2), rel=0.1)


@pytest.mark.parametrize("name", ["haptic", "ahap", "hjif"])
def test_a_sharp_onset_becomes_a_transient(tmp_path, name):
    fmt = format_named(name)
    path, decoded = write_read(fmt, tmp_path, impact())
    text = path.read_text()
    assert {"haptic": '"emphasis"', "ahap": '"HapticTransient"', "hjif": '"Transient"'}[name] in text
    assert np.max(np.abs(decoded.signal.samples)) > 0.3


def test_what_hapticfx_writes_passes_the_strict_haptic_rules(tmp_path):
    path, _ = write_read(format_named("haptic"), tmp_path, impact())
    HapticFormat(strict=True).read(path, QUEST, rate_hz=RATE)
    doc = json.loads(path.read_text())
    env = doc["signals"]["continuous"]["envelopes"]
    end = env["amplitude"][-1]["time"]
    assert all(0 <= p["time"] <= end for p in env["frequency"])


def test_breakpoints_keep_the_stated_bound():
    rng = np.random.default_rng(3)
    y = np.abs(np.cumsum(rng.standard_normal(2000))) / 50
    for tol in (0.001, 0.01, 0.05):
        idx = reduce_breakpoints(y, tol)
        assert np.max(np.abs(np.interp(np.arange(len(y)), idx, y[idx]) - y)) <= tol
        assert idx[0] == 0 and idx[-1] == len(y) - 1


def test_silence_and_a_clipped_signal_stay_bounded(tmp_path):
    for x in (Signal(np.zeros(4800), 48000.0), Signal(np.clip(impact(peak=3.0).samples, -1, 1), 48000.0)):
        for fmt in all_formats():
            _, decoded = write_read(fmt, tmp_path, x)
            assert np.all(np.isfinite(decoded.signal.samples)) and np.max(np.abs(decoded.signal.samples)) <= 1.0 + 1e-9


@pytest.mark.parametrize("name", ["haptic", "ahap", "hjif", "android", "android-ogg"])
@pytest.mark.parametrize("device", ["quest", "console-pcm"])
@pytest.mark.parametrize("f, decay_s", [(40.0, 0.5), (120.0, 0.5), (160.0, 0.15), (160.0, 0.5), (200.0, 0.03),
                                        (200.0, 0.15), (200.0, 0.5)])
def test_never_reads_back_above_the_impacts_peak(tmp_path, name, device, f, decay_s):
    """What reaches a device through the file stays within the limited impact. The continuous signal came back
    while the onset burst still played, ducked but adding to it: a slow 0.3 decay read back at up to 0.38 (hjif)
    and 0.40 (.haptic); an envelope above the peak (a 40 Hz carrier's ripple) read back above it (Android: 1.09x,
    and 1.01-1.02x on every 0.5 s decay). Android's waveform, the reading where a file holds no envelope, too."""
    dev = PRESETS[device]
    fmt = format_named(name)
    for rate in (RATE, 22050.0, 44100.0, 48000.0):
        x = impact(rate=rate, f=f, peak=0.3, decay_s=decay_s)
        path = tmp_path / f"x{fmt.suffixes[0]}"
        fmt.write(path, x, ExportOptions(device=dev))
        assert np.abs(fmt.read(path, dev, rate_hz=rate).signal.samples).max() <= np.abs(x.samples).max()
        if name == "android":
            doc = json.loads(path.read_text())
            del doc["envelope"]
            path.write_text(json.dumps(doc))
            assert np.abs(fmt.read(path, dev, rate_hz=rate).signal.samples).max() <= np.abs(x.samples).max()


def test_the_frequency_maps_onto_the_device_range():
    pattern = analyse(impact(f=120.0).samples, 48000.0, QUEST)
    assert QUEST.hz(pattern.frequency[:, 1]).mean() == pytest.approx(120.0, rel=0.05)
    low = analyse(impact(f=30.0, duration=0.6).samples, 48000.0, QUEST)
    assert np.all(low.frequency[:, 1] == 0.0)  # below Quest's 55 Hz: clamped to its lowest


# --- .haptic: the spec's examples, written out by hand from resources/haptic-file-spec.md -------------------

MINIMAL = {"version": {"major": 1, "minor": 0, "patch": 0}, "metadata": {}, "signals": {"continuous": {"envelopes": {
    "amplitude": [{"time": 0.0, "amplitude": 0.0}, {"time": 1.0, "amplitude": 0.0}], "frequency": []}}}}
DETAILED = {"version": {"major": 1, "minor": 0, "patch": 0}, "metadata": {"editor": "Meta Haptics Studio 2.1"},
            "signals": {"continuous": {"envelopes": {
                "amplitude": [{"time": 0.0, "amplitude": 0.0},
                              {"time": 0.05, "amplitude": 0.7, "emphasis": {"amplitude": 1.0, "frequency": 1.0}},
                              {"time": 0.1, "amplitude": 1.0}],
                "frequency": [{"time": 0.0, "frequency": 0.9}, {"time": 0.07, "frequency": 0.7},
                              {"time": 0.1, "frequency": 0.0}]}}}}
GEAR = {"version": {"major": 1, "minor": 0, "patch": 0}, "metadata": {"description": "A gear being cranked"},
        "signals": {"continuous": {"envelopes": {
            "amplitude": [{"time": 0.0, "amplitude": 0.0}, {"time": 0.2, "amplitude": 0.11},
                          {"time": 0.48, "amplitude": 0.18},
                          {"time": 0.49, "amplitude": 0.71, "emphasis": {"amplitude": 0.8, "frequency": 0.5}},
                          {"time": 0.61, "amplitude": 0.08}, {"time": 0.91, "amplitude": 0.0}],
            "frequency": [{"time": 0.0, "frequency": 0.0}, {"time": 0.01, "frequency": 0.73},
                          {"time": 0.15, "frequency": 0.48}, {"time": 0.18, "frequency": 0.46},
                          {"time": 0.48, "frequency": 0.98}, {"time": 0.82, "frequency": 0.7},
                          {"time": 0.91, "frequency": 0.0}]}}}}


def _file(tmp_path, doc, name="x.haptic"):
    path = tmp_path / name
    path.write_text(doc if isinstance(doc, str) else json.dumps(doc))
    return path


def test_the_spec_examples_play(tmp_path):
    fmt = HapticFormat(strict=True)
    silent = fmt.read(_file(tmp_path, MINIMAL), QUEST, rate_hz=RATE).signal
    assert silent.duration_s == pytest.approx(1.0, abs=1e-3) and not np.any(silent.samples)
    detailed = fmt.read(_file(tmp_path, DETAILED), QUEST, rate_hz=RATE).signal.samples
    burst = slice(int(0.05 * RATE), int(0.05 * RATE) + int(0.0121 * RATE))  # frequency 1: Quest's 12.1 ms square
    assert np.max(np.abs(detailed[burst])) == pytest.approx(1.0)  # emphasis 1 + ducked envelope: full scale, clipped
    gear = fmt.read(_file(tmp_path, GEAR), QUEST, rate_hz=RATE).signal
    assert gear.duration_s >= 0.91 and np.max(np.abs(gear.samples[: int(0.48 * RATE)])) == pytest.approx(0.18, abs=0.01)


BAD_HAPTIC = [
    ("amplitude out of range", ["amplitude", 1, "amplitude"], 1.3, "$.signals.continuous.envelopes.amplitude[1].amplitude",
     "amplitude within 0.0-1.0"),
    ("times out of order", ["amplitude", 2, "time"], 0.01, "$.signals.continuous.envelopes.amplitude[2].time",
     "non-decreasing time order"),
    ("emphasis below the envelope", ["amplitude", 1, "emphasis", "amplitude"], 0.5,
     "$.signals.continuous.envelopes.amplitude[1].emphasis.amplitude", "emphasis amplitude >= the envelope"),
    ("emphasis frequency out of range", ["amplitude", 1, "emphasis", "frequency"], -0.1,
     "$.signals.continuous.envelopes.amplitude[1].emphasis.frequency", "emphasis frequency within"),
    ("frequency out of range", ["frequency", 0, "frequency"], 2.0, "$.signals.continuous.envelopes.frequency[0].frequency",
     "frequency within 0.0-1.0"),
    ("frequency times out of order", ["frequency", 2, "time"], 0.01, "$.signals.continuous.envelopes.frequency[2].time",
     "non-decreasing time order"),
    ("negative time", ["amplitude", 0, "time"], -0.5, "$.signals.continuous.envelopes.amplitude[0].time", "time >= 0"),
    ("a string for a number", ["amplitude", 0, "amplitude"], "0.5", "$.signals.continuous.envelopes.amplitude[0].amplitude",
     "types"),
]


@pytest.mark.parametrize("case, keys, value, where, rule", BAD_HAPTIC, ids=[c[0] for c in BAD_HAPTIC])
def test_each_haptic_rule_refuses_its_case(tmp_path, case, keys, value, where, rule):
    doc = json.loads(json.dumps(DETAILED))
    node = doc["signals"]["continuous"]["envelopes"]
    for k in keys[:-1]:
        node = node[k]
    node[keys[-1]] = value
    path = _file(tmp_path, doc)
    with pytest.raises(HapticFileError) as err:
        HapticFormat().read(path, QUEST, rate_hz=RATE)
    message = str(err.value)
    assert message.startswith(f"{path}: {where}: ") and rule in message and len(message.splitlines()) == 1


@pytest.mark.parametrize("case, amplitude, rule", [
    ("fewer than two points", [{"time": 0.0, "amplitude": 0.5}], "at least two amplitude breakpoints"),
    ("no points", [], "at least two amplitude breakpoints"),
    ("zero duration", [{"time": 0.2, "amplitude": 0.5}, {"time": 0.2, "amplitude": 0.1}], "duration > 0"),
])
def test_too_few_points_or_no_duration_are_refused(tmp_path, case, amplitude, rule):
    doc = json.loads(json.dumps(MINIMAL))
    doc["signals"]["continuous"]["envelopes"]["amplitude"] = amplitude
    with pytest.raises(HapticFileError, match=rule):
        HapticFormat().read(_file(tmp_path, doc), QUEST, rate_hz=RATE)


@pytest.mark.parametrize("remove, where", [("signals", "$"), ("version", "$")])
def test_missing_sections_are_refused(tmp_path, remove, where):
    doc = json.loads(json.dumps(MINIMAL))
    del doc[remove]
    with pytest.raises(HapticFileError, match=rf": \{where}: required key '{remove}' is missing"):
        HapticFormat().read(_file(tmp_path, doc), QUEST, rate_hz=RATE)


def test_a_legacy_frequency_envelope_plays_with_a_warning_and_fails_strict(tmp_path):
    doc = json.loads(json.dumps(DETAILED))
    doc["signals"]["continuous"]["envelopes"]["frequency"].append({"time": 0.4, "frequency": 0.2})
    path = _file(tmp_path, doc)
    decoded = HapticFormat().read(path, QUEST, rate_hz=RATE)
    assert len(decoded.notes) == 1 and "legacy" in decoded.notes[0] and decoded.signal.duration_s < 0.2
    with pytest.raises(HapticFileError, match="no frequency breakpoint after the amplitude envelope"):
        HapticFormat(strict=True).read(path, QUEST, rate_hz=RATE)


def test_not_json_is_refused(tmp_path):
    with pytest.raises(HapticFileError, match=r"x.haptic: \$: not JSON: line 1"):
        HapticFormat().read(_file(tmp_path, '{"version": '), QUEST, rate_hz=RATE)


# --- AHAP: an example written out by hand from Apple's "Representing haptic patterns in AHAP files" -----------

AHAP = """{
  "Version": 1.0,
  "Metadata": {"Project": "hand-written", "Description": "a tap, a rumble shaped by curves, and a sound"},
  "Pattern": [
    {"Event": {"Time": 0.0, "EventType": "HapticTransient",
               "EventParameters": [{"ParameterID": "HapticIntensity", "ParameterValue": 0.8},
                                   {"ParameterID": "HapticSharpness", "ParameterValue": 0.4},]}},
    {"Event": {"Time": 0.015, "EventType": "HapticContinuous", "EventDuration": 0.25,
               "EventParameters": [{"ParameterID": "HapticIntensity", "ParameterValue": 0.8},
                                   {"ParameterID": "HapticSharpness", "ParameterValue": 0.4}]}},
    {"ParameterCurve": {"ParameterID": "HapticIntensityControl", "Time": 0.015,
                        "ParameterCurveControlPoints": [{"Time": 0, "ParameterValue": 1},
                                                        {"Time": 0.1, "ParameterValue": 0.5},
                                                        {"Time": 0.25, "ParameterValue": 0.0}]}},
    {"Event": {"Time": 0.3, "EventType": "AudioCustom", "EventWaveformPath": "boing.wav"}},
  ],
}
"""


def test_an_ahap_with_trailing_commas_and_an_audio_event_plays(tmp_path):
    path = _file(tmp_path, AHAP, "boing.ahap")
    decoded = format_for(path).read(path, QUEST, rate_hz=RATE)
    assert len(decoded.notes) == 1 and "AudioCustom" in decoded.notes[0] and "left out" in decoded.notes[0]
    x = decoded.signal.samples
    mid = int((0.015 + 0.1) * RATE)  # intensity 0.8 x curve 0.5 -> amplitude (0.4)^2
    assert np.max(np.abs(x[mid - 80: mid + 80])) == pytest.approx(0.16, abs=0.02)
    assert np.max(np.abs(x[int(0.255 * RATE):])) < 0.01 and decoded.signal.duration_s < 0.27  # no audio event


def test_ahap_out_of_range_values_are_clamped_and_unknown_keys_ignored(tmp_path):
    text = ('{"Pattern": [{"Event": {"EventType": "HapticContinuous", "EventDuration": 0.2, "Shiny": 1, '
            '"EventParameters": [{"ParameterID": "HapticIntensity", "ParameterValue": 7}]}}]}')
    decoded = format_for(_file(tmp_path, text, "c.ahap")).read(tmp_path / "c.ahap", QUEST, rate_hz=RATE)
    assert any("clamped" in n for n in decoded.notes)
    assert np.max(np.abs(decoded.signal.samples)) == pytest.approx(1.0, abs=0.01)


@pytest.mark.parametrize("text, where, rule", [
    ('{"Pattern": [ {"Event": {"Time": 0.1}} ]}', r"\$.Pattern\[0\].Event", "required fields"),
    ('{"Pattern": [{"Event": {"EventType": "HapticContinuous"}}]}', r"\$.Pattern\[0\].Event",
     "continuous events must have a duration"),
    ('{"Pattern": [{"Event": {"EventType": "AudioCustom"}}]}', r"\$.Pattern", "at least one haptic event"),
    ('{"Pattern": {"Event": 1}}', r"\$.Pattern", "structure"),
    ('{"Pattern": [{"Event": {"EventType": "HapticTransient", "Time": "soon"}}]}', r"\$.Pattern\[0\].Event.Time", "types"),
    ('{"Pattern": [', r"\$", "not JSON5"),
])
def test_what_core_haptics_cannot_load_is_refused(tmp_path, text, where, rule):
    path = _file(tmp_path, text, "bad.ahap")
    with pytest.raises(HapticFileError, match=rf"bad.ahap: {where}: .*{rule}"):
        format_for(path).read(path, QUEST, rate_hz=RATE)


def test_ahap_curves_have_at_most_16_points_and_continuous_events_30_s(tmp_path):
    t = np.arange(int(31 * 1000)) / 1000
    x = Signal(0.5 * (1 + np.sin(2 * np.pi * 0.5 * t)) / 2 * np.sin(2 * np.pi * 100 * t), 1000.0)
    path, _ = write_read(format_named("ahap"), tmp_path, x, tolerance=0.05)
    doc = json.loads(path.read_text())
    curves = [e["ParameterCurve"] for e in doc["Pattern"] if "ParameterCurve" in e]
    events = [e["Event"] for e in doc["Pattern"] if "Event" in e and e["Event"]["EventType"] == "HapticContinuous"]
    assert len(curves) > 2 and all(len(c["ParameterCurveControlPoints"]) <= 16 for c in curves)
    assert len(events) == 2 and all(e["EventDuration"] <= 30 for e in events)


# --- Android and HJIF ---------------------------------------------------------------------------------------

def test_android_waveform_alone_plays_and_its_rules_hold(tmp_path):
    fmt = format_named("android")
    doc = {"waveform": {"timings": [0, 20, 30], "amplitudes": [0, 255, 64], "repeat": -1}}
    decoded = fmt.read(_file(tmp_path, doc, "w.android.json"), QUEST, rate_hz=RATE)
    assert decoded.signal.duration_s == pytest.approx(0.05, abs=1e-3)
    assert np.max(np.abs(decoded.signal.samples[: int(0.02 * RATE)])) == pytest.approx(1.0, abs=0.01)
    for change, rule in [({"amplitudes": [0, 256, 64]}, "amplitudes 0-255"), ({"timings": [0, -1, 3]}, "timings >= 0"),
                         ({"timings": [0, 20]}, "equal length"), ({"repeat": 3}, "repeat -1 or an index"),
                         ({"timings": [0, 0, 0]}, "total duration > 0")]:
        bad = {"waveform": {**doc["waveform"], **change}}
        with pytest.raises(HapticFileError, match=rule):
            fmt.read(_file(tmp_path, bad, "w.android.json"), QUEST, rate_hz=RATE)


def test_android_envelope_rules(tmp_path):
    fmt = format_named("android")
    ok = {"envelope": {"controlPoints": [{"amplitude": 1.0, "frequencyHz": 120, "durationMillis": 100},
                                         {"amplitude": 0.0, "frequencyHz": 120, "durationMillis": 100}]}}
    decoded = fmt.read(_file(tmp_path, ok, "e.android.json"), QUEST, rate_hz=RATE)
    assert decoded.signal.duration_s == pytest.approx(0.2, abs=1e-3)  # the builder's own example, in part
    for point, rule in [({"amplitude": 1.5}, "amplitude 0-1"), ({"frequencyHz": 0}, "frequencies > 0 Hz"),
                        ({"durationMillis": 0}, "durations > 0 ms")]:
        bad = json.loads(json.dumps(ok))
        bad["envelope"]["controlPoints"][0].update(point)
        with pytest.raises(HapticFileError, match=rule):
            fmt.read(_file(tmp_path, bad, "e.android.json"), QUEST, rate_hz=RATE)


def test_hjif_structure_rules(tmp_path):
    fmt = format_named("hjif")
    path, _ = write_read(fmt, tmp_path, impact())
    doc = json.loads(path.read_text())
    assert doc["version"] == "2023" and doc["perceptions"][0]["perception_modality"] == "Vibrotactile"
    for change, rule in [(("version", "2021"), "year >= 2023"), (("profile", "Extra"), "profile Main"),
                         (("level", 3), "level 1 or 2"), (("timescale", 96000), "timescale")]:
        bad = {**doc, change[0]: change[1]}
        with pytest.raises(HapticFileError, match=rule):
            fmt.read(_file(tmp_path, bad, "b.hjif"), QUEST, rate_hz=RATE)
    del doc["syncs"]
    with pytest.raises(HapticFileError, match=r"\$: required key 'syncs' is missing"):
        fmt.read(_file(tmp_path, doc, "b.hjif"), QUEST, rate_hz=RATE)


def test_device_files_and_presets(tmp_path):
    acf = tmp_path / "mine.acf"
    acf.write_text("{continuous: {gain: 1, emphasis_ducking: 0.5, frequency_min: 30, frequency_max: 300,},"
                   "emphasis: {gain: 1, fade_out_percent: 0, frequency_min: {output_frequency: 50, duration_ms: 30, "
                   "shape: 'sine'}, frequency_max: {output_frequency: 150, duration_ms: 10, shape: 'square'}}}")
    dev = device_named(str(acf))
    assert (dev.frequency_min_hz, dev.frequency_max_hz, dev.emphasis_max.shape) == (30.0, 300.0, "square")
    assert device_named("console-pcm").frequency_min_hz == 20.0
    with pytest.raises(Exception, match="unknown device 'ps9'"):
        device_named("ps9")


# --- Android audio-coupled haptics (Ogg Vorbis, ANDROID_HAPTIC=N) ---------------------------------------------

def test_ogg_checksums_match_what_libsndfile_writes(tmp_path):
    sf = pytest.importorskip("soundfile")
    from hapticfx.formats.ogg import _crc, _pages

    path = tmp_path / "plain.ogg"
    sf.write(path, np.zeros((4800, 2)), 48000, format="OGG", subtype="VORBIS")
    data = path.read_bytes()
    pos = 0
    for page in _pages(data, str(path)):  # every page's stored CRC is the one _crc computes with the field zeroed
        size = 27 + len(page["lacing"]) + len(page["body"])
        raw = data[pos:pos + size]
        assert int.from_bytes(raw[22:26], "little") == _crc(raw[:22] + bytes(4) + raw[26:])
        pos += size


def test_ogg_write_then_read_keeps_the_waveform(tmp_path):
    pytest.importorskip("soundfile")
    fmt = format_named("android-ogg")
    x = impact()
    path, decoded = write_read(fmt, tmp_path, x)
    from hapticfx.formats.ogg import _packets, _pages, parse_comments

    assert "ANDROID_HAPTIC=1" in parse_comments(_packets(_pages(path.read_bytes(), "x"), 1, 1)[0][0])
    y = decoded.signal.samples[: len(x.samples)]
    assert np.sqrt(np.mean((y - x.samples) ** 2)) < 0.01 * np.max(np.abs(x.samples))


@pytest.mark.parametrize("comments, rule", [(["ENCODER=x"], "no ANDROID_HAPTIC comment"),
                                            (["ANDROID_HAPTIC=3"], "1 or 2 haptic channels"),
                                            (["ANDROID_HAPTIC=two"], "1 or 2 haptic channels")])
def test_an_ogg_without_a_valid_haptic_tag_is_refused(tmp_path, comments, rule):
    sf = pytest.importorskip("soundfile")
    import io

    from hapticfx.formats.ogg import with_comments

    buffer = io.BytesIO()
    sf.write(buffer, np.zeros((4800, 2)), 48000, format="OGG", subtype="VORBIS")
    path = tmp_path / "music.ogg"
    path.write_bytes(with_comments(buffer.getvalue(), comments))
    with pytest.raises(HapticFileError, match=rule):
        format_named("android-ogg").read(path, QUEST, rate_hz=RATE)
    path.write_bytes(b"OggS not really")
    with pytest.raises(HapticFileError, match="not an Ogg page|truncated"):
        format_named("android-ogg").read(path, QUEST, rate_hz=RATE)


def test_what_a_fuzzer_found_is_refused_or_played(tmp_path):
    """Found by mutating exported files (1,000s of inputs per format): each now a one-line error, or plays."""
    long = json.loads(json.dumps(MINIMAL))
    long["signals"]["continuous"]["envelopes"]["amplitude"][1]["time"] = 1e308
    with pytest.raises(HapticFileError, match="hapticfx renders at most 120 s"):
        HapticFormat().read(_file(tmp_path, long), QUEST, rate_hz=RATE)
    text = '{"Pattern": [{"Event": {"EventType": "HapticTransient", "EventParameters": [{"ParameterID": [1]}]}}]}'
    with pytest.raises(HapticFileError, match=r"ParameterID: expected a string"):
        format_named("ahap").read(_file(tmp_path, text, "p.ahap"), QUEST, rate_hz=RATE)
    path, _ = write_read(format_named("hjif"), tmp_path, impact())
    doc = json.loads(path.read_text())
    doc["perceptions"][0]["channels"][0]["bands"][1]["effects"][0]["position"] = -50  # a transient before 0
    decoded = format_named("hjif").read(_file(tmp_path, doc, "n.hjif"), QUEST, rate_hz=RATE)
    assert np.all(np.isfinite(decoded.signal.samples))
