"""Noise parameters in the files visual-inertial tools read: Kalibr's ``imu.yaml`` and the
``kalibr_imu_chain.yaml`` of OpenVINS.

Kalibr's IMU noise model (its wiki, "IMU Noise Model"; Furgale et al. 2013) has per sensor a
white-noise density and a bias random walk, continuous time, SI:

- ``gyroscope_noise_density`` sigma_g, rad/s/sqrt(Hz): the white rate noise, the Allan term N
  (IEEE Std 952-1997, annex C: sigma^2(tau) = N^2 / tau, N in rad/s/sqrt(Hz) = rad/sqrt(s));
- ``gyroscope_random_walk`` sigma_bg, rad/s^2/sqrt(Hz): the bias random walk, the Allan term K
  (sigma^2(tau) = K^2 tau / 3, K in rad/s^2/sqrt(Hz) = rad/s/sqrt(s));
- ``accelerometer_noise_density`` (m/s^2/sqrt(Hz)) and ``accelerometer_random_walk``
  (m/s^3/sqrt(Hz)): the same terms of the accelerometer;
- ``update_rate``: the log's sample rate, Hz (Kalibr discretises with it: sigma_d = sigma
  sqrt(rate), sigma_bd = sigma_b / sqrt(rate)).

One value per sensor: the largest over the axes the log has (a filter that trusts one axis more
than it deserves diverges; the per-axis values are in the file's comments). A term the record
does not show is written as its one-sided 95 % upper bound, and the comment says so.

Kalibr's wiki recommends inflating the values for "unmodelled effects" (its example multiplies
the noise density by up to 10), and users of allan_variance_ros do the same because a static
bench record misses vibration and temperature (allan_variance_ros issue 44): ``--inflate-density``
and ``--inflate-walk`` do it, never by default, and the file states the factor and the
uninflated values.

Written by hand: these are two short YAML files of a fixed layout, with comments no YAML
library keeps; the tests load them back with PyYAML.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["NoiseValue", "pick", "values_from_models", "kalibr_text", "openvins_text", "is_own",
           "MARK", "TEXTS"]

MARK = "# written by fogbench "


@dataclass(frozen=True)
class NoiseValue:
    """One Kalibr entry: the value (SI, uninflated), its origin ("identified" or "upper
    bound") and the axis it came from; ``per_axis`` maps axis -> (value, origin)."""

    value: float
    origin: str
    axis: str
    per_axis: dict


def pick(models: dict, term: str) -> NoiseValue | None:
    """The Kalibr value of one term (``"N"`` or ``"K"``) over the axes' noise models
    (``{axis: fogcomp.noise.NoiseModel}``): the largest identified value or, where an axis does
    not show the term, its 95 % upper bound; None when no axis gives either."""
    per = {}
    for ax, m in models.items():
        t = next((t for t in m.terms if t.term == term), None)
        if t is None:
            continue
        if t.status == "identified" and t.value is not None:
            per[ax] = (float(t.value), "identified")
        elif t.bound is not None:
            per[ax] = (float(t.bound), "upper bound")
    if not per:
        return None
    ax = max(per, key=lambda a: per[a][0])
    return NoiseValue(per[ax][0], per[ax][1], ax, per)


def values_from_models(gyro: dict, acc: dict | None) -> dict:
    """The four Kalibr entries from the identified noise models of each axis (``{axis:
    NoiseModel}``; ``acc`` None when the log has no accelerometer): {(sensor, term): NoiseValue
    or None, or the string saying why it is missing}."""
    out = {}
    for sensor, models in (("gyroscope", gyro), ("accelerometer", acc)):
        for term in ("N", "K"):
            if models is None:
                out[sensor, term] = (f"not in this log (no {sensor} columns); fill it in "
                                     "before Kalibr reads the file")
            else:
                out[sensor, term] = pick(models, term) or (
                    f"the record neither shows nor bounds {term}; fill it in")
    return out


_UNITS = {("gyroscope", "N"): "rad/s/sqrt(Hz)", ("gyroscope", "K"): "rad/s^2/sqrt(Hz)",
          ("accelerometer", "N"): "m/s^2/sqrt(Hz)", ("accelerometer", "K"): "m/s^3/sqrt(Hz)"}
_KEYS = {"N": "noise_density", "K": "random_walk"}


def _entries(values: dict, inflate_density: float, inflate_walk: float):
    """(key, value or None, comment lines) for the four noise keys, in Kalibr's order."""
    out = []
    for sensor in ("gyroscope", "accelerometer"):
        for term in ("N", "K"):
            name, unit = f"{sensor}_{_KEYS[term]}", _UNITS[sensor, term]
            f = inflate_density if term == "N" else inflate_walk
            v = values.get((sensor, term), "not given; fill it in")
            if isinstance(v, str):
                out.append((name, None, [f"{name}: {v}"]))
                continue
            notes = [f"{name} [{unit}]: Allan {term} of {v.axis}, {v.origin}"
                     + (" (95 %, the record does not show the term)"
                        if v.origin == "upper bound" else "")
                     + ("; inflated x" + f"{f:g} from {v.value:.6g}" if f != 1.0 else "")]
            if len(v.per_axis) > 1:
                notes.append("  per axis: " + ", ".join(f"{a} {x:.6g} ({o})"
                                                        for a, (x, o) in v.per_axis.items()))
            out.append((name, v.value * f, notes))
    return out


def _header(source: str, fs: float, inflate_density: float, inflate_walk: float, what: str,
            command: str):
    lines = [f"{MARK}{command}: {what} from {source}",
             "# Kalibr IMU noise model, continuous time, SI: noise density = Allan N (IEEE Std",
             "# 952-1997 annex C, sigma^2(tau) = N^2/tau), random walk = Allan K",
             "# (sigma^2(tau) = K^2 tau/3)" + ("; the largest value over the log's axes."
                                                if command == "allan" else ".")]
    if inflate_density != 1.0 or inflate_walk != 1.0:
        lines.append(f"# INFLATED (--inflate-density {inflate_density:g}, --inflate-walk "
                     f"{inflate_walk:g}) for effects a static record misses (Kalibr wiki, IMU "
                     "Noise Model; allan_variance_ros #44)")
    else:
        lines.append("# not inflated (Kalibr's wiki suggests inflating for unmodelled effects: "
                     "--inflate-density, --inflate-walk)")
    lines.append(f"# update_rate: {fs:.9g} Hz, " + ("the log's sample rate" if command == "allan"
                                                     else "--rate-hz"))
    return lines


def kalibr_text(values: dict, fs: float, source: str, *, topic: str = "/imu0",
                inflate_density: float = 1.0, inflate_walk: float = 1.0,
                command: str = "allan") -> str:
    """Kalibr's ``imu.yaml`` (``kalibr_calibrate_imu_camera --imu``) of the entries
    ``values`` ({(sensor, term): NoiseValue or why it is missing})."""
    lines = _header(source, fs, inflate_density, inflate_walk, "Kalibr imu.yaml", command)
    for key, value, notes in _entries(values, inflate_density, inflate_walk):
        lines += [f"# {n}" for n in notes]
        lines.append(f"{key}: {value:.9g}" if value is not None else f"# {key}:")
    lines += [f"rostopic: {topic}", f"update_rate: {fs:.9g}"]
    return "\n".join(lines) + "\n"


def openvins_text(values: dict, fs: float, source: str, *,
                  topic: str = "/imu0", inflate_density: float = 1.0,
                  inflate_walk: float = 1.0, command: str = "allan") -> str:
    """OpenVINS' ``kalibr_imu_chain.yaml`` (its ``model: kalibr`` form, identity intrinsics:
    the noise only). Its first line is OpenCV's ``%YAML:1.0``, which OpenVINS needs."""
    lines = ["%YAML:1.0", *_header(source, fs, inflate_density, inflate_walk,
                                   "OpenVINS kalibr_imu_chain.yaml", command), "", "imu0:",
             "  T_i_b:"] + [f"    - [{', '.join('1.0' if i == j else '0.0' for j in range(4))}]"
                            for i in range(4)]
    for key, value, notes in _entries(values, inflate_density, inflate_walk):
        lines += [f"  # {n}" for n in notes]
        lines.append(f"  {key}: {value:.9g}" if value is not None else f"  # {key}:")
    ident = [f"    - [{', '.join('1.0' if i == j else '0.0' for j in range(3))}]"
             for i in range(3)]
    zero = ["    - [0.0, 0.0, 0.0]"] * 3
    lines += [f"  rostopic: {topic}", "  time_offset: 0.0", f"  update_rate: {fs:.9g}",
              '  model: "kalibr"', "  Tw:", *ident, "  R_IMUtoGYRO:", *ident, "  Ta:", *ident,
              "  R_IMUtoACC:", *ident, "  Tg:", *zero]
    return "\n".join(lines) + "\n"


def is_own(path) -> bool:
    """A file this module wrote (its mark in the first two lines)."""
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            head = [f.readline() for _ in range(2)]
    except OSError:
        return False
    return any(line.startswith(MARK) and ("imu.yaml" in line or "imu_chain.yaml" in line)
               for line in head)


def check_factor(flag: str, v: float) -> float:
    if not (math.isfinite(v) and 1.0 <= v <= 1000.0):
        raise ValueError(f"{flag}: expected a factor from 1 to 1000, got {v:g} (a factor "
                         "below 1 would claim a better sensor than the record shows)")
    return v


TEXTS = {"kalibr": kalibr_text, "openvins": openvins_text}
