"""The four interfaces of hapticfx: Reducer, Interpolator, Model, Actuator.

Plugins implement these and register factories for them through the hooks in
:mod:`hapticfx.hookspecs`. Arrays follow one convention: float64, time on the
last axis, accelerations in g, profiles at the bank's rate (1 kHz by default).
"""

from __future__ import annotations

import abc
import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar, Hashable, NamedTuple

import numpy as np

from .errors import SignalError, preview
from .signal import Signal, valid_number, valid_rate, valid_velocity

if TYPE_CHECKING:
    from .data.bank import ProfileBank
    from .data.dataset import Dataset


MAX_POINT_M = 10.0  # a contact point lies on the head: farther from its centre than this is not one


def valid_vector(value, *, name: str, unit: bool = False) -> tuple[float, float, float] | None:
    """``value`` as three finite floats (None stays None); ``unit``: scaled to length 1 (a zero vector is refused),
    else a point of the head frame, each coordinate within :data:`MAX_POINT_M` metres of its centre."""
    if value is None:
        return None
    try:
        items = list(value) if not isinstance(value, (str, bytes, np.ndarray)) else None
    except TypeError:
        items = None
    if items is not None and any(isinstance(v, (bool, np.bool_, str, bytes)) for v in items):  # "1" and True as numbers
        raise SignalError(f"{name} must be three numbers, got {preview(value)}")
    try:
        x = np.asarray(value if items is None else items, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise SignalError(f"{name} must be three numbers, got {preview(value)}") from None
    if x.shape != (3,) or not np.all(np.isfinite(x)):
        raise SignalError(f"{name} must be three finite numbers, got {preview(value)}")
    if not unit and np.max(np.abs(x)) > MAX_POINT_M:
        raise SignalError(f"{name} must lie within {MAX_POINT_M:g} m of the head's centre (head frame, metres), "
                          f"got {preview(value)}")
    if unit:
        big = float(np.max(np.abs(x)))  # scaled first: the norm of (1.7e308, ...) would overflow to inf
        scaled = x / big if big > 0.0 else x
        if big * float(np.linalg.norm(scaled)) < 1e-9:
            raise SignalError(f"{name} must not be zero")
        x = scaled / float(np.linalg.norm(scaled))
    return (float(x[0]), float(x[1]), float(x[2]))


@dataclass(frozen=True)
class Impact:
    """One collision event: which object, how fast, when, on which channel, and where on the head.

    ``time_s`` is the engine's own clock (the safety limiter runs on it);
    ``at`` is the simulation time the sender gave (seconds, None when not
    given: OSC's ``at`` argument or a bundle's timetag); ``point`` and
    ``normal`` are where on the head it landed, in the head frame of
    docs/protocol.md (metres from the head's centre; the normal is made unit).
    """

    object: str
    velocity: float
    time_s: float = 0.0
    channel: int | None = None
    at: float | None = None
    point: tuple[float, float, float] | None = None
    normal: tuple[float, float, float] | None = None

    def __post_init__(self):
        object.__setattr__(self, "velocity", valid_velocity(self.velocity))
        object.__setattr__(self, "time_s", valid_number(self.time_s, name="time_s"))
        if self.at is not None:
            object.__setattr__(self, "at", valid_number(self.at, name="at"))
        object.__setattr__(self, "point", valid_vector(self.point, name="point"))
        object.__setattr__(self, "normal", valid_vector(self.normal, name="normal", unit=True))


class Profile(NamedTuple):
    """A recorded 1D impact profile and the velocity it was recorded at."""

    velocity: float
    samples: np.ndarray


class Term(NamedTuple):
    """One fixed atom of a profile and its weight; ``key`` names these samples for as long as their owner lives."""

    key: Hashable
    weight: float
    samples: np.ndarray


def weighted_sum(pairs) -> np.ndarray:
    """``sum(weight * samples)`` over ``(weight, samples)`` pairs (at least one), in a new array."""
    (weight, samples), *rest = pairs
    out = weight * samples
    for weight, samples in rest:
        out += weight * samples
    return out


@dataclass(frozen=True)
class Terms:
    """A profile as a weighted sum of fixed atoms at ``rate_hz``: ``sum(t.weight * t.samples)``.

    Shaping is linear, so a pipeline shapes each atom once (under its key) and
    renders an impact by summing the shaped atoms with these weights: no filter
    or resampler runs per impact. Every atom is 1D and of one length.
    """

    rate_hz: float
    items: tuple[Term, ...]

    def __post_init__(self):
        object.__setattr__(self, "rate_hz", valid_rate(self.rate_hz, name="Terms.rate_hz"))
        if not self.items:
            raise SignalError("a profile needs at least one term")
        shape = self.items[0].samples.shape
        for t in self.items:
            if t.samples.ndim != 1 or t.samples.shape != shape:
                raise SignalError(f"the terms of one profile are 1D and of one length; got {shape} and {t.samples.shape}")
            valid_number(t.weight, name=f"weight of term {t.key!r}")

    @property
    def n_samples(self) -> int:
        return int(self.items[0].samples.shape[0])

    def profile(self) -> Signal:
        """The profile itself: the weighted sum of the atoms."""
        return Signal(weighted_sum((t.weight, t.samples) for t in self.items), self.rate_hz)


class Blend(NamedTuple):
    """A profile between two neighbours: ``lower * lower.samples + upper * upper.samples`` plus ``extra`` atoms."""

    lower: float
    upper: float
    extra: tuple[Term, ...] = ()

    def of(self, lower: Profile, upper: Profile) -> np.ndarray:
        """The profile's samples."""
        return weighted_sum(((self.lower, lower.samples), (self.upper, upper.samples),
                             *((t.weight, t.samples) for t in self.extra)))


class Reducer(abc.ABC):
    """Reduces 3-axis accelerations ``(..., N, 3)`` to one axis ``(..., N)``."""

    name: ClassVar[str]

    @abc.abstractmethod
    def reduce(self, xyz: np.ndarray) -> np.ndarray:
        """Return the 1D signal for each 3-axis recording in ``xyz``."""


@dataclass(frozen=True)
class TrainingData:
    """What an interpolator learns from: one bank per object and, where recorded, every drop.

    ``banks`` maps an object id to its bank, with any held-out velocity already
    removed. ``drops`` maps an object id to ``(velocities (V,), drops (V, D, N))``:
    every recorded drop, reduced like the bank (empty for a dataset without raw
    recordings). ``targets``, when given, restricts which recorded velocities of each
    object are training targets. See :func:`hapticfx.data.training.training_data`.
    """

    banks: dict[str, "ProfileBank"]
    reducer: str
    dataset: str = "<banks>"
    drops: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    targets: dict[str, list[float]] | None = None


class Interpolator(abc.ABC):
    """Predicts the profile at ``velocity`` from its two recorded neighbours."""

    name: ClassVar[str]

    def fit(self, data: TrainingData, **options) -> dict:
        """Learn from ``data``; returns a summary (losses, epochs, choices). Default: nothing to learn.

        Beside a learned row's own options, the benchmark passes ``label`` (what to call this fit) and
        ``progress=True``: long work shows its progress on standard error under that label.
        """
        return {}

    def prepare(self, bank: "ProfileBank", *, dataset: "Dataset | None" = None, base_dir: Path | None = None) -> None:
        """Called once per bank when an effect loads, before any ``interpolate``: load weights, fill caches.

        ``base_dir`` is the effect file's directory, for relative paths in the options.
        """

    @abc.abstractmethod
    def interpolate(self, lower: Profile, upper: Profile, velocity: float) -> np.ndarray:
        """Return the profile at ``velocity`` (``lower.velocity <= velocity <= upper.velocity``)."""

    def blend(self, lower: Profile, upper: Profile, velocity: float) -> Blend | None:
        """``interpolate``'s answer as a :class:`Blend` of fixed atoms, or None (the default) when it is not one."""
        return None

    def atoms(self, bank: "ProfileBank") -> tuple[Term, ...]:
        """Every extra atom ``blend`` can name between neighbours of ``bank`` (shaped ahead); default none."""
        return ()

    def save(self, path: Path) -> None:
        """Write learnt state to ``path``. Default: nothing to save."""

    def describe(self) -> dict:
        """Where the profiles come from (for ``hapticfx info``). Default: nothing to add."""
        return {}

    def load(self, path: Path) -> None:
        """Read learnt state from ``path``. Default: nothing to load."""


class Model(abc.ABC):
    """Renders what one impact feels like: a 1D acceleration signal in g."""

    name: ClassVar[str]

    @abc.abstractmethod
    def render(self, impact: Impact) -> Signal:
        """Return the impact profile for ``impact``: at most :data:`~hapticfx.signal.MAX_PROFILE_S` long, and of
        at most :data:`~hapticfx.signal.MAX_PROFILE_SAMPLES` samples (the pipeline refuses a longer one)."""

    def terms(self, impact: Impact) -> Terms | None:
        """``render``'s profile as :class:`Terms` of fixed atoms, or None (the default) when it is not such a sum."""
        return None

    def atoms(self) -> Terms | None:
        """Every atom ``terms`` can name for the effect's own object (weights unused), shaped when the effect
        opens rather than at its first impact; None (the default): none known ahead."""
        return None

    def describe(self) -> dict:
        """What this model loaded (for ``hapticfx info``)."""
        return {"model": self.name}

    def notes(self, impact: Impact) -> list[str]:
        """What a user should know about how this impact was rendered (an extrapolation, say); none by default."""
        return []


_LIMIT_RANGES = {  # field: (smallest, largest, may be None); every limit is stricter when smaller
    "peak": (0.0, 1.0, False), "rms": (0.0, 1.0, False), "rms_window_s": (1e-4, 60.0, False),
    "max_on_s": (0.0, 3600.0, True), "max_duty": (0.0, 1.0, True), "duty_window_s": (1e-3, 3600.0, False),
}


@dataclass(frozen=True)
class SafetyLimits:
    """Hard output limits for one actuator, in units of its full range.

    ``peak`` and ``rms`` are fractions of full scale; ``rms_window_s`` is the
    sliding window for the RMS limit. ``max_on_s`` and ``max_duty`` apply to
    actuators that take pulses rather than waveforms (a solenoid). Every value is
    checked when the limits are made (a plugin cannot declare ``peak=5`` or NaN).

    :meth:`lowered` makes stricter limits for an effect and keeps the actuator's own
    in ``hard``: the limiter enforces both, so no combination of overrides can let
    the output exceed the hard limits measured over the hard windows.
    """

    peak: float = 1.0
    rms: float = 0.7
    rms_window_s: float = 0.05
    max_on_s: float | None = None
    max_duty: float | None = None
    duty_window_s: float = 10.0
    hard: "SafetyLimits | None" = field(default=None, repr=False, compare=False)
    # who set these limits, for the log and stats() ("actuator vibro-transducer", "effect falling_brick.yaml")
    source: str = field(default="", repr=False, compare=False)
    # more limits that hold on the same output (the other effects and actuators sharing it): see strictest()
    also: tuple["SafetyLimits", ...] = field(default=(), repr=False, compare=False)

    def __post_init__(self):
        import math

        from .errors import PluginError

        for name, (lo, hi, optional) in _LIMIT_RANGES.items():
            value = getattr(self, name)
            if value is None and optional:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or not lo <= value <= hi:
                raise PluginError(f"invalid safety limits: {name} must be a number in [{lo:g}, {hi:g}]"
                                  f"{' or None' if optional else ''}, got {value!r}")

    def lowered(self, *, source: str = "", **changes) -> "SafetyLimits":
        """Stricter limits: each change may only lower a value (a window may only shrink).

        ``duty_window_s`` belongs to the actuator and cannot change. The result keeps
        the hard limits (``hard``), which the limiter enforces as well.
        """
        from .errors import EffectError

        values = {}
        if not any(v is not None for v in changes.values()):
            return self
        for key, new in changes.items():
            if new is None:
                continue
            if key not in _LIMIT_RANGES or key == "duty_window_s":
                allowed = [k for k in _LIMIT_RANGES if k != "duty_window_s"]
                raise EffectError(f"unknown safety limit {key!r}; an effect may lower: {', '.join(allowed)}")
            old = getattr(self, key)
            if old is not None and new > old:
                what = "lengthen the actuator's RMS window" if key == "rms_window_s" else "raise the actuator's hard limit"
                raise EffectError(f"{key} {new} would {what} {old}; an effect can only make limits stricter")
            values[key] = new
        own = {k: getattr(self, k) for k in _LIMIT_RANGES}
        return SafetyLimits(**{**own, **values}, hard=self.hard or self, source=source)

    def labelled(self, source: str) -> "SafetyLimits":
        """The same limits, saying who set them."""
        return dataclasses.replace(self, source=source)

    def constraints(self) -> list["SafetyLimits"]:
        """Every limit that holds: these, the hard ones they were lowered from, and those ``also`` holding."""
        out = [self] if self.hard is None else [self, self.hard]
        for more in self.also:
            out += [c for c in more.constraints() if not any(c is o for o in out)]
        return out

    def strictest(self, *others: "SafetyLimits") -> "SafetyLimits":
        """Limits that hold all of these at once (several effects or actuators on one physical output): the
        limiter enforces every one of them, each over its own window, so the strictest wins everywhere."""
        held, more = self.constraints(), []
        for other in others:
            if other is None:
                continue
            # ``==`` compares the values a constraint enforces, not the ``hard`` or ``also`` it carries: another
            # is redundant only where each of its own constraints is one already held
            extra = [c for c in other.constraints() if c not in held]
            if extra:
                more.append(other)
                held += extra
        return dataclasses.replace(self, also=self.also + tuple(more)) if more else self

    def describe(self) -> dict:
        """Each value with who set it (the strictest that holds), for ``stats()`` and the log."""
        every = self.constraints()
        out = {}
        for key in ("peak", "rms", "max_on_s", "max_duty"):
            held = [c for c in every if getattr(c, key) is not None]
            if held:
                c = min(held, key=lambda c: (getattr(c, key), c.hard is not None))  # a tie: the actuator's own
                value = {"value": getattr(c, key), "set_by": c.source or "unnamed"}
                if key == "rms":
                    value["window_s"] = c.rms_window_s
                out[key] = value
        return out


@dataclass(frozen=True)
class ActuatorSpec:
    """What an actuator can do: rate, output range, band, waveform support, hard limits."""

    rate_hz: float
    volts_peak: float
    band_hz: tuple[float, float]
    waveform: bool = True
    limits: SafetyLimits = field(default_factory=SafetyLimits)
    default_gain: float = 1.0


class Actuator(abc.ABC):
    """An output device. Takes signals normalised to [-1, 1] of its full range.

    Use as a context manager (``with actuator: actuator.play(signal)``).
    ``play`` receives the signal after shaping and the safety limiter, at
    ``spec.rate_hz``.
    """

    name: ClassVar[str]
    spec: ActuatorSpec
    # True when the actuator sums overlapping impacts itself and runs a SafetyLimiter with its ``limits`` on the
    # sum it outputs (a sound card's mixing stream). The host believes it only if the class's ``mix_probe``
    # passes hapticfx.conformance.check_mix_limiter; else it bounds the sum itself (hapticfx.sumbound).
    limits_mix: ClassVar[bool] = False
    # True when ``play`` takes ``received=`` (the ``time.perf_counter()`` at which the impact was received) and
    # counts the impact's latency from then, so that the time spent rendering it does not add to it (a sound
    # card's queue at the server): an engine then passes it.
    takes_received: ClassVar[bool] = False
    # True when ``play`` takes ``at_s=``, the impact's time in seconds since the session's first impact (the
    # sender's time when it gave one, else its arrival), and places the impact there (a file): an engine then
    # passes it.
    takes_time: ClassVar[bool] = False

    def open(self) -> None:
        """Acquire the device. Raises :class:`hapticfx.errors.DeviceError` if it is absent.

        ``spec`` may change here (the rate the device agreed to): the host shapes and limits at the rate
        ``spec`` reports after ``open()``."""

    def output_key(self):
        """The physical output (device and channel, as they resolve on this machine) this actuator plays
        into, or None (the default) for an output only this object writes to. Scene entries and effects whose
        actuators give one key share one output and one limiter; may be called before ``open()``."""
        return None

    @abc.abstractmethod
    def play(self, signal: Signal) -> None:
        """Output one (already limited) signal."""

    def wait(self, timeout: float | None = None) -> None:
        """Block until everything played so far has reached the device. Default: play is synchronous."""

    def close(self) -> None:
        """Release the device."""

    def losses(self) -> dict[str, int]:
        """Impacts this device took but could not play in full, by reason (none by default)."""
        return {}

    def describe(self) -> str:
        """Where the output goes, in a few words."""
        return self.name

    def __enter__(self):
        self.open()
        return self

    def __exit__(self, *exc):
        self.close()
        return False
