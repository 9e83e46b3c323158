"""The log formats people record, read back to the samples that were written: EuRoC / TUM-VI
CSV (the '#' header, nanosecond stamps, units in brackets), our CSV with ns/us time; each read
by ``fogbench allan`` to the same result as the project's own CSV of the same samples, and each
malformed file refused naming file, line and field, with nothing written."""

from __future__ import annotations

import contextlib
import json
import math
import re
import warnings

import numpy as np
import pytest

from fogbench.formats.table import read_log

from helpers import run_cli, run_parsed as run

FS = 200.0
T0_NS = 1403636579758555392       # a EuRoC MH_01 stamp: 1.4e18 ns, past float64's exact range
EUROC_HEADER = ("#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]")


def _record(n=6000, seed=3):
    """A simulated static record: white rate noise plus a small bias on each gyro axis, white
    noise on the accelerometers about 1 g on z."""
    rng = np.random.default_rng(seed)
    w = rng.normal(0.0, 2e-3, (n, 3)) + [1e-4, -2e-4, 3e-4]
    a = rng.normal(0.0, 2e-2, (n, 3)) + [0.0, 0.0, 9.80665]
    stamps = T0_NS + np.arange(n, dtype=np.int64) * 5_000_000
    return stamps, w, a


def _write_euroc(path, stamps, w, a, header=EUROC_HEADER, rows=None):
    """As the EuRoC MAV dataset's imu0/data.csv is laid out (its README; MH_01_easy)."""
    lines = [header]
    for i in range(len(stamps)) if rows is None else rows:
        lines.append(",".join([str(int(stamps[i]))] + [repr(float(x)) for x in (*w[i], *a[i])]))
    path.write_text("\n".join(lines) + "\n")
    return path


def _write_ours(path, stamps, w):
    t = (stamps - stamps[0]) / 1e9
    lines = ["time_s,gyro_x_rps,gyro_y_rps,gyro_z_rps"]
    lines += [",".join(repr(float(x)) for x in (t[i], *w[i])) for i in range(len(t))]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_euroc_file_reads_back_to_the_written_samples(tmp_path):
    stamps, w, a = _record()
    log = read_log(_write_euroc(tmp_path / "data.csv", stamps, w, a))
    assert log.fs == pytest.approx(FS, rel=1e-12)      # exact ns differences, not 256 ns steps
    for k, ax in enumerate("xyz"):
        np.testing.assert_array_equal(log.channels[f"gyro_{ax}"], w[:, k])
        np.testing.assert_array_equal(log.channels[f"acc_{ax}"], a[:, k])
    assert log.units["gyro_x"] == "rps" and log.sources["gyro_x"] == "w_RS_S_x [rad s^-1]"


def test_allan_on_a_euroc_file_equals_allan_on_our_csv(tmp_path):
    stamps, w, a = _record()
    e = _write_euroc(tmp_path / "data.csv", stamps, w, a)
    o = _write_ours(tmp_path / "ours.csv", stamps, w)
    assert run(["allan", e, "--out", tmp_path / "ae"])[0] == 0
    assert run(["allan", o, "--out", tmp_path / "ao"])[0] == 0
    je = json.loads((tmp_path / "ae" / "allan.json").read_text())
    jo = json.loads((tmp_path / "ao" / "allan.json").read_text())
    assert je["fs_hz"] == pytest.approx(jo["fs_hz"], rel=1e-9)
    for ax in "xyz":
        ce, co = je["columns"][f"gyro_{ax}_rps"], jo["columns"][f"gyro_{ax}_rps"]
        np.testing.assert_allclose(ce["adev_dph"], co["adev_dph"], rtol=1e-9)
        arw = {t["term"]: t for t in ce["noise"]["terms"]}["N"]
        # white noise of 2e-3 rad/s at 200 Hz: N = 2e-3 / sqrt(200) rad/s/sqrt(Hz), by hand
        n_hand = 2e-3 / math.sqrt(FS) * 180 / math.pi * 60
        assert arw["arw_deg_rt_h"] == pytest.approx(n_hand, rel=0.05)


@pytest.mark.parametrize("unit,scale", [("ns", 1e9), ("us", 1e6), ("ms", 1e3)])
def test_our_csv_takes_ns_and_us_time(tmp_path, unit, scale):
    n = 500
    t = np.arange(n) / FS
    stamps = np.round(t * scale).astype(np.int64) + (T0_NS if unit == "ns" else 0)
    p = tmp_path / "log.csv"
    p.write_text(f"time_{unit},gyro_z_dps\n" + "".join(
        f"{stamps[i]},{math.sin(i)}\n" for i in range(n)))
    assert read_log(p).fs == pytest.approx(FS, rel=1e-9)


