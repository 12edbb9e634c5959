"""The safety probe (issue 31): floods through every path to an output, what reached it measured against the
limit that applies there, in the output's own time: every sample against the peak, every 50 ms window
against the RMS.

Core cases here need no sound server (the memory device, third-party actuators registered at run time);
the sound-card plugin adds the cases that play into a PulseAudio null sink and records its monitor
(``hapticfx_soundcard.safetyprobe``); ``hapticfx bench safety`` runs them all.
"""

from __future__ import annotations

import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ..conformance import window_rms
from ..engine import Engine
from ..errors import HapticfxError
from ..registry import Registry, create_plugin_manager
from .thirdparty import HARD, ThirdParty

WINDOW_S = 0.05


@dataclass(frozen=True)
class Verdict:
    """One run of one case: the limit that applies, what reached the output, and whether it held.

    ``refused`` is the clear error a case that must be refused got (then nothing played, and it held).
    ``tolerance`` is the measurement's own resolution (a 16-bit sink's step), added to both limits.
    """

    case: str
    peak_limit: float
    rms_limit: float
    peak: float = 0.0
    rms: float = 0.0
    windows_over: int = 0
    samples_over: int = 0
    refused: str | None = None
    tolerance: float = 0.0
    note: str = ""

    @property
    def held(self) -> bool:
        return self.samples_over == 0 and self.windows_over == 0

    @property
    def limit(self) -> str:
        return f"peak {self.peak_limit:g} / RMS {self.rms_limit:g}"


def measure(case: str, x: np.ndarray, rate_hz: float, *, peak: float, rms: float, tolerance: float = 1e-6,
            note: str = "") -> Verdict:
    """``x`` (1D, or frames x channels: each channel on its own) against the limits."""
    x = np.asarray(x, dtype=np.float64)
    channels = x.reshape(x.shape[0], -1).T if x.ndim > 1 else x[None, :]
    got_peak = got_rms = 0.0
    over = samples = 0
    for ch in channels:
        if not ch.size:
            continue
        mag = np.abs(ch)
        got_peak = max(got_peak, float(mag.max()))
        samples += int(np.count_nonzero(mag > peak + tolerance))
        r = window_rms(ch, max(1, int(round(WINDOW_S * rate_hz))))
        got_rms = max(got_rms, float(r.max()))
        over += int(np.count_nonzero(r > rms + tolerance))
    return Verdict(case, peak, rms, got_peak, got_rms, over, samples, tolerance=tolerance, note=note)


def flood(engine: Engine, objects: list[str], n: int, *, every_s: float, velocity: float = 6.0) -> None:
    """``n`` impacts, ``every_s`` apart, cycling through ``objects``."""
    for k in range(n):
        engine.impact(objects[k % len(objects)], velocity)
        time.sleep(every_s)


def registry_with(*plugins) -> Registry:
    """A registry with the built-ins and ``plugins`` registered at run time."""
    pm, infos = create_plugin_manager()
    for k, plugin in enumerate(plugins):
        pm.register(plugin, name=f"probe-plugin-{k}")
    return Registry(pm, infos)


# a square pulse at full scale (the energy mapped to full scale is tiny): the limits must act
LOUD = "{type: kinetic-energy, ke_max_j: 0.001, pulse_ms: 60, duration_ms: 80}"
INLINE = "{{name: {name}, object: {obj}, model: " + LOUD.replace("{", "{{").replace("}", "}}") + \
    ", actuator: {{type: memory{extra}}}}}"


def write_scene(folder: Path, actuators: str, effects: str, *, queue: int = 4096) -> Path:
    path = folder / "probe.yaml"
    path.write_text(f"name: probe\nactuators:\n{actuators}\neffects:\n{effects}\n"
                    f"engine: {{queue_size: {queue}, close_timeout_s: 30}}\n")
    return path


def third_party_flood(actuator_type: str, n: int, *, every_s: float, effect_extra: str = ""):
    """The actuator of one ``actuator_type`` (a :class:`ThirdParty` plugin) after ``n`` bricks ``every_s`` apart
    through an Engine."""
    with tempfile.TemporaryDirectory() as tmp:
        scene = write_scene(Path(tmp), f"  out: {{type: {actuator_type}, gain: 1.0}}",
                            "  brick: {actuator: out, inline: " + INLINE.format(name="b", obj="concrete-brick",
                                                                                extra=effect_extra) + "}")
        engine = Engine(scene, registry=registry_with(ThirdParty()))
        actuator = engine._outputs["actuators.out"].actuator
        flood(engine, ["brick"], n, every_s=every_s)
        engine.close()
    return actuator


