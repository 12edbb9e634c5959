"""A simulated participant: answers a study from what reached the actuator, with configurable noise and bias.

- Matching and similarity come from the signals. Each played output is
  described by its level in 12 log-spaced bands from 10 Hz to 1 kHz (dB); the
  perceptual distance of two outputs is the RMS difference of those levels
  over 10 dB. A comparison is chosen with probability proportional to
  ``exp(-distance / choice_temperature)``; similarity is
  ``100 exp(-distance / similarity_scale)``.
- Ratings are ``base`` plus every ``effects`` shift whose factor levels the
  trial's stimulus has: the simulated participant holds no opinion on realism
  of its own, so a known effect is what the study file states.
- Every rating gets the participant's own offset (``participant_sd``, per task
  and question) and noise (``noise_sd``), and is clipped to the scale.

Each trial's draws are seeded by (study seed, participant number, trial index),
so a resumed simulated session answers exactly as an uninterrupted one would.
"""

from __future__ import annotations

import time

import numpy as np

from .schedule import Trial, participant_number
from .session import Session
from .spec import Question, Study, Task

BANDS_HZ = np.geomspace(10.0, 1000.0, 13)


def band_levels_db(samples: np.ndarray, rate_hz: float) -> np.ndarray:
    """Energy of a signal in each of the 12 bands of :data:`BANDS_HZ`, in dB (floor -120 dB)."""
    x = np.atleast_2d(np.asarray(samples, dtype=np.float64)).sum(axis=0)
    n = max(len(x), int(rate_hz))  # at least 1 s of spectrum, so the lowest band has bins
    spectrum = np.abs(np.fft.rfft(x, n)) ** 2
    freqs = np.fft.rfftfreq(n, 1.0 / rate_hz)
    idx = np.searchsorted(freqs, BANDS_HZ)
    energy = np.array([spectrum[a:b].sum() for a, b in zip(idx[:-1], idx[1:])]) / n
    return 10.0 * np.log10(energy + 1e-12)


def perceptual_distance(a: list, b: list) -> float:
    """Distance between two played slots (lists of engine ``Playback``): mean RMS band-level difference over 10 dB."""
    fa = np.mean([band_levels_db(p.signal.samples, p.signal.rate_hz) for p in a], axis=0)
    fb = np.mean([band_levels_db(p.signal.samples, p.signal.rate_hz) for p in b], axis=0)
    return float(np.sqrt(np.mean((fa - fb) ** 2)) / 10.0)


class SimulatedParticipant:
    """Answers trials like a participant would, by the study's ``simulate`` model."""

    def __init__(self, study: Study, participant: str):
        self.study = study
        self.sim = study.simulate
        self.number = participant_number(participant)
        rng = np.random.default_rng([study.seed, self.number, 1])
        self.offsets = {(t.name, q.id): float(rng.normal(0.0, self.sim.participant_sd))
                        for t in study.tasks for q in t.questions}

    def shift(self, task: Task, question: Question, trial: Trial) -> float:
        """The sum of the study's simulated effects that apply to this trial and question."""
        total = 0.0
        for e in self.sim.effects:
            if e.task not in (None, task.name) or e.question not in (None, question.id):
                continue
            if any(all(self.study.stimuli[s.stimulus].factors.get(f) == v for f, v in e.when.items()) for s in trial.slots):
                total += e.shift
        return total

    def respond(self, trial: Trial, task: Task, played: dict[str, list]) -> dict:
        """The answer to ``trial``, given what each of its slots played."""
        rng = np.random.default_rng([self.study.seed, self.number, 1000 + trial.index])
        if task.type == "matching":
            target = played[trial.slots[0].name]
            names = [s.name for s in trial.slots[1:]]
            d = np.array([perceptual_distance(target, played[n]) for n in names])
            w = np.exp(-(d - d.min()) / self.sim.choice_temperature)
            return {"choice": names[int(rng.choice(len(names), p=w / w.sum()))]}
        base = self.sim.base
        if task.type == "similarity":
            a, b = (played[s.name] for s in trial.slots)
            base = 100.0 * np.exp(-perceptual_distance(a, b) / self.sim.similarity_scale)
        ratings = {}
        for q in task.questions:
            value = base + self.shift(task, q, trial) + self.offsets[(task.name, q.id)] + rng.normal(0.0, self.sim.noise_sd)
            ratings[q.id] = round(float(np.clip(value, q.low, q.high)), 3)
        return {"ratings": ratings}


def run_simulated(session: Session, *, pace_s: float = 0.0, progress=None) -> int:
    """Let a simulated participant answer every remaining trial of ``session``; returns how many it answered."""
    who = SimulatedParticipant(session.study, session.participant)
    answered = 0
    while True:
        state = session.state()
        screen = state["screen"]
        if screen == "done":
            return answered
        index = state["trial"]["index"]
        if screen in ("instructions", "break"):
            session.proceed(index, screen)
            continue
        trial = session.schedule[index]
        played = {s.name: session.play(index, s.name) for s in trial.slots}
        session.answer(index, who.respond(trial, session.tasks[trial.task], played))
        answered += 1
        if progress is not None:
            progress(state["progress"]["answered"] + 1, state["progress"]["total"])
        if pace_s:
            time.sleep(pace_s)
