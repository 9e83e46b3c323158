"""Strapdown attitude from a gyro triad's angle increments, and the errors it leaves.

Frames and conventions (every function here keeps to them):

* **n**, the navigation frame: local level, **NED** (x north, y east, z down), fixed to the Earth
  at the lab; it turns with the Earth at ``earth_rate_ned(latitude)`` w.r.t. inertial space.
* **b**, the body (sensor) frame: the triad's x, y, z axes.
* An attitude is a ``scipy.spatial.transform.Rotation`` ``C`` taking body vectors to navigation
  vectors (active, body -> nav: ``v_n = C.apply(v_b)``), the direction cosine matrix C^n_b.
  A history is a Rotation of length n + 1: the attitude at each sample boundary, the initial one
  first.
* Roll, pitch and heading are the intrinsic z-y'-x'' (yaw, pitch, roll) angles of C^n_b
  (``C.as_euler("ZYX")``); heading is from north toward east.

Gyro input is the angle increment over each sample, rad, shape (n, 3): the integral of the
inertial angular rate of b over the sample, what a FOG outputs (a rate averaged over the sample
times 1 / fs is the same thing).

The update is the two-speed rotation-vector form of Savage [1]_: per sample m the body rotation
vector

    phi_m = alpha_m + (1/12) alpha_{m-1} x alpha_m            (coning correction)

(the single-sample, previous-cycle coning algorithm: Savage [1]_, section on the rotation
vector's coning term; Ignagni [2]_, the one-sample algorithm optimised for classical coning
motion; it leaves a drift of order (Omega T)^4 in classical coning where the uncorrected
alpha_m leaves (Omega T)^2 / 6, see :func:`coning_drift_rate`), then

    C_m = E_m C_{m-1} exp([phi_m x]),   E_m = exp(-[omega_ie^n T x])

the body update on the right, the navigation frame's rotation with the Earth on the left
(stationary lab: no transport rate). To first order the left factor is the subtraction of the
Earth rate at the nominal latitude transformed to body, ``phi_m - C^T omega_ie^n T``; applied on
the left it is exact for a constant Earth rate. Because E is the same every sample,
C_m = E^m C_0 (exp[phi_1] ... exp[phi_m]); the body product is computed as a prefix product of
Rotations in log2(n) vectorised rounds.

Static alignment (:func:`gyrocompass`) levels on the specific force and finds north from the
Earth's rate, with the heading error of a residual east gyro bias of [3]_.

References
----------
.. [1] P. G. Savage, "Strapdown Inertial Navigation Integration Algorithm Design Part 1: Attitude
   Algorithms", Journal of Guidance, Control, and Dynamics 21(1), 19-28, 1998.
.. [2] M. B. Ignagni, "Optimal Strapdown Attitude Integration Algorithms", Journal of Guidance,
   Control, and Dynamics 13(2), 363-369, 1990.
.. [3] D. H. Titterton and J. L. Weston, "Strapdown Inertial Navigation Technology", 2nd ed.,
   IEE 2004, chapter 10 (alignment; gyrocompassing: heading error = east gyro bias /
   (Omega cos L)).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from .units import EARTH_RATE

__all__ = [
    "earth_rate_ned",
    "lab_to_ned",
    "true_attitude",
    "inertial_attitude",
    "coning_corrected",
    "integrate_attitude",
    "attitude_errors",
    "orientation_error",
    "attitude_error_summary",
    "gyrocompass",
    "coning_drift_rate",
]


def earth_rate_ned(latitude: float) -> np.ndarray:
    """The Earth's rate in the NED frame, rad/s: (Omega cos L, 0, -Omega sin L).

    latitude : float
        Geodetic latitude L, rad.
    """
    return np.array([EARTH_RATE * math.cos(latitude), 0.0, -EARTH_RATE * math.sin(latitude)])


def lab_to_ned(heading: float) -> Rotation:
    """C^n_w: the rate table's world frame (x along the tilt axis at azimuth ``heading`` from
    north toward east, z up, y = z x x, i.e. at azimuth heading - 90 deg) to NED.

    heading : float
        Azimuth of the table's world x axis, rad.
    """
    c, s = math.cos(heading), math.sin(heading)
    # columns: world x, y, z in NED
    return Rotation.from_matrix(np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]]))


def true_attitude(quat_wxyz: np.ndarray, heading: float) -> Rotation:
    """The true attitude C^n_b from a table's poses: C^n_w C^w_b.

    quat_wxyz : ndarray, shape (n, 4)
        Orientation of the sensor frame in the table's world frame (sensor -> world), scalar
        first (MuJoCo's order).
    heading : float
        Azimuth of the table's world x axis from north toward east, rad.

    The table is fixed to the Earth, and so is NED at the lab: the local-level attitude is the
    pose seen through the lab's heading. The Earth's rotation (at the lab's latitude) enters
    through the inertial rates a gyro senses, which :func:`integrate_attitude` removes.
    """
    q = np.asarray(quat_wxyz, dtype=float)
    if q.ndim != 2 or q.shape[1] != 4:
        raise ValueError(f"quat_wxyz must have shape (n, 4), got {q.shape}")
    return lab_to_ned(heading) * Rotation.from_quat(q, scalar_first=True)


def inertial_attitude(nav_attitude: Rotation, t, latitude: float) -> Rotation:
    """C^i_b(t) = C^i_e(t) C^e_n C^n_b(t): a local-level attitude history seen from inertial
    space.

    nav_attitude : Rotation of length n
        C^n_b (body -> NED) at times ``t``.
    t : ndarray, shape (n,)
        Time, s, from the instant the inertial frame coincides with the Earth-fixed frame.
    latitude : float
        Geodetic latitude, rad (longitude 0: it only sets where the inertial frame's x points).

    Frames: e, Earth-fixed (x at the lab's meridian in the equator, z the Earth's axis); i, the
    inertial frame equal to e at t = 0, e turning about z at the Earth's rate:
    C^i_e(t) = R_z(Omega t). C^e_n holds NED's axes in e: north (-sin L, 0, cos L),
    east (0, 1, 0), down (-cos L, 0, -sin L). Integrating a body's inertial rate with
    ``integrate_attitude(..., latitude=None)`` from ``inertial_attitude(...)[0]`` follows this.
    """
    t = np.asarray(t, dtype=float)
    sL, cL = math.sin(latitude), math.cos(latitude)
    C_en = Rotation.from_matrix(np.array([[-sL, 0.0, -cL], [0.0, 1.0, 0.0], [cL, 0.0, -sL]]))
    C_ie = Rotation.from_rotvec(np.outer(EARTH_RATE * t, [0.0, 0.0, 1.0]))
    return C_ie * C_en * nav_attitude


def _increments(dtheta) -> np.ndarray:
    a = np.asarray(dtheta, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"dtheta must have shape (n, 3) (one angle increment per sample and "
                         f"axis, rad), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError("dtheta holds non-finite values")
    return a


def coning_corrected(dtheta, previous=None) -> np.ndarray:
    """Rotation vectors phi_m = alpha_m + (1/12) alpha_{m-1} x alpha_m, rad, shape (n, 3).

    dtheta : ndarray, shape (n, 3)
        Angle increments alpha_m, body axes, rad.
    previous : ndarray, shape (3,), optional
        alpha_0, the increment before the first (zero when not given: the body at rest before).
    """
    a = _increments(dtheta)
    prev = np.vstack([np.zeros((1, 3)) if previous is None else np.reshape(previous, (1, 3)),
                      a[:-1]])
    return a + np.cross(prev, a) / 12.0


def _prefix_product(r: Rotation, block: int = 1024) -> Rotation:
    """P_i = r_0 r_1 ... r_i for a Rotation of length n, in blocks: the running product within
    each block of ``block`` samples (one Rotation product over all blocks per step), the blocks'
    totals chained, then one product over all samples: about 2 sqrt-ish sweeps of small products
    and one of n, where a scan over n in log2 n rounds cost 20 products of n (scipy's product
    of n Rotations is the cost: 0.7 s per million here)."""
    q = r.as_quat()
    n = len(q)
    if n <= 1:
        return Rotation.from_quat(q)
    b = max(1, min(int(block), n))
    k = -(-n // b)                                   # blocks
    pad = k * b - n
    qq = np.vstack([q, np.tile([0.0, 0.0, 0.0, 1.0], (pad, 1))]).reshape(k, b, 4)
    run = np.empty_like(qq)
    run[:, 0] = qq[:, 0]
    for i in range(1, b):                            # within every block at once
        run[:, i] = (Rotation.from_quat(run[:, i - 1]) * Rotation.from_quat(qq[:, i])).as_quat()
    totals = Rotation.from_quat(run[:, -1])
    lead = np.empty((k, 4))
    lead[0] = [0.0, 0.0, 0.0, 1.0]
    acc = Rotation.identity()
    for j in range(1, k):                            # the product of the blocks before each
        acc = acc * totals[j - 1]
        lead[j] = acc.as_quat()
    out = Rotation.from_quat(np.repeat(lead, b, axis=0)) * Rotation.from_quat(run.reshape(-1, 4))
    return out[:n]


def integrate_attitude(initial: Rotation, dtheta, fs: float, latitude: float | None = None,
                       coning: bool = True) -> Rotation:
    """Strapdown attitude history C^n_b from angle increments (see the module doc).

    Parameters
    ----------
    initial : Rotation
        C^n_b at the start (body -> NED), a single rotation.
    dtheta : ndarray, shape (n, 3)
        Angle increment of each sample, body axes, rad (inertial: the Earth's rate included).
    fs : float
        Sample rate, Hz.
    latitude : float or None
        Nominal latitude, rad: the Earth's rate at it is removed (the NED frame turns with the
        Earth). None integrates in a non-rotating frame (the frame of ``initial`` at t = 0).
    coning : bool
        Apply the coning correction (1/12) alpha_{m-1} x alpha_m.

    Returns
    -------
    Rotation of length n + 1: the attitude at t = m / fs, m = 0..n.
    """
    if not isinstance(initial, Rotation) or not initial.single:
        raise ValueError("initial must be a single scipy.spatial.transform.Rotation (body -> "
                         "NED)")
    if not fs > 0:
        raise ValueError(f"fs must be > 0 Hz, got {fs}")
    a = _increments(dtheta)
    phi = coning_corrected(a) if coning else a
    body = _prefix_product(Rotation.from_rotvec(phi)) if len(phi) else None
    m = np.arange(1, len(a) + 1)
    if latitude is None:
        earth = Rotation.identity(len(a))
    else:
        earth = Rotation.from_rotvec(-np.outer(m / fs, earth_rate_ned(latitude)))
    if body is None:
        return Rotation.concatenate([initial])
    return Rotation.concatenate([initial, earth * initial * body])


def orientation_error(estimate: Rotation, truth: Rotation) -> np.ndarray:
    """Absolute orientation error: the angle of C_est^T C_true, rad, shape (n,)."""
    return (estimate.inv() * truth).magnitude()


def _wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def attitude_errors(estimate: Rotation, truth: Rotation) -> dict[str, np.ndarray]:
    """Roll, pitch and heading error (estimate - truth, wrapped to [-pi, pi)), rad, and the
    absolute orientation error; each an array of shape (n,).

    Euler angles are singular at pitch +-90 deg; there, read ``orientation_error_rad``.
    """
    e = estimate.as_euler("ZYX")
    t = truth.as_euler("ZYX")
    d = _wrap(e - t)
    return {"roll_error_rad": d[..., 2], "pitch_error_rad": d[..., 1],
            "heading_error_rad": d[..., 0],
            "orientation_error_rad": orientation_error(estimate, truth)}


def attitude_error_summary(estimate: Rotation, truth: Rotation, fs: float,
                           at_s=(60.0, 600.0, 3600.0)) -> dict[str, float]:
    """Roll, pitch, heading and absolute orientation errors at stated times and their RMS, in
    degrees (the unit in every key: ``heading_error_deg_at_600s``, ``heading_error_rms_deg``).

    estimate, truth : Rotation of length n + 1, the attitude at t = m / fs, m = 0..n.
    fs : sample rate, Hz.  at_s : times, s; a time past the record is left out.
    """
    if len(estimate) != len(truth):
        raise ValueError(f"estimate and truth differ in length: {len(estimate)} and "
                         f"{len(truth)}")
    err = attitude_errors(estimate, truth)
    out: dict[str, float] = {}
    for name, e in err.items():
        stem = name.removesuffix("_rad")
        deg = np.degrees(e)
        for t in at_s:
            i = int(round(t * fs))
            if i < len(deg):
                out[f"{stem}_deg_at_{t:g}s"] = float(deg[i])
        out[f"{stem}_rms_deg"] = float(np.sqrt(np.mean(deg ** 2)))
    return out


def gyrocompass(rate, specific_force, latitude: float) -> Rotation:
    """Static analytic alignment (levelling and gyrocompassing): C^n_b from mean readings.

    rate : ndarray, shape (3,)
        Mean inertial angular rate at rest, body axes, rad/s.
    specific_force : ndarray, shape (3,)
        Mean specific force at rest, body axes (any unit: only its direction is used; at rest it
        points up).
    latitude : float
        Latitude, rad.

    'Down' is aligned exactly (-f), the Earth's rate as well as it can be after that
    (``Rotation.align_vectors`` with the first vector's weight infinite). A residual east gyro
    bias b_E turns the found north by b_E / (Omega cos L) (Titterton and Weston 2004, chapter
    10): the heading error.
    """
    w = np.asarray(rate, dtype=float).reshape(3)
    f = np.asarray(specific_force, dtype=float).reshape(3)
    if not (np.all(np.isfinite(w)) and np.all(np.isfinite(f))) or np.linalg.norm(f) == 0:
        raise ValueError("gyrocompass needs finite readings and a non-zero specific force")
    down_b = -f / np.linalg.norm(f)
    rot, _ = Rotation.align_vectors([[0.0, 0.0, 1.0], earth_rate_ned(latitude)], [down_b, w],
                                    weights=[np.inf, 1.0])
    return rot


def coning_drift_rate(cone_angle: float, omega: float, interval: float) -> float:
    """Drift rate about the cone axis of an uncorrected update (phi_m = alpha_m), rad/s.

    Classical coning motion (Savage 1998, Ignagni 1990; module references): the attitude C(t) = exp([alpha u(t) x]),
    u(t) = (cos Omega t, sin Omega t, 0), whose body rate is

        omega_b = (-Omega sin(a) sin(Omega t), Omega sin(a) cos(Omega t), -Omega (1 - cos a)).

    Over an update interval T the rotation vector holds, besides the increment alpha, the coning
    term (1/2) int (alpha(t) x omega_b) dt; its z component is
    (1/2) Omega sin^2(a) (T - sin(Omega T) / Omega) (alpha(t) the increment from the interval's
    start). An update that leaves it out drifts about z at

        (1/2) Omega sin^2(a) (1 - sin(Omega T) / (Omega T))  ~  Omega^3 T^2 sin^2(a) / 12,

    the estimate turning the opposite way of this term (drift of the estimate = minus it).
    cone_angle : rad.  omega : coning frequency Omega, rad/s.  interval : T, s.
    """
    x = omega * interval
    return 0.5 * omega * math.sin(cone_angle) ** 2 * (1.0 - math.sin(x) / x)
