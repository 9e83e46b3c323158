"""Claim maps: a point of a scenario's [map] is the scenario with only the values it
names changed (the other keys and every seed held), its verdicts are those of a plain scenario
file written with those values, bad maps are refused before any work, the filter oracle is the
generalised least-squares estimate, and paper 004's two-way centrifuge recovers the coefficients
with a misalignment present where a one-way spin does not."""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from fogbench.run.engines import SerialExecutor
from fogbench.run.maps import MapRun
from fogbench.run.montecarlo import ScenarioMC
from fogbench.run.runner import noise_autocovariance, oracle_filter, run_scenario, run_seed
from fogbench.scenario.device_file import _FOG_KEYS
from fogbench.scenario.load import RUNNER_SECTIONS
from fogbench.scenario import ScenarioError, load_plan, load_scenario
from sim.rig import simulate_run

ROOT = Path(__file__).resolve().parents[2]
MAPPED = ["paper000_wnn", "paper002_acobp", "paper004_flnn"]


def _load(path, overrides=None):
    sc = load_scenario(path, extra_sections=RUNNER_SECTIONS, overrides=overrides)
    return sc, load_plan(sc)


def _named_fog_fields(overrides: dict) -> set[str]:
    """FogParams fields a point's dotted paths name (``fog.<key>``)."""
    out = set()
    for path in overrides:
        if path.startswith("fog."):
            key = path.split(".", 1)[1]
            out.add(_FOG_KEYS[key][0] if key in _FOG_KEYS else
                    {"misalignment_mrad": "misalignment", "g_sens_dph_per_g": "g_sens",
                     "g2_sens_dph_per_g2": "g2_sens"}.get(key, key))
    return out


def _named_segments(overrides: dict, run_names) -> set[tuple[str, int]]:
    out = set()
    for path in overrides:
        m = re.fullmatch(r"runs\.([^.]+)\.motion\.(\d+)(\..+)?", path)
        if m:
            runs = run_names if m.group(1) == "*" else [m.group(1)]
            out |= {(r, int(m.group(2))) for r in runs}
    return out


@pytest.mark.parametrize("name", MAPPED)
def test_every_point_changes_only_what_it_names(name):
    """Per axis and point: the FOG parameters differ from the scenario's in exactly the fields
    the point names, the runs in exactly the motion segments it names, and every run keeps its
    seed (and so its random streams, run_seed) and the protocols their selections unless named."""
    path = ROOT / "scenarios" / f"{name}.toml"
    base, bplan = _load(path)
    assert bplan.map is not None
    names = [r.name for r in base.runs]
    for pt in bplan.map.points:
        sc, plan = _load(path, pt.overrides)
        diff = {f.name for f in dataclasses.fields(base.fog)
                if getattr(base.fog, f.name) != getattr(sc.fog, f.name)}
        named = _named_fog_fields(pt.overrides)
        assert diff <= named, (pt.label, diff - named)
        # a named key set to the value the scenario already has is not a change
        assert all(getattr(sc.fog, f) != getattr(base.fog, f) for f in diff)
        segs = {(a.name, j) for a, b in zip(base.runs, sc.runs)
                for j, (s0, s1) in enumerate(zip(a.motion, b.motion)) if s0 != s1}
        assert segs <= _named_segments(pt.overrides, names), (pt.label, segs)
        for i, (a, b) in enumerate(zip(base.runs, sc.runs)):
            assert (a.name, a.seed, a.thermal, a.tilt0) == (b.name, b.seed, b.thermal, b.tilt0)
            assert len(a.motion) == len(b.motion)
            for r in (0, 3):
                assert run_seed(base, bplan, r, i) == run_seed(sc, plan, r, i)
        named_prot = {p.split(".")[1] for p in pt.overrides if p.startswith("protocols.")}
        for p0, p1 in zip(bplan.protocols, plan.protocols):
            if p0.name not in named_prot:
                assert p0 == p1
        assert [m.label for m in bplan.methods] == [m.label for m in plan.methods]
        assert bplan.claims == plan.claims
        assert (sc.fs, sc.table, sc.axes) == (base.fs, base.table, base.axes)


