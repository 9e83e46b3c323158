"""EuRoC / TUM-VI ``imu0/data.csv``: the header is a comment line, ``#timestamp [ns],w_RS_S_x
[rad s^-1],...,a_RS_S_x [m s^-2],...``, each name followed by its unit in brackets (the EuRoC
MAV dataset, Burri et al. 2016, IJRR 35(10); TUM-VI, Schubert et al. 2018, IROS). The CSV
reader takes such a line as the header and these functions give its columns our names
(``w_RS_S_x [rad s^-1]`` -> ``gyro_x_rps``); the same ``NAME [UNIT]`` form is read in any CSV
header."""

from __future__ import annotations

import re

__all__ = ["bracketed_column", "commented_header"]

_BRACKETED = re.compile(r"^\s*(\S.*?)\s*\[([^\]]+)\]\s*$")
_XYZ = {"x": "x", "y": "y", "z": "z", "0": "x", "1": "y", "2": "z"}
# EuRoC's names, ours, and the message fields the bag and ULog readers name their columns by
# (sensor_msgs/msg/Imu: angular_velocity.x; PX4: sensor_gyro.x, sensor_combined.gyro_rad[0])
_NAMES = [
    (re.compile(r"^(?:timestamp|time|t|header\.stamp|bag time|[a-z_]+\.timestamp(?:_sample)?)$",
                re.I), "time"),
    (re.compile(r"^(?:w_RS_S_|w_|omega_|gyro_|angular_velocity\.|sensor_gyro\.)([xyz])$", re.I),
     "gyro_{}"),
    (re.compile(r"^sensor_combined\.gyro_rad\[([012])\]$"), "gyro_{}"),
    (re.compile(r"^(?:a_RS_S_|a_|acc_|accel_|linear_acceleration\.|sensor_accel\.)([xyz])$",
                re.I), "acc_{}"),
    (re.compile(r"^sensor_combined\.accelerometer_m_s2\[([012])\]$"), "acc_{}"),
    (re.compile(r"^(?:temp|temperature|sensor_gyro\.temperature)$", re.I), "temp"),
]
_UNITS = {
    "ns": "ns", "us": "us", "ms": "ms", "s": "s",
    "rad s^-1": "rps", "rad/s": "rps", "deg s^-1": "dps", "deg/s": "dps", "deg h^-1": "dph",
    "deg/h": "dph", "m s^-2": "mps2", "m/s^2": "mps2", "g": "g", "c": "c", "deg c": "c",
    "degc": "c",
}


def bracketed_column(col: str) -> str | None:
    """``w_RS_S_x [rad s^-1]`` -> ``gyro_x_rps``; ``timestamp [ns]`` -> ``time_ns``; None for a
    name that is not ``NAME [UNIT]`` with a known NAME (an unknown unit is kept as written, so
    that the unit check names it)."""
    m = _BRACKETED.match(col)
    if not m:
        return None
    name, unit = m.group(1), " ".join(m.group(2).split())
    for pat, fmt in _NAMES:
        k = pat.match(name)
        if k:
            base = fmt.format(*(_XYZ[g.lower()] for g in k.groups()))
            return f"{base}_{_UNITS.get(unit.lower(), unit.lower().replace(' ', ''))}"
    return None


def commented_header(raw: bytes, skip: int) -> int | None:
    """The byte offset of the last of the ``skip`` leading comment lines when it is a EuRoC
    header (every field ``NAME [UNIT]`` with a known NAME, as many fields as the next line),
    else None."""
    if skip == 0:
        return None
    pos = 0
    for _ in range(skip - 1):
        pos = raw.find(b"\n", pos) + 1
    end = raw.find(b"\n", pos)
    if end < 0:
        return None
    line = raw[pos + 1:end].decode("utf-8", "replace").rstrip("\r")
    fields = line.split(",")
    if len(fields) < 2 or not all(bracketed_column(f) for f in fields):
        return None
    stop = raw.find(b"\n", end + 1)
    nxt = raw[end + 1:stop if stop >= 0 else len(raw)]
    return pos if nxt.count(b",") + 1 == len(fields) else None
