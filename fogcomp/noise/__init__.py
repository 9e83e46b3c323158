"""Composite noise identification: the Allan variance of a record fitted to a sum of processes.

The overlapping Allan variance ``v[j]`` of a record at the octave averaging times
``tau_j = m_j tau0`` is fitted to the variance a sum of independent latent processes implies,
``v(tau; theta) = sum_p v_p(tau; theta_p)``, by minimising the quadratic form::

    J(theta) = (v - v(theta))^T  Omega  (v - v(theta)),      Omega = Sigma(theta_pilot)^-1,

with ``Sigma`` the covariance of the estimates ``v`` for Gaussian processes of the model at a
pilot value of ``theta``, computed exactly from the processes' autocovariances (below), not from
an approximation per point. This is the generalized method of wavelet moments (GMWM; Guerrier,
Skaloud, Stebler, Victoria-Feser, JASA 108(502), 776-789, 2013, eq. 4) written for the Allan
variance: the Haar wavelet variance at scale tau is half the Allan variance,
``nu_Haar^2(tau) = AVAR(tau) / 2`` (Percival & Guttorp, "Long-memory processes, the Allan
variance and wavelets", 1994; Percival & Walden, *Wavelet Methods for Time Series Analysis*,
2000, eq. 322b), so the two fits are the same up to a factor that cancels in ``J``.

Notes
-----
**Processes and their Allan variance** (``tau = m tau0``, ``tau0 = 1/fs``):

=====  ===========================  ==========================  ====================================
term   process                      coefficient (SI)            AVAR(tau)
=====  ===========================  ==========================  ====================================
Q      quantisation (white angle)   Q, rad (rms angle error)    3 Q^2 / tau^2
N      white rate (ARW)             N, rad/sqrt(s)              N^2 / tau
B      flicker rate (bias instab.)  B, rad/s                    (2 ln 2 / pi) B^2
K      rate random walk             K, rad/s/sqrt(s)            K^2 tau / 3
R      rate ramp                    R, rad/s^2                  R^2 tau^2 / 2
GM     first-order Gauss-Markov     sigma rad/s, T s            see below
=====  ===========================  ==========================  ====================================

Q, N, B, K, R: IEEE Std 952-1997 Annex C, Table C.1 (B the flicker coefficient: its Allan floor
is ``sqrt(2 ln 2 / pi) B = 0.664 B`` for tau well above the inverse of the flicker band's upper
corner; an angle quantum q gives ``Q = q / sqrt(12)``). GM: a stationary first-order
Gauss-Markov (AR(1)) rate sampled at fs, ``x[k+1] = phi x[k] + w[k]``, ``phi = exp(-tau0 / T)``,
variance ``sigma^2``: its autocovariance is ``sigma^2 phi^|h|``, and the Allan variance of m-sample
means follows exactly (Zhang, "Allan variance of time series models for measurement data",
Metrologia 45, 549-561, 2008, section 3 for AR(1))::

    AVAR(m) = sigma^2 / (m^2 (1 - phi)^2) * [ m (1 - phi^2) - phi (1 - phi^m) (3 - phi^m) ]

which tends to IEEE 952's correlated-noise term ``(q_c T)^2/tau [1 - T/(2 tau)(3 - 4 e^(-tau/T) +
e^(-2 tau/T))]`` with ``q_c^2 = 2 sigma^2 / T`` as fs grows, to ``2 sigma^2 T / tau`` (white) for
tau >> T and to ``2 sigma^2 tau / (3 T)`` (a random walk's slope, K^2 = 2 sigma^2 / T) for tau << T.

**The covariance of the estimates** ``Sigma`` follows from the generalised autocovariance of
each process's integrated angle, summed exactly over the pairs of second differences (the
derivation is in ``fogcomp/noise/_covariance.py``).

**Estimation, selection and intervals.** For given Gauss-Markov correlation times the model is
linear in the variances (Q^2, N^2, B^2, K^2, R^2, sigma_g^2), solved by non-negative least squares
on the whitened system; the correlation times are found by a grid over the octaves and a
Nelder-Mead refinement of ``J``. ``Omega`` is computed at a pilot fit and then once more at the
estimate (two steps, as GMWM's two-step estimator). Model selection is by the
distance-difference test of the method of moments (Newey & West, "Hypothesis testing with
efficient method of moments estimation", Int. Econ. Rev. 28(3), 777-787, 1987): with ``Omega``
the inverse covariance, the increase of J when q parameters are removed is asymptotically
chi-squared with q degrees of freedom; a term is kept only when removing it raises J by more
than the 1 - ``alpha`` quantile (``alpha`` = 1 % by default), and a further Gauss-Markov term is
added only when it lowers J by as much. The intervals come from the covariance
``(D^T Omega D)^-1`` of the estimate (D the Jacobian of the model), scaled by ``J / dof`` when
the fit is significantly worse than its error bars say (a real curve departing from the model);
a variance coefficient's normal interval is taken to the square root, a correlation time's is
normal in log T.

**Where each part is** (private modules of this package): ``_processes`` the candidate
processes, their Allan variance and the parsing of a stated model; ``_covariance`` the
covariance of the estimates; ``_fit`` fitting one stated model; ``_select`` choosing among
models; ``_intervals`` the intervals and the record length a term would need; ``_result`` the
result types :class:`NoiseModel` and :class:`ModelTerm`; ``_identify`` the identifier that runs
them in turn.
"""

from ._covariance import avar_covariance
from ._identify import identify_noise_model
from ._processes import (
    LINEAR_TERMS,
    TERM_NAMES,
    avar_gm,
    avar_model,
    avar_term,
    parse_model,
)
from ._result import (
    DATASHEET,
    DATASHEET_VERSION,
    Datasheet,
    ModelTerm,
    NoiseModel,
    check_datasheet,
)

__all__ = [
    "DATASHEET",
    "DATASHEET_VERSION",
    "Datasheet",
    "LINEAR_TERMS",
    "TERM_NAMES",
    "ModelTerm",
    "NoiseModel",
    "avar_covariance",
    "avar_gm",
    "avar_model",
    "avar_term",
    "check_datasheet",
    "identify_noise_model",
    "parse_model",
]
