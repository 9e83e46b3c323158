"""The bias-tracking Kalman filter a noise model implies (:class:`BiasFilterModel`), its exact
discretisation, and a batched run over many records or models at once (:func:`run_filter`).

One gyro axis measures ``z_k = w_k + b_k + v_k`` (rad/s, the mean rate over sample k) with
``w_k`` the known true rate (subtracted before the filter: ``z = rate - known``), ``b_k`` the
bias the filter tracks and ``v_k`` the white rate noise of the angle random walk N, variance
``N^2 fs`` per sample. The states, each a term of the noise model a finite-state filter can
carry (IEEE Std 952-1997 Annex C for the terms; the discrete forms as
:meth:`fogcomp.noise.NoiseModel.filter_parameters` states them):

======  =========================================  ==============================================
state   continuous time                            discrete, exact (dt = 1/fs)
======  =========================================  ==============================================
b       b' = r + w_K, w_K density K (rate random   b+ = b + r dt + u, var(u) = K^2 dt; prior
        walk); an unknown constant when K = 0       std ``bias_prior`` (diffuse: the constant
                                                    bias and the known rate's error)
r       r' = 0, the rate ramp's slope (if R)        r+ = r; prior std R
g_i     g' = -g/T + w, stationary variance s^2      g+ = phi g + u, phi = exp(-dt/T),
        (each Gauss-Markov term)                    var(u) = s^2 (1 - phi^2); prior s^2
f_j     the flicker B as a sum of Gauss-Markov      as g_i (:func:`flicker_as_gm`)
        terms
q, q-   the quantisation: white angle noise of      q+ = e, var(e) = Q^2; q-+ = q; the rate
        std Q, seen by the rate differenced         sees fs (q - q-)
======  =========================================  ==============================================

The discrete forms are the closed forms of Van Loan's matrix exponential (C. F. Van Loan,
"Computing integrals involving the matrix exponential", IEEE TAC 23(3), 395-404, 1978), which
:func:`van_loan` computes and the tests compare with. Measurement row ``H``: 1 on b and on every
g_i, f_j, ``fs`` on q and ``-fs`` on q-. The bias (what the filter estimates and the truth of a
simulation knows) is ``b + sum g_i + sum f_j``: its row is ``bias_row``.

A triad is three independent axes (the noise model of each), run side by side.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

__all__ = ["BiasFilterModel", "FilterRun", "flicker_as_gm", "van_loan", "run_filter",
           "from_noise_model"]

FLICKER_FLOOR = 2.0 * math.log(2.0) / math.pi


def van_loan(A: np.ndarray, Qc: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact discretisation of ``x' = A x + w``, ``E[w w^T] = Qc delta``: (F, Qd) by Van Loan's
    method (IEEE TAC 23(3), 1978): ``expm([[-A, Qc], [0, A^T]] dt) = [[., F^-1 Qd], [0, F^T]]``.

    Parameters
    ----------
    A : ndarray, shape (d, d)
        Continuous-time system matrix, 1/s.
    Qc : ndarray, shape (d, d)
        Spectral density of the driving noise (units of x^2 per s).
    dt : float
        Sample interval, s.
    """
    from scipy.linalg import expm

    d = A.shape[0]
    M = np.zeros((2 * d, 2 * d))
    M[:d, :d] = -A
    M[:d, d:] = Qc
    M[d:, d:] = A.T
    E = expm(M * dt)
    F = E[d:, d:].T
    Qd = F @ E[:d, d:]
    return F, 0.5 * (Qd + Qd.T)


