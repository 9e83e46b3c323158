"""The scenario runner: simulate the runs, fit every method, score it against the truth.

For every protocol and every (fit, score) pairing it fits each method on the fit samples (with the
protocol's reference: the truth rate, an ideal lab's, or ``reference = "lab"``: the rate and the
specific force a lab computes from the table's commands and its nominal site, ``sim/lab.py``;
methods see the chosen specific force at scoring too) and scores it on the score samples, beside
the raw output and the oracle (raw minus the true deterministic error terms: the floor that no
compensator of the error model can beat without also filtering the signal). A method that fails
(diverges, or raises) is recorded as failed with its message and the run goes on.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import hashlib
import json
import math
import time
import traceback
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

import fogcomp
from fogbench.outputs.files import atomic_write_text, json_ready, versions
from fogbench.run.metrics import IMPROVEMENT_OF
from fogbench.run.seeds import replicate_seed
from fogbench.scenario import (
    Plan,
    Protocol,
    Scenario,
    Selection,
    expand,
    load_plan,
    load_scenario,
    select_indices,
)
from fogbench.scenario.load import RUNNER_SECTIONS
from fogcomp import GyroData
from fogcomp import metrics as M
from fogcomp._limits import MethodExit, MethodTimeout, no_exit, sigint_seen, time_limit
from fogcomp.units import DPH, DPS
from sim.rig import RunData, simulate_run
from sim.thermal import ThermalHold

__all__ = ["run_scenario", "ScenarioResult", "Scored"]

DETERMINISTIC = ("constant_bias", "switch_on_bias", "rate_ramp", "scale_factor", "misalignment",
                 "g_sensitivity", "g2_sensitivity", "temperature")


@dataclass
class Piece:
    """Selected (and possibly smoothed) samples of one run: inputs, truth, terms."""

    run: str
    fs: float
    t: np.ndarray
    raw: np.ndarray
    truth: np.ndarray
    g: np.ndarray
    temp: np.ndarray
    temp_rate: np.ndarray
    oracle: np.ndarray
    ref: np.ndarray | None = None         # the reference rate the fit is handed (protocol's
    #                                       reference: the lab's, sim/lab.py; None: the truth)
    saturated: np.ndarray | None = None   # (n,) float: fraction of the samples clipped (0 or 1
    #                                       unsmoothed; the fraction of the block when smoothed)
    unmodelled: tuple[str, ...] = ()      # the error terms outside the filter oracle's noise
    #                                       model that vary over the piece (:func:`varying_terms`)

    def gyro(self) -> GyroData:
        return GyroData(rate=self.raw, fs=self.fs, g=self.g, temp=self.temp,
                        temp_rate=self.temp_rate)


@dataclass
class Scored:
    """One scored piece: the outputs of raw, oracle and every method."""

    protocol: str
    run: str
    piece: Piece
    outputs: dict[str, np.ndarray] = field(default_factory=dict)   # label -> compensated rate
    metrics: dict[str, dict] = field(default_factory=dict)         # label -> metric -> value
    seed_metrics: dict[str, list] = field(default_factory=dict)    # label -> [metrics per seed]


@dataclass
class ScenarioResult:
    scenario: Scenario
    plan: Plan
    data: dict[str, RunData]
    scored: list[Scored]
    fits: dict  # protocol -> method label -> list of fit records
    metrics: dict
    wall_s: float


def _smooth(x: np.ndarray, k: int) -> np.ndarray:
    n = (x.shape[0] // k) * k
    return x[:n].reshape((n // k, k) + x.shape[1:]).mean(axis=1)


def make_piece(rd: RunData, sel: Selection, prot: Protocol, axis_j: int,
               lab_ref: tuple | None = None) -> Piece:
    """The samples of one run that ``sel`` picks: selection, then smoothing (when the protocol
    smooths, in blocks that never straddle a gap), then the stride (over the smoothed samples).

    With the protocol's ``reference = "lab"`` the reference rate and the specific force a method
    is handed are the lab's, ``lab_ref`` = (rate, specific force) of the whole run from
    ``sim.lab.lab_reference``; the truth stays for scoring."""
    plain = replace(sel, stride=1, offset=0)
    idx = select_indices(plain, rd.run, rd.fs, prot.skip_s, rd.truth.table_rate)
    truth = rd.truth_axis(axis_j)
    ref, g = truth, rd.truth.specific_force
    if prot.reference == "lab":
        if lab_ref is None:
            raise ValueError(f"protocol {prot.name!r}: reference = 'lab' needs the lab's "
                             "reference of the run")
        rate_lab, g = lab_ref
        ref = rate_lab[:, "xyz".index(rd.axes[axis_j])]
    det = sum((rd.fog.terms[k][:, axis_j] for k in DETERMINISTIC if k in rd.fog.terms),
              np.zeros(rd.n))
    # a compensator sees what a lab sees: the temperature sensor's reading and the dT/dt
    # differenced from it; the oracle (raw minus the true terms) keeps the true coil temperature
    sat = rd.fog.saturated
    cols = dict(t=rd.truth.t, raw=rd.fog.raw[:, axis_j], truth=truth, ref=ref,
                g=g, temp=rd.thermal.sensor,
                temp_rate=rd.thermal.sensor_rate, oracle=rd.fog.raw[:, axis_j] - det,
                saturated=(np.zeros(rd.n) if sat is None else sat[:, axis_j].astype(float)))
    fs = rd.fs
    if prot.smooth_s:
        k = int(round(prot.smooth_s * fs))
        parts = [p for p in np.split(idx, np.flatnonzero(np.diff(idx) != 1) + 1) if p.size >= k]
        cols = {c: (np.concatenate([_smooth(v[p], k) for p in parts]) if parts else v[:0])
                for c, v in cols.items()}
        fs = fs / k
    else:
        cols = {c: v[idx] for c, v in cols.items()}
    if sel.stride > 1:
        cols = {c: v[sel.offset::sel.stride] for c, v in cols.items()}
    if cols["raw"].size == 0:
        raise ValueError(f"selection {sel.describe()} of protocol {prot.name!r} has no samples")
    # (smoothed pieces are not the filter oracle's: their terms are not looked at)
    unmodelled = () if prot.smooth_s else \
        varying_terms(rd, axis_j, idx[sel.offset::sel.stride] if sel.stride > 1 else idx)
    return Piece(run=rd.run.name, fs=fs, unmodelled=unmodelled, **cols)


#: The error terms the filter oracle's noise model carries (:func:`noise_autocovariance`):
#: every other term is inside it only where it is constant over the piece (then it is part of
#: the constant the oracle estimates)
ORACLE_FILTER_NOISE_TERMS = ("arw", "bias_instability", "gm_drift", "quantization")

#: A term is constant over a piece when its standard deviation there is at most this fraction
#: of its largest size (a constant term varies by rounding only, ~1e-12; the terms that move
#: vary by tenths of their size)
CONSTANT_RTOL = 1e-6


def varying_terms(rd: RunData, axis_j: int, idx: np.ndarray) -> tuple[str, ...]:
    """The true error terms of the samples ``idx`` of a run that the filter oracle's noise
    model lacks and that are not constant there: a temperature term where the temperature
    moves, g-sensitivity where the specific force changes, scale factor or misalignment where
    the rates change, a rate ramp, a rate random walk, clipping (in ``sim.fog``'s order)."""
    out = []
    for name, v in rd.fog.terms.items():
        if name in ORACLE_FILTER_NOISE_TERMS:
            continue
        x = np.asarray(v[idx, axis_j], dtype=float)
        if x.size > 1 and np.std(x) > CONSTANT_RTOL * np.max(np.abs(x)):
            out.append(name)
    return tuple(out)


def concat(pieces: list[Piece]) -> Piece:
    if len(pieces) == 1:
        return pieces[0]
    # (a term constant in each piece but not across them is not seen: a joined piece is a fit
    # piece, which the filter oracle never scores)
    unmodelled = tuple(dict.fromkeys(n for p in pieces for n in p.unmodelled))
    return Piece(run="+".join(p.run for p in pieces), fs=pieces[0].fs, unmodelled=unmodelled,
                 **{c: np.concatenate([getattr(p, c) for p in pieces])
                    for c in ("t", "raw", "truth", "g", "temp", "temp_rate", "oracle", "ref",
                              "saturated")})


def thermal_segments(rd: RunData) -> list[tuple[str, float, float]]:
    """(label, start_s, end_s) of the thermal program's holds and ramps."""
    if rd.run.thermal is None or not rd.run.thermal.steps:
        return []
    prog = rd.run.thermal
    out, t, temp = [], 0.0, prog.start
    for st in prog.steps:
        if isinstance(st, ThermalHold):
            out.append((f"hold {temp:g} C", t, t + st.duration))
            t += st.duration
        else:
            d = abs(st.to - temp) / st.rate
            out.append((f"ramp {temp:g}..{st.to:g} C", t, t + d))
            t, temp = t + d, st.to
    return out


def score(out: np.ndarray, piece: Piece, raw_ref: dict | None = None) -> dict:
    """Metrics of a compensated output against the truth, units in every name."""
    err = out - piece.truth
    m = {
        "std_dps": M.std(out) / DPS,
        "std_dph": M.std(out) / DPH,
        "rmse_dph": M.rmse(out, piece.truth) / DPH,
        "mean_error_dph": float(np.mean(err)) / DPH,
    }
    ang = M.integrated_angle_error(out, piece.truth, piece.fs)
    if piece.saturated is not None and np.any(piece.saturated):
        m["saturated_pct"] = 100.0 * float(np.mean(piece.saturated))   # output clipped
    m["angle_error_final_deg"] = math.degrees(ang["angle_error_final_rad"])
    m["angle_error_max_deg"] = math.degrees(ang["angle_error_max_rad"])
    # pieces made of separate static dwells (multi-position tests): the drift left at each
    # position is the mean error over its dwell, which averages the noise out
    gaps = np.flatnonzero(np.diff(piece.t) > 1.5 / piece.fs) + 1
    if gaps.size:
        means = [np.mean(b) for b in np.split(err, gaps) if b.size]
        m["drift_rms_dph"] = float(np.sqrt(np.mean(np.square(means)))) / DPH
    dur = out.size / piece.fs
    if dur >= 1000.0 and out.size >= 512 and piece.fs >= 1.0 and gaps.size == 0:
        # noise identification of the error against the truth: the one identifier
        # (fogcomp.noise through fogcomp.metrics.noise_terms), the datasheet floor beside it
        ds = M.noise_terms(err, piece.fs)
        for k in ("arw_deg_rt_h", "bias_instability_dph", "rrw_dph_rt_h",
                  "bias_instability_floor_dph", "gm_sigma_dph", "gm_tau_s"):
            if ds.get(k) is not None:
                m[k] = ds[k]
    if dur >= 300.0 and gaps.size == 0:  # of one contiguous record, not of stitched dwells
        m["bias_stability_100s_dph"] = M.bias_stability(out, piece.fs, 100.0) / DPH
    if raw_ref is not None:
        for key, name in IMPROVEMENT_OF.items():
            if key in m and raw_ref.get(key):
                m[name] = 100.0 * (1.0 - m[key] / raw_ref[key])
    return m


def _coef_record(model) -> dict | None:
    for attr in ("coef_dph", "coef_dict"):
        fn = getattr(model, attr, None)
        if callable(fn):
            try:
                return {k: float(v) for k, v in fn().items() if np.isscalar(v)}
            except Exception:  # a method without coefficients for this fit
                return None
    return None


def _ident_record(model) -> dict | None:
    ident = getattr(model, "identifiability_", None)
    if ident is None:
        return None
    rec = {"rank": int(ident.rank), "n_terms": int(ident.n_terms),
           "condition": float(ident.condition), "summary": list(ident.summary)}
    names = getattr(ident, "names", None)
    stderr = getattr(ident, "stderr", None)
    if names is not None and stderr is not None:
        # the FLNN's d0..d9 are in rad/s per g^k: deg/h per g^k for people
        rec["stderr_dph"] = {n: (None if not np.isfinite(s) else float(s) / DPH)
                             for n, s in zip(names, np.asarray(stderr)) if n in TERM_NAMES}
    return rec


def _only_methods(sc, plan, methods: list[str] | None):
    """The plan with only the methods labelled in ``methods`` (all of them when none is named)."""
    if methods:
        unknown = sorted(set(methods) - {m.label for m in plan.methods})
        if unknown:
            raise ValueError(f"{sc.path}: no method labelled {unknown}; methods: "
                             f"{[m.label for m in plan.methods]}")
        plan = replace(plan, methods=tuple(m for m in plan.methods if m.label in methods))
    return plan


def _simulate_runs(sc, plan, replicate: int, truths: dict, say) -> tuple[dict, dict]:
    """(run -> RunData, run -> seed) of one replicate; the table motion cached in ``truths``."""
    data, seeds = {}, {}
    for i, run in enumerate(sc.runs):
        cached = truths.get(run.name)
        say(f"simulate {run.name} ({i + 1}/{len(sc.runs)}, {run.duration:g} s)"
            + (f", replicate {replicate}" if replicate else "")
            + (" (table motion reused)" if cached is not None else ""))
        seeds[run.name] = run_seed(sc, plan, replicate, i)
        data[run.name] = simulate_run(sc.rig, run, seed=seeds[run.name], truth=cached)
        truths[run.name] = data[run.name].truth
    return data, seeds


def _lab_references(sc, plan, data: dict, seeds: dict) -> dict:
    """The lab's references of every run, once (empty unless a protocol has reference = "lab")."""
    if not any(p.reference == "lab" for p in plan.protocols):
        return {}
    from sim.lab import LabKnowledge, lab_reference

    # (an accelerometer triad, gravity_source = "accelerometer", draws its noise from the
    # run's own seed, sim.lab.accelerometer_reading)
    return {name: lab_reference(rd.truth, sc.table, plan.lab or LabKnowledge(),
                                seed=seeds[name])
            for name, rd in data.items()}


def _score_references(items: list[Scored], sc, axis_j: int = 0) -> None:
    """Score raw, the oracle and (where it is computed) the filter oracle on every piece; where
    the filter oracle's noise model does not hold, its entry says so (no value, the reason).
    ``axis_j``: the sensitive axis scored (a triad device file's axes have their own terms)."""
    fog = sc.fog[axis_j] if isinstance(sc.fog, tuple) else sc.fog
    for it in items:
        it.outputs["raw"] = it.piece.raw
        it.outputs["oracle"] = it.piece.oracle
        it.metrics["raw"] = score(it.piece.raw, it.piece)
        it.metrics["oracle"] = score(it.piece.oracle, it.piece, it.metrics["raw"])
        of = oracle_filter(it.piece, fog, sc.fs)
        if of is not None:
            it.metrics["oracle_filter"] = score(of, it.piece, it.metrics["raw"])
        elif it.piece.unmodelled and oracle_filter_reason(it.piece, fog, sc.fs) == \
                outside_model_reason(it.piece.unmodelled):
            # a piece it would apply to but whose terms its model lacks: no value, the reason
            # (the other pieces, moving, smoothed, gapped, long, are not the filter oracle's)
            it.metrics["oracle_filter"] = {"status": "not computed",
                                           "reason": outside_model_reason(it.piece.unmodelled)}


def _score_fit(model, rec: dict, items: list[Scored], label: str, first: bool,
               per_seed: bool, data: dict, axis_j: int, timeout_s: float | None) -> None:
    """Score one fit on every piece (the first fit's are the method's; with K > 1, each kept)."""
    for it in items:
        m, out = _score_model(model, rec, it, data[it.run], axis_j, timeout_s)
        if first:
            it.metrics[label] = m
            if out is not None:
                it.outputs[label] = out
        if per_seed:
            it.seed_metrics.setdefault(label, []).append(m)


def _fit_keys(ms, seeds: list, piece: Piece) -> list[tuple]:
    """What decides each seed's fit: the method, its parameters, its seed and the bytes it is
    handed (the
    record's inputs and the reference rate). Two protocols whose fits share a key (a lab
    protocol and its ideal-lab twin where the lab's reference equals the truth, as on a static
    table) get one fit: the second is the first's, not a new draw. A method of fogcomp's own is
    keyed by the inputs its ``requires`` names (the only ones its code reads: a temperature
    model is not refitted because the lab's specific force differs from the truth's in the
    last bit); a plug-in by all of them."""
    h = hashlib.blake2b(digest_size=16)
    g = piece.gyro()
    ref = piece.truth if piece.ref is None else piece.ref
    names = ("g", "temp", "temp_rate")
    try:
        cls = fogcomp.get_method(ms.name)
    except Exception:   # a plug-in that does not load (its fit is recorded as failed)
        cls = None
    if cls is not None and cls.__module__.startswith("fogcomp."):
        names = tuple(n for n in names if n in cls.requires)
    for a in (g.rate, ref, *(getattr(g, n) for n in names)):
        if a is None:
            h.update(b"-")
            continue
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())
    h.update(repr(float(g.fs)).encode())
    params = json.dumps(json_ready(ms.params), sort_keys=True, default=repr)
    digest = h.hexdigest()      # once for the K seeds: the bytes are the same
    return [(ms.name, params, seed, digest) for seed in seeds]


