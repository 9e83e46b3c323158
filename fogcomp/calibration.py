"""Six-position + three-rotation calibration of a gyro/accelerometer triad (Ferraris procedure).

The sensor model (Ferraris et al. 1995 [1]_, eqs. 1-2; the same as imucal's
``FerrarisCalibrationInfo`` [2]_)::

    acc_raw = K_a R_a a + b_a                        a: specific force, m/s^2
    gyr_raw = K_g R_g w + K_ga a + b_g               w: angular rate, rad/s

with ``K`` diagonal scale factors (raw units per SI unit), ``R`` misalignment matrices whose rows
are the unit vectors of the sensitive axes in the body frame, ``b`` biases (raw units) and ``K_ga``
the gyro g-sensitivity (raw units per m/s^2, column j the response to specific force along body
axis j). Inverting it gives the calibrated signals::

    a = R_a^-1 K_a^-1 (acc_raw - b_a)
    w = R_g^-1 K_g^-1 (gyr_raw - K_ga a - b_g)

The procedure: six static positions with each body axis pointing up (``+``, specific force +g along
it) and down (``-``), then one rotation of a known angle about each body axis.

* Accelerometer (eqs. 19-23): with U+ and U- the 3x3 matrices of mean readings (column j: body
  axis j up / down), ``b_a = diag(U+ + U-) / 2``, ``U_d = U+ - U- = 2 g K_a R_a``, so ``K_a`` is the
  row norms of ``U_d / 2g`` and ``R_a = K_a^-1 U_d / 2g``.
* Gyro bias: the mean of every static sample (Earth rate, 15 deg/h, is ignored: it averages out
  over opposite positions only to the extent the heading is kept).
* g-sensitivity (eq. 9): ``K_ga = (G+ - G-) / 2g`` with G the gyro's mean readings in the static
  positions.
* Gyro scale and misalignment (eqs. 13-14): the bias- and g-corrected gyro readings are summed over
  each rotation (rectangle rule, ``sum / fs``: the readings are rates over the sample interval)
  giving the columns of ``W = K_g R_g theta``; ``K_g`` is the row norms of ``W / theta`` and
  ``R_g = K_g^-1 W / theta``.

.. rubric:: References

.. [1] F. Ferraris, U. Grimaldi, M. Parvis, "Procedure for effortless in-field calibration of
   three-axis rate gyros and accelerometers", Sensors and Materials 7(5), 311-330 (1995).
.. [2] imucal (MaD-Lab, FAU Erlangen), ``FerrarisCalibration``: the same procedure; its published
   result on its own example session is the reference of this module's tests.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np

from ._checks import _sample_rate
from .units import G0

__all__ = ["FERRARIS_PARTS", "TriadCalibration", "ferraris_calibration",
           "ferraris_plausibility", "MIN_GRAVITY_SNR", "MAX_AXIS_ANGLE_DEG"]

#: Fewest times the up-minus-down difference of the accelerometer readings (2 g along the axis)
#: must exceed the noise of one reading in a static position. A MEMS accelerometer gives several
#: hundred (the imucal session: 560-660); a gyro's readings there differ only by the Earth rate's
#: projection, about 0.1-0.2 of its noise: that is what swapped accelerometer and gyro columns
#: look like.
MIN_GRAVITY_SNR = 10.0
#: Largest angle, deg, between a sensitive axis and the body axis it is meant to measure. Real
#: triads are aligned to a degree or better (the imucal session: within 2.3 deg); 15 deg leaves
#: room for a poor mount and refuses what is not a calibration of these axes at all.
MAX_AXIS_ANGLE_DEG = 15.0

#: Names of the nine parts of a Ferraris session, as in imucal's annotated files: axis up
#: (``_p``, the axis' accelerometer reads +g) and down (``_a``), then the rotation about each axis.
FERRARIS_PARTS = ("x_p", "x_a", "y_p", "y_a", "z_p", "z_a", "x_rot", "y_rot", "z_rot")

_FORMAT = "fogcomp-triad-calibration"
_VERSION = 1


@dataclass(frozen=True)
class TriadCalibration:
    """Calibration of a gyro + accelerometer triad (model in the module docstring).

    Attributes
    ----------
    acc_scale : ndarray, shape (3,)
        Diagonal of ``K_a``, raw accelerometer units per m/s^2.
    acc_misalignment : ndarray, shape (3, 3)
        ``R_a``, rows the unit sensitive axes in the body frame (dimensionless).
    acc_bias : ndarray, shape (3,)
        ``b_a``, raw accelerometer units.
    gyro_scale : ndarray, shape (3,)
        Diagonal of ``K_g``, raw gyro units per rad/s.
    gyro_misalignment : ndarray, shape (3, 3)
        ``R_g`` (dimensionless; a rotation sense opposite to the one declared shows as -1 on the
        diagonal).
    gyro_g_sensitivity : ndarray, shape (3, 3)
        ``K_ga``, raw gyro units per m/s^2; column j is the response to specific force along
        body axis j.
    gyro_bias : ndarray, shape (3,)
        ``b_g``, raw gyro units.
    g : float
        The gravity value the calibration assumed, m/s^2.
    """

    acc_scale: np.ndarray
    acc_misalignment: np.ndarray
    acc_bias: np.ndarray
    gyro_scale: np.ndarray
    gyro_misalignment: np.ndarray
    gyro_g_sensitivity: np.ndarray
    gyro_bias: np.ndarray
    g: float = G0

    def __post_init__(self):
        for name, shape in (("acc_scale", (3,)), ("acc_misalignment", (3, 3)),
                            ("acc_bias", (3,)), ("gyro_scale", (3,)),
                            ("gyro_misalignment", (3, 3)), ("gyro_g_sensitivity", (3, 3)),
                            ("gyro_bias", (3,))):
            try:
                v = np.array(getattr(self, name), dtype=float)
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{name}: cannot be read as a float array ({exc})") from None
            if v.shape != shape:
                raise ValueError(f"{name}: expected shape {shape}, got {v.shape}")
            if not np.all(np.isfinite(v)):
                raise ValueError(f"{name}: expected finite values")
            object.__setattr__(self, name, v)
        for name in ("acc_scale", "gyro_scale"):
            if np.any(getattr(self, name) == 0):
                raise ValueError(f"{name}: a scale factor of zero cannot be inverted")
        for name in ("acc_misalignment", "gyro_misalignment"):
            if abs(np.linalg.det(getattr(self, name))) < 1e-6:
                raise ValueError(f"{name}: matrix is singular (sensitive axes not independent)")

    # -- applying -------------------------------------------------------------------------------
    def calibrate_acc(self, acc_raw) -> np.ndarray:
        """Specific force from raw accelerometer readings.

        Parameters
        ----------
        acc_raw : array_like, shape (n, 3)
            Raw accelerometer readings (the units the calibration was made in).

        Returns
        -------
        ndarray, shape (n, 3)
            Specific force in the body frame, m/s^2.
        """
        a = _triad("acc_raw", acc_raw)
        m = np.linalg.inv(self.acc_misalignment) @ np.diag(1.0 / self.acc_scale)
        return (a - self.acc_bias) @ m.T

    def calibrate_gyro(self, gyro_raw, acc) -> np.ndarray:
        """Angular rate from raw gyro readings and the calibrated specific force.

        Parameters
        ----------
        gyro_raw : array_like, shape (n, 3)
            Raw gyro readings.
        acc : array_like, shape (n, 3)
            Calibrated specific force, m/s^2 (from :meth:`calibrate_acc`).

        Returns
        -------
        ndarray, shape (n, 3)
            Angular rate in the body frame, rad/s.
        """
        w = _triad("gyro_raw", gyro_raw)
        a = _triad("acc", acc)
        if a.shape != w.shape:
            raise ValueError(f"acc: shape {a.shape} must match gyro_raw {w.shape}")
        m = np.linalg.inv(self.gyro_misalignment) @ np.diag(1.0 / self.gyro_scale)
        return (w - a @ self.gyro_g_sensitivity.T - self.gyro_bias) @ m.T

    def calibrate(self, gyro_raw, acc_raw) -> tuple[np.ndarray, np.ndarray]:
        """Both: ``(rate rad/s, specific force m/s^2)``, each shape (n, 3), from raw (n, 3)."""
        acc = self.calibrate_acc(acc_raw)
        return self.calibrate_gyro(gyro_raw, acc), acc

    # -- persistence (JSON, no pickle) ------------------------------------------------------------
    def to_dict(self) -> dict:
        """A JSON-safe dict, the unit in every key."""
        return {
            "format": _FORMAT, "version": _VERSION, "method": "ferraris",
            "acc_scale_raw_per_mps2": self.acc_scale.tolist(),
            "acc_misalignment": self.acc_misalignment.tolist(),
            "acc_bias_raw": self.acc_bias.tolist(),
            "gyro_scale_raw_per_rps": self.gyro_scale.tolist(),
            "gyro_misalignment": self.gyro_misalignment.tolist(),
            "gyro_g_sensitivity_raw_per_mps2": self.gyro_g_sensitivity.tolist(),
            "gyro_bias_raw": self.gyro_bias.tolist(),
            "g_mps2": float(self.g),
        }

    @classmethod
    def from_dict(cls, doc: dict, source: str = "calibration") -> "TriadCalibration":
        """The inverse of :meth:`to_dict`; ``source`` names the file in error messages."""
        if not isinstance(doc, dict) or doc.get("format") != _FORMAT:
            raise ValueError(f"{source}: key 'format' must be {_FORMAT!r}")
        if doc.get("version") != _VERSION:
            raise ValueError(f"{source}: key 'version' is {doc.get('version')!r}; this fogcomp "
                             f"reads version {_VERSION}")
        keys = {"acc_scale_raw_per_mps2": "acc_scale", "acc_misalignment": "acc_misalignment",
                "acc_bias_raw": "acc_bias", "gyro_scale_raw_per_rps": "gyro_scale",
                "gyro_misalignment": "gyro_misalignment",
                "gyro_g_sensitivity_raw_per_mps2": "gyro_g_sensitivity",
                "gyro_bias_raw": "gyro_bias", "g_mps2": "g"}
        missing = [k for k in keys if k not in doc]
        if missing:
            raise ValueError(f"{source}: missing key(s) {missing}")
        for k in keys:  # numbers, or (nested) lists of numbers: never a text read as one
            v = doc[k]
            flat = v if isinstance(v, list) else [v]
            while any(isinstance(x, list) for x in flat):
                flat = [y for x in flat for y in (x if isinstance(x, list) else [x])]
            if not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in flat):
                raise ValueError(f"{source}: key {k!r} must hold numbers, got {v!r}")
        if not (math.isfinite(doc["g_mps2"]) and doc["g_mps2"] > 0):
            raise ValueError(f"{source}: key 'g_mps2' must be a positive gravity in m/s^2")
        try:
            return cls(**{attr: doc[k] for k, attr in keys.items()})
        except ValueError as exc:
            raise ValueError(f"{source}: {exc}") from None

    def to_json(self) -> str:
        """:meth:`to_dict` as indented JSON text."""
        return json.dumps(self.to_dict(), indent=2, allow_nan=False)


def _triad(name: str, x, min_len: int = 1) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: cannot be read as a float array ({exc})") from None
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name}: expected shape (n, 3), got {a.shape}")
    if a.shape[0] < min_len:
        raise ValueError(f"{name}: expected at least {min_len} samples, got {a.shape[0]}")
    bad = ~np.isfinite(a)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise ValueError(f"{name}: non-finite value at sample {i}, axis {'xyz'[j]}")
    return a


def ferraris_calibration(acc: dict, gyro: dict, fs: float, angle: float | dict,
                         g: float = G0) -> TriadCalibration:
    """Calibrate a triad from a six-position + three-rotation session (Ferraris et al. 1995).

    Parameters
    ----------
    acc : dict of str to array_like, each shape (n_part, 3)
        Raw accelerometer readings of each part, keys :data:`FERRARIS_PARTS`.
    gyro : dict of str to array_like, each shape (n_part, 3)
        Raw gyro readings of each part, same keys and lengths.
    fs : float
        Sample rate, Hz (the gyro scale depends on it through the integration).
    angle : float or dict
        The known rotation angle of ``x_rot``, ``y_rot``, ``z_rot``, rad, signed by the right-hand
        rule about the axis (e.g. ``-2 pi`` for one clockwise turn seen from above the axis);
        a dict gives one per rotation.
    g : float, optional
        Local gravity, m/s^2 (default standard gravity 9.80665; imucal uses 9.81).

    Returns
    -------
    TriadCalibration

    References
    ----------
    .. [1] F. Ferraris, U. Grimaldi, M. Parvis, Sensors and Materials 7(5), 311-330 (1995),
       eqs. 9, 13-14, 19-23.
    """
    _sample_rate(fs)
    if not (isinstance(g, (int, float, np.floating)) and math.isfinite(g) and g > 0):
        raise ValueError(f"g: expected a positive gravity in m/s^2, got {g!r}")
    angles = {}
    for axis in "xyz":
        v = angle.get(f"{axis}_rot") if isinstance(angle, dict) else angle
        if not (isinstance(v, (int, float, np.floating)) and math.isfinite(v) and v != 0):
            raise ValueError(f"angle: expected a non-zero rotation angle in rad for {axis}_rot, "
                             f"got {v!r}")
        angles[axis] = float(v)
    parts = {}
    for name, src in (("acc", acc), ("gyro", gyro)):
        missing = [p for p in FERRARIS_PARTS if p not in src]
        if missing:
            raise ValueError(f"{name}: missing part(s) {missing}; a Ferraris session has "
                             f"{list(FERRARIS_PARTS)}")
        parts[name] = {p: _triad(f"{name}[{p!r}]", src[p]) for p in FERRARIS_PARTS}
    for p in FERRARIS_PARTS:
        if parts["acc"][p].shape != parts["gyro"][p].shape:
            raise ValueError(f"part {p!r}: acc has {parts['acc'][p].shape[0]} samples, gyro "
                             f"{parts['gyro'][p].shape[0]}")

    def means(sensor, sign):                        # columns: body axis x, y, z up (or down)
        return np.column_stack([parts[sensor][f"{ax}_{sign}"].mean(axis=0) for ax in "xyz"])

    # Accelerometer, eqs. 19-23.
    u_p, u_a = means("acc", "p"), means("acc", "a")
    b_a = np.diag(u_p + u_a) / 2.0
    u_d = u_p - u_a
    k_a = np.sqrt(np.sum(u_d**2, axis=1)) / (2.0 * g)
    r_a = (u_d / (2.0 * g)) / k_a[:, None]
    # Gyro bias: mean of every static sample.
    b_g = np.concatenate([parts["gyro"][f"{ax}_{s}"] for ax in "xyz" for s in "pa"]).mean(axis=0)
    # g-sensitivity, eq. 9.
    k_ga = (means("gyro", "p") - means("gyro", "a")) / (2.0 * g)
    # Gyro scale and misalignment, eqs. 13-14.
    acc_only = TriadCalibration(k_a, r_a, b_a, np.ones(3), np.eye(3), k_ga, b_g, g)
    w = np.empty((3, 3))
    for j, axis in enumerate("xyz"):
        part = f"{axis}_rot"
        a = acc_only.calibrate_acc(parts["acc"][part])
        corrected = parts["gyro"][part] - a @ k_ga.T - b_g
        w[:, j] = corrected.sum(axis=0) / fs / angles[axis]
    k_g = np.sqrt(np.sum(w**2, axis=1))
    r_g = w / k_g[:, None]
    return TriadCalibration(k_a, r_a, b_a, k_g, r_g, k_ga, b_g, float(g))


def ferraris_plausibility(acc: dict, gyro: dict, cal: TriadCalibration) -> list[tuple[str, str]]:
    """What in a Ferraris calibration contradicts the physics of the procedure.

    Two laws any real session obeys, whatever the sensor's raw units: the accelerometer's
    reading along an axis changes by 2 g between that axis up and down, far above the noise of
    one reading (:data:`MIN_GRAVITY_SNR`), and each sensitive axis lies close to the body axis it
    measures (:data:`MAX_AXIS_ANGLE_DEG`; the diagonal of ``R``, up to its sign).

    Parameters
    ----------
    acc, gyro : dict of str to array_like, each shape (n_part, 3)
        The session's raw readings per part, as given to :func:`ferraris_calibration`.
    cal : TriadCalibration
        Its result.

    Returns
    -------
    list of (str, str)
        ``(channel, why)`` per violation, channel ``acc_x`` ... ``gyro_z``; empty when plausible.
    """
    out = []
    static = [f"{ax}_{s}" for ax in "xyz" for s in "pa"]
    noise = math.sqrt(float(np.mean([np.var(np.asarray(acc[p], dtype=float), axis=0)
                                     for p in static])))
    for j, ax in enumerate("xyz"):
        diff = np.linalg.norm(np.mean(acc[f"{ax}_p"], axis=0) - np.mean(acc[f"{ax}_a"], axis=0))
        snr = diff / noise if noise > 0 else math.inf
        if snr < MIN_GRAVITY_SNR:
            out.append((f"acc_{ax}", f"the readings with body axis {ax} up and down differ by "
                                     f"{snr:.2g} times the noise of one reading (gravity gives a "
                                     f"real accelerometer hundreds; at least "
                                     f"{MIN_GRAVITY_SNR:g} is needed)"))
    for sensor, r in (("acc", cal.acc_misalignment), ("gyro", cal.gyro_misalignment)):
        for j, ax in enumerate("xyz"):
            angle = math.degrees(math.acos(min(1.0, abs(float(r[j, j])))))
            if angle > MAX_AXIS_ANGLE_DEG:
                out.append((f"{sensor}_{ax}", f"its sensitive axis comes out {angle:.0f} deg "
                                              f"from body axis {ax} (at most "
                                              f"{MAX_AXIS_ANGLE_DEG:g} deg is plausible)"))
    return out
