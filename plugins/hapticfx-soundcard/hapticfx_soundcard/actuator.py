"""The sound-card actuators of the paper (Sect. 3.2): a vibro-transducer and a haptuator.

Both are voice-coil actuators driven from a sound card through an amplifier;
full scale of the sound card (1.0) is taken to be the actuator's rated peak
voltage after the amplifier. Constructing one does not touch the device;
``open`` finds it, agrees on a sample rate and joins the device's shared,
mixing output stream on the actuator's channel.
"""

from __future__ import annotations

import dataclasses
import logging
import sys
from dataclasses import dataclass, field
from typing import ClassVar, Literal

from hapticfx.actuators.known import KNOWN
from hapticfx.errors import DeviceError, EffectError
from hapticfx.interfaces import Actuator, ActuatorSpec, SafetyLimits
from hapticfx.params import BuildContext, doc
from hapticfx.shaping import resample
from hapticfx.signal import Signal

from .devices import negotiate_rate, physical_output, resolve_device
from .mixer import QueueProbe
from .shared import SharedStream

log = logging.getLogger(__name__)
# queue: auto. A 100 ms queue ran dry once, 18 ms after the machine paused for 75.5 ms (docs/benchmarks.md).
AUTO_QUEUE_S = 0.15


@dataclass(frozen=True)
class SoundCardParams:
    """Options of a sound-card actuator (effect file keys under ``actuator:``)."""

    rate_hz: int = field(default=48000, metadata=doc("requested sample rate; the device default if refused", min=8000, max=768000))
    latency: Literal["low", "high"] | float = field(
        default="low", metadata=doc("output latency to start with: PortAudio's 'low' or 'high' class, or seconds",
                                     min=0.001, max=1.0))
    max_latency: float = field(default=0.03, metadata=doc(
        "after underflows the buffer is lengthened, up to this many seconds, to hold the machine's longest "
        "wait; 0 keeps the buffer latency sets", min=0.0, max=1.0))
    blocksize: int = field(default=0, metadata=doc("frames per audio callback; 0 lets the host choose", min=0, max=8192))
    max_impacts: int = field(default=1000, metadata=doc(
        "impacts sounding at once; one more is not mixed in (1000 fit a 48-frame block: docs/benchmarks.md)",
        min=1, max=4096))
    watchdog_s: float = field(default=0.5, metadata=doc("a stream silent this long is an outage, then reopened", min=0.05, max=5.0))
    queue: Literal["auto"] | float = field(default="auto", metadata=doc(
        "seconds of audio kept queued at a PulseAudio (or PipeWire-Pulse) server, so that pauses of the machine "
        "shorter than it leave no gap; each impact is written over the queue `ahead` before playback "
        "(docs/soundcard.md); device then names a sink; 0: a PortAudio stream of `latency`; 'auto': a 0.15 s "
        "queue when a PulseAudio server answers and the device is the default (or `pulse`) or names one of its "
        "sinks, else PortAudio", min=0.0, max=2.0))
    ahead: float = field(default=0.01, metadata=doc(
        "with queue: how far ahead of playback a new impact is written, i.e. its latency; an engine's impact is "
        "written that long after it was received, so its render time does not add (down to 5 ms ahead)",
        min=0.002, max=0.5))