def _keep(fitted: dict, key, protocol: str, rec: dict, model) -> None:
    """Keep a fit for later protocols (:func:`_fit_keys`): a copy taken before it scores
    anything (a plug-in whose ``compensate`` changes its own state would otherwise hand the
    next protocol another model than a refit), and only a fit that succeeded (a failure, a
    time limit above all, is not a property of the bytes)."""
    if model is None or rec.get("status") != "ok":
        return
    try:
        fitted[key] = (protocol, copy.deepcopy(rec), copy.deepcopy(model))
    except Exception:   # a plug-in's model that does not copy: the next protocol fits again
        pass


def _reuse(entry, fit_sel, score_sel) -> tuple | None:
    """A copy of an earlier protocol's fit (record, model) with the same key, the record
    saying where it comes from and what it is scored on here; or None (none kept)."""
    if entry is None:
        return None
    first, rec, model = entry
    try:
        model = copy.deepcopy(model)
    except Exception:   # a plug-in's model that does not copy: fit it again
        return None
    rec = copy.deepcopy(rec)
    rec["fit_on"] = [s.describe() for s in fit_sel]
    rec["scored_on"] = [s.describe() for s in score_sel]
    rec["fit_reused_from"] = first
    return rec, model


def _run_protocol(prot, sc, plan, data: dict, axis_j: int, lab_refs: dict, replicate: int,
                  method_seeds: int, say, fitted: dict | None = None
                  ) -> tuple[list[Scored], dict]:
    """One protocol: (its scored pieces, label -> fit records) over its (fit, score) pairings.
    ``fitted`` (fit key -> (protocol, record, model)) carries fits across protocols:
    :func:`_fit_keys`."""
    fitted = {} if fitted is None else fitted
    scored: list[Scored] = []
    fits: dict = {m.label: [] for m in plan.methods}
    for fit_sel, score_sel in expand(prot, sc):
        fit_piece = concat([make_piece(data[s.run], s, prot, axis_j, lab_refs.get(s.run))
                            for s in fit_sel])
        pieces = [make_piece(data[s.run], s, prot, axis_j, lab_refs.get(s.run))
                  for s in score_sel]
        items = [Scored(prot.name, p.run, p) for p in pieces]
        _score_references(items, sc, axis_j)
        for ms in plan.methods:
            say(f"{prot.name}: fit {ms.label} on {', '.join(s.describe() for s in fit_sel)}")
            seeded = ms.failed is None and fogcomp.get_method(ms.name).random and \
                ms.params.get("random_state") is None
            seeds = [method_seed(sc, plan, prot, ms, fit_sel, replicate, k) if seeded else None
                     for k in range(method_seeds if seeded else 1)]
            keys = _fit_keys(ms, seeds, fit_piece)
            done = [_reuse(fitted.get(key), fit_sel, score_sel) for key in keys]
            new = [k for k, d in enumerate(done) if d is None]
            if new:
                made = _fit_many(ms, [seeds[k] for k in new], fit_piece, fit_sel, score_sel,
                                 plan.fit_timeout_s)
                for k, (rec, model) in zip(new, made):
                    done[k] = rec, model
                    _keep(fitted, keys[k], prot.name, rec, model)
            for k, (rec, model) in enumerate(done):
                _score_fit(model, rec, items, ms.label, k == 0, seeded and method_seeds > 1,
                           data, axis_j, plan.fit_timeout_s)
                if k == 0:
                    fits[ms.label].append(rec)
        scored.extend(items)
    return scored, fits


