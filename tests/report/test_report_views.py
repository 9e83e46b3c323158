"""Views that show the effect: the PNG time series, PSD and Allan figures of
fogbench/report/__init__.py draw a sweep as an envelope (its default marked), at most 8 lines a panel with
legends outside the data, the methods' errors zoomed to them with raw in a panel of its own when
it dwarfs them, what every output keeps alike taken out; Allan and PSD figures are left out (not
written, not linked) for pieces made of separate static dwells; thermal.png shows a scored run.

Every expected value is recomputed here from the inputs with plain Python loops or scipy, not by
calling the report's own helpers.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from fogbench import report as R
from fogbench.report import coefficients as report_coefficients
from fogbench.report import montecarlo as report_montecarlo
from fogbench.report import spectra as report_spectra
from fogbench.report import style as report_style
from fogbench.report import thermal as report_thermal
from fogbench.report import timeseries as report_timeseries
from fogbench.run.runner import Piece, Scored
from fogbench.run.runner import TERM_NAMES
from fogbench.outputs import files
from fogcomp.units import DPH


@pytest.fixture
def figs(monkeypatch):
    kept = []
    monkeypatch.setattr(files, "save_figure", lambda fig, path: kept.append(fig))
    yield kept
    import matplotlib.pyplot as plt

    for f in kept:
        plt.close(f)


def _spec(label, name, group=None, paper=False):
    return SimpleNamespace(label=label, name=name, group=group, paper_setting=paper,
                           setting={}, params={})


SWEEP = [f"band.level-{lv}" for lv in (3, 4, 5, 6)]
DEFAULT = "band.level-6"


def _plan(extra=()):
    methods = [_spec("kalman", "kalman"), _spec("wnn", "wnn")]
    methods += [_spec(lab, "wavelet_soft", group="band", paper=(lab == DEFAULT)) for lab in SWEEP]
    methods += list(extra)
    return SimpleNamespace(methods=tuple(methods))


def _item(outs: dict, truth, fs):
    n = truth.size
    t = np.arange(n) / fs
    piece = Piece(run="r1", fs=fs, t=t, raw=outs["raw"], truth=truth, g=np.zeros((n, 3)),
                  temp=np.full(n, 20.0), temp_rate=np.zeros(n), oracle=outs["oracle"])
    return Scored(protocol="p", run="r1", piece=piece, outputs=outs)


def _dwarfed_item(n=1500, fs=10.0, seed=0):
    """raw (and oracle) with a 2000 deg/h ramp and 30 deg/h noise; the methods remove the ramp
    and leave errors of a few deg/h with noises of their own: nothing kept alike."""
    rng = np.random.default_rng(seed)
    truth = np.full(n, 0.01)                         # rad/s, a constant rate
    ramp = np.linspace(-1000.0, 1000.0, n) * DPH
    raw = truth + ramp + rng.standard_normal(n) * 30.0 * DPH
    outs = {"raw": raw, "oracle": raw - 0.5 * ramp}
    for i, lab in enumerate(["kalman", "wnn"] + SWEEP):
        outs[lab] = truth + (1.0 + 0.3 * i) * rng.standard_normal(n) * DPH + (0.2 * i) * DPH
    return _item(outs, truth, fs)


DPS_ = math.pi / 180.0      # rad/s per deg/s


def _envelope(ax, group):
    got = [c for c in ax.collections if c.get_gid() == f"envelope:{group}"]
    assert len(got) == 1
    v = got[0].get_paths()[0].vertices
    lo, hi = {}, {}
    for x, y in v:
        k = round(float(x), 9)
        lo[k] = min(lo.get(k, math.inf), y)
        hi[k] = max(hi.get(k, -math.inf), y)
    xs = sorted(lo)
    return np.array(xs), np.array([lo[x] for x in xs]), np.array([hi[x] for x in xs])


def test_a_sweep_is_drawn_as_the_envelope_of_its_members_with_its_default_marked(figs, tmp_path):
    it = _dwarfed_item()
    plan = _plan()
    report_timeseries.fig_timeseries(it, tmp_path / "t.png", plan=plan)
    fig = figs[-1]
    axes = [ax for ax in fig.axes
            if any(c.get_gid() == "envelope:band" for c in ax.collections)]
    assert len(axes) == 1
    ax = axes[0]
    xs, lo, hi = _envelope(ax, "band")
    # by hand: at every sample, the best and the worst member's error, deg/h
    p = it.piece
    want_lo, want_hi = [], []
    for i in range(p.t.size):
        vals = [(it.outputs[m][i] - p.truth[i]) / DPH for m in SWEEP]
        want_lo.append(min(vals))
        want_hi.append(max(vals))
    np.testing.assert_allclose(xs, p.t, atol=1e-9)
    np.testing.assert_allclose(lo, want_lo, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(hi, want_hi, rtol=1e-12, atol=1e-12)
    # one line per sweep, the default's, named as such; no member has a line of its own
    labels = [ln.get_label() for a in fig.axes for ln in a.get_lines()]
    assert not any(lab in SWEEP for lab in labels)
    default = [ln for a in fig.axes for ln in a.get_lines()
               if ln.get_label().startswith("band default")]
    assert len(default) == 1 and "level-6" in default[0].get_label()
    np.testing.assert_allclose(default[0].get_ydata(),
                               (it.outputs[DEFAULT] - p.truth) / DPH, rtol=1e-12)


def test_the_psd_envelope_is_the_members_welch_spectra(figs, tmp_path):
    from scipy.signal import welch

    it = _dwarfed_item()
    report_spectra.fig_psd(it, tmp_path / "p.png", plan=_plan())
    ax = next(a for a in figs[-1].axes if any(c.get_gid() == "envelope:band"
                                              for c in a.collections))
    xs, lo, hi = _envelope(ax, "band")
    p = it.piece
    spectra = []
    for m in SWEEP:
        # scipy's Welch (Hann, half-overlapping segments of the largest power of two not above
        # n / 4.5 samples: 8 segments), its ordinates between DC and Nyquist averaged by hand in
        # 10 bands a decade from the lowest
        e = (it.outputs[m] - p.truth) / DPH
        nper = 2 ** int(math.floor(math.log2(e.size / 4.5)))
        f, s = welch(e - e.mean(), fs=p.fs, window="hann", nperseg=nper, noverlap=nper // 2)
        f, s = f[1:-1], s[1:-1]
        fb, sb = [], []
        for j in range(60):
            sel = (f >= f[0] * 10 ** (j / 10) * (1 - 1e-9)) & \
                (f < f[0] * 10 ** ((j + 1) / 10) * (1 - 1e-9))
            if sel.any():
                fb.append(f[sel].mean())
                sb.append(s[sel].mean())
        spectra.append(sb)
    np.testing.assert_allclose(xs, fb, rtol=1e-9)
    np.testing.assert_allclose(lo, np.min(spectra, axis=0), rtol=1e-9)
    np.testing.assert_allclose(hi, np.max(spectra, axis=0), rtol=1e-9)


@pytest.mark.parametrize("kind", ["timeseries", "psd", "allan"])
def test_no_panel_has_more_than_eight_lines_and_legends_stay_outside_the_data(figs, tmp_path,
                                                                              kind):
    # 12 methods of their own families besides the sweep: more than one panel is needed
    extra = [_spec(f"m{i}", f"plugin{i}") for i in range(12)]
    plan = _plan(extra)
    it = _dwarfed_item()
    rng = np.random.default_rng(5)
    for s in extra:
        it.outputs[s.label] = it.piece.truth + rng.standard_normal(it.piece.t.size) * 3.0 * DPH
    fn = {"timeseries": report_timeseries.fig_timeseries, "psd": report_spectra.fig_psd, "allan": report_spectra.fig_allan}[kind]
    fn(it, tmp_path / "f.png", plan=plan)
    fig = figs[-1]
    fig.canvas.draw()
    drawn = set()
    for ax in fig.axes:
        assert len(ax.get_lines()) <= 8, (kind, [ln.get_label() for ln in ax.get_lines()])
        drawn |= {ln.get_label().split(" (falls below")[0] for ln in ax.get_lines()}
        leg = ax.get_legend()
        if leg is not None:
            assert leg.get_window_extent().x0 >= ax.get_window_extent().x1 - 1e-6
    # nothing is lost: every method that is not a sweep member, and the sweep's default
    want = {"kalman", "wnn"} | {s.label for s in extra}
    assert want <= drawn
    assert any(lab.startswith("band default") for lab in drawn)


def test_the_zoom_holds_every_method_and_raw_gets_its_own_panel_when_it_dwarfs_them(figs,
                                                                                     tmp_path):
    it = _dwarfed_item()
    report_timeseries.fig_timeseries(it, tmp_path / "t.png", plan=_plan())
    fig = figs[-1]
    p = it.piece
    method_axes = [ax for ax in fig.axes
                   if any(ln.get_label() == "kalman" for ln in ax.get_lines())]
    assert method_axes
    raw_err = (it.outputs["raw"] - p.truth) / DPH
    for ax in method_axes:
        lo, hi = ax.get_ylim()
        for m in ["kalman", "wnn"] + SWEEP:
            e = (it.outputs[m] - p.truth) / DPH
            assert lo <= e.min() and e.max() <= hi, m
        # raw (+-1000 deg/h) is not on this axis: neither its line nor its range
        assert raw_err.min() < lo and raw_err.max() > hi
        assert "raw" not in [ln.get_label() for ln in ax.get_lines()]
        assert hi - lo < 0.2 * (raw_err.max() - raw_err.min())
    # raw's error, as it is, in a panel of its own
    raw_lines = [ln for ax in fig.axes if ax not in method_axes for ln in ax.get_lines()
                 if ln.get_label() == "raw" and "error" in ax.get_ylabel()]
    assert len(raw_lines) == 1
    np.testing.assert_allclose(raw_lines[0].get_ydata(), raw_err, rtol=1e-12)


def _slow_moving_mean(y, k):
    h = k // 2
    out = []
    for i in range(len(y)):
        a, b = max(0, i - h), min(len(y), i + h + 1)
        out.append(sum(y[a:b]) / (b - a))
    return np.array(out)


def test_a_wander_no_denoiser_removes_is_taken_out_of_every_curve(figs, tmp_path):
    """Denoisers under a +-500 deg/h wander: every method keeps raw's slow error, so the
    methods' panels show each error minus raw's moving mean over 1/50 of the piece."""
    n, fs = 2000, 100.0
    rng = np.random.default_rng(2)
    truth = np.full(n, -60.0 * DPS_)
    wander = 500.0 * np.sin(2 * np.pi * np.arange(n) / n * 3.0) * DPH
    raw = truth + wander + rng.standard_normal(n) * 200.0 * DPH
    outs = {"raw": raw, "oracle": raw.copy()}
    for i, lab in enumerate(["kalman", "wnn"] + SWEEP):
        outs[lab] = truth + wander + rng.standard_normal(n) * (20.0 + 5 * i) * DPH
    it = _item(outs, truth, fs)
    report_timeseries.fig_timeseries(it, tmp_path / "t.png", plan=_plan())
    fig = figs[-1]
    k = round(n / 50)
    trend = _slow_moving_mean(list((raw - truth) / DPH), k) - np.mean((raw - truth) / DPH)
    ln = next(ln for ax in fig.axes for ln in ax.get_lines() if ln.get_label() == "kalman")
    np.testing.assert_allclose(ln.get_ydata(), (outs["kalman"] - truth) / DPH - trend,
                               rtol=1e-9, atol=1e-9)
    assert "trend" in ln.axes.get_ylabel()
    # the wander is gone from the methods' panel: it spans their noise, not the 1000 deg/h
    lo, hi = ln.axes.get_ylim()
    assert hi - lo < 500.0


def _claim(metric, run=None):
    return SimpleNamespace(metric=metric, run=run, better="wnn", than="kalman", text="",
                           source="", min_pct=50.0, max_pct=None)


def test_which_runs_are_scored_by_a_metric_blind_to_the_mean():
    from fogbench.report.views import mean_blind

    plan = SimpleNamespace(claims=(_claim("std_dps", "r1"), _claim("rmse_dph", "r2")))
    assert mean_blind(plan, "r1") and not mean_blind(plan, "r2")
    assert not mean_blind(plan, "r3")                    # no claim scored on it
    both = SimpleNamespace(claims=(_claim("std_dps"), _claim("rmse_dph", "r1")))
    assert not mean_blind(both, "r1") and mean_blind(both, "r2")
    assert not mean_blind(None, "r1") and not mean_blind(SimpleNamespace(claims=()), "r1")


def test_under_a_std_claim_every_curve_is_drawn_less_its_own_mean(figs, tmp_path):
    """paper000's test_m60, scored by the output's std under a wander: the true deterministic
    terms (-300 deg/h here) offset part of raw's error, so the oracle (raw less them) drew
    300 deg/h above raw. With each curve less its own mean, the oracle lies on raw (a constant
    removed) and is named so; the methods' curves are their errors less raw's trend and their
    own means (a slow twin of both)."""
    n, fs = 2000, 100.0
    rng = np.random.default_rng(4)
    truth = np.full(n, -60.0 * DPS_)
    wander = (200.0 + 500.0 * np.sin(2 * np.pi * np.arange(n) / n * 3.0)) * DPH
    raw = truth + wander - 300.0 * DPH + rng.standard_normal(n) * 50.0 * DPH
    outs = {"raw": raw, "oracle": raw + 300.0 * DPH}
    for i, lab in enumerate(["kalman", "wnn"]):
        outs[lab] = truth + wander + (40.0 * i) * DPH + rng.standard_normal(n) * 30.0 * DPH
    plan = SimpleNamespace(methods=_plan().methods, claims=(_claim("std_dps"),))
    report_timeseries.fig_timeseries(_item(outs, truth, fs), tmp_path / "t.png", plan=plan)
    fig = figs[-1]
    k = round(n / 50)
    e_raw = list((raw - truth) / DPH)
    trend = _slow_moving_mean(e_raw, k) - sum(e_raw) / n
    for lab in ("kalman", "wnn", "raw"):
        ln = [ln for ax in fig.axes for ln in ax.get_lines() if ln.get_label() == lab][-1]
        want = (outs[lab] - truth) / DPH - trend
        np.testing.assert_allclose(ln.get_ydata(), want - sum(want) / n, atol=1e-7)
    oracle = [ln for ax in fig.axes for ln in ax.get_lines()
              if ln.get_label().startswith("oracle")]
    assert "oracle (on raw here)" in {ln.get_label() for ln in oracle}
    title = " ".join(ax.get_title() for ax in fig.axes)
    assert "less its own mean" in title and "std" in title
    # without the std claim (rmse: the mean counts), the means stay
    figs.clear()
    plan = SimpleNamespace(methods=_plan().methods, claims=(_claim("rmse_dph"),))
    report_timeseries.fig_timeseries(_item(outs, truth, fs), tmp_path / "t.png", plan=plan)
    ln = [ln for ax in figs[-1].axes for ln in ax.get_lines() if ln.get_label() == "wnn"][-1]
    assert float(np.mean(ln.get_ydata())) == pytest.approx(200.0 + 40.0, abs=5.0)


def test_a_bias_the_methods_remove_under_the_trend_stays_visible(figs, tmp_path):
    """lab_references: the methods remove a 2 deg/h bias but keep raw's slow variation; taking
    raw's whole trend out drew them at -2 deg/h under a caption saying no method removes it.
    Only raw's variation about its mean is taken out: the methods sit near 0, raw near +2. They
    keep raw's fast noise too, so each curve is drawn as its moving mean (less raw's trend):
    near constants (bias_lab's 2 deg/h lay under +-10 deg/h of noise when only the trend was
    taken out)."""
    n, fs = 2000, 100.0
    rng = np.random.default_rng(5)
    truth = np.zeros(n)
    wander = 30.0 * np.sin(2 * np.pi * np.arange(n) / n * 2.0) * DPH
    raw = truth + 2.0 * DPH + wander + rng.standard_normal(n) * 0.5 * DPH
    outs = {"raw": raw, "oracle": raw - 2.0 * DPH}
    for i, lab in enumerate(["kalman", "wnn"]):
        outs[lab] = raw - 2.0 * DPH + rng.standard_normal(n) * 0.05 * DPH
    report_timeseries.fig_timeseries(_item(outs, truth, fs), tmp_path / "t.png", plan=_plan())
    fig = figs[-1]
    for lab in ("kalman", "wnn"):
        ln = next(ln for ax in fig.axes for ln in ax.get_lines() if ln.get_label() == lab)
        assert abs(float(np.mean(ln.get_ydata()))) < 0.2, lab     # its own level: ~0
        assert float(np.std(ln.get_ydata())) < 0.2, lab           # a near constant
    title = " ".join(ax.get_title() for ax in fig.axes)
    assert "moving means less raw's slow variation" in title, title


def test_methods_that_do_not_differ_keep_raw_and_oracle_on_their_axis(figs, tmp_path):
    """lab_references' bias_lab: three fits book the same bias, so the methods' zoom spanned
    nothing and raw (2 deg/h above) and the oracle were left off it as dwarfing them: one flat
    line, no comparison. Methods within the unit's minimum span (0.01 deg/h) of each other are
    no zoom: raw, the oracle and the methods share the panel, raw 2 deg/h above them."""
    n, fs = 2000, 10.0
    rng = np.random.default_rng(6)
    truth = np.zeros(n)
    noise = rng.standard_normal(n) * 5.0 * DPH
    raw = truth + 2.3 * DPH + noise
    outs = {"raw": raw, "oracle": truth + noise, "kalman": raw - 2.0 * DPH,
            "wnn": raw - 2.0 * DPH}
    report_timeseries.fig_timeseries(_item(outs, truth, fs), tmp_path / "t.png", plan=_plan())
    ax = figs[-1].axes[-1]
    mean = {ln.get_label(): float(np.mean(ln.get_ydata())) for ln in ax.get_lines()}
    assert {"raw", "oracle", "kalman", "wnn"} <= set(mean), mean
    assert mean["raw"] - mean["kalman"] == pytest.approx(2.0, abs=0.05)
    assert mean["kalman"] - mean["oracle"] == pytest.approx(0.3, abs=0.05)


def test_a_fast_noise_no_drift_model_removes_is_averaged_out(figs, tmp_path):
    """Thermal drift models under white noise: every method keeps raw's fast noise, so the
    methods' panels draw each error's moving mean over 1/50 of the piece."""
    n, fs = 3000, 1.0
    rng = np.random.default_rng(4)
    truth = np.zeros(n)
    drift = np.linspace(0.0, 3.0, n) * DPH
    noise = rng.standard_normal(n) * 2.0 * DPH
    raw = truth + drift + noise
    outs = {"raw": raw, "oracle": truth + noise}
    for i, lab in enumerate(["kalman", "wnn"] + SWEEP):
        outs[lab] = truth + noise + 0.05 * (i + 1) * np.sin(np.arange(n) / 300.0) * DPH
    it = _item(outs, truth, fs)
    report_timeseries.fig_timeseries(it, tmp_path / "t.png", plan=_plan())
    k = round(n / 50)
    ln = next(ln for ax in figs[-1].axes for ln in ax.get_lines() if ln.get_label() == "wnn")
    np.testing.assert_allclose(ln.get_ydata(),
                               _slow_moving_mean(list((outs["wnn"] - truth) / DPH), k),
                               rtol=1e-9, atol=1e-12)
    assert f"{k}-sample mean" in ln.axes.get_ylabel()


TINY_POSITIONS = """
[scenario]
name = "tiny_positions"
sample_rate_hz = 10.0

