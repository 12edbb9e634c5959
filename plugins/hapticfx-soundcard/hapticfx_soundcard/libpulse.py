"""A playback stream on a PulseAudio server through libpulse's threaded main loop (ctypes).

Only what :mod:`hapticfx_soundcard.queuestream` needs: a float32 stream with a
chosen queue length, writes at absolute stream positions (over audio already
queued), the playing position, and the server's read index after a write.
PortAudio cannot write over queued audio; libpulse can (``PA_SEEK_ABSOLUTE``).
Callbacks run on libpulse's own thread with its lock held; every other call
takes the lock (:meth:`Playback.locked`).

The playing position is worked out here from the server's timing, asked for
again at every request for audio, rather than taken from libpulse's own
interpolation (``PA_STREAM_INTERPOLATE_TIMING``): that one only moves forward,
and after a stall of the server it learns the slope of the server catching up
and ran ahead of playback by a second and more, so impacts were written that
much too late.
"""

from __future__ import annotations

import ctypes as C
import os
import threading
import time
from contextlib import contextmanager
from typing import Callable

import numpy as np
from hapticfx.errors import DeviceError, DeviceUnavailable

_P = C.c_void_p
CONTEXT_READY, CONTEXT_FAILED, CONTEXT_TERMINATED = 4, 5, 6
STREAM_READY, STREAM_FAILED, STREAM_TERMINATED = 2, 3, 4
_CONTEXT_NOAUTOSPAWN = 1
_FLOAT32LE = 5
_SEEK_ABSOLUTE = 1
# PA_STREAM_EARLY_REQUESTS: ask for data every minreq (not only when the queue runs low); timing is asked for by
# hand. PA_STREAM_NO_REMAP_CHANNELS: channel k of the stream is channel k of the sink, by index: an actuator's
# channel is an output, not a loudspeaker position to up- or downmix (a 4-channel stream on a 4-channel sink
# whose map differs from libpulse's default was spread over the wrong actuators, one on channel 0 leaked to 1).
_STREAM_FLAGS = 0x4000 | 0x0010
_CONNECT_S = 5.0


class _SampleSpec(C.Structure):
    _fields_ = [("format", C.c_int), ("rate", C.c_uint32), ("channels", C.c_uint8)]


class _BufferAttr(C.Structure):
    _fields_ = [("maxlength", C.c_uint32), ("tlength", C.c_uint32), ("prebuf", C.c_uint32),
                ("minreq", C.c_uint32), ("fragsize", C.c_uint32)]


class _Timeval(C.Structure):
    _fields_ = [("sec", C.c_long), ("usec", C.c_long)]


class _TimingInfo(C.Structure):
    _fields_ = [("timestamp", _Timeval), ("synchronized_clocks", C.c_int), ("sink_usec", C.c_uint64),
                ("source_usec", C.c_uint64), ("transport_usec", C.c_uint64), ("playing", C.c_int),
                ("write_index_corrupt", C.c_int), ("write_index", C.c_int64), ("read_index_corrupt", C.c_int),
                ("read_index", C.c_int64), ("configured_sink_usec", C.c_uint64),
                ("configured_source_usec", C.c_uint64), ("since_underrun", C.c_int64)]


class _ServerInfo(C.Structure):  # the leading fields of pa_server_info
    _fields_ = [("user_name", C.c_char_p), ("host_name", C.c_char_p), ("server_version", C.c_char_p),
                ("server_name", C.c_char_p), ("sample_spec", _SampleSpec), ("default_sink_name", C.c_char_p)]


class _SinkInfo(C.Structure):  # the leading fields of pa_sink_info
    _fields_ = [("name", C.c_char_p), ("index", C.c_uint32), ("description", C.c_char_p),
                ("sample_spec", _SampleSpec)]


