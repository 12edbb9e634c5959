"""Android's audio-coupled haptics: an Ogg Vorbis file whose last N channels are haptic (``ANDROID_HAPTIC=N``).

Android plays such a file through its audio path and routes the last N channels (1 or 2:
haptic channels A and B) to the vibrator at audio rate; the Vorbis comment ``ANDROID_HAPTIC=N``
says how many. Of the Android paths it is the closest to what hapticfx renders: the waveform
itself, not an envelope. hapticfx writes two channels, a silent audio channel and the impact as
haptic channel A, at the signal's own rate (Vorbis, libsndfile's quality 0.9 of 1), and reads
back the mean of the haptic channels, clipped to full scale. Vorbis overshoots a peak by up to a
few per cent, so the writer decodes what it encoded and, where that reads back above the impact's
peak, encodes the impact again scaled down by the overshoot. A file without the tag, or with N not 1 or 2 or more than its channels, is refused.

libsndfile (through ``soundfile``, the ``ogg`` extra) encodes and decodes the audio, but it
writes its own Vorbis comment (``ENCODER=...``) and no way to add the ``ANDROID_HAPTIC`` tag,
so the comment header is replaced after encoding: the Ogg pages that carry the comment and
setup headers are rebuilt, and every page's sequence number and checksum rewritten.
"""

from __future__ import annotations

import io
import struct
from pathlib import Path

import numpy as np

from ..errors import HapticfxError
from ..signal import Signal
from .base import Decoded, ExportOptions, Format, HapticFileError
from .document import atomic_bytes

RULES = "Android audio-coupled haptics"
TAG = "ANDROID_HAPTIC"
MAX_BYTES = 64 << 20
OVERSHOOT_MARGINS = (0.0, 0.002, 0.005, 0.01, 0.02, 0.05)  # below the overshoot, each try: its coding noise moves


def _soundfile():
    try:
        import soundfile
    except (ImportError, OSError) as exc:
        raise HapticfxError(f"Ogg files need soundfile and libsndfile: pip install 'hapticfx[ogg]' ({exc})") from None
    return soundfile


def _crc_table() -> list[int]:
    table = []
    for i in range(256):
        r = i << 24
        for _ in range(8):
            r = ((r << 1) ^ 0x04C11DB7) if r & 0x80000000 else (r << 1)
        table.append(r & 0xFFFFFFFF)
    return table


_CRC = _crc_table()


def _crc(data: bytes) -> int:
    """Ogg's page checksum: CRC-32, polynomial 0x04C11DB7, not reflected, initial value 0."""
    crc = 0
    for byte in data:
        crc = ((crc << 8) & 0xFFFFFFFF) ^ _CRC[((crc >> 24) ^ byte) & 0xFF]
    return crc


def _pages(data: bytes, source: str) -> list[dict]:
    pages, pos = [], 0
    while pos < len(data):
        if data[pos:pos + 4] != b"OggS" or len(data) < pos + 27:
            raise HapticFileError(f"byte {pos}: not an Ogg page ({RULES}: an Ogg Vorbis file)", source=source)
        nseg = data[pos + 26]
        lacing = list(data[pos + 27:pos + 27 + nseg])
        start = pos + 27 + nseg
        body = data[start:start + sum(lacing)]
        if len(body) != sum(lacing):
            raise HapticFileError(f"byte {pos}: a truncated Ogg page ({RULES}: an Ogg Vorbis file)", source=source)
        pages.append({"flags": data[pos + 5], "granule": data[pos + 6:pos + 14], "serial": data[pos + 14:pos + 18],
                      "lacing": lacing, "body": body})
        pos = start + len(body)
    if not pages:
        raise HapticFileError(f"an empty file ({RULES}: an Ogg Vorbis file)", source=source)
    return pages


def _packets(pages: list[dict], count: int, first_page: int) -> tuple[list[bytes], int]:
    """The first ``count`` packets from ``first_page`` on, and the index of the page after the last one ends."""
    packets, current = [], b""
    for index in range(first_page, len(pages)):
        page, offset = pages[index], 0
        for size in page["lacing"]:
            current += page["body"][offset:offset + size]
            offset += size
            if size < 255:
                packets.append(current)
                current = b""
                if len(packets) == count:
                    return packets, index + 1
    raise ValueError("the headers do not end")


def _page(flags: int, granule: bytes, serial: bytes, sequence: int, lacing: list[int], body: bytes) -> bytes:
    head = b"OggS\x00" + bytes([flags]) + granule + serial + struct.pack("<I", sequence) + b"\x00\x00\x00\x00"
    raw = head + bytes([len(lacing)]) + bytes(lacing) + body
    return raw[:22] + struct.pack("<I", _crc(raw)) + raw[26:]


