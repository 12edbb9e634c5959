"""An ADXL335-like 3-axis accelerometer read by a 14-bit USB DAQ.

The chain, per axis, on a fine time grid: gravity added (the sensor reads
specific force, +1 g up at rest) -> saturation of the sensing element at
``range_g`` -> first-order output filter at the axis bandwidth -> white noise
of the datasheet density over the filter's noise bandwidth -> zero-g bias ->
sampling by the DAQ at ``rate_hz`` (no anti-alias filter, as on an NI USB-6009)
-> quantisation to ``bits`` over ``+-daq_range_v`` at ``sensitivity_v_per_g``.
Defaults follow the ADXL335 datasheet (typical values, 3 V supply) and the
USB-6009 differential input.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from ..signal import valid_number, valid_signal

G = 9.80665


@dataclass(frozen=True)
class Accelerometer:
    """ADXL335-like sensor and DAQ settings (see the module docstring)."""

    range_g: float = 3.6
    bandwidth_hz: tuple[float, float, float] = (1600.0, 1600.0, 550.0)
    noise_ug_per_rthz: tuple[float, float, float] = (150.0, 150.0, 300.0)
    bias_g: tuple[float, float, float] = (0.012, -0.008, 0.02)
    sensitivity_v_per_g: float = 0.300
    daq_range_v: float = 5.0
    bits: int = 14
    rate_hz: float = 1000.0

    def to_dict(self) -> dict:
        d = asdict(self)
        d["model"] = "ADXL335-like (simulated) behind a 14-bit USB DAQ"
        return d

    @property
    def lsb_g(self) -> float:
        return 2 * self.daq_range_v / 2**self.bits / self.sensitivity_v_per_g

    def read(self, accel_mps2, fine_rate_hz: float, *, start_s: float, n_samples: int,
             rng: np.random.Generator, gravity_axis: np.ndarray) -> np.ndarray:
        """Sample ``n_samples`` readings (g) from fine-grid acceleration ``(N, 3)`` in m/s^2.

        The fine grid starts at time 0 at rest; DAQ sample ``n`` is taken at
        ``n / rate_hz - start_s`` (before 0: the helmet at rest). ``gravity_axis``
        is the unit vector of "up" in the sensor's axes.
        """
        from scipy.signal import lfilter

        acc = valid_signal(accel_mps2, name="acceleration", ndim=2)
        fine = valid_number(fine_rate_hz, name="fine_rate_hz", minimum=self.rate_hz)
        g = acc / G + np.asarray(gravity_axis, dtype=np.float64)
        g = np.clip(g, -self.range_g, self.range_g)
        out = np.empty_like(g)
        for axis in range(3):
            p = math.exp(-2 * math.pi * self.bandwidth_hz[axis] / fine)
            zi = [p * g[0, axis]]  # start settled at the resting reading
            out[:, axis], _ = lfilter([1 - p], [1, -p], g[:, axis], zi=zi)
        t = np.arange(n_samples) / self.rate_hz - start_s
        idx = np.clip(np.round(t * fine).astype(np.int64), 0, len(out) - 1)
        samples = out[idx]
        noise_rms = np.asarray(self.noise_ug_per_rthz) * 1e-6 * np.sqrt(np.asarray(self.bandwidth_hz) * math.pi / 2)
        samples = samples + rng.standard_normal(samples.shape) * noise_rms + np.asarray(self.bias_g)
        lsb = self.lsb_g
        full = self.daq_range_v / self.sensitivity_v_per_g
        return np.clip(np.round(samples / lsb) * lsb, -full, full)