def _bad(tmp_path, name):
    stamps, w, a = _record(n=1000)
    p = tmp_path / "data.csv"
    if name == "missing column":
        hdr = EUROC_HEADER.replace(",w_RS_S_z [rad s^-1]", "")
        lines = [hdr] + [",".join([str(int(stamps[i]))] + [repr(float(x)) for x in
                                                            (w[i, 0], w[i, 1], *a[i])])
                         for i in range(len(stamps))]
        p.write_text("\n".join(lines) + "\n")
        return p, ["--columns", "gyro_z"], r"data\.csv: a EuRoC / TUM-VI header without .w_RS_S_z"
    if name == "time going back":
        stamps = stamps.copy()
        stamps[500] = stamps[498]
        _write_euroc(p, stamps, w, a)
        # row 500 is the file's line 502 (the header is line 1)
        return p, [], r"data\.csv: line 502, column 'timestamp \[ns\]': time not increasing"
    if name == "unknown unit":
        _write_euroc(p, stamps, w, a, header=EUROC_HEADER.replace("w_RS_S_x [rad s^-1]",
                                                                  "w_RS_S_x [rpm]"))
        return p, [], r"column 'w_RS_S_x \[rpm\]': unknown unit 'rpm'"
    if name == "short row":
        _write_euroc(p, stamps, w, a)
        text = p.read_text().splitlines()
        text[300] = text[300].rsplit(",", 1)[0]
        p.write_text("\n".join(text) + "\n")
        return p, [], r"data\.csv: line 301: 6 field\(s\), the header \(line 1\) has 7"
    raise KeyError(name)


@pytest.mark.parametrize("name", ["missing column", "time going back", "unknown unit",
                                  "short row"])
def test_a_malformed_euroc_file_is_refused_naming_line_and_field(tmp_path, name):
    p, flags, match = _bad(tmp_path, name)
    before = set(tmp_path.rglob("*"))
    code, err = run(["allan", p, "--out", tmp_path / "out", *flags])
    assert code == 2
    assert re.search(match, err), err
    assert "\n" not in err
    assert set(tmp_path.rglob("*")) == before


# ---------------------------------------------------------------------------------------------
# Kalibr / OpenVINS noise files
RAD_PER_DEG = math.pi / 180.0


def _arw_si(deg_rt_h):      # deg/sqrt(h) -> rad/s/sqrt(Hz) = rad/sqrt(s)
    return deg_rt_h * RAD_PER_DEG / 60.0


def _rrw_si(dph_rt_h):      # deg/h/sqrt(h) -> rad/s^2/sqrt(Hz) = rad/s/sqrt(s)
    return dph_rt_h * RAD_PER_DEG / 3600.0 / 60.0


def _walk_record(path, n=120_000, fs=100.0, seed=5):
    """Gyro: white rate noise N plus a rate random walk K, large enough for a 20-minute record
    to show both; accelerometer: white noise only."""
    rng = np.random.default_rng(seed)
    N, K = 2e-4, 2e-5                       # rad/sqrt(s), rad/s/sqrt(s)
    w = rng.normal(0, N * math.sqrt(fs), (n, 3)) + np.cumsum(
        rng.normal(0, K / math.sqrt(fs), (n, 3)), axis=0)
    a = rng.normal(0, 3e-3 * math.sqrt(fs), (n, 3)) + [0, 0, 9.80665]
    stamps = T0_NS + np.arange(n, dtype=np.int64) * int(1e9 / fs)
    _write_euroc(path, stamps, w, a)
    return N, K


def _yaml(path):
    import yaml

    text = path.read_text()
    if text.startswith("%YAML:1.0"):       # OpenCV's directive, which OpenVINS needs
        text = text.split("\n", 1)[1]
    return yaml.safe_load(text)


def test_kalibr_and_openvins_files_hold_the_identified_terms_converted_by_hand(tmp_path):
    log = tmp_path / "data.csv"
    N, K = _walk_record(log)
    code, err = run(["allan", log, "--out", tmp_path / "a", "--kalibr", tmp_path / "imu.yaml",
                     "--openvins", tmp_path / "chain.yaml", "--imu-topic", "/imu1"])
    assert code == 0, err
    doc = json.loads((tmp_path / "a" / "allan.json").read_text())

    def si(kind, term):
        """The allan.json value per axis (identified, else its 95 % bound), to SI by hand."""
        out = []
        for ax in "xyz":
            t = {t["term"]: t for t in doc["columns"][f"gyro_{ax}_rps"]["noise"]["terms"]}[term]
            key = "arw_deg_rt_h" if term == "N" else "rrw_dph_rt_h"
            v = t[key] if t["status"] == "identified" else t[key + "_bound95"]
            out.append(_arw_si(v) if term == "N" else _rrw_si(v))
        return max(out)

    k = _yaml(tmp_path / "imu.yaml")
    o = _yaml(tmp_path / "chain.yaml")["imu0"]
    for d in (k, o):
        assert d["gyroscope_noise_density"] == pytest.approx(si("gyro", "N"), rel=1e-6)
        assert d["gyroscope_random_walk"] == pytest.approx(si("gyro", "K"), rel=1e-6)
        assert d["update_rate"] == pytest.approx(100.0)
        assert d["rostopic"] == "/imu1"
        # and the values are the record's, to the identifier's accuracy on 20 minutes
        assert d["gyroscope_noise_density"] == pytest.approx(N, rel=0.1)
        assert d["gyroscope_random_walk"] == pytest.approx(K, rel=0.5)
        assert d["accelerometer_noise_density"] == pytest.approx(3e-3, rel=0.1)
        assert d["accelerometer_random_walk"] > 0
    assert o["model"] == "kalibr" and o["Tg"] == [[0.0] * 3] * 3
    assert "not inflated" in (tmp_path / "imu.yaml").read_text()


