"""The synchronous pipeline: effect -> model -> shaping -> safety limiter -> actuator.

``Pipeline.from_effect("effects/falling_brick.yaml")`` builds everything an
effect references (nothing else); ``impact(velocity=...)`` renders one impact,
plays it and returns what was sent.
"""

from __future__ import annotations

import dataclasses
import math
import os
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from .actuators.virtual import CsvActuator, MemoryActuator, WavActuator
from .atomic import user_path
from .effect import Effect, Plan, check_effect, effective_limits, load_effect
from .errors import DeviceError, EffectError, HapticfxError, PluginError, preview
from .interfaces import Actuator, ActuatorSpec, Impact, Model, SafetyLimits
from .params import BuildContext
from .registry import Registry
from .safety import LimiterReport, SafetyLimiter
from .conformance import limits_own_mix
from .sumbound import host_limiter
from .shaping import FADE_IN_S, FADE_OUT_S, ShapedAtoms, shape
from .signal import MAX_PROFILE_S, MAX_PROFILE_SAMPLES, Signal, valid_velocity


@dataclass(frozen=True)
class Delivery:
    """One rendered impact: the model's profile, what went to the actuator, the limiter's account, and what
    the model says a user should know about it (``notes``: an extrapolation, say)."""

    impact: Impact
    profile: Signal
    output: Signal
    limiter: LimiterReport
    notes: tuple[str, ...] = ()


def _limits(limits) -> dict:
    """The effective limits, and the actuator's hard limits the limiter also enforces, as a mapping."""
    out = {k: v for k, v in limits.__dict__.items() if k != "hard"}
    if limits.hard is not None and limits.hard != limits:
        out["hard"] = _limits(limits.hard)
    return out


def stand_in(device: str | int | None) -> tuple[type, str | None] | None:
    """The virtual actuator a ``--device`` value names (``wav:PATH``, ``csv:PATH``, ``memory``), if any."""
    if isinstance(device, str):
        if device == "memory":
            return MemoryActuator, None
        for cls in (WavActuator, CsvActuator):
            if device.startswith(f"{cls.name}:"):
                path = device[len(cls.name) + 1:]
                if not path:
                    raise DeviceError(f"--device {cls.name}:PATH needs a file name after '{cls.name}:'")
                return cls, path
    return None


def _located(build, effect: Effect, key: str):
    """``build()``; a domain error that does not name its file is raised again naming the effect and ``key``."""
    try:
        return build()
    except HapticfxError as exc:
        if exc.source:
            raise
        raise type(exc)(str(exc), source=effect.source, key=key) from None


def _check_length(effect: Effect, rate_hz: float, n_samples: int, *, waveform: bool) -> None:
    """Refuse a model's profile longer than :data:`~hapticfx.signal.MAX_PROFILE_S` or of more samples than
    :data:`~hapticfx.signal.MAX_PROFILE_SAMPLES`, before it is shaped: at the actuator's rate it only grows
    (600 s at 1 kHz played as 220 MiB at 48 kHz); and, for a waveform actuator, one shorter than the fades
    shaping puts at its two ends, which would play it (nearly) silent."""
    if n_samples > MAX_PROFILE_SAMPLES or n_samples > MAX_PROFILE_S * rate_hz:
        raise PluginError(f"model {effect.model.type!r} rendered a profile of {n_samples / rate_hz:.6g} s "
                          f"({n_samples} samples at {rate_hz:g} Hz); a profile is at most {MAX_PROFILE_S:g} s and "
                          f"{MAX_PROFILE_SAMPLES} samples", source=effect.source, key="model")
    fades_ms = (FADE_IN_S + FADE_OUT_S) * 1000.0
    if waveform and n_samples / rate_hz * 1000.0 < fades_ms:
        raise EffectError(f"model {effect.model.type!r} renders {n_samples / rate_hz * 1000.0:.6g} ms, shorter than "
                          f"the {fades_ms:g} ms the actuator's signal fades in and out over: it would play (nearly) "
                          f"silent; give it at least {fades_ms:g} ms (duration_ms)", source=effect.source, key="model")


