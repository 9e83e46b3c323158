"""The options every log command shares (format, topic, column map, sample rate, gaps)."""

from __future__ import annotations


def _source(args) -> dict:
    """--format and --topic as read_log's keywords."""
    return {"fmt": getattr(args, "format", None), "topic": getattr(args, "topic", None)}


def _common(p) -> None:
    p.add_argument("--format", choices=("csv", "euroc", "rosbag", "ulog"),
                   help="the log's format (default: recognised from the file: a CSV, a "
                   "EuRoC/TUM-VI imu0/data.csv, a ROS 1/2 bag or MCAP file, a PX4 ULog)")
    p.add_argument("--topic", help="a bag's sensor_msgs/msg/Imu topic, or a ULog's "
                   "sensor_gyro, sensor_gyro:1, sensor_combined (default: the only one)")
    p.add_argument("--column", action="append", metavar="CH=HEADER:UNIT",
                   help="map a file column to a channel, e.g. gyro_z=GyroZ:dps (repeatable, or "
                        "comma-separated)")
    p.add_argument("--fs", type=float, help="sample rate, Hz (when the log has no time column)")
    p.add_argument("--gaps", choices=("refuse", "split"), default="refuse",
                   help="a gap in the time column: refuse the file (default) or split at it")
    p.add_argument("--time-tolerance", type=float, default=0.05,
                   help="largest relative departure of a sample interval from the median one "
                        "(default 0.05)")
