"""A Rerun recording of integrated attitude beside the true one (issue 42).

Entity paths (the world frame is the local level NED frame, x north, y east, z down):

- ``/attitude/truth``: the triad's case at its true attitude (grey, solid);
- ``/attitude/<reading>``: the case at the attitude integrated from that reading's rates
  (``raw``, ``triad_calibrated``, ``oracle``, ...), drawn over the truth as a wire frame in its
  colour, with its orientation error *magnified* by the factor in the entity's label and in
  ``/attitude/README`` (a navigation-grade error of a tenth of a degree cannot be seen at its
  size; the magnified body turns away from the truth as the error grows, in the error's own
  direction);
- ``/attitude/error/<reading>``: the orientation error, deg, not magnified (time series).

Timeline ``time`` (s from the start of the integration). The recording is written from memory
by this process (as :func:`fogbench.recording.write.write_recording` is), atomically.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .entities import APPLICATION_ID

__all__ = ["write_attitude_recording", "magnification"]

#: Half sizes of the drawn case, m (a triad's block, longest along x).
CASE_HALF_M = (0.12, 0.07, 0.04)
COLORS = {"raw": (214, 39, 40), "bias_at_alignment": (255, 127, 14),
          "triad_calibrated": (31, 119, 180), "oracle": (44, 160, 44), "truth": (127, 127, 127)}


def magnification(max_error_deg: float, shown_deg: float = 15.0) -> float:
    """The power of ten that shows the largest error as at most ``shown_deg`` (at least 1)."""
    if not (max_error_deg > 0 and math.isfinite(max_error_deg)):
        return 1.0
    return float(max(1.0, 10.0 ** math.floor(math.log10(shown_deg / max_error_deg))))


def _colour_name(c) -> str:
    return {(214, 39, 40): "red", (255, 127, 14): "orange", (31, 119, 180): "blue",
            (44, 160, 44): "green"}.get(tuple(c) if c else None, "purple")


def _blueprint(t_end: float):
    """The 3D view of the bodies beside one plot of every error over the whole integration,
    and the README under it."""
    import rerun as rr
    import rerun.blueprint as rrb

    whole = rrb.VisibleTimeRange("time", start=rrb.TimeRangeBoundary.infinite(),
                                 end=rrb.TimeRangeBoundary.infinite())
    axis = rrb.TimeAxis(view_range=rr.TimeRange(start=rrb.TimeRangeBoundary.absolute(seconds=0.0),
                                                end=rrb.TimeRangeBoundary.absolute(seconds=t_end)))
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(name="attitude: truth (grey) and integrated (errors magnified)",
                              origin="/attitude", contents=["+ /attitude/**",
                                                            "- /attitude/error/**",
                                                            "- /attitude/README"],
                              # from the south-west and above (NED: up is -z), 0.5 m off
                              eye_controls=rrb.EyeControls3D(position=(-0.28, -0.32, -0.28),
                                                             look_target=(0.0, 0.0, 0.0),
                                                             eye_up=(0.0, 0.0, -1.0))),
            rrb.Vertical(
                rrb.TimeSeriesView(name="orientation error, deg (not magnified)",
                                   origin="/attitude/error", time_ranges=[whole], axis_x=axis,
                                   plot_legend=rrb.PlotLegend(visible=True, corner="LeftTop")),
                rrb.TextDocumentView(name="what this shows", origin="/attitude/README"),
                row_shares=[3, 1]),
            column_shares=[1, 1]),
        rrb.TimePanel(timeline="time"), collapse_panels=False)


def write_attitude_recording(path, t, truth, estimates: dict, title: str = "attitude",
                             magnify: float | None = None, max_points: int = 20_000) -> float:
    """Write ``path`` (.rrd): the truth and each estimate (scipy Rotations of ``len(t)``, body
    -> NED) as bodies, each estimate's orientation error magnified (``magnify``; default
    :func:`magnification` of the largest error), and the errors in deg. Returns the
    magnification used."""
    import rerun as rr
    from scipy.spatial.transform import Rotation

    t = np.asarray(t, dtype=float)
    if not isinstance(truth, Rotation) or len(truth) != t.size:
        raise ValueError(f"truth must be a Rotation of {t.size} attitudes")
    for name, est in estimates.items():
        if not isinstance(est, Rotation) or len(est) != t.size:
            raise ValueError(f"estimate {name!r} must be a Rotation of {t.size} attitudes")
    step = max(1, int(math.ceil(t.size / max_points)))
    s = slice(None, None, step)
    err_vec = {k: (truth[s].inv() * e[s]).as_rotvec() for k, e in estimates.items()}
    err_deg = {k: np.degrees(np.linalg.norm(v, axis=1)) for k, v in err_vec.items()}
    big = max((float(np.max(v)) for v in err_deg.values()), default=0.0)
    mag = magnification(big) if magnify is None else float(magnify)

    rec = rr.RecordingStream(application_id=APPLICATION_ID, recording_id=title,
                             send_properties=False)
    mem = rec.memory_recording()
    try:
        rec.log("/attitude", rr.ViewCoordinates.RIGHT_HAND_Z_DOWN, static=True)
        colours = ", ".join(f"{k} {_colour_name(COLORS.get(k))}" for k in estimates)
        rec.log("/attitude/README", rr.TextDocument(
            f"# {title}\n\nThe grey solid body is the triad at its true attitude (NED: x north, "
            "y east, z down). Each wire frame is the attitude integrated from one reading's "
            f"rates ({colours}), with its orientation error **magnified {mag:g} times** so "
            "that it can be seen; the plot holds the errors in degrees, not magnified. "
            f"Largest error: {big:.4g} deg.", media_type="text/markdown"), static=True)
        tcol = [rr.TimeColumn("time", duration=np.rint(t[s] * 1e9).astype("timedelta64[ns]"))]
        rec.log("/attitude/truth", rr.Boxes3D(half_sizes=[CASE_HALF_M], colors=[COLORS["truth"]],
                                              fill_mode="solid", labels=["truth"]), static=True)
        rec.send_columns("/attitude/truth", indexes=tcol, columns=rr.Transform3D.columns(
            quaternion=np.ascontiguousarray(truth[s].as_quat())))
        for name, v in err_vec.items():
            color = COLORS.get(name, (148, 103, 189))
            shown = truth[s] * Rotation.from_rotvec(mag * v)
            rec.log(f"/attitude/{name}", rr.Boxes3D(
                half_sizes=[tuple(1.02 * h for h in CASE_HALF_M)], colors=[color],
                labels=[f"{name} (error x{mag:g})"], show_labels=False), static=True)
            rec.send_columns(f"/attitude/{name}", indexes=tcol, columns=rr.Transform3D.columns(
                quaternion=np.ascontiguousarray(shown.as_quat())))
            rec.log(f"/attitude/error/{name}", rr.SeriesLines(colors=[color], names=[
                f"{name} orientation error, deg"]), static=True)
            rec.send_columns(f"/attitude/error/{name}", indexes=tcol,
                             columns=rr.Scalars.columns(scalars=err_deg[name]))
        rec.send_blueprint(_blueprint(t[-1] if t.size else 0.0), make_active=True,
                           make_default=True)
        rec.flush()
        data = mem.drain_as_bytes()
    finally:
        rec.disconnect()
    from fogcomp._persistence import atomic_write_bytes

    atomic_write_bytes(Path(path), data)
    return mag
