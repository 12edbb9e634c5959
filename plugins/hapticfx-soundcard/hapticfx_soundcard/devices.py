"""Finding PortAudio output devices by name or index, and agreeing on a sample rate."""

from __future__ import annotations

from dataclasses import dataclass

from hapticfx.errors import DeviceError, DeviceUnavailable


def import_sounddevice():
    """``sounddevice``, or a :class:`DeviceError` saying which system library is missing."""
    try:
        import sounddevice
    except OSError as exc:  # raised when libportaudio is not installed
        raise DeviceUnavailable(
            f"the PortAudio library is missing ({exc}); install it, e.g. apt-get install libportaudio2"
        ) from None
    return sounddevice


@dataclass(frozen=True)
class OutputDevice:
    """One PortAudio output device."""

    index: int
    name: str
    hostapi: str
    channels: int
    default_rate_hz: float
    default_low_latency_s: float
    is_default: bool


def output_devices() -> list[OutputDevice]:
    """Every device that has at least one output channel."""
    sd = import_sounddevice()
    default = _default_output(sd)
    hostapis = sd.query_hostapis()
    return [
        OutputDevice(
            index=i, name=d["name"], hostapi=hostapis[d["hostapi"]]["name"],
            channels=int(d["max_output_channels"]), default_rate_hz=float(d["default_samplerate"]),
            default_low_latency_s=float(d["default_low_output_latency"]), is_default=(i == default),
        )
        for i, d in enumerate(sd.query_devices())
        if d["max_output_channels"] > 0
    ]


def _default_output(sd) -> int:
    try:
        return int(sd.default.device[1])
    except (TypeError, ValueError, IndexError):
        return -1


def _listing(devices: list[OutputDevice]) -> str:
    return "; ".join(f"{d.index}: {d.name!r}" for d in devices) or "none (is a sound server running?)"


def resolve_device(device: str | int | None) -> OutputDevice:
    """The output device named by ``device``: None/'default', an index, or part of a name.

    A name or index that matches none is a :class:`DeviceUnavailable` only where there is no output at all (a
    headless machine: ``play`` then writes a file); beside outputs it is a typo, a :class:`DeviceError`."""
    devices = output_devices()
    missing = DeviceError if devices else DeviceUnavailable
    if device is None or device == "default":
        sd = import_sounddevice()
        index = _default_output(sd)
        found = [d for d in devices if d.index == index]
        if not found:
            raise DeviceUnavailable(f"there is no default sound output device; outputs: {_listing(devices)}")
        return found[0]
    if isinstance(device, int) or (isinstance(device, str) and device.strip().isdigit()):
        index = int(device)
        found = [d for d in devices if d.index == index]
        if not found:
            raise missing(f"no sound output device with index {index}; outputs: {_listing(devices)}")
        return found[0]
    exact = [d for d in devices if d.name == device]
    found = exact or [d for d in devices if str(device).lower() in d.name.lower()]
    if not found:
        raise missing(f"no sound output device matches {device!r}; outputs: {_listing(devices)}")
    if len(found) > 1:
        raise DeviceError(f"{device!r} matches several outputs ({_listing(found)}); give the index")
    return found[0]


PULSE_ALSA_DEVICES = ("pulse", "default")  # ALSA devices that play into the PulseAudio server's default sink


def physical_output(device: OutputDevice) -> tuple[tuple, int | None]:
    """The output ``device`` plays into, as a key shared with every other way of reaching it, and the rate
    it runs at where that is known: ALSA's ``pulse`` and ``default`` devices play into the default sink of
    a PulseAudio server that answers (``("pulse", sink name)``, the sink's rate); any other device is
    itself (``("portaudio", index)``, None)."""
    if device.hostapi == "ALSA" and device.name in PULSE_ALSA_DEVICES:
        from .libpulse import sink_info
        from .queuestream import physical_sink

        try:
            name, rate = sink_info(None)
        except DeviceError:  # no server (or no libpulse): ALSA's own default device
            pass
        else:
            return physical_sink(name), rate
    return ("portaudio", device.index), None


def negotiate_rate(device: OutputDevice, rate_hz: float, channels: int) -> tuple[float, str | None]:
    """``rate_hz`` if the device takes it, else the device's default rate and a note saying so."""
    sd = import_sounddevice()
    try:
        sd.check_output_settings(device=device.index, samplerate=rate_hz, channels=channels, dtype="float32")
        return float(rate_hz), None
    except sd.PortAudioError as exc:
        fallback = device.default_rate_hz
        try:
            sd.check_output_settings(device=device.index, samplerate=fallback, channels=channels, dtype="float32")
        except sd.PortAudioError as exc2:
            raise DeviceError(f"sound output {device.name!r} refuses {channels} channel(s): {exc2}") from None
        return fallback, f"{device.name!r} does not take {rate_hz:g} Hz ({exc}); using its default {fallback:g} Hz"
