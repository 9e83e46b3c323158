"""The Rerun recording of a run (fogbench/recording/__init__.py), read back with rerun's own .rrd reader.

rerun-sdk 0.41 reads a file with ``rerun.chunk.RrdReader(path)``: ``recordings()`` /
``blueprints()`` list the stores, ``stream()`` yields the chunks of the first recording, and each
``Chunk`` gives its ``entity_path``, ``is_static`` and ``to_record_batch()`` (pyarrow; the index
column is named after the timeline, the data columns ``Archetype:field``, e.g. ``Scalars:scalars``).
"""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

import allantools
import numpy as np
import pyarrow as pa
import pytest
import scipy.signal
from rerun.chunk import RrdReader

import fogcomp
from fogcomp import Compensator, register
from fogcomp.units import DPH, DPS
from fogbench import recording as R
from fogbench.recording import blueprint as recording_blueprint
from fogbench.recording import entities as recording_entities
from fogbench.recording import loglog as recording_loglog
from fogbench.recording import viewer as recording_viewer
from fogbench.recording import write as recording_write
from fogbench.report.views import method_entries
from fogbench.run.runner import run_scenario

TINY = """
[scenario]
name = "rec_tiny"
description = "Tiny scenario for the recording tests (after paper000_wnn)"
sample_rate_hz = 100.0

[table]
radius_m = 0.05
latitude_deg = 45.0
heading_deg = 0.0

[fog]
preset = "low_grade"
axes = ["z"]

[thermal]
start_c = 20.0
coil_time_constant_s = 5.0
[[thermal.steps]]
ramp_to_c = 22.0
rate_c_per_min = 30.0

[[runs]]
name = "fit_run"
seed = 11
[[runs.motion]]
type = "rate"
rate_dps = -60.0
duration_s = 8.0

[[runs]]
name = "test_run"
seed = 12
start_tilt_deg = 30.0
[[runs.motion]]
type = "rate"
rate_dps = -30.0
tilt_deg = 30.0
duration_s = 6.0

[compensation]
axis = "z"

[[protocols]]
name = "held_out"
skip_s = 2.0
fit = [{ run = "fit_run" }]
score = ["test_run"]

[[methods]]
name = "wavelet_soft"

[[methods]]
name = "kalman"
"""

FAILING = TINY.replace('name = "rec_tiny"', 'name = "rec_tiny_failing"') + """
[[methods]]
name = "always_fails_rec"
"""


@register
class _AlwaysFails(Compensator):
    """A test-only method whose fit always diverges."""

    name = "always_fails_rec"

    def __init__(self):
        pass

    def _fit(self, data, error):
        raise fogcomp.DivergenceError("always_fails_rec: diverged on purpose (test)")


# --------------------------------------------------------------------------------------------
# reading a recording back
class Rrd:
    def __init__(self, path):
        self.reader = RrdReader(path)
        self.chunks: dict[str, list] = {}
        for c in self.reader.stream():
            self.chunks.setdefault(c.entity_path, []).append(c)

    @property
    def paths(self) -> set[str]:
        return set(self.chunks)

    def column(self, path: str, component: str, timeline: str = R.TIMELINE):
        """(times in ns, values) of a temporal component, sorted by time."""
        ts, vs = [], []
        for c in self.chunks[path]:
            if c.is_static:
                continue
            rb = c.to_record_batch()
            if component not in rb.schema.names:
                continue
            ts.append(rb.column(timeline).cast(pa.int64()).to_numpy())
            col = rb.column(component)
            lengths = col.value_lengths().to_numpy(zero_copy_only=False)
            assert np.all(lengths == 1), f"{path}: {component} is not one value per row"
            vals = col.flatten()
            if pa.types.is_fixed_size_list(vals.type):  # Vec3D / Quaternion rows
                width = vals.type.list_size
                vs.append(vals.flatten().to_numpy(zero_copy_only=False).reshape(-1, width))
            else:
                vs.append(vals.to_numpy(zero_copy_only=False))
        assert ts, f"{path}: no temporal {component}"
        t = np.concatenate(ts)
        v = np.concatenate(vs)
        order = np.argsort(t, kind="stable")
        return t[order], v[order]

    def scalars(self, path: str, timeline: str = R.TIMELINE):
        return self.column(path, "Scalars:scalars", timeline)

    def static_strips(self, path: str) -> list[np.ndarray]:
        """The static LineStrips2D of ``path``: a list of (k, 2) arrays."""
        for c in self.chunks[path]:
            rb = c.to_record_batch()
            if c.is_static and "LineStrips2D:strips" in rb.schema.names:
                return [np.array(strip, dtype=float)
                        for strip in rb.column("LineStrips2D:strips")[0].as_py()]
        raise AssertionError(f"{path}: no static LineStrips2D")

    def static_text(self, path: str) -> str:
        for c in self.chunks[path]:
            rb = c.to_record_batch()
            if c.is_static and "TextDocument:text" in rb.schema.names:
                return rb.column("TextDocument:text")[0][0].as_py()
        raise AssertionError(f"{path}: no static TextDocument")


def ns(t):
    return np.round(np.asarray(t) * 1e9).astype(np.int64)


def assert_f32_equal(got, want, what):
    """Equal to float32 precision (the scale of the series sets the absolute tolerance)."""
    got, want = np.asarray(got, float), np.asarray(want, float)
    assert got.shape == want.shape, f"{what}: shape {got.shape} != {want.shape}"
    scale = max(float(np.max(np.abs(want))), 1e-30)
    np.testing.assert_allclose(got, want, rtol=2 * np.finfo(np.float32).eps,
                               atol=2 * np.finfo(np.float32).eps * scale, err_msg=what)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    d = tmp_path_factory.mktemp("rec")
    (d / "tiny.toml").write_text(TINY)
    res = run_scenario(d / "tiny.toml")
    R.write_recording(res, d / "recording.rrd")
    return res, d / "recording.rrd", Rrd(d / "recording.rrd")


@pytest.fixture(scope="module")
def failing(tmp_path_factory):
    d = tmp_path_factory.mktemp("rec_fail")
    (d / "failing.toml").write_text(FAILING)
    res = run_scenario(d / "failing.toml")
    R.write_recording(res, d / "recording.rrd")
    return res, Rrd(d / "recording.rrd")


def test_the_file_holds_one_recording_named_after_the_scenario_and_a_blueprint(tiny):
    res, path, rrd = tiny
    recs = rrd.reader.recordings()
    assert [(r.application_id, r.recording_id) for r in recs] == [("fogbench", "rec_tiny")]
    (bp,) = rrd.reader.blueprints()
    assert bp.application_id == "fogbench"
    names, timeline = set(), None
    for c in rrd.reader.stream(store=bp):
        rb = c.to_record_batch()
        for col in ("ViewBlueprint:display_name", "ContainerBlueprint:display_name"):
            if col in rb.schema.names:
                names |= {x for row in rb.column(col).to_pylist() for x in row or []}
        if "TimePanelBlueprint:timeline" in rb.schema.names:
            timeline = rb.column("TimePanelBlueprint:timeline").to_pylist()[0][0]
    assert any(n.startswith("Error") and "test_run, deg/h" in n for n in names), names
    assert {"Overview", "Table and chamber",
            "Allan deviation", "PSD", "Report"} <= names
    assert any(n.startswith("Rate tables (3-D)") for n in names)
    assert timeline == R.TIMELINE


