"""The Rerun recording of a run (fogbench/recording.py), read back with rerun's own .rrd reader.

rerun-sdk 0.41 reads a file with ``rerun.chunk.RrdReader(path)``: ``recordings()`` /
``blueprints()`` list the stores, ``stream()`` yields the chunks of the first recording, and each
``Chunk`` gives its ``entity_path``, ``is_static`` and ``to_record_batch()`` (pyarrow; the index
column is named after the timeline, the data columns ``Archetype:field``, e.g. ``Scalars:scalars``).
"""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pyarrow as pa
import pytest
from rerun.chunk import RrdReader

import fogcomp
from fogcomp.base import Compensator, register
from fogcomp.units import DPH, DPS
from fogbench import recording as R
from fogbench.runner import run_scenario

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
    assert {"Overview", "Rate table (3-D)", "Rate: truth, raw, compensated (deg/s)",
            "Error vs truth (deg/h)", "Temperature (deg C)", "Allan / PSD"} <= names
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
            tau, adev = rrd.scalars(f"/report/allan/{it.protocol}/{it.run}/{lab}",
                                    timeline=R.TAU_TIMELINE)
            assert tau.size >= 3 and np.all(np.isfinite(adev))
            # the shortest tau is one sample interval: log10(1/fs) on the log10_tau_s timeline
            assert tau[0] == ns(math.log10(1.0 / p.fs))


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
    assert_f32_equal(g, rd.truth.gravity[::k] * R.GRAVITY_ARROW_M_PER_G, "gravity arrow")
    # tilted 30 deg about x: gravity has a y component in the sensor frame
    assert abs(g[0, 1] / R.GRAVITY_ARROW_M_PER_G - 0.5) < 1e-6


def test_static_report_documents(tiny):
    res, _, rrd = tiny
    assert res.scenario.text.strip() in rrd.static_text("/report/scenario")
    md = rrd.static_text("/report/metrics")
    for word in ("held_out", "test_run", "wavelet_soft", "kalman", "oracle", "rmse_dph",
                 "decimation"):
        assert word in md


def test_long_runs_are_decimated_as_documented(tiny, tmp_path, monkeypatch):
    res, _, _ = tiny
    monkeypatch.setattr(R, "MAX_SERIES_POINTS", 250)
    monkeypatch.setattr(R, "MAX_POSE_POINTS", 100)
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
    monkeypatch.setattr(R, "_viewer_command", lambda: None)
    monkeypatch.setattr(R.subprocess, "Popen", _no_popen)
    assert R.view(tmp_path) == 1
    err = capsys.readouterr().err
    assert f"rerun {tmp_path / 'recording.rrd'}" in err and "pip install rerun-sdk" in err


def test_view_without_a_display_says_how_to_open_the_file(tmp_path, capsys, monkeypatch):
    (tmp_path / "recording.rrd").write_bytes(b"x")
    monkeypatch.setattr(R, "_viewer_command", lambda: ["/opt/fake/rerun"])
    monkeypatch.setattr(R, "_has_display", lambda: False)
    monkeypatch.setattr(R.subprocess, "Popen", _no_popen)
    assert R.view(tmp_path) == 1
    assert f"rerun {tmp_path / 'recording.rrd'}" in capsys.readouterr().err


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
    monkeypatch.setattr(R, "_viewer_command", lambda: ["/opt/fake/rerun"])
    monkeypatch.setattr(R, "_has_display", lambda: True)
    monkeypatch.setattr(R.subprocess, "Popen", _FakeViewer)
    _FakeViewer.calls = []
    assert R.view(tmp_path) == 0
    assert _FakeViewer.calls == [["/opt/fake/rerun", str(tmp_path / "recording.rrd")]]


def test_the_viewer_found_is_the_one_of_the_installed_rerun_sdk():
    cmd = R._viewer_command()
    assert cmd is not None and cmd[0].endswith("rerun")