def flicker_as_gm(B: float, fs: float, taus, per_decade: int = 1) -> tuple[tuple, float]:
    """Gauss-Markov terms whose summed Allan variance approximates the flicker floor
    ``(2 ln 2 / pi) B^2`` over the averaging times ``taus`` of a record.

    Method: correlation times log-spaced ``per_decade`` per decade from ``taus[0]`` to
    ``taus[-1]`` (one more at each end), their variances by non-negative least squares on the
    relative misfit of the exact Allan variance of each sampled AR(1)
    (:func:`fogcomp.noise.avar_gm`) to the flat floor. The representation of 1/f noise as a sum
    of first-order relaxation processes with time constants spread evenly in log time is the
    classical one (J. S. Keshner, "1/f noise", Proc. IEEE 70(3), 212-218, 1982; N. J. Kasdin,
    "Discrete simulation of colored noise and stochastic processes and 1/f^alpha power law
    noise generation", Proc. IEEE 83(5), 802-827, 1995, section IV); this project's simulator
    makes its flicker the same way (``sim.fog.bias_instability_components``).

    Parameters
    ----------
    B : float
        Flicker (bias instability) coefficient, rad/s.
    fs : float
        Sample rate, Hz.
    taus : array_like, shape (k,)
        Averaging times of the record, s (whole multiples of 1/fs).
    per_decade : int
        Correlation times per decade (default 1).

    Returns
    -------
    gm : tuple of (sigma rad/s, T s)
    max_rel_error : float
        Largest relative error of the approximation's Allan variance over ``taus``.
    """
    from scipy.optimize import nnls

    from fogcomp.noise import avar_gm

    t = np.sort(np.asarray(taus, dtype=float))
    if B <= 0:
        return (), 0.0
    lo, hi = math.log10(t[0]), math.log10(t[-1])
    n = max(2, int(math.ceil((hi - lo) * per_decade)) + 3)
    Ts = np.logspace(lo - 1.0 / per_decade, hi + 1.0 / per_decade, n)
    target = FLICKER_FLOOR * B * B
    A = np.column_stack([avar_gm(t, T, fs) for T in Ts]) / target
    w, _ = nnls(A, np.ones(t.size))
    approx = A @ w
    # w is in units of target: sigma^2 = w * target
    gm = tuple((math.sqrt(wi * target), float(T)) for wi, T in zip(w, Ts) if wi > 0)
    return gm, float(np.max(np.abs(approx - 1.0)))


