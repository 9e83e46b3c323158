"""Real gyro logs: what ``fogbench allan``, ``calibrate`` and ``compensate`` do, one module
each (:mod:`.allan`, :mod:`.calibrate`, :mod:`.compensate`; the model files :mod:`.modelfile`;
how a log is read :mod:`.options`), each a function of its options.

The other log formats (EuRoC / TUM-VI CSV, ROS bags and MCAP, PX4 ULog) are read by
``fogbench.formats`` into the same table; the output files' safety rules are
``fogbench.outputs.folders.Outputs``, shared with ``fogbench device``.

A log is a CSV file (gzip accepted) whose header names carry their units, as the project's own keys
do: ``time_s``, ``gyro_x_dps`` / ``_rps`` / ``_dph``, ``acc_x_g`` / ``_mps2`` (``accel_`` is read as
``acc_``), ``temp_c``; ``_au`` marks raw sensor counts (only a calibration such as ``ferraris``
turns them into physical units). Files with other headers are mapped with
``--column gyro_z=GyroZ:dps``. The sample rate comes from the time column or from ``--fs``.

Everything is validated before any work starts and nothing is written when the input is refused:
each error (a :class:`LogError`) names the file, the row (line of the file) and the column.
Outputs are written to temporary files and renamed into place once all of them are complete.
"""

from __future__ import annotations

from fogbench.logs.allan import AllanOptions, allan
from fogbench.logs.calibrate import CalibrateOptions, calibrate
from fogbench.logs.compensate import CompensateOptions, compensate
from fogbench.logs.options import LogOptions

__all__ = ["LogOptions", "AllanOptions", "allan", "CalibrateOptions", "calibrate",
           "CompensateOptions", "compensate"]