MAX_ACTUATOR_RATE_HZ = 1e6


def _who(actuator: Actuator) -> str:
    return f"actuator {getattr(actuator, 'name', type(actuator).__name__)!r}"


def close_after_failure(actuators, error: BaseException) -> None:
    """Close ``actuators`` after ``error`` stopped them from opening. A close that raises too is noted on
    ``error``, which stays the one raised: it says why nothing plays."""
    for actuator in actuators:
        try:
            actuator.close()
        except Exception as exc:
            error.add_note(f"{_who(actuator)} also failed to close: {type(exc).__name__}: {exc}")


def check_spec(actuator: Actuator) -> None:
    """Refuse an actuator whose spec the core cannot trust: a rate, range, band or gain out of bounds, or hard
    limits that are not the core's own :class:`SafetyLimits` (a subclass may skip their checks)."""
    spec, who = actuator.spec, _who(actuator)

    def real(v, lo, hi) -> bool:
        return isinstance(v, (int, float)) and not isinstance(v, bool) and lo <= v <= hi

    if not isinstance(spec, ActuatorSpec):
        raise PluginError(f"{who}: spec is a {type(spec).__name__}, not an ActuatorSpec")
    band = spec.band_hz
    problems = [
        (not real(spec.rate_hz, 1.0, MAX_ACTUATOR_RATE_HZ), f"rate_hz {spec.rate_hz!r} (1 to {MAX_ACTUATOR_RATE_HZ:g})"),
        (not real(spec.volts_peak, 1e-9, 1e6), f"volts_peak {spec.volts_peak!r} (> 0)"),
        (not (isinstance(band, tuple) and len(band) == 2 and real(band[0], 0.0, math.inf)
              and real(band[1], band[0], math.inf) and band[1] > band[0]), f"band_hz {band!r} (low < high, >= 0)"),
        (not real(spec.default_gain, 0.0, 1.0), f"default_gain {spec.default_gain!r} (0 to 1)"),
        (type(spec.limits) is not SafetyLimits, f"limits of type {type(spec.limits).__name__} (SafetyLimits)"),
    ]
    bad = [what for wrong, what in problems if wrong]
    if bad:
        raise PluginError(f"{who}: its spec has {bad[0]}")


def check_rate(actuator: Actuator, rate_hz: float) -> None:
    """Refuse to play through ``actuator`` once its rate is no longer the one its limiter was built at (what it
    agreed in ``open()``): the limiter's windows, counted in samples, would be another length of time."""
    if actuator.spec.rate_hz != rate_hz:
        raise PluginError(f"{_who(actuator)} changed its rate from {rate_hz:g} Hz to {actuator.spec.rate_hz:g} Hz "
                          "after open(): an actuator agrees on its rate in open() and keeps it; nothing was played")


def open_actuator(actuator: Actuator, *, source: str | None = None, key: str | None = None) -> None:
    """``actuator.open()``, then its spec checked again: it may agree on another rate with the device, but
    its hard limits are what the limiters were built with, and they stay. What ``open()`` raises that is not a
    HapticfxError (a plugin's bug) is one DeviceError naming ``source``, ``key`` and the actuator."""
    limits = actuator.spec.limits
    try:
        actuator.open()
    except HapticfxError:
        raise
    except Exception as exc:
        raise DeviceError(f"{_who(actuator)} failed to open: {type(exc).__name__}: {exc}", source=source,
                          key=key) from exc
    try:
        check_spec(actuator)
        if actuator.spec.limits != limits:
            raise PluginError(f"{_who(actuator)} changed its hard limits when it opened; an actuator declares "
                              "them before")
    except PluginError as exc:
        close_after_failure([actuator], exc)
        raise


# What the refusal to replace a file a stand-in (``device="wav:PATH"``) names says to give.
STAND_IN_OVERWRITE = "--force (in Python: overwrite=True)"


