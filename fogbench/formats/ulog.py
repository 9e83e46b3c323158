"""PX4 ULog (``.ulg``, gzip-compressed too): the ``sensor_combined`` topic (``gyro_rad[3]``
and ``accelerometer_m_s2[3]``) or ``sensor_gyro`` (rad/s, one instance per IMU), read with
``pyulog``.

Time: ``timestamp_sample`` where the topic has it (when the sample was taken), else
``timestamp``, in microseconds since boot (PX4's uORB convention).

Which topic: ``--topic`` (``sensor_combined``, ``sensor_gyro``, ``sensor_gyro:1`` for another
IMU); without it the fastest one, by the median interval of its time column. PX4's logger
(``src/modules/logger/logged_topics.cpp``) writes ``sensor_combined`` at its full rate (the
IMU integration rate, ``IMU_INTEG_RATE``, 100 to 1000 Hz, 200 by default) in its default
profile, but ``sensor_gyro`` only once per 1000 ms there ("log all raw sensors at minimal
rate") and once per 100 ms in the sensor-comparison and thermal-calibration profiles: a
decimated record, whose Allan noise density N comes out sqrt(full rate / logged rate) times too
high (16x at 1 Hz of 250 Hz). The choice and its reason are said on stderr; a topic that looks
decimated (below 90 Hz, or messages further apart than ``gyro_integral_dt``, the time each
covers: a float32 in seconds in older firmware, a uint32 in microseconds since, read by its
type) is warned of, with advice true for the log (never to read the topic being read). Two
topics equally fast: ``sensor_combined`` (the IMU PX4's estimator uses) when it is one of them,
else refused with the list.

A file that ends inside a message (a log cut by a power loss, a full card, a copy stopped
early) is read up to there and warned of, with the count of messages read; so is a file
``pyulog`` found damaged (its ``file_corruption`` flag).
"""

from __future__ import annotations

import gzip
import io
import mmap
import struct
import warnings
import zlib
from pathlib import Path

import numpy as np

from fogbench.console import note
from fogbench.formats.detect import Rows

__all__ = ["read_ulog", "TOPICS", "integral_dt_us"]

TOPICS = ("sensor_gyro", "sensor_combined")


def _error(text: str):
    from fogbench.formats.errors import LogError

    return LogError(text)


#: Below this rate an IMU topic of PX4 looks decimated: PX4 publishes sensor_combined at
#: IMU_INTEG_RATE (at least 100 Hz) and sensor_gyro at the driver's rate (faster).
DECIMATED_BELOW_HZ = 90.0
#: Topics within this ratio of the fastest one count as equally fast.
SAME_RATE = 0.9


def _hz(rate: float) -> str:
    return f"{rate:.3g} Hz" if rate > 0 else "one message"


def _time_key(d) -> str:
    return "timestamp_sample" if "timestamp_sample" in d.data else "timestamp"


def _rate(d) -> float:
    """Messages per second of a topic: 1 / the median positive interval of its time column."""
    t = np.asarray(d.data[_time_key(d)], dtype=np.int64)
    steps = np.diff(t)
    steps = steps[steps > 0]
    return 1e6 / float(np.median(steps)) if steps.size else 0.0


def _decimated(name: str, d, rate: float) -> str | None:
    """Why topic ``name`` looks decimated by the logger, or None."""
    if rate < DECIMATED_BELOW_HZ:
        return (f"{_hz(rate)}, slower than PX4 publishes any IMU topic (sensor_combined at "
                "IMU_INTEG_RATE, 100 Hz or more)")
    if name == "sensor_combined" and "gyro_integral_dt" in d.data:
        dt = integral_dt_us(d.data["gyro_integral_dt"])
        dt = dt[dt > 0]
        if dt.size and 1e6 / rate > 1.5 * float(np.median(dt)):
            return (f"a message every {1e3 / rate:.3g} ms, each covering "
                    f"{float(np.median(dt)) / 1e3:.3g} ms (gyro_integral_dt)")
    return None


def integral_dt_us(values) -> np.ndarray:
    """``gyro_integral_dt`` in microseconds, read as the firmware wrote it: by the field's type
    in the ULog's own format message. PX4's ``sensor_combined.msg`` declared it ``float32`` in
    seconds in older firmware (``sample.ulg``: 0.004) and ``uint32`` in microseconds since
    (``sample_log_small.ulg``: 4888); pyulog keeps the type (a float32 or a uint32 array)."""
    v = np.asarray(values)
    if v.dtype.kind == "f":
        return v.astype(float) * 1e6
    return v.astype(float)