def _paginate(packets: list[bytes], serial: bytes, sequence: int) -> list[bytes]:
    """Header packets on pages of their own (granule 0), as many as they need."""
    segments = []
    for packet in packets:
        sizes = [255] * (len(packet) // 255) + [len(packet) % 255]
        offset = 0
        for size in sizes:
            segments.append((size, packet[offset:offset + size]))
            offset += size
    pages, continued = [], False
    for start in range(0, len(segments), 255):
        chunk = segments[start:start + 255]
        pages.append(_page(0x01 if continued else 0x00, bytes(8), serial, sequence + len(pages), [s for s, _ in chunk],
                           b"".join(b for _, b in chunk)))
        continued = chunk[-1][0] == 255
    return pages


def comment_packet(comments: list[str], vendor: str = "hapticfx") -> bytes:
    """A Vorbis comment header holding ``comments`` (``KEY=value`` each)."""
    out = b"\x03vorbis" + struct.pack("<I", len(vendor.encode())) + vendor.encode() + struct.pack("<I", len(comments))
    for c in comments:
        out += struct.pack("<I", len(c.encode())) + c.encode()
    return out + b"\x01"


def parse_comments(packet: bytes) -> list[str]:
    if packet[:7] != b"\x03vorbis":
        raise ValueError("not a Vorbis comment header")
    (vlen,) = struct.unpack("<I", packet[7:11])
    pos = 11 + vlen
    (count,) = struct.unpack("<I", packet[pos:pos + 4])
    pos += 4
    out = []
    for _ in range(count):
        (n,) = struct.unpack("<I", packet[pos:pos + 4])
        out.append(packet[pos + 4:pos + 4 + n].decode("utf-8", "replace"))
        pos += 4 + n
    return out


def with_comments(data: bytes, comments: list[str], source: str = "<ogg>") -> bytes:
    """The Ogg Vorbis ``data`` with its comment header replaced by one holding ``comments``."""
    pages = _pages(data, source)
    (comment, setup), after = _packets(pages, 2, 1)
    head = [pages[0]]
    out = [_page(p["flags"], p["granule"], p["serial"], i, p["lacing"], p["body"]) for i, p in enumerate(head)]
    out += _paginate([comment_packet(comments), setup], pages[0]["serial"], len(out))
    for p in pages[after:]:
        out.append(_page(p["flags"], p["granule"], p["serial"], len(out), p["lacing"], p["body"]))
    return b"".join(out)


class AndroidOggFormat(Format):
    """Android audio-coupled haptics (Ogg Vorbis with ``ANDROID_HAPTIC=N``)."""

    name = "android-ogg"
    suffixes = (".ogg",)
    holds = frozenset({"waveform"})
    description = "Android audio-coupled haptics (Ogg Vorbis, ANDROID_HAPTIC=1)"

    def write(self, path: Path, signal: Signal, options: ExportOptions) -> None:
        sf = _soundfile()
        rate = int(round(signal.rate_hz))
        x = np.clip(signal.samples, -1.0, 1.0)
        peak = float(np.max(np.abs(x))) if x.size else 0.0
        # Vorbis overshoots a peak by up to a few per cent (0.302 for a 0.3 square pulse): the impact is encoded
        # again, scaled down by what its decode overshot and a margin, until the decode keeps within its own peak
        for margin in OVERSHOOT_MARGINS:
            buffer = io.BytesIO()
            sf.write(buffer, np.column_stack((np.zeros(len(x)), x)), rate, format="OGG", subtype="VORBIS",
                     compression_level=0.1)
            decoded, _ = sf.read(io.BytesIO(buffer.getvalue()), always_2d=True)
            got = float(np.max(np.abs(decoded[:, -1]))) if decoded.size else 0.0
            if got <= peak:
                break
            x = x * (peak / got * (1.0 - margin))
        else:
            raise HapticfxError(f"{path}: the Vorbis encoding of this impact reads back at {got:.4f}, above its peak "
                                f"{peak:.4f}, after {len(OVERSHOOT_MARGINS)} tries; nothing was written")
        atomic_bytes(Path(path), with_comments(buffer.getvalue(), [f"{TAG}=1", "ENCODER=hapticfx"], str(path)))

    def read(self, path: Path, device, *, rate_hz: float) -> Decoded:
        source = str(path)
        path = Path(path)
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise HapticFileError(f"cannot read: {exc.strerror}", source=source) from None
        if len(data) > MAX_BYTES:
            raise HapticFileError(f"{len(data)} bytes; at most {MAX_BYTES}", source=source)
        pages = _pages(data, source)
        try:
            (ident,), _ = _packets(pages, 1, 0)
            (comment,), _ = _packets(pages, 1, 1)
            comments = parse_comments(comment)
        except (ValueError, struct.error):
            raise HapticFileError(f"no Vorbis headers ({RULES}: an Ogg Vorbis file)", source=source) from None
        channels = ident[11] if len(ident) > 11 and ident[:7] == b"\x01vorbis" else 0
        tags = [c.split("=", 1)[1] for c in comments if c.split("=", 1)[0].upper() == TAG and "=" in c]
        if not tags:
            raise HapticFileError(f"no {TAG} comment: not an audio-coupled haptic file ({RULES}: the comment "
                                  f"{TAG}=N names the haptic channels)", source=source)
        try:
            count = int(tags[0])
        except ValueError:
            count = 0
        if not 1 <= count <= min(2, channels):
            raise HapticFileError(f"{TAG}={tags[0]!r} with {channels} channel(s) ({RULES}: 1 or 2 haptic channels, the "
                                  "file's last ones)", source=source)
        sf = _soundfile()
        try:
            samples, rate = sf.read(str(path), always_2d=True)
        except (RuntimeError, sf.LibsndfileError) as exc:
            raise HapticFileError(f"cannot decode: {exc}", source=source) from None
        haptic = np.clip(samples[:, -count:].mean(axis=1), -1.0, 1.0)  # a lossy decode overshoots full scale a little
        signal = Signal(haptic, float(rate))
        if rate != rate_hz:
            from ..shaping import resample

            signal = resample(signal, rate_hz)
        return Decoded(signal)