def test_documented_entity_paths_exist(tiny):
    res, _, rrd = tiny
    want = {"/report/metrics", "/report/scenario"}
    for run in res.data:
        want |= {f"/table/{run}", f"/table/{run}/base", f"/table/{run}/tilt",
                 f"/table/{run}/turntable", f"/table/{run}/fog",
                 f"/table/{run}/fog/sensitive_axis", f"/table/{run}/fog/gravity",
                 f"/runs/{run}/truth/rate", f"/runs/{run}/fog/raw",
                 f"/runs/{run}/table/tilt_deg", f"/runs/{run}/table/tilt_cmd_deg",
                 f"/runs/{run}/table/turn_rate_dps", f"/runs/{run}/table/turn_rate_cmd_dps",
                 f"/runs/{run}/thermal/chamber_c", f"/runs/{run}/thermal/coil_c",
                 f"/runs/{run}/thermal/coil_rate_c_per_min",
                 f"/runs/{run}/thermal/housing_c", f"/runs/{run}/thermal/sensor_c",
                 f"/runs/{run}/thermal/sensor_rate_c_per_min",
                 f"/runs/{run}/gravity/x", f"/runs/{run}/gravity/y", f"/runs/{run}/gravity/z"}
        want |= {f"/runs/{run}/fog/error_terms/{term}" for term in res.data[run].fog.terms}
    for it in res.scored:
        assert set(it.outputs) == {"raw", "oracle", "wavelet_soft", "kalman"}
        for lab in it.outputs:
            want |= {f"/runs/{it.run}/fog/compensated/{it.protocol}/{lab}",
                     f"/runs/{it.run}/fog/error/{it.protocol}/{lab}",
                     f"/report/allan/{it.protocol}/{it.run}/{lab}",
                     f"/report/psd/{it.protocol}/{it.run}/{lab}"}
    missing = want - rrd.paths
    assert not missing, f"missing entity paths: {sorted(missing)}"


def test_truth_and_raw_are_every_sample_of_each_run_in_deg_per_s(tiny):
    res, _, rrd = tiny
    j = res.scenario.axes.index(res.plan.axis)
    for run, rd in res.data.items():
        assert R.decimation(rd.n, R.MAX_SERIES_POINTS) == 1
        t, truth = rrd.scalars(f"/runs/{run}/truth/rate")
        assert t.size == rd.n
        np.testing.assert_array_equal(t, ns(rd.truth.t))
        assert_f32_equal(truth, rd.truth_axis(j) / DPS, f"{run} truth")
        t, raw = rrd.scalars(f"/runs/{run}/fog/raw")
        assert t.size == rd.n
        assert_f32_equal(raw, rd.fog.raw[:, j] / DPS, f"{run} raw")
        # a moving table: the truth really is the commanded rate, not a constant placeholder
        assert abs(np.median(truth) - rd.run.motion[0].rate / DPS) < 1.0
        _, coil = rrd.scalars(f"/runs/{run}/thermal/coil_c")
        assert_f32_equal(coil, rd.thermal.coil, f"{run} coil")
        _, sensor = rrd.scalars(f"/runs/{run}/thermal/sensor_c")
        assert_f32_equal(sensor, rd.thermal.sensor, f"{run} sensor reading")
        _, housing = rrd.scalars(f"/runs/{run}/thermal/housing_c")
        assert_f32_equal(housing, rd.thermal.housing, f"{run} housing")
        _, srate = rrd.scalars(f"/runs/{run}/thermal/sensor_rate_c_per_min")
        assert_f32_equal(srate, rd.thermal.sensor_rate * 60.0, f"{run} sensor dT/dt")
        for i, ax in enumerate("xyz"):
            _, g = rrd.scalars(f"/runs/{run}/gravity/{ax}")
            assert_f32_equal(g, rd.truth.gravity[:, i], f"{run} gravity {ax}")
        for term, v in rd.fog.terms.items():
            _, e = rrd.scalars(f"/runs/{run}/fog/error_terms/{term}")
            assert_f32_equal(e, v[:, j] / DPH, f"{run} {term}")


def test_compensated_and_error_series_of_every_scored_piece(tiny):
    res, _, rrd = tiny
    for it in res.scored:
        p = it.piece
        for lab, out in it.outputs.items():
            t, y = rrd.scalars(f"/runs/{it.run}/fog/compensated/{it.protocol}/{lab}")
            np.testing.assert_array_equal(t, ns(p.t))
            assert_f32_equal(y, out / DPS, f"{lab} compensated")
            t, e = rrd.scalars(f"/runs/{it.run}/fog/error/{it.protocol}/{lab}")
            np.testing.assert_array_equal(t, ns(p.t))
            assert_f32_equal(e, (out - p.truth) / DPH, f"{lab} error")
            # the Allan deviation, in (log10 tau/s, log10 ADEV/(deg/h)), against allantools
            xy = rrd.static_strips(f"/report/allan/{it.protocol}/{it.run}/{lab}")[0]
            taus, adev, _, _ = allantools.oadev((out - p.truth) / DPH, rate=p.fs,
                                                data_type="freq", taus="octave")
            # drawn up to the longest tau with at least 8 non-overlapping clusters of tau * fs
            # samples in the record (IEEE Std 952 / NIST SP 1065; the README's rule)
            keep = [math.floor(out.size / round(tau * p.fs)) >= 8 for tau in taus]
            taus, adev = taus[keep], adev[keep]
            np.testing.assert_allclose(10 ** xy[:, 0], taus, rtol=1e-5)
            np.testing.assert_allclose(10 ** xy[:, 1], adev, rtol=1e-5)
            assert math.isclose(10 ** xy[0, 0], 1.0 / p.fs, rel_tol=1e-6)
            bars = rrd.static_strips(f"/report/allan/{it.protocol}/{it.run}/{lab}/ci")
            assert len(bars) == taus.size
            for (lo, hi), a in zip(bars, adev):
                assert lo[0] == hi[0] and 10 ** lo[1] < a < 10 ** hi[1]
            # the PSD of the error, (deg/h)^2/Hz: scipy's Welch estimate (Hann, 8 half-overlapping
            # segments: 64 of the 400 samples) averaged by hand in 10 bands a decade
            xy = rrd.static_strips(f"/report/psd/{it.protocol}/{it.run}/{lab}")[0]
            e = (out - p.truth) / DPH
            assert e.size == 400
            f, pxx = scipy.signal.welch(e - e.mean(), fs=p.fs, nperseg=64)
            f, pxx = f[1:-1], pxx[1:-1]
            fb, pb = [], []
            for lo_f in f[0] * 10.0 ** (np.arange(0, 40) / 10.0):
                sel = (f >= lo_f * (1 - 1e-9)) & (f < lo_f * 10 ** 0.1 * (1 - 1e-9))
                if sel.any():
                    fb.append(f[sel].mean())
                    pb.append(pxx[sel].mean())
            np.testing.assert_allclose(10 ** xy[:, 0], fb, rtol=1e-5)
            # values below the plot's floor (its lowest grid line) are drawn on the floor
            floor = min(pt[1] for strip in rrd.static_strips(
                f"/report/psd/{it.protocol}/{it.run}/axes/grid") for pt in strip)
            assert floor >= math.log10(max(pb)) - R.LOGLOG_MAX_DECADES - 1
            np.testing.assert_allclose(10 ** xy[:, 1], np.maximum(pb, 10 ** floor), rtol=1e-4)
            # each band has its interval bar around it
            bars = rrd.static_strips(f"/report/psd/{it.protocol}/{it.run}/{lab}/ci")
            assert len(bars) == len(fb)
            for (lo, hi), v in zip(bars, pb):
                if v > 10 ** floor:      # (a value on the floor has its bar clipped to it)
                    assert lo[0] == hi[0] and 10 ** lo[1] < v < 10 ** hi[1]


def test_table_poses_follow_the_truth_quaternions(tiny):
    res, _, rrd = tiny
    rd = res.data["test_run"]
    k = R.decimation(rd.n, R.MAX_POSE_POINTS)
    t, q = rrd.column("/table/test_run/fog", "Transform3D:quaternion")
    np.testing.assert_array_equal(t, ns(rd.truth.t[::k]))
    assert_f32_equal(q, rd.truth.fog_quat[::k][:, [1, 2, 3, 0]], "fog quaternion (xyzw)")
    _, pos = rrd.column("/table/test_run/fog", "Transform3D:translation")
    assert_f32_equal(pos, rd.truth.fog_pos[::k], "fog position")
    _, q = rrd.column("/table/test_run/tilt", "Transform3D:quaternion")
    assert_f32_equal(q, rd.truth.tilt_quat[::k][:, [1, 2, 3, 0]], "tilt quaternion (xyzw)")
    _, g = rrd.column("/table/test_run/fog/gravity", "Arrows3D:vectors")
    assert_f32_equal(g, rd.truth.gravity[::k] * recording_entities.GRAVITY_ARROW_M_PER_G, "gravity arrow")
    # tilted 30 deg about x: gravity has a y component in the sensor frame
    assert abs(g[0, 1] / recording_entities.GRAVITY_ARROW_M_PER_G - 0.5) < 1e-6


