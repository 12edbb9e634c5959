"""Writers for rendered signals: WAV (streamed, PCM by default) and CSV (whole or streamed), all atomic.

Every WAV hapticfx writes names its software in a ``LIST/INFO/ISFT`` chunk, and
every PNG in a ``Software`` text chunk (a CSV starts with hapticfx's header row, the JSON Schema with its
``$id``), so that an output path holding a file hapticfx did not write is not replaced without an explicit
``--force`` / ``overwrite: true`` (:func:`check_overwrite`).
"""

from __future__ import annotations

import io
import os
import struct
from contextlib import ExitStack
from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..errors import DeviceError, HapticfxError

SOFTWARE = b"hapticfx"
WAV_FORMATS = {"pcm16": (1, 2), "pcm24": (1, 3), "float32": (3, 4)}  # name: (WAVE format tag, bytes per sample)
DEFAULT_WAV_FORMAT = "pcm24"


# The header rows of the CSV files `render --out x.csv` writes (a CSV has no place for a software tag).
CSV_HEADERS = ("t_s,profile_g", "t_s,profile_fraction")
# How the JSON Schema `hapticfx schema --out` writes starts (keys sorted: "$id" first; hapticfx.schema.SCHEMA_ID).
SCHEMA_START = b'{\n  "$id": "https://hapticfx.invalid/schema/'
# How each line of `hapticfx serve --log` starts (hapticfx.builtins.scene._played_line).
PLAYED_LOG_START = b'{"object": '


def written_by_hapticfx(path: Path) -> bool:
    """Whether ``path`` is a WAV or PNG file that carries hapticfx's software tag, a CSV file that
    starts with one of the header rows hapticfx writes (``CSV_HEADERS``), hapticfx's JSON Schema, or a log of
    played impacts (``serve --log``)."""
    try:
        with open(path, "rb") as f:
            head = f.read(4096)
    except OSError:
        return False
    if head[:4] == b"RIFF" and head[8:12] == b"WAVE":
        return b"ISFT" in head and SOFTWARE in head[head.index(b"ISFT"):head.index(b"ISFT") + 32]
    if head[:8] == b"\x89PNG\r\n\x1a\n":
        return b"tEXtSoftware\x00" + SOFTWARE in head
    if head.startswith(SCHEMA_START) or head.startswith(PLAYED_LOG_START):
        return True
    return head.split(b"\n", 1)[0].rstrip(b"\r").decode("latin-1") in CSV_HEADERS


def check_overwrite(path: Path, *, force: bool, option: str = "--force") -> None:
    """Refuse to replace an existing file that hapticfx did not write, unless ``force`` (an empty file holds
    nothing to lose: a `serve --log` of a session without impacts, say); and a directory, always."""
    path = Path(path)
    if path.is_dir():
        raise HapticfxError(f"{path}: is a directory, expected a file name")
    if path.exists() and not force and not (path.is_file() and (path.stat().st_size == 0 or written_by_hapticfx(path))):
        raise HapticfxError(f"{path}: exists and was not written by hapticfx; use {option} to replace it")


def _encode(samples: np.ndarray, fmt: str) -> bytes:
    """Interleaved little-endian frames of ``samples`` (channels, N) in ``fmt``."""
    x = np.clip(np.ascontiguousarray(samples.T), -1.0, 1.0)
    if fmt == "float32":
        return x.astype("<f4").tobytes()
    if fmt == "pcm16":
        return np.round(x * 32767.0).astype("<i2").tobytes()
    ints = np.round(x * 8388607.0).astype("<i4")
    return ints.view(np.uint8).reshape(-1, 4)[:, :3].tobytes()  # the low three bytes of each sample


