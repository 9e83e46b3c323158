"""What a calibration lab knows of its rate table, and the references it computes from it.

A lab has neither the true rate at the sensor nor the true specific force (``sim.rate_table.Truth``
holds both, for scoring). It has the table's commands (or its encoders), the latitude and heading
it believes, the mounting radius it measured and the local gravity. :func:`lab_reference` computes
from those, and from nothing else of the truth, what a lab hands a calibration as its reference:

* the rate about each sensor axis: the commanded turntable rate (about the platform normal, the
  sensor's z), the commanded tilt rate (about the tilt axis, world x, seen through the commanded
  turntable angle), plus the Earth rate at the believed latitude and heading
  (``sim.earth.earth_rate_world``) projected through the commanded attitude;
* the specific force at the sensor, in g: gravity through the commanded attitude, plus the
  centripetal (-omega^2 r) and tangential (alpha r) accelerations of a sensor at the believed
  radius on the turntable's x, from the commanded rate and its rate of change.

The commanded attitude is R = R_x(tilt) R_z(turn) (sensor -> world), the chain of
``sim/rate_table.xml``: the tilt command (plus the lab's tilt zero error), the turntable angle as
the running integral of the rate command from 0 at the run's start (``sim.rate_table._Roller``
commands it that way). A tilt move's accelerations of a sensor above the tilt axis are left out: a
lab calibrates on dwells and rate plateaus.

Alternatively (``rate_source="encoder"``) the turntable rate is the turntable encoder's angle
(the true joint angle at each sample's start, rounded to the encoder's resolution) differenced
over the sample: what a lab that reads its encoder has, servo ripple included.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fogcomp.units import G0

from . import earth

__all__ = ["LabKnowledge", "lab_reference", "commanded_angles"]


@dataclass(frozen=True)
class LabKnowledge:
    """What the lab believes, as errors against the truth (believed minus true), SI.

    latitude_error, heading_error : rad.  tilt_zero_error : rad, the tilt angle the lab believes
    minus the one the table holds (an encoder zero offset).  radius_error : m.
    encoder_resolution : rad, the turntable encoder's step (0: a perfect encoder).
    rate_source : "command" (the commanded rate) or "encoder" (the encoder angle differenced).
    """

    latitude_error: float = 0.0
    heading_error: float = 0.0
    tilt_zero_error: float = 0.0
    radius_error: float = 0.0
    encoder_resolution: float = 0.0
    rate_source: str = "command"

    def __post_init__(self):
        if self.rate_source not in ("command", "encoder"):
            raise ValueError(f"rate_source: expected 'command' or 'encoder', got "
                             f"{self.rate_source!r}")
        for name in ("latitude_error", "heading_error", "tilt_zero_error", "radius_error",
                     "encoder_resolution"):
            v = getattr(self, name)
            if not math.isfinite(v):
                raise ValueError(f"{name}: expected a finite number, got {v!r}")
        if self.encoder_resolution < 0:
            raise ValueError(f"encoder_resolution: expected >= 0, got {self.encoder_resolution}")


def commanded_angles(truth, lab: LabKnowledge = LabKnowledge()):
    """(tilt at each sample's start, turntable angle at each sample's middle, rad), as the lab
    believes them: the tilt command plus the tilt zero error, the integral of the rate command."""
    fs = truth.fs
    rate = np.asarray(truth.turn_rate_cmd, dtype=float)      # mean over each sample
    start = np.concatenate([[0.0], np.cumsum(rate)[:-1]]) / fs
    return np.asarray(truth.tilt_cmd, dtype=float) + lab.tilt_zero_error, start + rate / (2 * fs)


def _to_sensor(v_world: np.ndarray, tilt: np.ndarray, turn: np.ndarray) -> np.ndarray:
    """R^T v for R = R_x(tilt) R_z(turn), v of shape (3,) or (n, 3) -> (n, 3)."""
    v = np.broadcast_to(v_world, (tilt.size, 3))
    ct, st = np.cos(tilt), np.sin(tilt)
    # R_x^T v
    x, y, z = v[:, 0], ct * v[:, 1] + st * v[:, 2], -st * v[:, 1] + ct * v[:, 2]
    cp, sp = np.cos(turn), np.sin(turn)
    # R_z^T (x, y, z)
    return np.stack([cp * x + sp * y, -sp * x + cp * y, z], axis=1)


def lab_reference(truth, cfg, lab: LabKnowledge = LabKnowledge()):
    """(rate rad/s, specific force g), each (n, 3) in sensor axes: the lab's references for a run
    simulated with ``cfg`` (``sim.rate_table.TableConfig``), module docstring. Of ``cfg`` only
    what a lab knows is read: latitude, heading and radius (each with the lab's error added),
    local gravity, and whether the Earth's rate is in the truth at all."""
    fs = truth.fs
    tilt, turn = commanded_angles(truth, lab)
    n = tilt.size
    turn_rate = np.asarray(truth.turn_rate_cmd, dtype=float)
    if lab.rate_source == "encoder":
        q = lab.encoder_resolution
        ang = np.asarray(truth.turn, dtype=float)
        ang = np.round(ang / q) * q if q > 0 else ang
        d = np.diff(ang) * fs      # over each sample; the last sample repeats the one before
        turn_rate = np.concatenate([d, d[-1:]]) if n > 1 else np.zeros(n)
    tilt_rate = np.diff(tilt, append=tilt[-1:]) * fs
    rate = np.zeros((n, 3))
    rate[:, 2] = turn_rate
    # the tilt rate about world x, which is platform x, seen from the turntable at angle turn
    rate[:, 0] += np.cos(turn) * tilt_rate
    rate[:, 1] += -np.sin(turn) * tilt_rate
    if cfg.earth_rate:
        w = earth.earth_rate_world(cfg.latitude + lab.latitude_error,
                                   cfg.heading + lab.heading_error)
        rate += _to_sensor(w, tilt, turn)
    f = _to_sensor(np.array([0.0, 0.0, cfg.gravity / G0]), tilt, turn)
    r = cfg.radius + lab.radius_error
    if r:
        # the mean angular acceleration over each sample: the command's change across it
        first = np.asarray(truth.turn_rate_cmd_first, dtype=float)
        alpha = np.diff(first, append=first[-1:]) * fs
        f[:, 0] += -turn_rate ** 2 * r / G0
        f[:, 1] += alpha * r / G0
    return rate, f
