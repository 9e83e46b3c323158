"""A run directory written whole: ``metrics.json``, ``report.md`` with its figures, the data
and ``recording.rrd``, into a part folder moved into place at the end."""

from __future__ import annotations

import dataclasses
import io
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from fogbench.outputs.files import atomic_write_bytes, atomic_write_text, versions
from fogbench.outputs.folders import (
    as_final,
    check_out_dir,
    discard_part,
    new_part_dir,
    replace_dir,
)
from fogbench.report.claims import (
    draw_claim_figures,
    open_on_answer,
)
from fogbench.report.coefficients import fig_coefficients
from fogbench.report.markdown import render_report, same_as_lab
from fogbench.report.montecarlo import (
    _insert_mc,
    fig_replicates,
    fig_runs,
    fig_starts,
    recording_replicates,
    render_bands,
    render_montecarlo,
)
from fogbench.report.spectra import fig_allan, fig_psd, shows_time_structure
from fogbench.report.thermal import fig_thermal, thermal_run
from fogbench.report.timeseries import fig_timeseries
from fogbench.report.views import offsets_only
from fogbench.run.runner import ScenarioResult, write_metrics
from fogbench.run.simulate import run_arrays

__all__ = ["write_run_dir"]


def write_run_dir(res: ScenarioResult, out: Path, recording: bool = True, save_data: bool = True,
                  montecarlo: dict | None = None, work=None, map_doc: dict | None = None,
                  map_run=None, figures: bool = True) -> Path:
    """Write metrics.json, report.md, figures, data (and recording.rrd) into ``out``.

    Everything is written into a hidden temporary sibling (its marker file first), which then
    replaces ``out``: an interrupted run leaves the previous complete directory, never a
    half-written one, and only an empty directory or a run directory of ours is ever replaced
    (``fogbench.outputs.folders``). A figure that cannot be drawn is left out with a note in the report.
    ``montecarlo`` is the replicate aggregate (``fogbench.run.montecarlo``; in ``metrics.json`` under
    that key, in the report, in the recording); ``work`` the replicates' work folder, whose files
    are copied into ``replicates/`` and which is removed once the directory is in place.
    ``map_doc`` is the claim map (``fogbench.run.maps``; in ``metrics.json`` under ``"map"``, a
    section and one figure per claim in the report), ``map_run`` its points, whose replicates
    are copied into ``map/point<i>/replicates/``. ``figures=False`` draws none (a bounds check
    that needs only the numbers; the report says so).
    """
    out = check_out_dir(out, "run")
    tmp = new_part_dir(out, "run", {"scenario": res.scenario.name,
                                    "scenario_file": str(res.scenario.path),
                                    "fogbench": versions().get("fogbench")})
    try:
        notes = [] if figures else ["figures: none drawn (--no-figures)"]
        figure = _figure_drawer(figures, notes)
        if figures:
            (tmp / "figures").mkdir()
        same = same_as_lab(res)
        fig_names, decim = _draw_run_figures(res, tmp / "figures", figure, same)
        _draw_summary_figures(res, montecarlo, map_doc, tmp / "figures", figure, fig_names)
        doc = res.metrics if montecarlo is None else {**res.metrics, "montecarlo": montecarlo}
        if map_doc is not None:
            doc = {**doc, "map": map_doc}
        write_metrics(tmp / "metrics.json", doc)
        text = _report_text(res, fig_names, decim, same, montecarlo, map_doc, notes)
        atomic_write_text(tmp / "report.md", text)
        atomic_write_text(tmp / "scenario.toml", res.scenario.text)
        if save_data:
            _write_data(res, tmp / "data")
        if recording:
            from fogbench.recording import write_recording

            write_recording(res, tmp / "recording.rrd",
                            replicates=None if montecarlo is None else
                            recording_replicates(montecarlo, work))
        if work is not None:
            work.copy_into(tmp, keep=list(range(montecarlo["replicates_requested"]))
                           if montecarlo else [0])
        if map_run is not None:
            map_run.copy_into(tmp)
        replace_dir(tmp, out, "run")
        if work is not None:
            work.remove()  # only now: until the run directory is in place it is the only copy
        if map_run is not None:
            map_run.remove()
    except OSError as exc:
        discard_part(tmp)
        raise as_final(exc, tmp, out) from None  # the file as the user will look for it
    except BaseException:
        discard_part(tmp)
        raise
    return out


def _figure_drawer(figures: bool, notes: list[str]):
    """The ``figure(what, fn, *args)`` every figure is drawn through: nothing when ``figures``
    is off, a note in ``notes`` for a figure that cannot be drawn."""

    def figure(what: str, fn, *args):
        """Draw one figure; a figure that cannot be drawn is noted, never fatal. A figure
        that cannot be written (a full disk, a file-size limit) or memory running out is
        an error of the whole command: nothing is put in place."""
        if not figures:
            return None
        try:
            return fn(*args)
        except (OSError, MemoryError):
            plt.close("all")
            raise
        except Exception as exc:
            plt.close("all")
            notes.append(f"figure {what} left out: {type(exc).__name__}: {exc}")
            return None

    return figure