class _StreamedFile:
    """A file streamed into :func:`~hapticfx.atomic.atomic_path`'s temporary file beside ``path``;
    :meth:`_finish` moves it into place whole.

    Nothing partial ever appears at ``path``: a failure (disk full, read-only
    directory) raises :class:`DeviceError` and removes the temporary file.
    """

    def __init__(self, path: Path):
        self.path = Path(path)
        self.bytes = 0  # written so far, header included
        self._stack = ExitStack()
        try:
            self._tmp = self._stack.enter_context(atomic_path(self.path))
            self._file = open(self._tmp, "wb")
        except HapticfxError as exc:
            raise DeviceError(str(exc)) from None
        except OSError as exc:
            self._drop()
            raise DeviceError(f"{self.path}: cannot write: {exc.strerror}") from None

    def _write(self, data: bytes) -> None:
        try:
            self._file.write(data)
        except OSError as exc:
            self.abort()
            raise DeviceError(f"{self.path}: cannot write: {exc.strerror}") from None
        self.bytes += len(data)

    def _finish(self, header: bytes = b"") -> Path:
        """Write ``header`` over the file's first bytes (a size known only now), then move it into place."""
        try:
            if header:
                self._file.seek(0)
                self._file.write(header)
            self._file.flush()
            os.fsync(self._file.fileno())
            self._file.close()
            self._stack.close()  # atomic_path moves it into place
        except OSError as exc:
            self.abort()
            raise DeviceError(f"{self.path}: cannot write: {exc.strerror}") from None
        return self.path

    def abort(self) -> None:
        """Drop what was written; ``path`` is left as it was."""
        try:
            self._file.close()
        except (OSError, AttributeError):
            pass
        self._drop()

    def _drop(self) -> None:
        # leave atomic_path's block with an error: it removes the temporary file
        self._stack.__exit__(DeviceError, DeviceError(f"{self.path}: not written"), None)


class WavWriter(_StreamedFile):
    """Streams frames into a WAV file that appears at ``path`` whole on :meth:`close`, or not at all."""

    def __init__(self, path: Path, rate_hz: float, channels: int = 1, *, fmt: str = DEFAULT_WAV_FORMAT):
        if fmt not in WAV_FORMATS:
            raise DeviceError(f"unknown WAV format {fmt!r}; one of: {', '.join(WAV_FORMATS)}")
        if abs(rate_hz - round(rate_hz)) > 1e-6:
            raise DeviceError(f"{path}: WAV needs an integer sample rate, got {rate_hz}")
        self.fmt, self.channels = fmt, int(channels)
        self.rate = int(round(rate_hz))
        self.frames = 0
        tag, width = WAV_FORMATS[fmt]
        self.frame_bytes = self.channels * width
        fmt_chunk = struct.pack("<HHIIHH", tag, self.channels, self.rate, self.rate * self.frame_bytes,
                                self.frame_bytes, 8 * width)
        info = b"INFO" + b"ISFT" + struct.pack("<I", 10) + SOFTWARE + b"\x00\x00"
        self._header = (b"fmt " + struct.pack("<I", len(fmt_chunk)) + fmt_chunk
                        + b"LIST" + struct.pack("<I", len(info)) + info)
        # RIFF sizes are 32-bit: the most frames a WAV file can hold
        self.max_frames = (2**32 - 1 - 4 - len(self._header) - 8) // self.frame_bytes
        super().__init__(path)
        self._write(self._riff(0))

    def _riff(self, data_bytes: int) -> bytes:
        return (b"RIFF" + struct.pack("<I", 4 + len(self._header) + 8 + data_bytes) + b"WAVE" + self._header
                + b"data" + struct.pack("<I", data_bytes))

    def write(self, samples: np.ndarray) -> None:
        """Append ``samples`` (channels, N) or (N,), normalised to [-1, 1]."""
        block = np.atleast_2d(np.asarray(samples, dtype=np.float64))
        if block.shape[0] != self.channels:
            raise DeviceError(f"{self.path}: {block.shape[0]} channels, the file has {self.channels}")
        if self.frames + block.shape[1] > self.max_frames:
            self.abort()
            raise DeviceError(f"{self.path}: a WAV file holds at most {self.max_frames} frames")
        self._write(_encode(block, self.fmt))
        self.frames += block.shape[1]

    def close(self) -> Path:
        """Finish the header and move the file into place atomically."""
        return self._finish(self._riff(self.frames * self.frame_bytes))


class CsvWriter(_StreamedFile):
    """Streams frames into a CSV file (``t_s`` and one column per channel) that appears whole on :meth:`close`."""

    # the longest row: t_s as %.8f up to 1e7 s (17), each value as %.9g in [-1, 1] (15), separators, newline
    def __init__(self, path: Path, rate_hz: float, channels: int = 1):
        self.rate, self.channels, self.frames = float(rate_hz), int(channels), 0
        self.frame_bytes = 17 + 16 * self.channels + 1
        self.max_frames = int(1e7 * self.rate)
        super().__init__(path)
        names = ["out"] if self.channels == 1 else [f"ch{c}" for c in range(self.channels)]
        self._write(("t_s," + ",".join(names) + "\n").encode())

    def write(self, samples: np.ndarray) -> None:
        """Append ``samples`` (channels, N) or (N,), normalised to [-1, 1]."""
        block = np.clip(np.atleast_2d(np.asarray(samples, dtype=np.float64)), -1.0, 1.0)
        if block.shape[0] != self.channels:
            raise DeviceError(f"{self.path}: {block.shape[0]} channels, the file has {self.channels}")
        t = (self.frames + np.arange(block.shape[1])) / self.rate
        rows = io.StringIO()
        np.savetxt(rows, np.column_stack([t, block.T]), delimiter=",", fmt=["%.8f"] + ["%.9g"] * self.channels)
        self._write(rows.getvalue().encode())
        self.frames += block.shape[1]

    def close(self) -> Path:
        """Move the file into place atomically."""
        return self._finish()