_NOTIFY = C.CFUNCTYPE(None, _P, _P)
_SERVER_INFO = C.CFUNCTYPE(None, _P, C.POINTER(_ServerInfo), _P)
_SINK_INFO = C.CFUNCTYPE(None, _P, C.POINTER(_SinkInfo), C.c_int, _P)
_SUCCESS = C.CFUNCTYPE(None, _P, C.c_int, _P)
_REQUEST = C.CFUNCTYPE(None, _P, C.c_size_t, _P)

_PROTOTYPES = [
    ("pa_threaded_mainloop_new", _P, []), ("pa_threaded_mainloop_start", C.c_int, [_P]),
    ("pa_threaded_mainloop_stop", None, [_P]), ("pa_threaded_mainloop_free", None, [_P]),
    ("pa_threaded_mainloop_lock", None, [_P]), ("pa_threaded_mainloop_unlock", None, [_P]),
    ("pa_threaded_mainloop_wait", None, [_P]), ("pa_threaded_mainloop_signal", None, [_P, C.c_int]),
    ("pa_threaded_mainloop_get_api", _P, [_P]),
    ("pa_context_new", _P, [_P, C.c_char_p]), ("pa_context_unref", None, [_P]),
    ("pa_context_connect", C.c_int, [_P, C.c_char_p, C.c_int, _P]), ("pa_context_disconnect", None, [_P]),
    ("pa_context_get_state", C.c_int, [_P]), ("pa_context_set_state_callback", None, [_P, _P, _P]),
    ("pa_context_errno", C.c_int, [_P]), ("pa_strerror", C.c_char_p, [C.c_int]),
    ("pa_stream_new", _P, [_P, C.c_char_p, C.POINTER(_SampleSpec), _P]), ("pa_stream_unref", None, [_P]),
    ("pa_stream_connect_playback", C.c_int, [_P, C.c_char_p, C.POINTER(_BufferAttr), C.c_int, _P, _P]),
    ("pa_stream_disconnect", C.c_int, [_P]),
    ("pa_stream_get_state", C.c_int, [_P]), ("pa_stream_set_state_callback", None, [_P, _P, _P]),
    ("pa_stream_set_write_callback", None, [_P, _P, _P]), ("pa_stream_set_underflow_callback", None, [_P, _P, _P]),
    ("pa_stream_write", C.c_int, [_P, _P, C.c_size_t, _P, C.c_int64, C.c_int]),
    ("pa_stream_get_timing_info", C.POINTER(_TimingInfo), [_P]),
    ("pa_stream_update_timing_info", _P, [_P, _P, _P]), ("pa_operation_unref", None, [_P]),
    ("pa_context_get_server_info", _P, [_P, _P, _P]), ("pa_context_get_sink_info_by_name", _P, [_P, C.c_char_p, _P, _P]),
    ("pa_operation_get_state", C.c_int, [_P]),
]
_lib = None
_lib_lock = threading.Lock()


def load():
    """libpulse, with its prototypes set; :class:`DeviceUnavailable` naming the package if it is missing."""
    global _lib
    with _lib_lock:
        if _lib is None:
            try:
                lib = C.CDLL("libpulse.so.0")
            except OSError as exc:
                raise DeviceUnavailable(f"the PulseAudio client library is missing ({exc}); install it, "
                                        "e.g. apt-get install libpulse0 (a queue needs a PulseAudio or "
                                        "PipeWire-Pulse server)") from None
            for name, restype, argtypes in _PROTOTYPES:
                f = getattr(lib, name)
                f.restype, f.argtypes = restype, argtypes
            _lib = lib
    return _lib


