"""Writing ``recording.rrd``: every run's table poses, signals, scored pieces, error terms,
Allan deviation and PSD, the metrics and the scenario, with the blueprint."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from fogbench.recording.blueprint import _blueprint
from fogbench.recording.entities import (
    _BASE_BOXES,
    _FOG_BOX,
    _ORACLE,
    _PALETTE,
    _RAW,
    _RUN_PALETTE,
    _TILT_BOX,
    _TURNTABLE,
    APPLICATION_ID,
    AXIS_ARROW_M,
    CONFIDENCE,
    CONSTANT_PTP,
    ENVELOPE,
    GRAVITY_ARROW_M_PER_G,
    MAX_POSE_POINTS,
    MAX_SERIES_POINTS,
    TABLE_SPACING_M,
    TIMELINE,
    _envelope_style,
    _in_sample,
    _legend_names,
    _method_colors,
    _p,
    _piece_color,
    _piece_keys,
    _piece_name,
    _series_name,
    _tint,
    _Writer,
)
from fogbench.recording.loglog import _loglog
from fogbench.recording.replicates import _log_replicates
from fogbench.report import palette as PAL
from fogbench.report.fmt import decimation, md_table, metrics_table
from fogbench.report.views import (
    kept_alike,
    mean_blind,
    method_entries,
    offsets_only,
    shown_error,
    sweep_names,
)
from fogcomp.units import DPH, DPS

__all__ = ["write_recording", "blueprint_for", "ReplicatesError"]


class ReplicatesError(ValueError):
    """The ``replicates`` argument of :func:`write_recording` is malformed."""


def _check_replicates(replicates) -> dict:
    """``{protocol: {metric: {label: values}}}`` as float arrays, or a ReplicatesError naming
    the key that is wrong."""
    if replicates is None:
        return {}
    if not isinstance(replicates, dict):
        raise ReplicatesError(f"replicates: expected a dict {{protocol: {{metric: {{label: "
                              f"[values]}}}}}}, got {type(replicates).__name__}")
    out: dict = {}
    for prot, metrics in replicates.items():
        if not isinstance(metrics, dict):
            raise ReplicatesError(f"replicates[{prot!r}]: expected a dict {{metric: {{label: "
                                  f"[values]}}}}, got {type(metrics).__name__}")
        for metric, labels in metrics.items():
            if not isinstance(labels, dict):
                raise ReplicatesError(f"replicates[{prot!r}][{metric!r}]: expected a dict "
                                      f"{{label: [values]}}, got {type(labels).__name__}")
            for lab, vals in labels.items():
                where = f"replicates[{prot!r}][{metric!r}][{lab!r}]"
                try:
                    v = np.array([np.nan if x is None else x for x in vals], dtype=float)
                except (TypeError, ValueError) as exc:
                    raise ReplicatesError(f"{where}: expected a list of numbers (one per "
                                          f"replicate, None for a failed one): {exc}") from None
                if v.ndim != 1:
                    raise ReplicatesError(f"{where}: expected a flat list of numbers, got "
                                          f"shape {v.shape}")
                out.setdefault(str(prot), {}).setdefault(str(metric), {})[str(lab)] = v
    return out


def write_recording(res, path: Path, replicates: dict | None = None) -> None:
    """Write the Rerun recording of a scenario result to ``path``.

    Parameters
    ----------
    res : ScenarioResult
        The result of :func:`fogbench.run.runner.run_scenario`; with Monte Carlo, one representative
        replicate, shown in full.
    path : path-like
        The ``.rrd`` file to write.
    replicates : dict, optional
        ``{protocol: {metric: {label: values}}}``: each metric (unit in its name) of each label
        (``raw``, ``oracle``, a method) over the replicates, ``values[r]`` that of replicate
        ``r`` (None or NaN for a replicate where it is undefined). Logged on the sequence
        timeline ``replicate`` and summarised (median, 5-95 % range) in ``/replicates/summary``.

    Raises
    ------
    ReplicatesError
        ``replicates`` is malformed (checked before anything is written).

    See the module docstring for the entity paths, timelines and decimation.
    """
    import rerun as rr

    reps = _check_replicates(replicates)
    path = Path(path)
    rec = rr.RecordingStream(application_id=APPLICATION_ID, recording_id=res.scenario.name,
                             send_properties=False)
    # Logged into memory, then written by this process: a file sink writes from Rerun's own
    # thread, where a full disk or a file-size limit is only a line on stderr, never an error.
    mem = rec.memory_recording()
    try:
        w = _log_all(rec, res, reps)
        rec.send_blueprint(_blueprint(res, w, reps), make_active=True, make_default=True)
        rec.flush()
        data = mem.drain_as_bytes()
    finally:
        rec.disconnect()
    from fogcomp._persistence import atomic_write_bytes

    atomic_write_bytes(path, data)


def _log_all(rec, res, reps: dict) -> _Writer:
    """Log everything but the blueprint into ``rec``; the writer knows the ranges logged."""
    import rerun as rr

    sc = res.scenario
    rec.send_recording_name(sc.name)
    w = _Writer(rec)
    colors = _method_colors(res)
    axis = res.plan.axis
    j = sc.axes.index(axis)
    decim = {}
    for i, (name, rd) in enumerate(res.data.items()):
        decim[name] = _log_run(w, name, rd, j, _RUN_PALETTE[i % len(_RUN_PALETTE)])
        _log_table3d(w, name, i, rd, axis)
    piece_decim = []
    ins = _in_sample(res)
    for key, it in zip(_piece_keys(res), res.scored):
        piece_decim.append(_log_piece(w, key, it, colors, ins.get(it.protocol, False),
                                      _legend_names(res), res.plan))
    rec.log("/report/metrics", rr.TextDocument(_metrics_text(res, decim, piece_decim),
                                               media_type="text/markdown"), static=True)
    rec.log("/report/scenario", rr.TextDocument(
        f"# Scenario `{sc.name}`\n\n`{sc.path}`\n\n```toml\n{sc.text}\n```\n",
        media_type="text/markdown"), static=True)
    if reps:
        _log_replicates(w, reps, colors, res.plan)
    return w


def blueprint_for(res, replicates: dict | None = None, active_tab: str = "Overview"):
    """The blueprint :func:`write_recording` sends, opened on the tab ``active_tab``.

    For tools that drive a viewer (``scripts/screenshots.py``): it logs the recording once more
    into memory to know the ranges of the series (about the time of a write).
    """
    import rerun as rr

    reps = _check_replicates(replicates)
    rec = rr.RecordingStream(application_id=APPLICATION_ID, recording_id=res.scenario.name,
                             send_properties=False)
    rec.memory_recording()
    try:
        w = _log_all(rec, res, reps)
    finally:
        rec.disconnect()
    return _blueprint(res, w, reps, active_tab=active_tab)


def _log_run(w: _Writer, name: str, rd, j: int, run_color) -> tuple[int, int]:
    """The time series of one run; returns the (series, pose) decimation factors."""
    tr = rd.truth
    k = decimation(rd.n, MAX_SERIES_POINTS)
    s = slice(None, None, k)
    t = tr.t[s]
    w.series(_p("runs", name, "truth", "rate"), t, rd.truth_axis(j)[s] / DPS,
             f"{name} truth", run_color, width=2.0)
    w.series(_p("runs", name, "fog", "raw"), t, rd.fog.raw[s, j] / DPS,
             f"{name} raw", _tint(run_color, 0.5), width=1.0)
    table = {"tilt_deg": (np.degrees(tr.tilt[s]), "tilt", run_color),
             "tilt_cmd_deg": (np.degrees(tr.tilt_cmd[s]), "tilt command", _tint(run_color, 0.5)),
             "turn_rate_dps": (np.degrees(tr.turn_rate[s]), "turntable rate", run_color),
             "turn_rate_cmd_dps": (np.degrees(tr.turn_rate_cmd[s]), "turntable rate command",
                                   _tint(run_color, 0.5))}
    for leaf, (y, label, c) in table.items():
        w.series(_p("runs", name, "table", leaf), t, y, f"{name} {label}", c)
    th = rd.thermal
    for leaf, y, label, c in (("chamber_c", th.chamber, "chamber", _tint(run_color, 0.5)),
                              ("coil_c", th.coil, "coil", run_color),
                              ("housing_c", th.housing, "housing", _tint(run_color, 0.25)),
                              ("sensor_c", th.sensor, "sensor reading", _tint(run_color, 0.7)),
                              ("coil_rate_c_per_min", th.coil_rate * 60.0, "coil dT/dt",
                               run_color),
                              ("sensor_rate_c_per_min", th.sensor_rate * 60.0,
                               "sensor dT/dt", _tint(run_color, 0.6))):
        if y is not None:
            w.series(_p("runs", name, "thermal", leaf), t, y[s], f"{name} {label}", c)
    for i, (ax, c) in enumerate(zip("xyz", ((214, 39, 40), (44, 160, 44), (31, 119, 180)))):
        w.series(_p("runs", name, "gravity", ax), t, tr.gravity[s, i], f"{name} gravity {ax}", c)
    for i, (term, v) in enumerate(rd.fog.terms.items()):
        w.series(_p("runs", name, "fog", "error_terms", term), t, v[s, j] / DPH, term,
                 (_PALETTE + [_ORACLE, _RAW])[i % (len(_PALETTE) + 2)])
    return k, decimation(rd.n, MAX_POSE_POINTS)


def _log_table3d(w: _Writer, name: str, i: int, rd, axis: str) -> None:
    rr, rec = w.rr, w.rec
    tr = rd.truth
    root = _p("table", name)
    rec.log(root, rr.Transform3D(translation=[0.0, i * TABLE_SPACING_M, 0.0]), static=True)
    rec.log(f"{root}/base", rr.Boxes3D(half_sizes=[b[0] for b in _BASE_BOXES],
                                       centers=[b[1] for b in _BASE_BOXES],
                                       colors=[(110, 110, 120)] * 3,
                                       labels=[name, "", ""], show_labels=True,
                                       fill_mode="solid"), static=True)
    rec.log(f"{root}/tilt", rr.Boxes3D(half_sizes=[_TILT_BOX[0]], centers=[_TILT_BOX[1]],
                                       colors=[(170, 170, 185)], fill_mode="solid"), static=True)
    rec.log(f"{root}/turntable", rr.Cylinders3D(radii=[_TURNTABLE[0]], lengths=[_TURNTABLE[1]],
                                                centers=[(0.0, 0.0, 0.0)],
                                                colors=[(200, 200, 210)], fill_mode="solid"),
            static=True)
    rec.log(f"{root}/turntable/index_mark",
            rr.Boxes3D(half_sizes=[(0.025, 0.008, 0.004)], centers=[(0.12, 0.0, 0.019)],
                       colors=[(214, 39, 40)], fill_mode="solid"), static=True)
    rec.log(f"{root}/fog", rr.Boxes3D(half_sizes=[_FOG_BOX], colors=[(31, 119, 180)],
                                      fill_mode="solid"), static=True)
    # the sensitive axis starts at a corner of the case, off the gravity arrow (which starts at
    # the centre): the two stay apart when they are collinear (a level table, axis z)
    ia = "xyz".index(axis)
    e = np.zeros(3)
    e[ia] = AXIS_ARROW_M
    corner = 2.5 * np.array(_FOG_BOX, dtype=float)
    corner[ia] = 0.0
    corner[(ia + 1) % 3] *= -1.0
    rec.log(f"{root}/fog/sensitive_axis",
            rr.Arrows3D(vectors=[e], origins=[corner], colors=[(255, 127, 14)],
                        labels=[f"sensitive axis {axis}"], show_labels=False, radii=[0.005]), static=True)
    rec.log(f"{root}/fog/gravity", rr.Arrows3D.from_fields(
        origins=[(0.0, 0.0, 0.0)], colors=[(44, 160, 44)], labels=["gravity (up, 1 g)"],
        show_labels=False,
        radii=[0.005]), static=True)

    s = slice(None, None, decimation(rd.n, MAX_POSE_POINTS))
    tcol = [w._time(tr.t[s])]
    wxyz_to_xyzw = [1, 2, 3, 0]
    rec.send_columns(f"{root}/tilt", indexes=tcol, columns=rr.Transform3D.columns(
        quaternion=np.ascontiguousarray(tr.tilt_quat[s][:, wxyz_to_xyzw])))
    rec.send_columns(f"{root}/turntable", indexes=tcol, columns=rr.Transform3D.columns(
        quaternion=np.ascontiguousarray(tr.turntable_quat[s][:, wxyz_to_xyzw])))
    rec.send_columns(f"{root}/fog", indexes=tcol, columns=rr.Transform3D.columns(
        translation=np.ascontiguousarray(tr.fog_pos[s]),
        quaternion=np.ascontiguousarray(tr.fog_quat[s][:, wxyz_to_xyzw])))
    rec.send_columns(f"{root}/fog/gravity", indexes=tcol, columns=rr.Arrows3D.columns(
        vectors=np.ascontiguousarray(tr.gravity[s] * GRAVITY_ARROW_M_PER_G)))


def _log_piece(w: _Writer, key: str, it, colors, in_sample: bool,
               names: dict | None = None, plan=None) -> int:
    """Compensated outputs, errors, Allan deviation and PSD of one scored piece. In the
    Overview's error view (``error_shown``) a sweep is its default setting's line and the
    envelope of its members (the best and the worst at each time), as in the PNGs."""
    p = it.piece
    names = names or {}
    k = decimation(p.t.size, MAX_SERIES_POINTS)
    s = slice(None, None, k)
    allan, psd = [], []
    # what every output keeps alike (a wander no method removes), taken out for the Overview's
    # error view as in the PNG time series (fogbench.report.views.kept_alike)
    errs = {lab: (out - p.truth) / DPH for lab, out in it.outputs.items()}
    kind, trend, kw = kept_alike(errs, [lab for lab in errs if lab not in ("raw", "oracle")])
    centre = mean_blind(plan, it.run)
    if kind is not None or centre:
        w.shown[_p("runs", it.run, "fog", "error", key)] = (kind, kw, centre)
    sweeps = [e for e in method_entries(list(it.outputs), plan) if e["group"]] \
        if plan is not None else []
    members_shown: dict[str, np.ndarray] = {}
    in_envelope = {m for e in sweeps for m in e["members"] if m != e["default"]}
    # where a sweep is its default's line and an envelope, the default is named as such (the
    # Errors tab keeps every member under the sweep's one name)
    as_default = {e["default"]: sweep_names(e)[0] for e in sweeps}
    # outputs that are raw plus a constant: the Allan deviation and PSD of raw alone (every
    # other curve would lie on raw's), as in the PNGs
    spectra = {"raw"} if offsets_only(it) else set(it.outputs)
    for lab, out in it.outputs.items():
        c = _piece_color(colors, lab, in_sample)
        name = _piece_name(as_default.get(lab, names.get(lab, lab)), in_sample)  # Allan, PSD
        sname = _series_name(lab, in_sample, it.protocol, names)  # time series legends
        width = 3.0 if lab == "raw" else 1.5
        w.series(_p("runs", it.run, "fog", "compensated", key, lab), p.t[s], out[s] / DPS,
                 sname, c, width)
        w.series(_p("runs", it.run, "fog", "error", key, lab), p.t[s],
                 (out[s] - p.truth[s]) / DPH, sname, c, width)
        err = errs[lab]
        if kind is not None or centre or sweeps:  # (a sweep's default is named as such)
            shown = shown_error(kind, err, trend, kw, centre)
            members_shown[lab] = shown
            if lab not in in_envelope:
                w.series(_p("runs", it.run, "fog", "error_shown", key, lab), p.t[s], shown[s],
                         _series_name(lab, in_sample, it.protocol, {**names, **as_default}),
                         c, width)
        if lab in spectra and p.raw.size >= 64:
            curve = _allan_curve(err, p.fs)
            if curve is not None:
                allan.append((lab, name, c, *curve))
        if lab in spectra and p.raw.size >= 16:
            curve = _psd_curve(err, p.fs)
            if curve is not None:
                psd.append((lab, name, c, *curve))
    if sweeps:
        _log_sweep_envelopes(w, key, it, sweeps, members_shown, in_envelope, s, colors,
                             in_sample)
    allan, psd = (_sweeps_as_envelopes(curves, sweeps, colors, in_sample, it.protocol)
                  for curves in (allan, psd))
    _log_spectra(w, key, it.run, allan, psd)
    return k


def _allan_curve(err: np.ndarray, fs: float):
    """``(taus, adev, low, high)`` of an error in deg/h where drawn as in the PNG, intervals
    from the EDF of the noise type leading each tau (Greenhall & Riley); None when it cannot be
    computed or fewer than 2 taus are drawn (display only: the curve is left out)."""
    from fogcomp.allan import oadev_ci

    try:
        ad = oadev_ci(err, fs, ci=CONFIDENCE)
    except ValueError:
        return None
    ok = np.isfinite(ad.adev) & (ad.adev > 0) & np.isfinite(ad.low) & \
        np.isfinite(ad.high) & PAL.allan_drawn(ad.m, ad.n)   # as the PNG
    if ok.sum() >= 2:
        return ad.taus[ok], ad.adev[ok], ad.low[ok], ad.high[ok]
    return None


def _psd_curve(err: np.ndarray, fs: float):
    """``(f, pxx, low, high)`` of an error in deg/h as the PNGs: Welch averaged in log-spaced
    bands, each with its interval; None when fewer than 2 bands are positive."""
    from fogcomp import metrics as M

    try:
        f, pxx, edf = M.psd_bands(err, fs, per_decade=PAL.PSD_PER_DECADE)
        low, high = M.psd_band_interval(pxx, edf, CONFIDENCE)
    except ValueError:
        f = pxx = low = high = np.zeros(0)
    ok = (f > 0) & np.isfinite(pxx) & (pxx > 0)
    if ok.sum() >= 2:
        return f[ok], pxx[ok], low[ok], high[ok]
    return None


def _log_sweep_envelopes(w: _Writer, key: str, it, sweeps: list, members_shown: dict,
                         in_envelope: set, s: slice, colors, in_sample: bool) -> None:
    """The envelope of each sweep's members in the Overview's error view (the lowest and the
    highest shown error at each time), and the members the Overview leaves to it."""
    p = it.piece
    envelope = []
    for e in sweeps:
        stack = np.vstack([members_shown[m][s] for m in e["members"]])
        c, name = _envelope_style(e, colors, in_sample, it.protocol, series=True)
        with warnings.catch_warnings():     # a time no member has: NaN, not drawn
            warnings.simplefilter("ignore", RuntimeWarning)
            ends = {"low": np.nanmin(stack, axis=0), "high": np.nanmax(stack, axis=0)}
        for end, y in ends.items():
            path = _p("runs", it.run, "fog", "error_shown", key, f"{e['group']} {ENVELOPE}", end)
            w.series(path, p.t[s], y, name, c, 1.0)
            envelope.append(path)
    w.sweeps[_p("runs", it.run, "fog", "error", key)] = (
        {_p("runs", it.run, "fog", "error_shown", key, m) for m in in_envelope}, envelope)


def _log_spectra(w: _Writer, key: str, run: str, allan: list, psd: list) -> None:
    """The log-log Allan deviation and PSD plots of one scored piece, each where it has a
    curve."""
    if allan:
        _loglog(w, _p("report", "allan", key, run), allan, "tau, s",
                "Allan deviation of output - truth, deg/h",
                f"bars: {100 * CONFIDENCE:.0f} % interval, EDF of the leading noise type")
    if psd:
        _loglog(w, _p("report", "psd", key, run), psd, "frequency, Hz",
                "PSD of output - truth, (deg/h)^2/Hz",
                f"Welch in {PAL.PSD_PER_DECADE} bands a decade; bars: "
                f"{100 * CONFIDENCE:.0f} % interval, EDF of each band")


def _sweeps_as_envelopes(curves: list, sweeps: list, colors, in_sample: bool,
                         protocol: str) -> list:
    """Log-log ``curves`` (label, name, colour, x, y, lo, hi) with each sweep's members but its
    default setting replaced by their envelope, as in the PNGs: two thin lines, the lowest and
    the highest member at every x all of them reach, one legend entry, no interval bars."""
    by_lab = {c[0]: c for c in curves}
    out = list(curves)
    for e in sweeps:
        have = [by_lab[m] for m in e["members"] if m in by_lab]
        if len(have) < 2:
            continue
        xs = have[0][3]
        for c in have[1:]:
            xs = np.union1d(xs, c[3])           # every x a member reaches (the PNG's nanmin)
        ys = np.full((len(have), xs.size), np.nan)
        for row, c in zip(ys, have):
            row[np.searchsorted(xs, c[3])] = c[4]
        color, name = _envelope_style(e, colors, in_sample, protocol, series=False)
        out = [c for c in out if c[0] not in e["members"] or c[0] == e["default"]]
        out += [(f"{e['group']} {ENVELOPE} {end}", name, color, xs, y, None, None)
                for end, y in (("low", np.nanmin(ys, axis=0)), ("high", np.nanmax(ys, axis=0)))]
    return out


def _metrics_text(res, decim: dict, piece_decim: list[int]) -> str:
    sc, plan = res.scenario, res.plan
    L = [f"# {sc.name}", "", sc.description, "",
         f"Axis `{plan.axis}`, {sc.fs:g} Hz, FOG: {sc.device}. "
         f"Wall time {res.wall_s:.1f} s.", "",
         "Metric units are in their names: `_dps` deg/s, `_dph` deg/h, `_deg` deg, `_pct` "
         "percent improvement over raw, `_s` seconds. Every metric uses every sample.", "",
         "## Display decimation", "",
         f"Series are decimated for display only (every k-th sample; at most "
         f"{MAX_SERIES_POINTS:,} points per series per run or piece, {MAX_POSE_POINTS:,} 3-D "
         "poses per run).", "",
         md_table(["run", "samples", "series decimation k", "3-D pose decimation k"],
                   [[name, str(rd.n), str(decim[name][0]), str(decim[name][1])]
                    for name, rd in res.data.items()]), ""]
    keys = _piece_keys(res)
    L += [md_table(["protocol (entity name)", "run", "piece samples", "fs, Hz", "decimation k"],
                    [[key, it.run, str(it.piece.t.size), f"{it.piece.fs:g}", str(k)]
                     for key, it, k in zip(keys, res.scored, piece_decim)]), ""]
    failed = []
    prots = {p.name: p for p in plan.protocols}
    for key, it in zip(keys, res.scored):
        prot = prots.get(it.protocol)
        flag = " (IN-SAMPLE)" if prot is not None and prot.in_sample else " (held out)"
        L += [f"## `{key}`{flag} / `{it.run}`", ""]
        failed += [(key, it.run, lab, m.get("error", "")) for lab, m in it.metrics.items()
                   if m.get("status") == "failed"]
        L += [metrics_table(it.metrics), ""]
    if failed:
        L += ["## Failed methods", "",
              "These have no `compensated` or `error` series in this recording:", ""]
        L += [f"- `{lab}` in `{key}` / `{run}`: {err}" for key, run, lab, err in failed]
        L += [""]
    L += ["## Viewer", "",
          f"Time series are on the `{TIMELINE}` timeline (simulated time since power-on, s; "
          "every run starts at 0); every plot opens on the whole of the longest run and their "
          "time axes are linked. Errors are output minus truth in deg/h: raw grey, oracle cyan, "
          "one colour per method; an in-sample protocol is drawn in a lighter tint and named "
          "`(in-sample)`. Tabs `Allan deviation` and `PSD` hold log-log plots (decade grid, "
          f"tau in s, deviation in deg/h) with {100 * CONFIDENCE:.0f} % intervals. A plot whose "
          f"values are constant to within {CONSTANT_PTP:g} (its unit) is shown on a fixed range "
          "around the value.", ""]
    return "\n".join(L)