def write_wav(path: Path, samples: np.ndarray, rate_hz: float, *, fmt: str = DEFAULT_WAV_FORMAT) -> Path:
    """Write normalised samples (time last; channels first if 2D) as a WAV file, atomically (24-bit PCM)."""
    data = np.atleast_2d(np.asarray(samples, dtype=np.float64))
    writer = WavWriter(Path(path), rate_hz, data.shape[0], fmt=fmt)
    writer.write(data)
    return writer.close()


def read_wav(path: Path) -> tuple[int, np.ndarray]:
    """``(rate_hz, samples)`` of a PCM16, PCM24 or float32 WAV file, samples ``(channels, N)`` in [-1, 1].

    A damaged file (truncated, a header that does not fit its data, no samples, NaN) is a
    :class:`HapticfxError` naming the file and what was wrong.
    """
    data = Path(path).read_bytes()

    def bad(message: str, key: str | None = None) -> HapticfxError:
        return HapticfxError(message, source=str(path), key=key)

    if len(data) < 12 or data[:4] != b"RIFF" or data[8:12] != b"WAVE":
        raise bad("not a WAV file")
    pos, fmt, payload = 12, None, None
    while pos + 8 <= len(data) and (fmt is None or payload is None):
        cid, size = data[pos:pos + 4], struct.unpack("<I", data[pos + 4:pos + 8])[0]
        if pos + 8 + size > len(data):
            raise bad(f"truncated: the {cid.decode('latin-1').strip()!r} chunk needs a file of {pos + 8 + size} "
                      f"bytes, this one has {len(data)}")
        body = data[pos + 8:pos + 8 + size]
        if cid == b"fmt ":
            if size < 16:
                raise bad(f"a chunk of {size} bytes, expected at least 16", "fmt")
            fmt = struct.unpack("<HHIIHH", body[:16])
        elif cid == b"data":
            payload = body
        pos += 8 + size + (size & 1)
    if fmt is None or payload is None:
        raise bad("WAV file without fmt or data chunk")
    tag, channels, rate, _, _, bits = fmt
    for name, value in (("channels", channels), ("sample rate", rate)):
        if value == 0:
            raise bad(f"{name} is 0, expected at least 1", "fmt")
    if (tag, bits) not in {(3, 32), (1, 16), (1, 24)}:
        raise bad(f"unsupported WAV format (tag {tag}, {bits} bits)")
    frame = channels * bits // 8
    if not payload:
        raise bad("no samples, expected at least one frame", "data")
    if len(payload) % frame:
        raise bad(f"{len(payload)} bytes, expected a whole number of {frame}-byte frames "
                  f"({channels} channel(s) of {bits} bits)", "data")
    if tag == 3:
        x = np.frombuffer(payload, "<f4").astype(np.float64)
        if not np.all(np.isfinite(x)):
            raise bad(f"{np.count_nonzero(~np.isfinite(x))} sample(s) NaN or infinite, expected finite", "data")
    elif bits == 16:
        x = np.frombuffer(payload, "<i2") / 32767.0
    else:
        b = np.frombuffer(payload, np.uint8).reshape(-1, 3).astype(np.int32)
        x = ((b[:, 0] | (b[:, 1] << 8) | (b[:, 2] << 16)) << 8 >> 8) / 8388607.0
    return rate, x.reshape(-1, channels).T


def write_csv(path: Path, columns: dict[str, np.ndarray]) -> Path:
    """Write named equal-length columns as CSV with a header row, atomically."""
    names = list(columns)
    data = np.column_stack([np.asarray(columns[n], dtype=np.float64) for n in names])
    with atomic_path(path) as tmp:
        np.savetxt(tmp, data, delimiter=",", header=",".join(names), comments="", fmt="%.9g")
    return Path(path)