def run_scenario(path, progress=None, methods: list[str] | None = None, replicate: int = 0,
                 method_seeds: int = 1, truths: dict | None = None,
                 overrides: dict | None = None) -> ScenarioResult:
    """Simulate and score one scenario file. ``progress(message)`` reports each step.

    ``replicate`` r draws every random stream (the FOG's switch-on draws and noise, the
    temperature sensor's noise, every random method's start) from coordinates (scenario seed, r,
    run, stream) alone (:func:`run_seed`, :func:`method_seed`); replicate 0 uses the runs' own
    seeds, as a single
    run always did. ``method_seeds`` K > 1 fits every method that draws random numbers K times
    per fit, with K seeds (their metrics in ``Scored.seed_metrics``). ``truths`` (run name ->
    ``Truth``) caches the deterministic table motion between replicates: filled when empty.
    ``overrides`` (dotted path -> value) make it a point of the scenario's claim map.
    """
    t_start = time.monotonic()
    say = progress or (lambda msg: None)
    sc = load_scenario(path, extra_sections=RUNNER_SECTIONS, overrides=overrides)
    plan = _only_methods(sc, load_plan(sc), methods)
    axis_j = sc.axes.index(plan.axis)
    truths = {} if truths is None else truths
    data, seeds = _simulate_runs(sc, plan, replicate, truths, say)
    lab_refs = _lab_references(sc, plan, data, seeds)
    scored: list[Scored] = []
    fits: dict = {}
    fitted: dict = {}
    for prot in plan.protocols:
        prot_scored, fits[prot.name] = _run_protocol(prot, sc, plan, data, axis_j, lab_refs,
                                                     replicate, method_seeds, say, fitted)
        scored.extend(prot_scored)

    metrics = _metrics_doc(sc, plan, data, scored, fits, time.monotonic() - t_start)
    metrics["replicate"] = replicate
    metrics["method_seeds"] = method_seeds
    return ScenarioResult(sc, plan, data, scored, fits, metrics, time.monotonic() - t_start)