@functools.cache
def _scenario_first_run(name: str):
    """Run 0 of a bundled scenario at replicate 2, simulated once for every point below (each
    point compares its own draw with this one)."""
    base, bplan = _load(ROOT / "scenarios" / f"{name}.toml")
    return simulate_run(base.rig, base.runs[0], seed=run_seed(base, bplan, 2, 0))


@pytest.mark.parametrize("name,label", [
    ("paper004_flnn", ("ARW 0.06", "+400 / -600 (scenario)")),
    ("paper004_flnn", ("misalignment 0.1 mrad", "+400 / -600 (scenario)")),
    ("paper004_flnn", ("switch-on change x3", "+400 / -600 (scenario)")),
    ("paper000_wnn", ("white noise",)),
])
def test_a_device_point_draws_the_same_random_numbers(name, label):
    """Simulated with the same seed, a device point's FOG terms are the scenario's, sample for
    sample, except the terms of the keys it names (the noise streams are the same draws)."""
    path = ROOT / "scenarios" / f"{name}.toml"
    _, bplan = _load(path)
    pt = next(p for p in bplan.map.points if p.labels == label)
    sc, plan = _load(path, pt.overrides)
    rd0 = _scenario_first_run(name)
    rd1 = simulate_run(sc.rig, sc.runs[0], seed=run_seed(sc, plan, 2, 0), truth=rd0.truth)
    terms = {"ARW 0.06": {"arw"}, "misalignment 0.1 mrad": {"misalignment"},
             "switch-on change x3": {"g_sensitivity", "g2_sensitivity"},
             # the pulse quantisation's error follows the signal it quantises
             "white noise": {"arw", "gm_drift", "quantization"}}[label[0]]
    changed = {k for k in set(rd0.fog.terms) | set(rd1.fog.terms)
               if k not in rd0.fog.terms or k not in rd1.fog.terms
               or not np.array_equal(rd0.fog.terms[k], rd1.fog.terms[k])}
    assert changed == terms, changed
    if label[0] == "ARW 0.06":   # the same white draws, scaled by 0.06 / 0.02
        np.testing.assert_allclose(rd1.fog.terms["arw"], 3.0 * rd0.fog.terms["arw"], rtol=1e-12)


WNN_LIGHT = ["wnn_recnorm", "kalman", "kalman_datasheet"]


def test_a_points_verdicts_are_those_of_the_plain_scenario_with_its_values(tmp_path):
    """Paper 000's white-noise point run through the map equals a scenario file written by hand
    with gm_drift_dps = 0 and arw_deg_rt_h = 0.79 (and no [map]): the same claims, verdicts and
    numbers, replicate for replicate."""
    src = ROOT / "scenarios" / "paper000_wnn.toml"
    text = src.read_text()
    plain = text[:text.index("\n[map]")]
    plain = plain.replace('preset = "low_grade"',
                          'preset = "low_grade"\ngm_drift_dps = 0.0\narw_deg_rt_h = 0.79')
    # the plain copy lives in its own folder under the same file name: the scenario's name
    # (and so its seeds) is the same
    (tmp_path / "plain").mkdir()
    plain_path = tmp_path / "plain" / "paper000_wnn.toml"
    plain_path.write_text(plain)
    base = ScenarioMC(src, tmp_path / "mapped", replicates=3, methods=WNN_LIGHT)
    mapper = MapRun(src, tmp_path / "mapped", base, replicates=3, methods=WNN_LIGHT)
    white = next(i for i, p in enumerate(base.plan.map.points) if p.labels == ("white noise",))
    ex = SerialExecutor()
    base.simulate_truths()
    mapper.simulate_truths()
    base.run_first()
    base.submit(ex)
    mapper.submit(ex)
    base.wait()
    mapper.wait()
    doc = base.finish("test")
    mdoc = mapper.finish(doc, "test")
    point_doc = mapper.mcs[white].finish("test")
    ref = ScenarioMC(plain_path, tmp_path / "plain_out", replicates=3, methods=WNN_LIGHT)
    ref.simulate_truths()
    ref.run_first()
    ref.submit(ex)
    ref.wait()
    ref_doc = ref.finish("test")
    assert len(ref_doc["claims"]) == len(point_doc["claims"]) > 0
    for a, b in zip(point_doc["claims"], ref_doc["claims"]):
        assert (a["text"], a["verdict"]) == (b["text"], b["verdict"])
        assert a["summary"]["n"] == b["summary"]["n"] == 3, a["summary"]
        assert a["summary"]["mean"] == pytest.approx(b["summary"]["mean"], rel=1e-12)
    for c in mdoc["claims"]:
        hit = next(x for x in ref_doc["claims"]
                   if x["text"] == c["text"] and x["protocol"] == c["protocol"])
        assert c["points"][white]["verdict"] == hit["verdict"]
    mapper.release()


