"""Real PX4 ULogs (shared/realdata/px4_ulog, recorded on hardware; pyulog's test data): their
dropouts and jitter taken as gaps (``--gaps split``), a piece too short for the shortest
averaging time left out and counted in a note, each firmware's ``gyro_integral_dt`` read in its
own unit, and the Allan deviation of every piece the one allantools computes from the samples
pyulog returns for it. Also the one-sample piece of any reader (a CSV) as a note, not a crash."""

from __future__ import annotations

import json
import math
import re
import struct
import warnings

import numpy as np
import pytest

from helpers import need_realdata, realdata_dir, run_cli

ULOGS = realdata_dir() / "px4_ulog"
DPH = math.pi / 180.0 / 3600.0

#: The options each log is analysed with, and the note on what was left out. sample.ulg and
#: sample_appended_multiple.ulg hold hundreds of 4.8 ms intervals among 4 ms ones (20 % off:
#: jitter, no sample missing) beside real dropouts (8 to 65 ms): --time-tolerance 0.25 keeps
#: the jitter inside the pieces, the dropouts cut.
CASES = {
    "sample.ulg": (["--time-tolerance", "0.25"], 0.25,
                   r"3 pieces of 9 left out, 3 samples in all: the pieces between its 8 cuts "
                   r"\(intervals more than 25% off the median\) shorter than 3 samples.*; "
                   r"6 pieces of 17067 samples analysed together"),
    "sample_appended_multiple.ulg": (["--time-tolerance", "0.25"], 0.25,
                                     r"1 piece of 3 left out, 1 sample in all: .*2 cuts .*; "
                                     r"2 pieces of 2372 samples analysed together"),
    "sample_log_small.ulg": ([], 0.05,
                             r"1 piece of 2 left out, 1 sample in all: .*1 cut \(intervals "
                             r"more than 5% off the median\).*; 1 piece of 1297 samples "
                             r"analysed together"),
}


def _pyulog_gyro(path):
    """(time in us, gyro rad/s (n, 3)) of sensor_combined as pyulog returns them."""
    from pyulog import ULog

    d = next(d for d in ULog(str(path), message_name_filter_list=["sensor_combined"]).data_list
             if d.name == "sensor_combined")
    t = np.asarray(d.data["timestamp"], dtype=np.int64)
    w = np.column_stack([np.asarray(d.data[f"gyro_rad[{k}]"], dtype=float) for k in range(3)])
    return t, w


def _pieces(t_us, tolerance):
    """The pieces of at least 3 samples between the intervals more than ``tolerance`` off the
    median: worked out here from the time stamps, not by fogbench."""
    dt = np.diff(t_us).astype(float)
    cuts = np.flatnonzero(np.abs(dt / np.median(dt) - 1.0) > tolerance) + 1
    bounds = [0, *cuts.tolist(), t_us.size]
    return [(a, b) for a, b in zip(bounds[:-1], bounds[1:]) if b - a >= 3]


def _files(*folders):
    return {p for f in folders for p in f.rglob("*")}


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_real_ulog_is_analysed_piece_by_piece_as_allantools_does(tmp_path, name):
    import allantools

    from fogcomp.allan import oadev_details

    log = ULOGS / name
    need_realdata(log)
    flags, tol, note = CASES[name]
    before = _files(tmp_path, ULOGS)
    code, out, err = run_cli("allan", log, "--gaps", "split", *flags, "--out", tmp_path / "o",
                             cwd=tmp_path)
    assert code == 0, err
    assert not re.search(r"error|Traceback|decimated", err), err
    lines = err.splitlines()
    assert len([x for x in lines if re.search(note, x)]) == 1, err
    assert {p.relative_to(tmp_path) for p in _files(tmp_path, ULOGS) - before} == {
        p.relative_to(tmp_path) for p in [tmp_path / "o", tmp_path / "o" / "allan.json",
                                          *(tmp_path / "o" / f"allan_gyro_{a}_rps.png"
                                            for a in "xyz")]}
    doc = json.loads((tmp_path / "o" / "allan.json").read_text())
    t_us, w = _pyulog_gyro(log)
    pieces = _pieces(t_us, tol)
    assert [tuple(s) for s in doc["segments"]] == pieces
    fs = doc["fs_hz"]
    worst = 0.0
    for k, ax in enumerate("xyz"):
        col = doc["columns"][f"gyro_{ax}_rps"]
        m_all = np.rint(np.asarray(col["tau_s"]) * fs).astype(int)
        sums, counts = np.zeros(m_all.size), np.zeros(m_all.size)
        for a, b in pieces:
            y = w[a:b, k]
            ok = m_all <= (b - a - 1) // 2
            taus, adev, _, n_terms = allantools.oadev(y, rate=fs, data_type="freq",
                                                      taus=m_all[ok] / fs)
            assert np.array_equal(np.rint(taus * fs).astype(int), m_all[ok])
            mine = oadev_details(y, fs, taus=m_all[ok] / fs)   # this piece's own curve
            np.testing.assert_allclose(mine.adev, adev, rtol=1e-9, atol=0)
            np.testing.assert_array_equal(mine.n_terms, n_terms)
            worst = max(worst, float(np.max(np.abs(mine.adev / adev - 1.0))))
            sums[ok] += adev**2 * n_terms
            counts[ok] += n_terms
        pooled = np.sqrt(sums / counts)
        written = np.asarray(col["adev_dph"]) * DPH
        np.testing.assert_allclose(written, pooled, rtol=1e-9, atol=0)
        worst = max(worst, float(np.max(np.abs(written / pooled - 1.0))))
    print(f"{name}: largest relative difference to allantools {worst:.3g}")


