"""``fogbench attitude LOG``: a static triad log integrated to roll, pitch and heading, raw
and bias-calibrated, against the attitude it started in (:func:`fogbench.logs.attitude.attitude`)."""

from __future__ import annotations

from fogbench.cli._common import add_log_flags, number, options
from fogbench.console import warnings_as_lines


def add_parser(sub) -> None:
    a = sub.add_parser("attitude", help="integrate a static triad log to roll, pitch and "
                       "heading: its drift raw and with the bias of its first part removed")
    a.add_argument("log", help="a triad log (gyro_x, gyro_y, gyro_z; acc_* for levelling)")
    a.add_argument("--latitude-deg", type=number(float, -90.0, hi=90.0),
                   help="the site's latitude, deg: the Earth's rate is removed (default: left in "
                   "the raw integration, with a note)")
    a.add_argument("--heading-deg", type=number(float, -360.0, hi=360.0), default=0.0,
                   help="heading of the x axis at the start, deg from north, clockwise "
                   "(default 0: a static log's heading is unknown)")
    a.add_argument("--initial-rpy-deg", metavar="ROLL,PITCH,HEADING",
                   help="the initial attitude whole (z-y-x Euler angles, deg), instead of "
                   "levelling on the accelerometers")
    a.add_argument("--initial-quat", metavar="W,X,Y,Z",
                   help="the initial attitude as a unit quaternion, body to NED")
    a.add_argument("--align-s", type=number(float, 0.0, lo_open=True), default=60.0,
                   help="levelling: the mean specific force over the first seconds (default 60)")
    a.add_argument("--calibrate-s", type=number(float, 0.0, lo_open=True),
                   help="the bias from the first seconds, scored on the rest (default: the "
                   "first 20 %% of the log)")
    a.add_argument("--window-s", type=number(float, 0.0, lo_open=True), default=600.0,
                   help="drift windows of the scored part, s (default 600)")
    a.add_argument("--out", help="folder for attitude.json and attitude.png")
    a.add_argument("--overwrite", action="store_true", help="replace an earlier fogbench "
                   "attitude's outputs (recognised by attitude.json's format key)")
    add_log_flags(a)
    a.set_defaults(func=warnings_as_lines(_attitude))


def _attitude(args) -> int:
    from fogbench.logs.attitude import AttitudeOptions, attitude

    return attitude(options(AttitudeOptions, args))
