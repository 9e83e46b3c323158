"""An Allan deviation curve given as a file (``fogbench allan --curve``, ``device fit
--curve``): ``tau_s``, ``adev_<unit>``, optional interval columns and ``axis``; its first line may
carry the record's ``sample_rate_hz`` and ``n_samples``."""

from __future__ import annotations

import re

import numpy as np

from fogbench.formats.csvfile import comment_fields, read_frame
from fogbench.formats.errors import LogError
from fogbench.formats.table import GYRO_UNITS, numeric

__all__ = ["read_curve"]


def read_curve(path, ci: float | None = None, with_header: bool = False):
    """Read an Allan deviation curve: ``tau_s``, ``adev_<unit>``, optionally
    ``adev_ci_low_<unit>``/``adev_ci_high_<unit>`` (or ``adev_low_``/``adev_high_``) and an
    ``axis`` column. Returns ``{axis: (taus s, adev rad/s, low rad/s or None, high or None)}``
    and the unit suffix (and, with ``with_header``, the ``key=value`` fields of its comment
    lines)."""
    if ci is not None and not (0 < ci < 1):
        raise LogError(f"--curve-ci: expected the probability content of the curve's interval "
                       f"columns, between 0 and 1 (e.g. 0.95), got {ci:g}")
    if with_header:
        header = comment_fields(path)
        curves, unit = read_curve(path, ci)
        return curves, unit, header
    frame, first_line = read_frame(path)
    if "tau_s" not in frame.columns:
        raise LogError(f"{path}: missing column 'tau_s'; columns: {', '.join(frame.columns)}")
    adev_cols = [c for c in frame.columns if c.startswith("adev_") and not re.match(
        r"adev_(ci_)?(low|high)_", c)]
    if len(adev_cols) != 1:
        raise LogError(f"{path}: expected exactly one column adev_<unit> (e.g. adev_dps), "
                       f"found {adev_cols or 'none'}")
    col = adev_cols[0]
    unit = col[5:].lower()
    if unit not in GYRO_UNITS or GYRO_UNITS[unit] is None:
        raise LogError(f"{path}: column {col!r}: unknown unit {unit!r}; known: "
                       f"{', '.join(u for u, f in GYRO_UNITS.items() if f is not None)}")
    factor = GYRO_UNITS[unit]
    low = high = None
    for lo_name, hi_name in ((f"adev_ci_low_{col[5:]}", f"adev_ci_high_{col[5:]}"),
                             (f"adev_low_{col[5:]}", f"adev_high_{col[5:]}")):
        if lo_name in frame.columns or hi_name in frame.columns:
            if not (lo_name in frame.columns and hi_name in frame.columns):
                raise LogError(f"{path}: give both {lo_name!r} and {hi_name!r} or neither")
            low, high = lo_name, hi_name
    if low is not None and ci is None:
        raise LogError(f"{path}: the curve has interval columns; give their probability "
                       "content with --curve-ci (e.g. 0.95 for 95 % bounds)")
    taus = numeric(path, frame, "tau_s", first_line)
    adev = numeric(path, frame, col, first_line) * factor
    lo = None if low is None else numeric(path, frame, low, first_line) * factor
    hi = None if high is None else numeric(path, frame, high, first_line) * factor
    axes = frame["axis"].astype(str).to_numpy() if "axis" in frame.columns else \
        np.array(["curve"] * len(frame))
    out = {}
    for ax in dict.fromkeys(axes):
        sel = axes == ax
        rows = np.flatnonzero(sel)
        bad = np.flatnonzero((taus[sel] <= 0) | (adev[sel] <= 0))
        if bad.size:
            raise LogError(f"{path}: {first_line(rows[bad[0]])}: tau_s and {col} must be "
                           "positive")
        if sel.sum() < 3:
            raise LogError(f"{path}: axis {ax!r}: {int(sel.sum())} points; at least 3 needed")
        if np.unique(taus[sel]).size != sel.sum():
            raise LogError(f"{path}: axis {ax!r}: duplicated tau_s")
        out[ax] = (taus[sel], adev[sel], None if lo is None else lo[sel],
                   None if hi is None else hi[sel])
    return out, unit
