"""Plug-in methods (fogcomp.get_method: entry points of the group fogcomp.methods and
module:Class names): a working plug-in runs beside the built-ins; one that does not import,
raises, hangs, exits, returns the wrong shape or non-finite values is reported as failed with
its reason and the run goes on, its outputs complete; names that are paths are refused."""

from __future__ import annotations

import json
import sys
import textwrap

import numpy as np
import pytest

import fogcomp
from fogcomp import _registry

from helpers import SMALL_SCENARIO, run_cli

FAILING = {
    "Raises": "planted failure in fit",
    "Hangs": "did not return within 1 s",
    "WrongShape": "estimated error has shape",
    "WrongOutput": "compensated output has shape",
    "NonFinite": "non-finite",
    "Exits": "SystemExit",
    "BadConstructor": "planted failure in __init__",
    "Broken": "does not import: ImportError: planted",
    "HardExits": "os._exit(0)",
    "RaisesInterrupt": "raised KeyboardInterrupt itself",
}


def _scenario(tmp_path, methods: list[str], extra: str = "") -> str:
    text = SMALL_SCENARIO.replace('[[methods]]\nname = "wavelet_soft"\n', "")
    text += "\n[compensation]\nfit_timeout_s = 1.0\n" + extra
    text += "".join(f'\n[[methods]]\nname = "{m}"\n' for m in ["wavelet_soft"] + methods)
    path = tmp_path / "s.toml"
    path.write_text(text)
    return path


def test_failing_plugins_are_reported_and_the_run_goes_on(tmp_path):
    names = ["plugin_methods:MeanBias"] + [f"plugin_methods:{c}" for c in FAILING
                                           if c != "Broken"] + ["plugin_broken:Broken"]
    s = _scenario(tmp_path, names)
    code, out, err = run_cli("run", s, "--out", tmp_path / "run", "--no-recording",
                             "--no-figures", "--quiet")
    assert code == 0, err
    doc = json.loads((tmp_path / "run" / "metrics.json").read_text())   # complete JSON
    report = (tmp_path / "run" / "report.md").read_text()
    prot = doc["protocols"][0] if isinstance(doc["protocols"], list) else \
        next(iter(doc["protocols"].values()))
    text = json.dumps(prot)
    for label, why in FAILING.items():
        assert "FAILED" in report and why in report, (label, why)
        assert why in text, (label, why)
    # the built-in and the working plug-in were scored
    for label in ("wavelet_soft", "MeanBias"):
        row = next(ln for ln in report.splitlines() if ln.startswith(f"| {label} |"))
        assert "FAILED" not in row, row
    assert "will be reported as failed" in err        # said before the work, on stderr


@pytest.mark.parametrize("name, msg", [
    ("../evil.py:Method", "never a file path"),
    ("/tmp/evil.py", "unknown method"),
    ("no_such_module_xyz:Method", "no module 'no_such_module_xyz' is installed"),
    ("plugin_methods:NoSuchClass", "has no 'NoSuchClass'"),
])
def test_a_plugin_name_that_is_a_path_or_unknown_is_refused_at_check(tmp_path, name, msg):
    s = _scenario(tmp_path, [name])
    code, _, err = run_cli("check", s)
    assert code == 2 and msg in err and "[[methods]]" in err, err


def test_a_plugin_that_is_no_method_is_named_with_the_reason():
    with pytest.raises(fogcomp.PluginError, match="not a subclass of fogcomp.Compensator"):
        fogcomp.get_method("json:JSONDecoder")
    with pytest.raises(fogcomp.PluginError, match="does not import: ImportError"):
        fogcomp.get_method("plugin_broken:Broken")


def test_bad_hyperparameters_of_a_plugin_are_refused_at_load(tmp_path):
    s = _scenario(tmp_path, [])
    s.write_text(s.read_text() + '\n[[methods]]\nname = "plugin_methods:MeanBias"\n'
                 '[methods.params]\nscale = "big"\n')
    code, _, err = run_cli("check", s)
    assert code == 2 and "scale: expected a number" in err, err


@pytest.fixture
def entry_points_dir(tmp_path, monkeypatch):
    """A directory on sys.path holding the metadata of an installed distribution whose entry
    points (group fogcomp.methods) name a working plug-in and a broken one, as pip writes it."""
    dist = tmp_path / "site" / "fake_fogcomp_plugin-0.1.dist-info"
    dist.mkdir(parents=True)
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: fake-fogcomp-plugin\n"
                                   "Version: 0.1\n")
    (dist / "entry_points.txt").write_text(textwrap.dedent("""\
        [fogcomp.methods]
        test_mean_bias = plugin_methods:MeanBias
        test_broken = plugin_broken:Broken
        test_misnamed = plugin_methods:Raises
        kalman = plugin_methods:MeanBias
        """))
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    monkeypatch.setattr(_registry, "_ENTRY_POINTS_READ", False)
    monkeypatch.setattr(_registry, "_REGISTRY", dict(_registry._REGISTRY))
    monkeypatch.setattr(_registry, "_PLUGIN_PROBLEMS", {})
    monkeypatch.setattr(_registry, "_SHADOW_SAID", set())
    return tmp_path


