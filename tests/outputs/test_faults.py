"""Faults that once got through, one test (or more) per case, each asserting the exit
status, the one-line message and what is left on disk.

1. an engine address that answers but is not a Dask scheduler; an unreachable one with one
   replicate;
2. a failed write (a file-size limit, a full disk) reported as success, or leaving half-written
   model sets, empty folders, work folders that block the next run;
3. model files edited, swapped or mixed up, and triad calibrations of swapped columns;
4. two runs into one --out at once; the pool's processes outliving a kill -9;
5. --resume trusting edited, relabelled or surplus replicate files;
6. signals swallowed or during imports, --out ., implausible values and units, short rows,
   symbolic link loops, the list of allowed top-level tables.
"""

from __future__ import annotations

import hashlib
import http.server
import json
import math
import os
import resource
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from helpers import SMALL_SCENARIO, run_cli

ROOT = Path(__file__).resolve().parents[2]
CLI = [sys.executable, "-m", "fogbench"]


def snapshot(root: Path) -> dict[str, str]:
    """Every file and folder under ``root`` (hidden ones included), files with their SHA-256."""
    out = {}
    for p in sorted(root.rglob("*")):
        out[str(p.relative_to(root))] = (hashlib.sha256(p.read_bytes()).hexdigest()
                                         if p.is_file() and not p.is_symlink() else "dir")
    return out


def one_error_line(err: str) -> str:
    """The one ``fogbench: error: ...`` line of a failed command's stderr (its other lines are
    notes such as the record's length, or warnings), and no traceback."""
    lines = [ln for ln in err.strip().splitlines() if ln.startswith("fogbench: error")]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.fixture
def tiny(tmp_path):
    p = tmp_path / "tiny.toml"
    p.write_text(SMALL_SCENARIO)
    return p


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# --- 1. engines ----------------------------------------------------------------------------------
@pytest.fixture
def http_server():
    """An HTTP server on loopback, started by the test: it accepts, then waits for a request."""
    srv = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.SimpleHTTPRequestHandler)
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    yield f"tcp://127.0.0.1:{srv.server_address[1]}"
    srv.shutdown()
    srv.server_close()


