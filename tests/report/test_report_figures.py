"""The report's figures (fogbench/report/__init__.py): every curve stays visible, axes cover the range that
matters, multi-position tests show per-dwell means, legends name what is drawn.

Figures are drawn from small hand-made scored pieces; ``report._save`` is replaced by a function
that keeps the figure, so the tests read the matplotlib artists themselves.
"""

from __future__ import annotations

import itertools
import math
from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.container import ErrorbarContainer

from fogcomp.units import DPH, DPS
from fogbench import report as R
from fogbench.report import coefficients as report_coefficients
from fogbench.report import spectra as report_spectra
from fogbench.report import style as report_style
from fogbench.report import thermal as report_thermal
from fogbench.report import timeseries as report_timeseries
from fogbench.run.runner import Piece, Scored
from fogbench.run.runner import TERM_NAMES
from fogbench.outputs import files


@pytest.fixture
def figs(monkeypatch):
    """Figures passed to ``_save``, kept open instead of written."""
    kept = []
    monkeypatch.setattr(files, "save_figure", lambda fig, path: kept.append(fig))
    yield kept
    import matplotlib.pyplot as plt

    for f in kept:
        plt.close(f)


def _piece(t, truth, raw, oracle, fs):
    n = t.size
    return Piece(run="r1", fs=fs, t=t, raw=raw, truth=truth, g=np.zeros((n, 3)),
                 temp=np.full(n, 20.0), temp_rate=np.zeros(n), oracle=oracle)


