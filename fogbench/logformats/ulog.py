"""PX4 ULog (``.ulg``): the ``sensor_gyro`` topic (rad/s, one instance per IMU) or
``sensor_combined`` (``gyro_rad[3]`` and ``accelerometer_m_s2[3]``), read with ``pyulog``.

Time: ``timestamp_sample`` where the topic has it (when the sample was taken), else
``timestamp``, in microseconds since boot (PX4's uORB convention). ``--topic`` chooses
``sensor_gyro`` (instance 0), ``sensor_gyro:1`` (another IMU) or ``sensor_combined``; without
it the only one there is, refused with the list when there are several.
"""

from __future__ import annotations

import numpy as np

from . import Rows

__all__ = ["read_ulog", "TOPICS"]

TOPICS = ("sensor_gyro", "sensor_combined")


def _error(text: str):
    from .errors import LogError

    return LogError(text)


def read_ulog(path, topic: str | None):
    """(frame, Rows, description) of a ULog's gyro topic."""
    import pandas as pd
    from pyulog import ULog

    try:
        ulog = ULog(str(path), message_name_filter_list=list(TOPICS))
    except FileNotFoundError:
        raise _error(f"{path}: file not found") from None
    except Exception as exc:          # pyulog raises plain exceptions on a damaged file
        raise _error(f"{path}: not a readable ULog file ({type(exc).__name__}: "
                     f"{str(exc).splitlines()[0] if str(exc) else 'no detail'})") from None
    found = {}
    for d in ulog.data_list:
        name = d.name if d.multi_id == 0 else f"{d.name}:{d.multi_id}"
        if d.name in TOPICS and len(d.data.get("timestamp", ())):
            found[name] = d
    if not found:
        raise _error(f"{path}: no gyro data (no sensor_gyro or sensor_combined messages); "
                     "log them with SDLOG_PROFILE's high-rate or sensor-comparison profile")
    if topic is None:
        gyro = [n for n in found if n.startswith("sensor_gyro")]
        pick = gyro if gyro else list(found)
        if len(pick) > 1:
            raise _error(f"{path}: {len(pick)} gyro topics ({', '.join(sorted(found))}); "
                         "choose one with --topic")
        topic = pick[0]
    if topic not in found:
        raise _error(f"{path}: no topic {topic!r} with data; gyro topics: "
                     f"{', '.join(sorted(found))}")
    d = found[topic]
    base = d.name
    tkey = "timestamp_sample" if "timestamp_sample" in d.data else "timestamp"
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
    return frame, Rows(what=topic), f"topic {topic}"