@dataclass(frozen=True)
class BiasFilterModel:
    """The noise model of one axis as a bias-tracking Kalman filter (SI units).

    Attributes
    ----------
    fs : float
        Sample rate, Hz.
    N : float
        Angle random walk, rad/sqrt(s) (measurement noise ``N^2 fs`` per sample; > 0).
    K : float
        Rate random walk, rad/s/sqrt(s) (0: the bias state is an unknown constant).
    R : float
        Rate ramp, rad/s^2: the prior std of the ramp's slope state (0: no slope state).
    Q : float
        Quantisation, rad (rms angle error; 0: none).
    gm : tuple of (sigma rad/s, T s)
        Gauss-Markov terms.
    flicker : tuple of (sigma rad/s, T s)
        The Gauss-Markov terms approximating the flicker (:func:`flicker_as_gm`).
    bias_prior : float
        Prior std of the bias state b, rad/s: the unknown constant (turn-on bias, the error of
        the known rate). Default 0.1 rad/s, diffuse for any gyro.
    label : str
        A name for reports.
    """

    fs: float
    N: float
    K: float = 0.0
    R: float = 0.0
    Q: float = 0.0
    gm: tuple = ()
    flicker: tuple = ()
    bias_prior: float = 0.1
    label: str = ""

    def __post_init__(self):
        if not (math.isfinite(self.fs) and self.fs > 0):
            raise ValueError(f"fs: expected a positive sample rate in Hz, got {self.fs!r}")
        if not (math.isfinite(self.N) and self.N > 0):
            raise ValueError(f"N: the filter needs the white rate noise (angle random walk) "
                             f"as its measurement noise, > 0 rad/sqrt(s); got {self.N!r}")
        for name in ("K", "R", "Q", "bias_prior"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{name}: expected a finite value >= 0, got {v!r}")
        for s, T in tuple(self.gm) + tuple(self.flicker):
            if not (s >= 0 and T > 0):
                raise ValueError(f"gm: expected (sigma >= 0 rad/s, T > 0 s), got {(s, T)!r}")

    @property
    def states(self) -> list[str]:
        out = ["b"] + (["r"] if self.R > 0 else [])
        out += [f"gm{i}" for i in range(len(self.gm))]
        out += [f"fl{j}" for j in range(len(self.flicker))]
        out += ["q", "q-"] if self.Q > 0 else []
        return out

    def inflated(self, factor: float, terms: str = "all") -> BiasFilterModel:
        """Every coefficient (a standard deviation or density) times ``factor`` (variances times
        its square): ``terms="all"``, or ``"bias"`` (K, R, the Gauss-Markov and flicker terms;
        N and Q as they are)."""
        f = float(factor)
        if terms not in ("all", "bias"):
            raise ValueError(f"terms: expected 'all' or 'bias', got {terms!r}")
        fw = f if terms == "all" else 1.0
        return replace(self, N=self.N * fw, Q=self.Q * fw, K=self.K * f, R=self.R * f,
                       gm=tuple((s * f, T) for s, T in self.gm),
                       flicker=tuple((s * f, T) for s, T in self.flicker))

    def without_gm(self, index: int = -1) -> BiasFilterModel:
        """The model missing one Gauss-Markov term (default the last)."""
        gm = list(self.gm)
        gm.pop(index)
        return replace(self, gm=tuple(gm), label=(self.label + " - GM").strip())

    def matrices(self) -> dict:
        """``F, Qd, H (d,), Rm (scalar), P0, bias_row (d,), states``: the discrete filter."""
        dt = 1.0 / self.fs
        st = self.states
        d = len(st)
        F = np.zeros((d, d))
        Qd = np.zeros((d, d))
        P0 = np.zeros((d, d))
        H = np.zeros(d)
        hb = np.zeros(d)
        i = 0
        F[0, 0] = 1.0
        Qd[0, 0] = self.K**2 * dt
        P0[0, 0] = self.bias_prior**2
        H[0] = hb[0] = 1.0
        i = 1
        if self.R > 0:
            F[0, 1] = dt
            F[1, 1] = 1.0
            P0[1, 1] = self.R**2
            i = 2
        for s, T in tuple(self.gm) + tuple(self.flicker):
            phi = math.exp(-dt / T)
            F[i, i] = phi
            Qd[i, i] = s * s * (-math.expm1(-2.0 * dt / T))   # s^2 (1 - phi^2)
            P0[i, i] = s * s
            H[i] = hb[i] = 1.0
            i += 1
        if self.Q > 0:
            Qd[i, i] = self.Q**2
            P0[i, i] = P0[i + 1, i + 1] = self.Q**2
            F[i + 1, i] = 1.0
            H[i] = self.fs
            H[i + 1] = -self.fs
        return {"F": F, "Qd": Qd, "H": H, "Rm": self.N**2 * self.fs, "P0": P0,
                "bias_row": hb, "states": st}


def from_noise_model(model, *, per_decade: int = 1, bias_prior: float = 0.1,
                     label: str = "identified") -> BiasFilterModel:
    """The filter of an identified :class:`fogcomp.noise.NoiseModel`: its identified terms
    (significant at the selection's level, as :meth:`~fogcomp.noise.NoiseModel.filter_parameters`
    gives them; a weak term kept in the fit for the others' sake is left out: a quantisation
    term that the record does not show would tell the filter the rate noise is strongly
    anti-correlated from one sample to the next), the flicker by :func:`flicker_as_gm` over the
    model's averaging times.

    A filter needs a measurement noise: when the model holds no white rate noise N (a record
    whose shortest averaging times are dominated by another term), N is taken from the Allan
    variance at the shortest averaging time, ``N^2 = AVAR(tau_0) tau_0`` (the white noise that
    alone would give that point: an upper bound of N), and the label says so."""
    co = {t.term: t.value for t in model.identified if t.term != "GM"}
    gm = [(t.value, t.tau) for t in model.identified if t.term == "GM"]
    B = co.get("B") or 0.0
    fl = flicker_as_gm(B, model.fs, model.taus, per_decade)[0] if B > 0 else ()
    N = co.get("N") or 0.0
    if not N > 0:
        N = math.sqrt(float(model.avar[0]) * float(model.taus[0]))
        label += " (N from the Allan variance at the shortest tau: not in the model)"
        if not N > 0:
            raise ValueError("model: no white rate noise (N) in the identified model and a "
                             "zero Allan variance at the shortest averaging time; the filter "
                             "needs a measurement noise")
    return BiasFilterModel(fs=model.fs, N=N, K=co.get("K") or 0.0, R=co.get("R") or 0.0,
                           Q=co.get("Q") or 0.0, gm=tuple((float(s), float(T)) for s, T in gm),
                           flicker=fl, bias_prior=bias_prior, label=label)


@dataclass
class FilterRun:
    """What :func:`run_filter` returns for a batch of B members (model, record) over n samples.

    Attributes
    ----------
    bias : ndarray, shape (B, n)
        The bias estimate ``bias_row x_k``, rad/s (filtered: after sample k).
    bias_var : ndarray, shape (B, n)
        Its variance from the filter's covariance, rad^2/s^2.
    innov : ndarray, shape (B, n)
        The innovations ``z_k - H F x_{k-1}``, rad/s.
    S : ndarray, shape (B, n)
        Their variance, rad^2/s^2.
    track : ndarray or None
        Indices at which ``P`` and the transition of the error were kept (``P_track`` (B, m, d,
        d); ``Phi_track`` (B, m, d, d): the product of ``(I - K H) F`` from the previous tracked
        index (exclusive) to this one (inclusive)).
    """

    bias: np.ndarray
    bias_var: np.ndarray
    innov: np.ndarray
    S: np.ndarray
    bias_row: np.ndarray
    track: np.ndarray | None = None
    P_track: np.ndarray | None = None
    Phi_track: np.ndarray | None = None
    x_track: np.ndarray | None = None

    @property
    def nis(self) -> np.ndarray:
        return self.innov**2 / self.S


def _pad(mats: list[dict]) -> dict:
    d = max(len(m["H"]) for m in mats)
    out = {}
    for key in ("F", "Qd", "P0"):
        a = np.zeros((len(mats), d, d))
        for j, m in enumerate(mats):
            k = m[key].shape[0]
            a[j, :k, :k] = m[key]
        out[key] = a
    for key in ("H", "bias_row"):
        a = np.zeros((len(mats), d))
        for j, m in enumerate(mats):
            a[j, :len(m[key])] = m[key]
        out[key] = a
    out["Rm"] = np.array([m["Rm"] for m in mats])
    return out


def run_filter(models, z, *, track=None) -> FilterRun:
    """Run the bias filter of each model over its record, all members side by side.

    Parameters
    ----------
    models : BiasFilterModel or sequence of BiasFilterModel, length B
        One per member (a single model: every record); models of fewer states are padded with
        inert ones (zero prior, zero noise, not measured).
    z : array_like, shape (n,) or (B, n)
        Measured rate minus the known true rate, rad/s (one record: every model).
    track : array_like of int, optional
        Sample indices (increasing) at which to keep the covariance and the error's transition
        (for the autocorrelation of the NEES, :func:`fogcomp.consistency.nees_test`).

    Notes
    -----
    The Kalman filter in its textbook form (the equations as comments below); the covariance
    is the same for every record of one model and is updated once per step for the batch. A
    per-sample loop over n (NumPy on (B, d, d) arrays): about 30-60 microseconds a sample here,
    whatever B.
    """
    if isinstance(models, BiasFilterModel):
        models = [models]
    models = list(models)
    z = np.asarray(z, dtype=float)
    if z.ndim == 1:
        z = np.broadcast_to(z, (len(models), z.size))
    if len(models) == 1 and z.shape[0] > 1:
        models = models * z.shape[0]
    if z.ndim != 2 or z.shape[0] != len(models):
        raise ValueError(f"z: expected shape (n,) or ({len(models)}, n), got {z.shape}")
    if not np.all(np.isfinite(z)):
        raise ValueError("z: the record holds NaN or infinite values")
    mats = _pad([m.matrices() for m in models])
    Bn, n = z.shape
    F, Qd, P, H, Rm, hb = mats["F"], mats["Qd"], mats["P0"].copy(), mats["H"], mats["Rm"], \
        mats["bias_row"]
    d = F.shape[1]
    x = np.zeros((Bn, d))
    FT = np.transpose(F, (0, 2, 1))
    bias = np.empty((Bn, n))
    bvar = np.empty((Bn, n))
    innov = np.empty((Bn, n))
    S_all = np.empty((Bn, n))
    eye = np.eye(d)
    tr = None if track is None else np.asarray(track, dtype=int)
    if tr is not None:
        P_tr = np.empty((Bn, tr.size, d, d))
        Phi_tr = np.empty((Bn, tr.size, d, d))
        x_tr = np.empty((Bn, tr.size, d))
        Phi = np.broadcast_to(eye, (Bn, d, d)).copy()
        ti = 0
    for k in range(n):
        # predict: x- = F x;  P- = F P F' + Q
        x = np.einsum("bij,bj->bi", F, x)
        P = F @ P @ FT + Qd
        # innovation: nu = z - H x-;  S = H P- H' + R
        PH = np.einsum("bij,bj->bi", P, H)
        S = np.einsum("bi,bi->b", H, PH) + Rm
        nu = z[:, k] - np.einsum("bi,bi->b", H, x)
        # update: K = P- H' / S;  x = x- + K nu;  P = P- - K S K'
        Kg = PH / S[:, None]
        x = x + Kg * nu[:, None]
        P = P - Kg[:, :, None] * PH[:, None, :]
        P = 0.5 * (P + np.transpose(P, (0, 2, 1)))
        innov[:, k] = nu
        S_all[:, k] = S
        bias[:, k] = np.einsum("bi,bi->b", hb, x)
        bvar[:, k] = np.einsum("bi,bij,bj->b", hb, P, hb)
        if tr is not None:
            A = (eye - Kg[:, :, None] * H[:, None, :]) @ F      # e_k = A e_{k-1} + noise
            Phi = A @ Phi
            if ti < tr.size and k == tr[ti]:
                P_tr[:, ti] = P
                Phi_tr[:, ti] = Phi
                x_tr[:, ti] = x
                Phi = np.broadcast_to(eye, (Bn, d, d)).copy()
                ti += 1
    out = FilterRun(bias=bias, bias_var=bvar, innov=innov, S=S_all, bias_row=hb)
    if tr is not None:
        out.track, out.P_track, out.Phi_track, out.x_track = tr, P_tr, Phi_tr, x_tr
    return out