def _static_item(n=4096, fs=10.0, seed=0):
    """A static piece in which raw and oracle are almost the same signal and two methods give
    identical outputs (as flnn_lstsq and model_lstsq do), plus a smoother whose output is
    numerically constant."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    truth = np.full(n, 10.0 * DPH)
    noise = rng.standard_normal(n) * 5.0 * DPH
    oracle = truth + noise
    raw = oracle + 0.2 * DPH                       # a constant bias: same Allan curve and PSD
    fit = truth + 0.5 * noise
    smooth = truth + 1e-13 * DPH * np.sin(2 * np.pi * 0.01 * t)   # numerically zero PSD
    outs = {"raw": raw, "oracle": oracle, "flnn_lstsq": fit, "model_lstsq": fit.copy(),
            "wavelet_soft": smooth}
    return Scored(protocol="p", run="r1", piece=_piece(t, truth, raw, oracle, fs), outputs=outs)


def _lines_by_label(fig):
    out = {}
    for ax in fig.axes:
        for ln in ax.get_lines():
            lab = ln.get_label()
            if not lab.startswith("_"):
                out.setdefault(ax, {})[lab.split(" (")[0]] = ln
    return out


def _legend_texts(fig) -> set[str]:
    texts = set()
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is not None:
            texts |= {t.get_text() for t in leg.get_texts()}
    for leg in fig.legends:
        texts |= {t.get_text() for t in leg.get_texts()}
    return texts


def _plotted_labels(fig) -> set[str]:
    labels = set()
    for ax in fig.axes:
        for a in list(ax.get_lines()) + list(ax.patches) + list(ax.containers) + \
                list(ax.collections):
            lab = a.get_label() if hasattr(a, "get_label") else None
            if lab and not lab.startswith("_"):
                labels.add(lab)
    return labels


def _style(ln):
    return (str(ln.get_color()), round(ln.get_linewidth(), 3), str(ln.get_linestyle()),
            str(ln.get_marker()))


@pytest.mark.parametrize("kind", ["allan", "psd", "timeseries"])
def test_raw_is_above_oracle_and_every_curve_has_its_own_style(figs, tmp_path, kind):
    it = _static_item()
    if kind == "allan":
        assert report_spectra.fig_allan(it, tmp_path / "a.png")
    elif kind == "psd":
        report_spectra.fig_psd(it, tmp_path / "p.png")
    else:
        # a continuous static record (no gaps): the time-series figure, not the dwell one
        report_timeseries.fig_timeseries(it, tmp_path / "t.png")
    fig = figs[-1]
    by_ax = _lines_by_label(fig)
    err_ax = fig.axes[-1] if kind == "timeseries" else fig.axes[0]
    lines = by_ax[err_ax]
    assert {"raw", "oracle", "flnn_lstsq", "model_lstsq"} <= set(lines)
    assert lines["raw"].get_zorder() > lines["oracle"].get_zorder()
    styles = [_style(ln) for ln in lines.values()]
    assert len(set(styles)) == len(styles), styles
    # where two curves coincide, the upper one must be narrower so that the lower one shows
    ordered = sorted(lines.values(), key=lambda ln: ln.get_zorder())
    for lower, upper in zip(ordered, ordered[1:]):
        assert upper.get_zorder() > lower.get_zorder()
        assert upper.get_linewidth() < lower.get_linewidth(), (lower.get_label(),
                                                                upper.get_label())


def test_psd_axis_stays_within_the_range_that_matters(figs, tmp_path):
    it = _static_item()
    report_spectra.fig_psd(it, tmp_path / "p.png")
    ax = figs[-1].axes[0]
    lo, hi = ax.get_ylim()
    assert math.log10(hi / lo) <= report_spectra.PSD_MAX_DECADES + 1e-9
    # the raw and oracle curves (white noise, 5 deg/h per sample at 10 Hz) are inside the axis
    lines = _lines_by_label(figs[-1])[ax]
    for lab in ("raw", "oracle", "flnn_lstsq"):
        y = lines[lab].get_ydata()
        y = y[np.isfinite(y)]
        assert lo <= y.min() and y.max() <= hi, lab
    # the expected white level of the error, independent of the code: 2 sigma^2 / fs
    # (one-sided), in (deg/h)^2/Hz as in the recording
    level = 2 * 5.0 ** 2 / 10.0
    assert lo < level / 10 and hi > level * 2
    # the smoother's numerically-zero spectrum does not stretch the axis, and the legend says so
    assert lo > 1e-20
    assert any("below the axis" in t for t in _legend_texts(figs[-1]))


def _dwell_twin(t, y, fs):
    """Slow obvious twin: walk the samples, start a new dwell at every time jump."""
    groups, cur = [], [0]
    for i in range(1, len(t)):
        if t[i] - t[i - 1] > 1.5 / fs:
            groups.append(cur)
            cur = []
        cur.append(i)
    groups.append(cur)
    means, sems, mids = [], [], []
    for g in groups:
        vals = [y[i] for i in g]
        m = sum(vals) / len(vals)
        var = sum((v - m) ** 2 for v in vals) / (len(vals) - 1)
        means.append(m)
        sems.append(math.sqrt(var) / math.sqrt(len(vals)))
        mids.append((t[g[0]] + t[g[-1]]) / 2)
    return np.array(mids), np.array(means), np.array(sems)


def _dwell_item(seed=1):
    fs = 10.0
    rng = np.random.default_rng(seed)
    t_parts, truth_parts = [], []
    start = 0.0
    levels = [12.0, -5.0, 7.5, 0.3, -11.0]          # deg/h, a multi-position test's Earth rate
    for k, lev in enumerate(levels):
        n = 150 + 10 * k
        t_parts.append(start + np.arange(n) / fs)
        truth_parts.append(np.full(n, lev * DPH))
        start = t_parts[-1][-1] + 12.0                 # 12 s of moving between dwells, left out
    t = np.concatenate(t_parts)
    truth = np.concatenate(truth_parts)
    oracle = truth + rng.standard_normal(t.size) * 3.0 * DPH
    raw = oracle + (4.0 + 0.5 * np.sign(truth)) * DPH
    fit = oracle + 0.1 * DPH
    it = Scored(protocol="recal", run="r1", piece=_piece(t, truth, raw, oracle, fs),
                outputs={"raw": raw, "oracle": oracle, "flnn": fit})
    return it, fs


def test_dwell_means_equal_a_slow_twin():
    it, fs = _dwell_item()
    for y in it.outputs.values():
        mid, mean, sem = R.dwell_means(it.piece.t, y, fs)
        tm, tmean, tsem = _dwell_twin(list(it.piece.t), list(y), fs)
        assert mean.size == 5
        np.testing.assert_allclose(mid, tm, rtol=0, atol=1e-9)
        np.testing.assert_allclose(mean, tmean, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(sem, tsem, rtol=1e-10)


def test_multi_position_pieces_are_plotted_as_dwell_means_in_deg_per_h(figs, tmp_path):
    it, fs = _dwell_item()
    report_timeseries.fig_timeseries(it, tmp_path / "t.png")
    fig = figs[-1]
    assert all("deg/h" in ax.get_ylabel() for ax in fig.axes)
    # below the positions: raw and oracle's dwell-mean errors, then the methods' zoomed to them
    conts = [(ax, c) for ax in fig.axes[1:] for c in ax.containers
             if isinstance(c, ErrorbarContainer)]
    assert {c.get_label() for _, c in conts} == {"raw", "oracle", "flnn"}
    assert {c.get_label() for c in fig.axes[1].containers} == {"raw", "oracle"}
    for ax, c in conts:
        lab = c.get_label()
        _, tmean, tsem = _dwell_twin(list(it.piece.t), list(it.outputs[lab] - it.piece.truth),
                                     fs)
        data_line = c.lines[0]
        np.testing.assert_allclose(data_line.get_ydata(), tmean / DPH, rtol=1e-9)
        # error bar half-lengths are the standard errors, deg/h
        segs = c.lines[2][0].get_segments()
        half = np.array([abs(s[1][1] - s[0][1]) / 2 for s in segs])
        np.testing.assert_allclose(half, tsem / DPH, rtol=1e-9)
        if lab == "flnn":
            # zoomed to the methods, their error bars whole (switch_on_repeatability's were
            # cut): raw's 4 deg/h offset is off this panel's scale
            lo, hi = ax.get_ylim()
            assert lo <= (tmean - tsem).min() / DPH and (tmean + tsem).max() / DPH <= hi
            assert hi < 4.0
    # no line joins one dwell to the next: nothing in the figure is a per-sample trace
    for ax in fig.axes:
        for ln in ax.get_lines():
            assert len(ln.get_xdata()) <= 5
    assert _plotted_labels(fig) <= _legend_texts(fig)


def test_many_dwells_are_joined_lines_without_bars(figs, tmp_path, monkeypatch):
    """thermal_with_motion drew 133 dwells x 6 outputs of error bars; above DWELL_BARS_MAX
    dwells each output's dwell means are one line (its values the means, by the slow twin).
    Their noisy means tangled in the methods' panel: there each method is drawn less the
    oracle's dwell means, the deterministic error it leaves (here the 0.1 deg/h the fit leaves
    over the oracle, noise-free), the oracle a zero line."""
    it, fs = _dwell_item()
    monkeypatch.setattr(report_timeseries, "DWELL_BARS_MAX", 3)         # 5 dwells: more than 3
    report_timeseries.fig_timeseries(it, tmp_path / "t.png")
    fig = figs[-1]
    assert not any(isinstance(c, ErrorbarContainer) for ax in fig.axes for c in ax.containers)
    for lab in ("raw", "oracle"):
        _, tmean, _ = _dwell_twin(list(it.piece.t), list(it.outputs[lab] - it.piece.truth), fs)
        lines = [ln for ax in fig.axes[1:] for ln in ax.get_lines() if ln.get_label() == lab]
        assert lines
        for ln in lines:
            np.testing.assert_allclose(ln.get_ydata(), tmean / DPH, rtol=1e-9)
    (ln,) = [ln for ax in fig.axes[2:] for ln in ax.get_lines() if ln.get_label() == "flnn"]
    np.testing.assert_allclose(ln.get_ydata(), 0.1, rtol=1e-6)
    assert "oracle" in ln.axes.get_ylabel()
    assert any(x.get_label().startswith("oracle (0") for x in ln.axes.get_lines())


def test_members_of_one_family_differ_in_marker_in_the_dwell_figure(figs, tmp_path):
    """paper004's flnn_recorded and flnn_shuffled (one family: two greens 30 % apart) were the
    same dot: each member of a family has its own marker; raw and oracle keep theirs."""
    from types import SimpleNamespace

    it, _ = _dwell_item()
    it.outputs["flnn_b"] = it.outputs["flnn"] + 0.2 * DPH
    plan = SimpleNamespace(methods=tuple(
        SimpleNamespace(label=lab, name="flnn", group=None, paper_setting=False, setting={},
                        params={}) for lab in ("flnn", "flnn_b")))
    report_timeseries.fig_timeseries(it, tmp_path / "t.png", plan)
    marker = {c.get_label(): c.lines[0].get_marker() for ax in figs[-1].axes[1:]
              for c in ax.containers if isinstance(c, ErrorbarContainer)}
    assert marker["raw"] == "D" and marker["oracle"] == "s"
    assert marker["flnn"] != marker["flnn_b"], marker


def _thermal_res():
    from sim.thermal import ThermalHold, ThermalProgram, ThermalRamp, TempSensor, ThermalModel, \
        simulate_thermal

    fs = 1.0
    t = np.arange(0.0, 4000.0, 1.0 / fs)
    prog = ThermalProgram(start=20.0, steps=(ThermalHold(600.0), ThermalRamp(40.0, 1.0 / 60.0),
                                             ThermalHold(1000.0)))
    th = simulate_thermal(prog, t, ThermalModel(housing_time_constant=200.0,
                                                coil_time_constant=300.0,
                                                sensor=TempSensor("housing", 30.0, 0.02,
                                                                  0.0625)))
    rng = np.random.default_rng(3)
    raw = (rng.standard_normal(t.size) * 0.01 + 0.02 * th.coil_rate)[:, None] * DPH
    rd = SimpleNamespace(run=SimpleNamespace(thermal=prog, name="r1"), fs=fs, n=t.size,
                         truth=SimpleNamespace(t=t), thermal=th,
                         fog=SimpleNamespace(raw=raw), truth_axis=lambda j: np.zeros(t.size))
    return SimpleNamespace(data={"r1": rd}, scenario=SimpleNamespace(axes=("z",)),
                           plan=SimpleNamespace(axis="z", paper=(), protocols=()))


def test_every_curve_of_the_thermal_figure_is_in_its_legend(figs, tmp_path):
    res = _thermal_res()
    assert report_thermal.fig_thermal(res, "r1", tmp_path / "th.png")
    fig = figs[-1]
    plotted = _plotted_labels(fig)
    assert any("dT/dt" in lab for lab in plotted)
    assert {"chamber", "housing", "sensor reading"} <= plotted
    assert plotted <= _legend_texts(fig), plotted - _legend_texts(fig)


def _loop_res(shupe_dph_per_c_per_s: float):
    """A heat-up and cool-down at 1 deg C/min with fast lags (5 s) and a bias of 0.02 deg/h
    per deg C plus ``shupe`` times the coil's dT/dt (deg C/s)."""
    from sim.thermal import (
        TempSensor,
        ThermalHold,
        ThermalModel,
        ThermalProgram,
        ThermalRamp,
        simulate_thermal,
    )

    fs = 1.0
    t = np.arange(0.0, 5400.0, 1.0 / fs)
    prog = ThermalProgram(start=20.0, steps=(ThermalHold(300.0), ThermalRamp(40.0, 1.0 / 60.0),
                                             ThermalHold(900.0), ThermalRamp(20.0, 1.0 / 60.0),
                                             ThermalHold(1800.0)))
    th = simulate_thermal(prog, t, ThermalModel(housing_time_constant=5.0,
                                                coil_time_constant=5.0,
                                                sensor=TempSensor("coil")))
    raw = (0.02 * (th.coil - 20.0) + shupe_dph_per_c_per_s * th.coil_rate)[:, None] * DPH
    rd = SimpleNamespace(run=SimpleNamespace(thermal=prog, name="r1"), fs=fs, n=t.size,
                         truth=SimpleNamespace(t=t), thermal=th,
                         fog=SimpleNamespace(raw=raw), truth_axis=lambda j: np.zeros(t.size))
    return SimpleNamespace(data={"r1": rd}, scenario=SimpleNamespace(axes=("z",)),
                           plan=SimpleNamespace(axis="z", paper=(), protocols=()))