def _decimation_advice(path, topic: str, base: str, found: dict, rates: dict) -> str:
    """What to do about a decimated topic, true for the log at hand: never to read the topic
    being read."""
    log_it = ("log the topic at full rate (PX4's logger: SDLOG_PROFILE, or a custom "
              "etc/logging/logger_topics.txt naming it with interval 0)")
    faster = sorted((n for n in found if n != topic and rates[n] > 1.5 * rates[topic]),
                    key=lambda n: -rates[n])
    if faster:
        return (f"read {faster[0]} ({_hz(rates[faster[0]])} in this log) with --topic "
                f"{faster[0]}, or {log_it}")
    if base == "sensor_gyro":
        return (f"{log_it}; PX4's default profile logs sensor_gyro at 1 Hz and sensor_combined "
                "at full rate")
    return log_it


def _choose(path, found: dict, rates: dict) -> tuple[str, str]:
    """(topic, why) when no --topic is given: the fastest gyro topic."""
    listing = ", ".join(f"{n} {_hz(rates[n])}" for n in sorted(found))
    if len(found) == 1:
        name = next(iter(found))
        return name, f"the only gyro topic in the log ({listing})"
    order = sorted(found, key=lambda n: (-rates[n], n))
    fastest = [n for n in order if rates[n] >= SAME_RATE * rates[order[0]]]
    if len(fastest) == 1:
        return fastest[0], f"the fastest gyro topic ({listing})"
    if "sensor_combined" in fastest:
        others = ", ".join(n for n in fastest if n != "sensor_combined")
        return "sensor_combined", (f"as fast as {others}, and the IMU PX4's estimator uses "
                                   f"({listing})")
    raise _error(f"{path}: {len(fastest)} gyro topics ({', '.join(sorted(fastest))}); choose "
                 f"one with --topic (equally fast: {listing})")


def _gunzipped(path: Path) -> bytes | None:
    """The decompressed bytes of a gzip-compressed file (by its magic bytes), else None."""
    with open(path, "rb") as f:
        if f.read(2) != b"\x1f\x8b":
            return None
    try:
        with gzip.open(path, "rb") as f:
            return f.read()
    except (OSError, EOFError, zlib.error) as exc:
        raise _error(f"{path}: not a readable gzip file ({exc}); a gzip-compressed ULog is "
                     "read whole: gunzip what can be recovered (gunzip -c) first") from None


def _ends_inside_a_message(buf) -> bool:
    """Whether the ULog in ``buf`` ends inside a message, by its framing (docs.px4.io, "ULog
    File Format"): a 16-byte header, then messages of a 3-byte header (uint16 payload size,
    uint8 type) and the payload; with the DATA_APPENDED flag of the 'B' message, counted from
    the last appended-data offset (the section before it may legitimately end mid-message)."""
    size = len(buf)
    pos = 16
    if size >= 16 + 3 + 40 and buf[18:19] == b"B":
        incompat = buf[19 + 8]
        offsets = struct.unpack_from("<3Q", buf, 19 + 16)
        appended = [o for o in offsets if 0 < o <= size]
        if incompat & 1 and appended:
            pos = max(appended)
    size_of = struct.Struct("<H").unpack_from
    while pos + 3 <= size:
        pos += 3 + size_of(buf, pos)[0]
    return pos != size


def read_ulog(path, topic: str | None):
    """(frame, Rows, description) of a ULog's gyro topic."""
    ulog, unzipped = _open_ulog(path)
    found = {}
    for d in ulog.data_list:
        name = d.name if d.multi_id == 0 else f"{d.name}:{d.multi_id}"
        if d.name in TOPICS and len(d.data.get("timestamp", ())):
            found[name] = d
    if not found:
        raise _error(f"{path}: no gyro data (no sensor_gyro or sensor_combined messages); "
                     "PX4's default logging profile records sensor_combined at full rate "
                     "(a custom etc/logging/logger_topics.txt must name it)")
    rates = {n: _rate(d) for n, d in found.items()}
    if topic is None:
        topic, why = _choose(path, found, rates)
        note(f"{path}: topic {topic} read: {why}"
              + ("; --topic chooses another" if len(found) > 1 else ""))
    if topic not in found:
        raise _error(f"{path}: no topic {topic!r} with data; gyro topics: "
                     f"{', '.join(sorted(found))}")
    d = found[topic]
    _warn_of_damage(path, ulog, d, topic, unzipped, found, rates)
    frame = _gyro_frame(path, d, topic)
    return frame, Rows(what=topic), f"topic {topic}"


