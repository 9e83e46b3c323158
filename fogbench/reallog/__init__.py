"""Real gyro logs from the command line: ``fogbench allan``, ``calibrate`` and ``compensate``,
one module each (:mod:`.allan`, :mod:`.calibrate`, :mod:`.compensate`; the model files
:mod:`.modelfile`, stderr :mod:`.console`).

The other log formats (EuRoC / TUM-VI CSV, ROS bags and MCAP, PX4 ULog) are read by
``fogbench.logformats`` into the same table; the output files' safety rules are
``fogbench.outdir.Outputs``, shared with ``fogbench device``.

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

from fogcomp.units import G0

from .allan import _cmd_allan
from .calibrate import _cmd_calibrate
from .compensate import _cmd_compensate
from .console import _warnings_as_lines
from .options import _common

__all__ = ["add_commands"]


def add_commands(subparsers) -> None:
    """Add ``allan``, ``calibrate`` and ``compensate`` to a ``fogbench`` argparse subparsers
    object; each sets ``func`` to a function of the parsed args returning the exit code."""
    a = subparsers.add_parser("allan", help="Allan deviation, confidence intervals and noise "
                              "terms of a gyro log (or of a given curve)")
    a.add_argument("log", nargs="?", help="log CSV (gzip accepted)")
    a.add_argument("--columns", help="gyro channels to analyse, comma-separated (default all)")
    a.add_argument("--out", help="folder for allan.json and one PNG per axis")
    a.add_argument("--curve", help="identify the noise terms of a given curve instead "
                   "(tau_s, adev_<unit>, optional adev_ci_low_/high_<unit>, optional axis; its "
                   "record's sample rate and length from --fs/--samples or its first line)")
    a.add_argument("--curve-ci", type=float,
                   help="probability content of the curve's interval columns (e.g. 0.95)")
    a.add_argument("--ci", type=float, help="probability content of the computed intervals "
                   "(default 0.683, one sigma)")
    a.add_argument("--model", help="a stated noise model, e.g. 'N + B + K' or 'N + GM + GM' "
                   "(terms Q, N, B, K, R, GM): fitted as stated, no selection")
    a.add_argument("--samples", type=int, help="--curve: number of samples of the record the "
                   "curve came from (default: its first line's n_samples=)")
    a.add_argument("--overwrite", action="store_true", help="replace the outputs of an earlier "
                   "fogbench allan in --out (recognised by its allan.json; nothing else)")
    a.add_argument("--kalibr", metavar="IMU.yaml", help="write Kalibr's imu.yaml: noise "
                   "density (Allan N) and random walk (K) of the gyroscopes and, when the log "
                   "has them, the accelerometers, SI, and update_rate")
    a.add_argument("--openvins", metavar="kalibr_imu_chain.yaml", help="the same values as "
                   "OpenVINS' kalibr_imu_chain.yaml")
    a.add_argument("--imu-topic", default="/imu0", help="rostopic written in --kalibr and "
                   "--openvins (default /imu0)")
    a.add_argument("--inflate-density", type=float, default=1.0, help="multiply the noise "
                   "densities written by this factor (default 1: none; stated in the file)")
    a.add_argument("--inflate-walk", type=float, default=1.0, help="multiply the random walks "
                   "written by this factor (default 1: none; stated in the file)")
    _common(a)
    a.set_defaults(func=_warnings_as_lines(_cmd_allan))

    c = subparsers.add_parser("calibrate", help="fit a fogcomp method, or the Ferraris "
                              "six-position + three-rotation triad calibration, on a record")
    c.add_argument("method", help="a fogcomp method name, or 'ferraris'")
    c.add_argument("log", help="calibration record CSV")
    c.add_argument("--out", required=True, help="model path (writes MODEL.json [+ per axis])")
    c.add_argument("--axis", choices=("x", "y", "z"), help="only this gyro axis")
    c.add_argument("--reference", help="column holding the applied rate (e.g. table_rate_dps)")
    c.add_argument("--rate-dps", type=float, help="constant applied rate, deg/s")
    c.add_argument("--static", action="store_true", help="at rest: the Earth rate is applied")
    c.add_argument("--latitude-deg", type=float, help="latitude for --static, deg, -90 to 90")
    c.add_argument("--heading-deg", type=float, help="heading of the x axis for --static, deg "
                   "from north, clockwise")
    c.add_argument("--z-up", action="store_true", help="--static body frame x forward, y left, "
                   "z up (default x forward, y right, z down)")
    c.add_argument("--seed", type=int, help="seed of methods that draw random numbers")
    c.add_argument("--angle-deg", type=float, help="ferraris: angle of each rotation, deg")
    c.add_argument("--g", type=float, default=G0, help="ferraris: local gravity in m/s^2 (not "
                   "in g), 9.7 to 9.9 (default 9.80665; imucal uses 9.81)")
    c.add_argument("--kalibr", metavar="IMU.yaml", help="ferraris: also write the triad's "
                   "intrinsics as Kalibr's scale-misalignment block (M, A, C_gyro_i), SI")
    c.add_argument("--openvins", metavar="kalibr_imu_chain.yaml", help="ferraris: also write "
                   "them as OpenVINS' kalibr_imu_chain.yaml (Tw, R_IMUtoGYRO, Ta, R_IMUtoACC, Tg)")
    c.add_argument("--imu-topic", default="/imu0", help="rostopic written in --kalibr and "
                   "--openvins (default /imu0)")
    c.add_argument("--overwrite", action="store_true", help="replace a model written by an "
                   "earlier fogbench calibrate (recognised by its format key; nothing else)")
    _common(c)
    c.set_defaults(func=_warnings_as_lines(_cmd_calibrate))

    m = subparsers.add_parser("compensate", help="apply a model from fogbench calibrate to a log")
    m.add_argument("model", help="MODEL(.json) written by fogbench calibrate")
    m.add_argument("log", help="log CSV")
    m.add_argument("--out", required=True, help="output CSV (.csv or .csv.gz)")
    m.add_argument("--overwrite", action="store_true", help="replace a CSV written by an "
                   "earlier fogbench compensate (recognised by its _comp_/_cal_ columns; "
                   "nothing else, never an input)")
    _common(m)
    m.set_defaults(func=_warnings_as_lines(_cmd_compensate))