_BAD = [
    ('[[map.axes]]\nname = "a"\nsource = "s"\nkey = "fog.no_such_key"\nvalues = [1.0]\n',
     "no_such_key"),
    ('[[map.axes]]\nname = "a"\nsource = "s"\nkey = "runs.nope.motion.0.rate_dps"\n'
     'values = [1.0]\n', "no single [[runs]] with name 'nope'"),
    ('[[map.axes]]\nname = "a"\nsource = "s"\nkey = "runs.*.motion.7.rate_dps"\n'
     'values = [1.0]\n', "is not an index of a list of 1"),
    ('[[map.axes]]\nname = "a"\nsource = "s"\nkey = "fog.arw_deg_rt_h"\nvalues = [-1.0]\n',
     "arw_deg_rt_h"),
    ('[[map.axes]]\nname = "a"\nsource = "s"\nkey = "fog.arw_deg_rt_h"\nvalues = [0.1]\n'
     '[[map.axes]]\nname = "b"\nsource = "s"\nkey = "fog.arw_deg_rt_h"\nvalues = [0.2]\n',
     "set 'fog.arw_deg_rt_h' twice"),
    ('[[map.axes]]\nname = "a"\nsource = "s"\nkey = "fog.arw_deg_rt_h"\n'
     'values = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]\n[[map.axes]]\nname = "b"\nsource = "s"\n'
     'key = "fog.bias_dph"\nvalues = [1.0, 2.0, 3.0, 4.0, 5.0]\n', "at most 25"),
    ('[[map.axes]]\nname = "a"\nsource = "s"\nkey = "fog.arw_deg_rt_h"\nvalues = [0.1]\n'
     'labels = ["x", "y"]\n', "expected 1 labels"),
    ('metrics = ["held_out.raw"]\n[[map.axes]]\nname = "a"\nsource = "s"\n'
     'key = "fog.arw_deg_rt_h"\nvalues = [0.1]\n', "protocol.method.metric"),
    ('metrics = ["held_out.nope.std_dps"]\n[[map.axes]]\nname = "a"\nsource = "s"\n'
     'key = "fog.arw_deg_rt_h"\nvalues = [0.1]\n', "no method labelled 'nope'"),
    ('[[map.axes]]\nname = "a"\nsource = "s"\nkey = "scenario.name.x"\nvalues = [0.1]\n',
     "is a value, not a table"),
    ('[[map.axes]]\nname = "a"\nsource = "s"\n', "give either key and values, or points"),
    ('[[map.axes]]\nname = "a"\nkey = "fog.arw_deg_rt_h"\nvalues = [0.1]\n', "source"),
]

_TINY = """
[scenario]
name = "tiny_map"
sample_rate_hz = 10.0

[fog]
preset = "tactical"

[[runs]]
name = "a"
seed = 1
[[runs.motion]]
type = "hold"
duration_s = 60.0

[[runs]]
name = "b"
seed = 2
[[runs.motion]]
type = "hold"
duration_s = 60.0

[[protocols]]
name = "held_out"
fit = ["a"]
score = ["b"]

[[methods]]
name = "kalman"

[map]
"""


