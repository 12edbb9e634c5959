"""Checks for plugin authors, to run in a plugin's own tests (``pytest``).

``assert_mix_limiter(MyActuator)``: an actuator that declares ``limits_mix = True`` sums overlapping
impacts and limits the sum itself; the host believes it only if this check passes (docs/plugin-guide.md).
"""

from __future__ import annotations

from .conformance import PROBE_RATE_HZ, PROBES, check_mix_limiter
from .interfaces import SafetyLimits


def assert_mix_limiter(actuator_cls, *, limits: SafetyLimits | None = None, rate_hz: float = PROBE_RATE_HZ,
                       seeds=(0, 1, 2)) -> None:
    """AssertionError naming what failed unless ``actuator_cls.mix_probe`` keeps a flood of overlapping
    impacts within ``limits`` (every sample, every RMS window), for each seed; by default within each of
    the limits the host checks with."""
    for probe_limits in (PROBES if limits is None else (limits,)):
        for seed in seeds:
            problems = check_mix_limiter(actuator_cls, limits=probe_limits, rate_hz=rate_hz, seed=seed)
            assert not problems, f"{actuator_cls.__name__} (seed {seed}): " + "; ".join(problems)


__all__ = ["assert_mix_limiter", "check_mix_limiter"]
