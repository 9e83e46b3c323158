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

Alternatively (``gravity_source="accelerometer"``) the specific force is what a triad of
accelerometers at the FOG, aligned with its axes, reads (:func:`accelerometer_reading`): the true
specific force at the FOG times (1 + its scale factor error), plus its bias, plus white noise of
density N, each axis from its own random stream ``SeedSequence(seed, spawn_key=(crc32(
"accelerometer"), axis))`` of the run's seed (as ``sim.fog`` draws its terms). N follows the
convention of the bench's angle random walk (``sim.fog``, IEEE Std 1293-1998's velocity random
walk): the Allan deviation of the reading at tau is N / sqrt(tau), so a reading averaged over one
sample 1/fs has standard deviation N sqrt(fs).

Class values for a lab's imperfections, with their sources, are in ``CLASS_VALUES`` below; every
default is 0 (a lab that knows its table and site exactly and reads gravity through the commanded
attitude), which is what the bench did before these keys existed.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass

import numpy as np

from fogcomp.units import G0

from . import earth

__all__ = ["LabKnowledge", "lab_reference", "commanded_angles", "accelerometer_reading",
           "CLASS_VALUES"]

#: Published class values of the lab's imperfections, in the scenario keys' units, each with its
#: source; none is a default (every default is 0). A value the search of the public record did not
#: find is None, with what was found instead.
CLASS_VALUES = {
    # [table] keys (sim.rate_table.TableConfig)
    "turn_axis_error_arcsec": (5.0, "turntable for navigation-grade IMU calibration: axis "
                               "verticality better than 5 arcsec (consumer grade: position "
                               "accuracy <= 30 arcsec); Ruya-T, 'Standard process for IMU two-"
                               "dimensional calibration using a dual axis turntable', "
                               "https://www.ruya-t.com/en/news/ry119.html, section 1(1)"),
    "level_error_arcsec": (None, "no levelling class value found; the tilt-axis verification of "
                           "https://www.ruyaturntable.com/news/tilt-angle-rotation-error-test-"
                           "335389.html reads the table with an electronic level of 0.2 arcsec "
                           "resolution (section 2), the floor of what a levelled table knows"),
    "rate_error_ppm": (100.0, "a single-axis turntable's rate calibration and its angle "
                       "(position) calibration of one gyro's scale factor differ by 1e-4 at "
                       "10-60 deg/s and 2e-4 at 90-120 deg/s (measured, table 1 of "
                       "https://github.com/XinLiGH/TurntableSpeedAndPosition); no maker's rate-"
                       "accuracy specification was found"),
    # [lab] keys (LabKnowledge)
    "encoder_resolution_arcsec": (0.309, "an inductosyn angle readout of 2^-14 of an electrical "
                                  "revolution in its 256-speed channel: 0.309 arcsec (NASA CASI "
                                  "19760010102, https://ntrs.nasa.gov/search.jsp?R=19760010102)"),
    "heading_error_deg": (15.0 / 3600.0, "true north by gyrotheodolite: standard error about "
                          "15 arcsec (Hilger & Watts type, "
                          "https://files.library.nung.edu.ua/chytalnya/4670/files/basic-html/"
                          "page175.html); 5-7 arcsec with a GI-B2 (Lviv Polytechnic, vol. 26, "
                          "1977); a gyrocompass calibrated by RTK GNSS to 1.5 arcsec "
                          "(https://community.emlid.com/t/reach-used-to-calibrate-a-gyrocompass/"
                          "4096)"),
    "latitude_error_deg": (None, "no class value needed: a GNSS fix (metres) is ~1e-5 deg, whose "
                           "Earth-rate error (Omega sin L' - sin L ~ 1e-11 rad/s) is below any FOG"),
    "tilt_zero_error_arcsec": (10.0, "navigation-grade turntable angular position accuracy "
                               "better than 10 arcsec, Ruya-T ry119 (above)"),
    "radius_error_mm": (None, "no class value found for a static radius; IEEE Std 836-2009 "
                        "section 6.1 ('Radius uncertainty') lists it as a centrifuge error source, "
                        "and a precision centrifuge's arm stretches 0.0115 um per m/s^2 "
                        "(Niu and Ning 2019, J. Terahertz Sci. Electron. Inf. Technol. 17(5) "
                        "892-897): 0.11 um at 1 g"),
    "acc_bias_ug": (30.0, "tactical MEMS: Xsens MTi-1 accelerometer zero-offset instability "
                    "0.03 mg (https://reference-global.com/article/10.2478/tar-2023-0022, table "
                    "'Characteristics of IMU Xsens MTI-1'); a quartz pendulous accelerometer's "
                    "raw bias: <= 3 mg (ERICCO GSY-QA-03A1, http://joinsunny.cn/application75/"
                    "1459.html)"),
    "acc_scale_factor_ppm": (None, "no published class value found in the searched record (the "
                             "Honeywell QA-2000 datasheet was not in it)"),
    "acc_noise_ug_rt_hz": (120.0, "Xsens MTi-1 accelerometer noise density 120 ug/sqrt(Hz) "
                           "(reference-global tar-2023-0022, above); BMI270 160 ug/sqrt(Hz) "
                           "(https://docs.luxonis.com/hardware/platform/sensors/imu/bmi270/)"),
}


