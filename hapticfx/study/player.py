"""Plays a study's stimuli through :class:`hapticfx.Engine`: the same pipelines, limiters and actuators as a scene.

The study becomes a scene: each stimulus an entry on its study actuator (so
stimuli on one actuator share one opened device and a limiter over all they
send), each recorded drop a trial uses an entry of its own.
"""

from __future__ import annotations

import dataclasses
import queue
import time

from ..effect import Section
from ..errors import DeviceError
from ..scene import EngineSettings, Scene, SceneEntry
from .schedule import Slot, Trial
from .spec import Study


def entry_id(stimulus: str, drop: int | None) -> str:
    """The scene entry that plays ``stimulus`` (one per recorded drop)."""
    return stimulus if drop is None else f"{stimulus}~drop{drop}"


def study_scene(study: Study, schedule: list[Trial]) -> Scene:
    """A scene with an entry for every stimulus (and recorded drop) that ``schedule`` plays."""
    entries = {}
    for trial in schedule:
        for slot in trial.slots:
            s = study.stimuli[slot.stimulus]
            for drop in slot.drops:
                eid = entry_id(s.name, drop)
                if eid in entries:
                    continue
                effect = s.effect
                if drop is not None:
                    effect = dataclasses.replace(effect, model=Section("recorded", {**effect.model.options, "drop": drop}))
                entries[eid] = SceneEntry(eid, effect, f"actuators.{s.actuator}")
    return Scene(study.name, study.source, entries, None, EngineSettings(queue_size=16))


class StimulusPlayer:
    """Plays one trial slot at a time and returns what reached the actuator. Use as a context manager.

    ``realtime`` waits for each impact to finish playing before the next starts
    (a real device); stand-ins (``memory``, ``wav:``) need no waiting.
    """

    def __init__(self, study: Study, schedule: list[Trial], *, device: str | int | None = None, realtime: bool = True,
                 overwrite: bool = False):
        from ..engine import Engine

        self.realtime = realtime
        self._played: queue.SimpleQueue = queue.SimpleQueue()
        self.engine = Engine(study_scene(study, schedule), device=device, on_played=self._played.put,
                             overwrite=overwrite)
        self._failed = 0  # impacts the engine failed so far (a failure ends the play, so none goes unseen)

    def play(self, slot: Slot, gap_s: float) -> list:
        """Play the slot's impacts in order, ``gap_s`` apart; returns their :class:`~hapticfx.engine.Playback`
        records (with the signals sent)."""
        out = []
        for k, (velocity, drop) in enumerate(zip(slot.velocities, slot.drops)):
            if k and self.realtime:
                time.sleep(gap_s)
            self.engine.impact(entry_id(slot.stimulus, drop), velocity)
            deadline = time.monotonic() + 30.0
            while True:
                try:
                    played = self._played.get(timeout=0.05)
                    break
                except queue.Empty:  # stats() sums every limiter's report: asked only while an impact is late
                    stats = self.engine.stats()
                    if stats["failed"] > self._failed or time.monotonic() > deadline:
                        self._failed = stats["failed"]
                        raise DeviceError(
                            f"playing {slot.stimulus} at {velocity} m/s failed: {stats['errors'] or 'timed out'}") from None
            out.append(played)
            if self.realtime:
                time.sleep(played.duration_s)
        return out

    def close(self) -> None:
        self.engine.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
