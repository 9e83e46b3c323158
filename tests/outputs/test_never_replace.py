"""The never-replace rule at the moment of writing: a file that appears where a command will
write, or changes there, after the command checked the place and before it puts its outputs in
place, is left as it is and nothing is written; the command ends with the one error line."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from fogbench.outputs.folders import Outputs, OutDirError


def _own(path: Path) -> bool:
    return path.read_text().startswith("# mine")


def test_a_file_that_appears_before_the_commit_survives_and_nothing_is_written(tmp_path):
    out = Outputs(False, "device fit")
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    out.target(a, recognise=_own)
    out.target(b, recognise=_own)
    out.write_text(a, "# mine a\n")
    out.write_text(b, "# mine b\n")
    b.write_text("the user's own\n")            # saved while the command ran
    with pytest.raises(OutDirError, match="appeared or changed"):
        out.commit()
    out.discard()
    assert b.read_text() == "the user's own\n"
    assert not a.exists()                        # all or nothing
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.toml"]


def test_a_file_replaced_only_while_it_is_still_the_one_checked(tmp_path):
    p = tmp_path / "dev.toml"
    p.write_text("# mine, an earlier fit\n")
    out = Outputs(True, "device fit")
    out.target(p, recognise=_own)
    out.write_text(p, "# mine, the new fit\n")
    p.write_text("# mine, but edited by the user meanwhile\n")
    os.utime(p, ns=(1, 1))                       # a different modification time, for sure
    with pytest.raises(OutDirError, match="appeared or changed"):
        out.commit()
    out.discard()
    assert p.read_text() == "# mine, but edited by the user meanwhile\n"
    # and without interference the same replacement goes through
    out = Outputs(True, "device fit")
    out.target(p, recognise=_own)
    out.write_text(p, "# mine, the new fit\n")
    out.commit()
    assert p.read_text() == "# mine, the new fit\n"


def test_two_commands_into_one_output_the_second_is_refused(tmp_path):
    p = tmp_path / "dev.toml"
    first, second = Outputs(False, "device fit"), Outputs(False, "device fit")
    first.target(p, recognise=_own)
    second.target(p, recognise=_own)             # both checked while it was absent
    first.write_text(p, "# mine, the first\n")
    second.write_text(p, "# mine, the second\n")
    first.commit()
    with pytest.raises(OutDirError):
        second.commit()
    second.discard()
    assert p.read_text() == "# mine, the first\n"
    assert [q.name for q in tmp_path.iterdir()] == ["dev.toml"]


# ---------------------------------------------------------------------------------------------
# every writing command: a user's file appearing after the check, before the outputs are put in
# place, survives; the command fails with its one line and leaves no output of its own
import gzip  # noqa: E402

import numpy as np  # noqa: E402

from helpers import SMALL_SCENARIO, run_cli  # noqa: E402

USER = "the user's own file, saved while the command ran\n"


def _log(tmp_path):
    rng = np.random.default_rng(3)
    p = tmp_path / "log.csv"
    p.write_text("time_s,gyro_x_dps,gyro_y_dps,gyro_z_dps\n" + "".join(
        f"{i / 100:.2f},{a:.6e},{b:.6e},{c:.6e}\n"
        for i, (a, b, c) in enumerate(rng.standard_normal((20_000, 3)) * 1e-3)))
    return p


def _intrude(monkeypatch, paths):
    """Just before the outputs are put in place, the user saves a file at each of ``paths``
    (a file output) or into it (a folder output)."""
    from fogbench.outputs import folders

    real_commit, real_replace = folders.Outputs.commit, folders.replace_dir

    def commit(self):
        for _, p in self.pending:
            if p in paths or p.parent in paths:
                p.write_text(USER)
        return real_commit(self)

    def replace_dir(tmp, out, kind):
        if out in paths:
            out.mkdir(parents=True, exist_ok=True)
            (out / "mine.txt").write_text(USER)
        return real_replace(tmp, out, kind)

    monkeypatch.setattr(folders.Outputs, "commit", commit)
    monkeypatch.setattr(folders, "replace_dir", replace_dir)
    for mod in ("fogbench.run.simulate", "fogbench.report.rundir"):
        import importlib

        m = importlib.import_module(mod)
        if hasattr(m, "replace_dir"):
            monkeypatch.setattr(m, "replace_dir", replace_dir)


def _commands(tmp_path):
    log = _log(tmp_path)
    s = tmp_path / "s.toml"
    s.write_text(SMALL_SCENARIO)
    dev = tmp_path / "dev.toml"
    out = tmp_path / "out"
    return {
        "allan --out": (["allan", log, "--out", out], out / "allan.json"),
        "allan --kalibr": (["allan", log, "--kalibr", tmp_path / "imu.yaml"], tmp_path / "imu.yaml"),
        "calibrate": (["calibrate", "kalman", log, "--axis", "x", "--out", tmp_path / "m"],
                      tmp_path / "m.json"),
        "device fit": (["device", "fit", "--static", log, "--axis", "x", "--out", dev], dev),
        "device show --kalibr": (["device", "show", "tactical", "--kalibr",
                                  tmp_path / "dev.yaml", "--rate-hz", "100"],
                                 tmp_path / "dev.yaml"),
        "simulate": (["simulate", s, "--out", out, "--quiet"], out),
        "run": (["run", s, "--out", out, "--quiet", "--no-recording", "--no-figures"], out),
        "compensate": (["compensate", tmp_path / "m.json", log, "--out", tmp_path / "c.csv"],
                       tmp_path / "c.csv"),
        "device check --out": (["device", "check", dev, log, "--axis", "x", "--replicates",
                                "19", "--out", out], out / "device_check.json"),
        "compare": (["compare", tmp_path / "rep" / "s", "--out", out], out / "compare.md"),
        "suite": (["suite", "--scenarios", tmp_path / "scn", "--out", tmp_path / "rep",
                   "--quiet", "--no-recording", "--no-figures", "--jobs", "1"],
                  tmp_path / "rep" / "README.md"),
    }


def _prepare(tmp_path, name):
    """What a command reads, made beforehand (a model, a device file, a run folder)."""
    import json

    if name == "compensate":
        assert run_cli("calibrate", "kalman", tmp_path / "log.csv", "--axis", "x", "--out",
                       tmp_path / "m")[0] == 0
    if name == "device check --out":
        assert run_cli("device", "fit", "--static", tmp_path / "log.csv", "--axis", "x",
                       "--out", tmp_path / "dev.toml")[0] == 0
    if name == "compare":
        d = tmp_path / "rep" / "s"
        d.mkdir(parents=True)
        (d / "metrics.json").write_text(json.dumps({"scenario": "s", "protocols": {"p": {}},
                                                    "montecarlo": {"series": {"p": {
                                                        "improvement_rmse_pct": {
                                                            "raw": [0, 0], "a": [1.0, 2.0]}}}}}))
    if name == "suite":
        (tmp_path / "scn").mkdir()
        (tmp_path / "scn" / "s.toml").write_text(SMALL_SCENARIO)


@pytest.mark.parametrize("name", ["allan --out", "allan --kalibr", "calibrate", "device fit",
                                  "device show --kalibr", "simulate", "run", "compensate",
                                  "device check --out", "compare", "suite"])
def test_a_users_file_appearing_during_a_command_survives(tmp_path, monkeypatch, name):
    argv, target = _commands(tmp_path)[name]
    _prepare(tmp_path, name)
    _intrude(monkeypatch, {target})
    code, _, err = run_cli(*argv)
    assert code != 0, err
    assert "Traceback" not in err
    mine = target / "mine.txt" if target.is_dir() else target
    assert mine.read_text() == USER, name
    leftovers = [p for p in tmp_path.rglob(".*") if p.name.endswith((".tmp", ".part", ".old"))]
    assert leftovers == []