@pytest.mark.parametrize("body,words", _BAD)
def test_a_bad_map_is_refused_at_load_naming_where(tmp_path, body, words):
    p = tmp_path / "tiny_map.toml"
    p.write_text(_TINY + body)
    with pytest.raises(ScenarioError) as ei:
        _load(p)
    msg = str(ei.value)
    assert str(p) in msg and "map" in msg and words in msg, msg


def test_a_star_sets_every_run_and_settle_needs_segments(tmp_path):
    p = tmp_path / "tiny_map.toml"
    p.write_text(_TINY + '[[map.axes]]\nname = "a"\nsource = "s"\n'
                 'key = "runs.*.motion.0.duration_s"\nvalues = [30.0, 60.0]\n')
    sc, plan = _load(p)
    assert [pt.is_base for pt in plan.map.points] == [False, True]
    short, _ = _load(p, plan.map.points[0].overrides)
    assert [r.duration for r in short.runs] == [30.0, 30.0]
    p.write_text(_TINY.replace('fit = ["a"]', 'fit = [{ run = "a", settle_s = 5.0 }]')
                 .removesuffix("[map]\n"))
    with pytest.raises(ScenarioError, match="settle_s.*segments"):
        _load(p)


def test_settle_leaves_out_the_start_of_each_segment():
    from fogbench.scenario import Run, Selection, select_indices
    from sim.motion import Hold

    run = Run("r", 1, (Hold(10.0), Hold(5.0), Hold(20.0)), None, 0.0)
    idx = select_indices(Selection("r", segments=(0, 2), settle_s=3.0), run, 10.0, 0.0)
    want = np.concatenate([np.arange(30, 100), np.arange(150 + 30, 350)])
    np.testing.assert_array_equal(idx, want)


# ---------------------------------------------------------------------------------------------
# the filter oracle
def test_the_noise_autocovariance_is_the_simulated_noises():
    """Against the sample autocovariance of a long simulated noise-only record (white, the
    Gauss-Markov drift, the flicker's components and the pulse quantisation), lags 0..5 and
    50: within 5 sigma of the estimate's sampling error."""
    from fogcomp.units import DEG_RT_H, DPH
    from sim.fog import FogParams, simulate_fog

    fs, n = 10.0, 400_000
    p = FogParams(arw=0.05 * DEG_RT_H, gm_drift=2.0 * DPH, gm_time_constant=3.0,
                  bias_instability=0.5 * DPH, bi_band=(1e-3, 1.0),
                  quantization=math.radians(2.0 / 3600.0))
    out = simulate_fog(p, fs, np.zeros((n, 3)), np.zeros((n, 3)), axes=("z",), seed=4)
    keep = ("arw", "gm_drift", "bias_instability", "quantization")
    x = sum(out.terms[k][:, 0] for k in keep if k in out.terms)
    x = x - x.mean()
    c = noise_autocovariance(p, fs, 60)
    for lag in (0, 1, 2, 5, 50):
        emp = float(np.mean(x[lag:] * x[:n - lag]))
        # the sampling sd of a lag product mean of a process with correlation time T is about
        # c0 sqrt(2 T fs / n); T = 3 s bounds the slowest component that matters here
        sd = c[0] * math.sqrt(2.0 * 3.0 * fs / n) + c[0] * math.sqrt(2.0 / n)
        assert abs(emp - c[lag]) <= 5.0 * sd, (lag, emp, c[lag], sd)


