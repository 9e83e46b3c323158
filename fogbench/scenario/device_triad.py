"""A triad device file: three gyros, one ``[x]``, ``[y]``, ``[z]`` table each, and the triad's
optional cross-axis matrices.

Each axis table holds the keys a one-axis device file holds (datasheet units in their names,
each axis's own values; ``input_axis``, where written, is the table's own axis). At the top
level, beside ``source``:

- ``Tw``: the 3x3 scale-factor-and-misalignment matrix M of ``w_meas = b + M w + G f``
  (dimensionless; the identity for a perfect triad; row a: gyro a's reading per unit rate
  about x, y, z), as :class:`fogcomp.triad.TriadModel` holds it and Kalibr / OpenVINS write
  ``Tw`` with the IMU frame the body axes (``R_IMUtoGYRO`` the identity; Kalibr's own ``Tw`` is
  lower triangular, with the rotation apart: ``fogbench.formats.kalibr``);
- ``Tg_dph_per_g``: the 3x3 g-sensitivity G (deg/h per g; row a: gyro a's d1-d3 on fx, fy, fz),
  OpenVINS' ``Tg`` per g instead of per m/s^2.

Where a matrix is given, it is each axis's scale factor and misalignment (``Tw``: row a is
gyro a's ``1 + scale_factor`` on its own axis and its misalignments on the others) or its
``g_sens_dph_per_g`` (``Tg_dph_per_g``): an axis table setting those keys as well is refused.
The thermal build and temperature sensor (``coil_time_constant_s``, ``temp_sensor_*``, ...)
are the rig's, one for the triad: top level only.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from fogbench.scenario.tables import ScenarioError, _Table
from fogcomp import units as U

__all__ = ["TRIAD_AXES", "CROSS_KEYS", "THERMAL_BUILD_KEYS", "is_triad", "check_triad_doc",
           "triad_fog", "triad_matrices"]

TRIAD_AXES = ("x", "y", "z")
CROSS_KEYS = ("Tw", "Tg_dph_per_g")
THERMAL_BUILD_KEYS = ("temp_sensor_location", "temp_sensor_time_constant_s",
                      "temp_sensor_noise_c", "temp_sensor_resolution_c", "temp_sensor_rate_hz",
                      "temp_rate_window_s", "housing_time_constant_s", "coil_time_constant_s")
G_SENS_LIMIT_DPH = 1e4       # deg/h per g (a DTG is ~10, MEMS ~100-1000)
TW_DIAG_LIMIT = 0.1          # |Tw[a][a] - 1|: the scale factor's limit (1e5 ppm)
TW_OFF_LIMIT = 0.1           # |Tw[a][b]|: the misalignment's limit (100 mrad)
# a [fog] key an axis table may not set where a matrix gives it
_BY_MATRIX = {"Tw": ("scale_factor_ppm", "misalignment_mrad"),
              "Tg_dph_per_g": ("g_sens_dph_per_g",)}


def is_triad(doc: dict) -> bool:
    """Whether a device file's (or a merged [fog] table's) keys are a triad's: an axis table."""
    return any(isinstance(doc.get(a), dict) for a in TRIAD_AXES)


def check_triad_doc(doc: dict, file: str) -> None:
    """The triad's layout (before its values are validated): the three axis tables, no other
    table, at the top level only ``source``, the matrices and the thermal build."""
    missing = [a for a in TRIAD_AXES if not isinstance(doc.get(a), dict)]
    if missing:
        have = [a for a in TRIAD_AXES if isinstance(doc.get(a), dict)]
        raise ScenarioError(f"{file}: a triad device file has the tables [x], [y] and [z]; it "
                            f"has {', '.join(f'[{a}]' for a in have)} and not "
                            f"{', '.join(f'[{a}]' for a in missing)}")
    allowed = {"source", *TRIAD_AXES, *CROSS_KEYS, *THERMAL_BUILD_KEYS}
    for k, v in doc.items():
        if isinstance(v, dict) and k not in TRIAD_AXES:
            raise ScenarioError(f"{file}: [{k}]: a triad device file has only the tables [x], "
                                "[y] and [z]")
        if k not in allowed:
            raise ScenarioError(f"{file}: key '{k}': at the top level of a triad device file "
                                f"only {', '.join(sorted(allowed - set(TRIAD_AXES)))}; a gyro's "
                                f"own keys go in its table ([x], [y], [z])")
    for a in TRIAD_AXES:
        for k, v in doc[a].items():
            if isinstance(v, dict):
                raise ScenarioError(f"{file}: [{a}.{k}]: an axis table has no tables")
            if k in THERMAL_BUILD_KEYS or k in ("source", "preset", "device", "axes"):
                raise ScenarioError(f"{file}: [{a}] key '{k}': not an axis's key in a triad "
                                    "device file (" + ("the thermal build and temperature "
                                                       "sensor are the triad's: top level"
                                                       if k in THERMAL_BUILD_KEYS else
                                                       "a scenario's choice or the file's") + ")")
        ia = doc[a].get("input_axis")
        if ia is not None and ia != a:
            raise ScenarioError(f"{file}: [{a}] key 'input_axis': the gyro of table [{a}] is "
                                f"on body axis {a}, got {ia!r}")