#: Longest piece the filter oracle is computed for (its Toeplitz solve is O(n^2)).
ORACLE_FILTER_MAX_SAMPLES = 20_000


def noise_autocovariance(params, fs: float, n: int) -> np.ndarray:
    """Autocovariance of the FOG's stationary noise at lags 0..n-1, (rad/s)^2, from its
    configured terms (``sim.fog``): white rate (N^2 fs at lag 0), the Gauss-Markov drift
    (sigma^2 phi^|h|), the flicker's Gauss-Markov components (their variance and corners,
    ``sim.fog.bias_instability_components``) and the pulse counter's quantisation (a white
    angle error of one pulse q: 2 (q^2/12) fs^2 at lag 0, -(q^2/12) fs^2 at lag 1). The rate
    random walk and ramp are not stationary: left out (none of the filter claims' devices has
    them)."""
    from sim.fog import bias_instability_components

    h = np.arange(n, dtype=float)
    c = np.zeros(n)
    c[0] += params.arw**2 * fs
    if params.gm_drift:
        c += params.gm_drift**2 * np.exp(-h / (fs * params.gm_time_constant))
    if params.bias_instability:
        corners, sigma = bias_instability_components(params.bias_instability, params.bi_band,
                                                     params.bi_per_decade)
        for fc in corners:
            c += sigma**2 * np.exp(-2.0 * np.pi * fc * h / fs)
    if params.quantization:
        q2 = params.quantization**2 / 12.0 * fs**2
        c[0] += 2.0 * q2
        if n > 1:
            c[1] -= q2
    return c