def test_the_filter_oracle_is_the_gls_estimate_of_the_constant():
    """For a constant true rate: the dense generalised least squares (the noise covariance
    matrix built and solved directly, the slow twin of the Toeplitz solve), and for white noise
    alone the plain mean."""
    from fogbench.run.runner import Piece
    from fogcomp.units import DEG_RT_H, DPH
    from sim.fog import FogParams

    fs, n = 10.0, 600
    rng = np.random.default_rng(2)
    p = FogParams(arw=0.05 * DEG_RT_H, gm_drift=2.0 * DPH, gm_time_constant=3.0)
    truth = np.full(n, 0.3)
    raw = truth + rng.normal(0, 1e-4, n) + np.cumsum(rng.normal(0, 1e-5, n))
    t = np.arange(n) / fs
    z = np.zeros(n)
    piece = Piece(run="r", t=t, raw=raw, truth=truth, g=np.zeros((n, 3)), temp=z,
                  temp_rate=z, oracle=raw, fs=fs)
    got = oracle_filter(piece, p, fs)
    h = np.abs(np.subtract.outer(np.arange(n), np.arange(n)))
    C = np.where(h == 0, p.arw ** 2 * fs, 0.0) + p.gm_drift ** 2 * np.exp(-h / (fs * 3.0))
    w = np.linalg.solve(C, np.ones(n))
    assert got == pytest.approx(np.full(n, w @ raw / w.sum()), rel=1e-9)
    white = FogParams(arw=0.05 * DEG_RT_H)
    assert oracle_filter(piece, white, fs) == pytest.approx(np.full(n, raw.mean()), rel=1e-12)
    moving = dataclasses.replace(piece, truth=truth + 0.01 * np.sin(t))
    assert oracle_filter(moving, p, fs) is None


# ---------------------------------------------------------------------------------------------
# paper 004: the centrifuge spun one way and both ways, with a misalignment
def _one_power_on(tmp_path, spins, misalignment=0.1, truths=None):
    """Paper 004's scenario cut to its first power-on (the per-run protocols are unchanged),
    with a misalignment (mrad, on every off-diagonal) and the given spin rates."""
    text = (ROOT / "scenarios" / "paper004_flnn.toml").read_text()
    assert len(tomllib.loads(text)["runs"]) == 4
    text = text[:text.index("\n[map]")]
    first = text.index("[[runs]]")
    text = text[:text.index("[[runs]]", first + 1)] + text[text.index("[compensation]"):]
    text = text.replace('name = "paper004_flnn"', 'name = "paper004_one_power_on"')
    text = re.sub(r"\[\[bounds\]\].*?(?=\n\[\[|\Z)", "", text, flags=re.S)
    text = re.sub(r'\[\[protocols\]\]\nname = "calibrate_once".*?(?=\n\[\[|\Z)', "", text,
                  flags=re.S)
    p = tmp_path / f"p004_{misalignment}_{spins[0]:g}_{spins[1]:g}.toml"
    p.write_text(text)
    m = misalignment
    over = {"fog.misalignment_mrad": [[0.0, m, m], [m, 0.0, m], [m, m, 0.0]]}
    over.update({f"runs.*.motion.{3 + i}.rate_dps": r for i, r in enumerate(spins)})
    res = run_scenario(p, methods=["flnn_lstsq"], overrides=over, truths=truths)
    return res.metrics["protocols"]["recal_centrifuge"]["runs"]["switch_on_1"]["flnn_lstsq"]


def test_the_two_way_centrifuge_recovers_the_coefficients_despite_misalignment(tmp_path):
    """The interval the analysis predicts: the standard errors of the same least-squares fit on
    the same power-on without misalignment (white residuals; about 0.13 deg/h per coefficient).
    Spun both ways (+-500 deg/s at each tilt) with 0.1 mrad of misalignment, the ten
    coefficients are within it (RMS of error / predicted stderr below 3: for ten standard normal
    errors the RMS exceeds 2 with probability 3e-5; the rest allows for the stderr's estimate);
    spun one way (+500 at every tilt), the misalignment's 180 deg/h at the spin goes into the
    g^2 terms: errors of many standard errors (RMS above 10)."""
    table: dict = {}   # the two-way table motion, simulated once
    clean = _one_power_on(tmp_path, [500.0, -500.0] * 4, misalignment=0.0, truths=table)
    se = clean["coef_rms_stderr_dph"]
    assert len(clean["coef_identified"]) == 10 and 0.0 < se < 1.0
    assert clean["coef_z_rms"] < 3.0                 # the analysis holds without misalignment
    two = _one_power_on(tmp_path, [500.0, -500.0] * 4, truths=table)
    one = _one_power_on(tmp_path, [500.0] * 8)
    assert len(two["coef_identified"]) == len(one["coef_identified"]) == 10
    assert two["coef_rms_error_dph"] / se < 3.0, (two, se)
    assert one["coef_rms_error_dph"] / se > 10.0, (one, se)
    # the fit's own stderr cannot see the leak: one way it stays near the noise-only value
    # while the errors are far outside it
    assert one["coef_z_rms"] > 10.0


