"""Whether an actuator that sums overlapping impacts itself may take over the limit on their sum.

An actuator class that declares ``limits_mix = True`` says it sums the impacts it is given and limits the
sum. The host believes it only when its own limiter passes :func:`check_mix_limiter`, run once per class
in this process the first time one opens: the class's ``mix_probe(limits, rate_hz)`` hands over its mixer
and limiter without a device, the check plays a dense flood of overlapping impacts through it and measures
what it would send (every sample against the peak, every ``rms_window_s`` window against the RMS). A class
without ``mix_probe``, or whose probe lets one sample or one window over, keeps the host's limiter on the
sum (:class:`~hapticfx.sumbound.SumBound`) and a warning says why. Plugin authors run the same check in
their tests: :func:`hapticfx.testing.assert_mix_limiter`.

The verdict depends only on code, so it is computed once per version of it: it is kept in
``conformance.json`` of the user cache folder (:func:`hapticfx.caches.cache_root`) under a hash of every
source file of the class's top-level package and of the core's limiter, and checked again when one of them
changes.
"""

from __future__ import annotations

import hashlib
import inspect
import json
import logging
import sys
import threading
from pathlib import Path
from typing import Protocol

import numpy as np

from .atomic import atomic_path
from .caches import cache_root
from .errors import HapticfxError
from .interfaces import SafetyLimits

log = logging.getLogger(__name__)

# Limits tight enough that a flood of full-scale impacts must be limited on both counts.
PROBE_LIMITS = SafetyLimits(peak=0.3, rms=0.2, source="conformance check")
# every field other than the first's: a probe that limits to fixed values, not to the limits it is given, fails one
PROBES = (PROBE_LIMITS, SafetyLimits(peak=0.2, rms=0.12, rms_window_s=0.02, source="conformance check"))
PROBE_RATE_HZ = 8000.0
PROBE_S = 1.0
ROUNDING = 1e-6  # relative: a limit of 0.3 is 0.30000001 in the float32 a device takes


class MixProbe(Protocol):
    """What ``mix_probe`` returns: the actuator's mixer and limiter, with no device behind them."""

    def play(self, samples: np.ndarray, at_frame: int) -> None:
        """Mix one impact in from stream frame ``at_frame`` on (it may lie in what was already produced)."""

    def output(self, frames: int) -> np.ndarray:
        """What would reach the device for frames 0 .. ``frames`` (1D), everything played so far mixed in."""


def window_rms(x: np.ndarray, window: int) -> np.ndarray:
    """The RMS of every ``window``-sample window of ``x`` (float64 sums)."""
    c = np.concatenate([[0.0], np.cumsum(np.asarray(x, dtype=np.float64) ** 2)])
    n = min(window, x.size)
    return np.sqrt(np.maximum(c[n:] - c[:-n], 0.0) / window)


