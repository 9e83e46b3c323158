"""Motion programs for the two-axis rate table, and their servo commands.

A program is a list of segments, each with its own duration. A segment sets the tilt angle (the
outer axis, position servo) and the turntable rate (the inner axis, rate servo). The commands are
built at the physics rate; the truth is what MuJoCo's sensors read, never these commands.

Segment kinds (SI units inside; the scenario file uses deg, deg/s, s, Hz):

- ``Hold``: the turntable at rest, the tilt at ``tilt``.
- ``ConstantRate``: the turntable at ``rate``.
- ``RateSteps``: a sequence of turntable rates, ``step_duration`` each.
- ``SineRate``: turntable rate ``offset + amplitude sin(2 pi f t)``.
- ``Positions``: every (tilt, heading) pair in order, dwelling ``dwell`` at each; the turntable
  moves between headings with a trapezoidal rate profile whose integral is the heading change.

A change of tilt at the start of a segment is a smooth (raised-cosine) move at the table's slew
rate, inside that segment's duration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Hold", "ConstantRate", "RateSteps", "SineRate", "Positions", "Segment",
           "Commands", "build_commands", "program_duration"]


@dataclass(frozen=True)
class Hold:
    duration: float            # s
    tilt: float | None = None  # rad; None keeps the previous tilt
    kind: str = field(default="hold", init=False)


@dataclass(frozen=True)
class ConstantRate:
    duration: float
    rate: float                # rad/s
    tilt: float | None = None
    kind: str = field(default="rate", init=False)


@dataclass(frozen=True)
class RateSteps:
    rates: tuple[float, ...]   # rad/s
    step_duration: float       # s
    tilt: float | None = None
    kind: str = field(default="rate_steps", init=False)

    @property
    def duration(self) -> float:
        return self.step_duration * len(self.rates)


@dataclass(frozen=True)
class SineRate:
    duration: float
    amplitude: float           # rad/s
    frequency: float           # Hz
    offset: float = 0.0        # rad/s
    tilt: float | None = None
    kind: str = field(default="sine", init=False)


@dataclass(frozen=True)
class Positions:
    tilts: tuple[float, ...]     # rad
    headings: tuple[float, ...]  # rad, turntable angle relative to the start of the segment
    dwell: float                 # s at each position, after the move
    move_time: float             # s allowed for each move (tilt and heading), before the dwell
    max_rate: float = math.radians(30.0)    # rad/s, turntable move rate
    max_accel: float = math.radians(60.0)   # rad/s^2, turntable move acceleration
    tilt: float | None = None
    kind: str = field(default="positions", init=False)

    @property
    def duration(self) -> float:
        return len(self.tilts) * len(self.headings) * (self.move_time + self.dwell)

    def pairs(self) -> list[tuple[float, float]]:
        return [(t, h) for t in self.tilts for h in self.headings]


Segment = Hold | ConstantRate | RateSteps | SineRate | Positions


def program_duration(segments) -> float:
    """Total duration of a program, s."""
    return float(sum(s.duration for s in segments))


@dataclass(frozen=True)
class Commands:
    """Servo commands at the physics rate.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Time of each physics step from the start of the program, s.
    tilt : ndarray, shape (n,)
        Tilt position command, rad.
    turn_rate : ndarray, shape (n,)
        Turntable rate command, rad/s.
    """

    t: np.ndarray
    tilt: np.ndarray
    turn_rate: np.ndarray


def _smooth_move(t, start, end, duration):
    """Raised-cosine move from start to end over duration (t from 0); holds end after."""
    if duration <= 1e-9 or start == end:
        return np.full_like(t, end)
    s = np.clip(t / duration, 0.0, 1.0)
    return start + (end - start) * 0.5 * (1.0 - np.cos(np.pi * s))


def _trapezoid_rate(t, delta, max_rate, max_accel):
    """Rate profile (starting at t=0) whose integral is exactly ``delta`` rad."""
    if delta == 0:
        return np.zeros_like(t), 0.0
    d = abs(delta)
    v = min(max_rate, math.sqrt(d * max_accel))     # triangular profile if too short
    ta = v / max_accel
    tc = d / v - ta                                 # cruise time (>= 0)
    total = 2 * ta + tc
    r = np.where(t < ta, max_accel * t,
                 np.where(t < ta + tc, v, np.maximum(0.0, v - max_accel * (t - ta - tc))))
    r = np.where(t >= total, 0.0, r)
    return math.copysign(1.0, delta) * r, total


def tilt_move_time(delta: float, slew: float) -> float:
    """Time of a raised-cosine tilt move of ``delta`` rad whose peak rate is ``slew`` rad/s."""
    return 0.0 if delta == 0 else math.pi * abs(delta) / (2.0 * slew)


def _blend_from(t, rate, previous, accel):
    """Start ``rate`` from ``previous`` with a linear ramp at ``accel`` rad/s^2 (fading offset)."""
    if rate.size == 0 or previous == rate[0]:
        return rate
    ramp = abs(previous - rate[0]) / accel
    return rate + (previous - rate[0]) * np.clip(1.0 - t / ramp, 0.0, 1.0)


def segment_commands(seg, dt: float, tilt_before: float, tilt_slew: float, n: int | None = None,
                     rate_before: float = 0.0, turn_accel: float = math.radians(200.0)
                     ) -> tuple[np.ndarray, np.ndarray, float]:
    """Tilt command (rad) and turntable rate command (rad/s) for one segment at physics step dt.

    Returns the first ``n`` steps (all of the segment when None) and the tilt after the segment.
    A change of turntable rate (from ``rate_before`` at the segment start, and between the steps
    of ``RateSteps``) is a ramp at ``turn_accel`` rad/s^2, as a table's controller limits it.
    """
    n_all = int(round(seg.duration / dt))
    n = n_all if n is None else min(n, n_all)
    t = np.arange(n) * dt
    tilt = tilt_before
    target = tilt if seg.tilt is None else seg.tilt
    tilt_cmd = _smooth_move(t, tilt, target, tilt_move_time(target - tilt, tilt_slew))
    tilt = target
    if isinstance(seg, Hold):
        rate = np.zeros(n)
    elif isinstance(seg, ConstantRate):
        rate = np.full(n, seg.rate)
    elif isinstance(seg, RateSteps):
        levels = np.asarray(seg.rates, dtype=float)
        idx = np.minimum((t / seg.step_duration).astype(int), len(levels) - 1)
        rate = levels[idx]
        for i in range(1, len(levels)):
            a = int(round(i * seg.step_duration / dt))
            if a < n:
                rate[a:] = _blend_from(t[a:] - t[a], rate[a:], levels[i - 1], turn_accel)
    elif isinstance(seg, SineRate):
        rate = seg.offset + seg.amplitude * np.sin(2 * np.pi * seg.frequency * t)
    elif isinstance(seg, Positions):
        rate = np.zeros(n)
        tilt_cmd = np.empty(n)
        heading = 0.0
        period = seg.move_time + seg.dwell
        for i, (pt, ph) in enumerate(seg.pairs()):
            sl = slice(min(n, int(round(i * period / dt))), min(n, int(round((i + 1) * period / dt))))
            tt = t[sl] - i * period
            tilt_cmd[sl] = _smooth_move(tt, tilt, pt, tilt_move_time(pt - tilt, tilt_slew))
            rate[sl], _ = _trapezoid_rate(tt, ph - heading, seg.max_rate, seg.max_accel)
            tilt, heading = pt, ph
    else:  # pragma: no cover - the loader only builds the kinds above
        raise TypeError(f"unknown motion segment {seg!r}")
    rate = _blend_from(t, rate, rate_before, turn_accel)
    return tilt_cmd, rate, tilt


def build_commands(segments, dt: float, tilt0: float = 0.0, tilt_slew: float = math.radians(20.0)
                   ) -> Commands:
    """Servo commands for a whole motion program at physics step ``dt`` (s).

    ``tilt0`` is the tilt the table starts at (rad), ``tilt_slew`` the peak tilt rate of a move
    (rad/s). For long programs prefer ``segment_commands``, segment by segment.
    """
    tilts, rates = [], []
    tilt, last = tilt0, 0.0
    for seg in segments:
        c, r, tilt = segment_commands(seg, dt, tilt, tilt_slew, rate_before=last)
        last = float(r[-1]) if r.size else last
        tilts.append(c)
        rates.append(r)
    tilt_all, rate_all = np.concatenate(tilts), np.concatenate(rates)
    return Commands(np.arange(tilt_all.size) * dt, tilt_all, rate_all)


def positions_move_fits(seg: Positions, tilt_before: float, tilt_slew: float) -> str | None:
    """None when every move of a Positions segment fits in its move_time, else a message."""
    tilt, heading = tilt_before, 0.0
    for pt, ph in seg.pairs():
        need_t = tilt_move_time(pt - tilt, tilt_slew)
        _, need_h = _trapezoid_rate(np.zeros(1), ph - heading, seg.max_rate, seg.max_accel)
        need = max(need_t, need_h)
        if need > seg.move_time + 1e-9:
            return (f"moving to tilt {math.degrees(pt):g} deg, heading {math.degrees(ph):g} deg "
                    f"takes {need:.2f} s, more than move_s = {seg.move_time:g} allows")
        tilt, heading = pt, ph
    return None
