"""One palette and one set of units for the PNG figures and the Rerun recording
(fogbench/report/palette.py): every bundled method label has a colour, families are told apart by a
perceptual distance computed here by hand (sRGB -> CIE Lab, CIE76), the viewer and the PNGs
give a label the same colour, and the Allan figure stops where too few independent clusters
remain (IEEE Std 952 / NIST SP 1065: at least 8 non-overlapping clusters)."""

from __future__ import annotations

import glob
import itertools
import math
from types import SimpleNamespace

import numpy as np
import pytest

from fogcomp.units import DPH
from fogbench.outputs import files
from fogbench.report import palette as PAL
from fogbench.recording import blueprint as recording_blueprint
from fogbench.recording import entities as recording_entities
from fogbench.report import spectra as report_spectra
from fogbench.report import thermal as report_thermal
from fogbench.report import timeseries as report_timeseries
from fogbench.run.runner import RUNNER_SECTIONS, Piece, Scored
from fogbench.scenario import load_plan, load_scenario

SCENARIOS = sorted(glob.glob("scenarios/*.toml"))


def _lab(c):
    """8-bit sRGB -> CIE L*a*b* (D65), by the textbook formulas (IEC 61966-2-1, CIE 15)."""
    lin = []
    for v in c[:3]:
        v = v / 255.0
        lin.append(v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4)
    r, g, b = lin
    x = (0.4124 * r + 0.3576 * g + 0.1805 * b) / 0.95047
    y = (0.2126 * r + 0.7152 * g + 0.0722 * b) / 1.0
    z = (0.0193 * r + 0.1192 * g + 0.9505 * b) / 1.08883
    d = 6.0 / 29.0

    def f(t):
        return t ** (1.0 / 3.0) if t > d**3 else t / (3 * d * d) + 4.0 / 29.0

    return 116.0 * f(y) - 16.0, 500.0 * (f(x) - f(y)), 200.0 * (f(y) - f(z))


def _delta_e(c1, c2) -> float:
    return math.dist(_lab(c1), _lab(c2))


def test_lab_conversion_matches_known_values():
    assert _lab((255, 255, 255)) == pytest.approx((100.0, 0.0, 0.0), abs=0.05)
    assert _lab((0, 0, 0)) == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)
    assert _lab((255, 0, 0)) == pytest.approx((53.24, 80.09, 67.20), abs=0.1)   # sRGB red


def _plan(path):
    return load_plan(load_scenario(path, extra_sections=RUNNER_SECTIONS))


@pytest.mark.parametrize("path", SCENARIOS)
def test_every_method_label_has_a_colour_and_families_are_told_apart(path):
    plan = _plan(path)
    st = PAL.plan_styles(plan)
    labels = [m.label for m in plan.methods]
    assert set(labels) <= set(st)
    for lab in labels:
        c = st[lab].color
        assert len(c) == 3 and all(0 <= v <= 255 for v in c)
    # different families (the built-in method a label runs), raw, oracle and the truth apart
    fixed = {"raw": PAL.RAW, "oracle": PAL.ORACLE, "truth": PAL.TRUTH}
    family = {m.label: m.name for m in plan.methods}
    family.update({k: k for k in fixed})
    colour = {lab: st[lab].color for lab in labels} | fixed
    for a, b in itertools.combinations(colour, 2):
        if family[a] != family[b]:
            assert _delta_e(colour[a], colour[b]) > 10.0, (path, a, b)
    # members of a family share its hue and differ in shade (the first len(SHADES)) or style
    by_fam: dict[str, list] = {}
    for m in plan.methods:
        by_fam.setdefault(m.name, []).append(m.label)
    for fam, labs in by_fam.items():
        looks = [(st[x].color, str(st[x].dash)) for x in labs]
        first = [st[x].color for x in labs[:len(PAL.SHADES)]]
        assert len(set(first)) == len(first), (fam, first)
        assert len(set(looks)) == min(len(looks), len(PAL.SHADES) * len(PAL.DASHES))