#: How a report names each term the filter oracle's noise model lacks (:func:`varying_terms`)
TERM_PHRASES = {"temperature": "a temperature drift", "rrw": "a rate random walk",
                "rate_ramp": "a rate ramp",
                "g_sensitivity": "a g-sensitivity error that changes with the specific force",
                "g2_sensitivity": "a g^2-sensitivity error that changes with the specific force",
                "scale_factor": "a scale-factor error that changes with the rate",
                "misalignment": "a misalignment error that changes with the rates",
                "saturation": "clipping at the measurement range"}


def outside_model_reason(terms: tuple[str, ...]) -> str:
    """Why the filter oracle is not computed on a piece with these varying terms, in a phrase:
    "the piece has a temperature drift and a rate random walk the noise model lacks"."""
    names = [TERM_PHRASES.get(t, f"a varying {t} term") for t in terms]
    listed = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
    return f"the piece has {listed} the noise model lacks"


def oracle_filter_reason(piece: Piece, params, fs_run: float) -> str | None:
    """Why the filter oracle is not computed on ``piece`` (None: it is). Its model is a
    constant plus the stationary noise of :func:`noise_autocovariance` (white rate,
    Gauss-Markov drift, flicker, quantisation); it does not apply to a piece too short or too
    long (``ORACLE_FILTER_MAX_SAMPLES``), smoothed, gapped, on a rate that is not constant, or
    of a device without noise, and it does not hold where an error term outside that model
    varies over the piece (``Piece.unmodelled``: a temperature drift, a rate random walk, a
    ramp, ...; a constant term, such as a bias, is part of the constant it estimates). Only
    the last is a piece where a filter claim could otherwise be bounded by it: the runner
    records that reason (:func:`_score_references`)."""
    n = piece.raw.size
    if n < 2:
        return "the piece has fewer than 2 samples"
    if n > ORACLE_FILTER_MAX_SAMPLES:
        return f"the piece has more than {ORACLE_FILTER_MAX_SAMPLES} samples"
    if abs(piece.fs - fs_run) > 1e-9 * fs_run:
        return "the piece is smoothed"
    if np.any(np.diff(piece.t) > 1.5 / piece.fs):
        return "the piece has gaps"
    noise = piece.raw - piece.truth
    if np.std(piece.truth) > 0.01 * max(np.std(noise), 1e-300):
        return "the true rate is not constant"
    if not noise_autocovariance(params, piece.fs, 1)[0] > 0:
        return "the device has no noise"
    if piece.unmodelled:
        return outside_model_reason(piece.unmodelled)
    return None


