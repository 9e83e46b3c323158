"""The Rerun recording of a scenario run (``recording.rrd`` in the run directory).

``write_recording(res, path)`` writes one Rerun recording (application id ``fogbench``,
recording id = the scenario name) holding every run of the scenario, with a blueprint (the
viewer's layout) declared in code; ``fogbench view DIR`` opens it (:func:`view`).

All series are logged in bulk with ``send_columns`` on one timeline, ``sim_time`` (a duration:
the simulated time since the run's power-on, s). The runs of a scenario are separate power-ons that
all start at ``sim_time`` 0, so they sit side by side in one recording, under ``/runs/<run>``: one
plot then compares the runs, and the static report is stored once. In the 3-D view each run has
its own table (``/table/<run>``), placed in a row along the world y axis (0.8 m apart, base
labelled with the run name), all moving together as ``sim_time`` plays.

Entity paths (`<run>`: run name; `<protocol>`: protocol name, with `_2`, `_3`... appended when
a protocol scores the same run more than once; `<label>`: `raw`, `oracle` or a method label;
`<term>`: a FOG error term). The table is markdown, as in the README:

| entity path | content |
|---|---|
| `/table` | world frame, z up (static) |
| `/table/<run>` | the run's table, offset 0.8 m per run along world y (static transform) |
| `/table/<run>/base` | base and yoke boxes, labelled with the run name (static) |
| `/table/<run>/tilt` | tilt platform box; pose per sample = truth `tilt_quat` |
| `/table/<run>/turntable` | turntable cylinder (r 0.15 m); pose = `turntable_quat` |
| `/table/<run>/turntable/index_mark` | a mark near the turntable rim, to see it turn (static) |
| `/table/<run>/fog` | FOG case (9 cm cube); pose = `fog_pos`, `fog_quat` |
| `/table/<run>/fog/sensitive_axis` | arrow along the scenario's sensitive axis, FOG frame (static) |
| `/table/<run>/fog/gravity` | arrow of `Truth.gravity` in the FOG frame, per sample (Arrows3D vectors column): 1 g *up*, what an accelerometer at rest reads, 0.12 m per g |
| `/runs/<run>/truth/rate` | true inertial rate about the sensitive axis, deg/s |
| `/runs/<run>/fog/raw` | raw FOG output, deg/s |
| `/runs/<run>/fog/compensated/<protocol>/<label>` | output of a scored piece (raw, oracle, each method), deg/s |
| `/runs/<run>/fog/error/<protocol>/<label>` | that output minus the truth, deg/h |
| `/runs/<run>/fog/error_terms/<term>` | each simulated error term (`FogOutput.terms`), deg/h |
| `/runs/<run>/table/tilt_deg`, `tilt_cmd_deg` | tilt angle and its command, deg |
| `/runs/<run>/table/turn_rate_dps`, `turn_rate_cmd_dps` | turntable rate and its command, deg/s |
| `/runs/<run>/thermal/chamber_c`, `coil_c` | chamber and coil temperature, deg C |
| `/runs/<run>/thermal/coil_rate_c_per_min` | coil temperature rate, deg C/min |
| `/runs/<run>/gravity/x`, `y`, `z` | `Truth.gravity` on the sensor axes, g |
| `/report/metrics` | metrics tables, failed methods, display decimation (markdown, static) |
| `/report/scenario` | the scenario file (markdown with a TOML block, static) |
| `/report/allan/<protocol>/<run>/<label>` | log10 of the overlapping Allan deviation of (output - truth) in deg/h, on timeline `log10_tau_s` |
| `/report/psd/<protocol>/<run>/<label>` | log10 of the Welch PSD of the output (mean removed) in (deg/s)^2/Hz, on timeline `log10_freq_hz` |

Scored pieces are logged at their own sample times (``Piece.t``): a subset of the run, and for
smoothed protocols the block means at the blocks' mean times. A method that failed has no
``compensated``/``error`` series; the metrics text says so.

Allan deviation and PSD curves are series over a second and a third timeline (`log10_tau_s`,
`log10_freq_hz`, of duration type; Rerun's plot axes are linear, so both axes are in log10): pick
that timeline in the viewer's time panel to see them (tab "Allan / PSD"). A timeline value of
1.5 s reads as log10(tau / 1 s) = 1.5, i.e. tau = 31.6 s.

Long runs are decimated for display only (every k-th sample): at most ``MAX_SERIES_POINTS`` points
per series per run or piece and ``MAX_POSE_POINTS`` 3-D poses per run; ``/report/metrics`` gives k
for every run and piece. Every metric is computed on the full record.

The blueprint (sent with the recording, active and default for the application) opens on tab
"Overview": the 3-D table and the metrics on the left; on the right the rate comparison (truth,
raw, compensated; deg/s), the error against the truth (deg/h) and the temperatures. Further tabs:
"Table and chamber" (tilt, turntable rate, gravity, coil dT/dt), "FOG error terms", "Allan / PSD"
and "Report" (metrics and scenario file).
"""