def test_entry_point_plugins_are_found_and_broken_ones_named(entry_points_dir):
    assert "test_mean_bias" in fogcomp.available_methods()
    problems = fogcomp.plugin_problems()
    assert "does not import" in problems["test_broken"]
    assert "'name' is 'test_raises'" in problems["test_misnamed"]
    with pytest.raises(fogcomp.PluginError, match="does not import"):
        fogcomp.get_method("test_broken")
    # a model of a plug-in saves under its entry-point name and loads back
    model = fogcomp.make_method("test_mean_bias")
    data = fogcomp.GyroData(rate=np.full(100, 1e-4), fs=10.0)
    model.fit(data, np.zeros(100))
    model.save(entry_points_dir / "m")
    again = fogcomp.load_model(entry_points_dir / "m")
    assert np.array_equal(again.compensate(data), model.compensate(data))


def test_a_module_class_model_saves_under_that_name_and_loads_back(tmp_path):
    model = fogcomp.make_method("plugin_methods:MeanBias")
    data = fogcomp.GyroData(rate=np.full(100, 2e-4), fs=10.0)
    model.fit(data, np.zeros(100))
    model.save(tmp_path / "m")
    assert json.loads((tmp_path / "m.json").read_text())["method"] == \
        "plugin_methods:MeanBias"
    assert np.array_equal(fogcomp.load_model(tmp_path / "m").compensate(data),
                          model.compensate(data))
    assert "plugin_methods" in sys.modules


def test_with_method_reaches_worker_processes_and_later_runs_do_not_inherit_it(tmp_path):
    """--with-method travels with each replicate to the workers (a forkserver started before
    the flag was given has another environment): every replicate scores the added method; a
    later run in the same process without the flag has no trace of it."""
    s = _scenario(tmp_path, [])
    code, _, err = run_cli("run", s, "--out", tmp_path / "a", "--no-recording",
                           "--no-figures", "--quiet", "--replicates", "3", "--jobs", "2",
                           "--with-method", "plugin_methods:MeanBias")
    assert code == 0, err
    mc = json.loads((tmp_path / "a" / "metrics.json").read_text())["montecarlo"]
    series = mc["series"]["p"]["rmse_dph"]["MeanBias"]
    assert len(series) == 3 and all(v is not None for v in series), series
    code, _, err = run_cli("run", s, "--out", tmp_path / "b", "--no-recording",
                           "--no-figures", "--quiet", "--replicates", "3", "--jobs", "2")
    assert code == 0, err
    mc = json.loads((tmp_path / "b" / "metrics.json").read_text())["montecarlo"]
    assert "MeanBias" not in json.dumps(mc)


def test_a_plug_in_named_as_a_built_in_is_named_and_the_built_in_runs(entry_points_dir,
                                                                      tmp_path):
    """An installed entry point ``kalman`` is not dropped without a word: asking for
    ``kalman`` warns, naming the entry point and how to run it, and gets the built-in; a
    scenario naming it says so on stderr as a fogbench warning."""
    with pytest.warns(_registry.PluginShadowWarning,
                      match=r"entry point 'kalman' \(plugin_methods:MeanBias\) has the name of "
                            r"a built-in.*module:Class"):
        cls = fogcomp.get_method("kalman")
    assert cls.__module__.startswith("fogcomp.")
    _registry._SHADOW_SAID.clear()
    s = _scenario(tmp_path, [])
    s.write_text(s.read_text() + '\n[[methods]]\nname = "kalman"\n')
    code, _, err = run_cli("check", s)
    assert code == 0
    assert "fogbench: warning:" in err and "entry point 'kalman'" in err


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_plugin_ending_the_process_or_raising_keyboard_interrupt_fails_only_itself(
        tmp_path, jobs):
    """os._exit(0) in a plug-in's fit, or a KeyboardInterrupt it raises itself, is that
    method's failure: the run goes on, ends 0 with every other method scored, and leaves no
    work folder (on one process and on two)."""
    s = _scenario(tmp_path, ["plugin_methods:HardExits", "plugin_methods:RaisesInterrupt"])
    code, _, err = run_cli("run", s, "--out", tmp_path / "run", "--no-recording",
                           "--no-figures", "--quiet", "--replicates", "2", "--jobs", jobs)
    assert code == 0, err
    report = (tmp_path / "run" / "report.md").read_text()
    assert "os._exit(0)" in report and "raised KeyboardInterrupt itself" in report
    row = next(ln for ln in report.splitlines() if ln.startswith("| wavelet_soft |"))
    assert "FAILED" not in row
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run", "s.toml"]