def check_mix_limiter(actuator_cls, *, limits: SafetyLimits = PROBE_LIMITS, rate_hz: float = PROBE_RATE_HZ,
                      seed: int = 0) -> list[str]:
    """What is wrong with ``actuator_cls``'s own limit on the sum of overlapping impacts (empty: nothing).

    Plays 400 bursts at full scale, 2.5 ms apart on average, some into what was already produced (late),
    through ``actuator_cls.mix_probe(limits, rate_hz)``.
    """
    probe_of = getattr(actuator_cls, "mix_probe", None)
    if probe_of is None:
        return [f"{actuator_cls.__name__} has no mix_probe(limits, rate_hz) to check its limiter with"]
    try:
        probe = probe_of(limits, rate_hz)
        rng = np.random.default_rng(seed)
        frames = int(PROBE_S * rate_hz)
        n = 400
        starts = np.sort(rng.integers(0, frames - frames // 10, n))
        for k, start in enumerate(starts):
            length = int(rng.integers(int(0.005 * rate_hz), int(0.05 * rate_hz)))
            burst = rng.uniform(-1.0, 1.0, length) * (1.0 if k % 2 else 3.0)
            probe.play(burst, int(start))
        out = np.asarray(probe.output(frames), dtype=np.float64).reshape(-1)
    except Exception as exc:  # a plugin's bug: reported, and the host keeps the limit
        return [f"{actuator_cls.__name__}.mix_probe failed: {type(exc).__name__}: {exc}"]
    problems = []
    if out.size < frames // 2:
        problems.append(f"its probe produced {out.size} frames of {frames}")
    if not np.all(np.isfinite(out)):
        problems.append("its output is not finite")
        return problems
    peak = float(np.max(np.abs(out))) if out.size else 0.0
    if peak > limits.peak * (1 + ROUNDING):
        problems.append(f"peak {peak:.4f} over the limit {limits.peak:g}")
    rms = window_rms(out, max(1, int(round(limits.rms_window_s * rate_hz))))
    over = int(np.count_nonzero(rms > limits.rms * (1 + ROUNDING)))
    if over:
        problems.append(f"{over} windows of {limits.rms_window_s * 1e3:g} ms over the RMS limit {limits.rms:g} "
                        f"(max {float(rms.max()):.4f})")
    if peak < 0.5 * limits.peak:
        problems.append(f"peak {peak:.4f}: the flood barely came through (is the probe mixing?)")
    return problems


_verdicts: dict[type, bool] = {}
_lock = threading.Lock()


def _cache_file() -> Path:
    return cache_root() / "conformance.json"


def fingerprint(cls) -> str | None:
    """A hash of the code a class's verdict depends on: its top-level package's sources (a single module: its
    own file) and the core limiter; None for a class with no source file (defined in a REPL, a notebook or
    ``python -c``), whose verdict is then not remembered."""
    top = sys.modules[cls.__module__.split(".")[0]]
    source = getattr(top, "__file__", None)
    if source is None:
        return None
    own = sorted(Path(source).parent.rglob("*.py")) if hasattr(top, "__path__") else [Path(source)]
    digest = hashlib.sha256(f"{cls.__module__}.{cls.__qualname__}".encode())
    for path in own + [Path(__file__), Path(__file__).with_name("safety.py")]:
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _remembered(cls, mark: str) -> list[str] | None:
    try:
        entry = json.loads(_cache_file().read_text()).get(f"{cls.__module__}.{cls.__qualname__}", {})
    except (OSError, ValueError, AttributeError):
        return None
    return entry.get("problems") if entry.get("fingerprint") == mark else None


def _remember(cls, mark: str, problems: list[str]) -> None:
    path = _cache_file()
    try:
        known = json.loads(path.read_text()) if path.exists() else {}
        known = known if isinstance(known, dict) else {}
        known[f"{cls.__module__}.{cls.__qualname__}"] = {"fingerprint": mark, "problems": problems}
        with atomic_path(path, make_parents=True) as tmp:
            tmp.write_text(json.dumps(known, indent=1))
    except (OSError, ValueError, HapticfxError):  # a read-only home: checked again next time
        pass


PLAYING = ("open", "play", "wait", "drain", "close")


def _changes_playing(cls: type, base: type) -> list[str]:
    """What a subclass of ``base`` (whose ``mix_probe`` it inherits) defines anew on the way impacts take: the
    playing methods, and any method ``base`` itself implements (not one it leaves abstract for subclasses)."""
    below = cls.__mro__[:cls.__mro__.index(base)]
    implemented = {name for name, value in vars(base).items()
                   if inspect.isfunction(value) and not getattr(value, "__isabstractmethod__", False)}
    return sorted({name for c in below for name, value in vars(c).items()
                   if inspect.isfunction(value) and (name in PLAYING or name in implemented)})


def limits_own_mix(actuator) -> bool:
    """Whether the host leaves the limit on the sum to ``actuator``: it declares ``limits_mix`` and its class
    passed :func:`check_mix_limiter` (checked once per version of its code). The host asks before it opens
    the actuator: a check that runs while a stream plays could hold the interpreter from its callbacks."""
    cls = type(actuator)
    if not getattr(cls, "limits_mix", False):
        return False
    # the class whose mix_probe it uses: actuators sharing one mixer (a vibro-transducer and a haptuator) are
    # checked once
    base = next((c for c in cls.__mro__ if "mix_probe" in vars(c)), cls)
    if base is not cls and (changed := _changes_playing(cls, base)):
        with _lock:
            if cls not in _verdicts:
                _verdicts[cls] = False
                log.warning("%s declares limits_mix and inherits the mix_probe of %s, but replaces %s: the probe "
                            "does not check that code, and the host limits the sum of its impacts itself",
                            cls.__name__, base.__name__, ", ".join(f"{name}()" for name in changed))
        return False
    cls = base
    with _lock:
        verdict = _verdicts.get(cls)
        if verdict is None:
            mark = fingerprint(cls)
            problems = _remembered(cls, mark) if mark is not None else None
            if problems is None:
                problems = [p for limits in PROBES for p in check_mix_limiter(cls, limits=limits)]
                if mark is not None:
                    _remember(cls, mark, problems)
            verdict = _verdicts[cls] = not problems
            if problems:
                log.warning("%s declares limits_mix but its limiter failed the conformance check (%s); the host "
                            "limits the sum of its impacts itself", cls.__name__, "; ".join(problems))
    return verdict
