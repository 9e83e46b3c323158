"""``fogbench calibrate METHOD LOG --out MODEL``: a fogcomp method, or the Ferraris triad
calibration, fitted on a record against its reference (:func:`fogbench.logs.calibrate.calibrate`)."""

from __future__ import annotations

from fogbench.cli._common import add_log_flags, options
from fogcomp.units import G0

from fogbench.console import warnings_as_lines


def add_parser(sub) -> None:
    c = sub.add_parser("calibrate", help="fit a fogcomp method, or the Ferraris "
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
    add_log_flags(c)
    c.set_defaults(func=warnings_as_lines(_calibrate))


def _calibrate(args) -> int:
    from fogbench.logs.calibrate import CalibrateOptions, calibrate

    return calibrate(options(CalibrateOptions, args))