def _open_ulog(path):
    """(pyulog's ULog of the gyro topics, the unzipped bytes or None): a missing, unreadable
    or damaged file refused naming it."""
    from pyulog import ULog

    p = Path(path)
    try:
        unzipped = _gunzipped(p)
    except FileNotFoundError:
        raise _error(f"{path}: file not found") from None
    except OSError as exc:
        raise _error(f"{path}: cannot be read ({exc.strerror or exc})") from None
    try:
        source = io.BytesIO(unzipped) if unzipped is not None else str(path)
        ulog = ULog(source, message_name_filter_list=list(TOPICS))
    except FileNotFoundError:
        raise _error(f"{path}: file not found") from None
    except Exception as exc:          # pyulog raises plain exceptions on a damaged file
        what = "a gzip-compressed file, not a readable ULog" if unzipped is not None else \
            "not a readable ULog file"
        raise _error(f"{path}: {what} ({type(exc).__name__}: "
                     f"{str(exc).splitlines()[0] if str(exc) else 'no detail'})") from None
    return ulog, unzipped


def _warn_of_damage(path, ulog, d, topic: str, unzipped, found, rates) -> None:
    """Warnings of a file cut inside a message, of data pyulog skipped, and of a topic the
    logger decimated."""
    p = Path(path)
    base = d.name
    count = len(d.data["timestamp"])
    if unzipped is not None:
        cut = _ends_inside_a_message(unzipped)
    else:
        with open(p, "rb") as f:
            try:
                with mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as buf:
                    cut = _ends_inside_a_message(buf)
            except ValueError:        # an empty file cannot be mapped (pyulog refused it)
                cut = True
    if cut:
        warnings.warn(f"{path}: truncated: the file ends inside a message (a log cut by a "
                      "power loss, a full card or a copy stopped early); read up to there: "
                      f"{count} messages of {topic}", stacklevel=3)
    if ulog.file_corruption:
        warnings.warn(f"{path}: damaged: pyulog skipped data it could not read (its "
                      f"file_corruption flag); {count} messages of {topic} read", stacklevel=3)
    why = _decimated(base, d, rates[topic])
    if why:
        warnings.warn(f"{path}: topic {topic} looks decimated ({why}): the logger kept only "
                      "some of its messages, so the Allan noise density N comes out about "
                      "sqrt(full rate / logged rate) times too high; "
                      + _decimation_advice(path, topic, base, found, rates), stacklevel=3)


def _gyro_frame(path, d, topic: str):
    """The topic's time, gyro (and accelerometer or temperature) columns as a frame, each
    column named with its unit."""
    import pandas as pd

    base = d.name
    tkey = _time_key(d)
    frame = pd.DataFrame({f"{base}.{tkey} [us]": np.asarray(d.data[tkey], dtype=np.int64)})
    if base == "sensor_gyro":
        fields = [(f"{base}.{ax}", ax) for ax in "xyz"]
        units = "rad s^-1"
    else:
        fields = [(f"{base}.gyro_rad[{k}]", f"gyro_rad[{k}]") for k in range(3)]
        units = "rad s^-1"
    for col, key in fields:
        if key not in d.data:
            raise _error(f"{path}: topic {topic!r} has no field {key!r}")
        frame[f"{col} [{units}]"] = np.asarray(d.data[key], dtype=float)
    if base == "sensor_combined":
        for k in range(3):
            key = f"accelerometer_m_s2[{k}]"
            if key in d.data:
                frame[f"{base}.{key} [m s^-2]"] = np.asarray(d.data[key], dtype=float)
    elif "temperature" in d.data:
        temp = np.asarray(d.data["temperature"], dtype=float)
        if np.isfinite(temp).all():
            frame[f"{base}.temperature [C]"] = temp
    return frame