def test_a_map_figure_s_long_claim_and_label_stay_inside_it_apart(tmp_path, monkeypatch):
    """paper000's map__6 ran a 150-character claim off both sides of the figure and into a
    one-line y label: the title and the label are wrapped and laid out inside, not overlapping."""
    import matplotlib.pyplot as plt

    from fogbench.report import maps as MR

    from fogbench.outputs import files as IO

    kept = []
    monkeypatch.setattr(IO, "save_figure", lambda fig, path: kept.append(fig))
    pt = {"verdict": "agrees", "mean": 61.0, "ci_low": 57.0, "ci_high": 65.0, "n": 20,
          "held": 0.9, "oracle_mean": 100.0, "oracle_ci_low": 100.0, "oracle_ci_high": 100.0,
          "oracle_bounds": True, "oracle": "oracle_filter", "side": None}
    claim = {"text": "the WNN compensates far better than the Kalman filter (Table 1: 85 % lower "
                     "std); against the datasheet-tuned Kalman; WNN with fit-record "
                     "normalisation", "protocol": "held_out", "in_sample": False,
             "metric": "std_dps", "better": "wnn_fitnorm", "than": "kalman_datasheet",
             "min_pct": 50.0, "max_pct": None, "points": [pt, pt, pt]}
    doc = {"axes": [{"name": "source of the 0.13 deg/s", "labels": ["a", "b", "c"],
                     "numeric": None}],
           "points": [{"index": [i], "labels": [x], "label": x, "base": i == 0}
                      for i, x in enumerate("abc")],
           "claims": [claim], "replicates_per_point": 20}
    assert MR.fig_map(doc, 0, tmp_path / "m.png")
    fig = kept[-1]
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    ax = fig.axes[0]
    title, ylab = ax.title.get_window_extent(r), ax.yaxis.label.get_window_extent(r)
    box = fig.bbox
    for what, bb in (("title", title), ("y label", ylab)):
        assert box.x0 <= bb.x0 and bb.x1 <= box.x1 and bb.y1 <= box.y1, what
    assert not title.overlaps(ylab)
    # the legend lists the verdicts drawn (all three points agree), not all five
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "claimed: >= 50 %", "agrees", "oracle"]
    plt.close(fig)
    # no oracle tick drawn (its bound not the claim's): no oracle key either
    claim["points"] = [{**pt, "oracle_bounds": False}] * 3
    assert MR.fig_map(doc, 0, tmp_path / "m.png")
    assert [t.get_text() for t in kept[-1].axes[0].get_legend().get_texts()] == [
        "claimed: >= 50 %", "agrees"]
    plt.close(kept[-1])