class SoundCardActuator(Actuator):
    """A voice-coil actuator on one channel of a sound card, mixed with its other impacts.

    ``play`` queues the signal and returns at once; overlapping impacts add up
    in one stream, and a :class:`~hapticfx.safety.SafetyLimiter` with this
    actuator's limits runs on the sum. ``drain`` waits until they were heard;
    ``close`` drains, then leaves the stream.
    """

    Params = SoundCardParams
    limits_mix = True  # the stream's mixer limits each channel's sum with this actuator's limits
    takes_received = True  # the queue at the server writes an impact `ahead` after it was received
    name: ClassVar[str]
    band_hz: ClassVar[tuple[float, float]]
    volts_peak: ClassVar[float]
    default_gain: ClassVar[float]
    hard_limits: ClassVar[SafetyLimits]

    def __init__(self, params: SoundCardParams | None = None, context: BuildContext | None = None):
        self.params = params if params is not None else self.Params()
        context = context if context is not None else BuildContext()
        self.device_request = context.device
        self.channel = 0 if context.channel is None else int(context.channel)
        if self.channel < 0:
            raise DeviceError(f"{self.name}: channel must be >= 0, got {self.channel}", source=context.source)
        self.spec = ActuatorSpec(
            rate_hz=float(self.params.rate_hz), volts_peak=self.volts_peak, band_hz=self.band_hz,
            waveform=True, limits=self.hard_limits, default_gain=self.default_gain,
        )
        self.limits = self.spec.limits
        queue = self.params.queue
        if queue != "auto" and queue and not self.params.ahead < queue:
            raise EffectError(f"ahead ({self.params.ahead:g} s) must be shorter than queue ({queue:g} s)",
                              source=context.source, key="actuator.ahead")
        self.note: str | None = None
        self._stream: SharedStream | None = None

    def open(self) -> None:
        if self._stream is not None:
            return
        # The streams load libpulse and PortAudio: only when a sound card is opened, not to read the spec.
        from . import queuestream
        from . import stream as streams

        p = self.params
        default_device = self.device_request in (None, "default", "pulse")  # the server's default sink
        # auto: a queue wherever the device names a sink of a PulseAudio server that answers (a number is a
        # PortAudio device index)
        sink_name = isinstance(self.device_request, str) and not self.device_request.strip().isdigit()
        if p.queue == "auto" and (default_device or sink_name) or p.queue not in ("auto", 0):
            try:
                self._stream = queuestream.acquire(
                    None if default_device else str(self.device_request), channel=self.channel,
                    limits=self.limits, queue_s=AUTO_QUEUE_S if p.queue == "auto" else p.queue,
                    ahead_s=p.ahead, max_voices=p.max_impacts, watchdog_s=p.watchdog_s)
                self._adopt_rate(self._stream.rate_hz)
                return
            except DeviceError as exc:
                if p.queue != "auto":
                    raise
                log.debug("%s: no PulseAudio queue (%s); PortAudio instead", self.name, exc)
        device = resolve_device(self.device_request)
        physical, sink_rate = physical_output(device)
        rate, self.note = negotiate_rate(device, sink_rate or self.spec.rate_hz, channels=min(2, device.channels))
        if self.note:
            print(f"{self.name}: {self.note}", file=sys.stderr)
        self._stream = streams.acquire(
            device, physical, channel=self.channel, rate_hz=rate, limits=self.limits, latency=p.latency,
            max_latency=p.max_latency, blocksize=p.blocksize, max_voices=p.max_impacts, watchdog_s=p.watchdog_s,
        )
        self._adopt_rate(self._stream.rate_hz)

    def _adopt_rate(self, rate_hz: float) -> None:
        """Run at the rate of the stream: the sink's on a PulseAudio server (which then resamples nothing
        after the limiter), the device's otherwise; impacts are shaped for it after open()."""
        if rate_hz != self.spec.rate_hz:
            self.note = self.note or f"{self.spec.rate_hz:g} Hz asked, the output runs at {rate_hz:g} Hz"
            log.info("%s: %s", self.name, self.note)
            self.spec = dataclasses.replace(self.spec, rate_hz=float(rate_hz))

    def output_key(self):
        """The sink (or PortAudio device) and channel this actuator plays into, resolved as ``open()`` would:
        the default sink named ``default``, ``pulse`` or by its own name is one output."""
        from . import queuestream
        from .libpulse import sink_info

        p = self.params
        if self._stream is not None:
            return self._stream.physical, self.channel
        default_device = self.device_request in (None, "default", "pulse")
        sink_name = isinstance(self.device_request, str) and not self.device_request.strip().isdigit()
        try:
            if p.queue == "auto" and (default_device or sink_name) or p.queue not in ("auto", 0):
                try:
                    name, _ = sink_info(None if default_device else str(self.device_request))
                    return queuestream.physical_sink(name), self.channel
                except DeviceError:
                    if p.queue != "auto":
                        raise
            return physical_output(resolve_device(self.device_request))[0], self.channel
        except DeviceError:
            return None  # open() will say what is wrong

    @classmethod
    def mix_probe(cls, limits: SafetyLimits, rate_hz: float):
        """The stream's mixer and limiter without a device, for the host's conformance check
        (:mod:`hapticfx.conformance`): impacts written over a queue, landing late as a busy machine makes them."""
        return QueueProbe(limits, rate_hz)

    @property
    def queue_s(self) -> float:
        """Seconds queued at the PulseAudio server, impacts written over them; 0: a PortAudio stream."""
        return self._require_stream().queue_s

    def _require_stream(self) -> SharedStream:
        if self._stream is None:
            raise DeviceError(f"{self.name} is not open; use it as a context manager or call open()")
        return self._stream

    def play(self, signal: Signal, *, received: float | None = None) -> None:
        """Queue ``signal`` (normalised, limited) on this actuator's channel; returns at once.

        ``received``: when the impact was received (``time.perf_counter()``; default: now). Through the
        queue at the server it is heard ``ahead`` after that, however long it took to render, as long as
        it can still be written that far ahead of playback (else as soon as it safely can); a PortAudio
        stream mixes it into its next block either way.
        """
        if not isinstance(signal, Signal):
            signal = Signal(signal, self.spec.rate_hz)
        stream = self._require_stream()
        if signal.samples.ndim != 1:
            raise DeviceError(f"{self.name} takes one channel; got a signal of shape {signal.samples.shape}")
        if signal.rate_hz != stream.rate_hz:
            signal = resample(signal, stream.rate_hz)
        stream.play(self.channel, signal.samples, received=received)

    def check(self) -> None:
        """Raise :class:`DeviceError` while the device is unavailable (it is being reopened)."""
        self._require_stream().check()

    def drain(self, timeout: float | None = 10.0) -> None:
        """Wait until every queued impact has been output; ``DeviceError`` on failure or timeout."""
        self._require_stream().drain(timeout)

    wait = drain

    def close(self) -> None:
        stream, self._stream = self._stream, None
        if stream is not None:
            stream.release(self.channel, drain_timeout_s=10.0, limits=self.limits)

    def losses(self) -> dict[str, int]:
        """Impacts taken but not played in full: not mixed in because ``max_impacts`` were sounding
        (``voice_cap``), longer than the mixer's ring (``truncated``), cut off by an outage (``outage``),
        written over the queue after the server had read their first frame (``late``: with ``queue`` only)."""
        stream = self._stream
        if stream is None:
            return {}
        counts = {"voice_cap": stream.mixer.refused, "truncated": stream.mixer.truncated, "outage": stream.lost,
                  "late": stream.late}
        return {k: v for k, v in counts.items() if v}

    @property
    def underflows(self) -> int:
        """Output underflows of the device's stream so far."""
        return self._require_stream().underflows

    @property
    def outages(self) -> int:
        """Outages of the output so far (each began when the stream failed or stalled, and ended when it played
        again)."""
        return self._require_stream().outages

    @property
    def output_latency_s(self) -> float:
        """The device stream's output latency (its buffer), as PortAudio reported it when the stream opened."""
        return self._require_stream().output_latency_s

    @property
    def buffer_changes(self) -> tuple[tuple[float, float, float], ...]:
        """``(time.monotonic(), from_s, to_s)`` of each time the stream was reopened with a longer buffer
        after underflows (``max_latency``)."""
        return tuple(self._require_stream().buffer_changes)

    @property
    def underflow_times(self) -> tuple[float, ...]:
        """When the latest (up to 1,024) underflows were reported, in ``time.monotonic()`` seconds."""
        return tuple(self._require_stream().underflow_times)

    @property
    def late_callbacks(self) -> tuple[tuple[float, float], ...]:
        """``(time.monotonic(), gap_s)`` of the latest (up to 1,024) audio callbacks that came longer than
        the buffer after the one before: a stream left unfed that long, whether or not an underflow was
        reported for it."""
        return tuple(self._require_stream().late_callbacks)

    def limiter_report(self):
        """What the mixer's safety limiter on this channel did (the sum of overlapping impacts)."""
        return self._require_stream().mixer.report(self.channel)

    def describe(self) -> str:
        where = "default device" if self.device_request in (None, "default") else f"device {self.device_request!r}"
        queued = self._stream.queue_s if self._stream is not None else 0.0
        how = f", a {queued * 1e3:g} ms queue at the PulseAudio server" if queued else ""
        return f"{self.name} on {where}, channel {self.channel}, {self.spec.rate_hz:g} Hz{how}"


class VibroTransducer(SoundCardActuator):
    """Vibro-transducer Vp408: +-5 V input, 20-15,000 Hz response (paper Sect. 3.2)."""

    name = "vibro-transducer"
    band_hz, volts_peak = KNOWN[name].band_hz, KNOWN[name].volts_peak
    default_gain, hard_limits = KNOWN[name].default_gain, KNOWN[name].hard_limits


class Haptuator(SoundCardActuator):
    """Haptuator MM1C (Tactile Labs): +-5 V input, 30-800 Hz response (paper Sect. 3.2)."""

    name = "haptuator"
    band_hz, volts_peak = KNOWN[name].band_hz, KNOWN[name].volts_peak
    default_gain, hard_limits = KNOWN[name].default_gain, KNOWN[name].hard_limits