def test_static_report_documents(tiny):
    res, _, rrd = tiny
    assert res.scenario.text.strip() in rrd.static_text("/report/scenario")
    md = rrd.static_text("/report/metrics")
    for word in ("held_out", "test_run", "wavelet_soft", "kalman", "oracle", "rmse_dph",
                 "decimation"):
        assert word in md


def test_long_runs_are_decimated_as_documented(tiny, tmp_path, monkeypatch):
    res, _, _ = tiny
    monkeypatch.setattr(recording_write, "MAX_SERIES_POINTS", 250)
    monkeypatch.setattr(recording_write, "MAX_POSE_POINTS", 100)
    R.write_recording(res, tmp_path / "recording.rrd")
    rrd = Rrd(tmp_path / "recording.rrd")
    j = res.scenario.axes.index(res.plan.axis)
    md = rrd.static_text("/report/metrics")
    for run, rd in res.data.items():
        k = R.decimation(rd.n, 250)
        assert k > 1
        assert f"| {run} | {rd.n} | {k} | {R.decimation(rd.n, 100)} |" in md
        t, raw = rrd.scalars(f"/runs/{run}/fog/raw")
        assert t.size == math.ceil(rd.n / k) <= 250
        assert_f32_equal(raw, rd.fog.raw[::k, j] / DPS, f"{run} decimated raw")
        t, _ = rrd.column(f"/table/{run}/fog", "Transform3D:quaternion")
        assert t.size <= 100
    it = res.scored[0]
    t, y = rrd.scalars(f"/runs/{it.run}/fog/compensated/{it.protocol}/kalman")
    k = R.decimation(it.piece.t.size, 250)
    assert k > 1 and t.size == math.ceil(it.piece.t.size / k)
    assert_f32_equal(y, it.outputs["kalman"][::k] / DPS, "decimated kalman")


def test_a_failed_method_has_no_series_and_the_rest_are_recorded(failing):
    res, rrd = failing
    it = res.scored[0]
    assert it.metrics["always_fails_rec"]["status"] == "failed"
    assert "always_fails_rec" not in it.outputs
    assert [r.recording_id for r in rrd.reader.recordings()] == ["rec_tiny_failing"]
    assert not any("always_fails_rec" in p for p in rrd.paths)
    for lab in ("raw", "oracle", "wavelet_soft", "kalman"):
        t, y = rrd.scalars(f"/runs/{it.run}/fog/compensated/{it.protocol}/{lab}")
        assert t.size == it.piece.t.size
        assert_f32_equal(y, it.outputs[lab] / DPS, lab)
    md = rrd.static_text("/report/metrics")
    assert "FAILED" in md and "always_fails_rec" in md and "diverged on purpose" in md


# --------------------------------------------------------------------------------------------
# fogbench view
def test_view_without_a_recording_exits_2_naming_the_path(tmp_path, capsys):
    assert R.view(tmp_path) == 2
    err = capsys.readouterr().err
    assert str(tmp_path / "recording.rrd") in err


def test_view_without_a_viewer_says_how_to_open_the_file(tmp_path, capsys, monkeypatch):
    (tmp_path / "recording.rrd").write_bytes(b"x")
    monkeypatch.setattr(recording_viewer, "_viewer_command", lambda: None)
    monkeypatch.setattr(recording_viewer.subprocess, "Popen", _no_popen)
    assert R.view(tmp_path) == 1
    err = capsys.readouterr().err
    assert f"rerun {tmp_path / 'recording.rrd'}" in err and "pip install rerun-sdk" in err


def test_view_without_a_display_says_how_to_open_the_file(tmp_path, capsys, monkeypatch):
    (tmp_path / "recording.rrd").write_bytes(b"x")
    monkeypatch.setattr(recording_viewer, "_viewer_command", lambda: ["/opt/fake/rerun"])
    monkeypatch.setattr(recording_viewer, "_has_display", lambda: False)
    monkeypatch.setattr(recording_viewer.subprocess, "Popen", _no_popen)
    assert R.view(tmp_path) == 1
    assert f"rerun {tmp_path / 'recording.rrd'}" in capsys.readouterr().err


def test_without_a_display_the_first_suggestion_is_the_local_web_viewer(tmp_path, capsys,
                                                                       monkeypatch):
    (tmp_path / "recording.rrd").write_bytes(b"x")
    monkeypatch.setattr(recording_viewer, "_viewer_command", lambda: ["/opt/fake/rerun"])
    monkeypatch.setattr(recording_viewer, "_has_display", lambda: False)
    monkeypatch.setattr(recording_viewer.subprocess, "Popen", _no_popen)
    assert R.view(tmp_path) == 1
    err = capsys.readouterr().err
    assert err.index(f"fogbench view {tmp_path} --web") < err.index(f"rerun {tmp_path}")
    assert "127.0.0.1" in err


def _listening(port: int) -> list[str]:
    """Local addresses (hex, as /proc/net/tcp{,6} write them) listening on ``port``."""
    out = []
    for name in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            lines = Path(name).read_text().splitlines()[1:]
        except OSError:
            continue
        for ln in lines:
            f = ln.split()
            addr, hexport = f[1].rsplit(":", 1)
            if f[3] == "0A" and int(hexport, 16) == port:
                out.append(addr)
    return out


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _rrd(run_dir: Path) -> Path:
    """A valid recording.rrd in ``run_dir`` (one scalar), as `fogbench run` would leave one."""
    import rerun as rr

    rec = rr.RecordingStream("fogbench_view_test")
    rec.save(str(run_dir / "recording.rrd"))
    rec.log("x", rr.Scalars([1.0]))
    rec.flush()
    return run_dir / "recording.rrd"


def _serve_and_stop(run_dir: Path, *flags: str):
    """`fogbench view DIR --web FLAGS` with the real web viewer on two free ports, until both
    listen; then SIGTERM to fogbench, which must stop the viewer (the ports released).
    Returns (addresses the web port listened on, the gRPC port's, fogbench's stdout)."""
    import signal
    import sys
    import time

    _rrd(run_dir)
    web, grpc = _free_port(), _free_port()
    exe = Path(sys.executable).with_name("fogbench")      # the console script of this venv
    proc = subprocess.Popen([str(exe), "view", str(run_dir), "--web", *flags,
                             "--web-port", str(web), "--grpc-port", str(grpc)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and not (_listening(web) and _listening(grpc)):
            assert proc.poll() is None, proc.stdout.read() + proc.stderr.read()
            time.sleep(0.2)
        addrs = _listening(web), _listening(grpc)
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            raise
    out = proc.stdout.read()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and (_listening(web) or _listening(grpc)):
        time.sleep(0.2)
    assert not _listening(web) and not _listening(grpc)
    return *addrs, out


@pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="reads Linux's socket table")
def test_view_web_listens_on_this_machine_only_and_stops_with_its_viewer(tmp_path):
    """`fogbench view DIR --web` starts the real web viewer; the kernel's socket table shows
    both its ports bound to 127.0.0.1 (rerun's own default is 0.0.0.0), and SIGTERM to
    fogbench stops the viewer (the ports are released)."""
    web, grpc, out = _serve_and_stop(tmp_path)
    assert web == ["0100007F"] and grpc == ["0100007F"]
    assert "http://127.0.0.1:" in out


@pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="reads Linux's socket table")
def test_view_web_bind_to_a_host_name_listens_on_its_address(tmp_path):
    """`--bind localhost`: rerun wants an IP address, so fogbench resolves the name
    (getaddrinfo) and hands it the address; both ports listen on 127.0.0.1, announced as this
    machine only."""
    import socket

    assert socket.getaddrinfo("localhost", None, socket.AF_INET)[0][4][0] == "127.0.0.1"
    web, grpc, out = _serve_and_stop(tmp_path, "--bind", "localhost")
    assert web == ["0100007F"] and grpc == ["0100007F"]
    assert "http://127.0.0.1:" in out and "this machine only" in out
    assert "EVERY" not in out