@pytest.mark.parametrize("base", [(0, 0), (1, 0), (0, 1)])
def test_an_axis_the_claim_does_not_see_is_drawn_as_one_line_of_cells(tmp_path, monkeypatch,
                                                                     base):
    """paper004's recal_positions scores the positions runs alone: the centrifuge axis left its
    three map columns identical. Such an axis is named as having no effect and drawn as one
    column (the scenario's), and the report says so; an axis along which one cell differs is
    drawn whole."""
    import matplotlib.pyplot as plt

    from fogbench.outputs import files as IO
    from fogbench.report import maps as MR

    kept = []
    monkeypatch.setattr(IO, "save_figure", lambda fig, path: kept.append(fig))

    def pt(mean):
        return {"verdict": "agrees", "mean": mean, "ci_low": mean - 3, "ci_high": mean + 3,
                "n": 5, "oracle_mean": 97.0, "oracle_ci_low": 96.0, "oracle_ci_high": 98.0,
                "oracle_bounds": True, "side": None}

    rows, cols = ["preset", "ARW x2"], ["+400/-600", "one way", "two ways"]
    points = [{"index": [i, j], "labels": [rows[i], cols[j]], "label": f"{rows[i]}, {cols[j]}",
               "base": (i, j) == base} for i in range(2) for j in range(3)]
    # the base point is the scenario's own run (more replicates): its numbers differ
    vals = [pt(80.7 if p["base"] else (82.0 if p["index"][0] == 0 else 46.0)) for p in points]
    row = {0: 82.0, 1: 46.0}
    claim = {"text": "recalibration removes the g drift", "protocol": "recal_positions",
             "in_sample": False, "metric": "drift_rms_dph", "better": "flnn", "than": "raw",
             "min_pct": 80.0, "max_pct": None, "points": vals, "source": "paper 004",
             "sentence": "agrees at every point"}
    doc = {"axes": [{"name": "device", "labels": rows, "source": "test"},
                    {"name": "centrifuge spins", "labels": cols, "source": "test"}],
           "points": points, "claims": [claim], "replicates_per_point": 5}
    assert MR.no_effect_axes(doc, 0) == [1]
    assert MR.fig_map(doc, 0, tmp_path / "m.png")
    ax = kept[-1].axes[0]
    assert [t.get_text() for t in ax.get_xticklabels()] == ["any of its 3 values"]
    assert "no effect" in ax.get_xlabel()
    cells = sorted(t.get_text() for t in ax.texts)
    # the map's numbers (not the scenario's own run's) in both rows, the scenario's noted in
    # its row's cell, wherever the scenario's point is
    assert [c.split(" %")[0] for c in cells] == ["+46.0", "+82.0"]
    noted = [c for c in cells if "the scenario's run:\n+80.7 %" in c]
    assert len(noted) == 1 and noted[0].startswith(f"+{row[base[0]]:.1f}")
    assert sum("scenario" in c for c in cells) == 1
    text = MR.render_map(doc, {("map", 0): "figures/map__0.png"})
    assert "**centrifuge spins** does not change this claim" in text
    plt.close(kept[-1])
    # one cell off: the axis matters there, every column is drawn
    claim["points"] = [dict(v) for v in vals]
    claim["points"][5]["mean"] = 50.0
    assert MR.no_effect_axes(doc, 0) == []
    assert MR.fig_map(doc, 0, tmp_path / "m.png")
    assert len(kept[-1].axes[0].get_xticklabels()) == 3
    plt.close(kept[-1])


def test_a_map_run_that_fails_on_a_write_names_every_folder_it_keeps(tmp_path, monkeypatch):
    """A claim-map run whose run directory cannot be written: its last lines name the
    scenario's work folder and each map point's, with the replicates each keeps."""
    from helpers import SMALL_SCENARIO, run_cli

    s = tmp_path / "s.toml"
    s.write_text(SMALL_SCENARIO + """
[montecarlo]
replicates = 2
[map]
replicates = 2
[[map.axes]]
name = "noise"
source = "test"
key = "fog.arw_deg_rt_h"
values = [0.06, 0.09]
""")
    from fogbench.run import scenario_dir

    def full_disk(*a, **k):
        raise OSError(28, "No space left on device", str(tmp_path / "run" / "metrics.json"))

    monkeypatch.setattr("fogbench.report.write_run_dir", full_disk)
    code, _, err = run_cli("run", s, "--out", tmp_path / "run", "--quiet", "--no-recording",
                           "--no-figures", "--jobs", "1")
    assert code == 1, err
    last = err.strip().splitlines()[-1]
    for folder in (".run.replicates", ".run.map0.replicates", ".run.map1.replicates"):
        assert str(tmp_path / folder) in last, last
        assert len(list((tmp_path / folder).glob("r*.json"))) >= 1
    assert scenario_dir   # the module whose note this is