@dataclass(frozen=True)
class LabKnowledge:
    """What the lab believes, as errors against the truth (believed minus true), SI.

    latitude_error, heading_error : rad.  tilt_zero_error : rad, the tilt angle the lab believes
    minus the one the table holds (an encoder zero offset).  radius_error : m.
    encoder_resolution : rad, the turntable encoder's step (0: a perfect encoder).
    rate_source : "command" (the commanded rate) or "encoder" (the encoder angle differenced).
    gravity_source : "command" (gravity through the commanded attitude, the believed radius's
    centripetal and tangential terms) or "accelerometer" (a triad at the FOG, module docstring):
    acc_bias, m/s^2, and acc_scale_factor (dimensionless, reading = (1 + k) f), each per sensor
    axis (x, y, z); acc_noise_density, m/s^2/sqrt(Hz), the same on every axis.
    """

    latitude_error: float = 0.0
    heading_error: float = 0.0
    tilt_zero_error: float = 0.0
    radius_error: float = 0.0
    encoder_resolution: float = 0.0
    rate_source: str = "command"
    gravity_source: str = "command"
    acc_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    acc_scale_factor: tuple[float, float, float] = (0.0, 0.0, 0.0)
    acc_noise_density: float = 0.0

    def __post_init__(self):
        if self.rate_source not in ("command", "encoder"):
            raise ValueError(f"rate_source: expected 'command' or 'encoder', got "
                             f"{self.rate_source!r}")
        if self.gravity_source not in ("command", "accelerometer"):
            raise ValueError(f"gravity_source: expected 'command' or 'accelerometer', got "
                             f"{self.gravity_source!r}")
        for name in ("latitude_error", "heading_error", "tilt_zero_error", "radius_error",
                     "encoder_resolution", "acc_noise_density"):
            v = getattr(self, name)
            if not math.isfinite(v):
                raise ValueError(f"{name}: expected a finite number, got {v!r}")
        for name in ("acc_bias", "acc_scale_factor"):
            v = getattr(self, name)
            if len(v) != 3 or not all(math.isfinite(x) for x in v):
                raise ValueError(f"{name}: expected 3 finite numbers (x, y, z), got {v!r}")
            if name == "acc_scale_factor" and min(v) <= -1.0:
                raise ValueError(f"{name}: expected each > -1 (a reading of the right sign), "
                                 f"got {v!r}")
        if self.encoder_resolution < 0:
            raise ValueError(f"encoder_resolution: expected >= 0, got {self.encoder_resolution}")
        if self.acc_noise_density < 0:
            raise ValueError(f"acc_noise_density: expected >= 0, got {self.acc_noise_density}")


def accelerometer_reading(specific_force_g, fs: float, lab: LabKnowledge, seed: int):
    """What the lab's accelerometer triad reads, in g, shape (n, 3): the true specific force at
    the FOG (``specific_force_g``, g, sensor axes, each sample's mean) through the triad's
    errors (module docstring): (1 + k) f + b + N sqrt(fs) w, w standard normal, axis j's w from
    ``SeedSequence(seed, spawn_key=(crc32("accelerometer"), j))``. With every error 0 it is
    ``specific_force_g`` itself, bit for bit."""
    f = np.asarray(specific_force_g, dtype=float)
    out = f.copy()
    for j in range(3):
        k, b = lab.acc_scale_factor[j], lab.acc_bias[j] / G0
        col = f[:, j] * (1.0 + k) + b if (k or b) else f[:, j].copy()
        if lab.acc_noise_density:
            ss = np.random.SeedSequence(seed, spawn_key=(zlib.crc32(b"accelerometer"), j))
            col = col + np.random.default_rng(ss).standard_normal(f.shape[0]) * (
                lab.acc_noise_density * math.sqrt(fs) / G0)
        out[:, j] = col
    return out


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


def lab_reference(truth, cfg, lab: LabKnowledge = LabKnowledge(), seed: int | None = None):
    """(rate rad/s, specific force g), each (n, 3) in sensor axes: the lab's references for a run
    simulated with ``cfg`` (``sim.rate_table.TableConfig``), module docstring. Of ``cfg`` only
    what a lab knows is read: latitude, heading and radius (each with the lab's error added),
    local gravity, and whether the Earth's rate is in the truth at all. With
    ``lab.gravity_source == "accelerometer"`` the specific force is the triad's reading
    (:func:`accelerometer_reading`), drawn from the run's ``seed`` (required then)."""
    if lab.gravity_source == "accelerometer" and seed is None:
        raise ValueError("gravity_source = 'accelerometer': the run's seed is needed for the "
                         "triad's noise")
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
    if lab.gravity_source == "accelerometer":
        f = accelerometer_reading(truth.specific_force, fs, lab, seed)
    return rate, f
