"""A file output's own timeline: impacts placed at their times, summed, limited in the file's time, bounded.

A session written to a file must hold what a device would have played: each
impact where it happened, overlapping impacts summed, and the safety limits
(peak, RMS over its window) true of the file's samples. The limiter therefore
runs here, on the sum, in file time; the gaps between impacts are silence in
the file, as they are in the limiter's windows.

Impacts come in about the order of their times. Everything older than
``hold_s`` before the latest impact is final: it is limited and written, so
memory stays bounded however long the session; an impact placed before what
is already written (more than ``hold_s`` out of order) starts at the first
frame not yet written and is counted (``late``). The file holds at most
``max_frames``: what would lie beyond is not written, counted (``cut``), and
said once in the log.
"""

from __future__ import annotations

import logging
from typing import Callable

import numpy as np

from ..interfaces import SafetyLimits
from ..safety import SafetyLimiter

log = logging.getLogger(__name__)

BLOCK = 512  # frames the limiter takes at a time: one gain per block where the RMS limit acts
SILENCE_CHUNK_S = 1.0


class Timeline:
    """Places impacts on one file's timeline and writes it, limited, through ``open_writer(channels)``.

    ``open_writer`` is called at the first impact and returns a writer with
    ``write(block)``, ``close()``, ``abort()``, ``frame_bytes`` and
    ``max_frames`` (:class:`~hapticfx.actuators.files.WavWriter`,
    :class:`~hapticfx.actuators.files.CsvWriter`). ``max_bytes`` bounds the
    file's size. Not thread-safe: the actuator that owns it holds a lock.
    """

    def __init__(self, open_writer: Callable[[int], object], rate_hz: float, limits: SafetyLimits, *,
                 max_bytes: int, hold_s: float = 2.0, name: str = "file"):
        self.open_writer = open_writer
        self.rate_hz = float(rate_hz)
        self.limits = limits
        self.max_bytes = int(max_bytes)
        self.hold = int(round(hold_s * self.rate_hz))
        self.name = name
        self.writer = None
        self.limiter: SafetyLimiter | None = None
        self.max_frames = 0
        self.written = 0  # frames limited and written
        self.end = 0  # the frame after the last impact's last sample: where an impact with no time goes
        self.late = 0
        self.cut = 0
        self._buf = np.zeros((1, 0))  # frames written .. written + buf width, mixed, not yet limited

    def place(self, samples: np.ndarray, at_s: float | None = None) -> None:
        """Add ``samples`` (channels, N) at ``at_s`` seconds into the file (None: after the last impact)."""
        block = np.atleast_2d(np.asarray(samples, dtype=np.float64))
        if self.writer is None:
            self._open(block.shape[0])
        elif block.shape[0] != self._buf.shape[0]:
            from ..errors import DeviceError

            raise DeviceError(f"{self.name}: {block.shape[0]} channels, the file has {self._buf.shape[0]}")
        start = self.end if at_s is None else int(round(float(at_s) * self.rate_hz))
        if start < self.written:
            self.late += 1
            start = self.written
        room = self.max_frames - start
        if room < block.shape[1]:
            if not self.cut:
                mib = self.max_bytes / 2**20
                log.warning("%s: the file reached its bound (%.3g MiB, %.1f s at %g Hz); impacts after %.1f s are "
                            "not written", self.name, mib, self.max_frames / self.rate_hz, self.rate_hz,
                            self.max_frames / self.rate_hz)
            self.cut += 1
            if room <= 0:  # wholly past the bound: not written, and the file is not padded out to it for it
                return
            block = block[:, :room]
        self._flush(start - self.hold)
        end = start + block.shape[1]
        if block.shape[1]:
            need = end - self.written - self._buf.shape[1]
            if need > 0:
                self._buf = np.concatenate([self._buf, np.zeros((self._buf.shape[0], need))], axis=1)
            self._buf[:, start - self.written:end - self.written] += block
        self.end = max(self.end, end)

    def close(self):
        """Write what is left and finish the file; returns its path, or None when nothing was placed."""
        if self.writer is None:
            return None
        self._flush(self.end)
        return self.writer.close()

    def abort(self) -> None:
        if self.writer is not None:
            self.writer.abort()

    def _open(self, channels: int) -> None:
        self.writer = self.open_writer(channels)
        self.limiter = SafetyLimiter(self.limits, self.rate_hz)
        frame_bytes = self.writer.frame_bytes
        self.max_frames = max(0, min(self.writer.max_frames, (self.max_bytes - self.writer.bytes) // frame_bytes))
        self._buf = np.zeros((channels, 0))

    def _flush(self, to: int) -> None:
        """Limit and write every frame before ``to`` (no later than the bound)."""
        to = min(to, self.max_frames)
        mixed = min(to, self.written + self._buf.shape[1])
        if mixed > self.written:  # what impacts were mixed into
            n = mixed - self.written
            chunk, self._buf = self._buf[:, :n], self._buf[:, n:]
            self.writer.write(self._limited(chunk, self.written))
            self.written = mixed
        if self.written < to:  # silence after the last impact
            silence = np.zeros((self._buf.shape[0], int(SILENCE_CHUNK_S * self.rate_hz) or 1))
            while self.written < to:
                n = min(silence.shape[1], to - self.written)
                self.writer.write(silence[:, :n])
                self.written += n

    def _limited(self, x: np.ndarray, first: int) -> np.ndarray:
        """``x`` (frames ``first`` on) through the limiter: each run of blocks that holds sound, at its time in
        the file; silent blocks are left out, and the limiter counts them as the silence they are (``at_s``)."""
        out = np.zeros_like(x)
        sounding = np.flatnonzero(np.any(x != 0.0, axis=0)) // BLOCK  # ascending
        if not sounding.size:
            return out
        blocks = sounding[np.concatenate(([True], sounding[1:] != sounding[:-1]))]  # np.unique would import numpy.ma
        for run in np.split(blocks, np.flatnonzero(np.diff(blocks) > 1) + 1):
            a, b = run[0] * BLOCK, min((run[-1] + 1) * BLOCK, x.shape[1])
            if x.shape[0] == 1:  # one pass over the run where the RMS limit does not act
                out[0, a:b] = self.limiter.process_blocks(x[0, a:b], block=BLOCK, at_s=(first + a) / self.rate_hz)[0]
                continue
            for k in range(a, b, BLOCK):
                out[:, k:min(k + BLOCK, b)] = self.limiter.process(x[:, k:min(k + BLOCK, b)],
                                                                   at_s=(first + k) / self.rate_hz)
        return out


class _Kept:
    """A writer that keeps what it is given (for :class:`TimelineProbe`)."""

    frame_bytes, bytes, max_frames = 8, 0, 1 << 40

    def __init__(self):
        self.blocks: list[np.ndarray] = []

    def write(self, block: np.ndarray) -> None:
        self.blocks.append(np.array(block))

    def close(self):
        return None


class TimelineProbe:
    """A :class:`Timeline` on one channel, kept in memory: what a file output's mixer and limiter make of
    impacts placed at given frames, for the host's conformance check (:mod:`hapticfx.conformance`)."""

    def __init__(self, limits: SafetyLimits, rate_hz: float):
        self.kept = _Kept()
        self.rate_hz = float(rate_hz)
        self.timeline = Timeline(lambda channels: self.kept, rate_hz, limits, max_bytes=1 << 40)

    def play(self, samples: np.ndarray, at_frame: int) -> None:
        self.timeline.place(np.asarray(samples)[None, :], at_frame / self.rate_hz)

    def output(self, frames: int) -> np.ndarray:
        self.timeline.close()
        return np.concatenate([b[0] for b in self.kept.blocks])[:frames] if self.kept.blocks else np.zeros(0)