def test_the_same_method_is_the_same_colour_in_every_scenario():
    seen: dict[str, set] = {}
    for path in SCENARIOS:
        for m in _plan(path).methods:
            if m.name in PAL.FAMILY_HUES:
                st = PAL.plan_styles(_plan(path))
                if st[m.label].member == 0:
                    seen.setdefault(m.name, set()).add(st[m.label].color)
    assert seen and all(len(v) == 1 for v in seen.values()), seen


def test_built_in_families_are_told_apart_whatever_scenario_combines_them():
    hues = dict(PAL.FAMILY_HUES) | {"raw": PAL.RAW, "oracle": PAL.ORACLE, "truth": PAL.TRUTH}
    for a, b in itertools.combinations(hues, 2):
        assert _delta_e(hues[a], hues[b]) > 10.0, (a, b)


def test_every_member_of_every_family_reads_on_a_white_page():
    """Members are shades of their family's hue; none fades towards the page (paper002's
    rs_bp_gd, the third olive member, was L* 82 before light hues were only darkened)."""
    for hue in [*PAL.FAMILY_HUES.values(), *PAL.EXTRA_HUES]:
        members = [PAL._shade(hue, s) for s in
                   (PAL.SHADES_LIGHT if _lab(hue)[0] > PAL.LIGHT_HUE_L else PAL.SHADES)]
        assert all(_lab(c)[0] <= 75.0 for c in members[1:]), (hue, members)
        for a, b in itertools.combinations(members, 2):
            assert _delta_e(a, b) > 5.0, (hue, a, b)
    for fam, hue in PAL.FAMILY_HUES.items():
        st = PAL.styles([(f"m{k}", fam) for k in range(5)])
        assert all(_lab(s.color)[0] <= max(75.0, _lab(hue)[0]) for s in st.values()
                   if s.family == fam), (fam, st)
    assert abs(PAL.lightness((188, 189, 34)) - _lab((188, 189, 34))[0]) < 1e-9


def test_in_sample_tint_is_readable_and_distinct():
    for c in list(PAL.FAMILY_HUES.values()):
        t = PAL.in_sample(c)
        assert _lab(t)[0] <= 85.0, (c, t)            # still reads on a white page
        assert _delta_e(t, c) > 8.0, (c, t)           # and differs from the held-out colour


def _item(labels, n=5000, fs=10.0, seed=0, protocol="p"):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    truth = np.full(n, 15.0 * DPH)
    outs = {lab: truth + rng.standard_normal(n) * (2.0 + i) * DPH
            for i, lab in enumerate(["raw", "oracle"] + labels)}
    piece = Piece(run="r1", fs=fs, t=t, raw=outs["raw"], truth=truth, g=np.zeros((n, 3)),
                  temp=np.full(n, 20.0), temp_rate=np.zeros(n), oracle=outs["oracle"])
    return Scored(protocol=protocol, run="r1", piece=piece, outputs=outs)


@pytest.fixture
def figs(monkeypatch):
    kept = []
    monkeypatch.setattr(files, "save_figure", lambda fig, path: kept.append(fig))
    yield kept
    import matplotlib.pyplot as plt

    for f in kept:
        plt.close(f)


def _png_colours(fig) -> dict[str, tuple]:
    """label -> colour of every line of every panel; a sweep's default line
    ("<group> default (<setting>)", the sweep drawn as an envelope) under its member's label."""
    import re

    from matplotlib.colors import to_rgb

    out = {}
    for ax in fig.axes:
        for ln in ax.get_lines():
            lab = ln.get_label()
            if not lab.startswith("_") and ":" not in lab:
                lab = lab.split(" (falls below")[0]
                m = re.fullmatch(r"(\S+) default \((.+)\)", lab)
                lab = f"{m.group(1)}.{m.group(2)}" if m else lab
                out[lab] = tuple(int(round(255 * v)) for v in to_rgb(ln.get_color()))
    return out


