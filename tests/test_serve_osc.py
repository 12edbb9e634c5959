"""The OSC decoder and the bridge's drop accounting (no engine: a recording submit)."""

from __future__ import annotations

import random
import re
import socket
import struct
import time
from pathlib import Path

import pytest
from pythonosc.osc_bundle_builder import IMMEDIATELY, OscBundleBuilder
from pythonosc.osc_message_builder import OscMessageBuilder

from hapticfx.errors import EffectError
from hapticfx.osc import (
    DROP_REASONS, IMPACT_ADDRESS, ImpactMessage, OscBridge, OscDecodeError, TokenBucket, decode_message,
    parse_impact,
)


def osc(address: str, *args) -> bytes:
    """A datagram built by python-osc (the other implementation on the wire)."""
    b = OscMessageBuilder(address)
    for a in args:
        if isinstance(a, tuple):
            b.add_arg(a[0], a[1])
        else:
            b.add_arg(a)
    return b.build().dgram


def test_decode_matches_python_osc_for_every_documented_form():
    cases = [
        (("brick", (3.8, "f")), "sf"),
        (("brick", (3.8, "d")), "sd"),
        (("brick", (4, "i")), "si"),
        (("brick", (3.8, "f"), (2, "i")), "sfi"),
        (("brick", (3.8, "f"), (-1, "i"), (12.5, "d")), "sfid"),
    ]
    for args, tags in cases:
        address, got_tags, got = decode_message(osc(IMPACT_ADDRESS, *args))
        assert address == IMPACT_ADDRESS and got_tags == tags
        assert got[0] == "brick"
        msg = parse_impact(got_tags, got)
        assert msg.object == "brick" and msg.velocity == pytest.approx(float(args[1][0]), rel=1e-6)
    assert parse_impact("sfi", ["a", 1.0, 2]).channel == 2
    assert parse_impact("sfi", ["a", 1.0, -1]).channel is None
    assert parse_impact("sfif", ["a", 1.0, -1, 7.0]) == ImpactMessage("a", 1.0, None, 7.0)


@pytest.mark.parametrize("data, reason", [
    (b"", "not_osc"),
    (b"abc", "not_osc"),
    (b"hello world!", "not_osc"),                       # no leading '/'
    (b"/abc", "not_osc"),                               # no NUL terminator
    (b"/ab\x00,s\x00\x00", "not_osc"),                  # string argument missing
    (b"/ab\x00,f\x00\x00\x00\x00", "not_osc"),           # float cut short
    (b"/ab\x00\x00\x00\x00\x00", "not_osc"),            # type tags not starting with ','
    (b"/a\xff\x00,\x00\x00\x00", "not_osc"),            # address not UTF-8
    (b"/ab\x00,\x00\x00\x00\x00\x00\x00\x00", "not_osc"),  # trailing bytes
    (b"/a\x00\x01,\x00\x00\x00", "not_osc"),            # non-zero padding
])
def test_decode_rejects_what_is_not_osc(data, reason):
    with pytest.raises(OscDecodeError) as err:
        decode_message(data)
    assert err.value.reason == reason


def test_bundle_is_its_own_reason():
    b = OscBundleBuilder(IMMEDIATELY)
    b.add_content(OscMessageBuilder(IMPACT_ADDRESS).build())
    with pytest.raises(OscDecodeError) as err:
        decode_message(b.build().dgram)
    assert err.value.reason == "bundle"


@pytest.mark.parametrize("tags, args, reason", [
    ("s", ["a"], "wrong_types"),
    ("fs", [1.0, "a"], "wrong_types"),
    ("sfs", ["a", 1.0, "x"], "wrong_types"),
    ("sT", None, "wrong_types"),
    ("sf", ["a", -0.1], "bad_value"),
    ("sf", ["a", float("nan")], "bad_value"),
    ("sd", ["a", float("inf")], "bad_value"),
    ("sd", ["a", 1.7e308], "bad_value"),  # once an OverflowError traceback in the contact model
    ("sf", ["a", 100.5], "bad_value"),
    ("sfi", ["a", 1.0, -2], "bad_value"),
    ("sfid", ["a", 1.0, 0, float("nan")], "bad_value"),
    ("sfid", ["a", 1.0, 0, 1e305], "bad_value"),  # once an OverflowError traceback in the WAV output
    ("sfidddd", ["a", 1.0, -1, 0.0, -1e160, 0.0, 0.0], "bad_value"),  # played on two sites whatever its direction
])
def test_parse_impact_rejects(tags, args, reason):
    with pytest.raises(OscDecodeError) as err:
        parse_impact(tags, args)
    assert err.value.reason == reason


