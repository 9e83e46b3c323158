"""Write the example logs of the guide "Your own gyro log" (docs/guides/real-logs.md).

    .venv/bin/python docs/examples/make_logs.py out/logs

writes, with numbers drawn from fixed seeds (the same files on every machine):

- ``out/logs/mav0/imu0/data.csv``: a static IMU in the EuRoC / TUM-VI layout (``#timestamp
  [ns],w_RS_S_x [rad s^-1],...``), 20 minutes at 100 Hz: on each gyro white rate noise of
  density N = 2e-4 rad/s/sqrt(Hz) (0.69 deg/sqrt(h)) and a rate random walk of K = 2e-5
  rad/s^2/sqrt(Hz); on each accelerometer white noise of 3e-3 m/s^2/sqrt(Hz) about 1 g on z;
- ``out/logs/rosbag2_imu/``: a ROS 2 bag (MCAP storage, written by the ``rosbags`` package's
  own writer) with two ``sensor_msgs/msg/Imu`` topics, ``/camera/imu`` and ``/imu/data``, each
  3 minutes at 200 Hz of white noise (2e-3 rad/s per sample) on a small bias;
- ``out/logs/flight.ulg``: a PX4 ULog built as PX4's "ULog File Format" page lays it out, with
  two instances of ``sensor_gyro`` (``sensor_gyro`` and ``sensor_gyro:1``), each 90 s at 400 Hz
  of white noise (2e-3 rad/s per sample).

Real logs are beside the project in ``../shared/realdata`` (the ADIS16405 CSV, an imucal
Ferraris session, PX4 ULogs).
"""

import argparse
import math
from pathlib import Path

import numpy as np

T0_NS = 1403636579758555392          # a EuRoC MH_01 stamp (1.4e18 ns)
EUROC_HEADER = ("#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]")


def write_euroc(path: Path, minutes: float = 20.0, fs: float = 100.0, seed: int = 5) -> None:
    rng = np.random.default_rng(seed)
    n = int(round(minutes * 60 * fs))
    N, K = 2e-4, 2e-5                                   # rad/sqrt(s), rad/s/sqrt(s)
    w = rng.normal(0, N * math.sqrt(fs), (n, 3)) + np.cumsum(
        rng.normal(0, K / math.sqrt(fs), (n, 3)), axis=0)
    a = rng.normal(0, 3e-3 * math.sqrt(fs), (n, 3)) + [0, 0, 9.80665]
    stamps = T0_NS + np.arange(n, dtype=np.int64) * int(round(1e9 / fs))
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w") as f:
        f.write(EUROC_HEADER + "\n")
        for i in range(n):
            f.write(",".join([str(int(stamps[i]))] + [repr(float(x)) for x in (*w[i], *a[i])]))
            f.write("\n")


def write_bag(path: Path, minutes: float = 3.0, fs: float = 200.0, seed: int = 3) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    rng = np.random.default_rng(seed)
    n = int(round(minutes * 60 * fs))
    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    typ = "sensor_msgs/msg/Imu"
    stamps = T0_NS + np.arange(n, dtype=np.int64) * int(round(1e9 / fs))
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as wr:
        for topic in ("/camera/imu", "/imu/data"):
            conn = wr.add_connection(topic, typ, typestore=ts)
            w = rng.normal(0.0, 2e-3, (n, 3)) + [1e-4, -2e-4, 3e-4]
            a = rng.normal(0.0, 2e-2, (n, 3)) + [0.0, 0.0, 9.80665]
            for i in range(n):
                t = int(stamps[i])
                msg = T[typ](
                    header=T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](
                        sec=t // 1_000_000_000, nanosec=t % 1_000_000_000), frame_id="imu"),
                    orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
                    orientation_covariance=np.zeros(9),
                    angular_velocity=T["geometry_msgs/msg/Vector3"](x=w[i, 0], y=w[i, 1],
                                                                    z=w[i, 2]),
                    angular_velocity_covariance=np.zeros(9),
                    linear_acceleration=T["geometry_msgs/msg/Vector3"](x=a[i, 0], y=a[i, 1],
                                                                       z=a[i, 2]),
                    linear_acceleration_covariance=np.zeros(9))
                wr.write(conn, t + 1000, ts.serialize_cdr(msg, typ))   # received 1 us later


def write_ulog(path: Path, seconds: float = 90.0, fs: float = 400.0, seed: int = 2) -> None:
    """The 16-byte header (magic 'ULog' 01 12 35, version 1, start time in us), a flag-bits
    message 'B', a format message 'F', an 'A' (add logged message) per instance and the 'D'
    data messages, little-endian."""
    import struct

    rng = np.random.default_rng(seed)
    n = int(round(seconds * fs))
    t_us = 5_000_000 + np.arange(n, dtype=np.int64) * int(round(1e6 / fs))
    name, instances = "sensor_gyro", (0, 1)
    w = rng.normal(0, 2e-3, (len(instances), n, 3)).astype(np.float32)
    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", int(t_us[0])))

    def msg(kind, payload):
        out.extend(struct.pack("<HB", len(payload), ord(kind)))
        out.extend(payload)

    msg("B", bytes(16) + struct.pack("<QQQ", 0, 0, 0))
    fields = ("uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;"
              "float x;float y;float z;float temperature;uint32_t error_count;")
    msg("F", f"{name}:{fields}".encode())
    for k, m in enumerate(instances):
        msg("A", struct.pack("<BH", m, k) + name.encode())
    for i in range(n):
        for k in range(len(instances)):
            msg("D", struct.pack("<HQQIffffI", k, int(t_us[i]) + 150, int(t_us[i]), 7 + k,
                                 *w[k, i], 31.5, 0))
    path.write_bytes(bytes(out))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", type=Path, help="folder to write into (must not hold the logs yet)")
    args = p.parse_args()
    write_euroc(args.out / "mav0" / "imu0" / "data.csv")
    write_bag(args.out / "rosbag2_imu")
    write_ulog(args.out / "flight.ulg")
    for name in ("mav0/imu0/data.csv", "rosbag2_imu", "flight.ulg"):
        print(f"wrote {args.out / name}")


if __name__ == "__main__":
    main()
