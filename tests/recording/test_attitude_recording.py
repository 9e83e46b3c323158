"""The attitude recording (issue 42): the integrated attitude drawn beside the truth, its error
magnified by the stated factor, the errors in degrees unmagnified; and the bench's --rrd
refusals. Checked against rotations built here (scipy), not the writer's own arithmetic."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fogbench.bench.attitude import main as bench_attitude
from fogbench.recording.attitude import magnification, write_attitude_recording

from test_recording import Rrd  # noqa: E402 (the reader of recordings beside it)


def test_the_bodies_and_errors_read_back(tmp_path):
    t = np.arange(101) * 0.1
    truth = Rotation.from_euler("z", np.radians(3.0 * t)[:, None])             # a slow turn
    err_deg = 0.01 * t                                                 # about x, 0..0.1 deg
    est = truth * Rotation.from_euler("x", np.radians(err_deg)[:, None])
    path = tmp_path / "att.rrd"
    mag = write_attitude_recording(path, t, truth, {"raw": est})
    assert mag == 100.0                           # 0.1 deg shown as at most 15 deg
    rrd = Rrd(path)
    assert {"/attitude/truth", "/attitude/raw", "/attitude/error/raw"} <= rrd.paths
    _, q_true = rrd.column("/attitude/truth", "Transform3D:quaternion", "time")
    _, q_shown = rrd.column("/attitude/raw", "Transform3D:quaternion", "time")
    want = truth * Rotation.from_euler("x", np.radians(100.0 * err_deg)[:, None])
    assert np.allclose(Rotation.from_quat(q_true).as_quat(canonical=True),
                       truth.as_quat(canonical=True), atol=1e-6)
    ang = (Rotation.from_quat(q_shown).inv() * want).magnitude()
    assert np.max(ang) < 1e-6
    _, e = rrd.scalars("/attitude/error/raw", "time")
    assert np.allclose(e, err_deg, atol=1e-9)
    assert "magnified 100 times" in rrd.static_text("/attitude/README")


def test_magnification_is_a_power_of_ten_and_never_shrinks():
    assert magnification(0.1) == 100.0
    assert magnification(2.0) == 1.0
    assert magnification(40.0) == 1.0
    assert magnification(0.0) == 1.0


@pytest.mark.parametrize("name,content,why", [
    ("notes.txt", b"mine", "must end in .rrd"),
    ("old.rrd", b"not a recording", "not a Rerun recording"),
])
def test_rrd_refused_before_any_work_and_the_file_kept(tmp_path, capsys, name, content, why):
    p = tmp_path / name
    p.write_bytes(content)
    with pytest.raises(SystemExit) as e:
        bench_attitude(["--triad", "--replicates", "1", "--rrd", str(p)])
    assert e.value.code == 2
    assert why in capsys.readouterr().err
    assert p.read_bytes() == content


def test_rrd_needs_triad(tmp_path):
    with pytest.raises(SystemExit):
        bench_attitude(["--rrd", str(tmp_path / "a.rrd")])


def test_an_existing_recording_is_replaced_only_with_overwrite(tmp_path, capsys):
    p = tmp_path / "old.rrd"
    t = np.arange(3) * 0.1
    r = Rotation.identity(3)
    write_attitude_recording(p, t, r, {"raw": r})
    before = p.read_bytes()
    with pytest.raises(SystemExit) as e:
        bench_attitude(["--triad", "--replicates", "1", "--rrd", str(p)])
    assert e.value.code == 2 and "--overwrite" in capsys.readouterr().err
    assert p.read_bytes() == before