def sink_info(sink: str | None) -> tuple[str, int]:
    """``(name, rate_hz)`` of the sink ``sink`` names on the PulseAudio server (None or 'default': ``PULSE_SINK``
    if set, as for any libpulse client, else the server's default sink, as it is now): what a stream on it plays into, whatever name it was given.
    :class:`DeviceError` if the server or the sink does not answer."""
    pa = load()
    loop = pa.pa_threaded_mainloop_new()
    if not loop or pa.pa_threaded_mainloop_start(loop) < 0:
        raise DeviceError("libpulse could not start its main loop")
    found: dict = {}

    def on_state(_c, _u):
        pa.pa_threaded_mainloop_signal(loop, 0)

    def on_server(_c, info, _u):
        if info:
            found["default"] = (info.contents.default_sink_name or b"").decode()
        found["server_done"] = True
        pa.pa_threaded_mainloop_signal(loop, 0)

    def on_sink(_c, info, eol, _u):
        if eol == 0 and info:
            found["sink"] = (info.contents.name.decode(), int(info.contents.sample_spec.rate))
        elif eol:
            found["sink_done"] = True
            pa.pa_threaded_mainloop_signal(loop, 0)

    callbacks = (_NOTIFY(on_state), _SERVER_INFO(on_server), _SINK_INFO(on_sink))
    deadline = time.monotonic() + _CONNECT_S
    context = None
    pa.pa_threaded_mainloop_lock(loop)
    try:
        def wait(done, what):
            while not done():
                if time.monotonic() > deadline:
                    raise DeviceError(f"{what}: no answer in {_CONNECT_S:g} s")
                pa.pa_threaded_mainloop_unlock(loop)
                time.sleep(0.001)
                pa.pa_threaded_mainloop_lock(loop)

        context = pa.pa_context_new(pa.pa_threaded_mainloop_get_api(loop), b"hapticfx-sink-info")
        pa.pa_context_set_state_callback(context, callbacks[0], None)
        if pa.pa_context_connect(context, None, _CONTEXT_NOAUTOSPAWN, None) < 0:
            raise DeviceError("cannot reach a PulseAudio server")

        def ready():
            state = pa.pa_context_get_state(context)
            if state in (CONTEXT_FAILED, CONTEXT_TERMINATED):
                raise DeviceError("cannot reach a PulseAudio server")
            return state == CONTEXT_READY

        wait(ready, "cannot reach a PulseAudio server")
        name = sink
        if sink in (None, "", "default", "@DEFAULT_SINK@"):  # where libpulse sends a stream with no sink
            name = os.environ.get("PULSE_SINK") or None
        if name is None:
            pa.pa_operation_unref(pa.pa_context_get_server_info(context, callbacks[1], None))
            wait(lambda: "server_done" in found, "the PulseAudio server did not say its default sink")
            name = found.get("default")
            if not name:
                raise DeviceError("the PulseAudio server has no default sink (`pactl list short sinks`)")
        pa.pa_operation_unref(pa.pa_context_get_sink_info_by_name(context, name.encode(), callbacks[2], None))
        wait(lambda: "sink_done" in found, f"the PulseAudio server did not describe sink {name!r}")
        if "sink" not in found:
            raise DeviceError(f"cannot play on sink {name!r}: no such sink (`pactl list short sinks` lists the sinks)")
        return found["sink"]
    finally:
        if context:
            pa.pa_context_disconnect(context)
            pa.pa_context_unref(context)
        pa.pa_threaded_mainloop_unlock(loop)
        pa.pa_threaded_mainloop_stop(loop)
        pa.pa_threaded_mainloop_free(loop)
        del callbacks