@pytest.mark.parametrize("shupe", [0.0, 30.0])
def test_the_thermal_loop_opens_by_twice_the_shupe_term(figs, tmp_path, shupe):
    """thermal.png's bias-against-temperature panel: at 30 deg C, mid-ramp, the heating and the
    cooling branch sit apart by 2 c r (a bias c dT/dt, ramps of +-r = 1/60 deg C/s), analytic;
    with no term in dT/dt they coincide (no loop drawn where the physics has none)."""
    assert report_thermal.fig_thermal(_loop_res(shupe), "r1", tmp_path / "th.png")
    by = {ln.get_gid(): ln for ax in figs[-1].axes for ln in ax.get_lines()
          if str(ln.get_gid()).startswith("loop:")}
    assert {"loop:heating", "loop:cooling", "loop:steady"} <= set(by)

    def at_30(name):
        x, y = by[name].get_xdata(), by[name].get_ydata()
        order = np.argsort(x)
        return float(np.interp(30.0, x[order], y[order]))

    gap = at_30("loop:heating") - at_30("loop:cooling")
    assert gap == pytest.approx(2.0 * shupe / 60.0, abs=0.01 * max(shupe / 60.0, 1.0)), gap
    # the 100 s points of the bias against time and of the loop are the same numbers
    ax_time = next(ax for ax in figs[-1].axes if ax.get_xlabel().startswith("time"))
    heat = by["loop:heating"].get_ydata()
    assert np.all(np.isin(heat, ax_time.get_lines()[0].get_ydata()))


