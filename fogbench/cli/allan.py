"""``fogbench allan LOG`` (or ``--curve``): the Allan deviation of a log's gyro channels, its
intervals, the identified noise terms, figures, and Kalibr / OpenVINS noise files
(:func:`fogbench.logs.allan.allan`)."""

from __future__ import annotations

from fogbench.cli._common import add_log_flags, number, options
from fogbench.console import warnings_as_lines


def add_parser(sub) -> None:
    a = sub.add_parser("allan", help="Allan deviation, confidence intervals and noise "
                              "terms of a gyro log (or of a given curve)")
    a.add_argument("log", nargs="?", help="log CSV (gzip accepted)")
    a.add_argument("--columns", help="gyro channels to analyse, comma-separated: gyro_x or "
                   "gyro_x_dps (the unit is the header's; default all)")
    a.add_argument("--out", help="folder for allan.json and one PNG per axis")
    a.add_argument("--curve", help="identify the noise terms of a given curve instead "
                   "(tau_s, adev_<unit>, optional adev_ci_low_<unit>/adev_ci_high_<unit>, "
                   "optional axis; its record's sample rate and length from --fs/--samples or "
                   "its first line)")
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
    a.add_argument("--inflate-density", type=number(float, 0.0, lo_open=True), default=1.0,
                   help="multiply the noise densities written by this factor, > 0 (default 1: "
                   "none; stated in the file)")
    a.add_argument("--inflate-walk", type=number(float, 0.0, lo_open=True), default=1.0,
                   help="multiply the random walks written by this factor, > 0 (default 1: "
                   "none; stated in the file)")
    a.add_argument("--consistency", action="store_true", help="identify the noise model on "
                   "the first part of the log, run the Kalman filter it implies (and Kalibr's "
                   "N + K filter) over the rest, and measure the inflation factor that makes "
                   "its NIS consistent, with its interval (printed, in allan.json, and in the "
                   "comments of --kalibr / --openvins)")
    a.add_argument("--holdout", type=float, default=0.5, help="--consistency: fraction of the "
                   "log held out for the filter (default 0.5: identified on the first half)")
    a.add_argument("--inflate-measured", action="store_true", help="inflate the values of "
                   "--kalibr / --openvins by the measured factor (implies --consistency)")
    add_log_flags(a)
    a.set_defaults(func=warnings_as_lines(_allan))


def _allan(args) -> int:
    from fogbench.logs.allan import AllanOptions, allan

    return allan(options(AllanOptions, args))