class Playback:
    """One float32 playback stream on a PulseAudio sink (``sink=None``: the server's default).

    ``on_request(playback, frames)`` is called on libpulse's thread, with its lock held, whenever
    the server has room for ``frames`` more (the first time before the constructor returns); it must
    :meth:`write` them. ``on_underflow()`` when
    the queue ran dry, ``on_failure(why)`` once when the server or the stream is gone.
    Positions are stream frames: the server's byte index divided by the frame size.
    """

    def __init__(self, *, rate_hz: float, channels: int, queue_frames: int, request_frames: int,
                 sink: str | None, name: str, on_request: Callable[["Playback", int], None],
                 on_underflow: Callable[[], None], on_failure: Callable[[str], None]):
        self._pa = load()
        self.rate_hz = int(round(rate_hz))
        self.channels = int(channels)
        self.frame_bytes = 4 * self.channels
        self._on_request, self._on_underflow, self._on_failure = on_request, on_underflow, on_failure
        self._failed = False
        self._playing = 0  # the latest playing_frame()
        self._guard = threading.RLock()  # a lock taken on a freed main loop would crash the process
        self._landed: list[Callable[[int], None]] = []  # per pending read-index query, in order
        self._callbacks = (_NOTIFY(self._state_changed), _REQUEST(self._request), _NOTIFY(self._underflow),
                           _SUCCESS(self._timing))  # kept alive as long as libpulse may call them
        pa = self._pa
        self._loop = pa.pa_threaded_mainloop_new()
        self._context = self._stream = None
        if not self._loop or pa.pa_threaded_mainloop_start(self._loop) < 0:
            raise DeviceError("libpulse could not start its main loop")
        try:
            with self.locked():
                self._connect(sink, name.encode(), queue_frames, request_frames)
        except BaseException:
            self.close()
            raise

    def _wait_for(self, state_of, ready: int, failed: tuple[int, ...], what: str) -> None:
        pa, deadline = self._pa, threading.Event()
        timer = threading.Timer(_CONNECT_S, self._time_out, args=(deadline,))
        timer.start()
        try:
            while (state := state_of()) != ready:
                if state in failed or deadline.is_set():
                    raise DeviceError(f"{what}: {self._error() if state in failed else f'no answer in {_CONNECT_S:g} s'}")
                pa.pa_threaded_mainloop_wait(self._loop)
        finally:
            timer.cancel()

    def _connect(self, sink: str | None, name: bytes, queue_frames: int, request_frames: int) -> None:
        pa, fb = self._pa, self.frame_bytes
        self._context = pa.pa_context_new(pa.pa_threaded_mainloop_get_api(self._loop), name)
        pa.pa_context_set_state_callback(self._context, self._callbacks[0], None)
        if pa.pa_context_connect(self._context, None, _CONTEXT_NOAUTOSPAWN, None) < 0:
            raise DeviceError(f"cannot reach a PulseAudio server: {self._error()}")
        self._wait_for(lambda: pa.pa_context_get_state(self._context), CONTEXT_READY,
                       (CONTEXT_FAILED, CONTEXT_TERMINATED), "cannot reach a PulseAudio server")
        spec = _SampleSpec(_FLOAT32LE, self.rate_hz, self.channels)
        self._stream = pa.pa_stream_new(self._context, name, C.byref(spec), None)
        if not self._stream:
            raise DeviceError(f"PulseAudio refused a {self.channels}-channel stream at {self.rate_hz} Hz")
        pa.pa_stream_set_state_callback(self._stream, self._callbacks[0], None)
        pa.pa_stream_set_write_callback(self._stream, self._callbacks[1], None)
        pa.pa_stream_set_underflow_callback(self._stream, self._callbacks[2], None)
        attr = _BufferAttr(0xFFFFFFFF, queue_frames * fb, 0, request_frames * fb, 0xFFFFFFFF)
        where = f"sink {sink!r}" if sink else "the default sink"
        if pa.pa_stream_connect_playback(self._stream, sink.encode() if sink else None, C.byref(attr),
                                         _STREAM_FLAGS, None, None) < 0:
            raise DeviceError(f"cannot play on {where}: {self._error()}")
        self._wait_for(lambda: pa.pa_stream_get_state(self._stream), STREAM_READY,
                       (STREAM_FAILED, STREAM_TERMINATED),
                       f"cannot play on {where} (`pactl list short sinks` lists the sinks)")

    def _error(self) -> str:
        """libpulse's last error on the connection, in words."""
        return self._pa.pa_strerror(self._pa.pa_context_errno(self._context)).decode()

    def _time_out(self, deadline: threading.Event) -> None:
        deadline.set()
        with self.locked():
            self._signal()

    @property
    def failed(self) -> bool:
        """Whether the server or the stream is gone (``on_failure`` was called)."""
        return self._failed

    @contextmanager
    def locked(self):
        """Hold libpulse's lock (the callbacks do not run meanwhile); :class:`DeviceError` once closed."""
        with self._guard:
            if self._loop is None:
                raise DeviceError("the PulseAudio stream was closed")
            self._pa.pa_threaded_mainloop_lock(self._loop)
        try:
            yield self
        finally:
            self._pa.pa_threaded_mainloop_unlock(self._loop)

    def _signal(self) -> None:
        self._pa.pa_threaded_mainloop_signal(self._loop, 0)

    # --- on libpulse's thread -------------------------------------------------------

    def _state_changed(self, *_):
        pa = self._pa
        self._signal()
        if self._failed or self._stream is None:
            return
        if pa.pa_context_get_state(self._context) in (CONTEXT_FAILED, CONTEXT_TERMINATED):
            why = f"the PulseAudio server closed the connection ({self._error()})"
        elif pa.pa_stream_get_state(self._stream) in (STREAM_FAILED, STREAM_TERMINATED):
            why = "the PulseAudio server ended the stream (sink removed?)"
        else:
            return
        self._failed = True
        self._on_failure(why)

    def _request(self, _stream, nbytes, _userdata):
        self._refresh()
        self._on_request(self, nbytes // self.frame_bytes)

    def _refresh(self) -> None:
        """Ask for the server's timing again (the answer updates :meth:`playing_frame`)."""
        op = self._pa.pa_stream_update_timing_info(self._stream, None, None)
        if op:
            self._pa.pa_operation_unref(op)

    def _underflow(self, *_):
        self._on_underflow()

    def _timing(self, _stream, ok, _userdata):
        done = self._landed.pop(0)
        ti = self._pa.pa_stream_get_timing_info(self._stream)
        if ok and ti and not ti.contents.read_index_corrupt:
            done(ti.contents.read_index // self.frame_bytes)

    # --- with the lock held ---------------------------------------------------------

    def write(self, block: np.ndarray, at: int) -> None:
        """Queue ``block`` (frames x channels, float32, C order) at stream frame ``at``, over what is there."""
        if self._pa.pa_stream_write(self._stream, block.ctypes.data, block.nbytes, None,
                                    at * self.frame_bytes, _SEEK_ABSOLUTE) < 0:
            raise DeviceError(f"PulseAudio refused a write: {self._error()}")

    def playing_frame(self) -> int:
        """The frame being heard now: the server's read index less what its sink holds, when it last
        said, moved on by the time since (0 before the first answer)."""
        info = self._pa.pa_stream_get_timing_info(self._stream)
        if not info or info.contents.read_index_corrupt:
            return self._playing
        ti = info.contents
        # the timestamp is when the server answered (libpulse's estimate where the clocks differ)
        since_s = max(0.0, time.time() - (ti.timestamp.sec + ti.timestamp.usec * 1e-6))
        frames = ti.read_index // self.frame_bytes + int((since_s - ti.sink_usec * 1e-6) * self.rate_hz)
        self._playing = max(0, frames)
        return self._playing

    def read_index_then(self, done: Callable[[int], None]) -> None:
        """Ask for the server's read index (frames) as it stands after the writes so far; ``done`` gets it."""
        op = self._pa.pa_stream_update_timing_info(self._stream, self._callbacks[3], None)
        if op:
            self._landed.append(done)
            self._pa.pa_operation_unref(op)

    # --- lifetime -------------------------------------------------------------------

    def close(self) -> None:
        """Leave the server and stop libpulse's thread (never waits on the server)."""
        pa = self._pa
        with self._guard:
            if self._loop is None:
                return
            with self.locked():
                self._failed = True  # a disconnect is not a failure to report
                if self._stream:
                    pa.pa_stream_disconnect(self._stream)
                    pa.pa_stream_unref(self._stream)
                if self._context:
                    pa.pa_context_disconnect(self._context)
                    pa.pa_context_unref(self._context)
                self._stream = self._context = None
            pa.pa_threaded_mainloop_stop(self._loop)
            pa.pa_threaded_mainloop_free(self._loop)
            self._loop = None