def test_unknown_type_tag_is_wrong_types_on_our_address():
    data = b"/hapticfx/impact\x00\x00\x00\x00,sT\x00a\x00\x00\x00"
    address, tags, args = decode_message(data)
    assert (address, tags, args) == (IMPACT_ADDRESS, "sT", None)


def test_random_bytes_never_raise_anything_but_decode_errors():
    rng = random.Random(7)
    good = osc(IMPACT_ADDRESS, "concrete-brick", (3.8, "f"), (1, "i"))
    for _ in range(20000):
        data = bytearray(good)
        for _ in range(rng.randint(1, 4)):
            data[rng.randrange(len(data))] = rng.randrange(256)
        try:
            address, tags, args = decode_message(bytes(data))
            if address == IMPACT_ADDRESS:
                parse_impact(tags, args)
        except OscDecodeError as exc:
            assert exc.reason in DROP_REASONS


def test_token_bucket():
    now = [0.0]
    bucket = TokenBucket(10.0, 5, clock=lambda: now[0])
    assert sum(bucket.take() for _ in range(20)) == 5
    now[0] += 0.3  # three tokens back
    assert sum(bucket.take() for _ in range(20)) == 3
    assert all(TokenBucket(0, 1).take() for _ in range(1000))


class Recorder:
    """A submit callable that records messages; ``full`` makes it refuse like a full queue."""

    def __init__(self):
        self.messages = []
        self.full = False

    def __call__(self, message, received_at):
        if self.full:
            return False
        if message.object == "refuse":
            raise EffectError("refused on purpose")
        self.messages.append(message)
        return True


def test_bridge_counts_every_reason_over_a_real_socket():
    rec = Recorder()
    bridge = OscBridge(rec, {"brick", "refuse"}, port=0, max_datagram=128, rate_hz=0)
    sent = {
        None: [osc(IMPACT_ADDRESS, "brick", (3.0, "f"))],
        "oversize": [osc(IMPACT_ADDRESS, "x" * 200, (3.0, "f"))],
        "not_osc": [b"garbage!", b""],
        "bundle": [b"#bundle\x00" + bytes(8)],
        "wrong_address": [osc("/other", "brick", (3.0, "f"))],
        "wrong_types": [osc(IMPACT_ADDRESS, "brick")],
        "bad_value": [osc(IMPACT_ADDRESS, "brick", (-3.0, "f"))],
        "unknown_object": [osc(IMPACT_ADDRESS, "anvil", (3.0, "f"))],
        "engine_refused": [osc(IMPACT_ADDRESS, "refuse", (3.0, "f"))],
    }
    total = sum(len(v) for v in sent.values())
    with bridge:
        host, port = bridge.address
        assert host == "127.0.0.1"
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:
            for datagrams in sent.values():
                for d in datagrams:
                    client.sendto(d, (host, port))
            deadline = time.monotonic() + 5
            while bridge.stats()["received"] < total and time.monotonic() < deadline:
                time.sleep(0.01)
        stats = bridge.stats()
    assert stats["received"] == total
    assert stats["accepted"] == 1 and rec.messages == [ImpactMessage("brick", 3.0)]
    for reason, datagrams in sent.items():
        if reason:
            assert stats["dropped"][reason] == len(datagrams), reason
    assert stats["received"] == stats["accepted"] + stats["dropped_total"]
    assert stats["kernel_dropped"] == 0


def test_bridge_rate_limit_and_queue_full_are_counted():
    rec = Recorder()
    bridge = OscBridge(rec, {"brick"}, port=0, rate_hz=1.0, burst=3)
    good = osc(IMPACT_ADDRESS, "brick", (3.0, "f"))
    reasons = [bridge.handle(good, 0.0) for _ in range(10)]
    assert reasons.count(None) == 3 and reasons.count("rate_limited") == 7
    rec.full = True
    bridge.bucket = TokenBucket(0, 1)
    assert bridge.handle(good, 0.0) == "queue_full"
    stats = bridge.stats()
    assert stats["received"] == 11 and stats["accepted"] == 3
    assert stats["dropped"]["rate_limited"] == 7 and stats["dropped"]["queue_full"] == 1
    bridge.stop()