def _draw_run_figures(res: ScenarioResult, figdir: Path, figure,
                      same: set) -> tuple[dict, dict]:
    """Each scored run's time series, PSD and Allan deviation in ``figdir`` (once per protocol
    and run; none for a lab twin the same as its ideal one): the figure names by (protocol,
    run, kind) and each time series' decimation by (protocol, run)."""
    fig_names, decim = {}, {}
    for it in res.scored:
        base = f"{it.protocol}__{it.run}"
        key = (it.protocol, it.run)
        if key in decim or key in same:
            continue
        decim[key] = figure(f"{base} time series", fig_timeseries, it,
                            figdir / f"{base}__timeseries.png", res.plan) or 1
        if (figdir / f"{base}__timeseries.png").exists():
            fig_names[(it.protocol, it.run, "timeseries")] = f"figures/{base}__timeseries.png"
        if not shows_time_structure(it.piece):
            continue        # no Allan deviation or PSD of stitched dwells (the rule above)
        if offsets_only(it):  # the others would lie on raw's curve: raw (its noise) alone
            it = dataclasses.replace(it, outputs={"raw": it.outputs["raw"]})
        figure(f"{base} PSD", fig_psd, it, figdir / f"{base}__psd.png", res.plan)
        if (figdir / f"{base}__psd.png").exists():
            fig_names[(it.protocol, it.run, "psd")] = f"figures/{base}__psd.png"
        if figure(f"{base} Allan", fig_allan, it, figdir / f"{base}__allan.png", res.plan):
            fig_names[(it.protocol, it.run, "allan")] = f"figures/{base}__allan.png"
    return fig_names, decim


def _draw_summary_figures(res: ScenarioResult, montecarlo: dict | None, map_doc: dict | None,
                          figdir: Path, figure, fig_names: dict) -> None:
    """The figures over the whole scenario into ``figdir``, their names added to
    ``fig_names``: each protocol's coefficients, the thermal run, the distributions over
    replicates and starts, the metric by run, the claims and the claim map."""
    for prot in res.plan.protocols:
        if figure(f"{prot.name} coefficients", fig_coefficients, res, prot.name,
                  figdir / f"{prot.name}__coefficients.png"):
            fig_names[(prot.name, None, "coefficients")] = \
                f"figures/{prot.name}__coefficients.png"
    if figure("thermal", fig_thermal, res, thermal_run(res), figdir / "thermal.png"):
        fig_names[("thermal",)] = "figures/thermal.png"
    if montecarlo is not None:
        if figure("replicate distributions", fig_replicates, res, montecarlo,
                  figdir / "replicates.png"):
            fig_names[("replicates",)] = "figures/replicates.png"
        if figure("start distributions", fig_starts, res, montecarlo, figdir / "starts.png"):
            fig_names[("starts",)] = "figures/starts.png"
        if figure("metric by run", fig_runs, res, montecarlo, figdir / "runs.png"):
            fig_names[("runs",)] = "figures/runs.png"
        fig_names.update(draw_claim_figures(montecarlo, figdir, figure))
    if map_doc is not None:
        from fogbench.report.maps import fig_map

        for k in range(len(map_doc["claims"])):
            if figure(f"claim map {k}", fig_map, map_doc, k, figdir / f"map__{k}.png"):
                fig_names[("map", k)] = f"figures/map__{k}.png"


def _report_text(res: ScenarioResult, fig_names: dict, decim: dict, same: set,
                 montecarlo: dict | None, map_doc: dict | None, notes: list[str]) -> str:
    """report.md's text: the run's report, opened on the answer over replicates (or with the
    bounds alone), the claim map's section, and the figures left out."""
    text = render_report(res, fig_names, decim, same)
    if montecarlo is not None:
        # the answer first: takeaway, verdicts, evidence; then the set-up
        text = open_on_answer(text, render_montecarlo(res, montecarlo, fig_names),
                              montecarlo, fig_names, res.plan)
    else:
        bands = render_bands(res, None)
        if bands:
            text = _insert_mc(text, "\n".join(bands))
    if map_doc is not None:
        from fogbench.report.maps import render_map

        text = _insert_mc(text, render_map(map_doc, fig_names))
    if notes:
        text += "\n## Left out\n\n" + "\n".join(f"- {n}" for n in notes) + "\n"
    return text


def _write_data(res: ScenarioResult, datadir: Path) -> None:
    """The data into ``datadir``: each run's arrays (``<run>.npz``, as ``fogbench simulate``
    writes them) and each scored piece (``scored__<protocol>__<run>.npz``: ``t_s``,
    ``truth_rps`` and every output as ``<label>_rps``). Not all rad/s: each array's unit is
    in its name (``_s`` s, ``_rps`` rad/s, ``_rad``, ``_g``, ``_m``, ``_c`` deg C; the
    table in ``fogbench.run.simulate``)."""
    datadir.mkdir()
    for name, rd in res.data.items():
        buf = io.BytesIO()
        np.savez_compressed(buf, **run_arrays(rd))
        atomic_write_bytes(datadir / f"{name}.npz", buf.getvalue())
    for it in res.scored:
        buf = io.BytesIO()
        np.savez_compressed(buf, t_s=it.piece.t, truth_rps=it.piece.truth,
                            **{f"{k}_rps": v for k, v in it.outputs.items()})
        atomic_write_bytes(datadir / f"scored__{it.protocol}__{it.run}.npz", buf.getvalue())