def _matrix(tbl: _Table, key: str, check, what: str):
    """A 3x3 list of lists of finite numbers, each passing ``check(i, j, x)``; None when
    absent."""
    m = tbl.get(key, "any", None)
    if m is None:
        return None
    ok = (isinstance(m, list) and len(m) == 3 and all(
        isinstance(r, list) and len(r) == 3 and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
            and check(i, j, x) for j, x in enumerate(r)) for i, r in enumerate(m)))
    if not ok:
        raise tbl.err(key, f"expected a 3x3 list of lists of finite numbers ({what}), got {m!r}")
    return np.asarray(m, dtype=float)


def triad_fog(values: dict, tbl: _Table, fs: float, fog_one):
    """A triad's [fog] keys (a triad device file's, with a scenario's keys over them) at ``fs``:
    (one FogParams per sensitive axis, or the one FogParams of a single axis; the axes; the
    thermal build). ``fog_one`` validates one axis's keys (``device_file._fog``). A scenario's
    own keys set over every axis (the thermal build's over the triad's); its ``axes`` pick the
    triad's gyros (default all three)."""
    merged = _Table(values, tbl.where, tbl.file)
    merged.used |= {"source", *TRIAD_AXES}
    axes = tuple(merged.get("axes", "strs", list(TRIAD_AXES), choices=set(TRIAD_AXES)))
    if not axes or len(set(axes)) != len(axes):
        raise merged.err("axes", f"expected 1 to 3 distinct axes among x, y, z, got {list(axes)}")
    Tw = _matrix(merged, "Tw", lambda i, j, x: abs(x - (i == j)) <= (
        TW_DIAG_LIMIT if i == j else TW_OFF_LIMIT), f"dimensionless; diagonal within 1 +- "
        f"{TW_DIAG_LIMIT:g}, off-diagonal within +-{TW_OFF_LIMIT:g}")
    Tg = _matrix(merged, "Tg_dph_per_g", lambda i, j, x: abs(x) <= G_SENS_LIMIT_DPH,
                 f"deg/h per g, each within +-{G_SENS_LIMIT_DPH:g}")
    top = {k: values[k] for k in THERMAL_BUILD_KEYS if k in values}
    over = {k: v for k, v in values.items()
            if k not in (*TRIAD_AXES, *CROSS_KEYS, *THERMAL_BUILD_KEYS, "source", "axes")}
    merged.used |= set(top) | set(over)
    merged.done()
    params, thermal = [], None
    for a in axes:
        data = {**values[a], **over, **top}
        for key, mat in (("Tw", Tw), ("Tg_dph_per_g", Tg)):
            clash = [k for k in _BY_MATRIX[key] if mat is not None and k in data]
            if clash:
                raise ScenarioError(f"{tbl.file}: {tbl.where} [{a}] key '{clash[0]}': the triad's "
                                    f"{key} gives it (row {a}); give one or the other")
        p, _, _, _, thermal, _ = fog_one(_Table(data, f"{tbl.where} [{a}]", tbl.file), fs)
        i = TRIAD_AXES.index(a)
        if np.asarray(p.g_sens).ndim != 1 or np.asarray(p.g2_sens).ndim != 1:
            raise ScenarioError(f"{tbl.file}: {tbl.where} [{a}]: g_sens_dph_per_g and "
                                "g2_sens_dph_per_g2 of an axis table are one list (that gyro's)")
        if Tw is not None:
            mis = np.zeros((3, 3))
            mis[i] = Tw[i]
            mis[i, i] = 0.0
            p = replace(p, scale_factor=float(Tw[i, i] - 1.0),
                        misalignment=tuple(map(tuple, mis)))
        if Tg is not None:
            p = replace(p, g_sens=tuple(float(x) * U.DPH for x in Tg[i]))
        params.append(p)
    return (params[0] if len(params) == 1 else tuple(params)), axes, thermal


def triad_matrices(params, axes=TRIAD_AXES) -> tuple[np.ndarray, np.ndarray]:
    """(M, G) of a simulated triad, SI (G in rad/s per g), as :class:`fogcomp.triad.TriadModel`
    holds them: row a from axis a's parameters (one FogParams for every axis, or one per axis
    of ``axes``, which must be x, y, z)."""
    if tuple(axes) != TRIAD_AXES:
        raise ValueError(f"a triad's matrices need the axes x, y, z, got {tuple(axes)}")
    per = params if isinstance(params, (tuple, list)) else (params,) * 3
    M, G = np.zeros((3, 3)), np.zeros((3, 3))
    for i, p in enumerate(per):
        M[i] = np.asarray(p.misalignment, dtype=float)[i]
        M[i, i] = 1.0 + p.scale_factor
        g = np.asarray(p.g_sens, dtype=float)
        G[i] = g if g.ndim == 1 else g[i]
    return M, G