def test_the_refusals_of_real_ulogs_say_what_to_do(tmp_path):
    log = ULOGS / "sample.ulg"
    need_realdata(log)
    before = _files(tmp_path, ULOGS)
    # refused by default: what is there and what to do, in one line
    code, out, err = run_cli("allan", log, "--out", tmp_path / "o", cwd=tmp_path)
    assert code == 2 and out == ""
    errors = [x for x in err.splitlines() if x.startswith("fogbench: error:")]
    assert len(errors) == 1, err
    assert re.fullmatch(
        r"fogbench: error: \S*sample\.ulg: message 2 of sensor_combined, column "
        r"'sensor_combined\.timestamp \[us\]': gap of 0\.036 s \(8 missing samples at 0\.004 s\) "
        r"after time 0; 8 gap\(s\) of more than 1\.5 intervals, 495 jitter\(s\) more than 5% off "
        r"in all; use --gaps split to cut the log at each of them and analyse the pieces "
        r"together; --time-tolerance 0\.22 takes the jitter as regular \(the gaps still need "
        r"--gaps split\)", errors[0]), errors[0]
    # split at 5 %: 500 pieces of at most 42 samples, too short for the command; the note and
    # the advice (0.22 is enough: see the analysed case above, at 0.25)
    code, out, err = run_cli("allan", log, "--gaps", "split", "--out", tmp_path / "o",
                             cwd=tmp_path)
    assert code == 2 and out == ""
    errors = [x for x in err.splitlines() if x.startswith("fogbench: error:")]
    assert len(errors) == 1, err
    assert re.search(r"sample\.ulg: record too short: 42 samples in its longest gap-free piece, "
                     r"this command needs at least 64 .*; 495 of them are jitter, not dropouts "
                     r".*--time-tolerance 0\.22 keeps them inside the pieces$", errors[0])
    assert re.search(r"sample\.ulg: 4 pieces of 504 left out, 4 samples in all", err), err
    code, _, err = run_cli("allan", log, "--gaps", "split", "--time-tolerance", "0.22",
                           cwd=tmp_path)
    assert code == 0, err
    assert _files(tmp_path, ULOGS) == before


# ---------------------------------------------------------------------------------------------
# gyro_integral_dt: float32 seconds (older firmware) and uint32 microseconds, read as written
def test_integral_dt_is_read_in_the_unit_each_firmware_wrote():
    from fogbench.formats.ulog import integral_dt_us

    np.testing.assert_allclose(integral_dt_us(np.array([0.004, 0.0048], np.float32)),
                               [4000.0, 4800.0], rtol=1e-6)
    np.testing.assert_array_equal(integral_dt_us(np.array([4888, 4889], np.uint32)),
                                  [4888.0, 4889.0])


@pytest.mark.parametrize("name,dtype", [("sample.ulg", "float32"),
                                        ("sample_appended_multiple.ulg", "float32"),
                                        ("sample_log_small.ulg", "uint32")])
def test_real_ulogs_integral_dt_is_not_read_as_decimation(name, dtype):
    from pyulog import ULog

    from fogbench.formats.ulog import read_ulog

    log = ULOGS / name
    need_realdata(log)
    d = next(d for d in ULog(str(log), message_name_filter_list=["sensor_combined"]).data_list)
    assert d.data["gyro_integral_dt"].dtype == np.dtype(dtype)        # as pyulog gives it
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        read_ulog(log, None)
    assert not [c for c in caught if "decimated" in str(c.message)], \
        [str(c.message) for c in caught]


def _ulog(path, topics):
    """A ULog as docs.px4.io's "ULog File Format" lays it out; ``topics``: (name, format
    text, struct format, rows of (t_us, values))."""
    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 1000))

    def msg(kind, payload):
        out.extend(struct.pack("<HB", len(payload), ord(kind)))
        out.extend(payload)

    msg("B", bytes(16) + struct.pack("<QQQ", 0, 0, 0))
    for name, text, _, _ in topics:
        msg("F", f"{name}:{text}".encode())
    data = []
    for k, (name, _, fmt, rows) in enumerate(topics):
        msg("A", struct.pack("<BH", 0, k) + name.encode())
        data += [(t, k, struct.pack("<H", k) + struct.pack(fmt, *v)) for t, v in rows]
    for _, _, payload in sorted(data, key=lambda m: (m[0], m[1])):
        msg("D", payload)
    path.write_bytes(bytes(out))
    return path