from __future__ import annotations

import importlib.util
import math
import os
import shutil
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np

from fogcomp.units import DPH, DPS

from .fmt import KEY_METRICS, fmt, md_table

__all__ = ["write_recording", "view", "decimation", "MAX_SERIES_POINTS", "MAX_POSE_POINTS",
           "TIMELINE", "TAU_TIMELINE", "FREQ_TIMELINE", "APPLICATION_ID"]

APPLICATION_ID = "fogbench"
TIMELINE = "sim_time"
TAU_TIMELINE = "log10_tau_s"
FREQ_TIMELINE = "log10_freq_hz"
MAX_SERIES_POINTS = 20_000
MAX_POSE_POINTS = 5_000
TABLE_SPACING_M = 0.8
GRAVITY_ARROW_M_PER_G = 0.12
AXIS_ARROW_M = 0.15

# geometry of sim/rate_table.xml (half sizes and centres in the body frame, m)
_BASE_BOXES = (((0.35, 0.30, 0.05), (0.0, 0.0, -0.55)),
               ((0.03, 0.08, 0.25), (-0.32, 0.0, -0.25)),
               ((0.03, 0.08, 0.25), (0.32, 0.0, -0.25)))
_TILT_BOX = ((0.28, 0.22, 0.02), (0.0, 0.0, -0.04))
_TURNTABLE = (0.15, 0.03)             # radius, length (MuJoCo half-height 0.015)
_FOG_BOX = (0.045, 0.045, 0.04)

_GREY, _DARK, _GREEN = (150, 150, 150), (40, 40, 40), (44, 160, 44)
_PALETTE = [(31, 119, 180), (255, 127, 14), (214, 39, 40), (148, 103, 189), (140, 86, 75),
            (227, 119, 194), (23, 190, 207), (188, 189, 34)]


def decimation(n: int, max_points: int) -> int:
    """The display stride k (every k-th sample) that keeps ``n`` samples under ``max_points``."""
    return max(1, int(math.ceil(n / max_points)))


def _p(*parts: str) -> str:
    """An entity path from fixed words and names (names are escaped)."""
    import rerun as rr

    return "/" + "/".join(rr.escape_entity_path_part(str(x)) for x in parts)


class _Writer:
    def __init__(self, rec):
        import rerun as rr

        self.rr, self.rec = rr, rec

    def _time(self, t: np.ndarray, timeline: str = TIMELINE):
        ns = np.round(np.asarray(t, dtype=float) * 1e9).astype(np.int64)
        return self.rr.TimeColumn(timeline, duration=ns.astype("timedelta64[ns]"))

    def series(self, path: str, t, y, name: str, color, timeline: str = TIMELINE,
               width: float | None = None):
        rr = self.rr
        y = np.ascontiguousarray(y, dtype=np.float64)
        self.rec.log(path, rr.SeriesLines(names=name, colors=[color],
                                          widths=None if width is None else [width]),
                     static=True)
        self.rec.send_columns(path, indexes=[self._time(t, timeline)],
                              columns=rr.Scalars.columns(scalars=y))


def _colors(res) -> dict[str, tuple]:
    out = {"raw": _GREY, "oracle": _DARK, "truth": _GREEN}
    for i, ms in enumerate(res.plan.methods):
        out.setdefault(ms.label, _PALETTE[i % len(_PALETTE)])
    return out


def _piece_keys(res) -> list[str]:
    """The protocol part of the entity paths of each scored piece (unique per run)."""
    seen: dict[tuple[str, str], int] = {}
    keys = []
    for it in res.scored:
        k = (it.protocol, it.run)
        seen[k] = seen.get(k, 0) + 1
        keys.append(it.protocol if seen[k] == 1 else f"{it.protocol}_{seen[k]}")
    return keys


