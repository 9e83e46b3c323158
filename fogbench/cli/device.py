"""``fogbench device show|schema|fit|check``: device files shown, fitted to a user's logs and
checked against a log (:mod:`fogbench.device.commands`)."""

from __future__ import annotations

from fogbench.cli._common import add_log_flags, options
from fogbench.console import warnings_as_lines


def add_parser(commands) -> None:
    d = commands.add_parser("device", help="device files: show a preset as one, fit one to "
                            "your logs, check one against a log")
    sub = d.add_subparsers(dest="device_command", required=True)
    _add_show(sub)
    _add_schema(sub)
    _add_fit(sub)
    _add_check(sub)


def _add_show(sub) -> None:
    s = sub.add_parser("show", help="print a preset (or a device file, validated) as a device "
                       "file")
    s.add_argument("name", help="a preset of sim/presets.toml, or a device file")
    s.add_argument("--kalibr", metavar="IMU.yaml", help="write the device's noise as Kalibr's "
                   "imu.yaml instead (gyroscope noise density and random walk, SI)")
    s.add_argument("--openvins", metavar="kalibr_imu_chain.yaml", help="the same as OpenVINS' "
                   "kalibr_imu_chain.yaml")
    s.add_argument("--rate-hz", type=float, help="with --kalibr/--openvins: the IMU's rate, "
                   "Hz (update_rate)")
    s.add_argument("--imu-topic", default="/imu0", help="rostopic written (default /imu0)")
    s.add_argument("--inflate-density", type=float, default=1.0, help="multiply the noise "
                   "density by this factor (default 1; stated in the file)")
    s.add_argument("--inflate-walk", type=float, default=1.0, help="multiply the random walk "
                   "by this factor (default 1; stated in the file)")
    s.add_argument("--overwrite", action="store_true", help="replace a file an earlier "
                   "--kalibr/--openvins wrote (nothing else)")
    s.set_defaults(func=warnings_as_lines(_show))


def _add_schema(sub) -> None:
    j = sub.add_parser("schema", help="print the JSON Schema of a device file (the [fog] keys), "
                       "for an editor to complete and check them")
    j.set_defaults(func=_schema)


def _add_fit(sub) -> None:
    f = sub.add_parser("fit", help="fit a device file to static, thermal, multi-position logs "
                       "and/or an Allan curve")
    f.add_argument("--static", action="append", default=[], metavar="LOG.csv",
                   help="a static log of one power-on (repeatable: several power-ons give the "
                        "switch-on repeatability)")
    f.add_argument("--curve", help="an Allan curve (tau_s, adev_<unit>; as fogbench allan "
                   "--curve reads it)")
    f.add_argument("--thermal", metavar="LOG.csv", help="a log at a constant rate through a "
                   "temperature program, with its temperature sensor (temp_c): the "
                   "temperature terms and the coil's lag (needs --static or --curve)")
    f.add_argument("--multipos", metavar="LOG.csv", help="a multi-position, centrifuge or "
                   "rate-table log: gyro, acc_x/y/z (specific force in the body axes) and a "
                   "reference rate column (--reference): the g and g^2 terms and the scale "
                   "factor; with --static or --curve for the noise model")
    f.add_argument("--reference", metavar="COLUMN", help="--multipos: the column of the "
                   "reference rate about the input axis, with its unit (e.g. ref_dps)")
    f.add_argument("--full-scale-dps", type=float, help="--multipos: the gyro's full scale, "
                   "deg/s (datasheet), at which the scale factor's non-linearity is stated")
    f.add_argument("--curve-ci", type=float, help="--curve: probability content of its "
                   "interval columns (e.g. 0.95); the fit uses its own covariance, not them")
    f.add_argument("--samples", type=int, help="--curve: samples of its record (default: its "
                   "first line's n_samples=)")
    f.add_argument("--axis", choices=("x", "y", "z"), help="the gyro axis (column gyro_<axis>) "
                   "when the log has several")
    f.add_argument("--latitude-deg", type=float, help="latitude of the static logs, deg: the "
                   "bias is corrected for the Earth rate")
    f.add_argument("--input-axis", choices=("up", "down", "level"), help="the gyro's input "
                   "axis during the static logs: with --latitude-deg, the Earth rate's "
                   "projection; with --multipos, up or down states their attitude (specific "
                   "force +-1 g along the input axis) for a static log without acc_x/y/z "
                   "columns, whose bias the fitted g terms are taken out of")
    f.add_argument("--heading-deg", type=float, help="--input-axis level: its heading from "
                   "north, deg")
    f.add_argument("--ci", type=float, help="probability content of the intervals (default "
                   "0.683)")
    f.add_argument("--min-tau-s", type=float, help="fit the noise terms on averaging times "
                   "from this on, s (leaves out those the sensor's own low-pass filter shapes)")
    f.add_argument("--out", required=True, help="the device file to write (.toml)")
    f.add_argument("--overwrite", action="store_true", help="replace a device file written by "
                   "an earlier fogbench device fit (recognised by its first line; nothing else)")
    add_log_flags(f)
    f.set_defaults(func=warnings_as_lines(_fit))


def _add_check(sub) -> None:
    c = sub.add_parser("check", help="simulate a device under a log's conditions and compare "
                       "the Allan curves")
    c.add_argument("device", help="device file (.toml)")
    c.add_argument("log", nargs="?", help="static log CSV")
    c.add_argument("--curve", help="an Allan curve with interval columns instead of a log "
                   "(its record's rate and length from its first line, --fs, --samples)")
    c.add_argument("--curve-ci", type=float, help="--curve: probability content of its "
                   "interval columns (e.g. 0.95)")
    c.add_argument("--samples", type=int, help="--curve: samples of its record")
    c.add_argument("--axis", choices=("x", "y", "z"), help="the gyro axis of the log")
    c.add_argument("--replicates", type=int, default=39, help="simulated records (twins), "
                   "19 to 1000 (default 39: the test's p-value moves in steps of 1/40)")
    c.add_argument("--seed", type=int, default=0, help="first seed of the twin's records")
    c.add_argument("--out", help="folder for device_check.json and device_check.png")
    c.add_argument("--overwrite", action="store_true", help="replace the outputs of an earlier "
                   "fogbench device check in --out")
    add_log_flags(c)
    c.set_defaults(func=warnings_as_lines(_check))


def _show(args) -> int:
    from fogbench.device.commands import ShowOptions, show

    return show(options(ShowOptions, args))


def _schema(args) -> int:
    from fogbench.device.commands import schema

    return schema()


def _fit(args) -> int:
    from fogbench.device.commands import FitOptions, fit

    return fit(options(FitOptions, args))


def _check(args) -> int:
    from fogbench.device.commands import CheckOptions, check

    return check(options(CheckOptions, args))
