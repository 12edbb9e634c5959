"""`hapticfx.Engine`: render a scene's impacts off the simulator's thread.

``impact()`` validates its arguments, puts the impact on a bounded queue and
returns at once; one worker thread renders (model, shaping, safety limiter)
and plays. A full queue drops the impact and counts it (the caller never
blocks); an impact that fails while rendering is counted and logged and the
worker goes on with the next one.

Time: ``at`` (the simulation time of the collision) is recorded with each
delivery and not used for scheduling: an impact plays as soon as the worker
reaches it. The safety limiters run on the engine's own monotonic clock, so a
sender cannot space out its timestamps to defeat a duty-cycle limit.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .errors import EffectError, HapticfxError, one_line
from .interfaces import Actuator, Impact
from .osc import ImpactMessage
from .pipeline import Delivery, Pipeline
from .registry import Registry
from .safety import SafetyLimiter
from .scene import Scene, load_scene, stand_in_for
from .signal import Signal, valid_number, valid_velocity

log = logging.getLogger(__name__)

_STOP = object()


@dataclass(frozen=True)
class Played:
    """One impact the engine played: what was sent, and when (``time.perf_counter`` seconds)."""

    object: str
    at: float | None
    delivery: Delivery
    output: Signal
    received: float
    started: float
    played: float

    @property
    def latency_s(self) -> float:
        """From submission (or datagram arrival) to the actuator holding the samples."""
        return self.played - self.received


@dataclass
class _Job:
    object: str
    velocity: float
    at: float | None
    channel: int | None
    received: float


class _Output:
    """One opened actuator and the pipelines that play on it.

    When several effects share the actuator, a limiter with the actuator's
    limits also runs on what they send together: each effect's own limiter
    only sees its own impacts.
    """

    def __init__(self, name: str, actuator: Actuator, shared: bool, limits):
        self.name = name
        self.actuator = actuator
        self.limiter = SafetyLimiter(limits, actuator.spec.rate_hz) if shared else None


class Engine:
    """Renders impacts of a scene on a worker thread; thread-safe; use as a context manager.

    ``Engine("scenes/earthquake_room.yaml")`` builds every effect of the scene
    (only what they reference) and opens the actuators. ``device`` replaces
    every actuator, as ``--device`` does (``memory``, ``wav:PATH``).
    ``on_played(Played)`` is called on the worker thread after each impact.
    """

    def __init__(self, scene: Scene | str | Path, *, device: str | int | None = None,
                 queue_size: int | None = None, on_played: Callable[[Played], None] | None = None,
                 keep_last: int = 10_000, registry: Registry | None = None):
        self.scene = scene if isinstance(scene, Scene) else load_scene(scene)
        size = self.scene.engine.queue_size if queue_size is None else int(valid_number(queue_size, name="queue_size", minimum=1))
        self.close_timeout_s = self.scene.engine.close_timeout_s
        self.on_played = on_played
        self._pipelines: dict[str, Pipeline] = {}
        self._outputs: dict[str, _Output] = {}
        self._route: dict[str, _Output] = {}
        self._build(device, registry)
        self._queue: queue.Queue = queue.Queue(maxsize=size)
        self._lock = threading.Lock()
        self._counts = dict.fromkeys(
            ("submitted", "queued", "dropped_queue_full", "rendered", "failed", "cancelled", "callback_errors"), 0
        )
        self._errors: dict[str, int] = {}
        self._close_errors: dict[str, str] = {}
        self._last: deque[Played] = deque(maxlen=keep_last)
        self._closed = False
        self._open_outputs()
        self._worker = threading.Thread(target=self._run, name="hapticfx-engine", daemon=True)
        self._worker.start()

    # --- building ---------------------------------------------------------------

    def _build(self, device, registry) -> None:
        groups: dict[str, list[str]] = {}
        for oid, entry in self.scene.entries.items():
            groups.setdefault(entry.output, []).append(oid)
        for output, oids in groups.items():
            dev = stand_in_for(device, output, len(groups))
            first = None
            for oid in oids:
                pipeline = Pipeline(self.scene.entries[oid].effect, device=dev, registry=registry)
                self._pipelines[oid] = pipeline
                first = first or pipeline
            self._outputs[output] = _Output(output, first.actuator, len(oids) > 1, first.limits)
            for oid in oids:
                self._route[oid] = self._outputs[output]

    def _open_outputs(self) -> None:
        opened = []
        try:
            for out in self._outputs.values():
                out.actuator.open()
                opened.append(out)
        except BaseException:
            for out in opened:
                out.actuator.close()
            raise

    # --- the caller's side ------------------------------------------------------

    @property
    def objects(self) -> list[str]:
        """The object ids this engine renders."""
        return list(self._pipelines)

    def impact(self, object: str, velocity: float, at: float | None = None, *, channel: int | None = None) -> bool:
        """Queue one impact and return at once: True if queued, False if dropped (queue full).

        Raises :class:`~hapticfx.errors.HapticfxError` for an unknown object,
        a bad velocity, time or channel, or a closed engine.
        """
        return self._submit(object, velocity, at, channel, time.perf_counter())

    def submit(self, message: ImpactMessage, received: float) -> bool:
        """Queue an impact decoded by the OSC bridge; ``received`` is its arrival (perf_counter)."""
        return self._submit(message.object, message.velocity, message.at, message.channel, received)

    def _submit(self, object, velocity, at, channel, received) -> bool:
        route = self._pipelines.get(object)
        if route is None:
            raise EffectError(f"unknown object {object!r}; the scene has: {', '.join(self._pipelines)}", source=self.scene.source)
        velocity = valid_velocity(velocity)
        if at is not None:
            at = valid_number(at, name="at")
        wired = route.effect.actuator.channel
        if channel is not None and channel != wired:
            raise EffectError(
                f"object {object!r} plays on channel {wired if wired is not None else 'default'}, not {channel}",
                source=self.scene.source, key=f"effects.{object}.channel",
            )
        job = _Job(object, velocity, at, channel, received)
        with self._lock:
            if self._closed:  # checked under the lock: nothing is queued behind close()'s stop marker
                raise HapticfxError("the engine is closed")
            self._counts["submitted"] += 1
            try:
                self._queue.put_nowait(job)
            except queue.Full:
                self._counts["dropped_queue_full"] += 1
                return False
            self._counts["queued"] += 1
        return True

    # --- the worker ---------------------------------------------------------------

    def _run(self) -> None:
        t0 = time.monotonic()
        while True:
            job = self._queue.get()
            if job is _STOP:
                return
            try:
                played = self._play(job, time.monotonic() - t0)
            except Exception as exc:  # one bad event must never stop the engine
                self._failed(job, exc)
                continue
            if self.on_played is not None:
                try:
                    self.on_played(played)
                except Exception:  # the caller's callback: counted apart, the impact was played
                    with self._lock:
                        self._counts["callback_errors"] += 1
                        first = self._counts["callback_errors"] == 1
                    if first:
                        log.exception("on_played raised (further errors are counted, not logged)")

    def _play(self, job: _Job, now: float) -> Played:
        """Render one impact (its limiter on the engine's clock ``now``) and play it."""
        started = time.perf_counter()
        pipeline, out = self._pipelines[job.object], self._route[job.object]
        delivery = pipeline.render(Impact(pipeline.effect.object_id, job.velocity, now, job.channel))
        output = delivery.output
        if out.limiter is not None:
            output = output.with_samples(out.limiter.process(output.samples, at_s=now))
        out.actuator.play(output)
        played = Played(job.object, job.at, delivery, output, job.received, started, time.perf_counter())
        with self._lock:
            self._counts["rendered"] += 1
            self._last.append(played)
        return played

    def _failed(self, job: _Job, exc: Exception) -> None:
        kind = type(exc).__name__
        with self._lock:
            self._counts["failed"] += 1
            self._errors[kind] = self._errors.get(kind, 0) + 1
            first = self._errors[kind] == 1
        if isinstance(exc, HapticfxError):
            log.warning("impact %s at %.3g m/s failed: %s", job.object, job.velocity, exc)
        elif first:
            log.exception("impact %s at %.3g m/s failed (further %s errors are counted, not logged)",
                          job.object, job.velocity, kind)

    # --- state and shutdown ----------------------------------------------------------

    def stats(self) -> dict:
        """Counters: submitted = queued + dropped_queue_full; queued = rendered + failed + cancelled + pending."""
        with self._lock:
            out = dict(self._counts)
            out["errors"] = dict(self._errors)
            if self._close_errors:
                out["close_errors"] = dict(self._close_errors)
            lat = np.array([p.latency_s for p in self._last])
        out["pending"] = out["queued"] - out["rendered"] - out["failed"] - out["cancelled"]  # queued or rendering
        if lat.size:
            out["latency_ms"] = {
                "n": int(lat.size), "median": float(np.median(lat) * 1e3), "p99": float(np.percentile(lat, 99) * 1e3),
                "max": float(lat.max() * 1e3),
            }
        return out

    def played(self) -> list[Played]:
        """The last ``keep_last`` impacts played, oldest first."""
        with self._lock:
            return list(self._last)

    def close(self, *, drain: bool = True, timeout: float | None = None) -> dict:
        """Stop accepting impacts; render what is queued (``drain``) or cancel it; close the actuators.

        Waits at most ``timeout`` seconds (default: the scene's
        ``engine.close_timeout_s``) for the worker. Returns :meth:`stats`.
        Closing twice is harmless.
        """
        with self._lock:
            already, self._closed = self._closed, True
        if already:
            return self.stats()
        timeout = self.close_timeout_s if timeout is None else timeout
        deadline = time.monotonic() + timeout
        if not drain:
            self._cancel_pending()
        while True:
            try:
                self._queue.put(_STOP, timeout=max(0.0, deadline - time.monotonic()) or 0.001)
                break
            except queue.Full:
                if time.monotonic() >= deadline:
                    self._cancel_pending()
        self._worker.join(max(0.0, deadline - time.monotonic()))
        if self._worker.is_alive():
            log.warning("the engine's worker is still rendering after %.1f s; closing the actuators anyway", timeout)
            self._cancel_pending()
        for out in self._outputs.values():
            try:
                out.actuator.close()
            except Exception as exc:  # close every actuator even if one fails
                log.warning("closing %s failed: %s", out.actuator.describe(), exc)
                with self._lock:
                    self._close_errors[out.actuator.describe()] = one_line(str(exc), 200)
        return self.stats()

    def _cancel_pending(self) -> None:
        n = 0
        while True:
            try:
                job = self._queue.get_nowait()
            except queue.Empty:
                break
            if job is _STOP:
                self._queue.put_nowait(_STOP)
                break
            n += 1
        with self._lock:
            self._counts["cancelled"] += n

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