def lying_mixer(n: int = 300) -> Verdict:
    """A plugin that declares limits_mix and limits nothing: overlapping impacts, 2 ms apart, on its sum."""
    actuator = third_party_flood("lying-mixer", n, every_s=0.002, effect_extra=", gain: 1.0")
    hard = HARD["lying-mixer"]
    return measure("third-party limits_mix that limits nothing", actuator.timeline(), actuator.spec.rate_hz,
                   peak=hard.peak, rms=hard.rms)


def lying_mixer_pipeline(n: int = 100) -> Verdict:
    """The same plugin under a plain Pipeline (``hapticfx play``, embedding): impacts 2 ms apart."""
    import yaml

    from ..effect import effect_from_mapping
    from ..pipeline import Pipeline

    effect = effect_from_mapping(yaml.safe_load(f"{{name: b, object: concrete-brick, model: {LOUD}, "
                                                "actuator: {type: lying-mixer, gain: 1.0}}"),
                                 source="probe.yaml", base_dir=Path("."))
    with Pipeline(effect, registry=registry_with(ThirdParty())) as pipeline:
        for _ in range(n):
            pipeline.impact()
            time.sleep(0.002)
        actuator = pipeline.actuator
    hard = HARD["lying-mixer"]
    return measure("third-party limits_mix that limits nothing, through a Pipeline", actuator.timeline(),
                   actuator.spec.rate_hz, peak=hard.peak, rms=hard.rms)


def timeline_mixer(n: int = 6, every_s: float = 0.3) -> Verdict:
    """A plugin that sums impacts at their time on the session's timeline and limits nothing: ``n`` impacts that
    all carry one ``at``, arriving ``every_s`` apart (a replay, a slow network), all placed at one instant."""
    with tempfile.TemporaryDirectory() as tmp:
        scene = write_scene(Path(tmp), "  out: {type: timeline-mixer, gain: 1.0}",
                            "  brick: {actuator: out, inline: " + INLINE.format(name="b", obj="concrete-brick",
                                                                                extra=", gain: 1.0") + "}")
        engine = Engine(scene, registry=registry_with(ThirdParty()))
        actuator = engine._outputs["actuators.out"].actuator
        for _ in range(n):
            engine.impact("brick", 6.0, at=100.0)
            time.sleep(every_s)
        engine.close()
    hard = HARD["timeline-mixer"]
    return measure("third-party limits_mix on the session's timeline that limits nothing, one at, spaced arrivals",
                   actuator.timeline(), actuator.spec.rate_hz, peak=hard.peak, rms=hard.rms)


def wav_remixer(n: int = 20) -> Verdict:
    """A subclass of the core's WAV actuator with its own ``play()`` that sums and limits nothing: ``n`` impacts
    at one instant."""
    with tempfile.TemporaryDirectory() as tmp:
        scene = write_scene(Path(tmp), f"  out: {{type: wav-remixer, path: {Path(tmp) / 'x.wav'}, gain: 1.0}}",
                            "  brick: {actuator: out, inline: " + INLINE.format(name="b", obj="concrete-brick",
                                                                                extra=", gain: 1.0") + "}")
        with Engine(scene, registry=registry_with(ThirdParty())) as engine:
            actuator = engine._outputs["actuators.out"].actuator
            for _ in range(n):
                engine.impact("brick", 6.0, at=0.0)
    hard = actuator.spec.limits
    return measure("third-party subclass of the WAV actuator with its own play()", actuator.timeline(),
                   actuator.spec.rate_hz, peak=hard.peak, rms=hard.rms)


def rate_dropper(n: int = 60) -> Verdict:
    """A plugin that lowers its rate in open(): impacts back to back in its own time, at the rate it agreed."""
    actuator = third_party_flood("rate-dropper", n, every_s=0.0)
    hard = HARD["rate-dropper"]
    return measure("third-party that lowers its rate in open()", actuator.timeline(), actuator.spec.rate_hz,
                   peak=hard.peak, rms=hard.rms, note=f"runs at {actuator.spec.rate_hz:g} Hz")