def write_recording(res, path: Path) -> None:
    """Write the Rerun recording of a scenario result ``res`` (a ``ScenarioResult``) to ``path``.

    See the module docstring for the entity paths, timelines and decimation.
    """
    import rerun as rr

    path = Path(path)
    sc = res.scenario
    rec = rr.RecordingStream(application_id=APPLICATION_ID, recording_id=sc.name,
                             send_properties=False)
    rec.save(path)
    try:
        rec.send_recording_name(sc.name)
        rec.send_blueprint(_blueprint(res), make_active=True, make_default=True)
        w = _Writer(rec)
        colors = _colors(res)
        axis = res.plan.axis
        j = sc.axes.index(axis)
        decim = {}
        for i, (name, rd) in enumerate(res.data.items()):
            decim[name] = _log_run(w, name, rd, j, colors)
            _log_table3d(w, name, i, rd, axis)
        piece_decim = []
        for key, it in zip(_piece_keys(res), res.scored):
            piece_decim.append(_log_piece(w, key, it, colors))
        rec.log("/report/metrics", rr.TextDocument(_metrics_text(res, decim, piece_decim),
                                                   media_type="text/markdown"), static=True)
        rec.log("/report/scenario", rr.TextDocument(
            f"# Scenario `{sc.name}`\n\n`{sc.path}`\n\n```toml\n{sc.text}\n```\n",
            media_type="text/markdown"), static=True)
        rec.flush()
    finally:
        rec.disconnect()


def _log_run(w: _Writer, name: str, rd, j: int, colors) -> tuple[int, int]:
    """The time series of one run; returns the (series, pose) decimation factors."""
    tr = rd.truth
    k = decimation(rd.n, MAX_SERIES_POINTS)
    s = slice(None, None, k)
    t = tr.t[s]
    w.series(_p("runs", name, "truth", "rate"), t, rd.truth_axis(j)[s] / DPS,
             f"{name} truth, deg/s", colors["truth"], width=2.0)
    w.series(_p("runs", name, "fog", "raw"), t, rd.fog.raw[s, j] / DPS,
             f"{name} raw, deg/s", colors["raw"])
    table = {"tilt_deg": (np.degrees(tr.tilt[s]), "tilt, deg", (31, 119, 180)),
             "tilt_cmd_deg": (np.degrees(tr.tilt_cmd[s]), "tilt command, deg", _GREY),
             "turn_rate_dps": (np.degrees(tr.turn_rate[s]), "turntable rate, deg/s",
                               (255, 127, 14)),
             "turn_rate_cmd_dps": (np.degrees(tr.turn_rate_cmd[s]),
                                   "turntable rate command, deg/s", _GREY)}
    for leaf, (y, label, c) in table.items():
        w.series(_p("runs", name, "table", leaf), t, y, f"{name} {label}", c)
    th = rd.thermal
    for leaf, y, label, c in (("chamber_c", th.chamber, "chamber, deg C", (31, 119, 180)),
                              ("coil_c", th.coil, "coil, deg C", (214, 39, 40)),
                              ("coil_rate_c_per_min", th.coil_rate * 60.0,
                               "coil dT/dt, deg C/min", (148, 103, 189))):
        w.series(_p("runs", name, "thermal", leaf), t, y[s], f"{name} {label}", c)
    for i, (ax, c) in enumerate(zip("xyz", ((214, 39, 40), (44, 160, 44), (31, 119, 180)))):
        w.series(_p("runs", name, "gravity", ax), t, tr.gravity[s, i], f"{name} gravity {ax}, g", c)
    for i, (term, v) in enumerate(rd.fog.terms.items()):
        w.series(_p("runs", name, "fog", "error_terms", term), t, v[s, j] / DPH,
                 f"{name} {term}, deg/h", _PALETTE[i % len(_PALETTE)])
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
    e = np.zeros(3)
    e["xyz".index(axis)] = AXIS_ARROW_M
    rec.log(f"{root}/fog/sensitive_axis",
            rr.Arrows3D(vectors=[e], origins=[(0.0, 0.0, 0.0)], colors=[(255, 127, 14)],
                        labels=[f"sensitive axis {axis}"], radii=[0.004]), static=True)
    rec.log(f"{root}/fog/gravity", rr.Arrows3D.from_fields(
        origins=[(0.0, 0.0, 0.0)], colors=[(44, 160, 44)], labels=["gravity (up, 1 g)"],
        radii=[0.004]), static=True)

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