@pytest.fixture
def chatty_server():
    """A TCP server on loopback that answers every connection with an HTTP error at once."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen()
    stop = threading.Event()

    def serve():
        srv.settimeout(0.2)
        while not stop.is_set():
            try:
                conn, _ = srv.accept()
            except OSError:
                continue
            with conn:
                conn.sendall(b"HTTP/1.0 400 Bad Request\r\n\r\n" + b"\xff" * 64)
                time.sleep(0.1)

    t = threading.Thread(target=serve, daemon=True)
    t.start()
    yield f"tcp://127.0.0.1:{srv.getsockname()[1]}"
    stop.set()
    t.join()
    srv.close()


@pytest.mark.parametrize("server, words, within_s", [
    ("http_server", ["no Dask scheduler answered within 5 s", "no Dask handshake"], 9.0),
    # refused on what it sent, before the 5 s handshake timeout (4.5 s: make test shares the
    # two cores between two pytest-xdist workers)
    ("chatty_server", ["not a Dask handshake", "not a Dask scheduler"], 4.5),
])
def test_an_address_that_answers_but_is_not_dask_is_refused_within_seconds(
        request, tiny, tmp_path, server, words, within_s):
    pytest.importorskip("distributed")
    address = request.getfixturevalue(server)
    before = snapshot(tmp_path)
    t0 = time.monotonic()
    code, _, err = run_cli("run", tiny, "--out", tmp_path / "run", "--replicates", 2, "--quiet",
                           "--no-recording", "--scheduler", address)
    assert time.monotonic() - t0 < within_s
    assert code == 2
    line = one_error_line(err)
    assert address in line and all(w in line for w in words), line
    assert snapshot(tmp_path) == before


def test_a_dask_worker_address_is_refused_as_not_a_scheduler(tiny, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  protocol="tcp", dashboard_address=None) as cluster:
        worker = next(iter(cluster.scheduler_info["workers"]))
        code, _, err = run_cli("run", tiny, "--out", tmp_path / "run", "--replicates", 2,
                               "--quiet", "--no-recording", "--scheduler", worker)
        assert code == 2
        line = one_error_line(err)
        assert worker in line and "not a scheduler" in line
        # the scheduler itself is accepted and runs the replicates
        code, _, err = run_cli("run", tiny, "--out", tmp_path / "ok", "--replicates", 2,
                               "--quiet", "--no-recording", "--scheduler",
                               cluster.scheduler_address)
        assert code == 0, err
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("command", ["run", "suite"])
def test_the_scheduler_is_checked_whatever_the_replicate_count(tiny, tmp_path, command):
    pytest.importorskip("distributed")
    port = _free_port()  # nothing listens there
    args = (["run", tiny, "--out", tmp_path / "run"] if command == "run" else
            ["suite", "--scenarios", tmp_path, "--out", tmp_path / "rep"])
    code, _, err = run_cli(*args, "--replicates", 1, "--quiet", "--no-recording",
                           "--scheduler", f"tcp://127.0.0.1:{port}")
    assert code == 2
    line = one_error_line(err)
    assert f"tcp://127.0.0.1:{port}" in line and "no Dask scheduler answered" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tiny.toml"]


# --- 2. writes that fail --------------------------------------------------------------------------
def _limited(limit_bytes: int):
    def pre():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))
    return pre


def _cli_process(args, cwd, limit_bytes=None, timeout=300):
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    proc = subprocess.run([*CLI, *map(str, args)], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, env=env,
                          preexec_fn=_limited(limit_bytes) if limit_bytes else None)
    return proc.returncode, proc.stdout, proc.stderr


def _static_log(path: Path, n=3000, fs=100.0, seed=0) -> Path:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    g = 0.01 * rng.standard_normal((n, 3))
    lines = ["time_s,gyro_x_dps,gyro_y_dps,gyro_z_dps"]
    lines += [f"{a:.2f},{float(b[0])!r},{float(b[1])!r},{float(b[2])!r}" for a, b in zip(t, g)]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_file_size_limit_fails_the_run_naming_the_file_and_keeps_only_resumable_work(
        tiny, tmp_path):
    """`ulimit -f`: a figure cannot be written. The run says so naming the file (where the user
    looks for it, not its temporary name), exits 1, puts no run directory in place, and its last
    line says where its finished replicate is kept; --resume then finishes the run."""
    code, out, err = _cli_process(["run", tiny, "--out", "out/run", "--no-recording", "--quiet"],
                                  tmp_path, limit_bytes=40_000)
    assert code == 1, err
    lines = err.strip().splitlines()
    assert lines[0].startswith("fogbench: error: File too large (") and \
        str(tmp_path / "out" / "run" / "figures") in lines[0], err
    assert "--resume" in lines[-1] and ".run.replicates" in lines[-1], err
    assert "wrote" not in out and "Traceback" not in err
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [".run.replicates"]
    assert sorted(p.name for p in (tmp_path / "out" / ".run.replicates").glob("r*.json")) == \
        ["r00000.json"]
    code, out, err = _cli_process(["run", tiny, "--out", "out/run", "--no-recording", "--quiet",
                                   "--resume"], tmp_path)
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["run"]


@pytest.mark.parametrize("command", ["allan", "calibrate", "compensate", "simulate"])
def test_a_file_size_limit_fails_every_command_and_leaves_nothing(tiny, tmp_path, command):
    log = _static_log(tmp_path / "log.csv")
    if command == "compensate":
        code, _, err = run_cli("calibrate", "wavelet_soft", log, "--out", tmp_path / "m" / "w")
        assert code == 0, err
    before = snapshot(tmp_path)
    args = {"allan": ["allan", log, "--out", "new/allan"],
            "calibrate": ["calibrate", "kalman", log, "--out", "new/models/kal"],
            "compensate": ["compensate", tmp_path / "m" / "w", log, "--out", "new/clean.csv"],
            "simulate": ["simulate", tiny, "--out", "new/sim", "--quiet"]}[command]
    # a limit below the size of the command's first output file
    limit = {"allan": 20_000, "calibrate": 1_000, "compensate": 20_000, "simulate": 5_000}
    code, out, err = _cli_process(args, tmp_path, limit_bytes=limit[command])
    assert code == 1, (out, err)
    line = one_error_line(err)
    assert "File too large (" in line and str(tmp_path / "new") in line or "new/" in line, line
    assert "wrote" not in out
    assert snapshot(tmp_path) == before  # no half-written model set, no empty folder


@pytest.fixture
def full_disk(tmp_path):
    """A 256 KiB file system of its own (tmpfs), so a command runs out of space: mounted by the
    test where the machine allows it (root with CAP_SYS_ADMIN), skipped with the reason if not."""
    mnt = tmp_path / "disk"
    mnt.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(mnt)],
                       capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here ({r.stderr.strip() or r.returncode}); the "
                    "file-size limit tests cover the same paths")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


def _fill(mnt: Path, free_bytes: int) -> None:
    """Leave about ``free_bytes`` free on the file system at ``mnt`` (a filler file)."""
    st = os.statvfs(mnt)
    (mnt / ".filler").write_bytes(b"\0" * max(st.f_bavail * st.f_frsize - free_bytes, 0))


@pytest.mark.parametrize("command, free", [("run", 64_000), ("allan", 32_000),
                                           ("calibrate", 8_000), ("simulate", 16_000)])
def test_a_full_disk_names_the_path_and_leaves_nothing_half_written(tiny, tmp_path, full_disk,
                                                                   command, free):
    _fill(full_disk, free)
    log = _static_log(tmp_path / "log.csv", n=20_000)
    args = {"run": ["run", tiny, "--out", full_disk / "run", "--no-recording", "--quiet",
                    "--method", "wavelet_soft"],
            "allan": ["allan", log, "--out", full_disk / "al"],
            "calibrate": ["calibrate", "kalman", log, "--out", full_disk / "m" / "kal"],
            "simulate": ["simulate", tiny.with_name("long.toml"), "--out", full_disk / "sim",
                         "--quiet"]}[command]
    tiny.with_name("long.toml").write_text(SMALL_SCENARIO.replace("30.0", "3000.0"))
    code, out, err = _cli_process(args, tmp_path)
    assert code == 1, (out, err)
    lines = [ln for ln in err.strip().splitlines() if ln.startswith("fogbench: error")]
    assert len(lines) == 1 and "No space left on device (" in lines[0] and \
        str(full_disk) in lines[0], err
    assert "Traceback" not in err
    left = sorted(p.name for p in full_disk.iterdir() if p.name != ".filler")
    if command == "run":  # the replicate already computed is kept, and the last line says so
        assert left == [".run.replicates"] and "--resume" in err.strip().splitlines()[-1]
    else:
        assert left == [], left


# --- 3. model files ---------------------------------------------------------------------------
def _calibrated(tmp_path, method="kalman"):
    log = _static_log(tmp_path / "log.csv")
    code, _, err = run_cli("calibrate", method, log, "--out", tmp_path / "m" / "kal")
    assert code == 0, err
    return log, tmp_path / "m"


def assert_compensate_refused(tmp_path, model, log, *words):
    before = snapshot(tmp_path)
    code, _, err = run_cli("compensate", model, log, "--out", tmp_path / "clean.csv")
    assert code == 2, err
    line = one_error_line(err)
    for w in words:
        assert w in line, line
    assert snapshot(tmp_path) == before
    return line


def _reseal(path: Path, change) -> None:
    """Edit a model file and give it a valid checksum again (what a careful editor could do)."""
    from fogcomp._persistence import _canonical_sha256

    doc = json.loads(path.read_text())
    change(doc)
    doc["sha256"] = _canonical_sha256(doc)
    path.write_text(json.dumps(doc))


def test_swapped_per_axis_model_files_are_refused(tmp_path):
    log, m = _calibrated(tmp_path)
    for suffix in (".json", ".npz"):
        x, z = m / f"kal.gyro_x{suffix}", m / f"kal.gyro_z{suffix}"
        tmp = m / "swap"
        x.rename(tmp)
        z.rename(x)
        tmp.rename(z)
    assert_compensate_refused(tmp_path, m / "kal", log, "kal.gyro_x.json", "does not match the "
                        "checksum", "swapped")


def test_a_model_of_another_method_under_the_manifest_is_refused(tmp_path):
    log, m = _calibrated(tmp_path)
    code, _, err = run_cli("calibrate", "wavelet_soft", log, "--out", tmp_path / "w" / "ws")
    assert code == 0, err
    for suffix in (".json", ".npz"):
        shutil.copyfile(tmp_path / "w" / f"ws.gyro_y{suffix}", m / f"kal.gyro_y{suffix}")
    assert_compensate_refused(tmp_path, m / "kal", log, "kal.gyro_y.json", "does not match")
    # even with the manifest's pins updated, the model's own method is compared
    from fogbench.logs.modelfile import _file_sha256

    def repin(doc):
        doc["axes"]["gyro_y"]["json_sha256"] = _file_sha256(m / "kal.gyro_y.json")
        doc["axes"]["gyro_y"]["npz_sha256"] = _file_sha256(m / "kal.gyro_y.npz")

    _reseal(m / "kal.json", repin)
    assert_compensate_refused(tmp_path, m / "kal", log, "kal.gyro_y.json", "'wavelet_soft' model",
                        "'kalman'")


def test_an_edited_sample_rate_is_refused_by_the_checksum_and_by_the_models_own(tmp_path):
    log, m = _calibrated(tmp_path)
    doc = json.loads((m / "kal.json").read_text())
    doc["fs_hz"] = 50.0
    (m / "kal.json").write_text(json.dumps(doc))
    assert_compensate_refused(tmp_path, m / "kal", log, "kal.json", "does not match its checksum")
    _reseal(m / "kal.json", lambda d: d.update(fs_hz=50.0))
    assert_compensate_refused(tmp_path, m / "kal", log, "'fs_hz' is 50 Hz", "fitted at 100 Hz")


@pytest.mark.parametrize("change, words", [
    (lambda d: d.pop("fs_hz"), ["missing key 'fs_hz'"]),
    (lambda d: d.update(fs_hz="100"), ["key 'fs_hz' must be a positive sample rate"]),
    (lambda d: d.update(axes=[]), ["key 'axes' must be a table"]),
    (lambda d: d["axes"]["gyro_x"].pop("model"), ["missing key 'axes.gyro_x.model'"]),
    (lambda d: d["axes"]["gyro_x"].update(model="../../etc/passwd"),
     ["'axes.gyro_x.model' must name the gyro_x file"]),
    # the axes' entries swapped, the checksum made valid again: each entry must name its axis
    (lambda d: d["axes"].update(gyro_x=d["axes"]["gyro_z"], gyro_z=d["axes"]["gyro_x"]),
     ["'axes.gyro_x.model' must name the gyro_x file", "'kal.gyro_z'"]),
    (lambda d: d["axes"]["gyro_x"].update(unit=3), ["'axes.gyro_x.unit' must be a text"]),
    (lambda d: d.pop("sha256"), ["missing key 'sha256'"]),
    (lambda d: d.update(version=1), ["key 'version' is 1"]),
])
def test_missing_or_wrongly_typed_manifest_keys_are_a_model_file_error(tmp_path, change, words):
    log, m = _calibrated(tmp_path)
    if "sha256" in words[0]:
        doc = json.loads((m / "kal.json").read_text())
        change(doc)
        (m / "kal.json").write_text(json.dumps(doc))
    else:
        _reseal(m / "kal.json", change)
    assert_compensate_refused(tmp_path, m / "kal", log, "kal.json", *words)


def _ferraris_csv(path: Path, swap: bool = False, seed: int = 3) -> Path:
    """A noisy six-position + three-rotation session in raw counts (the model of
    fogcomp.calibration), written as the imucal files are; ``swap``: gyro and accelerometer
    columns exchanged, as a user may mislabel them."""
    import pandas as pd

    rng = np.random.default_rng(seed)
    g, fs, n = 9.81, 100.0, 300
    ka, kg = np.diag([200.0, 205.0, 210.0]), np.diag([900.0, 950.0, 1000.0])
    ba, bg = np.array([5.0, -3.0, 7.0]), np.array([1.5, -2.0, 0.5])
    rows = []

    def rot(ax, ang):
        c, s = math.cos(ang), math.sin(ang)
        i, j = [(1, 2), (2, 0), (0, 1)][ax]
        r = np.eye(3)
        r[i, i] = r[j, j] = c
        r[i, j], r[j, i] = -s, s
        return r

    for j, ax in enumerate("xyz"):
        for sign, tag in ((1, "p"), (-1, "a")):
            f = np.zeros(3)
            f[j] = sign * g
            acc = ka @ f + ba + rng.normal(0, 0.3, (n, 3))
            gyr = bg + rng.normal(0, 0.5, (n, 3))
            rows += [(f"{ax}_{tag}", a, w) for a, w in zip(acc, gyr)]
    for j, ax in enumerate("xyz"):
        k = int(4 * fs)
        w = np.zeros((k, 3))
        w[:, j] = -2 * math.pi / 4.0
        f0 = np.zeros(3)
        f0[(j + 1) % 3] = g
        fb = np.array([rot(j, 2 * math.pi * i / k) @ f0 for i in range(k)])
        acc = fb @ ka.T + ba + rng.normal(0, 0.3, (k, 3))
        gyr = w @ kg.T + bg + rng.normal(0, 0.5, (k, 3))
        rows += [(f"{ax}_rot", a, v) for a, v in zip(acc, gyr)]
    df = pd.DataFrame({"part": [r[0] for r in rows]})
    a = np.array([r[1] for r in rows])
    w = np.array([r[2] for r in rows])
    if swap:
        a, w = w, a
    for i, x in enumerate("xyz"):
        df[f"acc_{x}"] = a[:, i]
    for i, x in enumerate("xyz"):
        df[f"gyr_{x}"] = w[:, i]
    df.to_csv(path, index=False)
    return path


FERRARIS_ARGS = ["--fs", "100", "--angle-deg", "-360", "--g", "9.81", "--column",
                 "acc_x=acc_x:au,acc_y=acc_y:au,acc_z=acc_z:au,gyro_x=gyr_x:au,gyro_y=gyr_y:au,"
                 "gyro_z=gyr_z:au"]


def test_a_triad_calibration_of_swapped_columns_is_refused_naming_them(tmp_path):
    good = _ferraris_csv(tmp_path / "good.csv")
    code, out, err = run_cli("calibrate", "ferraris", good, *FERRARIS_ARGS, "--out",
                             tmp_path / "ok")
    assert code == 0, err
    cal = json.loads((tmp_path / "ok.json").read_text())["calibration"]
    np.testing.assert_allclose(cal["gyro_scale_raw_per_rps"], [900, 950, 1000], rtol=0.01)
    bad = _ferraris_csv(tmp_path / "swapped.csv", swap=True)
    before = snapshot(tmp_path)
    code, out, err = run_cli("calibrate", "ferraris", bad, *FERRARIS_ARGS, "--out",
                             tmp_path / "bad")
    assert code == 2, out
    line = [ln for ln in err.splitlines() if "error" in ln][-1]
    assert "swapped" in line and "'acc_x'" in line and "gyr_x" in line, line
    assert snapshot(tmp_path) == before


def test_a_triad_calibration_edited_by_a_factor_is_refused(tmp_path):
    good = _ferraris_csv(tmp_path / "good.csv")
    assert run_cli("calibrate", "ferraris", good, *FERRARIS_ARGS, "--out", tmp_path / "c")[0] == 0
    doc = json.loads((tmp_path / "c.json").read_text())
    doc["calibration"]["gyro_scale_raw_per_rps"][0] *= 1000
    (tmp_path / "c.json").write_text(json.dumps(doc))
    code, _, err = run_cli("compensate", tmp_path / "c", good, "--out", tmp_path / "x.csv",
                           "--column", FERRARIS_ARGS[-1])
    assert code == 2
    assert "c.json" in err and "does not match its checksum" in err and \
        not (tmp_path / "x.csv").exists()


# --- 4. two runs at once; the pool after kill -9 --------------------------------------------------
SLOW = SMALL_SCENARIO.replace('name = "wavelet_soft"',
                              'name = "bp"\nparams = { max_epochs = 5000000, goal = 0.0 }') \
    .replace('preset = "tactical"', 'preset = "tactical"\n') + """
