"""`hapticfx.Engine`: render a scene's impacts off the simulator's thread.

``impact()`` validates its arguments, puts the impact on its output's bounded
queue and returns at once. Every output (one opened actuator) has its own
queue and worker thread, which renders (model, shaping, safety limiter) and
plays, so a slow or silent device never delays another. A full queue drops
the impact and counts it (the caller never blocks); an impact that fails is
counted by reason, logged at a limited rate, and the worker goes on.

Memory stays bounded on a long run: the engine keeps a summary of each of the
last ``keep_last`` impacts (:class:`Played`, no samples); the samples go to
the ``on_played`` callback (:class:`Playback`) and are not kept.

Time: ``at`` (the simulation time of the collision) is recorded with each
impact and not used for scheduling: an impact plays as soon as its worker
reaches it. The safety limiters run on the engine's own monotonic clock, so a
sender cannot space out its timestamps to defeat a duty-cycle limit. A file
output (``takes_time``) places each impact at its time on the session's
timeline instead: its arrival, or, when it carries ``at``, that time, shifted
once so that the first impact with an ``at`` lies where it arrived; the
session's first impact (on any output) is at 0, so the files of one engine
line up. The file limits the sum in its own time.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import queue
import threading
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .errors import DeviceError, EffectError, HapticfxError, SignalError, one_line, preview
from .interfaces import Actuator, Impact, valid_vector
from .interpolators.table import shared_tables
from .osc import ImpactMessage
from .pipeline import Delivery, Pipeline, build_actuator, check_rate, close_after_failure, open_actuator
from .ratelog import RateLimitedLog
from .registry import Registry
from .safety import SafetyLimiter
from .scene import Scene, load_scene, stand_in_for
from .signal import MAX_AT_S, Signal, valid_number, valid_velocity
from .conformance import limits_own_mix
from .sumbound import SumBound, host_limiter
from .spatial import Spatialiser

log = logging.getLogger(__name__)

OUTPUT_COUNTS = ("queued", "dropped_queue_full", "rendered", "failed", "cancelled")
LATENCIES_KEPT = 10_000  # per output, for the latency figures in stats()


@dataclass(frozen=True)
class Played:
    """One impact the engine played, as its history keeps it: what, when, how strong; no samples.

    Times are ``time.perf_counter`` seconds: ``received`` (submission or datagram
    arrival), ``started`` (its worker began rendering), ``played`` (the actuator
    took the samples).
    """

    object: str
    at: float | None
    velocity: float
    output: str
    peak: float
    duration_s: float
    limited: bool
    received: float
    started: float
    played: float
    point: tuple[float, float, float] | None = None
    normal: tuple[float, float, float] | None = None

    @property
    def latency_s(self) -> float:
        """From submission (or datagram arrival) to the actuator holding the samples."""
        return self.played - self.received


@dataclass(frozen=True)
class Playback(Played):
    """What the ``on_played`` callback receives: the summary plus the rendered signals."""

    delivery: Delivery | None = None
    signal: Signal | None = None

    def summary(self) -> Played:
        return Played(self.object, self.at, self.velocity, self.output, self.peak, self.duration_s, self.limited,
                      self.received, self.started, self.played, self.point, self.normal)


@dataclass
class _Job:
    object: str
    velocity: float
    at: float | None
    channel: int | None
    received: float
    point: tuple[float, float, float] | None = None
    normal: tuple[float, float, float] | None = None
    timeline_s: float = 0.0  # where a file output places it (see the module's docstring)


@dataclass
class _Site:
    """One actuator of a head output: where it sits, its actuator (one channel) and the limiter on its sum."""

    name: str
    channel: int
    actuator: Actuator
    limiter: SafetyLimiter | SumBound | None = None


class _Output:
    """One physical output (however many scene entries name it): its queue, its worker, and the host's limit
    on the sum of its effects (:meth:`arm`). A head output (a scene's ``head``) has several actuators, its
    ``sites``, each with its own limiter, and a spatialiser that spreads each impact over them."""

    def __init__(self, name: str, actuator: Actuator, pipelines: list[Pipeline], queue_size: int, *,
                 sites: list[_Site] | None = None, spatialiser: Spatialiser | None = None):
        self.name = name
        self.actuator = actuator
        self.pipelines = pipelines
        self.limits = pipelines[0].limits.strictest(*(p.limits for p in pipelines[1:]))
        self.sites = sites
        self.spatialiser = spatialiser
        self.limiter: SafetyLimiter | SumBound | None = None
        self.aliases: list[str] = []  # the other scene names of this output
        self.told: set[str] = set()  # the limits the log has already said acted
        self.queue: queue.Queue = queue.Queue(maxsize=queue_size)
        self.stop = threading.Event()
        self.closed = threading.Event()  # its actuators are being closed: nothing more is played into them
        self.counts = dict.fromkeys(OUTPUT_COUNTS, 0)
        self.errors: dict[str, int] = {}
        self.latencies: deque[float] = deque(maxlen=LATENCIES_KEPT)
        self.failing: str | None = None  # the device error of its last impact, until one plays again
        self.worker: threading.Thread | None = None

    @property
    def actuators(self) -> list[Actuator]:
        return [self.actuator] if self.sites is None else [s.actuator for s in self.sites]

    def arm(self) -> None:
        """The host's limiters, once the actuators are open (see :func:`host_limiter`)."""
        if self.sites is None:
            self.limiter = host_limiter(self.actuator, self.limits, summed=len(self.pipelines) > 1)
            return
        for site in self.sites:  # a site's own hard limits (its channel's) hold on it as well
            limits = self.limits.strictest(site.actuator.spec.limits)
            site.limiter = host_limiter(site.actuator, limits, summed=len(self.sites) > 1 or len(self.pipelines) > 1
                                        or limits != self.limits)

    def reports(self) -> list:
        """The host's limiter reports of this output (its sum, or each site's)."""
        limiters = [self.limiter] if self.sites is None else [s.limiter for s in self.sites]
        return [lim.report() for lim in limiters if lim is not None]


class _Closed(Exception):
    """An impact that finished rendering after its output's actuators began to close: cancelled."""


def _play_on(actuator: Actuator, signal: Signal, job: "_Job") -> None:
    if actuator.takes_received:
        actuator.play(signal, received=job.received)
    elif actuator.takes_time:
        actuator.play(signal, at_s=job.timeline_s)
    else:
        actuator.play(signal)


def _sounds_at(actuator: Actuator, job: "_Job", now: float) -> float:
    """When ``job`` sounds on ``actuator``'s own clock, for the host's limiter there: where a file output places
    it (``takes_time``), else now."""
    return job.timeline_s if actuator.takes_time and not actuator.takes_received else now


MAX_QUEUE = 1_000_000  # as a scene's engine.queue_size
MAX_KEEP_LAST = 1_000_000  # summaries of played impacts kept (about 1 KB each)


def _count(value, name: str, lo: int, hi: int) -> int:
    """``value`` as a whole number in ``[lo, hi]``: memory stays bounded, and 2.5 is not quietly 2."""
    whole = (not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)
             and value == int(value))
    if not whole or not lo <= int(value) <= hi:
        raise HapticfxError(f"{name} must be a whole number in [{lo}, {hi:,}], got {preview(value)}")
    return int(value)


