"""The logs a device fit or check reads: one gyro channel of a static, thermal or
multi-position log (with the channels each needs), or one axis of an Allan curve."""

from __future__ import annotations

import numpy as np

from fogbench.device.fit import StaticLog
from fogbench.formats.curve import read_curve
from fogbench.formats.errors import LogError
from fogbench.logs.allan import _curve_record
from fogbench.logs.calibrate import reference_unit


def _channel(log, axis: str | None, path) -> str:
    """The log's gyro column for ``axis``, or its only one; refused naming the columns."""
    gyros = gyro_columns(log)
    if axis is not None:
        ch = f"gyro_{axis}"
        if ch not in log.channels:
            raise LogError(f"{path}: no {ch} column (it has {', '.join(gyros)})")
        return ch
    if len(gyros) != 1:
        raise LogError(f"{path}: {len(gyros)} gyro columns ({', '.join(gyros)}): a device file "
                       "is one gyro; choose it with --axis x, y or z")
    return gyros[0]


def _read_static(path, opts, acc: bool = False, temp: bool = False) -> tuple[StaticLog, object]:
    """One gyro channel of a static log; with ``temp``, its temperature column too where it
    has one; with ``acc``, its accelerometer columns where it has all three (their mean
    specific force in g: the log's attitude)."""
    log = _read_static_log(path, opts, acc, temp)
    return _static_of(path, log, _channel(log, opts.axis, path), acc), log


def _read_static_log(path, opts, acc: bool = False, temp: bool = False):
    """A static log as read (its ``--axis`` gyro column, or every gyro column)."""
    chans = [f"gyro_{opts.axis}"] if opts.axis else ["gyro_*"]
    return opts.read(path, chans + (["acc_*?"] if acc else []) + (["temp?"] if temp else []))


def gyro_columns(log) -> list[str]:
    """The log's gyro channels, sorted (gyro_x, gyro_y, gyro_z)."""
    return sorted(c for c in log.channels if c.startswith("gyro_"))


def _static_of(path, log, ch: str, acc: bool = False) -> StaticLog:
    """The gyro channel ``ch`` of a static log as read: a :class:`StaticLog`."""
    if log.units[ch] == "au":
        raise LogError(f"{path}: column {log.sources[ch]!r} is in raw counts (au); a device "
                       "file needs a rate unit (dps, rps, dph)")
    v = log.channels[ch]
    if np.ptp(v) == 0:
        raise LogError(f"{path}: column {log.sources[ch]!r} is constant: a stuck channel has no "
                       "noise to fit")
    f, src = _attitude(path, log) if acc else (None, "")
    temp = log.channels.get("temp")
    return StaticLog(str(path), v, log.fs, tuple(log.segments), log.sources[ch], f=f,
                     f_source=src, axis=ch.removeprefix("gyro_"), temp=temp,
                     temp_source=log.sources.get("temp", ""))


def _attitude(path, log) -> tuple[tuple | None, str]:
    """(the log's mean specific force in g along its body axes, where it comes from) from its
    acc_x/y/z columns, or (None, "") without all three."""
    from fogcomp.units import G0

    accs = [f"acc_{a}" for a in "xyz"]
    if not all(c in log.channels for c in accs):
        return None, ""
    for c in accs:
        if log.units[c] == "au":
            raise LogError(f"{path}: column {log.sources[c]!r} is in raw counts (au); the "
                           "log's attitude needs physical units")
    return (tuple(float(np.mean(log.channels[c])) / G0 for c in accs),
            "its " + ", ".join(log.sources[c] for c in accs) + " columns")


def _read_thermal(path, opts, acc: bool = False):
    from fogbench.device.thermal import ThermalLog

    chans = [f"gyro_{opts.axis}" if opts.axis else "gyro_*", "temp"] + (["acc_*?"] if acc
                                                                         else [])
    log = opts.read(path, chans, gaps="continuous")
    ch = _channel(log, opts.axis, path)
    if log.units[ch] == "au":
        raise LogError(f"{path}: column {log.sources[ch]!r} is in raw counts (au); a device "
                       "file needs a rate unit (dps, rps, dph)")
    f, src = _attitude(path, log) if acc else (None, "")
    return ThermalLog(str(path), log.channels[ch], log.channels["temp"], log.fs,
                      log.sources[ch], f=f, f_source=src), log


def _check_reference_flag(reference):
    """--reference names a column with a rate unit (checked before any log is read)."""
    if not reference:
        raise LogError("--multipos: give --reference COLUMN, the log's reference rate about the "
                       "input axis with its unit (e.g. ref_dps: the table's rate plus the Earth "
                       "rate's projection)")
    reference_unit(reference)


def _read_multipos(path, opts):
    from fogbench.device.multipos import MultiposLog
    from fogbench.logs.calibrate import reference_rate
    from fogcomp.units import G0

    _check_reference_flag(opts.reference)
    chans = [f"gyro_{opts.axis}" if opts.axis else "gyro_*", "acc_x", "acc_y", "acc_z"]
    log = opts.read(path, chans, gaps="continuous")
    ch = _channel(log, opts.axis, path)
    for c in [ch] + [f"acc_{a}" for a in "xyz"]:
        if log.units[c] == "au":
            raise LogError(f"{path}: column {log.sources[c]!r} is in raw counts (au); the "
                           "multi-position fit needs physical units")
    ref = reference_rate(path, log, opts.reference)
    f = np.column_stack([log.channels[f"acc_{a}"] for a in "xyz"]) / G0
    return MultiposLog(str(path), log.channels[ch], ref, f, log.fs, log.sources[ch]), log


def _read_curve_axis(opts):
    """(axis, (taus, adev, low, high), sample rate, samples) of ``--curve``: the axis
    ``--axis`` names, or the curve's only one."""
    curves, _, header = read_curve(opts.curve, opts.curve_ci, with_header=True)
    fs, samples = _curve_record(opts.curve, header, opts.fs, opts.samples)
    if len(curves) != 1 and opts.axis is None:
        raise LogError(f"{opts.curve}: {len(curves)} axes ({', '.join(curves)}); choose one "
                       "with --axis")
    ax = opts.axis if opts.axis is not None else next(iter(curves))
    if ax not in curves:
        raise LogError(f"{opts.curve}: no axis {ax!r} (it has {', '.join(curves)})")
    return ax, curves[ax], fs, samples
