"""``hapticfx bench helmet``: a scene's head of several actuators played on a multi-channel PulseAudio null sink
and recorded back from its monitor, so that each impact's per-channel levels can be held against the layout.

The sink is loaded into the running PulseAudio server for the run (``module-null-sink`` with one channel per
site, its channel map set apart from libpulse's default so that a stream remixed by position rather than
mapped by index would show), recorded with ``parec`` and unloaded afterwards. The engine plays in a child
process pointed at that sink (``PULSE_SINK``), so the streams of the calling process are left alone.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

RATE_HZ = 48000
CHANNEL_NAMES = ("front-left", "front-right", "rear-left", "rear-right", "front-center", "lfe", "side-left",
                 "side-right")
SILENT_DB = -240.0

_PLAYER = """
import json, sys, time
from hapticfx.engine import Engine
scene, obj, velocity, gap, points = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), json.loads(sys.argv[5])
with Engine(scene) as engine:
    time.sleep(0.5)
    for point in points:
        engine.impact(obj, velocity, point=tuple(point))
        time.sleep(gap)
print(json.dumps(engine.stats()))
"""


@dataclass(frozen=True)
class HelmetCapture:
    """Per impact (rows) and channel (columns): the level heard (dB, relative to the impact's energy over all
    channels) and the level the spatialiser asked for (dB of its gain); per impact its energy over all channels
    against the first impact's (dB: the same object at the same speed, so 0 when panning preserves energy);
    and the samples recorded."""

    points: list[tuple[float, float, float]]
    heard_db: np.ndarray
    expected_db: np.ndarray
    energy_db: np.ndarray
    samples: np.ndarray
    starts: list[int]
    stats: dict


def default_points(layout) -> dict[str, tuple[float, float, float]]:
    """On the first site (the crown in scenes/helmet_4.yaml), on the second and on the last, and halfway along the
    arc between the first two."""
    pos = [np.asarray(s.position, dtype=float) for s in layout.sites]
    unit = [p / np.linalg.norm(p) for p in pos]
    mid = (unit[0] + unit[1]) / np.linalg.norm(unit[0] + unit[1]) * float(np.linalg.norm(pos[0]))
    names = [s.name for s in layout.sites]
    return {names[0]: tuple(pos[0]), names[1]: tuple(pos[1]), names[-1]: tuple(pos[-1]),
            f"between {names[0]} and {names[1]}": tuple(mid)}


def _pactl(*args: str) -> str:
    done = subprocess.run(["pactl", *args], capture_output=True, text=True, timeout=30)
    if done.returncode != 0:
        raise RuntimeError(f"pactl {' '.join(args)} failed: {done.stderr.strip()}")
    return done.stdout.strip()


def _onsets(x: np.ndarray, *, threshold: float, min_gap: int) -> list[int]:
    loud = np.flatnonzero(np.abs(x).max(axis=0) > threshold)
    starts = []
    for i in loud:
        if not starts or i - last > min_gap:
            starts.append(int(i))
        last = i
    return starts


def capture(scene: Path, points: list, *, object: str, velocity: float, gap_s: float = 0.7,
            window_s: float = 0.4) -> HelmetCapture:
    """Play ``object`` at ``velocity`` at each point (head frame) through ``scene``'s head on a null sink with one
    channel per site, record it back and measure each impact's level per channel over ``window_s``."""
    from hapticfx.scene import load_scene
    from hapticfx.spatial import Spatialiser

    layout = load_scene(scene).head
    if layout is None:
        raise ValueError(f"{scene} has no head: nothing to spread over channels")
    channels = max(s.channel for s in layout.sites) + 1
    if channels > len(CHANNEL_NAMES):
        raise ValueError(f"{channels} channels; this bench names at most {len(CHANNEL_NAMES)}")
    spatialiser = Spatialiser(layout)
    expected = np.full((len(points), channels), SILENT_DB)
    for i, point in enumerate(points):
        for p in spatialiser.place(point):
            if p.gain > 0:
                expected[i, layout.sites[p.site].channel] = 20 * np.log10(p.gain)
    sink = f"hapticfx_helmet_{os.getpid()}"
    channel_map = ",".join(CHANNEL_NAMES[:channels])
    module = _pactl("load-module", "module-null-sink", f"sink_name={sink}", f"rate={RATE_HZ}",
                    f"channels={channels}", f"channel_map={channel_map}")
    with tempfile.TemporaryDirectory() as tmp, open("/dev/zero", "rb") as zeros:
        raw = Path(tmp) / "capture.raw"
        # A silent stream keeps the new sink running, as .ci/soundserver.sh does for its own: without it the
        # first stream on a sink just loaded waits 0.5-1 s for the server's first request and is counted an outage.
        keepalive = subprocess.Popen(["pacat", "--playback", "-d", sink, "--latency-msec=5", "--raw", "--format=s16le",
                                      f"--channels={channels}", f"--channel-map={channel_map}", f"--rate={RATE_HZ}"],
                                     stdin=zeros, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            time.sleep(1.0)
            with open(raw, "wb") as out:
                recorder = subprocess.Popen(
                    ["parec", "-d", f"{sink}.monitor", "--raw", "--format=float32le", f"--channels={channels}",
                     f"--channel-map={channel_map}", f"--rate={RATE_HZ}", "--latency-msec=10"], stdout=out)
                try:
                    time.sleep(0.3)
                    played = subprocess.run(
                        [sys.executable, "-c", _PLAYER, str(scene), object, str(velocity), str(gap_s),
                         json.dumps([list(map(float, p)) for p in points])],
                        capture_output=True, text=True, timeout=120, env={**os.environ, "PULSE_SINK": sink})
                    time.sleep(0.3)
                finally:
                    recorder.terminate()
                    recorder.wait(timeout=10)
        finally:
            keepalive.terminate()
            keepalive.wait(timeout=10)
            _pactl("unload-module", module)
        if played.returncode != 0:
            raise RuntimeError(f"the player failed: {played.stderr.strip()[-2000:]}")
        samples = np.fromfile(raw, dtype="<f4").reshape(-1, channels).T.astype(float)
    starts = _onsets(samples, threshold=1e-3, min_gap=int(0.1 * RATE_HZ))
    heard = np.full((len(starts), channels), SILENT_DB)
    totals = np.zeros(len(starts))
    for i, start in enumerate(starts):
        window = samples[:, start:start + int(window_s * RATE_HZ)]
        rms = np.sqrt((window ** 2).mean(axis=1))
        totals[i] = np.sqrt((rms ** 2).sum())
        heard[i] = np.where(rms > 0, 20 * np.log10(np.maximum(rms, 1e-300) / totals[i]), SILENT_DB)
    energy = 20 * np.log10(totals / totals[0]) if len(starts) else totals
    return HelmetCapture([tuple(p) for p in points], heard, expected, energy, samples, starts,
                         json.loads(played.stdout.strip().splitlines()[-1]))


def table(labels: list[str], cap: HelmetCapture) -> str:
    """Heard against expected, per impact and channel (dB)."""
    def cell(db):
        return "silent" if db <= -200 else f"{db:.2f}"

    n = cap.expected_db.shape[1]
    lines = ["| impact at | " + " | ".join(f"ch {k} heard / expected dB" for k in range(n))
             + " | worst error dB | energy vs the first dB |", "|---|" + "---:|" * (n + 2)]
    for label, heard, want, energy in zip(labels, cap.heard_db, cap.expected_db, cap.energy_db):
        sounding = want > -200
        worst = float(np.abs(heard[sounding] - want[sounding]).max())
        lines.append(f"| {label} | " + " | ".join(f"{cell(h)} / {cell(w)}" for h, w in zip(heard, want))
                     + f" | {worst:.3f} | {energy:+.3f} |")
    return "\n".join(lines)


def plot(path: Path, labels: list[str], cap: HelmetCapture, *, title: str) -> Path:
    """Each impact as recorded, one trace per channel, and the levels heard against the layout's."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hapticfx.atomic import atomic_path

    n_imp, n_ch = cap.heard_db.shape
    fig, axes = plt.subplots(2, n_imp, figsize=(3.4 * n_imp, 6), squeeze=False)
    for i, (label, start) in enumerate(zip(labels, cap.starts)):
        ax = axes[0, i]
        seg = cap.samples[:, max(0, start - 480):start + int(0.3 * RATE_HZ)]
        t = (np.arange(seg.shape[1]) - min(480, start)) / RATE_HZ * 1e3
        for k in range(n_ch):
            ax.plot(t, seg[k] - 0.5 * k, lw=0.6, label=f"ch {k}")
        ax.set_title(label, fontsize=9)
        ax.set_xlabel("ms after onset", fontsize=8)
        ax.set_yticks([-0.5 * k for k in range(n_ch)], [f"ch {k}" for k in range(n_ch)], fontsize=7)
        bars = axes[1, i]
        x = np.arange(n_ch)
        floor = -40.0
        bars.bar(x - 0.2, np.maximum(cap.expected_db[i], floor) - floor, 0.4, bottom=floor, label="layout",
                 color="0.7")
        bars.bar(x + 0.2, np.maximum(cap.heard_db[i], floor) - floor, 0.4, bottom=floor, label="heard",
                 color="tab:purple")
        bars.set_xticks(x, [f"ch {k}" for k in x], fontsize=7)
        bars.set_ylim(floor, 3)
        bars.set_ylabel("dB of the impact's energy" if i == 0 else "", fontsize=8)
        if i == 0:
            bars.legend(fontsize=7, loc="lower left")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    with atomic_path(Path(path)) as tmp:
        fig.savefig(tmp, dpi=100, format="png")
    plt.close(fig)
    return Path(path)