def oracle_filter(piece: Piece, params, fs_run: float) -> np.ndarray | None:
    """The best a denoiser can do on a piece whose true rate is constant, given the true noise
    model: the generalised least-squares estimate of that constant, weighted by the inverse of
    the noise's covariance (``noise_autocovariance``, a Toeplitz solve), output at every
    sample. A filter claim that asks more than it gives is untestable, as a compensation claim
    beyond the oracle of the deterministic terms is. None where it does not apply or its model
    does not hold (:func:`oracle_filter_reason` says why)."""
    from scipy.linalg import solve_toeplitz

    if oracle_filter_reason(piece, params, fs_run) is not None:
        return None
    n = piece.raw.size
    c = noise_autocovariance(params, piece.fs, n)
    w = solve_toeplitz(c, np.ones(n))
    return np.full(n, float(w @ piece.raw / w.sum()))


#: What a method may raise and be reported as failed for (a KeyboardInterrupt only when no
#: Ctrl-C arrived: the method raised it itself; see :func:`_guarded`)
_METHOD_FAILURES = (Exception, MethodTimeout, MethodExit, SystemExit)


@contextlib.contextmanager
def _guarded(what: str, timeout_s: float | None):
    """A method's code within its time limit, with ``os._exit`` a failure of the method and a
    KeyboardInterrupt it raises itself (no Ctrl-C arrived) one too; a real Ctrl-C stops the
    run as always."""
    with sigint_seen() as seen:
        try:
            with time_limit(timeout_s, what, note=" (fit_timeout_s)"), no_exit(what):
                yield
        except KeyboardInterrupt as exc:
            if seen:
                raise
            raise MethodExit(f"{what} raised KeyboardInterrupt itself (no Ctrl-C was "
                             f"pressed){': ' + str(exc) if str(exc) else ''}") from None


def _fit(ms, seed, fit_piece: Piece, fit_sel, score_sel, timeout_s: float | None = None):
    """Make and fit one method; a failure is recorded (rec["status"]), never raised."""
    return _fit_many(ms, [seed], fit_piece, fit_sel, score_sel, timeout_s)[0]


def _fit_many(ms, seeds: list, fit_piece: Piece, fit_sel, score_sel,
              timeout_s: float | None = None) -> list:
    """Make and fit one method at each seed (a random method's starts, None for one fit of a
    deterministic method): [(record, model or None)], a failure recorded, never raised. A
    method that trains its starts together (its class overrides ``fit_starts``: the same models
    as one by one) gets them in one call, under K times ``timeout_s`` (a start that hangs then
    fails them all), each record's ``fit_time_s`` the call's time over K; any other method
    fits each start alone under its own limit."""
    recs = []
    for seed in seeds:
        rec = {"fit_on": [s.describe() for s in fit_sel],
               "scored_on": [s.describe() for s in score_sel]}
        if seed is not None:
            rec["random_state"] = seed
        recs.append(rec)
    if getattr(ms, "failed", None):
        for rec in recs:
            rec.update(status="failed", error=ms.failed, warnings=[])
        return [(rec, None) for rec in recs]
    K = len(seeds)
    if K > 1 and _fits_one_by_one(ms):
        return [_fit_many(ms, [seed], fit_piece, fit_sel, score_sel, timeout_s)[0]
                for seed in seeds]
    outcomes, models = None, [None] * K
    label = f"{ms.label}: fit" + (f" ({K} starts)" if K > 1 else "")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with _guarded(label, None if timeout_s is None else timeout_s * K):
                models = [fogcomp.make_method(ms.name, **ms.params) for _ in seeds]
                for model, seed in zip(models, seeds):
                    if seed is not None:
                        model.random_state = seed
                ref = fit_piece.truth if fit_piece.ref is None else fit_piece.ref
                t0 = time.perf_counter()
                if K == 1:
                    models[0].fit(fit_piece.gyro(), ref)
                    outcomes = [(None, [])]
                else:
                    outcomes = type(models[0]).fit_starts(models, fit_piece.gyro(), ref)
                    if not (isinstance(outcomes, list) and len(outcomes) == K and all(
                            isinstance(o, tuple) and len(o) == 2 for o in outcomes)):
                        raise TypeError(f"{ms.label}: fit_starts returned "
                                        f"{type(outcomes).__name__}, not a list of {K} "
                                        "(exception or None, warnings) pairs")
                dt = (time.perf_counter() - t0) / K
        except _METHOD_FAILURES as exc:  # any failure of a method is reported, not fatal
            error = f"{type(exc).__name__}: {exc}"
            tb = traceback.format_exc(limit=3)
            outcomes = None
    shared = [f"{w.category.__name__}: {w.message}" for w in caught]
    out = []
    for k, rec in enumerate(recs):
        if outcomes is None:
            rec.update(status="failed", error=error, traceback=tb)
            model = None
            own = []
        else:
            exc, own = outcomes[k]
            own = [f"{w.category.__name__}: {w.message}" for w in own]
            model = models[k]
            if exc is None:
                rec["status"] = "ok"
                rec["fit_time_s"] = dt
            else:
                rec.update(status="failed", error=f"{type(exc).__name__}: {exc}",
                           traceback="".join(traceback.format_exception(exc, limit=3)))
                model = None
        rec["warnings"] = sorted(set(shared + own))
        if model is not None:
            _learned(rec, model)
        out.append((rec, model))
    return out


