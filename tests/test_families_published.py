"""Each impact family against the published quantities it must match (docs/families.md has the table)."""

from __future__ import annotations

import math

import pytest

from hapticfx.bench.families import checks

CHECKS = [c for c in checks() if not math.isnan(c.low)]


def test_every_family_is_checked_against_something_or_says_it_is_not():
    families = {c.family for c in checks()}
    assert {"bat_ball", "football_kick", "wheel_bump", "tapping_rubber", "tapping_wood", "tapping_aluminium"} <= families


@pytest.mark.parametrize("check", CHECKS, ids=lambda c: f"{c.family}: {c.quantity}")
def test_the_family_stays_in_its_published_range(check):
    value = check.measure(None)
    assert check.low <= value <= check.high, f"{check.family}: {check.quantity} = {value:.4g}, published " \
        f"range {check.low:g} to {check.high:g} ({check.source})"
