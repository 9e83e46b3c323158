"""The example plug-in package (examples/fogcomp-ar) installed as a user would, with pip, into a
folder of its own (not this environment's site-packages, which a test must not change), found
through its entry point by a fogbench process whose path includes that folder: it passes
check_method and runs in a scenario beside a built-in."""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from helpers import SMALL_SCENARIO

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "examples" / "fogcomp-ar"
FOGBENCH = Path(sys.executable).with_name("fogbench")


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """The package installed from a copy: pip builds a local folder in place (``build/``,
    ``*.egg-info``), which wrote into the repository and, with two pytest-xdist workers each
    running this fixture, into the same folder at once."""
    source = tmp_path_factory.mktemp("src") / PACKAGE.name
    shutil.copytree(PACKAGE, source, ignore=shutil.ignore_patterns("build", "*.egg-info"))
    target = tmp_path_factory.mktemp("site")
    cmd = [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target",
           str(target), str(source)]
    if all(importlib.util.find_spec(m) is not None for m in ("setuptools", "wheel")):
        cmd.insert(4, "--no-build-isolation")   # the test extras' backend: no download needed
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert list(target.glob("fogcomp_ar-*.dist-info/entry_points.txt"))
    return target


def _fogbench(installed, *args, cwd):
    env = dict(os.environ, PYTHONPATH=str(installed))
    return subprocess.run([str(FOGBENCH), *map(str, args)], capture_output=True, text=True,
                          env=env, cwd=cwd, timeout=900)


def test_the_installed_plugin_keeps_the_contract(installed, tmp_path):
    done = _fogbench(installed, "check-method", "ar_kalman", cwd=tmp_path)
    assert done.returncode == 0 and "every rule holds" in done.stdout, done.stdout + done.stderr


def test_the_installed_plugin_runs_in_a_scenario_beside_a_builtin(installed, tmp_path):
    s = tmp_path / "s.toml"
    s.write_text(SMALL_SCENARIO)
    done = _fogbench(installed, "run", s, "--out", tmp_path / "run", "--no-recording",
                     "--no-figures", "--quiet", "--with-method", "ar_kalman", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    report = (tmp_path / "run" / "report.md").read_text()
    rows = [ln for ln in report.splitlines() if ln.startswith(("| ar_kalman |",
                                                               "| wavelet_soft |"))]
    assert len(rows) >= 2 and not any("FAILED" in r for r in rows), rows
    assert 'name = "ar_kalman"' in (tmp_path / "run" / "scenario.toml").read_text()
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert "ar_kalman" in json.dumps(metrics)
    # without the plug-in on the path the name is unknown, refused before any work
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    done = subprocess.run([str(FOGBENCH), "run", str(s), "--out", str(tmp_path / "run2"),
                           "--with-method", "ar_kalman"], capture_output=True, text=True,
                          env=env, cwd=tmp_path, timeout=300)
    assert done.returncode == 2 and "unknown method 'ar_kalman'" in done.stderr
    assert "installed in this environment" in done.stderr     # and how it is found
    assert not (tmp_path / "run2").exists()