def shared_memory(n: int = 4000, threads: int = 1) -> Verdict:
    """``n`` impacts of four effects on one shared memory output (held before): back to back, as it keeps them."""
    with tempfile.TemporaryDirectory() as tmp:
        objs = ["concrete-brick", "steel-plate", "wood-beam", "plastic-frame"]
        effects = "\n".join(f"  {o}: {{actuator: out, inline: {INLINE.format(name=o, obj=o, extra=', gain: 1.0')}}}"
                            for o in objs)
        scene = write_scene(Path(tmp), "  out: {type: memory, rate_hz: 8000, keep_mib: 1024}", effects)
        engine = Engine(scene, queue_size=n + 1)
        actuator = engine._outputs["actuators.out"].actuator
        workers = [threading.Thread(target=flood, args=(engine, objs[k % 4:] + objs[:k % 4], n // threads),
                                    kwargs={"every_s": 0.0}) for k in range(threads)]
        for w in workers:
            w.start()
        for w in workers:
            w.join()
        engine.close()
    x = np.concatenate([s.samples.reshape(-1) for s in actuator.played]) if actuator.played else np.zeros(1)
    hard = actuator.spec.limits
    what = f"{n} impacts on a shared memory output" + (f", {threads} threads" if threads > 1 else "")
    return measure(what, x, actuator.spec.rate_hz, peak=hard.peak, rms=hard.rms)


def wav_flood(n: int = 300, every_s: float = 0.002) -> Verdict:
    """Case 4 (issue 31, in the file's own time): impacts 2 ms apart into a WAV output, read back."""
    from ..actuators.files import read_wav

    with tempfile.TemporaryDirectory() as tmp:
        wav = Path(tmp) / "session.wav"
        objs = ["concrete-brick", "steel-plate"]
        effects = "\n".join(f"  {o}: {{actuator: out, inline: {INLINE.format(name=o, obj=o, extra='')}}}" for o in objs)
        scene = write_scene(Path(tmp), f"  out: {{type: wav, path: {wav}, rate_hz: 8000, format: float32, gain: 1.0}}",
                            effects)
        engine = Engine(scene)
        hard = engine._outputs["actuators.out"].actuator.spec.limits
        flood(engine, objs, n, every_s=every_s)
        engine.close()
        rate, x = read_wav(wav)
    return measure("WAV output, impacts 2 ms apart, read back", x.T, rate, peak=hard.peak, rms=hard.rms,
                   note=f"{x.shape[1] / rate:.2f} s in the file")


def strict_beside_plain(first: str = "plain", n: int = 8) -> Verdict:
    """An effect with its own limits (peak 0.2, RMS 0.1) routed to a WAV output beside a plain effect, the one or
    the other listed first: ``n`` of its impacts at one instant, summed in the file, against its limits."""
    from ..actuators.files import read_wav

    with tempfile.TemporaryDirectory() as tmp:
        wav = Path(tmp) / "session.wav"
        entries = {"plain": "  plain: {actuator: out, inline: " + INLINE.format(name="plain", obj="steel-plate",
                                                                                 extra="") + "}",
                   "strict": "  strict: {actuator: out, inline: " + INLINE.format(
                       name="strict", obj="concrete-brick", extra=", limits: {peak: 0.2, rms: 0.1}") + "}"}
        order = [first, "strict" if first == "plain" else "plain"]
        scene = write_scene(Path(tmp), f"  out: {{type: wav, path: {wav}, rate_hz: 8000, format: float32, gain: 1.0}}",
                            "\n".join(entries[k] for k in order))
        with Engine(scene) as engine:
            for _ in range(n):
                engine.impact("strict", 6.0, at=0.0)
        rate, x = read_wav(wav)
    return measure(f"an effect's own limits on a shared WAV output, the {first} effect listed first", x.T, rate,
                   peak=0.2, rms=0.1)


def refused(case: str, build: Callable[[], object], peak: float, rms: float) -> Verdict:
    """A case that must be refused with a clear error (nothing plays); ``build()`` closes what it opened."""
    try:
        build()
    except HapticfxError as exc:
        return Verdict(case, peak, rms, refused=str(exc).splitlines()[0][:300])
    return Verdict(case, peak, rms, samples_over=1, note="was not refused")


CORE_CASES: dict[str, Callable[[], Verdict]] = {
    "lying-mixer": lying_mixer,
    "lying-mixer-pipeline": lying_mixer_pipeline,
    "rate-dropper": rate_dropper,
    "timeline-mixer": timeline_mixer,
    "wav-remixer": wav_remixer,
    "wav-flood": wav_flood,
    "memory-4000": shared_memory,
    "memory-8-threads": lambda: shared_memory(4000, threads=8),
    "strict-after-plain": strict_beside_plain,
    "strict-before-plain": lambda: strict_beside_plain("strict"),
}