def test_a_bundle_takes_a_token_for_each_of_its_messages():
    """A bundle of 21 impacts took one token: a bundle flood got past the rate (22,000 messages a second
    against 2,000) and held impacts back by seconds."""
    rec = Recorder()
    bridge = OscBridge(rec, {"brick"}, port=0, rate_hz=1.0, burst=5)
    full = _bundle(1, *[osc(IMPACT_ADDRESS, "brick", (3.0, "f"))] * 21)
    assert bridge.handle(full, 0.0) == "rate_limited"  # the first of its drops
    stats = bridge.stats()
    assert (stats["received"], stats["accepted"], stats["dropped"]["rate_limited"]) == (21, 5, 16)
    assert len(rec.messages) == 5 and bridge.handle(full, 0.0) == "rate_limited"
    bridge.stop()


def test_port_in_use_is_a_clear_device_error():
    from hapticfx.errors import DeviceError

    first = OscBridge(Recorder(), set(), port=0)
    try:
        with pytest.raises(DeviceError, match="cannot listen for OSC on 127.0.0.1:"):
            OscBridge(Recorder(), set(), port=first.address[1])
    finally:
        first.stop()


def test_struct_layout_of_a_hand_built_message():
    # Independent of both implementations: the bytes OSC 1.0 prescribes.
    data = b"/hapticfx/impact\x00\x00\x00\x00" + b",sf\x00" + b"brick\x00\x00\x00" + struct.pack(">f", 2.5)
    assert parse_impact(*decode_message(data)[1:]) == ImpactMessage("brick", 2.5)


def test_encode_impact_is_the_datagram_python_osc_builds():
    from pythonosc.osc_message_builder import OscMessageBuilder

    from hapticfx.osc import decode_message, encode_impact, parse_impact

    b = OscMessageBuilder("/hapticfx/impact")
    b.add_arg("concrete-brick")
    b.add_arg(3.8, "f")
    assert encode_impact("concrete-brick", 3.8) == b.build().dgram
    assert parse_impact(*decode_message(encode_impact("wood-beam", 2.5))[1:]).object == "wood-beam"


@pytest.mark.parametrize("scene", sorted(str(p) for p in Path(__file__).resolve().parents[1].glob("scenes/*.yaml")))
def test_every_shipped_scene_takes_an_impact_on_channel_0(scene):
    """docs/protocol.md's example and a Unity client send channel 0; no shipped scene sets one."""
    from hapticfx.engine import Engine
    from hapticfx.osc import ImpactMessage

    with Engine(scene, device="memory") as engine:
        assert engine.submit(ImpactMessage(engine.objects[0], 3.0, channel=0), 0.0)
    assert engine.stats()["rendered"] == 1


# --- protocol version 2: where on the head, and the engine's time ----------------------------------


def _bundle(timetag, *elements: bytes) -> bytes:
    body = b"".join(struct.pack(">i", len(e)) + e for e in elements)
    return b"#bundle\x00" + struct.pack(">Q", timetag) + body


def test_version_2_forms_carry_point_and_normal():
    data = osc(IMPACT_ADDRESS, "brick", (3.8, "f"), (-1, "i"), (12.5, "d"), *[(v, "f") for v in (0.0, 0.0, 0.13)],
               *[(v, "d") for v in (0.0, 0.0, 2.0)])
    msg = parse_impact(*decode_message(data)[1:])
    assert msg == ImpactMessage("brick", pytest.approx(3.8), None, 12.5, pytest.approx((0.0, 0.0, 0.13)), (0.0, 0.0, 2.0))
    point_only = parse_impact("sfidfff", ["a", 1.0, 0, 2.0, 0.1, 0.0, 0.0])
    assert point_only.channel == 0 and point_only.point == (0.1, 0.0, 0.0) and point_only.normal is None
    from hapticfx.osc import encode_impact
    assert parse_impact(*decode_message(encode_impact("a", 2.0, None, 1.5, (0.1, 0.2, 0.3), (0, 0, 1)))[1:]) == \
        ImpactMessage("a", 2.0, None, 1.5, pytest.approx((0.1, 0.2, 0.3)), (0.0, 0.0, 1.0))


@pytest.mark.parametrize("tags, args, reason", [
    ("sfidff", ["a", 1.0, 0, 2.0, 0.1, 0.0], "wrong_types"),            # a point of two numbers
    ("sfiffffffff", ["a", 1.0, 0, 2.0] + [0.0] * 6 + [1.0], "wrong_types"),  # one number too many
    ("sfidfff", ["a", 1.0, 0, 2.0, 0.1, float("nan"), 0.0], "bad_value"),
    ("sfidffffff", ["a", 1.0, 0, 2.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0], "bad_value"),  # a zero normal
    ("sfidffffff", ["a", 1.0, 0, 2.0, 0.1, 0.0, 0.0, float("inf"), 0.0, 1.0], "bad_value"),
])
def test_version_2_bad_points(tags, args, reason):
    with pytest.raises(OscDecodeError) as err:
        parse_impact(tags, args)
    assert err.value.reason == reason


