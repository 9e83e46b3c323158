"""Noise parameters in the files visual-inertial tools read: Kalibr's ``imu.yaml`` and the
``kalibr_imu_chain.yaml`` of OpenVINS.

Kalibr's IMU noise model (its wiki, "IMU Noise Model"; Furgale et al. 2013) has per sensor a
white-noise density and a bias random walk, continuous time, SI:

- ``gyroscope_noise_density`` sigma_g, rad/s/sqrt(Hz): the white rate noise, the Allan term N
  (IEEE Std 952-1997, annex C: sigma^2(tau) = N^2 / tau, N in rad/s/sqrt(Hz) = rad/sqrt(s));
- ``gyroscope_random_walk`` sigma_bg, rad/s^2/sqrt(Hz): the bias random walk, the Allan term K
  (sigma^2(tau) = K^2 tau / 3, K in rad/s^2/sqrt(Hz) = rad/s/sqrt(s));
- ``accelerometer_noise_density`` (m/s^2/sqrt(Hz)) and ``accelerometer_random_walk``
  (m/s^3/sqrt(Hz)): the same terms of the accelerometer;
- ``update_rate``: the log's sample rate, Hz (Kalibr discretises with it: sigma_d = sigma
  sqrt(rate), sigma_bd = sigma_b / sqrt(rate)).

One value per sensor: the largest over the axes the log has (a filter that trusts one axis more
than it deserves diverges; the per-axis values are in the file's comments). A term the record
does not show is written as its one-sided 95 % upper bound, and the comment says so.

Neither tool's noise model has a Gauss-Markov state (Kalibr's is white noise and a random
walk per sensor; OpenVINS reads the same four keys): the Gauss-Markov terms the record shows
are written as comments, every one of every axis (sigma, correlation time and its interval;
:func:`gm_terms`), with the discrete form in ``allan.json``'s ``filter`` entry, for a filter
that carries them.

Kalibr's wiki recommends inflating the values for "unmodelled effects" (its example multiplies
the noise density by up to 10), and users of allan_variance_ros do the same because a static
bench record misses vibration and temperature (allan_variance_ros, GitHub issue #44): ``--inflate-density``
and ``--inflate-walk`` do it, never by default, and the file states the factor and the
uninflated values.

Written by hand: these are two short YAML files of a fixed layout, with comments no YAML
library keeps; the tests load them back with PyYAML.

The Ferraris intrinsics (``calibrate ferraris --kalibr / --openvins``)
--------------------------------------------------------------------------------
:func:`intrinsics_from_ferraris` turns a :class:`fogcomp.calibration.TriadCalibration` into the
scale-misalignment intrinsics of both tools; :func:`kalibr_intrinsics_text` and
:func:`openvins_intrinsics_text` write them. The conventions, as the sources state them
(ethz-asl/kalibr at 1f60227, rpng/open_vins at 69488123):

fogbench (``fogcomp/calibration.py``, module docstring; Ferraris et al. 1995 eqs. 1-2), true to
measured, body frame b = the calibration jig's faces, specific force f (gravity included)::

    acc_raw = K_a R_a f_b + b_a          gyr_raw = K_g R_g w_b + K_ga f_b + b_g

``K`` diagonal (raw per SI), ``R`` rows the unit sensitive axes in b (not a rotation),
``K_ga`` raw per m/s^2, column j the response to specific force along body axis j.

Kalibr, model ``scale-misalignment``
(``aslam_offline_calibration/kalibr/python/kalibr_imu_camera_calibration/IccSensors.py``)::

    l. 999:   a = M * (C_i_b * (C_b_w * (a_w - g_w) + ...))      accelerometer, + bias b_i
    l. 1045:  C_gyro_b = C_gyro_i * C_i_b
    l. 1049:  w = M * (C_gyro_b * w_b) + Ma * (C_gyro_b * a_b)    gyro, + bias b_i
    l. 955-965: M_accel and M_gyro are MatrixBasicDv with the pattern
                [[1,0,0],[1,1,0],[1,1,1]] (lower triangular), Ma (``A``) a full 3x3
    l. 933-939: the result yaml holds accelerometers: {M}, gyroscopes: {M, A, C_gyro_i}
    l. 925:   "A [(rad/s)/(m/s^2)]"

i.e. true to measured, ``w_m = M_g C_gyro_i w_i + A C_gyro_i f_i + b_g``,
``f_m = M_a f_i + b_a``; C_i_b is the identity for the reference IMU (imu0, l. 658-666), so
the IMU frame i is the accelerometer's own (M_a lower triangular): x along its x sensitive axis,
y in the plane of its x and y axes.
Kalibr reads no intrinsics (it starts M from the identity, l. 955-965); the block is its
*output* (``<bag>-imu.yaml``, ``ConfigReader.ImuSetParameters``), which tools such as OpenVINS
read back.

OpenVINS (``docs/propagation.dox`` l. 31-36; ``ov_msckf/src/core/VioManagerOptions.h``
l. 305-349; ``ov_msckf/src/state/Propagator.cpp`` l. 415-427; ``ov_msckf/src/state/State.h``
l. 96)::

    w_m = T_w  R_IMUtoGYRO w_I + T_g f_I + b_g + n_g     (propagation.dox l. 33-34)
    a_m = T_a  R_IMUtoACC  f_I + b_a + n_a               (propagation.dox l. 35-36)
    Dw = Tw^-1, Da = Ta^-1 (VioManagerOptions.h l. 319-320); R_GYROtoIMU = R_IMUtoGYRO^T (l. 322)
    "kalibr" model: only the lower triangle of Dw, Da is kept (l. 343-344, State.h l. 96)
    a_hat = R_ACCtoIMU Da (a_m - b_a); w_hat = R_GYROtoIMU Dw (w_m - b_g - Tg a_hat)
                                                         (Propagator.cpp l. 415, 420, 427)

so ``T_g`` multiplies the specific force in the IMU frame I, (rad/s)/(m/s^2), and its
``model: "kalibr"`` is Kalibr's model with I = i. OpenVINS' example file
(``config/rpng_sim/kalibr_imu_chain.yaml`` l. 19-24) says "Tg is imu0:gyroscopes:A"; by the two
equations above that holds only where C_gyro_i is the identity: exactly, ``Tg = A C_gyro_i``,
which is what is written here.

The conversion (all true to measured; c_g, c_a the SI value of one raw unit, 1 for a log in a
physical unit, which fogbench reads into SI): LQ-factor ``c_a K_a R_a = L_a C_ib`` (L_a lower
triangular, C_ib a proper rotation: the tools' frame I = i relative to the body frame,
``v_I = C_ib v_b``), then ``c_g K_g R_g C_ib^T = L_g C_gi``, and::

    Kalibr accelerometers.M = OpenVINS Ta = L_a           R_IMUtoACC = I
    Kalibr gyroscopes.M     = OpenVINS Tw = L_g           gyroscopes.C_gyro_i = R_IMUtoGYRO = C_gi
    OpenVINS Tg = c_g K_ga C_ib^T                         Kalibr gyroscopes.A = Tg C_gi^T

Substituting gives back fogbench's model exactly: ``L_a C_ib f_b = c_a K_a R_a f_b`` and
``L_g C_gi (C_ib w_b) + Tg (C_ib f_b) = c_g (K_g R_g w_b + K_ga f_b)``. A triad whose matrix has
a negative determinant (a sensitive axis of reversed sense) keeps a proper rotation and takes
the sign on one diagonal element of M. The biases are estimated online by both tools; they are
written as comments (SI).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["NoiseValue", "pick", "values_from_models", "gm_terms", "kalibr_text",
           "openvins_text", "is_own", "MARK", "TEXTS", "ToolIntrinsics",
           "intrinsics_from_ferraris", "kalibr_intrinsics_text", "openvins_intrinsics_text",
           "INTRINSICS_TEXTS"]

MARK = "# written by fogbench "


@dataclass(frozen=True)
class NoiseValue:
    """One Kalibr entry: the value (SI, uninflated), its origin ("identified" or "upper
    bound") and the axis it came from; ``per_axis`` maps axis -> (value, origin)."""

    value: float
    origin: str
    axis: str
    per_axis: dict


def pick(models: dict, term: str) -> NoiseValue | None:
    """The Kalibr value of one term (``"N"`` or ``"K"``) over the axes' noise models
    (``{axis: fogcomp.noise.NoiseModel}``): the largest identified value or, where an axis does
    not show the term, its 95 % upper bound; None when no axis gives either."""
    per = {}
    for ax, m in models.items():
        t = m.term(term)
        if t.status == "identified" and t.value is not None:
            per[ax] = (float(t.value), "identified")
        elif t.bound is not None:
            per[ax] = (float(t.bound), "upper bound")
    if not per:
        return None
    ax = max(per, key=lambda a: per[a][0])
    return NoiseValue(per[ax][0], per[ax][1], ax, per)


def values_from_models(gyro: dict, acc: dict | None) -> dict:
    """The four Kalibr entries from the identified noise models of each axis (``{axis:
    NoiseModel}``; ``acc`` None when the log has no accelerometer): {(sensor, term): NoiseValue
    or None, or the string saying why it is missing}."""
    out = {}
    for sensor, models in (("gyroscope", gyro), ("accelerometer", acc)):
        for term in ("N", "K"):
            if models is None:
                out[sensor, term] = (f"not in this log (no {sensor} columns); fill it in "
                                     "before Kalibr reads the file")
            else:
                out[sensor, term] = pick(models, term) or (
                    f"the record neither shows nor bounds {term}; fill it in")
        if models is not None:
            out[sensor, "GM"] = gm_terms(models)
    return out


def gm_terms(models: dict) -> list:
    """Every identified Gauss-Markov term of every axis (``{axis: NoiseModel}``): ``[(axis,
    sigma SI, correlation time s, (its interval's low, high) s)]``, by axis then correlation
    time. Neither tool's noise model holds them: the files list them all as comments."""
    return [(ax, float(t.value), float(t.tau), (t.tau_low, t.tau_high))
            for ax, m in models.items() for t in m.gm_terms if t.status == "identified"]


def _side(x, open_side: str) -> str:
    """One side of an interval; ``open_side`` where the record does not bound it (None)."""
    return open_side if x is None else f"{x:.3g}"


def _gm_comments(values: dict) -> list:
    """The comment lines of the Gauss-Markov terms in ``values`` (``(sensor, "GM")``)."""
    lines = []
    for sensor in ("gyroscope", "accelerometer"):
        gms = values.get((sensor, "GM")) or []
        if gms:
            unit = "rad/s" if sensor == "gyroscope" else "m/s^2"
            lines.append(f"{sensor}: {len(gms)} Gauss-Markov term(s) the record shows; this "
                         "noise model has no state for them (white noise and a random walk "
                         "only), so none is written as a key: a filter that carries them takes "
                         "each sigma and tau (discrete form: allan.json's 'filter')")
            lines += [f"  {ax}: sigma {sg:.6g} {unit}, tau {T:.6g} s (interval "
                      f"{_side(lo, '0')}..{_side(hi, 'inf')} s)" for ax, sg, T, (lo, hi) in gms]
    return lines


_UNITS = {("gyroscope", "N"): "rad/s/sqrt(Hz)", ("gyroscope", "K"): "rad/s^2/sqrt(Hz)",
          ("accelerometer", "N"): "m/s^2/sqrt(Hz)", ("accelerometer", "K"): "m/s^3/sqrt(Hz)"}
_KEYS = {"N": "noise_density", "K": "random_walk"}


def _entries(values: dict, inflate_density: float, inflate_walk: float,
             gyro_only: bool = False):
    """(key, value or None, comment lines) for the four noise keys, in Kalibr's order
    (``gyro_only``: the factors inflate the gyroscope's values only, as a factor measured on
    the gyros)."""
    out = []
    for sensor in ("gyroscope", "accelerometer"):
        for term in ("N", "K"):
            name, unit = f"{sensor}_{_KEYS[term]}", _UNITS[sensor, term]
            f = inflate_density if term == "N" else inflate_walk
            if gyro_only and sensor != "gyroscope":
                f = 1.0
            v = values.get((sensor, term), "not given; fill it in")
            if isinstance(v, str):
                out.append((name, None, [f"{name}: {v}"]))
                continue
            notes = [f"{name} [{unit}]: Allan {term} of {v.axis}, {v.origin}"
                     + (" (95 %, the record does not show the term)"
                        if v.origin == "upper bound" else "")
                     + ("; inflated x" + f"{f:g} from {v.value:.6g}" if f != 1.0 else "")]
            if len(v.per_axis) > 1:
                notes.append("  per axis: " + ", ".join(f"{a} {x:.6g} ({o})"
                                                        for a, (x, o) in v.per_axis.items()))
            out.append((name, v.value * f, notes))
    return out


def _header(source: str, fs: float, inflate_density: float, inflate_walk: float, what: str,
            command: str, measured: tuple = (), measured_applied: bool = False):
    lines = [f"{MARK}{command}: {what} from {source}",
             "# Kalibr IMU noise model, continuous time, SI: noise density = Allan N (IEEE Std",
             "# 952-1997 annex C, sigma^2(tau) = N^2/tau), random walk = Allan K",
             "# (sigma^2(tau) = K^2 tau/3)" + ("; the largest value over the log's axes."
                                                if command == "allan" else ".")]
    lines += [f"# {m}" for m in measured]
    if measured_applied:
        lines.append(f"# INFLATED x{inflate_density:.4g} (the gyroscope's noise density and "
                     "random walk; the accelerometer's as identified) as measured above "
                     "(--inflate-measured)")
    elif inflate_density != 1.0 or inflate_walk != 1.0:
        lines.append(f"# INFLATED (--inflate-density {inflate_density:g}, --inflate-walk "
                     f"{inflate_walk:g}) for effects a static record misses (Kalibr wiki, IMU "
                     "Noise Model; allan_variance_ros #44)")
    else:
        lines.append("# not inflated (Kalibr's wiki suggests inflating for unmodelled effects: "
                     "--inflate-density, --inflate-walk)")
    lines.append(f"# update_rate: {fs:.9g} Hz, " + ("the log's sample rate" if command == "allan"
                                                     else "--rate-hz"))
    return lines


def kalibr_text(values: dict, fs: float, source: str, *, topic: str = "/imu0",
                inflate_density: float = 1.0, inflate_walk: float = 1.0,
                command: str = "allan", measured: tuple = (),
                measured_applied: bool = False) -> str:
    """Kalibr's ``imu.yaml`` (``kalibr_calibrate_imu_camera --imu``) of the entries
    ``values`` ({(sensor, term): NoiseValue or why it is missing}); ``measured``: comment
    lines saying how the inflation factor was measured (``fogbench allan --consistency``),
    ``measured_applied``: the factors given are that measurement's."""
    lines = _header(source, fs, inflate_density, inflate_walk, "Kalibr imu.yaml", command,
                    measured, measured_applied)
    for key, value, notes in _entries(values, inflate_density, inflate_walk, measured_applied):
        lines += [f"# {n}" for n in notes]
        lines.append(f"{key}: {_num9(value)}" if value is not None else f"# {key}:")
    lines += [f"# {n}" for n in _gm_comments(values)]
    lines += [f"rostopic: {topic}", f"update_rate: {_num(fs)}"]
    return "\n".join(lines) + "\n"


def openvins_text(values: dict, fs: float, source: str, *,
                  topic: str = "/imu0", inflate_density: float = 1.0,
                  inflate_walk: float = 1.0, command: str = "allan", measured: tuple = (),
                  measured_applied: bool = False) -> str:
    """OpenVINS' ``kalibr_imu_chain.yaml`` (its ``model: kalibr`` form, identity intrinsics:
    the noise only). It starts ``%YAML 1.0``, its comments, ``---`` (see ``_OPENCV_YAML``):
    OpenCV, which OpenVINS reads it with, and PyYAML load it as it is. ``measured``,
    ``measured_applied``: as :func:`kalibr_text`."""
    lines = [_OPENCV_YAML, *_header(source, fs, inflate_density, inflate_walk,
                                    "OpenVINS kalibr_imu_chain.yaml", command, measured,
                                    measured_applied), "---", "imu0:",
             "  T_i_b:"] + [f"    - [{', '.join('1.0' if i == j else '0.0' for j in range(4))}]"
                            for i in range(4)]
    for key, value, notes in _entries(values, inflate_density, inflate_walk, measured_applied):
        lines += [f"  # {n}" for n in notes]
        lines.append(f"  {key}: {_num9(value)}" if value is not None else f"  # {key}:")
    lines += [f"  # {n}" for n in _gm_comments(values)]
    ident = [f"    - [{', '.join('1.0' if i == j else '0.0' for j in range(3))}]"
             for i in range(3)]
    zero = ["    - [0.0, 0.0, 0.0]"] * 3
    lines += [f"  rostopic: {topic}", "  time_offset: 0.0", f"  update_rate: {_num(fs)}",
              '  model: "kalibr"', "  Tw:", *ident, "  R_IMUtoGYRO:", *ident, "  Ta:", *ident,
              "  R_IMUtoACC:", *ident, "  Tg:", *zero]
    return "\n".join(lines) + "\n"


def is_own(path) -> bool:
    """A file this module wrote (its mark in the first two lines)."""
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            head = [f.readline() for _ in range(2)]
    except OSError:
        return False
    return any(line.startswith(MARK) and ("imu.yaml" in line or "imu_chain.yaml" in line)
               for line in head)


def check_factor(flag: str, v: float) -> float:
    if not (math.isfinite(v) and 1.0 <= v <= 1000.0):
        raise ValueError(f"{flag}: expected a factor from 1 to 1000, got {v:g} (a factor "
                         "below 1 would claim a better sensor than the record shows)")
    return v


TEXTS = {"kalibr": kalibr_text, "openvins": openvins_text}


# ---------------------------------------------------------------------------------------------
# Ferraris intrinsics. Conventions and sources: the module docstring.

#: The first line of the OpenVINS file. OpenCV's FileStorage (which OpenVINS reads it with) takes
#: a file whose first bytes are "%YAML" and whose directive is "%YAML:1." or "%YAML 1."
#: (opencv modules/core/src/persistence.cpp, open(); persistence_yml.cpp, parse()); PyYAML reads
#: only the second form, and after a directive wants the document start "---". So this file
#: starts "%YAML 1.0", its comments, then "---": both readers load it as it is.
_OPENCV_YAML = "%YAML 1.0"


@dataclass(frozen=True)
class ToolIntrinsics:
    """A Ferraris calibration in Kalibr's and OpenVINS' conventions (true to measured, SI).

    Attributes
    ----------
    Ta : ndarray, shape (3, 3)
        Kalibr ``accelerometers: M`` = OpenVINS ``Ta``; lower triangular, dimensionless.
    Tw : ndarray, shape (3, 3)
        Kalibr ``gyroscopes: M`` = OpenVINS ``Tw``; lower triangular, dimensionless.
    R_IMUtoGYRO : ndarray, shape (3, 3)
        Kalibr ``gyroscopes: C_gyro_i`` = OpenVINS ``R_IMUtoGYRO``: a rotation, vectors in the
        IMU frame I to the gyro frame.
    Tg : ndarray, shape (3, 3)
        OpenVINS ``Tg``, (rad/s)/(m/s^2), multiplies the specific force in I.
    A : ndarray, shape (3, 3)
        Kalibr ``gyroscopes: A``, (rad/s)/(m/s^2), multiplies the specific force in the gyro
        frame: ``A = Tg R_IMUtoGYRO^T``.
    C_i_body : ndarray, shape (3, 3)
        Rotation from the calibration's body frame to I: ``v_I = C_i_body v_b``.
    acc_bias, gyro_bias : ndarray, shape (3,)
        The calibration's biases in the measurements' SI units (m/s^2, rad/s); both tools
        estimate them online, so they are only written as comments.
    g : float
        The gravity the calibration assumed, m/s^2.
    """

    Ta: np.ndarray
    Tw: np.ndarray
    R_IMUtoGYRO: np.ndarray
    Tg: np.ndarray
    A: np.ndarray
    C_i_body: np.ndarray
    acc_bias: np.ndarray
    gyro_bias: np.ndarray
    g: float

    @property
    def R_IMUtoACC(self) -> np.ndarray:
        """The identity: in Kalibr's model (and OpenVINS' "kalibr" one) I is the accelerometer
        frame."""
        return np.eye(3)

    def angle_deg(self) -> float:
        """Angle of ``C_i_body``, deg: how far the tools' frame I is from the body frame."""
        c = (np.trace(self.C_i_body) - 1.0) / 2.0
        return math.degrees(math.acos(max(-1.0, min(1.0, float(c)))))


def _lq_proper(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``m = L Q``: L lower triangular, Q a proper rotation (det +1), diag(L) positive where
    det(m) > 0; otherwise the one diagonal element whose flip keeps Q nearest the identity is
    negative."""
    q, r = np.linalg.qr(m.T)                      # m^T = q r  =>  m = r^T q^T
    low, rot = r.T.copy(), q.T.copy()
    s = np.where(np.diag(low) < 0, -1.0, 1.0)     # L diag(s) diag(s) Q: column / row signs
    low, rot = low * s[None, :], s[:, None] * rot
    if np.linalg.det(rot) < 0:
        k = int(np.argmin(np.diag(rot)))
        low[:, k] *= -1.0
        rot[k, :] *= -1.0
    low[np.triu_indices(3, 1)] = 0.0              # exactly zero above the diagonal
    return low, rot


def _si_factor(name: str, v) -> float:
    if not (isinstance(v, (int, float, np.floating)) and not isinstance(v, bool)
            and math.isfinite(v) and v > 0):
        raise ValueError(f"{name}: expected the positive SI value of one raw unit, got {v!r}")
    return float(v)


def intrinsics_from_ferraris(cal, *, gyro_si: float = 1.0, acc_si: float = 1.0) -> ToolIntrinsics:
    """Kalibr's and OpenVINS' intrinsics of a Ferraris calibration.

    Parameters
    ----------
    cal : fogcomp.calibration.TriadCalibration
        The calibration (``calibrate ferraris``), made on readings the tools will receive.
    gyro_si, acc_si : float, optional
        rad/s and m/s^2 of one raw unit of those readings: 1 (the default) for a log whose
        columns are in a physical unit, which fogbench reads into SI. Kalibr and OpenVINS read
        ``sensor_msgs/Imu`` in rad/s and m/s^2; a log in raw counts needs the factor its driver
        publishes with.

    Returns
    -------
    ToolIntrinsics

    The conversion (module docstring): ``acc_si K_a R_a = Ta C_i_body``,
    ``gyro_si K_g R_g C_i_body^T = Tw R_IMUtoGYRO``, ``Tg = gyro_si K_ga C_i_body^T``,
    ``A = Tg R_IMUtoGYRO^T``.
    """
    from fogcomp.calibration import TriadCalibration

    if not isinstance(cal, TriadCalibration):
        raise TypeError(f"cal: expected a fogcomp TriadCalibration, got {type(cal).__name__}")
    cg, ca = _si_factor("gyro_si", gyro_si), _si_factor("acc_si", acc_si)
    # accelerometer: c_a K_a R_a = L_a C_ib (Kalibr IccSensors.py l. 999: a_m = M f_i + b)
    ta, c_ib = _lq_proper(ca * np.diag(cal.acc_scale) @ cal.acc_misalignment)
    # gyro: c_g K_g R_g w_b = c_g K_g R_g C_ib^T w_I = L_g C_gi w_I (IccSensors.py l. 1049)
    tw, c_gi = _lq_proper(cg * np.diag(cal.gyro_scale) @ cal.gyro_misalignment @ c_ib.T)
    # g-sensitivity: c_g K_ga f_b = c_g K_ga C_ib^T f_I = Tg f_I (propagation.dox l. 34), and
    # Kalibr's A multiplies C_gyro_i f_I (IccSensors.py l. 1049): A = Tg C_gi^T
    tg = cg * cal.gyro_g_sensitivity @ c_ib.T
    m = {"Ta": ta, "Tw": tw, "R_IMUtoGYRO": c_gi, "Tg": tg, "A": tg @ c_gi.T, "C_i_body": c_ib}
    for v in m.values():          # rounding residue of the factorisation (1e-18 for a 0) out
        v[np.abs(v) < 1e-14 * np.abs(v).max(initial=0.0)] = 0.0
    return ToolIntrinsics(**m, acc_bias=ca * cal.acc_bias, gyro_bias=cg * cal.gyro_bias,
                          g=float(cal.g))


def _num(v: float) -> str:
    """A float as YAML both PyYAML and OpenCV read as a float: the shortest exact form, always
    with a dot (PyYAML's YAML 1.1 resolver reads ``1e-05`` as a string)."""
    s = repr(float(v))
    if not math.isfinite(v):
        raise ValueError(f"not a finite number: {v!r}")
    mant, _, exp = s.partition("e")
    if "." not in mant:
        mant += ".0"
    return mant + (f"e{exp}" if exp else "")


def _num9(v: float) -> str:
    """A noise value to 9 significant digits (far below its own uncertainty), written as
    :func:`_num` writes a float (always with a dot, so PyYAML reads a number)."""
    return _num(float(f"{float(v):.9g}"))


def _matrix(indent: str, m) -> list[str]:
    return [f"{indent}- [{', '.join(_num(x) for x in row)}]" for row in np.asarray(m)]


def _intrinsics_header(intr: ToolIntrinsics, source: str, what: str, command: str) -> list[str]:
    c = intr.C_i_body
    return [
        f"{MARK}{command}: {what} from {source}",
        "# Ferraris calibration (fogcomp.calibration, true to measured, body frame b):",
        "#   acc_raw = K_a R_a f_b + b_a,  gyr_raw = K_g R_g w_b + K_ga f_b + b_g",
        "# Kalibr scale-misalignment model (IccSensors.py l. 999, 1049), true to measured:",
        "#   f_m = M_a f_i + b_a,  w_m = M_g C_gyro_i w_i + A C_gyro_i f_i + b_g",
        "# OpenVINS (docs/propagation.dox l. 33-36), model kalibr, I = i:",
        "#   w_m = Tw R_IMUtoGYRO w_I + Tg f_I + b_g,  a_m = Ta R_IMUtoACC f_I + b_a",
        "# Conversion: K_a R_a = Ta C_ib (LQ: Ta lower triangular, C_ib a rotation),",
        "#   K_g R_g C_ib^T = Tw R_IMUtoGYRO, Tg = K_ga C_ib^T, A = Tg R_IMUtoGYRO^T,",
        "#   Tw = gyroscopes:M, Ta = accelerometers:M, R_IMUtoGYRO = C_gyro_i, R_IMUtoACC = I.",
        "# Units: M, Tw, Ta dimensionless; A, Tg (rad/s)/(m/s^2).",
        (f"# The frame I (Kalibr's i) is the accelerometer's: {intr.angle_deg():.4g} deg from "
         "the calibration's body frame,"),
        "#   v_I = C_ib v_b, C_ib rows: " + "; ".join(
            "[" + ", ".join(f"{x:.9f}" for x in row) + "]" for row in c),
        "# Biases (both tools estimate them online): gyro ["
        + ", ".join(f"{x:.6g}" for x in intr.gyro_bias) + "] rad/s, accelerometer ["
        + ", ".join(f"{x:.6g}" for x in intr.acc_bias) + f"] m/s^2; g = {intr.g:.9g} m/s^2",
    ]


def _noise_lines(values: dict | None, indent: str) -> list[str]:
    values = values or {k: ("not in a Ferraris calibration; fill it in (fogbench allan LOG "
                            "--kalibr gives it)")
                        for k in (("gyroscope", "N"), ("gyroscope", "K"),
                                  ("accelerometer", "N"), ("accelerometer", "K"))}
    out = []
    for key, value, notes in _entries(values, 1.0, 1.0):
        out += [f"{indent}# {n}" for n in notes]
        if value is not None:
            out.append(f"{indent}{key}: {_num(value)}")
    out += [f"{indent}# {n}" for n in _gm_comments(values)]
    return out


def kalibr_intrinsics_text(intr: ToolIntrinsics, fs: float, source: str, *,
                           topic: str = "/imu0", values: dict | None = None,
                           command: str = "calibrate ferraris") -> str:
    """The ``imu0`` block of Kalibr's result ``imu.yaml`` (``model: scale-misalignment``:
    ``accelerometers: M``, ``gyroscopes: M, A, C_gyro_i``; IccSensors.py l. 933-939), with
    ``T_i_b`` the identity (imu0 is the reference). ``values``: the noise entries as
    :func:`values_from_models` gives them; without, the noise keys are left commented out."""
    lines = _intrinsics_header(intr, source, "Kalibr imu.yaml intrinsics (scale-misalignment)",
                               command)
    lines += ["imu0:", "  T_i_b:"] + _matrix("  ", np.eye(4)) + [
        "  model: scale-misalignment", "  accelerometers:", "    M:",
        *_matrix("    ", intr.Ta), "  gyroscopes:", "    M:", *_matrix("    ", intr.Tw),
        "    # A [(rad/s)/(m/s^2)], on C_gyro_i f_i", "    A:", *_matrix("    ", intr.A),
        "    C_gyro_i:", *_matrix("    ", intr.R_IMUtoGYRO)]
    lines += _noise_lines(values, "  ")
    lines += [f"  rostopic: {topic}", "  time_offset: 0.0", f"  update_rate: {_num(fs)}"]
    return "\n".join(lines) + "\n"


def openvins_intrinsics_text(intr: ToolIntrinsics, fs: float, source: str, *,
                             topic: str = "/imu0", values: dict | None = None,
                             command: str = "calibrate ferraris") -> str:
    """OpenVINS' ``kalibr_imu_chain.yaml`` with the intrinsics (``model: "kalibr"``: ``Tw``,
    ``R_IMUtoGYRO``, ``Ta``, ``R_IMUtoACC`` the identity, ``Tg``; VioManagerOptions.h
    l. 305-315). Starts ``%YAML 1.0``, its comments, ``---`` (see ``_OPENCV_YAML``): OpenCV and
    PyYAML load it as it is. ``values`` as for :func:`kalibr_intrinsics_text`."""
    lines = [_OPENCV_YAML, *_intrinsics_header(
        intr, source, "OpenVINS kalibr_imu_chain.yaml intrinsics", command), "---",
        "imu0:", "  T_i_b:", *_matrix("    ", np.eye(4))]
    lines += _noise_lines(values, "  ")
    lines += [f"  rostopic: {topic}", "  time_offset: 0.0", f"  update_rate: {_num(fs)}",
              '  model: "kalibr"',
              "  Tw:", *_matrix("    ", intr.Tw),
              "  R_IMUtoGYRO:", *_matrix("    ", intr.R_IMUtoGYRO),
              "  Ta:", *_matrix("    ", intr.Ta),
              "  R_IMUtoACC:", *_matrix("    ", intr.R_IMUtoACC),
              "  # Tg [(rad/s)/(m/s^2)], on the specific force in I (Propagator.cpp l. 420)",
              "  Tg:", *_matrix("    ", intr.Tg)]
    return "\n".join(lines) + "\n"


INTRINSICS_TEXTS = {"kalibr": kalibr_intrinsics_text, "openvins": openvins_intrinsics_text}