#: sensor_combined as older PX4 firmware declared it (gyro_integral_dt a float in seconds) and
#: as newer firmware does (uint32 microseconds).
OLD = ("uint64_t timestamp;float[3] gyro_rad;float gyro_integral_dt;", "<Q3ff")
NEW = ("uint64_t timestamp;float[3] gyro_rad;uint32_t gyro_integral_dt;", "<Q3fI")
GYRO = ("uint64_t timestamp;uint64_t timestamp_sample;float x;float y;float z;", "<QQfff")


@pytest.mark.parametrize("firmware", ["old", "new"])
def test_a_decimated_sensor_combined_is_warned_of_in_either_unit_and_the_advice_is_true(
        tmp_path, firmware):
    from fogbench.formats.table import read_log

    text, fmt = OLD if firmware == "old" else NEW
    dt = 0.004 if firmware == "old" else 4000
    w = np.random.default_rng(3).normal(0, 1e-3, (500, 3)).astype(np.float32)
    rows = [(1_000_000 + 8000 * i, (1_000_000 + 8000 * i, *w[i], dt)) for i in range(500)]
    ulg = _ulog(tmp_path / "half.ulg", [("sensor_combined", text, fmt, rows)])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        read_log(ulg)
    msgs = [str(c.message) for c in caught if "decimated" in str(c.message)]
    assert len(msgs) == 1, msgs
    assert re.search(r"half\.ulg: topic sensor_combined looks decimated \(a message every 8 ms, "
                     r"each covering 4 ms \(gyro_integral_dt\)\)", msgs[0]), msgs[0]
    assert "read sensor_combined" not in msgs[0] and "--topic" not in msgs[0]
    assert "log the topic at full rate" in msgs[0]


def test_a_decimated_sensor_gyro_is_advised_the_faster_topic_of_the_log(tmp_path):
    from fogbench.formats.table import read_log

    w = np.random.default_rng(4).normal(0, 1e-3, (1000, 3)).astype(np.float32)
    comb = [(1_000_000 + 4000 * i, (1_000_000 + 4000 * i, *w[i], 4000)) for i in range(1000)]
    gyro = [(1_000_000 + 4000 * i + 100, (1_000_000 + 4000 * i + 100, 1_000_000 + 4000 * i,
                                          *w[i])) for i in range(0, 1000, 50)]
    ulg = _ulog(tmp_path / "f.ulg", [("sensor_combined", *NEW, comb),
                                     ("sensor_gyro", *GYRO, gyro)])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        read_log(ulg, topic="sensor_gyro")
    msgs = [str(c.message) for c in caught if "decimated" in str(c.message)]
    assert len(msgs) == 1 and re.search(
        r"topic sensor_gyro looks decimated .*; read sensor_combined \(250 Hz in this log\) "
        r"with --topic sensor_combined", msgs[0]), msgs


# ---------------------------------------------------------------------------------------------
# A piece of one sample, in any reader: a note, not a crash
def test_a_one_sample_piece_between_two_gaps_is_a_note(tmp_path):
    import pandas as pd

    fs, n = 100.0, 3000
    t = np.arange(n) / fs
    t[1500:] += 0.5                    # a gap after sample 1499 ...
    t[1501:] += 0.5                    # ... and one after sample 1500: a piece of one sample
    y = np.random.default_rng(5).normal(0, 0.01, n)
    log = tmp_path / "one.csv"
    pd.DataFrame({"time_s": t, "gyro_x_dps": y}).to_csv(log, index=False)
    before = _files(tmp_path)
    code, out, err = run_cli("allan", log, "--gaps", "split", "--out", tmp_path / "o",
                             cwd=tmp_path)
    assert code == 0, err
    assert "error" not in err
    lines = err.splitlines()
    assert lines == [f"fogbench: {log}: 1 piece of 3 left out, 1 sample in all: the pieces "
                     "between its 2 cuts (intervals more than 5% off the median) shorter than 3 "
                     "samples, the fewest the shortest averaging time (one interval) needs; "
                     "2 pieces of 2999 samples analysed together"], err
    assert f"{log}: 3000 samples at 100 Hz" in out and "(2999 of them analysed)" in out
    doc = json.loads((tmp_path / "o" / "allan.json").read_text())
    assert doc["segments"] == [[0, 1500], [1501, 3000]]
    assert _files(tmp_path) - before == {tmp_path / "o", tmp_path / "o" / "allan.json",
                                         tmp_path / "o" / "allan_gyro_x_dps.png"}
    # refused by default, in one line that says what to do
    code, out, err = run_cli("allan", log, "--out", tmp_path / "p", cwd=tmp_path)
    assert code == 2 and out == ""
    assert err.splitlines() == [
        f"fogbench: error: {log}: line 1502, column 'time_s': gap of 0.51 s (50 missing "
        "samples at 0.01 s) after time 14.99; 2 gap(s) of more than 1.5 intervals in all; use "
        "--gaps split to cut the log at each of them and analyse the pieces together"], err
    assert not (tmp_path / "p").exists()