def test_every_curve_of_allan_and_psd_is_in_the_legend(figs, tmp_path):
    it = _static_item()
    report_spectra.fig_allan(it, tmp_path / "a.png")
    report_spectra.fig_psd(it, tmp_path / "p.png")
    for fig in figs:
        assert _plotted_labels(fig) <= _legend_texts(fig)


def _coef_res():
    names = TERM_NAMES
    true = {n: float(v) for n, v in zip(names, [7.8, 7.1, 4.8, -5.4, 1.3, 0.6, -0.5, 0.27,
                                               -0.22, 0.14])}
    err = {n: 0.05 for n in names}
    err["d8"], err["d9"] = -7300.0, -9000.0         # unidentified: arbitrary minimum-norm values
    m = {"coef_true_dph": true, "coef_errors_dph": err,
         "coef_identified": [n for n in names if n not in ("d8", "d9")]}
    metrics = {"protocols": {"held_out": {"runs": {"test": {"flnn_lstsq_g_only": m}}}}}
    prot = SimpleNamespace(name="held_out", per_run=False,
                           fit=(SimpleNamespace(run="fit"),))
    return SimpleNamespace(metrics=metrics, plan=SimpleNamespace(protocols=(prot,)))


def test_unidentified_coefficients_are_hatched_clipped_and_labelled(figs, tmp_path):
    """Three panels, one per unit (deg/h, deg/h/g, deg/h/g^2: on one axis the g^2 terms were
    flat bars beside the 7.8 deg/h bias), each scaled to its own true values and identified
    estimates; the unidentified d8, d9 (-7300, -9000 deg/h/g^2) hatched, clipped, labelled."""
    res = _coef_res()
    assert report_coefficients.fig_coefficients(res, "held_out", tmp_path / "c.png")
    fig = figs[-1]
    d0, dg, dg2 = fig.axes[:3]
    assert [t.get_text() for t in dg2.get_xticklabels()] == [f"d{i}" for i in range(4, 10)]
    assert "deg/h/g^2" in dg2.get_ylabel() and "deg/h/g" in dg.get_ylabel()
    assert d0.get_ylim()[1] >= 7.8 and dg.get_ylim()[1] >= 7.1
    lo, hi = dg2.get_ylim()
    assert hi - lo < 5.0                # the g^2 panel on the g^2 terms' scale (|1.3| max)
    assert hi >= 1.3 + 0.05
    hatched = [p for p in dg2.patches if p.get_hatch() and np.isfinite(p.get_height())]
    assert len(hatched) == 2
    texts = [t.get_text() for t in dg2.texts]
    assert texts.count(report_style.NOT_IDENTIFIED) == 2
    assert any(report_style.NOT_IDENTIFIED in t for t in _legend_texts(fig))
    title = fig._suptitle.get_text()
    assert "fit" in title and "test" in title and "first power-on" not in title
    assert _plotted_labels(fig) <= _legend_texts(fig)


