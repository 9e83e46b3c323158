"""The log formats ``fogbench allan``, ``calibrate``, ``compensate`` and ``device`` read, one
module per format, each turning a file into the same table the CSV reader gives (a
``pandas.DataFrame`` whose column names carry their units: ``time_ns``, ``gyro_x_rps``,
``acc_x_mps2``) and a :class:`Rows` that names a row in the file's own terms (a CSV's line, a
bag's message), so that every later check (units, magnitudes, time, gaps) is the CSV reader's
and names the place in the file.

- CSV (:mod:`.csvfile`, with EuRoC / TUM-VI's ``#`` header: :mod:`.euroc`), validated by
  :mod:`.table` whatever the format;
- ROS 1 bags, ROS 2 bags (a folder with ``metadata.yaml``, or a ``.db3``) and MCAP files with
  ``sensor_msgs/msg/Imu`` (:mod:`.rosbag`, the ``rosbags`` package);
- PX4 ULog ``sensor_gyro`` / ``sensor_combined`` (:mod:`.ulog`, ``pyulog``).

The format is recognised from the file's content (its magic bytes; a folder with
``metadata.yaml``), or given with ``--format``; a gzip-compressed file by the magic bytes of
what it holds (a ``.ulg.gz`` is read, a compressed bag or MCAP refused saying to gunzip it).
"""

from __future__ import annotations

from fogbench.formats.detect import FORMATS, Rows, detect, gzip_payload
from fogbench.formats.table import read_table

__all__ = ["Rows", "FORMATS", "detect", "read_table", "gzip_payload"]