@pytest.mark.parametrize("path", ["scenarios/paper000_wnn.toml", "scenarios/paper002_acobp.toml"])
def test_viewer_and_png_give_a_label_the_same_colour(figs, tmp_path, path):
    plan = _plan(path)
    labels = [m.label for m in plan.methods]
    it = _item(labels)
    assert report_spectra.fig_allan(it, tmp_path / "a.png", plan=plan)
    png = _png_colours(figs[-1])
    viewer = recording_entities._method_colors(SimpleNamespace(plan=plan))
    # a sweep is one envelope with its default setting's line (fogbench.report.views.method_entries)
    shown = [m.label for m in plan.methods if not m.group or m.paper_setting]
    assert set(png) == {"raw", "oracle", *shown}
    for lab, c in png.items():
        assert tuple(recording_entities._piece_color(viewer, lab, False)[:3]) == c, lab
    # the time series and PSD figures use the same colours
    report_spectra.fig_psd(it, tmp_path / "p.png", plan=plan)
    assert _png_colours(figs[-1]) == png


def test_allan_figure_stops_at_eight_non_overlapping_clusters_with_a_band(figs, tmp_path):
    n, fs = 5000, 10.0
    it = _item(["m1"], n=n, fs=fs)
    assert report_spectra.fig_allan(it, tmp_path / "a.png")
    ax = figs[-1].axes[0]
    # octave averaging factors m = 1, 2, 4, ...; the largest with floor(n / m) >= 8
    m_max = 1
    while n // (2 * m_max) >= 8:
        m_max *= 2
    assert m_max == 512
    for ln in ax.get_lines():
        if ln.get_label() in ("raw", "oracle", "m1"):
            x = np.asarray(ln.get_xdata())
            assert math.isclose(x.max(), m_max / fs, rel_tol=1e-9), ln.get_label()
    # one interval band per curve, around it
    bands = [c for c in ax.collections if c.get_label().startswith("_")]
    assert len(bands) == 3
    ax_txt = ax.get_title()
    assert "8 non-overlapping clusters" in ax_txt and "interval" in ax_txt


def test_allan_figure_draws_the_identified_white_noise_model(figs, tmp_path):
    # 2000 s of white noise at 2 Hz: the bench identifies its noise terms (>= 1000 s)
    n, fs, sigma = 4000, 2.0, 3.0
    it = _item([], n=n, fs=fs, seed=4)
    rng = np.random.default_rng(9)
    it.outputs["raw"] = it.piece.truth + rng.standard_normal(n) * sigma * DPH
    assert report_spectra.fig_allan(it, tmp_path / "a.png")
    ax = figs[-1].axes[0]
    model = [ln for ln in ax.get_lines() if ln.get_label().startswith("raw: identified model")]
    assert len(model) == 1
    x, y = np.asarray(model[0].get_xdata()), np.asarray(model[0].get_ydata())
    # white rate noise of sigma per sample: ADEV(tau) = sigma / sqrt(fs tau)
    want = sigma / np.sqrt(fs * x)
    np.testing.assert_allclose(y, want, rtol=0.15)


def test_error_units_are_deg_per_h_in_png_as_in_the_viewer(figs, tmp_path):
    it = _item(["m1"], n=600, fs=10.0)
    report_timeseries.fig_timeseries(it, tmp_path / "t.png")
    ax = figs[-1].axes[-1]
    assert "deg/h" in ax.get_ylabel() and "time since power-on, s" in ax.get_xlabel()
    ln = next(x for x in ax.get_lines() if x.get_label() == "m1")
    p = it.piece
    np.testing.assert_allclose(ln.get_ydata(), (it.outputs["m1"] - p.truth) / DPH)
    report_spectra.fig_psd(it, tmp_path / "p.png")
    assert "(deg/h)^2/Hz" in figs[-1].axes[0].get_ylabel()