def test_inflation_is_applied_only_when_asked_and_stated(tmp_path):
    log = tmp_path / "data.csv"
    _walk_record(log, n=20_000)
    assert run(["allan", log, "--kalibr", tmp_path / "plain.yaml"])[0] == 0
    assert run(["allan", log, "--kalibr", tmp_path / "infl.yaml", "--inflate-density", "5",
                "--inflate-walk", "10"])[0] == 0
    p, i = _yaml(tmp_path / "plain.yaml"), _yaml(tmp_path / "infl.yaml")
    assert i["gyroscope_noise_density"] == pytest.approx(5 * p["gyroscope_noise_density"],
                                                         rel=1e-8)
    assert i["accelerometer_random_walk"] == pytest.approx(10 * p["accelerometer_random_walk"],
                                                           rel=1e-8)
    assert "INFLATED" in (tmp_path / "infl.yaml").read_text()


def test_a_device_file_round_trips_into_kalibr_values(tmp_path):
    """Device file -> Kalibr file -> values: the tactical preset's ARW 0.03 deg/sqrt(h) and RRW
    0.1 deg/h/sqrt(h) (sim/presets.toml), converted by hand."""
    from fogbench.cli import main

    dev = tmp_path / "dev.toml"
    dev.write_text('source = "test"\narw_deg_rt_h = 0.03\nrrw_dph_rt_h = 0.1\n')
    assert main(["device", "show", str(dev), "--kalibr", str(tmp_path / "imu.yaml"),
                 "--rate-hz", "400"]) == 0
    d = _yaml(tmp_path / "imu.yaml")
    assert d["gyroscope_noise_density"] == pytest.approx(_arw_si(0.03), rel=1e-8)
    assert d["gyroscope_random_walk"] == pytest.approx(_rrw_si(0.1), rel=1e-8)
    assert d["update_rate"] == 400
    assert "accelerometer_noise_density" not in d      # a gyro's device file: left to fill in
    assert main(["device", "show", "tactical", "--kalibr", str(tmp_path / "t.yaml"),
                 "--rate-hz", "400"]) == 0
    assert _yaml(tmp_path / "t.yaml")["gyroscope_noise_density"] == pytest.approx(
        _arw_si(0.03), rel=1e-8)


@pytest.mark.parametrize("case", ["input", "foreign", "factor", "no rate"])
def test_noise_file_refusals_write_nothing(tmp_path, case):
    from fogbench.cli import main

    log = tmp_path / "data.csv"
    stamps, w, a = _record(n=2000)
    _write_euroc(log, stamps, w, a)
    foreign = tmp_path / "imu.yaml"
    foreign.write_text("gyroscope_noise_density: 1.0  # mine\n")
    before = {p: p.read_bytes() for p in tmp_path.rglob("*")}
    if case == "input":
        code, err = run(["allan", log, "--kalibr", log])
        assert code == 2 and "is an input" in err
    elif case == "foreign":
        code, err = run(["allan", log, "--kalibr", foreign, "--overwrite"])
        assert code == 2 and "not a kalibr file written by fogbench" in err
    elif case == "factor":
        code, err = run(["allan", log, "--kalibr", tmp_path / "new.yaml", "--inflate-walk",
                         "0.5"])
        assert code == 2 and "--inflate-walk" in err
    else:
        assert main(["device", "show", "tactical", "--kalibr", str(tmp_path / "n.yaml")]) == 2
    assert {p: p.read_bytes() for p in tmp_path.rglob("*")} == before