[fog]
preset = "tactical"
axes = ["z"]

[[runs]]
name = "a"
seed = 1
[[runs.motion]]
type = "positions"
tilts_deg = [0.0, 90.0, 180.0]
headings_deg = [0.0]
move_s = 10.0
dwell_s = 20.0

[[runs]]
name = "b"
seed = 2
[[runs.motion]]
type = "positions"
tilts_deg = [0.0, 90.0, 180.0]
headings_deg = [0.0]
move_s = 10.0
dwell_s = 20.0

[[runs]]
name = "c"
seed = 3
[[runs.motion]]
type = "hold"
duration_s = 40.0

[[protocols]]
name = "p"
fit = [{ run = "a", static_only = true }]
score = [{ run = "b", static_only = true }, "c"]

[[methods]]
name = "wavelet_soft"
"""


def test_allan_and_psd_of_stitched_dwells_are_neither_written_nor_linked(tmp_path):
    from fogbench.run.runner import run_scenario

    path = tmp_path / "tiny.toml"
    path.write_text(TINY_POSITIONS)
    res = run_scenario(path)
    pieces = {it.run: it.piece for it in res.scored}
    # by hand: b's static samples jump over the moves between positions, c is contiguous
    assert max(np.diff(pieces["b"].t)) > 1.5 / pieces["b"].fs
    assert max(np.diff(pieces["c"].t)) < 1.5 / pieces["c"].fs
    out = R.write_run_dir(res, tmp_path / "out", recording=False, save_data=False)
    figs_dir = out / "figures"
    report = (out / "report.md").read_text()
    for kind in ("psd", "allan"):
        assert not (figs_dir / f"p__b__{kind}.png").exists()
        assert f"p__b__{kind}.png" not in report
        # the rule is not "no Allan/PSD at all": the contiguous piece has both
        assert (figs_dir / f"p__c__{kind}.png").exists()
        assert f"figures/p__c__{kind}.png" in report
    assert (figs_dir / "p__b__timeseries.png").exists()
    assert "No Allan deviation or PSD figure of b" in report


def test_outputs_that_are_raw_plus_a_constant_get_raw_s_allan_and_psd_alone(tmp_path, figs):
    """A bias fit (model_lstsq, terms bias) scored on a hold: every output is raw less a
    constant (the oracle too: no thermal program, a static table), so an Allan deviation or a
    PSD would draw them all on raw's curve (lab_references' bias_lab drew five identical
    curves): both show raw alone (its noise), the report says why. A denoiser on the same hold
    keeps every curve (the stitched-dwells test above)."""
    from types import SimpleNamespace

    from fogbench.run.runner import run_scenario
    from fogbench.report.views import offsets_only

    path = tmp_path / "tiny.toml"
    path.write_text(TINY_POSITIONS.replace('name = "wavelet_soft"',
                                           'name = "model_lstsq"\nparams = { terms = ["bias"] }'))
    res = run_scenario(path)
    (c,) = [it for it in res.scored if it.run == "c" and it.protocol == "p"]
    d = {lab: out - c.outputs["raw"] for lab, out in c.outputs.items()}
    assert all(np.ptp(v) < 1e-9 * np.ptp(c.outputs["raw"]) for v in d.values()), d  # by hand
    R.write_run_dir(res, tmp_path / "out", recording=False, save_data=False)
    report = (tmp_path / "out" / "report.md").read_text()
    assert "The Allan deviation and PSD of c are raw's alone: every output differs from raw " \
        "by a constant" in report
    spectra = []
    for fig in figs:      # piece c of protocol p's PSD and Allan figures: "p / c: PSD ..."
        title = " ".join(ax.get_title() for ax in fig.axes)
        if title.startswith("p / c: ") and ("PSD" in title or "Allan" in title):
            spectra.append({ln.get_label() for ax in fig.axes for ln in ax.get_lines()
                            if not ln.get_label().startswith("_")})
    assert len(spectra) == 2, spectra
    for labs in spectra:
        assert "raw" in labs and "oracle" not in labs and "model_lstsq" not in labs, labs
    # the rule itself: a constant apart is offsets only, a ramp of 1 % of the span is not
    rng = np.random.default_rng(0)
    truth = np.zeros(1000)
    raw = rng.normal(0, 1, 1000)
    piece = SimpleNamespace(truth=truth)
    assert offsets_only(SimpleNamespace(piece=piece, outputs={"raw": raw, "m": raw - 3.0}))
    ramp = 0.01 * np.ptp(raw) * np.linspace(0, 1, 1000)
    assert not offsets_only(SimpleNamespace(piece=piece, outputs={"raw": raw,
                                                                  "m": raw - 3.0 + ramp}))


def test_coefficient_bars_keep_their_colour_and_a_fit_with_none_identified_draws_none(figs):
    """lab_references' bias_lab: a fit on one dwell identifies none of the ten coefficients; its
    figure was all hatching, the legend key blue for gold bars (a key taken from no bar). Now:
    each method's key is its bars' colour whether or not any bar is identified, and a
    protocol where no fit identified any coefficient draws no figure (the report says why)."""
    names = list(TERM_NAMES)
    true = {n: float(k + 1) for k, n in enumerate(names)}

    def rec(identified):
        return {"coef_true_dph": true, "coef_errors_dph": {n: 0.1 for n in names},
                "coef_identified": identified}

    plan = SimpleNamespace(methods=(_spec("a", "flnn"), _spec("b", "model_lstsq")),
                           protocols=())
    res = SimpleNamespace(plan=plan, metrics={"protocols": {"p": {"runs": {"r1": {
        "a": rec(names[:3]), "b": rec([])}}}}})
    assert report_coefficients.fig_coefficients(res, "p", "x.png")
    ax = figs[-1].axes[0]
    keys = dict(zip(*reversed(ax.get_legend_handles_labels())))
    for lab in ("a", "b"):
        want = report_style._color(lab, ["a", "b"], plan)
        assert tuple(keys[lab].patches[0].get_facecolor()[:3]) == pytest.approx(want[:3]), lab
    res.metrics["protocols"]["p"]["runs"]["r1"]["a"] = rec([])
    assert report_coefficients.none_identified(res, "p")
    n = len(figs)
    assert not report_coefficients.fig_coefficients(res, "p", "x.png") and len(figs) == n


def test_thermal_png_shows_a_scored_run_not_the_fit_run():
    prog = SimpleNamespace(steps=(1,))
    data = {"fit": SimpleNamespace(run=SimpleNamespace(thermal=prog)),
            "test": SimpleNamespace(run=SimpleNamespace(thermal=prog))}
    res = SimpleNamespace(data=data, scored=[SimpleNamespace(protocol="p", run="test")])
    assert report_thermal.thermal_run(res) == "test"
    # a concatenated piece "x+test": the first of its runs that has a thermal program
    data["x"] = SimpleNamespace(run=SimpleNamespace(thermal=None))
    res.scored = [SimpleNamespace(protocol="p", run="x+test")]
    assert report_thermal.thermal_run(res) == "test"


def test_replicate_distributions_show_a_sweep_once_and_wrap_panels_three_a_row(figs, tmp_path):
    """paper000's 8 wavelet_band settings were 8 boxes with 8 long rotated labels; paper004's
    6 protocols one 2925-px row. A sweep is one column (its default setting's values) with the
    range of its members' medians beside it; 4 protocols make 2 rows of at most 3 panels."""
    plan = _plan()
    rng = np.random.default_rng(2)
    labels = ["raw", "kalman", "wnn"] + SWEEP
    vals = {lab: list(10.0 + i + rng.standard_normal(20)) for i, lab in enumerate(labels)}
    prots = [SimpleNamespace(name=f"p{i}", in_sample=False) for i in range(4)]
    plan.protocols = prots
    plan.claims = []
    mc = {"replicates": 20,
          "series": {p.name: {"rmse_dph": vals} for p in prots},
          "over_runs": {p.name: {lab: {"rmse_dph": {}} for lab in labels} for p in prots}}
    res = SimpleNamespace(plan=plan)
    assert report_montecarlo.fig_replicates(res, mc, tmp_path / "r.png")
    fig = figs[-1]
    shown = [ax for ax in fig.axes if ax.get_visible()]
    assert len(shown) == 4
    rows = sorted({round(ax.get_position().y0, 3) for ax in shown})
    assert len(rows) == 2
    for ax in shown:
        ticks = [t.get_text() for t in ax.get_xticklabels()]
        assert ticks == ["raw", "kalman", "wnn", "band\n(4 settings)"], ticks
        assert ax.get_ylabel() == "rmse_dph, deg/h"      # the unit, not the key alone
        # the members' medians' range, by hand
        (bar,) = [c for c in ax.collections if c.get_label().startswith("a sweep's members")]
        ys = bar.get_segments()[0][:, 1]
        meds = [np.median(vals[m]) for m in SWEEP]
        assert min(ys) == pytest.approx(min(meds)) and max(ys) == pytest.approx(max(meds))
        # the sweep's column holds its default setting's values
        pts = [ln for ln in ax.get_lines() if ln.get_marker() == "o"]
        np.testing.assert_allclose(sorted(pts[3].get_ydata()), sorted(vals[DEFAULT]))


def test_methods_whose_errors_dwarf_the_others_get_their_own_panel(figs, tmp_path):
    """dynamic_rates' sine_5hz: the two Kalman filters lag the sine by +-5000 deg/h, the
    denoisers' errors are +-300: in one zoom the denoisers were a flat line. The two lagging
    methods (together: neither alone is 3x the rest) go to a panel of their own, the rest
    keep the zoom."""
    rng = np.random.default_rng(4)
    n, fs = 2000, 100.0
    t = np.arange(n) / fs
    truth = np.full(n, 0.01)
    outs = {"raw": truth + rng.standard_normal(n) * 300.0 * DPH}
    outs["oracle"] = outs["raw"].copy()
    outs["kalman"] = truth + 5000.0 * np.sin(2 * np.pi * 5 * t) * DPH
    outs["kalman_rts"] = truth + 3000.0 * np.sin(2 * np.pi * 5 * t) * DPH
    outs["wnn"] = truth + rng.standard_normal(n) * 200.0 * DPH
    plan = SimpleNamespace(methods=(_spec("kalman", "kalman"), _spec("kalman_rts", "kalman"),
                                    _spec("wnn", "wnn")))
    report_timeseries.fig_timeseries(_item(outs, truth, fs), tmp_path / "t.png", plan=plan)
    fig = figs[-1]

    def panel_of(lab):
        (ax,) = [ax for ax in fig.axes if lab in [ln.get_label() for ln in ax.get_lines()]]
        return ax

    quiet, loud = panel_of("wnn"), panel_of("kalman")
    assert loud is panel_of("kalman_rts") and loud is not quiet
    lo, hi = quiet.get_ylim()
    w = (outs["wnn"] - truth) / DPH
    assert lo <= w.min() and w.max() <= hi and hi - lo < 3000.0
    lo, hi = loud.get_ylim()
    assert lo <= -5000.0 + 1 and 5000.0 - 1 <= hi


def test_ideal_twins_sit_under_their_lab_protocols(figs, tmp_path):
    plan = _plan()
    vals = {lab: list(10.0 + np.arange(20.0)) for lab in ["raw", "kalman"]}
    names = [("a", None), ("a.ideal", "a"), ("b", None), ("b.ideal", "b")]
    plan.protocols = [SimpleNamespace(name=n, in_sample=False, twin_of=t) for n, t in names]
    plan.claims = []
    mc = {"replicates": 20, "series": {n: {"rmse_dph": vals} for n, _ in names},
          "over_runs": {n: {lab: {"rmse_dph": {}} for lab in vals} for n, _ in names}}
    assert report_montecarlo.fig_replicates(SimpleNamespace(plan=plan), mc, tmp_path / "r.png")
    fig = figs[-1]
    pos = {ax.get_title().split(":")[0]: ax.get_position() for ax in fig.axes
           if ax.get_visible()}
    assert pos["a"].x0 == pytest.approx(pos["a.ideal"].x0)
    assert pos["b"].x0 == pytest.approx(pos["b.ideal"].x0) and pos["b"].x0 > pos["a"].x0
    assert pos["a.ideal"].y0 < pos["a"].y0


def test_a_static_record_has_no_rate_panel_and_its_title_gives_the_true_rate(figs, tmp_path):
    """thermal_hysteresis, static_allan, paper002: the rate panel drew a flat truth in deg/s
    over a few deg/h of noise, saying nothing the error panels below do not. A static piece
    (true rate within 0.01 deg/h) starts with the errors, its title giving the true rate; a
    piece whose rate moves keeps its rate panel."""
    it = _dwarfed_item()
    report_timeseries.fig_timeseries(it, tmp_path / "t.png", plan=_plan())
    fig = figs[-1]
    assert not any("rate" in ax.get_ylabel() for ax in fig.axes)
    assert "static record (true rate 2063 deg/h" in fig.axes[0].get_title()
    assert all("deg/h" in ax.get_ylabel() for ax in fig.axes)
    figs.clear()
    n = it.piece.t.size
    step = np.where(np.arange(n) < n // 2, 0.0, 10.0) * DPS_     # a 10 deg/s rate step
    outs = {lab: y + step for lab, y in it.outputs.items()}
    report_timeseries.fig_timeseries(_item(outs, it.piece.truth + step, it.piece.fs), tmp_path / "t.png",
                     plan=_plan())
    assert figs[-1].axes[0].get_ylabel() == "rate, deg/s"


def test_protocols_on_one_metric_share_the_y_range(figs, tmp_path):
    """switch_on_repeatability's calibrate_once and recalibrate panels had different y scales,
    so equal heights meant different errors: panels of one metric share its range, holding
    every value."""
    plan = _plan()
    rng = np.random.default_rng(3)
    labels = ["raw", "kalman", "wnn"]
    prots = [SimpleNamespace(name=f"p{i}", in_sample=False) for i in range(2)]
    plan.protocols, plan.claims = prots, []
    series = {p.name: {"rmse_dph": {lab: list((1.0 + 9.0 * i) * (3.0 + rng.random(20)))
                                    for lab in labels}} for i, p in enumerate(prots)}
    mc = {"replicates": 20, "series": series,
          "over_runs": {p.name: {lab: {"rmse_dph": {}} for lab in labels} for p in prots}}
    assert report_montecarlo.fig_replicates(SimpleNamespace(plan=plan), mc, tmp_path / "r.png")
    shown = [ax for ax in figs[-1].axes if ax.get_visible()]
    assert len(shown) == 2 and shown[0].get_ylim() == shown[1].get_ylim()
    lo, hi = shown[0].get_ylim()
    allv = [v for p in series.values() for vs in p["rmse_dph"].values() for v in vs]
    assert lo <= min(allv) and max(allv) <= hi


def test_the_key_metric_run_by_run_is_drawn_with_its_interval(figs, tmp_path):
    """switch_on_repeatability compares calibrating once with calibrating at every power-on,
    yet showed one power-on per figure. runs.png: per protocol scoring two or more runs (twins
    left out), each output's key metric on each run with its 95 % interval over replicates,
    the numbers of metrics.json's montecarlo.summary."""
    plan = _plan()
    prots = [SimpleNamespace(name="once", in_sample=False, twin_of=None),
             SimpleNamespace(name="every", in_sample=False, twin_of=None),
             SimpleNamespace(name="every.ideal", in_sample=False, twin_of="every"),
             SimpleNamespace(name="single", in_sample=False, twin_of=None)]
    plan.protocols, plan.claims = prots, []
    runs = ["power_on_2", "power_on_3", "power_on_4"]
    labels = ["raw", "oracle", "kalman"] + SWEEP

    def sm(v):
        return {"drift_rms_dph": {"mean": v, "ci_low": v - 0.1, "ci_high": v + 0.2}}

    summary = {p.name: {r: {lab: sm(1.0 + i + 0.01 * j + 0.3 * k)
                            for k, lab in enumerate(labels)}
                        for j, r in enumerate(runs if p.name != "single" else runs[:1])}
               for i, p in enumerate(prots)}
    # a reference some runs only have (dynamic_rates' filter oracle: its static run alone)
    summary["every"]["power_on_3"]["oracle_filter"] = sm(0.5)
    mc = {"replicates": 20, "summary": summary,
          "over_runs": {p.name: {"raw": {"drift_rms_dph": {}}} for p in prots}}
    assert report_montecarlo.fig_runs(SimpleNamespace(plan=plan), mc, tmp_path / "runs.png")
    fig = figs[-1]
    assert len(fig.axes) == 2                     # the twin and the one-run protocol left out
    for ax, name in zip(fig.axes, ("once", "every")):
        assert ax.get_title().startswith(f"{name}: drift_rms_dph")
        assert [t.get_text() for t in ax.get_xticklabels()] == runs
        drawn = {c.get_label(): c for c in ax.containers}
        assert set(drawn) == {"raw", "oracle", "kalman", "band default (level-6)"} | (
            {"oracle_filter"} if name == "every" else set())
        for lab, shown in (("kalman", "kalman"), (DEFAULT, "band default (level-6)")):
            c = drawn[shown]
            want = [summary[name][r][lab]["drift_rms_dph"] for r in runs]
            np.testing.assert_allclose(c.lines[0].get_ydata(), [w["mean"] for w in want])
            segs = c.lines[2][0].get_segments()
            np.testing.assert_allclose([s[:, 1].min() for s in segs],
                                       [w["ci_low"] for w in want])
            np.testing.assert_allclose([s[:, 1].max() for s in segs],
                                       [w["ci_high"] for w in want])
    assert fig.axes[0].get_ylim() == fig.axes[1].get_ylim()