def test_bundle_timetag_is_the_engine_time_unless_the_message_has_its_own():
    rec = Recorder()
    bridge = OscBridge(rec, {"brick"}, port=0, rate_hz=0)
    try:
        tt = ((7 + 2_208_988_800) << 32) | (1 << 31)  # 7.5 s after 1970, in NTP's count from 1900
        plain = osc(IMPACT_ADDRESS, "brick", (3.0, "f"))
        timed = osc(IMPACT_ADDRESS, "brick", (4.0, "f"), (-1, "i"), (2.25, "d"))
        assert bridge.handle(_bundle(tt, plain, timed), 0.0) is None
        # python-osc's bundle builder on the wire too, nested one level, 'immediately' gives no time
        inner = OscBundleBuilder(IMMEDIATELY)
        inner.add_content(_msg(IMPACT_ADDRESS, "brick", (5.0, "f")))
        assert bridge.handle(_bundle(tt, inner.build().dgram), 0.0) is None
        assert [(m.velocity, m.at) for m in rec.messages] == [(3.0, 7.5), (4.0, 2.25), (5.0, None)]
        stamped = OscBundleBuilder(20.25)  # python-osc writes a time t as NTP; it comes back as t
        stamped.add_content(_msg(IMPACT_ADDRESS, "brick", (6.0, "f")))
        assert bridge.handle(stamped.build().dgram, 0.0) is None and rec.messages[-1].at == pytest.approx(20.25, abs=1e-6)
        # a bundle with one good and one bad message: each is counted
        assert bridge.handle(_bundle(tt, plain, osc(IMPACT_ADDRESS, "anvil", (3.0, "f"))), 0.0) == "unknown_object"
        stats = bridge.stats()
        assert stats["received"] == 6 and stats["accepted"] == 5 and stats["dropped"]["unknown_object"] == 1
        deep = plain
        for _ in range(6):
            deep = _bundle(tt, deep)
        assert bridge.handle(deep, 0.0) == "bundle"
    finally:
        bridge.stop()


def _msg(address, *args):
    b = OscMessageBuilder(address)
    for a in args:
        b.add_arg(*a) if isinstance(a, tuple) else b.add_arg(a)
    return b.build()


def test_a_bundle_nested_too_deep_drops_only_what_is_below_the_limit():
    """Six levels of python-osc bundles, an impact at each: the whole datagram was one `bundle` drop, and the
    five impacts within the four levels allowed were lost with the sixth."""
    inner = None
    for level in reversed(range(6)):  # level 0 is the datagram's own bundle, level 5 is one too deep
        bundle = OscBundleBuilder(IMMEDIATELY)
        bundle.add_content(_msg(IMPACT_ADDRESS, "brick", (float(level + 1), "f")))
        if inner is not None:
            bundle.add_content(inner)
        inner = bundle.build()
    rec = Recorder()
    with OscBridge(rec, {"brick"}, port=0, rate_hz=0) as bridge:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:
            client.sendto(inner.dgram, bridge.address)
            deadline = time.monotonic() + 5
            while bridge.stats()["received"] < 6 and time.monotonic() < deadline:
                time.sleep(0.01)
        stats = bridge.stats()
    assert [m.velocity for m in rec.messages] == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert (stats["received"], stats["accepted"], stats["dropped"]["bundle"], stats["dropped_total"]) == (6, 5, 1, 1)


@pytest.mark.parametrize("setting, said", [
    ({"burst": float("inf")}, "burst must be a whole number"),  # the receiver thread died at the first datagram
    ({"rate_hz": float("nan")}, "rate_hz must be a number in [0, 1e+09]"),  # the rate limit was off
    ({"rate_hz": -5}, "rate_hz must be a number in [0, 1e+09]"),  # off as well (0 is the documented 'off')
    ({"max_datagram": -1}, "max_datagram must be a whole number in [16, 65507]"),  # every datagram oversize
    ({"port": "9000"}, "port must be a whole number in [0, 65535]"),  # a bare TypeError
    ({"host": None}, "host must be an address"),
])
def test_bridge_settings_outside_what_a_scene_allows_are_refused(setting, said):
    from hapticfx.errors import HapticfxError
    from hapticfx.osc import OscBridge

    with pytest.raises(HapticfxError, match=re.escape(said)):
        OscBridge(lambda message, received: True, {"a"}, **{"port": 0, **setting})
