"""Where on the head: a helmet's actuators and the spatialiser that spreads an impact over them.

A scene's ``head`` places actuators (sites) on the head, in the head frame of
docs/protocol.md (metres; x right, y forward, z up, origin at the head's
centre), one output channel each. :class:`Spatialiser` turns an impact's
contact point (or, without one, its normal; or the channel it names) into a
gain and an onset delay per site:

- the two sites nearest the contact, by the angle between their directions
  from the head's centre, carry the impact; the others stay silent;
- the contact is projected on the great circle through those two sites; when
  it falls beyond the nearest (not between them), that site carries it alone;
- between them, energy-preserving panning: with ``beta = a1 / (a1 + a2)`` (the
  angles along that circle to the nearest and the second-nearest site), the gains are
  ``sqrt(1 - beta)`` and ``sqrt(beta)``, so ``g1**2 + g2**2 == 1`` and a point
  halfway between two sites is felt between them at -3 dB on each: the
  phantom sensation of Israr and Poupyrev's Tactile Brush (CHI 2011), whose
  energy model sets the intensities ``A1 = sqrt(1 - beta) Av``, ``A2 = sqrt(beta) Av``;
- a contact on a site plays on that site alone, at gain 1;
- onset delays (optional, ``wave_speed_mps``): the farther site starts later by
  the extra distance over the head's surface divided by that speed; without a
  speed both start together, as Tactile Brush's phantom needs.

A scene without ``head`` has no spatialiser: one actuator, as in the paper, and
impacts play exactly as they did before contact points existed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import EffectError, preview

CROWN = (0.0, 0.0, 1.0)
ON_SITE_RAD = 1e-6  # a contact closer than this (angle) to a site plays on it alone


@dataclass(frozen=True)
class Site:
    """One actuator on the head: its name, position (head frame, m) and output channel."""

    name: str
    position: tuple[float, float, float]
    channel: int


@dataclass(frozen=True)
class HeadLayout:
    """A scene's ``head``: which scene actuator the sites are channels of, the sites, and the onset model."""

    actuator: str
    sites: tuple[Site, ...]
    wave_speed_mps: float | None = None


@dataclass(frozen=True)
class Placement:
    """One site's share of an impact: ``gain`` (amplitude) and ``delay_s`` (onset after the earliest site)."""

    site: int
    gain: float
    delay_s: float


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


class Spatialiser:
    """Gains and onset delays per site for a contact on the head (see the module's docstring)."""

    def __init__(self, layout: HeadLayout):
        self.layout = layout
        self.directions = np.array([_unit(s.position) for s in layout.sites])
        self.radii = np.array([float(np.linalg.norm(s.position)) for s in layout.sites])
        self.by_channel = {s.channel: i for i, s in enumerate(layout.sites)}
        # Without a point, normal or channel: the site nearest the crown (where the paper's actuator sits).
        self.default_site = int(np.argmax(self.directions @ np.array(CROWN)))

    def place(self, point=None, normal=None, channel: int | None = None) -> list[Placement]:
        """The sites that carry an impact at ``point`` (else in the direction ``normal``; else on the site
        of ``channel``; else on the default site), loudest first."""
        where = point if point is not None and np.linalg.norm(point) > 0 else normal
        if where is None:
            site = self.by_channel.get(channel, self.default_site) if channel is not None else self.default_site
            return [Placement(site, 1.0, 0.0)]
        d = _unit(where)
        angles = np.arccos(np.clip(self.directions @ d, -1.0, 1.0))
        order = np.argsort(angles, kind="stable")
        first = int(order[0])
        if len(order) == 1 or angles[first] < ON_SITE_RAD:
            return [Placement(first, 1.0, 0.0)]
        second = int(order[1])
        a1, a2 = self._along_arc(d, first, second, float(angles[first]), float(angles[second]))
        if a1 is None:  # beyond the nearest site, not between the two: that site alone
            return [Placement(first, 1.0, 0.0)]
        beta = a1 / (a1 + a2)
        delay = 0.0
        speed = self.layout.wave_speed_mps
        if speed:
            radius = float(np.linalg.norm(point)) if point is not None else float(self.radii[[first, second]].mean())
            delay = radius * (a2 - a1) / speed
        return [Placement(first, math.sqrt(1.0 - beta), 0.0), Placement(second, math.sqrt(beta), delay)]


    def spread(self, samples: np.ndarray, rate_hz: float, placements: list[Placement]) -> np.ndarray:
        """One row per site (sites x samples): each placed site gets ``samples`` times its gain after its onset
        delay; every row has one length (the longest delay's), silent where the impact does not reach."""
        shifts = [int(round(p.delay_s * rate_hz)) for p in placements]
        n = samples.shape[-1]
        out = np.zeros((len(self.layout.sites), n + max(shifts)))
        for p, shift in zip(placements, shifts):
            out[p.site, shift:shift + n] = samples if p.gain == 1.0 else p.gain * samples
        return out

    def _along_arc(self, d: np.ndarray, first: int, second: int, a1: float, a2: float):
        """The angles from the two sites to ``d`` projected on the great circle through them; (None, None) when
        the projection falls outside the arc between them (the contact is beyond the nearest site)."""
        u1, u2 = self.directions[first], self.directions[second]
        axis = np.cross(u1, u2)
        norm = float(np.linalg.norm(axis))
        if norm < 1e-9:  # opposite sites: every great circle joins them; the angles themselves
            return a1, a2
        axis /= norm
        on = d - (d @ axis) * axis
        if np.linalg.norm(on) < 1e-9:  # the contact is a pole of that circle: as far from both
            return a1, a2
        on = _unit(on)
        p1 = float(np.arccos(np.clip(on @ u1, -1.0, 1.0)))
        p2 = float(np.arccos(np.clip(on @ u2, -1.0, 1.0)))
        span = float(np.arccos(np.clip(u1 @ u2, -1.0, 1.0)))
        if p1 + p2 > span + 1e-9:
            return None, None
        return p1, p2