def test_view_web_refuses_a_bind_it_cannot_resolve_in_one_line(tmp_path, capsys, monkeypatch):
    from fogbench.cli import main

    _rrd(tmp_path)
    monkeypatch.setattr(recording_viewer, "_viewer_command", lambda: ["/opt/fake/rerun"])
    monkeypatch.setattr(recording_viewer.subprocess, "Popen", _no_popen)
    assert main(["view", str(tmp_path), "--web", "--bind", "no-such-host.invalid"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--bind" in err and "no-such-host.invalid" in err, err


class _ViewerThatEnds(list):
    """A stand-in for the web viewer's process: records its arguments, ends at once."""

    def __call__(self, args, **kwargs):
        self.append(list(args))
        return self

    def wait(self, timeout=None):
        return 0


@pytest.mark.parametrize("bind, every", [("0.0.0.0", True), ("::", True),
                                         ("0:0:0:0:0:0:0:0", True), ("192.0.2.7", False),
                                         ("2001:db8::7", False), ("127.0.0.1", False),
                                         ("::1", False)])
def test_view_web_says_every_interface_only_for_the_unspecified_address(tmp_path, capsys,
                                                                        monkeypatch, bind,
                                                                        every):
    """Only 0.0.0.0 and :: listen on every interface; a specific address is announced as
    itself (whoever reaches that address), a loopback one as this machine only."""
    from fogbench.cli import main

    _rrd(tmp_path)
    viewer = _ViewerThatEnds()
    monkeypatch.setattr(recording_viewer, "_viewer_command", lambda: ["/opt/fake/rerun"])
    monkeypatch.setattr(recording_viewer.subprocess, "Popen", viewer)
    assert main(["view", str(tmp_path), "--web", "--bind", bind]) == 0
    out = capsys.readouterr().out
    assert ("EVERY network interface" in out) == every, out
    assert ("this machine only" in out) == (bind in ("127.0.0.1", "::1")), out
    assert len(viewer) == 1 and viewer[0][viewer[0].index("--bind") + 1] == bind
    if not every:
        assert f"listening on {bind}" in out


def test_view_flags_of_the_web_viewer_need_web(tmp_path, capsys, monkeypatch):
    """--bind, --web-port and --grpc-port without --web are refused (exit 2, naming the flag)
    and no viewer is started, on a valid recording that `fogbench view` opens without them."""
    from fogbench.cli import main

    _rrd(tmp_path)
    monkeypatch.setattr(recording_viewer, "_viewer_command", lambda: ["/opt/fake/rerun"])
    monkeypatch.setattr(recording_viewer, "_has_display", lambda: True)
    monkeypatch.setattr(recording_viewer.subprocess, "Popen", _FakeViewer)
    _FakeViewer.calls = []
    assert main(["view", str(tmp_path)]) == 0      # the recording and the viewer are fine
    assert len(_FakeViewer.calls) == 1
    capsys.readouterr()
    for flag, value in (("--bind", "0.0.0.0"), ("--web-port", "9999"), ("--grpc-port", "9999")):
        assert main(["view", str(tmp_path), flag, value]) == 2
        assert f"{flag}: only with --web" in capsys.readouterr().err
    assert len(_FakeViewer.calls) == 1


def _no_popen(*a, **k):
    raise AssertionError("no viewer may be started in the tests")


class _FakeViewer:
    calls: list = []

    def __init__(self, args, **kwargs):
        _FakeViewer.calls.append(list(args))

    def wait(self, timeout=None):
        raise subprocess.TimeoutExpired("rerun", timeout)


def test_view_spawns_the_viewer_on_the_file(tmp_path, monkeypatch):
    (tmp_path / "recording.rrd").write_bytes(b"x")
    monkeypatch.setattr(recording_viewer, "_viewer_command", lambda: ["/opt/fake/rerun"])
    monkeypatch.setattr(recording_viewer, "_has_display", lambda: True)
    monkeypatch.setattr(recording_viewer.subprocess, "Popen", _FakeViewer)
    _FakeViewer.calls = []
    assert R.view(tmp_path) == 0
    assert _FakeViewer.calls == [["/opt/fake/rerun", str(tmp_path / "recording.rrd")]]


def test_the_viewer_found_is_the_one_of_the_installed_rerun_sdk():
    cmd = recording_viewer._viewer_command()
    assert cmd is not None and cmd[0].endswith("rerun")


# --------------------------------------------------------------------------------------------
# the layout: whole run, linked axes, constant values, 3-D camera
def _blueprint_props(rrd) -> dict[str, dict[str, list]]:
    """entity path in the blueprint store -> component column -> first row."""
    (bp,) = rrd.reader.blueprints()
    out: dict[str, dict[str, list]] = {}
    for c in rrd.reader.stream(store=bp):
        rb = c.to_record_batch()
        for n in rb.schema.names:
            if ":" in n:
                out.setdefault(c.entity_path, {})[n] = rb.column(n).to_pylist()[-1]
    return out


def test_every_time_series_view_opens_on_the_whole_run_and_their_time_axes_are_linked(tiny):
    res, _, rrd = tiny
    props = _blueprint_props(rrd)
    t_end = ns(max(rd.truth.t[-1] for rd in res.data.values()))
    whole = [{"start": 0, "end": int(t_end)}]
    series_views = [p for p, c in props.items()
                    if c.get("ViewBlueprint:class_identifier") == ["TimeSeries"]]
    assert len(series_views) >= 8
    for v in series_views:
        axis = props.get(f"{v}/TimeAxis", {})
        assert axis.get("TimeAxis:link") == [2], f"{v}: time axis not linked to the global one"
        assert axis.get("TimeAxis:view_range") == whole
    # the shared (global) time axis the linked views use opens on the whole run too
    assert props[f"/view/{recording_blueprint._GLOBAL_VIEW_ID}/TimeAxis"]["TimeAxis:view_range"] == whole


def test_a_view_of_values_constant_to_rounding_gets_a_fixed_range_around_them():
    w = recording_entities._Writer(rec=None)
    w.ranges = {"/coil_rate": (-7e-9, 7e-9), "/temp": (20.0, 20.0 + 1e-12),
                "/rate": (-60.2, -59.8)}
    axis = recording_blueprint._y_axis(w, ["/coil_rate"])
    lo, hi = axis.range.as_arrow_array().to_pylist()[0]
    assert lo <= -0.5 and hi >= 0.5           # noise of 1e-8 spans a hundred-millionth of it
    lo, hi = recording_blueprint._y_axis(w, ["/temp"]).range.as_arrow_array().to_pylist()[0]
    assert lo < 20.0 < hi and hi - lo >= 1.0
    assert recording_blueprint._y_axis(w, ["/rate"]) is None     # a real variation is autoscaled
    assert recording_blueprint._y_axis(w, ["/coil_rate", "/rate"]) is None


def test_the_default_camera_sees_every_table(tiny):
    res, _, rrd = tiny
    props = _blueprint_props(rrd)
    (eye,) = [c for p, c in props.items() if p.endswith("/EyeControls3D")]
    pos = np.array(eye["EyeControls3D:position"][0])
    target = np.array(eye["EyeControls3D:look_target"][0])
    look = (target - pos) / np.linalg.norm(target - pos)
    for i, run in enumerate(res.data):
        centre = np.array([0.0, i * recording_entities.TABLE_SPACING_M, -0.3])
        d = centre - pos
        angle = math.degrees(math.acos(np.dot(d, look) / np.linalg.norm(d)))
        assert angle < 20.0, f"table {run} is {angle:.0f} deg off the camera's axis"


def test_the_sensitive_axis_and_gravity_arrows_start_apart(tiny):
    res, _, rrd = tiny
    for run in res.data:
        ax = _static_component(rrd, f"/table/{run}/fog/sensitive_axis", "Arrows3D:origins")
        g = _static_component(rrd, f"/table/{run}/fog/gravity", "Arrows3D:origins")
        assert np.linalg.norm(np.array(ax[0]) - np.array(g[0])) >= 0.08


def _static_component(rrd, path, column):
    for c in rrd.chunks[path]:
        rb = c.to_record_batch()
        if c.is_static and column in rb.schema.names:
            return rb.column(column)[0].as_py()
    raise AssertionError(f"{path}: no static {column}")


# --------------------------------------------------------------------------------------------
# confidence intervals, against allantools and against a simulation
def test_allan_bars_are_allantools_greenhall_intervals_for_the_leading_noise_type(tiny):
    """The recorded Allan bars are the chi-square intervals with Greenhall's EDF (allantools'
    own ``edf_greenhall`` and ``confidence_interval``) for the noise type fogcomp identifies at
    each tau, not white noise's EDF everywhere."""
    from fogcomp.allan import oadev_ci

    res, _, rrd = tiny
    checked = 0
    for it in res.scored:
        p = it.piece
        for lab, out in it.outputs.items():
            err = (out - p.truth) / DPH
            ci = oadev_ci(err, p.fs)
            bars = rrd.static_strips(f"/report/allan/{it.protocol}/{it.run}/{lab}/ci")
            drawn = ci.n // ci.m >= 8           # at least 8 non-overlapping clusters
            assert len(bars) == drawn.sum()
            for (lo, hi), a, m, alpha in zip(bars, ci.adev[drawn], ci.m[drawn],
                                             ci.alpha[drawn]):
                if alpha == 2:      # allantools has no EDF for white angle noise at few clusters
                    continue
                edf = allantools.edf_greenhall(alpha=int(alpha), d=2, m=int(m), N=ci.n + 1,
                                               overlapping=True, modified=False)
                want_lo, want_hi = allantools.confidence_interval(a, edf)
                assert math.isclose(10 ** lo[1], want_lo, rel_tol=1e-5)
                assert math.isclose(10 ** hi[1], want_hi, rel_tol=1e-5)
                checked += 1
    assert checked >= 10


def test_a_log_log_plot_over_19_decades_labels_a_few_and_keeps_8(tmp_path):
    """paper000's PSD (a filtered output falling to 1e-13 (deg/h)^2/Hz under a raw 1e5) stacked
    19 decade labels on its y axis: at most 6 labels an axis, 8 decades in y, the curve below
    drawn on the floor, and the axis titles clear of the tick labels."""
    import rerun as rr

    rec = rr.RecordingStream(application_id="t", recording_id="t", send_properties=False)
    mem = rec.memory_recording()
    w = recording_entities._Writer(rec)
    f = np.logspace(-1, 2, 50)
    curves = [("raw", "raw", (128, 128, 128), f, 1e5 / f, None, None),
              ("m", "m", (214, 39, 40), f, 1e-13 * np.ones_like(f), None, None)]
    recording_loglog._loglog(w, "/p", curves, "frequency, Hz", "PSD, (deg/h)^2/Hz", "")
    rec.flush()
    (tmp_path / "p.rrd").write_bytes(mem.drain_as_bytes())
    rec.disconnect()
    rrd = Rrd(tmp_path / "p.rrd")
    grid = rrd.static_strips("/p/axes/grid")
    y_lines = sorted({st[0][1] for st in grid if st[0][1] == st[1][1]})
    x_lines = sorted({st[0][0] for st in grid if st[0][0] == st[1][0]})
    # raw tops out at 1e6 at 0.1 Hz: 8 decades down to the floor 1e-2, not 1e-13
    assert y_lines == list(range(-2, 7)) and x_lines == list(range(-1, 3))
    m = rrd.static_strips("/p/m")[0]
    assert np.all(m[:, 1] == -2)                                     # on the floor
    # in (log10 x, log10 y): x tick labels below the box, y tick labels left of it
    pos = _static_points(rrd, "/p/axes/labels")
    labels = _static_labels(rrd, "/p/axes/labels")
    xs = {lab: xy for lab, xy in zip(labels, pos) if xy[1] < -2 and "," not in lab}
    ys = {lab: xy for lab, xy in zip(labels, pos) if xy[0] < -1 and "," not in lab}
    assert list(xs) == ["0.1", "1", "10", "100"]
    assert 2 <= len(ys) <= 6 and "1e6" in ys, ys            # not 9 (nor paper000's 19)
    # the titles clear of the tick labels: the x title below them, the y title above the box
    (xt,) = [xy for lab, xy in zip(labels, pos) if lab == "frequency, Hz"]
    (yt,) = [xy for lab, xy in zip(labels, pos) if lab.startswith("PSD")]
    dy_tick = -2 - min(xy[1] for xy in xs.values())               # tick labels' offset
    assert xt[1] <= -2 - 2 * dy_tick
    assert yt[1] >= 6 + dy_tick


# --------------------------------------------------------------------------------------------
# legends that fit: a sweep is one entry, the methods of an in-sample protocol one entry
SWEPT = TINY.replace('name = "rec_tiny"', 'name = "rec_tiny_swept"') + """
[[methods]]
name = "wavelet_soft"
label = "wavelet_band"
sweep = { level = [3, 4], threshold = ["universal", "sure"] }

[[protocols]]
name = "refit"
in_sample = true
fit = [{ run = "test_run" }]
score = ["test_run"]
"""


def _static_names(rrd, path) -> list[str]:
    for c in rrd.chunks[path]:
        rb = c.to_record_batch()
        if c.is_static and "SeriesLines:names" in rb.schema.names:
            return rb.column("SeriesLines:names")[0].as_py()
    raise AssertionError(f"{path}: no static SeriesLines names")


def test_legends_list_a_sweep_once_and_the_in_sample_methods_once(tmp_path):
    """The viewer's legend cuts off what does not fit a plot (paper000 opened without its WNN
    listed, paper002 without raw and oracle): the 4 settings of a sweep are one legend entry,
    and the methods of an in-sample protocol one entry, in the error view of a run scored by a
    held-out and an in-sample protocol; the Allan legend lists the sweep as its default
    setting's line and its envelope, as the PNGs do."""
    (tmp_path / "swept.toml").write_text(SWEPT)
    res = run_scenario(tmp_path / "swept.toml")
    R.write_recording(res, tmp_path / "recording.rrd")
    rrd = Rrd(tmp_path / "recording.rrd")
    labels = ["raw", "oracle", "wavelet_soft", "kalman"] + [
        f"wavelet_band.level-{lv}.threshold-{th}" for lv in (3, 4) for th in ("universal", "sure")]
    names = set()
    for prot in ("held_out", "refit"):
        for lab in labels:
            path = f"/runs/test_run/fog/error/{prot}/{lab}"
            if path in rrd.paths:
                names |= set(_static_names(rrd, path))
    assert names == {"raw", "oracle", "wavelet_soft", "kalman", "wavelet_band (4 settings)",
                     "refit (in-sample): every method, lighter"}
    legend = _static_labels(rrd, "/report/allan/held_out/test_run/legend")
    assert legend == ["raw", "oracle", "wavelet_soft", "kalman",
                      "wavelet_band default (level-3.threshold-universal)",
                      "wavelet_band: 4 settings, best..worst"]


def test_allan_and_psd_plots_beyond_a_tab_s_share_go_in_a_tab_per_protocol(tmp_path,
                                                                          monkeypatch):
    """paper002's 12 PSD plots (4 protocols x 3 runs) were 110 px tall, their legends piled up:
    past MAX_LOGLOG_VIEWS plots, a tab per protocol holding its own."""
    (tmp_path / "swept.toml").write_text(SWEPT)
    res = run_scenario(tmp_path / "swept.toml")
    monkeypatch.setattr(recording_blueprint, "MAX_LOGLOG_VIEWS", 1)                   # 2 pieces: past it
    R.write_recording(res, tmp_path / "recording.rrd")
    props = _blueprint_props(Rrd(tmp_path / "recording.rrd"))
    for tab in ("Allan deviation", "PSD"):
        (root,) = [c for c in props.values()
                   if c.get("ContainerBlueprint:display_name") == [tab]]
        kids = [props["/" + k] for k in root["ContainerBlueprint:contents"]]
        assert [k["ContainerBlueprint:display_name"] for k in kids] == [["held_out"], ["refit"]]
        for k, prot in zip(kids, ("held_out", "refit")):
            (v,) = [props["/" + x] for x in k["ContainerBlueprint:contents"]]
            assert v["ViewBlueprint:space_origin"] == [
                f"/report/{'allan' if tab.startswith('Allan') else 'psd'}/{prot}/test_run"]
    monkeypatch.setattr(recording_blueprint, "MAX_LOGLOG_VIEWS", 6)                   # 2 pieces: one grid
    R.write_recording(res, tmp_path / "recording2.rrd")
    props = _blueprint_props(Rrd(tmp_path / "recording2.rrd"))
    (root,) = [c for c in props.values() if c.get("ContainerBlueprint:display_name") == ["PSD"]]
    assert all(k.startswith("view/") for k in root["ContainerBlueprint:contents"])


# --------------------------------------------------------------------------------------------
# Monte Carlo replicates
REPS = {"held_out": {"rmse_dph": {"raw": [491.0, 489.5, 490.2, 492.8, 488.1],
                                  "kalman": [12.5, None, 11.0, float("nan"), 13.25]},
                     "std_dps": {"wavelet_soft": [0.02, 0.021, 0.019, 0.0205, 0.022]}}}


def test_replicates_are_logged_on_their_own_timeline_and_summarised(tiny, tmp_path):
    res, _, _ = tiny
    R.write_recording(res, tmp_path / "recording.rrd", replicates=REPS)
    rrd = Rrd(tmp_path / "recording.rrd")
    for prot, metrics in REPS.items():
        for metric, labels in metrics.items():
            for lab, vals in labels.items():
                idx, got = rrd.scalars(f"/replicates/{prot}/{metric}/{lab}",
                                       timeline=R.REPLICATE_TIMELINE)
                want = [(i, v) for i, v in enumerate(vals) if v is not None and v == v]
                np.testing.assert_array_equal(idx, [i for i, _ in want])
                np.testing.assert_allclose(got, [v for _, v in want], rtol=1e-12)
    md = rrd.static_text("/replicates/summary")
    # one table per protocol and metric, numbers first (a long label cannot push them off the
    # panel): median, 5-95 % range (numpy's linear percentiles), finite / replicates, label
    assert "### `held_out`: `rmse_dph`" in md and "### `held_out`: `std_dps`" in md
    rows = {ln.split("|")[4].strip(): ln for ln in md.splitlines()
            if ln.startswith("| ") and ln.count("|") == 5}
    assert rows["kalman"].startswith("| 12.5 | 11.15 to 13.18 | 3/5 |")   # of 12.5, 11, 13.25
    assert rows["raw"].startswith("| 490.2 | 488.4 to 492.4 | 5/5 |")
    assert rows["wavelet_soft"].startswith("| 0.0205 |")
    # the representative replicate is still there in full
    it = res.scored[0]
    t, _ = rrd.scalars(f"/runs/{it.run}/fog/error/{it.protocol}/kalman")
    assert t.size == it.piece.t.size
    assert "Monte Carlo" in {x for c in _blueprint_props(rrd).values()
                             for x in c.get("ContainerBlueprint:display_name") or []}


def _tab_views(rrd, tab: str) -> list[dict]:
    """The views inside the blueprint's container named ``tab`` (read from the .rrd's
    blueprint store): their ViewBlueprint components."""
    props = _blueprint_props(rrd)
    (root,) = [p for p, c in props.items()
               if c.get("ContainerBlueprint:display_name") == [tab]]
    out, todo = [], [root]
    while todo:
        c = props[todo.pop(0)]
        for child in c.get("ContainerBlueprint:contents") or []:
            child = "/" + child
            if child.startswith("/view/"):
                out.append(props[child])
            else:
                todo.append(child)
    return out


def _static_points(rrd, path) -> np.ndarray:
    for c in rrd.chunks[path]:
        rb = c.to_record_batch()
        if c.is_static and "Points2D:positions" in rb.schema.names:
            return np.array(rb.column("Points2D:positions")[0].as_py(), dtype=float)
    raise AssertionError(f"{path}: no static Points2D")


def _static_labels(rrd, path) -> list[str]:
    for c in rrd.chunks[path]:
        rb = c.to_record_batch()
        if c.is_static and "Points2D:labels" in rb.schema.names:
            return rb.column("Points2D:labels")[0].as_py()
    raise AssertionError(f"{path}: no static Points2D labels")


REPS2 = {"held_out": {"rmse_dph": {"raw": [491.0, 489.5, 490.2], "kalman": [12.5, 11.0, 13.25]},
                      "std_dps": {"raw": [0.13, 0.12, 0.14], "kalman": [0.021, None, 0.025],
                                  "wavelet_soft": [0.05, 0.051, 0.049]},
                      "improvement_rmse_pct": {"kalman": [97.4, 97.7, 97.3]}}}


@pytest.mark.parametrize("claims,want", [
    ((), ["rmse_dph"]),                       # no claim: the report's key metric
    (("std_dps", "rmse_dph", "std_dps"), ["std_dps", "rmse_dph"]),   # the claims' metrics
])
def test_the_monte_carlo_tab_has_one_plot_per_headline_metric_with_every_replicate(
        tiny, tmp_path, claims, want):
    """One view per metric a claim is about (else the report's key metric), each a static
    2-D plot (it shows whatever timeline is selected: the tab does not open empty) whose dots
    are the replicates' values of every label, named in the plot."""
    import dataclasses

    from fogbench.scenario import Claim

    res, _, _ = tiny
    res = dataclasses.replace(res, plan=dataclasses.replace(res.plan, claims=tuple(
        Claim(text="t", source="s", metric=m, better="kalman", than="raw", min_pct=None,
              max_pct=None) for m in claims)))
    R.write_recording(res, tmp_path / "recording.rrd", replicates=REPS2)
    rrd = Rrd(tmp_path / "recording.rrd")
    views = _tab_views(rrd, "Monte Carlo")
    docs = [v for v in views if v["ViewBlueprint:class_identifier"] == ["TextDocument"]]
    plots = [v for v in views if v["ViewBlueprint:class_identifier"] != ["TextDocument"]]
    assert [d["ViewBlueprint:space_origin"] for d in docs] == [["/replicates/summary"]]
    assert [v["ViewBlueprint:class_identifier"] for v in plots] == [["2D"]] * len(want)
    origins = [v["ViewBlueprint:space_origin"][0] for v in plots]
    assert origins == [f"/report/replicates/{m}" for m in want]
    for origin, metric in zip(origins, want):
        labels = REPS2["held_out"][metric]
        # the row names, top to bottom
        names = _static_labels(rrd, f"{origin}/names")
        assert names == list(labels)
        for lab, vals in labels.items():
            assert all(c.is_static for c in rrd.chunks[f"{origin}/held_out/{lab}"])
            xy = _static_points(rrd, f"{origin}/held_out/{lab}")
            fin = np.array([v for v in vals if v is not None])
            # rmse spans 11..491 (a factor 45): log axis; std_dps 0.021..0.14: linear
            x = 10 ** xy[:, 0] if metric == "rmse_dph" else xy[:, 0]
            np.testing.assert_allclose(np.sort(x), np.sort(fin), rtol=1e-6)
            assert np.ptp(xy[:, 1]) == 0          # one row per label
        rows = [_static_points(rrd, f"{origin}/held_out/{lab}")[0, 1] for lab in labels]
        assert np.all(np.diff(rows) > 0), "rows not in the labels' order, top to bottom"


def test_one_monte_carlo_plot_per_metric_holds_a_column_per_protocol(tiny, tmp_path):
    """paper002 (4 protocols, one claimed metric) had 12 plots of about 110 px: now one, a
    column per protocol on the same x scale, side by side."""
    res, _, _ = tiny
    reps = {"held_out": {"rmse_dph": {"raw": [491.0, 489.5], "kalman": [12.5, 11.0]}},
            "refit": {"rmse_dph": {"raw": [490.0, 492.5], "kalman": [10.5, 9.0]}}}
    R.write_recording(res, tmp_path / "recording.rrd", replicates=reps)
    rrd = Rrd(tmp_path / "recording.rrd")
    plots = [v for v in _tab_views(rrd, "Monte Carlo")
             if v["ViewBlueprint:class_identifier"] == ["2D"]]
    assert [v["ViewBlueprint:space_origin"] for v in plots] == [["/report/replicates/rmse_dph"]]
    shift = {}
    for prot, metrics in reps.items():
        for lab, vals in metrics["rmse_dph"].items():
            xy = _static_points(rrd, f"/report/replicates/rmse_dph/{prot}/{lab}")
            np.testing.assert_allclose(np.sort(10 ** xy[:, 0]), np.sort(vals), rtol=1e-6)
        tf = _static_component(rrd, f"/report/replicates/rmse_dph/{prot}/kalman",
                               "Transform3D:translation")
        sc = _static_component(rrd, f"/report/replicates/rmse_dph/{prot}/kalman",
                               "Transform3D:scale")
        shift[prot] = (tf[0], sc[0])
    # the same x scale, the second column right of the first
    assert shift["held_out"][1] == shift["refit"][1]
    assert shift["refit"][0] > shift["held_out"][0]


def test_a_label_far_from_the_others_is_named_off_scale_and_the_axis_spans_the_rest(
        tiny, tmp_path):
    """paper000's oracle_filter (std 0 against 0.11..0.13 for the others) would squeeze the
    methods the claims compare into a corner: it is named with its median, without dots, and
    the axis spans the other labels' values."""
    res, _, _ = tiny
    close = {f"m{i}": [0.120 + 0.002 * i, 0.125 + 0.002 * i, 0.130 + 0.002 * i]
             for i in range(5)}
    reps = {"held_out": {"std_dps": {"raw": [0.13, 0.131, 0.132], "zero": [0.0, 0.0, 0.0],
                                     **close}}}
    R.write_recording(res, tmp_path / "recording.rrd", replicates=reps)
    rrd = Rrd(tmp_path / "recording.rrd")
    origin = "/report/replicates/std_dps"
    names = _static_labels(rrd, f"{origin}/names")
    assert names == ["raw", "zero", *close]
    with pytest.raises((AssertionError, KeyError)):
        _static_points(rrd, f"{origin}/held_out/zero")
    assert _static_labels(rrd, f"{origin}/held_out/zero/off_scale") == [
        "off scale: 0"]
    # the vertical grid lines (the x ticks, in data units) lie within the others' values
    ticks = [st[0][0] for st in rrd.static_strips(f"{origin}/held_out/axes/grid")
             if st[0][0] == st[1][0]]
    assert min(ticks) >= 0.115 and max(ticks) <= 0.142
    xs = np.concatenate([_static_points(rrd, f"{origin}/held_out/{lab}")[:, 0]
                         for lab in close])
    np.testing.assert_allclose(np.sort(xs), np.sort(np.concatenate(list(close.values()))))


def test_off_scale_notes_and_protocol_names_stay_in_their_own_column(tiny, tmp_path):
    """paper002 (two protocols and their ideal twins: four columns) ran the off-scale notes of
    one column into the next. Every note and every protocol name, at the estimated width of its
    characters (R.LEGEND_CHAR_W), lies within its column's box, and the boxes do not overlap."""
    res, _, _ = tiny
    close = {f"m{i}": [10.0 + i, 10.5 + i, 11.0 + i] for i in range(5)}
    prots = ["held_out", "held_out.ideal", "refit_every_run", "refit_every_run.ideal"]
    reps = {p: {"rmse_dph": {"raw": [123456.0, 123457.0, 123458.0], **close}} for p in prots}
    R.write_recording(res, tmp_path / "recording.rrd", replicates=reps)
    rrd = Rrd(tmp_path / "recording.rrd")
    origin = "/report/replicates/rmse_dph"
    half = 0.5 * recording_entities.LEGEND_CHAR_W
    boxes = []
    for p in prots:
        tx = _static_component(rrd, f"{origin}/{p}/axes", "Transform3D:translation")[0][0]
        sx = _static_component(rrd, f"{origin}/{p}/axes", "Transform3D:scale")[0][0]
        xs = [x for st in rrd.static_strips(f"{origin}/{p}/axes/grid") for x, _ in st]
        box = (tx + sx * min(xs), tx + sx * max(xs))
        boxes.append(box)
        (note,) = _static_labels(rrd, f"{origin}/{p}/raw/off_scale")
        assert note.startswith("off scale: ")
        x = tx + sx * _static_points(rrd, f"{origin}/{p}/raw/off_scale")[0, 0]
        assert box[0] - 1e-6 <= x - half * len(note) and x + half * len(note) <= box[1] + 1e-6
        labs = _static_labels(rrd, f"{origin}/{p}/axes/labels")
        pts = _static_points(rrd, f"{origin}/{p}/axes/labels")
        (k,) = [i for i, t in enumerate(labs) if t == p]
        x = tx + sx * pts[k, 0]
        assert box[0] - 1e-6 <= x - half * len(p) and x + half * len(p) <= box[1] + 1e-6
    assert all(a[1] < b[0] for a, b in zip(boxes, boxes[1:]))


@pytest.mark.parametrize("bad,where", [
    ([1, 2], "replicates: expected a dict"),
    ({"held_out": [1.0]}, "replicates['held_out']: expected a dict"),
    ({"held_out": {"rmse_dph": [1.0]}}, "replicates['held_out']['rmse_dph']: expected a dict"),
    ({"held_out": {"rmse_dph": {"raw": ["a", 1.0]}}}, "replicates['held_out']['rmse_dph']['raw']"),
    ({"held_out": {"rmse_dph": {"raw": [[1.0, 2.0]]}}}, "replicates['held_out']['rmse_dph']['raw']"),
])
def test_malformed_replicates_are_refused_naming_the_key_before_anything_is_written(
        tiny, tmp_path, bad, where):
    res, _, _ = tiny
    with pytest.raises(R.ReplicatesError) as exc:
        R.write_recording(res, tmp_path / "recording.rrd", replicates=bad)
    assert where in str(exc.value)
    assert not (tmp_path / "recording.rrd").exists()


def test_view_says_when_it_handed_the_file_to_a_viewer_already_running(tmp_path, monkeypatch,
                                                                     capsys):
    (tmp_path / "recording.rrd").write_bytes(b"x")
    monkeypatch.setattr(recording_viewer, "_viewer_command", lambda: ["/opt/fake/rerun"])
    monkeypatch.setattr(recording_viewer, "_has_display", lambda: True)

    class Handed(_FakeViewer):
        def wait(self, timeout=None):
            return 0                      # the rerun binary exits at once after handing over

    monkeypatch.setattr(recording_viewer.subprocess, "Popen", Handed)
    assert R.view(tmp_path) == 0
    out = capsys.readouterr().out
    assert "already running" in out and str(tmp_path / "recording.rrd") in out


def _overview_error_view(rrd, run: str):
    """(blueprint properties, the Overview's error view of ``run``, its contents query)."""
    props = _blueprint_props(rrd)
    (view,) = [p for p, c in props.items()
               if any(str(n).startswith("Error") and run in str(n)
                      for n in c.get("ViewBlueprint:display_name") or [])
               and not any("colours as in Overview" in str(n)
                           for n in c.get("ViewBlueprint:display_name") or [])]
    return props, view, " ".join(props[f"{view}/ViewContents"]["ViewContents:query"])


def test_the_overview_error_view_takes_out_raw_s_wander_and_zooms_to_the_methods(tiny):
    """paper000-like: low_grade's 0.16 deg/s Gauss-Markov drift is a wander every denoiser keeps.
    The Overview shows the errors with one curve taken out of all of them (so the paired
    differences between outputs, what the verdicts rest on, are those of the errors as they
    are), that curve is raw's slow variation (the shown raw error has far less slow variation
    than the raw error), and the view's y range holds the methods' shown errors but not raw's
    whole error."""
    res, _, rrd = tiny
    (it,) = res.scored
    root = f"/runs/{it.run}/fog"
    labs = list(it.outputs)
    err = {lab: rrd.scalars(f"{root}/error/{it.protocol}/{lab}")[1] for lab in labs}
    shown = {lab: rrd.scalars(f"{root}/error_shown/{it.protocol}/{lab}")[1] for lab in labs}
    out = {lab: err[lab] - shown[lab] for lab in labs}        # what was taken out of each
    scale = max(float(np.ptp(e)) for e in err.values())
    for lab in labs:
        np.testing.assert_allclose(out[lab], out["raw"], atol=1e-5 * scale, err_msg=lab)
    # raw's slow variation: a 1 s moving mean of raw's error varies far less once it is out
    k = int(it.piece.fs)

    def slow(y):
        return np.convolve(y, np.ones(k) / k, mode="valid")
    assert np.std(slow(shown["raw"])) < 0.3 * np.std(slow(err["raw"]))
    # the Overview's error view lists the shown series, and its y range holds the methods'
    props, view, query = _overview_error_view(rrd, it.run)
    assert f"error_shown/{it.protocol}/kalman" in query, query
    (rng,) = props[f"{view}/ScalarAxis"]["ScalarAxis:range"]
    lo, hi = rng.values() if isinstance(rng, dict) else rng
    methods = np.concatenate([shown[lab] for lab in labs if lab not in ("raw", "oracle")])
    assert lo <= methods.min() and methods.max() <= hi
    assert hi - lo < np.ptp(err["raw"])


def test_under_a_std_claim_the_overview_draws_each_error_less_its_mean(tmp_path):
    """As the PNG time series: where every claim on the run scores the std (paper000's
    test_m60), the Overview's shown errors are the errors less raw's wander and each less its
    own mean (the oracle, raw less the true terms, then lies on raw), and the view says so."""
    text = TINY.replace('name = "rec_tiny"', 'name = "rec_std"') + """
[[claims]]
text = "a std claim"
source = "test"
metric = "std_dps"
better = "wavelet_soft"
than = "kalman"
run = "test_run"
min_pct = 10.0
"""
    (tmp_path / "s.toml").write_text(text)
    res = run_scenario(tmp_path / "s.toml")
    R.write_recording(res, tmp_path / "recording.rrd")
    rrd = Rrd(tmp_path / "recording.rrd")
    (it,) = res.scored
    root = f"/runs/{it.run}/fog"
    err = {lab: rrd.scalars(f"{root}/error/{it.protocol}/{lab}")[1] for lab in it.outputs}
    shown = {lab: rrd.scalars(f"{root}/error_shown/{it.protocol}/{lab}")[1]
             for lab in it.outputs}
    assert len(shown["raw"]) == it.piece.t.size         # not decimated: the exact means
    for lab in it.outputs:
        assert abs(float(np.mean(shown[lab]))) < 1e-6 * float(np.ptp(err[lab])), lab
    # the oracle is raw less the true deterministic terms (here 25 deg/h on average): drawn
    # less their means, the two differ by those terms' variation alone
    gap = err["oracle"] - err["raw"]
    assert abs(float(np.mean(gap))) > 10.0
    np.testing.assert_allclose(shown["oracle"] - shown["raw"], gap - np.mean(gap), atol=1e-6)
    props, view, _ = _overview_error_view(rrd, it.run)
    name = " ".join(str(n) for n in props[view]["ViewBlueprint:display_name"])
    assert "less its mean" in name, name


@pytest.mark.parametrize("preset, taken_out", [("low_grade", True), ("navigation", False)])
def test_the_overview_error_view_draws_a_sweep_as_its_default_line_and_envelope(
        tmp_path, preset, taken_out):
    """A sweep of three wavelet levels (paper000's wavelet_band has 8 settings: 15 lines in
    its Overview): the Overview's error view holds the default setting's line and the sweep's
    envelope, not one line per member; the envelope is the pointwise best and worst of the
    members' shown errors, read back from the Errors tab's series with the same curve taken
    out (each member's error less the default's, plus the default's shown error). low_grade's
    wander is taken out of that view; navigation's errors are shown as they are."""
    text = TINY.replace('name = "rec_tiny"', 'name = "rec_swept"').replace(
        'preset = "low_grade"', f'preset = "{preset}"') + """
[[methods]]
name = "wavelet_soft"
label = "wband"
sweep = { level = [2, 3, 4] }
"""
    (tmp_path / "swept.toml").write_text(text)
    res = run_scenario(tmp_path / "swept.toml")
    R.write_recording(res, tmp_path / "recording.rrd")
    rrd = Rrd(tmp_path / "recording.rrd")
    (it,) = res.scored
    members = [lab for lab in it.outputs if lab.startswith("wband")]
    assert len(members) == 3, list(it.outputs)
    default = method_entries(list(it.outputs), res.plan)
    (sweep,) = [e for e in default if e["group"] == "wband"]
    def path(*parts):
        return recording_entities._p("runs", it.run, "fog", *parts)       # the labels escaped as entity paths

    err = {lab: rrd.scalars(path("error", it.protocol, lab))[1] for lab in members}
    d = sweep["default"]
    shown = "error_shown"                     # the view's series, taken out or as they are
    base = rrd.scalars(path(shown, it.protocol, d))[1] - err[d]  # what was taken out
    assert (float(np.ptp(base)) > 0) == taken_out
    want = np.vstack([err[m] + base for m in members])
    env = [path("error_shown", it.protocol, "wband envelope", end) for end in ("low", "high")]
    low, high = (rrd.scalars(x)[1] for x in env)
    scale = float(np.ptp(want))
    np.testing.assert_allclose(low, want.min(axis=0), atol=1e-5 * scale)
    np.testing.assert_allclose(high, want.max(axis=0), atol=1e-5 * scale)
    assert np.any(high - low > 1e-3 * scale)            # the members differ: a real envelope
    _, _, query = _overview_error_view(rrd, it.run)
    for m in members:
        assert (path(shown, it.protocol, m) in query) == (m == d), (m, query)
        assert path("error", it.protocol, m) not in query
    # the default's line is named as the default, as in the PNGs (the Errors tab keeps the
    # sweep's one name for every member)
    assert _static_names(rrd, path(shown, it.protocol, d)) == [
        f"wband default ({d[len('wband.'):]})"]
    assert env[0] in query and env[1] in query, query
    assert path(shown, it.protocol, "kalman") in query
    # the Allan view likewise: the default's curve, and the envelope of the members' Allan
    # deviations (allantools, drawn to 8 clusters as above); no other member's curve
    root = f"/report/allan/{it.protocol}/{it.run}"
    curves = []
    for m in members:
        taus, adev, _, _ = allantools.oadev((it.outputs[m] - it.piece.truth) / DPH,
                                            rate=it.piece.fs, data_type="freq", taus="octave")
        keep = [math.floor(it.piece.t.size / round(tau * it.piece.fs)) >= 8 for tau in taus]
        curves.append(adev[keep])
        assert (f"{root}/{recording_entities._p(m)[1:]}" in rrd.paths) == (m == d), m
    for end, want in (("low", np.min(curves, axis=0)), ("high", np.max(curves, axis=0))):
        xy = rrd.static_strips(f"{root}/{recording_entities._p(f'wband envelope {end}')[1:]}")[0]
        np.testing.assert_allclose(10 ** xy[:, 1], want, rtol=1e-5)