def test_raw_segment_bias_stability_equals_a_slow_twin_of_paper002_eq5():
    """Paper 002 eq. 5 by hand: the sample standard deviation of the 100 s means of each
    thermal segment (incomplete last block dropped)."""
    from fogbench.run.runner import thermal_segments

    res = _thermal_res()
    rd = res.data["r1"]
    got = R.raw_segment_stability(rd, 0)
    segs = thermal_segments(rd)
    assert [g[0] for g in got] == [s[0] for s in segs] == ["hold 20 C", "ramp 20..40 C",
                                                            "hold 40 C"]
    x = list(rd.fog.raw[:, 0])
    for (name, v), (_, a, b) in zip(got, segs):
        i0, i1 = int(round(a * rd.fs)), int(round(b * rd.fs))
        k = int(round(100.0 * rd.fs))
        means = []
        i = i0
        while i + k <= i1:
            means.append(sum(x[i:i + k]) / k)
            i += k
        m = sum(means) / len(means)
        twin = math.sqrt(sum((f - m) ** 2 for f in means) / (len(means) - 1)) / DPH
        assert v == pytest.approx(twin, rel=1e-9), name


SIM_SCENARIO = """
[scenario]
name = "io_tiny"
description = "fogbench simulate output: saturation flags and the temperature sensor"
sample_rate_hz = 20.0

[table]
latitude_deg = 45.0

[fog]
preset = "low_grade"
axes = ["z"]
range_dps = 100.0
temp_sensor_location = "housing"
temp_sensor_time_constant_s = 2.0
temp_sensor_noise_c = 0.05
temp_sensor_resolution_c = 0.0625
housing_time_constant_s = 3.0

[thermal]
start_c = 20.0
[[thermal.steps]]
ramp_to_c = 23.0
rate_c_per_min = 30.0

[[runs]]
name = "spin"
seed = 5
[[runs.motion]]
type = "rate"
rate_dps = 60.0
duration_s = 4.0
[[runs.motion]]
type = "rate"
rate_dps = 150.0
duration_s = 4.0
"""


