"""``sensor_msgs/msg/Imu`` from ROS 2 bags (a folder with ``metadata.yaml``, or its ``.db3``),
MCAP files and ROS 1 bags, read with the ``rosbags`` package (pure Python; its ``AnyReader``
reads all four and the message definitions stored in them).

Each message gives one row: the time from ``header.stamp`` (the driver's sampling time; the
bag's receive time when every stamp is zero, which the description says), the angular
velocity (rad/s, REP 103 / the message's definition) and the linear acceleration (m/s^2).
Columns are named by the message's fields (``angular_velocity.x [rad s^-1]``), so that an error
names the field and the message.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fogbench.formats.detect import Rows, gzip_payload

__all__ = ["read_imu_topic", "IMU_TYPES"]

IMU_TYPES = ("sensor_msgs/msg/Imu", "sensor_msgs/Imu")


def _error(text: str):
    from fogbench.formats.errors import LogError

    return LogError(text)


def read_imu_topic(path, topic: str | None):
    """(frame, Rows, description) of the IMU topic of a bag; ``topic`` None: the only
    ``sensor_msgs/msg/Imu`` topic (refused, listing them, when there are several)."""
    import pandas as pd

    reader = _open_bag(path)
    try:
        topic, chosen = _choose_topic(path, reader.connections, topic)
        stamp, logt, w, a = _read_messages(path, reader, topic, chosen)
    finally:
        try:
            reader.close()
        except Exception:
            pass
    if stamp.size == 0:
        raise _error(f"{path}: topic {topic!r} has no messages")
    when = "header.stamp"
    if not stamp.any():
        stamp, when = logt, "bag time"
    frame = pd.DataFrame({f"{when} [ns]": stamp})
    for k, ax in enumerate("xyz"):
        frame[f"angular_velocity.{ax} [rad s^-1]"] = w[:, k]
    for k, ax in enumerate("xyz"):
        frame[f"linear_acceleration.{ax} [m s^-2]"] = a[:, k]
    note = "" if when == "header.stamp" else " (every header.stamp is 0: the bag's time used)"
    return frame, Rows(what=topic), f"topic {topic}{note}"


def _open_bag(path):
    """rosbags' reader of the bag or MCAP file ``path``, opened; a gzip-compressed file, a
    missing one and one rosbags cannot read refused naming it."""
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_typestore

    p = Path(path)
    packed = gzip_payload(p)
    if packed is not None:
        raise _error(f"{path}: a gzip-compressed {packed[0]}; rosbags reads bags and MCAP files "
                     f"only uncompressed: gunzip it first ({packed[1]}) and give that file")
    try:
        reader = AnyReader([p], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except FileNotFoundError:
        raise _error(f"{path}: file not found") from None
    except (AnyReaderError, Exception) as exc:    # rosbags raises several kinds on bad files
        raise _error(f"{path}: not a readable ROS bag or MCAP file ({type(exc).__name__}: "
                     f"{str(exc).splitlines()[0] if str(exc) else 'no detail'})") from None
    return reader


def _choose_topic(path, conns, topic: str | None):
    """(topic, its connections): ``topic``, or the bag's only IMU topic when None; a missing
    topic, one that is not an IMU's, or several IMU topics without ``topic`` refused."""
    imu = sorted({c.topic for c in conns if c.msgtype in IMU_TYPES})
    listing = ", ".join(f"{c.topic} ({c.msgtype})" for c in conns) or "none"
    if topic is None:
        if not imu:
            raise _error(f"{path}: no sensor_msgs/msg/Imu topic; topics: {listing}")
        if len(imu) > 1:
            raise _error(f"{path}: {len(imu)} IMU topics ({', '.join(imu)}); choose one "
                         "with --topic")
        topic = imu[0]
    chosen = [c for c in conns if c.topic == topic]
    if not chosen:
        raise _error(f"{path}: no topic {topic!r}; topics: {listing}")
    bad = [c for c in chosen if c.msgtype not in IMU_TYPES]
    if bad:
        raise _error(f"{path}: topic {topic!r} is {bad[0].msgtype}, not "
                     "sensor_msgs/msg/Imu; IMU topics: " + (", ".join(imu) or "none"))
    return topic, chosen


def _read_messages(path, reader, topic: str, chosen):
    """(header stamps ns, bag times ns, angular velocities rad/s, linear accelerations
    m/s^2) of the messages of ``chosen``, with a progress bar; a message that cannot be read
    (a truncated or damaged bag) refused naming its number."""
    from fogbench.console import PROGRESS_MIN_ROWS, progress_bar

    n = sum(c.msgcount for c in chosen)
    stamp = np.empty(n, dtype=np.int64)
    logt = np.empty(n, dtype=np.int64)
    w = np.empty((n, 3))
    a = np.empty((n, 3))
    i = 0
    bar = progress_bar(n, f"{Path(path).name} {topic}", "msg", n >= PROGRESS_MIN_ROWS)
    try:
        for conn, t, raw in reader.messages(connections=chosen):
            bar.update(1)
            m = reader.deserialize(raw, conn.msgtype)
            if i >= n:       # more than the index said: grow
                stamp, logt = np.resize(stamp, 2 * n + 1), np.resize(logt, 2 * n + 1)
                w, a = np.resize(w, (2 * n + 1, 3)), np.resize(a, (2 * n + 1, 3))
                n = 2 * n + 1
            s = m.header.stamp
            stamp[i] = int(s.sec) * 1_000_000_000 + int(s.nanosec)
            logt[i] = int(t)
            av, la = m.angular_velocity, m.linear_acceleration
            w[i] = (av.x, av.y, av.z)
            a[i] = (la.x, la.y, la.z)
            i += 1
    except Exception as exc:   # a truncated or corrupt bag fails inside the iteration
        raise _error(f"{path}: topic {topic!r}: message {i + 1} cannot be read "
                     f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
                     "); the bag is truncated or damaged") from None
    finally:
        bar.close()
    return stamp[:i], logt[:i], w[:i], a[:i]