def test_a_map_report_states_each_point_s_values_one_label_list_and_each_cell_s_count(
        tmp_path, monkeypatch):
    """The map's report said "3 replicates per point" where the scenario's own cell had 20,
    joined labels holding commas ("wander, 0.5 s") into one ambiguous list, and never said what
    a point sets: each point's values (the map file's keys, their units), the labels quoted
    and separated by ";", each cell's own count (report, figure, suite summary)."""
    import matplotlib.pyplot as plt

    from fogbench.outputs import files as IO
    from fogbench.report import maps as MR
    from fogbench.run.suite import _map_lines

    kept = []
    monkeypatch.setattr(IO, "save_figure", lambda fig, path: kept.append(fig))
    labels = ["white noise", "wander, 0.5 s", "wander, 2 s (preset)"]
    sets = [{"fog.gm_drift_dps": 0.0, "fog.arw_deg_rt_h": 0.79},
            {"fog.gm_drift_dps": 0.139, "fog.gm_time_constant_s": 0.5}, {}]
    points = [{"index": [i], "labels": [x], "label": x, "set": sets[i], "base": i == 2,
               "replicates": 20 if i == 2 else 3, "failed_replicates": 0}
              for i, x in enumerate(labels)]
    pt = {"verdict": "agrees", "mean": 61.0, "ci_low": 57.0, "ci_high": 65.0, "n": 3,
          "held": 0.9, "oracle_mean": None, "oracle_bounds": False, "side": None}
    claim = {"text": "the WNN beats the Kalman filter", "protocol": "held_out",
             "in_sample": False, "metric": "std_dps", "better": "wnn", "than": "kalman",
             "min_pct": 50.0, "max_pct": None, "points": [pt, pt, pt], "source": "paper 000",
             "sentence": "holds everywhere"}
    doc = {"axes": [{"name": "source of the 0.13 deg/s", "labels": labels, "numeric": None,
                     "source": "paper 000"}],
           "points": points, "claims": [claim], "replicates_per_point": 3}
    lines = MR.render_map(doc, {}).splitlines()
    assert ("- axis **source of the 0.13 deg/s** (3 values): \"white noise\"; "
            "\"wander, 0.5 s\"; \"wander, 2 s (preset)\". Range from: paper 000") in lines
    assert "| white noise | fog.gm_drift_dps = 0; fog.arw_deg_rt_h = 0.79 | 3 |" in lines
    assert "| wander, 0.5 s | fog.gm_drift_dps = 0.139; fog.gm_time_constant_s = 0.5 | 3 |" \
        in lines
    assert ("| wander, 2 s (preset) (the scenario) | nothing: the scenario's own values | 20 |"
            in lines)
    assert "3 replicates per point, the scenario's own point its 20" in lines[2]
    assert "| wander, 2 s (preset) (the scenario) | 20 | +61.0 [+57.0, +65.0] % | agrees | - |" \
        in lines
    assert "| wander, 0.5 s | 3 | +61.0 [+57.0, +65.0] % | agrees | - |" in lines
    assert MR.fig_map(doc, 0, tmp_path / "m.png")
    ticks = [t.get_text() for t in kept[-1].axes[0].get_xticklabels()]
    assert ticks == ["white noise\n3 replicates", "wander, 0.5 s\n3 replicates",
                     "wander, 2 s (preset)\n(the scenario)\n20 replicates"]
    plt.close(kept[-1])
    assert "3 replicates per point, the scenario's own point its 20" in _map_lines("s", doc)[0]
    # every point with the map's count: one number
    for p in points:
        p["replicates"] = 3
    assert "(3 replicates per point, the scenario's own seeds;" in MR.render_map(doc, {})