def test_time_axis_unit_rule():
    assert PAL.time_unit(600.0) == (1.0, "s")
    assert PAL.time_unit(3 * 3600.0) == (1.0, "s")
    assert PAL.time_unit(3 * 3600.0 + 1) == (3600.0, "h")


def test_a_sensor_step_does_not_fill_the_temperature_axis(figs, tmp_path):
    from sim.thermal import TempSensor, ThermalHold, ThermalModel, ThermalProgram, \
        simulate_thermal

    fs = 1.0
    t = np.arange(0.0, 3000.0, 1.0 / fs)
    prog = ThermalProgram(start=20.0, steps=(ThermalHold(3000.0),))
    th = simulate_thermal(prog, t, ThermalModel(housing_time_constant=200.0,
                                                coil_time_constant=300.0,
                                                sensor=TempSensor("housing", 30.0, 0.02,
                                                                  0.0625)))
    th.sensor[1500:] = th.sensor[1500:] + 0.0625        # one quantisation step
    rd = SimpleNamespace(run=SimpleNamespace(thermal=prog, name="r1"), fs=fs, n=t.size,
                         truth=SimpleNamespace(t=t), thermal=th,
                         fog=SimpleNamespace(raw=np.zeros((t.size, 1))),
                         truth_axis=lambda j: np.zeros(t.size))
    res = SimpleNamespace(data={"r1": rd}, scenario=SimpleNamespace(axes=("z",)),
                          plan=SimpleNamespace(axis="z", paper=(), protocols=()))
    assert report_thermal.fig_thermal(res, "r1", tmp_path / "th.png")
    lo, hi = figs[-1].axes[0].get_ylim()
    assert hi - lo >= 1.0 - 1e-12


def test_the_viewer_temperature_axis_spans_at_least_one_degree():
    w = SimpleNamespace(ranges={"/a": (20.0, 20.0625), "/b": (20.0, 20.0)})
    ax = recording_blueprint._y_axis(w, ["/a", "/b"], unit="deg C")
    lo, hi = (float(v) for v in np.asarray(ax.range.as_arrow_array().to_pylist()[0]))
    assert hi - lo >= 1.0 - 1e-12 and lo <= 20.0 and hi >= 20.0625
    w = SimpleNamespace(ranges={"/a": (20.0, 45.0)})       # a real thermal program: autoscaled
    assert recording_blueprint._y_axis(w, ["/a"], unit="deg C") is None


def test_no_member_of_any_family_passes_for_raw_or_the_oracle():
    """paper004's flnn_dwell_means (teal lightened, CIE76 14.9 from the oracle's cyan) read as the
    oracle. Every member of every built-in and plug-in family, five members each, stays more than
    15 from raw's grey and the oracle's cyan (CIE76 by hand here), and a family's first three
    members differ from each other by more than 14 (paper002's olive aco_bp pair was 10.8)."""
    fams = list(PAL.FAMILY_HUES) + [f"plugin{i}" for i in range(len(PAL.EXTRA_HUES))]
    for fam in fams:
        st = PAL.styles([(f"m{k}", fam) for k in range(5)])
        cols = [st[f"m{k}"].color for k in range(5)]
        for c in cols:
            assert _delta_e(c, PAL.RAW) > 15.0 and _delta_e(c, PAL.ORACLE) > 15.0, (fam, c)
        for a, b in itertools.combinations(cols[:3], 2):
            assert _delta_e(a, b) > 14.0, (fam, a, b)
    # a teal (a plug-in's colour could be one) only darkens: lightened it is the oracle's cyan
    assert _delta_e(PAL._shade((0, 128, 128), 0.3), PAL.ORACLE) < 15.0
    assert PAL._darken_only((0, 128, 128))
    assert PAL.delta_e((255, 0, 0), (0, 0, 255)) == pytest.approx(_delta_e((255, 0, 0),
                                                                           (0, 0, 255)))