HEAD_KEYS = ("actuator", "sites", "wave_speed_mps")
SITE_KEYS = ("position", "channel")


def parse_head(raw, *, source: str, actuators) -> HeadLayout:
    """Validate a scene's ``head`` mapping (``actuators``: the scene's actuator names)."""
    def fail(key: str, text: str):
        raise EffectError(text, source=source, key=key)

    if not isinstance(raw, dict):
        fail("head", f"expected a mapping with {', '.join(HEAD_KEYS)}, got {preview(raw)}")
    unknown = [k for k in raw if k not in HEAD_KEYS]
    if unknown:
        fail("head", f"unknown key {preview(unknown[0])}; allowed: {', '.join(HEAD_KEYS)}")
    name = raw.get("actuator")
    if name not in actuators:
        fail("head.actuator", f"expected the name of a scene actuator ({', '.join(actuators) or 'none'}), got {preview(name)}")
    speed = raw.get("wave_speed_mps")
    if speed is not None and (isinstance(speed, bool) or not isinstance(speed, (int, float))
                              or not math.isfinite(speed) or speed <= 0):
        fail("head.wave_speed_mps", f"expected a speed > 0 in m/s (or no key: simultaneous onsets), got {preview(speed)}")
    sites_raw = raw.get("sites")
    if not isinstance(sites_raw, dict) or not sites_raw:
        fail("head.sites", f"expected a non-empty mapping of site name -> {{position, channel}}, got {preview(sites_raw)}")
    sites, channels, directions = [], set(), []
    for sname, site in sites_raw.items():
        key = f"head.sites.{sname}"
        if not isinstance(site, dict) or sorted(site) != sorted(SITE_KEYS):
            fail(key, f"expected a mapping with exactly {', '.join(SITE_KEYS)}, got {preview(site)}")
        pos = site["position"]
        if (not isinstance(pos, list) or len(pos) != 3 or any(isinstance(c, bool) or not isinstance(c, (int, float))
                                                               or not math.isfinite(c) for c in pos)):
            fail(f"{key}.position", f"expected [x, y, z] in metres (head frame), got {preview(pos)}")
        if math.hypot(*pos) < 1e-3:
            fail(f"{key}.position", "a site at the head's centre has no direction; give its place on the surface")
        channel = site["channel"]
        if isinstance(channel, bool) or not isinstance(channel, int) or channel < 0:
            fail(f"{key}.channel", f"expected a channel number >= 0, got {preview(channel)}")
        if channel in channels:
            fail(f"{key}.channel", f"channel {channel} is taken by another site: one actuator per channel")
        direction = _unit(pos)
        if any(float(direction @ d) > math.cos(ON_SITE_RAD) for d in directions):
            fail(f"{key}.position", "another site points the same way from the head's centre")
        channels.add(channel)
        directions.append(direction)
        sites.append(Site(str(sname), tuple(float(c) for c in pos), channel))
    return HeadLayout(name, tuple(sites), None if speed is None else float(speed))


__all__ = ["HeadLayout", "Placement", "Site", "Spatialiser", "parse_head"]