def _log_piece(w: _Writer, key: str, it, colors) -> int:
    """Compensated outputs, errors, Allan deviation and PSD of one scored piece."""
    from fogcomp import metrics as M
    from fogcomp.allan import oadev

    p = it.piece
    k = decimation(p.t.size, MAX_SERIES_POINTS)
    s = slice(None, None, k)
    for lab, out in it.outputs.items():
        c = colors.get(lab, _PALETTE[zlib.crc32(lab.encode()) % len(_PALETTE)])
        tag = f"{it.run} {lab} [{key}]"
        w.series(_p("runs", it.run, "fog", "compensated", key, lab), p.t[s], out[s] / DPS,
                 f"{tag}, deg/s", c)
        w.series(_p("runs", it.run, "fog", "error", key, lab), p.t[s],
                 (out[s] - p.truth[s]) / DPH, f"{tag} error, deg/h", c)
        if p.raw.size >= 64:
            try:
                taus, ad = oadev(out - p.truth, p.fs)
            except ValueError:  # display only: a curve that cannot be computed is left out
                taus = ad = np.zeros(0)
            ok = np.isfinite(ad) & (ad > 0)
            if ok.any():
                w.series(_p("report", "allan", key, it.run, lab), np.log10(taus[ok]),
                         np.log10(ad[ok] / DPH), f"{tag}: log10 ADEV, deg/h", c, TAU_TIMELINE)
        if p.raw.size >= 2:
            try:
                f, psd = M.psd(out - np.mean(out), p.fs, nperseg=min(p.raw.size, 1024))
            except ValueError:
                f = psd = np.zeros(0)
            ok = (f > 0) & np.isfinite(psd) & (psd > 0)
            if ok.any():
                w.series(_p("report", "psd", key, it.run, lab), np.log10(f[ok]),
                         np.log10(psd[ok] / DPS**2), f"{tag}: log10 PSD, (deg/s)^2/Hz", c,
                         FREQ_TIMELINE)
    return k