# ---------------------------------------------------------------------------------------------
# ROS bags and MCAP (written with the rosbags package's own writer), PX4 ULog (built as the ULog
# file format documentation lays it out)
def _imu_msg(ts, t_ns, w, a):
    T = ts.types
    return T["sensor_msgs/msg/Imu"](
        header=T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](
            sec=int(t_ns // 1_000_000_000), nanosec=int(t_ns % 1_000_000_000)), frame_id="imu"),
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=np.zeros(9),
        angular_velocity=T["geometry_msgs/msg/Vector3"](x=w[0], y=w[1], z=w[2]),
        angular_velocity_covariance=np.zeros(9),
        linear_acceleration=T["geometry_msgs/msg/Vector3"](x=a[0], y=a[1], z=a[2]),
        linear_acceleration_covariance=np.zeros(9))


def _write_bag(path, stamps, w, a, *, storage="mcap", topics=("/imu0",), other=False,
               zero_stamps=False):
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    typ = "sensor_msgs/msg/Imu"
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as wr:
        conns = [wr.add_connection(t, typ, typestore=ts) for t in topics]
        if other:
            s = wr.add_connection("/status", "std_msgs/msg/String", typestore=ts)
            wr.write(s, int(stamps[0]), ts.serialize_cdr(ts.types["std_msgs/msg/String"](
                data="ok"), "std_msgs/msg/String"))
        for i in range(len(stamps)):
            stamp = 0 if zero_stamps else stamps[i]
            raw = ts.serialize_cdr(_imu_msg(ts, stamp, w[i], a[i]), typ)
            for c in conns:
                wr.write(c, int(stamps[i]) + 1000, raw)   # received 1 us after the stamp
    return path


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_a_ros2_bag_reads_back_to_the_written_samples_and_allan_agrees(tmp_path, storage):
    stamps, w, a = _record(n=4000)
    bag = _write_bag(tmp_path / "bag", stamps, w, a, storage=storage, other=True)
    log = read_log(bag)
    assert log.fs == pytest.approx(FS, rel=1e-12)
    for k, ax in enumerate("xyz"):
        np.testing.assert_array_equal(log.channels[f"gyro_{ax}"], w[:, k])
        np.testing.assert_array_equal(log.channels[f"acc_{ax}"], a[:, k])
    assert "topic /imu0" in log.describe()
    # the storage file alone (the .mcap or .db3 inside the bag's folder) reads the same
    inner = next(p for p in bag.iterdir() if p.suffix in (".mcap", ".db3"))
    np.testing.assert_array_equal(read_log(inner).channels["gyro_z"], w[:, 2])
    o = _write_ours(tmp_path / "ours.csv", stamps, w)
    assert run(["allan", bag, "--out", tmp_path / "ab"])[0] == 0
    assert run(["allan", o, "--out", tmp_path / "ao"])[0] == 0
    jb = json.loads((tmp_path / "ab" / "allan.json").read_text())
    jo = json.loads((tmp_path / "ao" / "allan.json").read_text())
    np.testing.assert_allclose(jb["columns"]["gyro_x_rps"]["adev_dph"],
                               jo["columns"]["gyro_x_rps"]["adev_dph"], rtol=1e-9)


def test_a_bag_without_stamps_uses_the_bag_time_and_says_so(tmp_path):
    stamps, w, a = _record(n=500)
    log = read_log(_write_bag(tmp_path / "bag", stamps, w, a, zero_stamps=True))
    assert "bag's time" in log.describe()
    assert log.fs == pytest.approx(FS, rel=1e-12)


def _write_ulog(path, t_us, w, *, name="sensor_gyro", instances=(0,), fields=None):
    """A ULog file as docs.px4.io's "ULog File Format" lays it out: the 16-byte header (magic
    'ULog' 01 12 35, version 1, start time in us), a flag-bits message 'B', a format message
    'F', one 'A' (add logged message) per instance and 'D' data messages, little-endian."""
    import struct

    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", int(t_us[0])))

    def msg(kind, payload):
        out.extend(struct.pack("<HB", len(payload), ord(kind)))
        out.extend(payload)

    msg("B", bytes(16) + struct.pack("<QQQ", 0, 0, 0))
    fields = fields or ("uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;"
                        "float x;float y;float z;float temperature;uint32_t error_count;")
    msg("F", f"{name}:{fields}".encode())
    for k, m in enumerate(instances):
        msg("A", struct.pack("<BH", m, k) + name.encode())
    for i in range(len(t_us)):
        for k in range(len(instances)):
            msg("D", struct.pack("<HQQIffffI", k, int(t_us[i]) + 150, int(t_us[i]), 7,
                                 *w[i], 31.5, 0))
    path.write_bytes(bytes(out))
    return path


def test_a_ulog_reads_back_to_the_written_samples_and_allan_agrees(tmp_path):
    n = 4000
    t_us = 5_000_000 + np.arange(n, dtype=np.int64) * 2500            # 400 Hz
    w = np.random.default_rng(2).normal(0, 2e-3, (n, 3)).astype(np.float32)
    ulg = _write_ulog(tmp_path / "flight.ulg", t_us, w)
    log = read_log(ulg)
    assert log.fs == pytest.approx(400.0, rel=1e-12)
    for k, ax in enumerate("xyz"):
        np.testing.assert_array_equal(log.channels[f"gyro_{ax}"], w[:, k].astype(float))
    p = tmp_path / "ours.csv"
    p.write_text("time_us,gyro_x_rps,gyro_y_rps,gyro_z_rps\n" + "".join(
        f"{t_us[i]},{float(w[i, 0])!r},{float(w[i, 1])!r},{float(w[i, 2])!r}\n"
        for i in range(n)))
    assert run(["allan", ulg, "--out", tmp_path / "au"])[0] == 0
    assert run(["allan", p, "--out", tmp_path / "ao"])[0] == 0
    ju = json.loads((tmp_path / "au" / "allan.json").read_text())
    jo = json.loads((tmp_path / "ao" / "allan.json").read_text())
    np.testing.assert_allclose(ju["columns"]["gyro_y_rps"]["adev_dph"],
                               jo["columns"]["gyro_y_rps"]["adev_dph"], rtol=1e-9)


def _bad_binary(tmp_path, case):
    stamps, w, a = _record(n=300)
    if case == "truncated bag":
        bag = _write_bag(tmp_path / "bag", stamps, w, a)
        inner = next(p for p in bag.iterdir() if p.suffix == ".mcap")
        data = inner.read_bytes()
        cut = tmp_path / "cut.mcap"
        cut.write_bytes(data[:len(data) // 2])
        import shutil

        shutil.rmtree(bag)
        return cut, [], r"cut\.mcap: (not a readable ROS bag or MCAP file|topic '/imu0': " \
                        r"message \d+ cannot be read)"
    if case == "wrong message type":
        bag = _write_bag(tmp_path / "bag", stamps, w, a, other=True)
        return bag, ["--topic", "/status"], r"topic '/status' is std_msgs/msg/String, not " \
                                            r"sensor_msgs/msg/Imu; IMU topics: /imu0"
    if case == "missing topic":
        bag = _write_bag(tmp_path / "bag", stamps, w, a)
        return bag, ["--topic", "/imu9"], r"no topic '/imu9'; topics: /imu0 " \
                                          r"\(sensor_msgs/msg/Imu\)"
    if case == "two imu topics":
        bag = _write_bag(tmp_path / "bag", stamps, w, a, topics=("/imu0", "/imu1"))
        return bag, [], r"2 IMU topics \(/imu0, /imu1\); choose one with --topic"
    if case == "ulog without gyro":
        t_us = np.arange(300, dtype=np.int64) * 2500 + 1000
        ulg = _write_ulog(tmp_path / "f.ulg", t_us, w.astype(np.float32), name="vehicle_status")
        return ulg, [], r"f\.ulg: no gyro data \(no sensor_gyro or sensor_combined"
    if case == "ulog time back":
        t_us = np.arange(300, dtype=np.int64) * 2500 + 1000
        t_us[200] = t_us[198]
        ulg = _write_ulog(tmp_path / "f.ulg", t_us, w.astype(np.float32))
        return ulg, [], r"f\.ulg: message 201 of sensor_gyro, column " \
                        r"'sensor_gyro.timestamp_sample \[us\]': time not increasing"
    if case == "two ulog gyros":
        t_us = np.arange(300, dtype=np.int64) * 2500 + 1000
        ulg = _write_ulog(tmp_path / "f.ulg", t_us, w.astype(np.float32), instances=(0, 1))
        return ulg, [], r"2 gyro topics \(sensor_gyro, sensor_gyro:1\); choose one with --topic"
    if case == "topic on a csv":
        p = _write_euroc(tmp_path / "data.csv", stamps, w, a)
        return p, ["--topic", "/imu0"], r"--topic '/imu0': .*data\.csv is a CSV file"
    raise KeyError(case)


@pytest.mark.parametrize("case", ["truncated bag", "wrong message type", "missing topic",
                                  "two imu topics", "ulog without gyro", "ulog time back",
                                  "two ulog gyros", "topic on a csv"])
def test_malformed_bags_and_ulogs_are_refused_in_one_line_and_nothing_written(tmp_path, case):
    from fogbench.cli import main

    path, flags, match = _bad_binary(tmp_path, case)
    before = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")}
    code, err = run(["allan", path, "--out", tmp_path / "out", *flags])
    assert code == 2
    assert re.search(match, err), err
    assert "\n" not in err
    assert {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")} == before
    assert main(["allan", str(path), *flags]) == 2         # the CLI's exit status


def test_a_chosen_topic_reads_that_topic(tmp_path):
    stamps, w, a = _record(n=400)
    bag = _write_bag(tmp_path / "bag", stamps, w, a, topics=("/imu0", "/imu1"))
    log = read_log(bag, topic="/imu1")
    assert "topic /imu1" in log.describe()
    t_us = np.arange(400, dtype=np.int64) * 2500 + 1000
    ulg = _write_ulog(tmp_path / "f.ulg", t_us, w.astype(np.float32), instances=(0, 1))
    assert "sensor_gyro:1" in read_log(ulg, topic="sensor_gyro:1").describe()


def test_a_ros1_bag_reads_back_to_the_written_samples(tmp_path):
    """A ROS 1 bag written with rosbags' rosbag1 writer (ROS 1's sensor_msgs/Imu, the ROS 1
    serialisation)."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC)
    stamps, w, a = _record(n=600)
    path = tmp_path / "imu.bag"
    typ = "sensor_msgs/msg/Imu"
    T = ts.types
    with Writer(path) as wr:
        conn = wr.add_connection("/imu", typ, typestore=ts)
        for i in range(len(stamps)):
            t = int(stamps[i])
            msg = T[typ](
                header=T["std_msgs/msg/Header"](seq=i, stamp=T["builtin_interfaces/msg/Time"](
                    sec=t // 1_000_000_000, nanosec=t % 1_000_000_000), frame_id="imu"),
                orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
                orientation_covariance=np.zeros(9),
                angular_velocity=T["geometry_msgs/msg/Vector3"](x=w[i, 0], y=w[i, 1],
                                                                 z=w[i, 2]),
                angular_velocity_covariance=np.zeros(9),
                linear_acceleration=T["geometry_msgs/msg/Vector3"](x=a[i, 0], y=a[i, 1],
                                                                    z=a[i, 2]),
                linear_acceleration_covariance=np.zeros(9))
            wr.write(conn, t, ts.serialize_ros1(msg, typ))
    log = read_log(path)
    assert log.fs == pytest.approx(FS, rel=1e-12)
    np.testing.assert_array_equal(log.channels["gyro_y"], w[:, 1])
    np.testing.assert_array_equal(log.channels["acc_z"], a[:, 2])


@pytest.mark.parametrize("fmt", [None, "rosbag", "ulog"])
def test_a_pipe_is_refused_not_read_whatever_the_format(tmp_path, fmt):
    """Recognising a format reads the file's first bytes: a named pipe would block it for ever."""
    import os

    fifo = tmp_path / "imu.mcap"
    os.mkfifo(fifo)
    code, err = run(["allan", fifo, *(["--format", fmt] if fmt else [])])
    assert code == 2 and "not a regular file" in err


# ---------------------------------------------------------------------------------------------
# Review findings: a PX4 log's topics at the rates PX4's logger writes them, a EuRoC
# header with a field fogbench does not know, gzip-compressed ULog / MCAP, a truncated ULog
SENSOR_GYRO = (("uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;float x;"
                "float y;float z;float temperature;uint32_t error_count;"), "<QQIffffI")
# PX4's msg/SensorCombined.msg: gyro_integral_dt is the gyro's integration period, us
SENSOR_COMBINED = (("uint64_t timestamp;float[3] gyro_rad;uint32_t gyro_integral_dt;"
                    "int32_t accelerometer_timestamp_relative;float[3] accelerometer_m_s2;"
                    "uint32_t accelerometer_integral_dt;uint8_t accelerometer_clipping;"
                    "uint8_t gyro_clipping;uint8_t accel_calibration_count;"
                    "uint8_t gyro_calibration_count;"), "<Q3fIi3fIBBBB")


def _write_ulog_topics(path, topics):
    """A ULog as docs.px4.io's "ULog File Format" lays it out (see _write_ulog), holding
    several topics: ``topics`` is a list of (name, multi_id, rows), rows a list of
    (t_us, values) packed with the topic's format above; data messages in time order."""
    import struct

    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 1000))

    def msg(kind, payload):
        out.extend(struct.pack("<HB", len(payload), ord(kind)))
        out.extend(payload)

    formats = {"sensor_gyro": SENSOR_GYRO, "sensor_combined": SENSOR_COMBINED}
    msg("B", bytes(16) + struct.pack("<QQQ", 0, 0, 0))
    for name in dict.fromkeys(t[0] for t in topics):
        msg("F", f"{name}:{formats[name][0]}".encode())
    data = []
    for k, (name, multi, rows) in enumerate(topics):
        msg("A", struct.pack("<BH", multi, k) + name.encode())
        data += [(t, k, struct.pack("<H", k) + struct.pack(formats[name][1], *v))
                 for t, v in rows]
    for _, _, payload in sorted(data, key=lambda m: (m[0], m[1])):
        msg("D", payload)
    path.write_bytes(bytes(out))
    return path


def _px4_log(path, *, fs=250.0, seconds=120.0, gyro_every=None, combined_every=1,
             sigma=2e-3, seed=11):
    """A static PX4 record: white rate noise at ``fs``; sensor_combined keeps every
    ``combined_every``-th sample, sensor_gyro every ``gyro_every``-th, as the logger's
    interval does (logged_topics.cpp: sensor_gyro every 1000 ms in the default profile)."""
    n = int(fs * seconds)
    dt_us = round(1e6 / fs)
    t = 1_000_000 + np.arange(n, dtype=np.int64) * dt_us
    w = np.random.default_rng(seed).normal(0, sigma, (n, 3)).astype(np.float32)
    acc = (0.0, 0.0, -9.80665)
    topics = [("sensor_combined", 0, [(int(t[i]), (int(t[i]), *w[i], dt_us, 0, *acc, dt_us,
                                                     0, 0, 0, 0))
                                      for i in range(0, n, combined_every)])]
    if gyro_every:
        topics.append(("sensor_gyro", 0, [(int(t[i]) + 150, (int(t[i]) + 150, int(t[i]), 7,
                                                              *w[i], 31.5, 0))
                                          for i in range(0, n, gyro_every)]))
    return _write_ulog_topics(path, topics), w


def test_a_default_px4_log_is_read_from_sensor_combined_and_n_is_the_records(tmp_path,
                                                                            capsys):
    """PX4's default profile: sensor_combined at full rate (250 Hz here), sensor_gyro at 1 Hz.
    The fastest topic is read, the choice said on stderr, and N is the record's white noise by
    hand; sensor_gyro asked for by name is read and warned of as decimated."""
    ulg, _ = _px4_log(tmp_path / "flight.ulg", gyro_every=250)
    code, err = run(["allan", ulg, "--out", tmp_path / "a"])
    assert code == 0, err
    doc = json.loads((tmp_path / "a" / "allan.json").read_text())
    n_hand = 2e-3 / math.sqrt(250.0) * 180 / math.pi * 60         # deg/sqrt(h)
    for ax in "xyz":
        arw = {t["term"]: t for t in doc["columns"][f"gyro_{ax}_rps"]["noise"]["terms"]}["N"]
        assert arw["arw_deg_rt_h"] == pytest.approx(n_hand, rel=0.05)
    assert doc["fs_hz"] == pytest.approx(250.0, rel=1e-12)
    stderr = capsys.readouterr().err
    assert re.search(r"flight\.ulg: topic sensor_combined read: the fastest gyro topic "
                     r"\(sensor_combined 250 Hz, sensor_gyro 1 Hz\)", stderr), stderr
    assert "decimated" not in stderr
    assert run(["allan", ulg, "--topic", "sensor_gyro", "--out", tmp_path / "g"])[0] == 0
    stderr = capsys.readouterr().err
    assert re.search(r"fogbench: warning: .*flight\.ulg: topic sensor_gyro looks decimated "
                     r"\(1 Hz", stderr), stderr
    assert "topic sensor_gyro read" not in stderr          # --topic said which: no choice


def test_ulog_topic_choice_ties_and_decimation_by_integration_time(tmp_path, capsys):
    # equally fast: sensor_combined (the estimator's IMU) is read, and the note says why
    ulg, _ = _px4_log(tmp_path / "tie.ulg", seconds=2.0, gyro_every=1)
    assert "topic sensor_combined" in read_log(ulg).describe()
    assert re.search(r"tie\.ulg: topic sensor_combined read: as fast as sensor_gyro",
                     capsys.readouterr().err)
    # sensor_gyro faster than sensor_combined (logged every 4th sample): sensor_gyro is read
    ulg, w = _px4_log(tmp_path / "fast.ulg", seconds=2.0, gyro_every=1, combined_every=4)
    log = read_log(ulg)
    assert "topic sensor_gyro" in log.describe()
    np.testing.assert_array_equal(log.channels["gyro_x"], w[:, 0].astype(float))
    # sensor_combined logged every 2nd message at 250 Hz: 125 Hz, but each message covers
    # 4 ms of integration (gyro_integral_dt): decimated by the logger
    ulg, _ = _px4_log(tmp_path / "half.ulg", seconds=2.0, combined_every=2)
    with pytest.warns(UserWarning, match=r"half\.ulg: topic sensor_combined looks decimated "
                      r"\(a message every 8 ms, each covering 4 ms"):
        read_log(ulg)
    ulg, _ = _px4_log(tmp_path / "full.ulg", seconds=2.0)
    with warnings_recorded() as caught:
        read_log(ulg)
    assert not [c for c in caught if "decimated" in str(c.message)]


@contextlib.contextmanager
def warnings_recorded():
    """Every warning raised inside, as a list (none filtered out)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield caught


def test_a_euroc_header_with_an_unknown_field_is_the_header_and_names_the_field(tmp_path,
                                                                                capsys):
    """TUM-VI / EuRoC-like file with a column fogbench does not know: the '#timestamp' line
    is still the header, the known columns read back, the unknown one is named with its line."""
    from fogbench.formats.euroc import commented_header

    stamps, w, a = _record(n=500)
    p = tmp_path / "data.csv"
    lines = [EUROC_HEADER + ",mag_x [uT]"] + [
        ",".join([str(int(stamps[i]))] + [repr(float(x)) for x in (*w[i], *a[i], 0.25)])
        for i in range(len(stamps))]
    p.write_text("\n".join(lines) + "\n")
    log = read_log(p)
    assert log.fs == pytest.approx(FS, rel=1e-12)
    for k, ax in enumerate("xyz"):
        np.testing.assert_array_equal(log.channels[f"gyro_{ax}"], w[:, k])
        np.testing.assert_array_equal(log.channels[f"acc_{ax}"], a[:, k])
    err = capsys.readouterr().err
    assert re.search(r"fogbench: \S*data\.csv: line 1: header field 'mag_x \[uT\]' not known"
                     r".*left out", err), err
    assert commented_header(p.read_bytes(), 1) == 0                # the header's offset


def test_a_misspelt_euroc_field_is_named_then_the_missing_column_refused(tmp_path, capsys):
    stamps, w, a = _record(n=500)
    p = _write_euroc(tmp_path / "data.csv", stamps, w, a,
                     header=EUROC_HEADER.replace("w_RS_S_z [rad s^-1]", "w_RS_S_zz [rad s^-1]"))
    before = set(tmp_path.rglob("*"))
    code, err = run(["allan", p, "--columns", "gyro_z", "--out", tmp_path / "out"])
    assert code == 2 and "\n" not in err
    assert re.search(r"data\.csv: a EuRoC / TUM-VI header without 'w_RS_S_z \[rad s\^-1\]'",
                     err), err
    assert "data.csv: line 1: header field 'w_RS_S_zz [rad s^-1]' not known" in \
        capsys.readouterr().err
    assert set(tmp_path.rglob("*")) == before


def test_a_gzip_compressed_ulog_reads_as_the_ulog(tmp_path):
    import gzip

    n = 600
    t_us = 5_000_000 + np.arange(n, dtype=np.int64) * 2500
    w = np.random.default_rng(4).normal(0, 2e-3, (n, 3)).astype(np.float32)
    raw = _write_ulog(tmp_path / "flight.ulg", t_us, w).read_bytes()
    gz = tmp_path / "flight.ulg.gz"
    gz.write_bytes(gzip.compress(raw))
    log = read_log(gz)
    assert log.fs == pytest.approx(400.0, rel=1e-12)
    for k, ax in enumerate("xyz"):
        np.testing.assert_array_equal(log.channels[f"gyro_{ax}"], w[:, k].astype(float))


def _cut_ulog(tmp_path, n=400, keep_of_last=20):
    """A sensor_gyro ULog whose last data message (41 bytes: 3 header + 2 msg_id + 36 data)
    keeps only ``keep_of_last`` bytes, as a log cut by a power loss."""
    t_us = 5_000_000 + np.arange(n, dtype=np.int64) * 2500
    w = np.random.default_rng(6).normal(0, 2e-3, (n, 3)).astype(np.float32)
    full = _write_ulog(tmp_path / "full.ulg", t_us, w).read_bytes()
    cut = tmp_path / "cut.ulg"
    cut.write_bytes(full[:len(full) - 41 + keep_of_last])
    return cut, w


@pytest.mark.parametrize("keep", [1, 20, 40])    # inside the header, the payload, 1 byte short
def test_a_truncated_ulog_is_read_up_to_the_cut_and_warned_of(tmp_path, keep):
    cut, w = _cut_ulog(tmp_path, keep_of_last=keep)
    with pytest.warns(UserWarning, match=r"cut\.ulg: truncated: the file ends inside a "
                      r"message.*read up to there: 399 messages of sensor_gyro"):
        log = read_log(cut)
    np.testing.assert_array_equal(log.channels["gyro_z"], w[:399, 2].astype(float))
    with warnings_recorded() as caught:                 # the whole file: no warning
        read_log(tmp_path / "full.ulg")
    assert not [c for c in caught if "truncated" in str(c.message)]


def test_a_truncated_ulog_is_warned_of_on_the_command_line(tmp_path, capsys):
    cut, _ = _cut_ulog(tmp_path)
    assert run(["allan", cut, "--out", tmp_path / "a"])[0] == 0
    assert re.search(r"fogbench: warning: .*cut\.ulg: truncated.*399 messages of sensor_gyro",
                     capsys.readouterr().err)


def _gzipped(tmp_path, case):
    import gzip

    stamps, w, a = _record(n=300)
    if case == "gzip mcap":
        bag = _write_bag(tmp_path / "bag", stamps, w, a)
        inner = next(p for p in bag.iterdir() if p.suffix == ".mcap")
        out = tmp_path / "imu.mcap.gz"
        out.write_bytes(gzip.compress(inner.read_bytes()))
        import shutil

        shutil.rmtree(bag)
        return out, [], (r"imu\.mcap\.gz: a gzip-compressed MCAP file; rosbags reads bags and "
                         r"MCAP files only uncompressed: gunzip it first \(gunzip -k "
                         r"imu\.mcap\.gz, which writes imu\.mcap\)")
    if case == "gzip db3 named .db3":
        bag = _write_bag(tmp_path / "bag", stamps, w, a, storage="sqlite3")
        inner = next(p for p in bag.iterdir() if p.suffix == ".db3")
        out = tmp_path / "imu.db3"
        out.write_bytes(gzip.compress(inner.read_bytes()))
        import shutil

        shutil.rmtree(bag)
        return out, [], (r"imu\.db3: a gzip-compressed ROS 2 bag \(SQLite \.db3\); .*gunzip -c "
                         r"imu\.db3 > imu\.uncompressed\.db3")
    if case == "gzip of a broken ulog":
        out = tmp_path / "f.ulg.gz"
        out.write_bytes(gzip.compress(b"ULog\x01\x12\x35\x01" + bytes(3)))
        return out, [], r"f\.ulg\.gz: a gzip-compressed file, not a readable ULog"
    raise KeyError(case)


@pytest.mark.parametrize("case", ["gzip mcap", "gzip db3 named .db3", "gzip of a broken ulog"])
def test_gzip_compressed_bags_are_refused_saying_to_gunzip(tmp_path, case):
    from fogbench.cli import main

    path, flags, match = _gzipped(tmp_path, case)
    before = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")}
    code, err = run(["allan", path, "--out", tmp_path / "out", *flags])
    assert code == 2
    assert re.search(match, err), err
    assert "\n" not in err
    assert {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")} == before
    assert main(["allan", str(path), *flags]) == 2


# ---------------------------------------------------------------------------------------------
# units that contradict the data: said before any work, with what was assumed and the way out
def _imu_csv(path, header, times, cols=6, n=4000):
    rng = np.random.default_rng(5)
    data = rng.standard_normal((n, cols)) * 1e-3
    path.write_text(header + "\n" + "".join(
        f"{t}," + ",".join(f"{v:.6e}" for v in row) + "\n" for t, row in zip(times, data)))
    return path


def test_nanoseconds_under_a_microsecond_header_are_warned_of_with_the_unit_that_fits(tmp_path):
    t = np.arange(4000, dtype=np.int64) * 5_000_000            # 200 Hz, in ns
    p = _imu_csv(tmp_path / "data.csv", "#timestamp [us],w_RS_S_x [rad s^-1],w_RS_S_y "
                 "[rad s^-1],w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z "
                 "[m s^-2]", t)
    code, _, err = run_cli("allan", p)
    assert code == 0
    assert ("gives a sample rate of 0.2 Hz, unusual for an IMU or gyro log (its times read as "
            "us); if its times are in ns, not us, the rate is 200 Hz") in err


def test_milliseconds_under_time_s_are_warned_of(tmp_path):
    p = _imu_csv(tmp_path / "log.csv", "time_s,gyro_x_dps", np.arange(4000) * 10.0, cols=1)
    code, _, err = run_cli("allan", p)
    assert code == 0
    assert "if its times are in ms, not s, the rate is 100 Hz: name the column time_ms" in err


def test_a_euroc_header_without_one_of_its_seven_columns_is_refused(tmp_path):
    t = np.arange(4000, dtype=np.int64) * 5_000_000
    p = _imu_csv(tmp_path / "data.csv", "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y "
                 "[rad s^-1],a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]", t, cols=5)
    code, _, err = run_cli("allan", p, "--out", tmp_path / "a")
    assert code == 2
    assert "a EuRoC / TUM-VI header without 'w_RS_S_z [rad s^-1]'" in err
    assert not (tmp_path / "a").exists()


def test_a_gyro_axis_under_a_name_not_recognised_is_named(tmp_path):
    """A header with gyro_y_dps, gyro_z_dps and 'GyroX': the two axes are read and the column
    not read is named with how to map it (it was analysed on two axes without a word); mapped
    with --column, all three are read and the note is gone."""
    rng = np.random.default_rng(0)
    p = tmp_path / "log.csv"
    p.write_text("time_s,GyroX,gyro_y_dps,gyro_z_dps\n" + "".join(
        f"{i * 0.01:.2f},{a:.5f},{b:.5f},{c:.5f}\n"
        for i, (a, b, c) in enumerate(rng.standard_normal((3000, 3)))))
    code, out, err = run_cli("allan", p)
    assert code == 0, err
    assert "columns not read: GyroX" in err and "--column gyro_x=HEADER:UNIT" in err, err
    assert "gyro_y_dps" in out and "GyroX" not in out
    assert out.count("fit J =") == 2
    code, out, err = run_cli("allan", p, "--column", "gyro_x=GyroX:dps")
    assert code == 0 and "columns not read" not in err, err
    assert out.count("fit J =") == 3
