"""Driving mutants through a gate and classifying what came back (``hapticfx bench fuzz``).

Per input: *accepted*, *refused* (a :class:`~hapticfx.errors.HapticfxError` of one
line under 300 characters), *bad message* (a refusal on several lines or longer),
*traceback* (any other exception escaped: a bug) or *hang* (over the time limit;
interrupted by a timer signal). The slowest input and the process's peak resident
memory are reported with the counts.
"""

from __future__ import annotations

import resource
import signal
import tempfile
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import HapticfxError
from .confuse import confuse
from .gates import Gate
from .mutate import mutate

MESSAGE_LIMIT = 300


class _Hang(BaseException):
    """Raised by the timer in the middle of an input that took too long."""


def message_ok(exc: HapticfxError) -> bool:
    text = str(exc)
    return "\n" not in text and len(text) < MESSAGE_LIMIT


@dataclass
class GateResult:
    """The counts of one gate's run, and an example of each kind of failure."""

    gate: str
    inputs: int = 0
    accepted: int = 0
    refused: int = 0
    bad_messages: int = 0
    tracebacks: int = 0
    hangs: int = 0
    longest_message: int = 0
    slowest_s: float = 0.0
    examples: dict[str, str] = field(default_factory=dict)

    @property
    def failures(self) -> int:
        return self.bad_messages + self.tracebacks + self.hangs


MUTATORS: dict[str, Callable[[bytes, np.random.Generator], bytes]] = {"bytes": mutate, "types": confuse}


def fuzz_gate(gate: Gate, inputs: int, *, seed: int = 0, time_limit_s: float = 1.0,
              progress: Callable[[int], None] | None = None, mutator: str = "bytes") -> GateResult:
    """Run ``inputs`` mutants of the gate's seeds made by ``mutator`` (``MUTATORS``; input ``i`` is the
    same for the same ``seed``); ``progress(n)`` is told of every ``n`` more inputs done."""
    mutant = MUTATORS[mutator]
    res = GateResult(gate.name)
    previous = signal.signal(signal.SIGALRM, _raise_hang)
    try:
        with tempfile.TemporaryDirectory(prefix=f"hapticfx-fuzz-{gate.name}-") as tmp:
            work = Path(tmp)
            seeds = gate.seeds(work)
            if not seeds:
                return res
            for i in range(inputs):
                rng = np.random.default_rng([seed, i])
                data = seeds[i % len(seeds)] if i < len(seeds) else mutant(seeds[int(rng.integers(len(seeds)))], rng)
                _one(gate, data, work, res, time_limit_s)
                if progress and ((i + 1) % 100 == 0 or i + 1 == inputs):
                    progress(100 if (i + 1) % 100 == 0 else (i + 1) % 100)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    return res


def _raise_hang(signum, frame):
    raise _Hang()


def _one(gate: Gate, data: bytes, work: Path, res: GateResult, limit: float) -> None:
    res.inputs += 1
    t0 = time.perf_counter()
    signal.setitimer(signal.ITIMER_REAL, limit)
    try:
        try:
            gate.run(data, work)
        finally:  # disarmed before a refusal is looked at: the timer must not fire in the handlers below
            signal.setitimer(signal.ITIMER_REAL, 0)
        res.accepted += 1
    except HapticfxError as exc:
        res.longest_message = max(res.longest_message, len(str(exc)))
        if message_ok(exc):
            res.refused += 1
        else:
            res.bad_messages += 1
            res.examples.setdefault("bad message", f"{data[:120]!r} -> {str(exc)[:400]!r}")
    except _Hang:
        res.hangs += 1
        res.examples.setdefault("hang", repr(data[:120]))
    except Exception:  # the point of fuzzing: anything else is a bug to show
        res.tracebacks += 1
        res.examples.setdefault("traceback", f"{data[:120]!r} -> {traceback.format_exc(limit=-3)[-600:]}")
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        res.slowest_s = max(res.slowest_s, time.perf_counter() - t0)


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far (MiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
