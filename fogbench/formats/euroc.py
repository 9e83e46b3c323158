"""EuRoC / TUM-VI ``imu0/data.csv``: the header is a comment line, ``#timestamp [ns],w_RS_S_x
[rad s^-1],...,a_RS_S_x [m s^-2],...``, each name followed by its unit in brackets (the EuRoC
MAV dataset, Burri et al. 2016, IJRR 35(10); TUM-VI, Schubert et al. 2018, IROS). The CSV
reader takes such a line as the header and these functions give its columns our names
(``w_RS_S_x [rad s^-1]`` -> ``gyro_x_rps``); the same ``NAME [UNIT]`` form is read in any CSV
header.

A ``#`` line whose first field is ``timestamp`` (``#timestamp [ns],...``) just before the data
is the header, whatever its other fields: a field fogbench does not know (``mag_x [uT]``, a
misspelt name) is left out with a note naming it and its line, as a CSV's unknown column is
not read (``--column`` can still map it), rather than the whole line taken for a comment."""

from __future__ import annotations

import re
import sys

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


#: Our own header names (``fogbench.formats.table``): known without brackets.
_OURS = re.compile(r"^(?:(?:gyro|acc|accel)_[xyz](?:_.*)?|time(?:_.*)?|temp(?:_.*)?)$")
_TIMESTAMP = re.compile(r"^\s*timestamp(?:\s*\[[^\]]*\])?\s*$", re.I)


def _known(field: str) -> bool:
    return bracketed_column(field) is not None or bool(_OURS.match(field.strip()))


def commented_header(raw: bytes, skip: int, path=None) -> int | None:
    """The byte offset of the last of the ``skip`` leading comment lines when it is a EuRoC
    header, else None: its first field ``timestamp`` (``#timestamp [ns]``; fields it does not
    know are noted on stderr, naming ``path`` when given, and left to the reader, which does
    not use them), or every field ``NAME [UNIT]`` with a known NAME and as many fields as the
    next line."""
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
    if len(fields) < 2:
        return None
    if _TIMESTAMP.match(fields[0]):
        unknown = [f.strip() for f in fields[1:] if not _known(f)]
        if unknown:
            where = f"{path}: line {skip}" if path is not None else f"line {skip}"
            names = ", ".join(repr(f) for f in unknown)
            print(f"fogbench: {where}: header field{'s' if len(unknown) > 1 else ''} {names} "
                  "not known (a EuRoC NAME [UNIT] like 'w_RS_S_x [rad s^-1]', or ours like "
                  "'gyro_x_rps'): left out; --column maps a column by its name",
                  file=sys.stderr)
        return pos
    if not all(bracketed_column(f) for f in fields):
        return None
    stop = raw.find(b"\n", end + 1)
    nxt = raw[end + 1:stop if stop >= 0 else len(raw)]
    return pos if nxt.count(b",") + 1 == len(fields) else None