def build_actuator(plan: Plan, effect: Effect, device: str | int | None, *, overwrite: bool = False) -> Actuator:
    """The (unopened) actuator of ``effect``'s section, or the virtual one ``device`` names in its place; that
    one replaces an existing file hapticfx did not write only with ``overwrite`` (a directory, never)."""
    virtual = stand_in(device)
    context = effect.context(device=None if virtual else device, registry=plan.registry)
    device_actuator: Actuator = _located(lambda: plan.actuator_cls(plan.actuator_params, context), effect, "actuator")
    _located(lambda: check_spec(device_actuator), effect, "actuator")
    if not virtual:
        return device_actuator
    cls, path = virtual
    params = cls.Params(path=str(user_path(path)), overwrite=overwrite) if path is not None else cls.Params()
    actuator = cls(params, BuildContext(source=effect.source), spec=device_actuator.spec)
    actuator.overwrite_option = STAND_IN_OVERWRITE
    return actuator


class Pipeline:
    """Renders and plays impacts for one effect. Thread-safe; use as a context manager."""

    def __init__(self, effect: Effect, *, device: str | int | None = None, registry: Registry | None = None,
                 overwrite: bool = False):
        self.effect = effect
        self.plan: Plan = check_effect(effect, registry=registry)
        context = effect.context(device=None if stand_in(device) else device, registry=self.plan.registry)
        self.model: Model = _located(lambda: self.plan.model_cls(self.plan.model_params, context), effect, "model")
        self.actuator: Actuator = build_actuator(self.plan, effect, device, overwrite=overwrite)
        spec = self.actuator.spec
        self.limits = effective_limits(spec.limits.labelled(spec.limits.source or f"actuator {effect.actuator.type}"),
                                       effect)
        self.actuator.limits = self.limits
        self.limiter = SafetyLimiter(self.limits, spec.rate_hz)
        self.gain = effect.actuator.gain if effect.actuator.gain is not None else spec.default_gain
        units = getattr(self.model, "units", "g")
        self.scale = 1.0 / effect.actuator.full_scale_g if units == "g" else 1.0
        self.atoms = ShapedAtoms(gain=self.gain, scale=self.scale)  # the model's atoms, shaped for the actuator
        self.sum_limit = None  # see adopt()
        self._lock = threading.Lock()
        self._opened = False
        self._t0 = time.monotonic()
        self._first_s: float | None = None  # the first impact's time, 0 in a file

    @classmethod
    def from_effect(cls, effect: str | Path | Effect, *, device: str | int | None = None,
                    registry: Registry | None = None, overwrite: bool = False) -> "Pipeline":
        """Build from an effect file path (or a loaded :class:`Effect`)."""
        if not isinstance(effect, Effect):
            if not isinstance(effect, (str, os.PathLike)):
                raise EffectError(f"expected an effect file's path or an Effect, got {type(effect).__name__}")
            effect = load_effect(effect)
        return cls(effect, device=device, registry=registry, overwrite=overwrite)

    def open(self) -> "Pipeline":
        if not self._opened:
            limits_own_mix(self.actuator)  # the conformance verdict before the device plays (see adopt)
            open_actuator(self.actuator, source=self.effect.source, key="actuator")
            try:
                self.adopt(self.actuator)
            except BaseException as exc:  # the model's atoms, say: nothing is left open
                close_after_failure([self.actuator], exc)
                raise
            self._opened = True
        return self

    def adopt(self, actuator: Actuator) -> None:
        """Play through ``actuator`` as it is once open (an engine's shared one): the limiter runs at the rate it
        reports now (a device may have agreed to another in ``open()``), and the atoms are shaped for it."""
        self.actuator = actuator
        if self.limiter.rate_hz != actuator.spec.rate_hz:
            self.limiter = SafetyLimiter(self.limits, actuator.spec.rate_hz)
        # an actuator that sums overlapping impacts without a limiter the host trusts: a bound on their sum
        self.sum_limit = host_limiter(actuator, self.limits, summed=False)
        self.warm()

    def warm(self) -> None:
        """Shape the model's atoms for the actuator as it is now (opened: at its agreed rate), so that the
        first impacts cost what every later one does."""
        atoms = self.model.atoms()
        if atoms is not None:
            _check_length(self.effect, atoms.rate_hz, atoms.n_samples, waveform=self.actuator.spec.waveform)
            self.atoms.warm(atoms, self.actuator.spec)

    def close(self) -> None:
        if self._opened:
            self._opened = False
            self.actuator.close()

    def __enter__(self):
        return self.open()

    def __exit__(self, *exc):
        self.close()
        return False

    def _impact(self, velocity, object) -> Impact:
        v = self.effect.velocity_mps if velocity is None else valid_velocity(velocity)
        if object is not None and (not isinstance(object, str) or not object.strip()):  # "" fell back to the effect's
            raise EffectError(f"object {preview(object)}: expected an object id (none: the effect's "
                              f"{self.effect.object_id!r})", source=self.effect.source)
        return Impact(object or self.effect.object_id, v, time.monotonic() - self._t0)

    def render(self, impact: Impact | None = None, *, velocity: float | None = None, object: str | None = None) -> Delivery:
        """Model, shaping and safety limiter, without playing."""
        impact = impact or self._impact(velocity, object)
        check_rate(self.actuator, self.limiter.rate_hz)
        terms = _located(lambda: self.model.terms(impact), self.effect, "model")  # a plugin's error names the file
        if terms is None:
            profile = _located(lambda: self.model.render(impact), self.effect, "model")
            if not isinstance(profile, Signal):
                raise PluginError(f"model {self.effect.model.type!r} rendered a {type(profile).__name__}, not a "
                                  "Signal", source=self.effect.source, key="model")
            _check_length(self.effect, profile.rate_hz, profile.n_samples, waveform=self.actuator.spec.waveform)
            shaped = shape(profile, self.actuator.spec, gain=self.gain, scale=self.scale)
        else:
            _check_length(self.effect, terms.rate_hz, terms.n_samples, waveform=self.actuator.spec.waveform)
            profile = terms.profile()
            shaped = self.atoms.shape(terms, self.actuator.spec)
        with self._lock:
            out = self.limiter.process(shaped.samples, at_s=impact.time_s)
            report = self.limiter.report()
        # a Signal(): what an actuator plays and the caller's record are one array no plugin can write (a copy,
        # about 5 us for a render's 24,000 samples, of the 340 us or more the render takes)
        return Delivery(impact, profile, Signal(out, shaped.rate_hz), report, tuple(self.model.notes(impact)))

    def impact(self, *, velocity: float | None = None, object: str | None = None) -> Delivery:
        """Render one impact and play it; returns what was sent to the actuator."""
        if not self._opened:
            raise DeviceError("the pipeline is not open: use `with pipeline:` or call open() first")
        delivery = self.render(velocity=velocity, object=object)
        if self.sum_limit is not None:
            out = delivery.output
            bounded = Signal(self.sum_limit.process(out.samples, at_s=delivery.impact.time_s), out.rate_hz)
            delivery = dataclasses.replace(delivery, output=bounded)
        if self.actuator.takes_time:  # a file: the impact at its time after the first impact
            with self._lock:
                if self._first_s is None:
                    self._first_s = delivery.impact.time_s
            self.actuator.play(delivery.output, at_s=delivery.impact.time_s - self._first_s)
        else:
            self.actuator.play(delivery.output)
        return delivery

    def describe(self) -> dict:
        """What this pipeline loaded, for ``hapticfx info``."""
        m, a = self.plan.model_registration(), self.plan.actuator_registration()
        spec = self.actuator.spec
        return {
            "effect": self.effect.name, "file": self.effect.source, "object": self.effect.object_id,
            "velocity_mps": self.effect.velocity_mps,
            "model": {**self.model.describe(), "plugin": f"{m.plugin} ({m.distribution} {m.version})"},
            "actuator": {
                "type": self.effect.actuator.type, "output": self.actuator.describe(),
                "plugin": f"{a.plugin} ({a.distribution} {a.version})", "rate_hz": spec.rate_hz,
                "band_hz": list(spec.band_hz), "volts_peak": spec.volts_peak, "waveform": spec.waveform,
                "gain": self.gain, "limits": _limits(self.limits),
            },
        }


__all__ = ["Delivery", "Pipeline", "EffectError", "build_actuator"]