[thermal]
start_c = 20.0
[[thermal.steps]]
ramp_to_c = 25.0
rate_c_per_min = 10.0
[montecarlo]
replicates = 3
"""


def _start(args, cwd):
    return subprocess.Popen([*CLI, *map(str, args)], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)


def _wait_for(cond, timeout_s, what):
    t0 = time.monotonic()
    while not cond():
        if time.monotonic() - t0 > timeout_s:
            pytest.fail(f"timed out waiting for {what}")
        time.sleep(0.1)


def _descendants(pid: int) -> set[int]:
    children: dict[int, list[int]] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                ppid = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(d.name))
    out, todo = set(), [pid]
    while todo:
        for c in children.get(todo.pop(), []):
            out.add(c)
            todo.append(c)
    return out


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def test_a_second_run_into_the_same_place_is_refused_at_once(tmp_path):
    if not Path("/proc").is_dir():
        pytest.skip("needs /proc")
    (tmp_path / "slow.toml").write_text(SLOW)
    first = _start(["run", "slow.toml", "--out", "out", "--no-recording", "--quiet",
                    "--jobs", "1"], tmp_path)
    try:
        # the work folder is claimed before the first replicate starts
        _wait_for(lambda: (tmp_path / ".out.replicates").is_dir(), 60, "the first run's claim")
        t0 = time.monotonic()
        code, out, err = _cli_process(["run", "slow.toml", "--out", "out", "--no-recording",
                                       "--quiet"], tmp_path, timeout=60)
        assert time.monotonic() - t0 < 30
        assert code == 2, err
        line = one_error_line(err)
        assert "being filled by another fogbench process" in line and \
            f"pid {first.pid}" in line
        assert first.poll() is None  # the first goes on
    finally:
        os.killpg(first.pid, signal.SIGTERM)
        first.communicate(timeout=60)
    assert first.returncode == 143


def test_the_pool_ends_with_its_parent_after_kill_9(tmp_path):
    if not Path("/proc").is_dir():
        pytest.skip("needs /proc")
    (tmp_path / "slow.toml").write_text(SLOW)
    proc = _start(["run", "slow.toml", "--out", "out", "--no-recording", "--jobs", "2"], tmp_path)
    try:
        seen = ""
        while "fit bp" not in seen:  # replicate 0 fits here while the pool has the others
            line = proc.stderr.readline()
            if not line:
                pytest.fail(f"the run ended early: {seen}")
            seen += line
        _wait_for(lambda: len(_descendants(proc.pid)) >= 3, 60,
                  "the pool's processes (forkserver and two workers)")
        kids = _descendants(proc.pid)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
        _wait_for(lambda: not any(_alive(k) for k in kids), 20,
                  f"the pool's processes {sorted(k for k in kids if _alive(k))} to end")
    finally:
        for k in _descendants(proc.pid) | {proc.pid}:
            try:
                os.kill(k, signal.SIGKILL)
            except ProcessLookupError:
                pass


# --- 5. resume -------------------------------------------------------------------------------
@pytest.fixture
def killed(tiny, tmp_path):
    """A run of 4 replicates killed after 0, 1 and 2 were stored (the process gone)."""
    from fogbench.run.montecarlo import ScenarioMC, replicate_task
    from fogbench.run.workdir import scenario_digest

    tiny.write_text(SMALL_SCENARIO + "\n[montecarlo]\nreplicates = 4\n")
    mc = ScenarioMC(tiny, tmp_path / "run")
    mc.run_first()
    digest = scenario_digest(tiny.read_bytes().decode())
    for r in (1, 2):
        mc.work.write(replicate_task((str(tiny), digest, r, 1, None, {}, None, {})))
    mc.work.release()
    return tmp_path / ".run.replicates"


def _resume(tiny, tmp_path, *extra):
    return run_cli("run", tiny, "--out", tmp_path / "run", "--resume", "--quiet",
                   "--no-recording", "--no-figures", *extra)


def test_an_edited_replicate_is_refused_by_resume_naming_the_file(tiny, tmp_path, killed):
    f = killed / "r00002.json"
    doc = json.loads(f.read_text())
    runs = doc["protocols"]["p"]["runs"]["b"]
    runs["raw"]["rmse_dph"] *= 100
    f.write_text(json.dumps(doc))
    before = snapshot(tmp_path)
    code, _, err = _resume(tiny, tmp_path)
    assert code == 2
    line = one_error_line(err)
    assert str(f) in line and "does not match its checksum" in line
    assert snapshot(tmp_path) == before


def test_a_relabelled_replicate_is_refused_by_resume(tiny, tmp_path, killed):
    (killed / "r00002.json").rename(killed / "r00003.json")
    code, _, err = _resume(tiny, tmp_path)
    assert code == 2
    line = one_error_line(err)
    assert "r00003.json" in line and "holds replicate 2" in line


def test_a_replicate_of_another_scenario_is_refused(tiny, tmp_path, killed):
    doc = json.loads((killed / "r00001.json").read_text())
    doc["scenario_sha256"] = "0" * 64
    from fogbench.run.workdir import _doc_sha256

    doc["sha256"] = _doc_sha256(doc)
    (killed / "r00001.json").write_text(json.dumps(doc))
    code, _, err = _resume(tiny, tmp_path)
    assert code == 2 and "another scenario file" in one_error_line(err)


def test_resume_with_fewer_replicates_than_stored_uses_the_first_r(tiny, tmp_path, killed):
    code, out, err = _resume(tiny, tmp_path, "--replicates", 2)
    assert code == 0, err
    assert "the first 2 are used" in err and "Traceback" not in err
    mc = json.loads((tmp_path / "run" / "metrics.json").read_text())["montecarlo"]
    assert mc["replicates"] == 2 and mc["resumed_replicates"] == [0, 1]
    assert not killed.exists()


def test_the_resumed_aggregate_equals_an_uninterrupted_run(tiny, tmp_path, killed):
    code, _, err = _resume(tiny, tmp_path)
    assert code == 0, err
    got = json.loads((tmp_path / "run" / "metrics.json").read_text())["montecarlo"]["digest"]
    code, _, err = run_cli("run", tiny, "--out", tmp_path / "whole", "--quiet", "--no-recording",
                           "--no-figures")
    assert code == 0, err
    want = json.loads((tmp_path / "whole" / "metrics.json").read_text())["montecarlo"]["digest"]
    assert got == want


# --- 6. signals ------------------------------------------------------------------------------
def test_a_swallowed_sigterm_still_ends_with_143_and_puts_nothing_in_place(tiny, tmp_path,
                                                                           monkeypatch):
    """SIGTERM while a figure is drawn, its exception swallowed on the way (as in a matplotlib
    callback, where Python only prints it): the command still ends with the one line and 143,
    and no run directory is put in place."""
    from fogbench.report import rundir as report_rundir
    from fogbench.report import spectra as report_spectra
    from fogbench.outputs.folders import Terminated

    real = report_spectra.fig_psd

    def fig_psd(*a):
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.01)
        except Terminated:
            pass  # swallowed
        return real(*a)

    monkeypatch.setattr(report_rundir, "fig_psd", fig_psd)
    code, out, err = run_cli("run", tiny, "--out", tmp_path / "run", "--quiet", "--no-recording")
    assert code == 143, err
    assert err.strip().splitlines()[-1].startswith("fogbench: terminated (SIGTERM)")
    assert "wrote" not in out and not (tmp_path / "run").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".part")]


def test_a_half_built_object_failing_in_its_del_after_a_signal_is_not_printed(monkeypatch):
    """A signal that cut an ``__init__`` short leaves an object whose ``__del__`` fails (CI,
    2026-12-05: pyparsing's ``Forward`` "has no attribute 'expr'" printed between the two lines of
    a SIGTERM's ending); after a signal Python's "Exception ignored" report is the signal's
    consequence and stays silent, before one it is printed as Python prints it."""
    from fogbench.outputs import interrupts as signals

    class HalfBuilt:
        def __del__(self):
            self.expr is None

    printed = []
    monkeypatch.setattr(signals, "_default_unraisable", printed.append)
    monkeypatch.setattr(sys, "unraisablehook", signals._unraisable)
    monkeypatch.setattr(signals, "_RECEIVED", [])
    obj = HalfBuilt()
    del obj
    assert [type(u.exc_value) for u in printed] == [AttributeError]  # no signal: Python's report
    monkeypatch.setattr(signals, "_RECEIVED", [signal.SIGTERM])
    obj = HalfBuilt()
    del obj
    assert len(printed) == 1


@pytest.mark.parametrize("sig, code, delay_s", [
    (signal.SIGINT, 130, 0.15), (signal.SIGTERM, 143, 0.15),   # during the imports
    (signal.SIGINT, 130, 1.2), (signal.SIGTERM, 143, 1.5),      # simulating, fitting, writing
    # (the tiny run takes about 2.1 s here: a signal at 2.0 s met it leaving, exit 0)
])
def test_a_signal_at_any_moment_ends_with_the_one_line(tiny, tmp_path, sig, code, delay_s):
    proc = _start(["run", tiny, "--out", "run", "--no-recording", "--quiet"], tmp_path)
    time.sleep(delay_s)
    if proc.poll() is not None:
        pytest.skip("the run ended before the signal")
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == code, err
    lines = err.strip().splitlines()
    assert lines[-1] == (
        "fogbench: interrupted; files already complete are kept, none is half-written"
        if sig == signal.SIGINT else
        "fogbench: terminated (SIGTERM); files already complete are kept, none is half-written")
    kept = tmp_path / ".run.replicates"
    # before it, at most the line saying where finished replicates are kept
    assert lines[:-1] == ([] if not kept.exists() else
                          [f"fogbench: replicates of tiny are kept (1 in {kept}); run again "
                           "with --resume to go on, or remove those folders"]), err
    assert not kept.exists() or len(list(kept.glob("r*.json"))) == 1
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".part")]
    assert not (tmp_path / "run").exists()


# --- 6. smaller --------------------------------------------------------------------------------
def test_out_dot_in_an_empty_folder_is_refused(tiny, tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    for command in (["run", tiny, "--no-recording"], ["simulate", tiny]):
        code, _, err = run_cli(*command, "--out", ".", "--quiet", cwd=empty)
        assert code == 2
        assert "is the current folder" in one_error_line(err)
        assert list(empty.iterdir()) == []


def test_a_log_beyond_any_sensor_is_refused_and_nothing_written(tmp_path):
    log, m = _calibrated(tmp_path, "wavelet_soft")
    huge = tmp_path / "huge.csv"
    text = log.read_text().splitlines()
    parts = text[5].split(",")
    parts[1] = "1e300"
    text[5] = ",".join(parts)
    huge.write_text("\n".join(text) + "\n")
    before = snapshot(tmp_path)
    code, _, err = run_cli("compensate", m / "kal", huge, "--out", tmp_path / "clean.csv")
    assert code == 2
    line = one_error_line(err)
    assert "line 6" in line and "'gyro_x_dps'" in line and "no sensor measures" in line
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("header, scale, words", [
    ("time_ms,gyro_x_dps", 1.0, ["'time_ms'", "100000 Hz", "time_s"]),   # seconds under _ms
    ("time_s,gyro_x_rps", 1.0, ["'gyro_x_rps'", "deg/s", "'rps' right"]),   # deg/s under _rps
])
def test_units_the_values_contradict_are_warned(tmp_path, header, scale, words):
    rng = np.random.default_rng(0)
    t = np.arange(2000) * 0.01
    rate = 500.0 + rng.standard_normal(2000)      # a 500 deg/s table rate
    (tmp_path / "log.csv").write_text(header + "\n" + "".join(
        f"{a:.2f},{float(b)!r}\n" for a, b in zip(t, rate)))
    code, out, err = run_cli("allan", tmp_path / "log.csv")
    assert code == 0, err
    warns = [ln for ln in err.splitlines() if ln.startswith("fogbench: warning:")]
    assert len(warns) == 1 and all(w in warns[0] for w in words), err


@pytest.mark.parametrize("row, n", [("0.03,1.0", 2), ("0.03,1.0,2.0,3.0", 4)])
def test_a_short_row_is_refused_like_a_long_one(tmp_path, row, n):
    rows = ["time_s,gyro_x_dps,temp_c"] + [f"{i / 100:.2f},0.0{i % 10},20.0" for i in range(3)]
    rows += [row] + [f"{i / 100:.2f},0.0{i % 10},20.0" for i in range(4, 200)]
    (tmp_path / "log.csv").write_text("\n".join(rows) + "\n")
    code, _, err = run_cli("allan", tmp_path / "log.csv")
    assert code == 2
    line = one_error_line(err)
    assert f"line 5: {n} field(s), the header (line 1) has 3" in line


def test_a_symbolic_link_loop_is_one_line_not_a_traceback(tmp_path):
    loop = tmp_path / "loop.csv"
    loop.symlink_to(loop)
    log = _static_log(tmp_path / "log.csv")
    for args in (["allan", loop], ["calibrate", "wavelet_soft", loop, "--out", tmp_path / "m"],
                 ["compensate", tmp_path / "m", log, "--out", loop],
                 ["run", loop]):
        code, _, err = run_cli(*args)
        assert code == 2, (args, err)
        one_error_line(err)


def test_an_unknown_top_level_table_lists_every_allowed_one(tiny):
    tiny.write_text(SMALL_SCENARIO + "\n[bogus]\nx = 1\n")
    code, _, err = run_cli("check", tiny)
    assert code == 2
    line = one_error_line(err)
    for table in ("bounds", "thermal", "paper", "claims", "montecarlo", "methods", "protocols",
                  "compensation", "scenario", "table", "fog", "runs"):
        assert f"'{table}'" in line, line


# --- found by a second reader trying the fixes ----------------------------------------------
@pytest.mark.parametrize("text, words", [
    ('"fs_hz": NaN', ["kal.json", "not valid JSON", "NaN"]),
    ('"fs_hz": 1' + "0" * 5000, ["kal.json", "not valid JSON"]),
    ("[" * 100_000, ["kal.json"]),
])
def test_a_manifest_that_is_not_json_we_write_names_the_file(tmp_path, text, words):
    log, m = _calibrated(tmp_path)
    body = (m / "kal.json").read_text()
    if text.startswith("["):
        (m / "kal.json").write_text(text)
    else:
        (m / "kal.json").write_text(body.replace(f'"fs_hz": {json.loads(body)["fs_hz"]!r}',
                                                 text))
    assert_compensate_refused(tmp_path, m / "kal", log, *words)


def test_deeply_nested_inputs_are_one_line(tiny, tmp_path, killed):
    (killed / "r00001.json").write_text("[" * 100_000)
    code, _, err = _resume(tiny, tmp_path)
    assert code == 2 and "r00001.json" in one_error_line(err)
    deep = tmp_path / "deep.toml"
    deep.write_text(SMALL_SCENARIO.replace('preset = "tactical"',
                                           'preset = "tactical"\nbias_dph = ' + "[" * 600
                                           + "]" * 600))
    code, _, err = run_cli("check", deep)
    assert code == 2
    one_error_line(err)


def test_a_triad_calibration_with_a_text_for_a_number_is_refused(tmp_path):
    from fogcomp._persistence import _canonical_sha256

    good = _ferraris_csv(tmp_path / "good.csv")
    assert run_cli("calibrate", "ferraris", good, *FERRARIS_ARGS, "--out", tmp_path / "c")[0] == 0
    for change, words in ((lambda d: d["calibration"].update(g_mps2="9.81"),
                           ["'g_mps2' must hold numbers"]),
                          (lambda d: d.update(method="kalman"),
                           ["'method' of a triad calibration must be 'ferraris'"])):
        doc = json.loads((tmp_path / "c.json").read_text())
        change(doc)
        doc["sha256"] = _canonical_sha256(doc)
        (tmp_path / "x.json").write_text(json.dumps(doc))
        code, _, err = run_cli("compensate", tmp_path / "x", good, "--out", tmp_path / "o.csv",
                               "--column", FERRARIS_ARGS[-1])
        assert code == 2, err
        line = one_error_line(err)
        assert "x.json" in line and all(w in line for w in words), line


def test_a_column_mapped_to_two_channels_is_refused(tmp_path):
    good = _ferraris_csv(tmp_path / "good.csv")
    code, _, err = run_cli("calibrate", "ferraris", good, "--fs", "100", "--angle-deg", "-360",
                           "--column", "acc_x=acc_x:au,acc_y=acc_x:au,acc_z=acc_z:au,"
                           "gyro_x=gyr_x:au,gyro_y=gyr_y:au,gyro_z=gyr_z:au",
                           "--out", tmp_path / "c")
    assert code == 2
    assert "'acc_x' is mapped to two channels" in one_error_line(err)


def test_a_pipe_and_a_late_bad_byte_are_named(tmp_path):
    fifo = tmp_path / "log.csv"
    os.mkfifo(fifo)
    code, _, err = run_cli("allan", fifo)
    assert code == 2 and "not a regular file" in one_error_line(err)
    bad = tmp_path / "bad.csv"
    rows = ["time_s,gyro_x_dps"] + [f"{i / 100:.2f},0.0{i % 10}" for i in range(300)]
    data = ("\n".join(rows) + "\n").encode()
    at = data.index(b"\n1.50,")
    bad.write_bytes(data[:at + 4] + b"\xff" + data[at + 5:])
    code, _, err = run_cli("allan", bad)
    assert code == 2 and "line 152" in one_error_line(err) and "not UTF-8" in err


@pytest.mark.parametrize("out", ["newdir/..", "a/../b"])
def test_outputs_through_dot_dot_are_refused(tmp_path, out):
    log = _static_log(tmp_path / "log.csv")
    before = snapshot(tmp_path)
    for args in (["allan", log, "--out", out], ["calibrate", "kalman", log, "--out", out]):
        code, _, err = run_cli(*args, cwd=tmp_path)
        assert code == 2 and "'..'" in one_error_line(err), err
    code, _, err = run_cli("calibrate", "kalman", log, "--out", ".", cwd=tmp_path)
    assert code == 2 and "name the model file" in one_error_line(err)
    assert snapshot(tmp_path) == before


def test_a_second_suite_into_the_same_reports_folder_is_refused_at_once(tmp_path):
    if not Path("/proc").is_dir():
        pytest.skip("needs /proc")
    (tmp_path / "scn").mkdir()
    (tmp_path / "scn" / "slow.toml").write_text(SLOW)
    first = _start(["suite", "--scenarios", "scn", "--out", "rep", "--no-recording",
                    "--jobs", "1"], tmp_path)
    try:
        _wait_for(lambda: (tmp_path / "rep" / ".tiny.replicates").is_dir(), 60,
                  "the first suite's claim")
        (tmp_path / "rep" / "README.md").exists() and pytest.fail("no summary yet")
        code, out, err = _cli_process(["suite", "--scenarios", "scn", "--out", "rep",
                                       "--no-recording"], tmp_path, timeout=60)
        assert code == 2
        assert "another fogbench suite is writing into" in one_error_line(err)
        assert not (tmp_path / "rep" / "README.md").exists()   # nothing written over
    finally:
        os.killpg(first.pid, signal.SIGTERM)
        first.communicate(timeout=60)


def test_a_disk_filling_up_between_replicates_stops_the_run_with_one_line(tiny, tmp_path,
                                                                          full_disk):
    """The first replicate is stored, the disk then fills: the run stops at once with one line
    naming the file it could not write (no traceback per replicate, no further replicates
    computed), and says what it kept."""
    tiny.write_text(SMALL_SCENARIO + "\n[montecarlo]\nreplicates = 40\n")
    _fill(full_disk, 12_000)
    code, out, err = _cli_process(["run", tiny, "--out", full_disk / "run", "--no-recording",
                                   "--quiet", "--jobs", "1"], tmp_path)
    assert code == 1, (out, err)
    assert "Traceback" not in err and "exception calling callback" not in err, err
    line = one_error_line(err)
    assert "No space left on device (" in line and str(full_disk) in line, line
    assert ".part" not in line
