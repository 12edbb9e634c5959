"""The protocol's pure parts: the on-time book and the reply parsers."""

from __future__ import annotations

import pytest

from hapticfx.errors import DeviceError
from hapticfx_solenoid.protocol import (
    DutyWindow, FirmwareLimits, FirmwareRefused, decode_line, fire_command, parse_fire_reply, parse_pong,
    parse_status,
)


def test_duty_window_never_allows_more_than_budget_in_any_window():
    window = DutyWindow(budget_ms=250, window_ms=1000)  # 25 % duty over 1 s, slots of 100 ms
    fired = []  # (start, length)
    for now in range(0, 10_000, 7):  # a host that fires 5 ms whenever the book allows
        if window.available_ms(now) >= 5:
            window.book(now, 5)
            fired.append((now, 5))
    for start in range(0, 9_000, 13):
        on = sum(length for t, length in fired if start <= t < start + 1000)
        assert on <= 250
    # and it is not absurdly strict: at least 10/11 of the budget is usable in the long run
    assert sum(length for _, length in fired) >= 0.9 * 250 * 10 * 10 / 11


def test_duty_window_frees_after_the_window_and_after_a_long_pause():
    window = DutyWindow(budget_ms=100, window_ms=1000)
    window.book(0, 100)
    assert window.available_ms(50) == 0
    assert window.available_ms(1099) == 0  # still inside the conservative 11 slots
    assert window.available_ms(1100) == 100
    window.book(1100, 60)
    assert window.available_ms(1_000_000) == 100


def test_limits_budget():
    assert FirmwareLimits().budget_ms == 2500
    assert FirmwareLimits(max_on_ms=50, duty_permille=5, window_ms=10_000).budget_ms == 50


def test_parsers_accept_the_documented_replies():
    assert parse_pong("PONG 1 hapticfx-solenoid/1.0") == (1, "hapticfx-solenoid/1.0")
    status = parse_status("STATUS on=0 used_ms=3 budget_ms=2500 max_on_ms=100 duty_permille=250 "
                          "window_ms=10000 fired=1 refused=0")
    assert status["used_ms"] == 3 and status["max_on_ms"] == 100
    assert parse_fire_reply("OK FIRE 30 200") == (30, 200)
    assert fire_command(30, 200) == "FIRE 30 200"


@pytest.mark.parametrize("line", ["PONG", "PONG x id", "HELLO 1 id", "PONG 1"])
def test_bad_pong_is_a_device_error(line):
    with pytest.raises(DeviceError, match="PONG"):
        parse_pong(line, source="/dev/ttyX")


def test_other_protocol_version_names_both_versions():
    with pytest.raises(DeviceError, match="protocol 2, this host speaks 1"):
        parse_pong("PONG 2 future-fw")


def test_refusal_carries_its_code():
    with pytest.raises(FirmwareRefused) as info:
        parse_fire_reply("ERR DUTY 12 ms left in window")
    assert info.value.code == "DUTY" and "12 ms" in str(info.value)


@pytest.mark.parametrize("raw", [b"\xfe\xffPONG\r\n", b"PO\x1bNG 1 x\r\n"])
def test_garbage_bytes_are_a_device_error(raw):
    with pytest.raises(DeviceError, match="not the hapticfx solenoid protocol"):
        decode_line(raw, source="/dev/ttyX")


@pytest.mark.parametrize("bad", [(0, 10), (70_000, 10), (5, 256), (5, -1)])
def test_fire_command_range(bad):
    with pytest.raises(ValueError):
        fire_command(*bad)


@pytest.mark.parametrize("line, expected", [
    ("OK FIRE 0 99999999999999999999", "FIRE reply 0 ms at duty 99999999999999999999 is outside"),
    ("OK FIRE 70000 10", "FIRE reply 70000 ms at duty 10 is outside"),
])
def test_fire_replies_out_of_range_are_device_errors(line, expected):
    with pytest.raises(DeviceError, match=expected):
        parse_fire_reply(line)


def test_status_with_impossible_values_is_a_device_error():
    good = "STATUS on=0 used_ms=0 budget_ms=2500 max_on_ms=100 duty_permille=250 window_ms=10000 fired=0 refused=0"
    assert parse_status(good)["window_ms"] == 10000
    with pytest.raises(DeviceError, match="STATUS window_ms=0 is outside 1..4294967295"):
        parse_status(good.replace("window_ms=10000", "window_ms=0"))
    with pytest.raises(DeviceError, match="STATUS duty_permille=5000 is outside 0..1000"):
        parse_status(good.replace("duty_permille=250", "duty_permille=5000"))