def test_simulate_writes_saturation_flags_and_the_sensor_columns(tmp_path):
    """`fogbench simulate`: ``saturated`` (n, a) bool is set exactly where the true rate is
    beyond the 100 deg/s range; the sensor reading is quantised to its 0.0625 C step and lags
    the true coil; the documented columns are all there."""
    from helpers import read_run
    from helpers import run_cli

    scn = tmp_path / "io_tiny.toml"
    scn.write_text(SIM_SCENARIO)
    out = tmp_path / "sim"
    assert run_cli("simulate", str(scn), "--out", str(out), "--quiet")[0] == 0
    a = read_run(out / "spin.npz")
    n = a["t_s"].size
    for key in ("chamber_c", "coil_c", "housing_c", "coil_rate_c_per_s", "sensor_c",
                "sensor_rate_c_per_s"):
        assert a[key].shape == (n,), key
    assert a["saturated"].shape == (n, 1) and a["saturated"].dtype == bool
    beyond = np.abs(a["truth_rate_rps"][:, 2]) > 100.0 * DPS
    # the spin goes from 60 to 150 deg/s: some samples are beyond the range, some within
    assert beyond.any() and (~beyond).any()
    # flagged exactly where the true rate is clearly beyond (a margin for the noise)
    clear = np.abs(np.abs(a["truth_rate_rps"][:, 2]) - 100.0 * DPS) > 5.0 * DPS
    np.testing.assert_array_equal(a["saturated"][clear, 0], beyond[clear])
    assert np.all(np.abs(a["raw_rps"][a["saturated"][:, 0], 0]) <= 100.0 * DPS * (1 + 1e-12))
    steps = a["sensor_c"] / 0.0625
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)
    assert not np.array_equal(a["sensor_c"], a["coil_c"])