def _fits_one_by_one(ms) -> bool:
    """True when the method's class does not train its starts together (its ``fit_starts`` is
    the default): each start is then fitted alone, under its own time limit."""
    try:
        cls = fogcomp.get_method(ms.name)
    except Exception:   # a plug-in that does not load: recorded as failed per start
        return True
    return getattr(cls.fit_starts, "__func__", None) is fogcomp.Compensator.fit_starts.__func__


def _learned(rec: dict, model) -> None:
    """What a method learned, into its fit record, as far as it has the usual attributes (a
    plug-in may not)."""
    try:
        rec["coefficients"] = _coef_record(model)
        rec["identifiability"] = _ident_record(model)
        for attr in ("level_", "n_iter_", "n_epochs_", "initial_loss_"):
            if hasattr(model, attr):
                v = getattr(model, attr)
                rec[attr.rstrip("_")] = v if isinstance(v, (int, str)) else float(v)
        if hasattr(model, "loss_curve_"):
            rec["loss_curve"] = [float(x) for x in np.asarray(model.loss_curve_)]
    except _METHOD_FAILURES as exc:
        rec["warnings"].append(f"its learned attributes could not be recorded "
                               f"({type(exc).__name__}: {exc})")


def _score_model(model, rec: dict, it: "Scored", rd: RunData, axis_j: int,
                 timeout_s: float | None = None):
    """Compensate one scored piece with a fitted model: (metrics, output or None)."""
    if model is None:
        return {"status": "failed", "error": rec["error"]}, None
    try:
        with _guarded("compensate", timeout_s):
            t0 = time.perf_counter()
            out = np.asarray(model.compensate(it.piece.gyro()), dtype=float)
            dt = time.perf_counter() - t0
    except _METHOD_FAILURES as exc:
        return {"status": "failed", "error": f"{type(exc).__name__}: {exc}"}, None
    if out.shape != it.piece.raw.shape:
        return {"status": "failed", "error": f"compensated output has shape {out.shape}, "
                f"expected {it.piece.raw.shape}"}, None
    if not np.all(np.isfinite(out)):
        return {"status": "failed", "error": "compensated output is not finite"}, None
    m = score(out, it.piece, it.metrics["raw"])
    m["fit_time_s"] = rec["fit_time_s"]
    m["compensate_time_s"] = dt
    m["compensate_samples_per_s"] = out.size / dt if dt > 0 else None
    truth_coef = _true_coefficients(rd, axis_j)
    if rec.get("coefficients") and truth_coef:
        se = (rec.get("identifiability") or {}).get("stderr_dph", {})
        ident = [n for n in TERM_NAMES if se.get(n, 0.0) is not None]
        m.update(_coef_errors(rec["coefficients"], truth_coef, ident, se))
    return m, out


def scenario_seed(sc, plan) -> int:
    """The scenario's Monte Carlo seed: ``[montecarlo] seed``, else a hash of its name."""
    import zlib

    return plan.mc_seed if plan.mc_seed is not None else zlib.crc32(sc.name.encode())


def run_seed(sc, plan, replicate: int, run_index: int) -> int:
    """The seed of run ``run_index``'s random draws in ``replicate`` (0: the run's own seed)."""
    if replicate == 0:
        return sc.runs[run_index].seed
    return replicate_seed(scenario_seed(sc, plan), replicate, run_index, "fog")


def method_seed(sc, plan, prot, ms, fit_sel, replicate: int, k: int) -> int:
    """A random method's seed for one fit: replicate 0, k 0 keeps the single run's seed."""
    if replicate == 0 and k == 0:
        return _method_seed(sc, prot, ms, fit_sel)
    runs = [r.name for r in sc.runs]
    first = runs.index(fit_sel[0].run) if fit_sel and fit_sel[0].run in runs else 0
    # the members of a sweep share their random numbers: a band shows the setting, not the start
    stream = (f"method:{prot.seed_name}:{ms.group or ms.label}:"
              f"{'|'.join(s.run for s in fit_sel)}:{k}")
    return replicate_seed(scenario_seed(sc, plan), replicate, first, stream)


def _method_seed(sc, prot, ms, fit_sel) -> int:
    """A method's seed, derived from the scenario, protocol, method and fit runs (stable)."""
    import zlib

    key = f"{sc.name}|{prot.seed_name}|{ms.label}|{'|'.join(s.run for s in fit_sel)}"
    return zlib.crc32(key.encode())


TERM_NAMES = ("d0", "d1", "d2", "d3", "d4", "d5", "d6", "d7", "d8", "d9")