def _metrics_text(res, decim: dict, piece_decim: list[int]) -> str:
    sc, plan = res.scenario, res.plan
    L = [f"# {sc.name}", "", sc.description, "",
         f"Axis `{plan.axis}`, {sc.fs:g} Hz, FOG preset `{sc.fog_preset}`. "
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
        metrics = [m for m in KEY_METRICS
                   if any(isinstance(v, dict) and m in v for v in it.metrics.values())]
        rows = []
        for lab, m in it.metrics.items():
            if m.get("status") == "failed":
                rows.append([lab] + ["–"] * len(metrics) + [f"FAILED: {m.get('error', '')}"])
                failed.append((key, it.run, lab, m.get("error", "")))
                continue
            rows.append([lab] + [fmt(m.get(x), x) for x in metrics] + ["ok"])
        L += [md_table(["method"] + metrics + ["status"], rows), ""]
    if failed:
        L += ["## Failed methods", "",
              "These have no `compensated` or `error` series in this recording:", ""]
        L += [f"- `{lab}` in `{key}` / `{run}`: {err}" for key, run, lab, err in failed]
        L += [""]
    L += ["## Viewer", "",
          f"Time series are on the `{TIMELINE}` timeline (simulated time since power-on, s; "
          "every run starts at 0). The Allan deviation and PSD curves are on the "
          f"`{TAU_TIMELINE}` and `{FREQ_TIMELINE}` timelines (x = log10 of tau in s / of the "
          "frequency in Hz, y in log10 too): pick that timeline in the time panel to see them.",
          ""]
    return "\n".join(L)


def _blueprint(res):
    import rerun.blueprint as rrb

    runs = list(res.data)
    keys = sorted(set(zip(_piece_keys(res), (it.run for it in res.scored))))
    rate = []
    for r in runs:
        rate += [_p("runs", r, "truth", "rate"), _p("runs", r, "fog", "raw"),
                 _p("runs", r, "fog", "compensated") + "/**"]
    rate += [f"- {_p('runs', r, 'fog', 'compensated', k, 'raw')}" for k, r in keys]
    error = [_p("runs", r, "fog", "error") + "/**" for r in runs]
    temp = [x for r in runs for x in (_p("runs", r, "thermal", "chamber_c"),
                                       _p("runs", r, "thermal", "coil_c"))]
    tilt = [x for r in runs for x in (_p("runs", r, "table", "tilt_deg"),
                                       _p("runs", r, "table", "tilt_cmd_deg"))]
    turn = [x for r in runs for x in (_p("runs", r, "table", "turn_rate_dps"),
                                       _p("runs", r, "table", "turn_rate_cmd_dps"))]
    grav = [_p("runs", r, "gravity") + "/**" for r in runs]
    coil_rate = [_p("runs", r, "thermal", "coil_rate_c_per_min") for r in runs]
    terms = [_p("runs", r, "fog", "error_terms") + "/**" for r in runs]
    overview = rrb.Horizontal(
        rrb.Vertical(
            rrb.Spatial3DView(name="Rate table (3-D)", origin="/table"),
            rrb.TextDocumentView(name="Metrics", origin="/report/metrics"),
            row_shares=[3, 2]),
        rrb.Vertical(
            rrb.TimeSeriesView(name="Rate: truth, raw, compensated (deg/s)", contents=rate),
            rrb.TimeSeriesView(name="Error vs truth (deg/h)", contents=error),
            rrb.TimeSeriesView(name="Temperature (deg C)", contents=temp),
            row_shares=[3, 3, 2]),
        column_shares=[2, 3], name="Overview")
    environment = rrb.Grid(
        rrb.TimeSeriesView(name="Tilt (deg)", contents=tilt),
        rrb.TimeSeriesView(name="Turntable rate (deg/s)", contents=turn),
        rrb.TimeSeriesView(name="Gravity on the sensor axes (g)", contents=grav),
        rrb.TimeSeriesView(name="Coil dT/dt (deg C/min)", contents=coil_rate),
        grid_columns=2, name="Table and chamber")
    spectra = rrb.Horizontal(
        rrb.TimeSeriesView(name=f"Allan deviation of output - truth: log10 deg/h vs "
                                f"{TAU_TIMELINE}", origin="/report/allan"),
        rrb.TimeSeriesView(name=f"PSD: log10 (deg/s)^2/Hz vs {FREQ_TIMELINE}",
                           origin="/report/psd"),
        name="Allan / PSD")
    report = rrb.Horizontal(
        rrb.TextDocumentView(name="Metrics", origin="/report/metrics"),
        rrb.TextDocumentView(name="Scenario", origin="/report/scenario"),
        name="Report")
    return rrb.Blueprint(
        rrb.Tabs(overview, environment,
                 rrb.TimeSeriesView(name="FOG error terms (deg/h)", contents=terms),
                 spectra, report, active_tab=0),
        rrb.TimePanel(timeline=TIMELINE),
        collapse_panels=False)


# ---------------------------------------------------------------------------------------------
# fogbench view DIR
def _how_to(rrd: Path) -> str:
    return (f"To open the recording: `rerun {rrd}` (a native viewer; `rerun {rrd} --web-viewer` "
            f"serves it to a browser), or `python -m rerun {rrd}`. The viewer ships with "
            "rerun-sdk: `pip install rerun-sdk==0.41.*` (the recording's version).")


def _viewer_command() -> list[str] | None:
    """How to start the Rerun viewer of the installed rerun-sdk, or None."""
    spec = importlib.util.find_spec("rerun_cli")
    if spec is not None and spec.origin:
        exe = Path(spec.origin).with_name("rerun.exe" if os.name == "nt" else "rerun")
        if exe.is_file() and os.access(exe, os.X_OK):
            return [str(exe)]  # the binary bundled with this rerun-sdk: same version
    venv = Path(sys.executable).with_name("rerun")
    if venv.is_file() and os.access(venv, os.X_OK):
        return [str(venv)]
    found = shutil.which("rerun")
    return [found] if found else None


def _has_display() -> bool:
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def view(run_dir: Path) -> int:
    """Open ``run_dir/recording.rrd`` in the Rerun viewer.

    Returns 0 when the viewer was started, 2 when there is no recording, 1 when no viewer can be
    started here (no viewer installed, no display, or the viewer failed at once): a message then
    says how to open the file.
    """
    rrd = Path(run_dir) / "recording.rrd"
    if not rrd.is_file():
        print(f"fogbench view: no recording at {rrd} (written by `fogbench run` unless "
              "--no-recording)", file=sys.stderr)
        return 2
    cmd = _viewer_command()
    if cmd is None:
        print(f"fogbench view: no Rerun viewer found. {_how_to(rrd)}", file=sys.stderr)
        return 1
    if not _has_display():
        print(f"fogbench view: no display (DISPLAY and WAYLAND_DISPLAY unset). {_how_to(rrd)}",
              file=sys.stderr)
        return 1
    try:
        proc = subprocess.Popen([*cmd, str(rrd)], stdin=subprocess.DEVNULL,
                                start_new_session=True)
    except OSError as exc:
        print(f"fogbench view: cannot start {cmd[0]}: {exc}. {_how_to(rrd)}", file=sys.stderr)
        return 1
    try:
        rc = proc.wait(timeout=2.0)
    except subprocess.TimeoutExpired:
        print(f"fogbench view: opened {rrd} in the Rerun viewer")
        return 0
    if rc == 0:  # handed the file to a viewer already running, or closed at once
        return 0
    print(f"fogbench view: the viewer exited with status {rc}. {_how_to(rrd)}", file=sys.stderr)
    return 1