@pytest.mark.parametrize("n", [300, 1500, 40000])
def test_log_axis_tick_labels_never_collide_and_at_least_two_show(figs, tmp_path, n):
    """paper002's PSD spans 1.5 decades of frequency: matplotlib labelled its minor ticks and
    printed 3x10^-4 into 4x10^-4. Drawn, the tick labels of every log axis of the PSD and Allan
    figures keep apart (their rendered boxes do not overlap) and each axis keeps two labels."""
    it = _static_item(n=n)
    report_spectra.fig_psd(it, tmp_path / "p.png")
    report_spectra.fig_allan(it, tmp_path / "a.png")
    for fig in figs:
        fig.canvas.draw()
        rend = fig.canvas.get_renderer()
        for ax in fig.axes:
            for axis in (ax.xaxis, ax.yaxis):
                lo, hi = axis.get_view_interval()
                boxes = [lab.get_window_extent(rend) for lab in axis.get_ticklabels(which="both")
                         if lab.get_visible() and lab.get_text()
                         and lo * (1 - 1e-9) <= lab.get_position()[axis is ax.yaxis]
                         <= hi * (1 + 1e-9)]
                if axis is ax.xaxis and not ax.xaxis.get_tick_params()["labelbottom"]:
                    continue        # a shared x axis: labels on the bottom panel only
                assert len(boxes) >= 2, (fig.axes.index(ax), axis.axis_name, lo, hi)
                boxes.sort(key=lambda b: (b.x0, b.y0))
                for a, b in itertools.pairwise(boxes):
                    assert not a.overlaps(b), (axis.axis_name, a, b)


def test_a_smoother_far_below_raw_does_not_squeeze_the_allan_axis(figs, tmp_path):
    """static_allan's wavelet_soft ran to 2e-6 deg/h, squeezing raw into the top two of seven
    decades: the axis stops ALLAN_DECADES_BELOW_RAW decades below raw's and the oracle's
    lowest, and the curve below says it falls below the axis; one that stays above leaves the
    axis alone."""
    it = _static_item(n=4096)
    e = it.outputs["raw"] - it.piece.truth
    it.outputs["wavelet_soft"] = it.piece.truth + 1e-5 * (e - e.mean())   # 5 decades down
    report_spectra.fig_allan(it, tmp_path / "a.png")
    ax = figs[-1].axes[0]
    raw = next(ln for ln in ax.get_lines() if ln.get_label() == "raw")
    low = np.nanmin(raw.get_ydata())
    assert ax.get_ylim()[0] == pytest.approx(low * 10.0 ** -report_spectra.ALLAN_DECADES_BELOW_RAW, rel=1e-9)
    assert any(ln.get_label() == "wavelet_soft (falls below the axis)" for ln in ax.get_lines())
    figs.clear()
    it.outputs["wavelet_soft"] = it.piece.truth + 0.1 * (e - e.mean())    # one decade down
    report_spectra.fig_allan(it, tmp_path / "a.png")
    ax = figs[-1].axes[0]
    assert ax.get_ylim()[0] < 0.1 * low
    assert not any("falls below" in ln.get_label() for ln in ax.get_lines())


def test_the_thermal_loop_draws_the_true_thermal_term_beside_the_raw_points(figs, tmp_path):
    """thermal_with_motion's raw bias carries g terms by position that scatter the loop: the
    simulation's thermal term is drawn beside it, shifted by the mean of the rest. With the
    rest a 1 deg/h constant, the line goes through every raw point."""
    res = _loop_res(30.0)
    rd = res.data["r1"]
    thermal = rd.fog.raw.copy()
    rd.fog.raw = thermal + 1.0 * DPH
    rd.fog.terms = {"temperature": thermal}
    assert report_thermal.fig_thermal(res, "r1", tmp_path / "th.png")
    lines = {ln.get_gid(): ln for ax in figs[-1].axes for ln in ax.get_lines()}
    line = lines["loop:true_term"]
    pts = np.concatenate([lines[f"loop:{k}"].get_ydata() for k in ("heating", "cooling",
                                                                    "steady")])
    np.testing.assert_allclose(np.sort(line.get_ydata()), np.sort(pts), atol=1e-9)
    assert "rest's mean (1 deg/h)" in line.get_label()