def _true_coefficients(rd: RunData, j: int) -> dict | None:
    """The true g-model coefficients d0..d9 of this power-on (deg/h, deg/h/g, deg/h/g^2)."""
    if not any(k in rd.fog.terms for k in ("g_sensitivity", "g2_sensitivity")):
        return None
    bias = 0.0
    for k in ("constant_bias", "switch_on_bias"):
        if k in rd.fog.terms:
            bias += float(rd.fog.terms[k][0, j])
    d = [bias] + list(rd.fog.draws["g_sens"][j]) + list(rd.fog.draws["g2_sens"][j])
    return {n: v / DPH for n, v in zip(TERM_NAMES, d)}


def _coef_errors(est: dict, true: dict, identified: list[str],
                 stderr: dict | None = None) -> dict:
    """Errors of d0..d9 against the truth; the RMS is over the identified coefficients only
    (an unidentified one is an arbitrary point of its null direction, not an estimate). With
    the fit's own standard errors (``stderr``, deg/h per g^k: the least-squares covariance of
    ``fogcomp.methods.flnn.identifiability``) also their RMS and the RMS of error / standard
    error, ``coef_z_rms``: near 1 when the errors are the ones the analysis predicts, far above
    when something the model leaves out (a misalignment, a range) biases the coefficients."""
    vals = {}
    for name in TERM_NAMES:
        key = next((k for k in est if k == name or k.startswith(name + "_")), None)
        if key is not None:
            vals[name] = est[key]
    if len(vals) < len(TERM_NAMES):
        return {}
    err = np.array([vals[n] - true[n] for n in TERM_NAMES])
    ide = np.array([n in identified for n in TERM_NAMES])
    return {"coef_rms_error_dph": float(np.sqrt(np.mean(err[ide] ** 2))) if ide.any() else None,
            "coef_identified": [n for n in TERM_NAMES if n in identified],
            "coef_errors_dph": {n: float(e) for n, e in zip(TERM_NAMES, err)},
            "coef_true_dph": dict(true), **_coef_z(err, ide, stderr)}


def _coef_z(err: np.ndarray, ide: np.ndarray, stderr: dict | None) -> dict:
    if not stderr:
        return {}
    se = np.array([np.nan if stderr.get(n) is None else stderr[n] for n in TERM_NAMES])
    ok = ide & np.isfinite(se) & (se > 0)
    if not ok.any():
        return {}
    return {"coef_rms_stderr_dph": float(np.sqrt(np.mean(se[ok] ** 2))),
            "coef_z_rms": float(np.sqrt(np.mean((err[ok] / se[ok]) ** 2)))}


def _metrics_doc(sc, plan, data, scored, fits, wall) -> dict:
    prots = {}
    for prot in plan.protocols:
        runs = {}
        for it in scored:
            if it.protocol == prot.name:
                runs[it.run] = it.metrics
        prots[prot.name] = {
            "in_sample": prot.in_sample, "description": prot.description,
            "per_run": prot.per_run, "smooth_s": prot.smooth_s, "skip_s": prot.skip_s,
            "reference": prot.reference, **({"ideal_of": prot.twin_of} if prot.twin_of else {}),
            **({"lab": dataclasses.asdict(plan.lab)} if prot.reference == "lab" and plan.lab
               else {}),
            "runs": runs,
            "fits": {k: [{kk: vv for kk, vv in r.items() if kk not in ("traceback",)}
                         for r in v] for k, v in fits[prot.name].items()},
        }
    return {
        "scenario": sc.name, "scenario_file": sc.path, "description": sc.description,
        "sample_rate_hz": sc.fs, "axis": plan.axis, "fog_preset": sc.fog_preset,
        "fog_source": sc.fog_source, "fog_device": sc.device,
        "fog_set_over_preset": sc.fog_changed, "map_point": sc.overrides or None,
        "runs": {name: {"seed": rd.run.seed, "samples": rd.n, "duration_s": rd.n / rd.fs,
                        "physics_steps": rd.truth.physics_steps,
                        "settled_hold_fast_path_s": rd.truth.settled_fast_path_s}
                 for name, rd in data.items()},
        "protocols": prots,
        # each method label: the built-in or plug-in method it runs, and the sweep it is a
        # member of (its [[methods]] label) with whether it has the paper's (default) setting
        "methods": {m.label: {"method": m.name, "group": m.group,
                              "paper_setting": bool(m.paper_setting)} for m in plan.methods},
        "wall_time_s": wall,
        "versions": versions(),
        "units": "metric names end in their unit: _dps deg/s, _dph deg/h, _deg deg, _pct "
                 "percent (improvement over the raw output), _s seconds",
    }


def metrics_sha256(doc: dict) -> str:
    """SHA-256 of a ``metrics.json`` document without its ``sha256`` key (canonical JSON:
    sorted keys, no spaces), as :func:`write_metrics` records it and ``compare`` checks it."""
    import hashlib

    body = {k: v for k, v in doc.items() if k != "sha256"}
    return hashlib.sha256(json.dumps(body, sort_keys=True, separators=(",", ":"))
                          .encode()).hexdigest()


def write_metrics(path: Path, doc: dict) -> None:
    """``doc`` as ``metrics.json``, with its own checksum last (``sha256``, of the document as
    read back), so an edited file is named by ``compare`` instead of compared."""
    body = json.loads(json.dumps(json_ready(doc)))
    body.pop("sha256", None)
    body["sha256"] = metrics_sha256(body)
    atomic_write_text(path, json.dumps(body, indent=2))
