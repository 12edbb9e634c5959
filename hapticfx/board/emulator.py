"""An emulator of the accelerometer board on a pseudo-terminal pair.

It answers the line protocol of :mod:`hapticfx.board.protocol` exactly as
the firmware sketch does (``Serial.println`` line ends ``\r\n`` included), so
``hapticfx data record`` can be tested end to end with pyserial and no
hardware. While streaming it sends gravity plus sensor noise, and after
``idle_s`` of quiet each impact in ``impacts`` (``(N, 3)`` g, added to
gravity), separated by ``gap_s``. Values are clipped to the sensor's
``range_g`` and quantised to ADC counts like the real part.
"""

from __future__ import annotations

import os
import select
import threading
import time
import tty

import numpy as np

from .protocol import GY61, BoardInfo, sample_line


class AccelBoardEmulator:
    """A GY-61 / ADXL335 board behind a pty; use as a context manager, open ``port`` with pyserial."""

    def __init__(self, impacts=(), *, info: BoardInfo = GY61, gravity_g=(0.0, 0.0, 1.0), noise_g: float = 0.004,
                 idle_s: float = 0.3, gap_s: float = 1.5, range_g: float = 3.6, realtime: bool = False,
                 lose_samples_at: int | None = None, seed: int = 0):
        self.info = info
        self.impacts = [np.asarray(i, np.float64) for i in impacts]
        self.gravity = np.asarray(gravity_g, np.float64)
        self.noise_g = noise_g
        self.idle_n = int(idle_s * info.rate_hz)
        self.gap_n = int(gap_s * info.rate_hz)
        self.range_g = range_g
        self.realtime = realtime
        self.lose_samples_at = lose_samples_at
        self.rng = np.random.default_rng(seed)
        self.port: str | None = None
        self._master = self._slave = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.commands: list[str] = []

    def __enter__(self) -> "AccelBoardEmulator":
        import pty

        self._master, self._slave = pty.openpty()
        tty.setraw(self._slave)
        os.set_blocking(self._master, False)
        self.port = os.ttyname(self._slave)
        self._thread = threading.Thread(target=self._run, name="accel-emulator", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        for fd in (self._master, self._slave):
            if fd is not None:
                os.close(fd)
        return False

    def _signal(self):
        """Samples in g, forever: idle, impact, gap, impact, ..., then idle."""
        timeline = [np.zeros((self.idle_n, 3))]
        for imp in self.impacts:
            timeline += [imp, np.zeros((self.gap_n, 3))]
        for block in timeline:
            yield from self._noisy(block)
        while True:
            yield from self._noisy(np.zeros((256, 3)))

    def _noisy(self, block):
        g = block + self.gravity + self.rng.normal(0.0, self.noise_g, block.shape)
        yield from self.info.to_counts(np.clip(g, -self.range_g, self.range_g))

    def _run(self) -> None:
        buf = b""
        streaming = False
        source = None
        seq = 0
        out = b""
        t0 = time.monotonic()
        while not self._stop.is_set():
            want_write = streaming or bool(out)
            r, w, _ = select.select([self._master], [self._master] if want_write else [], [], 0.02)
            if r:
                try:
                    data = os.read(self._master, 4096)
                except BlockingIOError:
                    data = b""
                except OSError:
                    return
                buf += data
                while b"\n" in buf:
                    raw, buf = buf.split(b"\n", 1)
                    cmd = raw.decode("ascii", "replace").strip()
                    self.commands.append(cmd)
                    if cmd == "HELLO":
                        out += (self.info.hello_line() + "\r\n").encode()
                    elif cmd == "START":
                        streaming, source, seq, t0 = True, self._signal(), 0, time.monotonic()
                        out += b"OK START\r\n"
                    elif cmd == "STOP":
                        streaming = False
                        out += b"OK STOP\r\n"
                    elif cmd:
                        out += f"ERR unknown command {cmd}\r\n".encode()
            if w:
                if streaming and len(out) < 2048:
                    n = 32
                    if self.realtime:
                        n = max(0, min(n, int((time.monotonic() - t0) * self.info.rate_hz) - seq))
                    for _ in range(n):
                        counts = next(source)
                        if self.lose_samples_at is not None and seq == self.lose_samples_at:
                            seq += 3  # a burst of lost samples, as after a serial overrun
                        out += sample_line(seq, counts).encode()
                        seq += 1
                try:
                    sent = os.write(self._master, out)
                except BlockingIOError:
                    sent = 0
                except OSError:
                    return
                out = out[sent:]
                if not out:
                    time.sleep(0.0005 if self.realtime else 0.0)
        # The host's last lines (its closing STOP) may still be in the pty when we are told
        # to stop: take them in, so `commands` is the whole conversation.
        try:
            buf += os.read(self._master, 4096)
        except OSError:
            pass
        self.commands += [raw.decode("ascii", "replace").strip() for raw in buf.split(b"\n")[:-1]]