def _pending(counts: dict) -> int:
    """Impacts queued and not yet played, failed or cancelled (waiting, or rendering now)."""
    return counts["queued"] - counts["rendered"] - counts["failed"] - counts["cancelled"]


def _latency_summary(values) -> dict | None:
    lat = np.fromiter(values, dtype=float)
    if not lat.size:
        return None
    return {"n": int(lat.size), "median": float(np.median(lat) * 1e3), "p99": float(np.percentile(lat, 99) * 1e3),
            "max": float(lat.max() * 1e3)}


class Engine:
    """Renders impacts of a scene on one worker thread per output; thread-safe; use as a context manager.

    ``Engine("scenes/earthquake_room.yaml")`` builds every effect of the scene
    (only what they reference) and opens the actuators. ``device`` replaces
    every actuator, as ``--device`` does (``memory``, ``wav:PATH``); a file it
    names that exists and hapticfx did not write is refused (``DeviceError``)
    unless ``overwrite``, and a directory always.
    ``on_played(Playback)`` is called on the output's worker after each impact.
    ``queue_size`` (default: the scene's ``engine.queue_size``) bounds each
    output's queue.
    """

    def __init__(self, scene: Scene | str | Path, *, device: str | int | None = None,
                 queue_size: int | None = None, on_played: Callable[[Playback], None] | None = None,
                 keep_last: int = 10_000, registry: Registry | None = None, overwrite: bool = False):
        if not isinstance(scene, (Scene, str, os.PathLike)):
            raise EffectError(f"expected a scene file's path or a Scene, got {type(scene).__name__}")
        if on_played is not None and not callable(on_played):  # else every impact failed in its callback
            raise HapticfxError(f"on_played must be callable (it is given each Playback), got {preview(on_played)}")
        if device is not None and (isinstance(device, bool) or not isinstance(device, (str, int))):
            raise HapticfxError(f"device must be a name, an index or a stand-in ('memory', 'wav:PATH'), got "
                                f"{preview(device)}")
        if not isinstance(overwrite, bool):
            raise HapticfxError(f"overwrite must be True or False, got {preview(overwrite)}")
        self.scene = scene if isinstance(scene, Scene) else load_scene(scene)
        size = self.scene.engine.queue_size if queue_size is None else _count(queue_size, "queue_size", 1, MAX_QUEUE)
        keep_last = _count(keep_last, "keep_last", 0, MAX_KEEP_LAST)
        self.close_timeout_s = self.scene.engine.close_timeout_s
        self.on_played = on_played
        self._pipelines: dict[str, Pipeline] = {}
        self._outputs: dict[str, _Output] = {}
        self._route: dict[str, _Output] = {}
        with shared_tables():  # entries served from one velocity table file share one copy of it, read once
            self._build(device, registry, size, overwrite)
        self._lock = threading.Lock()
        self._callback_errors = 0
        self._close_errors: dict[str, str] = {}
        self._last: deque[Played] = deque(maxlen=keep_last)
        self._log = RateLimitedLog(log)
        self._closed = False
        self._t0 = time.monotonic()
        self._t0_received = time.perf_counter()  # the session's start, on the clock arrivals are stamped with
        self._at_origin: float | None = None  # sender time - session time, from the first impact with an ``at``
        self._first_s: float | None = None  # the first impact's time: 0 on the files' timeline
        self._open_outputs()
        for out in self._outputs.values():
            out.worker = threading.Thread(target=self._run, args=(out,), name=f"hapticfx-engine:{out.name}", daemon=True)
            out.worker.start()

    # --- building ---------------------------------------------------------------

    def _build(self, device, registry, queue_size: int, overwrite: bool) -> None:
        """One output per physical output: scene entries whose actuators resolve to one device and channel
        (``Actuator.output_key``), under whatever names, share one actuator, queue and limiter."""
        groups: dict[str, list[str]] = {}
        for oid, entry in self.scene.entries.items():
            groups.setdefault(entry.output, []).append(oid)
        head = self.scene.head
        physical: dict[object, _Output] = {}
        for output, oids in groups.items():
            dev = stand_in_for(device, output, len(groups))
            pipelines = []
            for oid in oids:
                pipelines.append(Pipeline(self.scene.entries[oid].effect, device=dev, registry=registry,
                                          overwrite=overwrite))
                self._pipelines[oid] = pipelines[-1]
            if head is not None and output == f"actuators.{head.actuator}":
                out = self._outputs[output] = self._head_output(output, pipelines, device, len(groups), queue_size,
                                                                overwrite)
            else:
                key = pipelines[0].actuator.output_key()
                out = physical.get(key) if key is not None else None
                if out is None:
                    out = self._outputs[output] = _Output(output, pipelines[0].actuator, pipelines, queue_size)
                    if key is not None:
                        physical[key] = out
                else:  # another name for an output already built
                    out.aliases.append(output)
                    out.pipelines += pipelines
                    out.limits = out.limits.strictest(*(p.limits for p in pipelines))
            for oid in oids:
                self._route[oid] = out
        if head is not None:
            self._check_head_alone(physical)

    def _check_head_alone(self, physical: dict[object, "_Output"]) -> None:
        """Each of the head's sites on a physical output of its own: two limiters on one output (another scene
        actuator on a site's device and channel) would each hold the limit on their own part of its sum, and
        sites that share one (the channels of a file) would each write over the other."""
        out = self._outputs[f"actuators.{self.scene.head.actuator}"]
        taken: dict[object, str] = {}
        for site in out.sites:
            key = site.actuator.output_key()
            if key is None:
                continue
            where = " ".join(map(str, key)) if isinstance(key, tuple) else str(key)
            if key in taken:
                raise EffectError(f"the head's sites {taken[key]!r} and {site.name!r} play into one output of "
                                  f"{out.name} ({where}): a head needs an actuator with a channel of its own for each "
                                  "site (a sound card)", source=self.scene.source, key="head.sites")
            taken[key] = site.name
            if key in physical:
                raise EffectError(f"{physical[key].name} plays into the output of the head's site {site.name!r} "
                                  f"({where}): route its effects to {self.scene.head.actuator!r}, or give it another "
                                  "device or channel", source=self.scene.source, key=physical[key].name)

    def _head_output(self, output: str, pipelines: list[Pipeline], device, n_groups: int,
                     queue_size: int, overwrite: bool) -> _Output:
        """The scene's head: one actuator per site (the head actuator's section on the site's channel)."""
        head = self.scene.head
        first = pipelines[0]
        sites = []
        for site in head.sites:
            effect = dataclasses.replace(first.effect, actuator=dataclasses.replace(first.effect.actuator,
                                                                                    channel=site.channel))
            dev = stand_in_for(device, f"{output}#{site.channel}", n_groups + len(head.sites) - 1)
            sites.append(_Site(site.name, site.channel, build_actuator(first.plan, effect, dev, overwrite=overwrite)))
        return _Output(output, sites[0].actuator, pipelines, queue_size, sites=sites, spatialiser=Spatialiser(head))

    def _open_outputs(self) -> None:
        opened = []
        try:
            for out in self._outputs.values():
                for actuator in out.actuators:  # the conformance verdicts, before any stream plays
                    limits_own_mix(actuator)
            for out in self._outputs.values():
                for actuator in out.actuators:  # what an actuator that limits its own mix holds on it
                    actuator.limits = out.limits.strictest(actuator.spec.limits)
                    open_actuator(actuator, source=self.scene.source, key=out.name)
                    opened.append(actuator)
                out.arm()
                for pipeline in out.pipelines:  # shape and limit at the rate the device agreed on
                    pipeline.adopt(out.actuator)
        except BaseException as exc:
            close_after_failure(opened, exc)
            raise

    # --- the caller's side ------------------------------------------------------

    @property
    def objects(self) -> list[str]:
        """The object ids this engine renders."""
        return list(self._pipelines)

    def impact(self, object: str, velocity: float, at: float | None = None, *, channel: int | None = None,
               point=None, normal=None) -> bool:
        """Queue one impact and return at once: True if queued, False if dropped (its output's queue is full).

        ``at``: the simulation time of the collision (s); ``point`` and ``normal``:
        where on the head it landed, in the head frame of docs/protocol.md.
        Raises :class:`~hapticfx.errors.HapticfxError` for an unknown object,
        a bad velocity, time, channel, point or normal, or a closed engine.
        """
        return self._submit(object, velocity, at, channel, time.perf_counter(), point, normal)

    def submit(self, message: ImpactMessage, received: float) -> bool:
        """Queue an impact decoded by the OSC bridge; ``received`` is its arrival (perf_counter)."""
        return self._submit(message.object, message.velocity, message.at, message.channel, received,
                            message.point, message.normal)

    def _submit(self, object, velocity, at, channel, received, point=None, normal=None) -> bool:
        route = self._pipelines.get(object) if isinstance(object, str) else None
        if route is None:
            raise EffectError(f"unknown object {preview(object)}; the scene has: {', '.join(self._pipelines)}",
                              source=self.scene.source)
        velocity = valid_velocity(velocity)
        if at is not None:  # seconds of simulation, or of the wall clock (an OSC bundle's timetag)
            at = valid_number(at, name="at", minimum=-MAX_AT_S, maximum=MAX_AT_S)
        if channel is not None and (isinstance(channel, bool) or not isinstance(channel, (int, np.integer))):
            raise SignalError(f"channel must be a whole number, got {preview(channel)}")
        point = valid_vector(point, name="point")
        normal = valid_vector(normal, name="normal", unit=True)
        out = self._route[object]
        if out.spatialiser is not None:
            if channel is not None and channel not in out.spatialiser.by_channel:
                raise EffectError(f"object {object!r} plays on the head's channels "
                                  f"{sorted(out.spatialiser.by_channel)}, not {channel}", source=self.scene.source,
                                  key="head.sites")
        elif channel is not None and channel != (route.effect.actuator.channel or 0):
            # no channel in the scene: the actuator's first, 0
            raise EffectError(
                f"object {object!r} plays on channel {route.effect.actuator.channel or 0}, not {channel}",
                source=self.scene.source, key=f"effects.{object}.channel",
            )
        job = _Job(object, velocity, at, channel, received, point, normal)
        with self._lock:
            if self._closed:  # checked under the lock: nothing is queued once close() began
                raise HapticfxError("the engine is closed")
            arrived = received - self._t0_received
            if at is not None and self._at_origin is None:
                self._at_origin = at - arrived
            t = arrived if at is None else at - self._at_origin
            if self._first_s is None:
                self._first_s = t
            job.timeline_s = t - self._first_s
            try:
                out.queue.put_nowait(job)
            except queue.Full:
                out.counts["dropped_queue_full"] += 1
                queued = False
            else:
                out.counts["queued"] += 1
                queued = True
        if not queued:
            self._log.event(("queue_full", out.name), f"{out.name}: queue full ({out.queue.maxsize}), impact of "
                                                      f"{object} dropped")
        return queued

    # --- the workers ------------------------------------------------------------

    def _run(self, out: _Output) -> None:
        while True:
            try:
                job = out.queue.get(timeout=0.05)
            except queue.Empty:
                if out.stop.is_set():
                    return
                continue
            try:
                playback = self._play(out, job, time.monotonic() - self._t0)
            except _Closed:
                with self._lock:
                    out.counts["cancelled"] += 1
                continue
            except BaseException as exc:  # one bad event (a plugin's SystemExit too) must never stop the engine
                self._failed(out, job, exc)
                if out.stop.is_set() and out.failing:  # closing: the rest would only fail the same way
                    self._cancel_pending(out)
                continue
            if self.on_played is not None:
                try:
                    self.on_played(playback)
                except Exception:  # the caller's callback: counted apart, the impact was played
                    with self._lock:
                        self._callback_errors += 1
                        first = self._callback_errors == 1
                    if first:
                        log.exception("on_played raised (further errors are counted, not logged)")

    def _play(self, out: _Output, job: _Job, now: float) -> Playback:
        """Render one impact (its limiter on the engine's clock ``now``) and play it."""
        started = time.perf_counter()
        pipeline = self._pipelines[job.object]
        delivery = pipeline.render(Impact(pipeline.effect.object_id, job.velocity, now, job.channel, at=job.at,
                                          point=job.point, normal=job.normal))
        signal = delivery.output
        limited = delivery.limiter.total > 0
        if out.closed.is_set():  # it rendered past the close timeout: its actuators are closing or closed
            raise _Closed
        if out.spatialiser is not None:
            signal, spread_limited = self._spread(out, job, signal, now)
            limited = limited or spread_limited
        else:
            if out.limiter is not None:
                before = out.limiter.report().total
                signal = Signal(out.limiter.process(signal.samples, at_s=_sounds_at(out.actuator, job, now)),
                                signal.rate_hz)  # see render()
                limited = limited or out.limiter.report().total > before
            _play_on(out.actuator, signal, job)
        acted = set(delivery.limiter.acted).union(*(r.acted for r in out.reports())) if limited else set()
        for what in acted - out.told:  # once per limit and output: which limit acted, and who set it
            out.told.add(what)
            self._log.event(("limit", out.name, what), f"{out.name}: the safety limit acted: {what}")
        for note in delivery.notes:
            self._log.event(("note", job.object), f"{job.object}: {note}")
        playback = Playback(job.object, job.at, job.velocity, out.name, signal.peak, signal.duration_s, limited,
                            job.received, started, time.perf_counter(), job.point, job.normal, delivery=delivery,
                            signal=signal)
        with self._lock:
            out.counts["rendered"] += 1
            out.latencies.append(playback.latency_s)
            out.failing = None
            self._last.append(playback.summary())
        return playback

    @staticmethod
    def _spread(out: _Output, job: _Job, signal: Signal, now: float) -> tuple[Signal, bool]:
        """Gains and onset delays per site, each site's limiter, and play: every site gets a block of the same
        length (silent where the impact does not reach), so that file outputs stay aligned. Returns the
        (sites x samples) signal played and whether a site's limiter acted."""
        rate = signal.rate_hz
        placements = out.spatialiser.place(job.point, job.normal, job.channel)
        per_site = out.spatialiser.spread(signal.samples, rate, placements)
        limited = False
        sounding = {p.site for p in placements if p.gain > 0}
        for site in out.sites:
            if site.limiter is not None:
                check_rate(site.actuator, site.limiter.rate_hz)
        for k, site in enumerate(out.sites):
            if site.limiter is not None and k in sounding:  # a silent row needs no limiting: zeros stay zeros
                before = site.limiter.report().total
                per_site[k] = site.limiter.process(per_site[k], at_s=_sounds_at(site.actuator, job, now))
                limited = limited or site.limiter.report().total > before
            _play_on(site.actuator, Signal(per_site[k], rate), job)  # a copy: no site can write into another's row
        return Signal.adopt(per_site, rate), limited

    def _failed(self, out: _Output, job: _Job, exc: BaseException) -> None:
        kind = type(exc).__name__
        with self._lock:
            out.counts["failed"] += 1
            out.errors[kind] = out.errors.get(kind, 0) + 1
            if isinstance(exc, DeviceError):
                out.failing = one_line(str(exc), 200)
        what = f"impact {job.object} at {job.velocity:.3g} m/s on {out.name} failed"
        if isinstance(exc, HapticfxError):
            self._log.event((kind, out.name), f"{what}: {exc}")
        else:
            self._log.event((kind, out.name), f"{what} (a bug, not a bad input)", exc_info=exc)

    # --- state and shutdown ----------------------------------------------------------

    def stats(self) -> dict:
        """Counters, overall and per output.

        submitted = queued + dropped_queue_full; queued = rendered + failed +
        cancelled + pending. ``errors`` counts failures by kind; per output,
        ``losses`` are impacts its device accepted but could not play in full
        (for example voices cut short by a full mixer), by reason.
        """
        with self._lock:
            per = {name: (dict(o.counts), dict(o.errors), list(o.latencies), o.failing) for name, o in self._outputs.items()}
            callback_errors, close_errors = self._callback_errors, dict(self._close_errors)
        totals = {k: sum(counts[k] for counts, _, _, _ in per.values()) for k in OUTPUT_COUNTS}
        out = {"submitted": totals["queued"] + totals["dropped_queue_full"], **totals, "callback_errors": callback_errors}
        by_kind: dict[str, int] = {}
        for _, kinds, _, _ in per.values():
            for kind, n in kinds.items():
                by_kind[kind] = by_kind.get(kind, 0) + n
        out["errors"] = by_kind
        if close_errors:
            out["close_errors"] = close_errors
        out["pending"] = _pending(out)
        latency = _latency_summary(v for _, _, lat, _ in per.values() for v in lat)
        if latency:
            out["latency_ms"] = latency
        outputs = {}
        for name, (counts, errors, lat, failing) in per.items():
            entry = {**counts, "pending": _pending(counts)}
            if errors:
                entry["errors"] = errors
            if failing:
                entry["failing"] = failing
            losses = {}
            for actuator in self._outputs[name].actuators:
                for reason, n in actuator.losses().items():
                    losses[reason] = losses.get(reason, 0) + n
            if losses:
                entry["losses"] = losses
            summary = _latency_summary(lat)
            if summary:
                entry["latency_ms"] = summary
            entry.update(self._limits_of(self._outputs[name]))
            outputs[name] = entry
        out["outputs"] = outputs
        return out

    @staticmethod
    def _limits_of(o: _Output) -> dict:
        """The limits that hold on an output, who set each, and which acted so far (the effects' limiters,
        the host's, and the mixer of an actuator that limits its own sum)."""
        acted = set().union(*(p.limiter.report().acted for p in o.pipelines), *(r.acted for r in o.reports()))
        for actuator in o.actuators:
            report = getattr(actuator, "limiter_report", None)
            if report is not None:
                try:
                    acted |= set(report().acted)
                except HapticfxError:  # closed: its mixer is gone
                    pass
        entry = {"limits": o.limits.describe()}
        if acted:
            entry["limits_acted"] = sorted(acted)
        if o.aliases:
            entry["also_named"] = list(o.aliases)
        return entry

    def played(self) -> list[Played]:
        """Summaries of the last ``keep_last`` impacts played, oldest first."""
        with self._lock:
            return list(self._last)

    def close(self, *, drain: bool = True, timeout: float | None = None) -> dict:
        """Stop accepting impacts; play what is queued (``drain``) or cancel it; close the actuators.

        Impacts queued for an output whose device is failing are cancelled, not
        waited on. Waits at most ``timeout`` seconds (default: the scene's
        ``engine.close_timeout_s``) for the workers, then closes every actuator
        (in parallel), waiting as long again (at least 1 s) for them: an impact
        that finishes rendering after that is cancelled, not played, and an
        actuator whose ``close()`` does not return is left to finish on its own
        and named in ``stats()["close_errors"]``. Returns :meth:`stats`.
        Closing twice is harmless.
        """
        with self._lock:
            already, self._closed = self._closed, True
        if already:
            return self.stats()
        timeout = self.close_timeout_s if timeout is None else timeout
        deadline = time.monotonic() + timeout
        for out in self._outputs.values():
            if not drain or out.failing:
                self._cancel_pending(out)
            out.stop.set()
        for out in self._outputs.values():
            out.worker.join(max(0.0, deadline - time.monotonic()))
        stuck = [out.name for out in self._outputs.values() if out.worker.is_alive()]
        if stuck:
            log.warning("still playing on %s after %.1f s; closing the actuators anyway", ", ".join(stuck), timeout)
            for out in self._outputs.values():
                self._cancel_pending(out)
        for out in self._outputs.values():
            out.closed.set()
        closers = [threading.Thread(target=self._close_output, args=(out,), name=f"hapticfx-close:{out.name}",
                                    daemon=True) for out in self._outputs.values()]
        for t in closers:
            t.start()
        waited = max(timeout, 1.0)  # as long again for the actuators' close()
        deadline = time.monotonic() + waited
        for t, out in zip(closers, self._outputs.values()):
            t.join(max(0.0, deadline - time.monotonic()))
            if t.is_alive():
                log.warning("closing %s did not return within %.1f s; left to finish on its own", out.name, waited)
                with self._lock:
                    self._close_errors[out.name] = f"close() did not return within {waited:g} s"
        self._log.flush()
        return self.stats()

    def _close_output(self, out: _Output) -> None:
        for actuator in out.actuators:
            try:
                actuator.close()
            except Exception as exc:  # close every actuator even if one fails
                log.warning("closing %s failed: %s", actuator.describe(), exc)
                with self._lock:
                    self._close_errors[actuator.describe()] = one_line(str(exc), 200)

    def _cancel_pending(self, out: _Output) -> None:
        n = 0
        while True:
            try:
                out.queue.get_nowait()
            except queue.Empty:
                break
            n += 1
        with self._lock:
            out.counts["cancelled"] += n

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def describe(self) -> dict:
        """What the engine loaded: per object, the effect, model and output."""
        return {
            "scene": self.scene.name, "file": self.scene.source,
            "objects": {
                oid: {"effect": p.effect.name, "model": p.model.describe(), "output": self._route[oid].name,
                      "actuator": self._route[oid].actuator.describe()}
                for oid, p in self._pipelines.items()
            },
        }
