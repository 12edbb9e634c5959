"""RateLimitedLog: the first event at once, then at most one line per key and interval, with a count."""

from __future__ import annotations

import logging

from hapticfx.ratelog import RateLimitedLog


def test_repeats_are_counted_and_reported_with_the_next_line(caplog):
    now = [0.0]
    rl = RateLimitedLog(logging.getLogger("t"), interval_s=5.0, clock=lambda: now[0])
    with caplog.at_level("WARNING", logger="t"):
        for i in range(100):
            now[0] = i * 0.1  # 10 s in all
            rl.event("queue_full", f"dropped {i}")
            rl.event("other", "other")
        rl.flush()
    lines = [r.getMessage() for r in caplog.records]
    assert lines[0] == "dropped 0" and lines[1] == "other"
    assert lines[2] == "dropped 50 (49 more like it in the last 5 s were not logged)"
    assert lines[-2:] == ["dropped 99 (and 49 more like it, not logged)", "other (and 49 more like it, not logged)"]
    assert len(lines) == 6
    rl.flush()  # nothing held back: nothing more
    assert len(caplog.records) == 6


def test_only_the_first_line_of_a_key_carries_a_traceback(caplog):
    rl = RateLimitedLog(logging.getLogger("t"), interval_s=0.0)
    with caplog.at_level("WARNING", logger="t"):
        for _ in range(3):
            rl.event("bug", "a bug", exc_info=ValueError("x"))
    assert [bool(r.exc_info) for r in caplog.records] == [True, False, False]
