"""Confidence intervals of the overlapping Allan deviation and noise identification with
uncertainties (fogcomp.allan), checked against allantools' `ci` module, Monte Carlo scatter of
synthetic noise, and the real FOG curves of /work/shared/realdata/fog_allan_curves."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fogcomp.allan import (
    ONE_SIGMA_CI,
    confidence_interval,
    edf_greenhall,
    identify_noise,
    identify_noise_terms,
    oadev_ci,
    oadev_details,
)

allantools = pytest.importorskip("allantools")
from allantools import ci as at_ci  # noqa: E402

DEG = math.pi / 180.0


from helpers import need_realdata, realdata_dir as _realdata_dir  # noqa: E402


FOG_DIR = _realdata_dir() / "fog_allan_curves"


# ---------------------------------------------------------------------------------------------
# EDF and intervals against allantools
@pytest.mark.parametrize("alpha", [2, 1, 0, -1, -2])
@pytest.mark.parametrize("overlapping", [True, False])
def test_edf_matches_allantools(alpha, overlapping):
    checked = 0
    for m in (1, 2, 3, 8, 30, 64, 500, 4096):
        for n in (40, 101, 1000, 65537, 10**6):
            if n <= 2 * m + 1:
                continue
            try:
                ref = at_ci.edf_greenhall(alpha=alpha, d=2, m=m, N=n, overlapping=overlapping,
                                          modified=False)
            except NotImplementedError:          # alpha=+2 with <= 2 clusters: ours is exact
                continue
            assert edf_greenhall(alpha, m, n, overlapping=overlapping) == \
                pytest.approx(ref, rel=1e-10), (m, n)
            checked += 1
    assert checked > 20


def test_confidence_interval_matches_allantools():
    for edf in (1.5, 4.0, 37.2, 1e4):
        for ci in (ONE_SIGMA_CI, 0.9, 0.95):
            lo, hi = at_ci.confidence_interval(2.5, edf, ci)
            mlo, mhi = confidence_interval(2.5, edf, ci)
            assert float(mlo) == pytest.approx(lo, rel=1e-12)
            assert float(mhi) == pytest.approx(hi, rel=1e-12)


def test_white_noise_edf_many_clusters_is_the_textbook_value():
    # Greenhall's Table 2 (alpha=0, d=2) for r = M/S >> 1: 1/edf ~ (2/3)/r, i.e. edf ~ 1.5 N/m,
    # the classic overlapping white-FM result (NIST SP 1065 Table 12, 3(N-1)/(2m) ...).
    n, m = 10**6 + 1, 1000
    assert edf_greenhall(0, m, n) == pytest.approx(1.5 * n / m, rel=0.01)


def test_edf_rejects_bad_arguments():
    with pytest.raises(ValueError, match="alpha"):
        edf_greenhall(-3, 4, 1000)              # alpha + 2d must exceed 1 for Allan
    with pytest.raises(ValueError, match="too few"):
        edf_greenhall(0, 100, 50)
    with pytest.raises(ValueError, match="ci"):
        confidence_interval(1.0, 3.0, 1.5)


# ---------------------------------------------------------------------------------------------
# Coverage of the intervals (Monte Carlo; independent of the EDF formulas)
@pytest.mark.parametrize("make, alpha", [
    (lambda rng, n: rng.standard_normal(n), 0),                       # white rate (ARW)
    (lambda rng, n: np.cumsum(rng.standard_normal(n)) * 1e-2, -2),    # random-walk rate
])
def test_interval_coverage_is_nominal(make, alpha):
    rng = np.random.default_rng(3)
    n, reps = 2048, 400
    taus = np.array([1, 4, 16, 64]) * 1.0
    curves = np.array([oadev_details(make(rng, n), 1.0, taus).adev for _ in range(reps)])
    truth = np.sqrt(np.mean(curves**2, axis=0))           # ensemble Allan deviation
    inside = np.zeros(taus.size)
    for _ in range(reps):
        c = oadev_ci(make(rng, n), 1.0, taus, alpha=alpha)
        inside += (c.low <= truth) & (truth <= c.high)
    coverage = inside / reps
    # 68.3 % nominal; binomial sd of 400 draws is 2.3 %.
    assert np.all((coverage > 0.60) & (coverage < 0.77)), coverage


def test_oadev_ci_identifies_white_noise_type():
    c = oadev_ci(np.random.default_rng(5).standard_normal(2**15), 100.0)
    assert np.all(c.alpha == 0)
    assert np.all(c.low < c.adev) and np.all(c.adev < c.high)
    assert c.ci == pytest.approx(0.6827, abs=1e-4)


# ---------------------------------------------------------------------------------------------
# identify_noise_terms
def test_terms_agree_with_identify_noise_and_arw_uncertainty_is_honest():
    # The values equal identify_noise's; the ARW sigma matches the scatter over realisations.
    arw, fs, n = 1e-3, 100.0, 2**15
    rng = np.random.default_rng(9)
    values, sigmas = [], []
    for _ in range(40):
        d = oadev_details(arw * math.sqrt(fs) * rng.standard_normal(n), fs)
        new = identify_noise_terms(d.taus, d.adev, d.adev_err)
        old = identify_noise(d.taus, d.adev, d.adev_err)
        assert new.terms["N"].value == old.N
        assert new.terms["N"].status == "identified"
        values.append(new.terms["N"].value)
        sigmas.append(new.terms["N"].sigma)
    assert np.mean(values) == pytest.approx(arw, rel=0.02)
    ratio = np.std(values) / np.mean(sigmas)
    assert 0.4 < ratio < 2.0, ratio


def test_not_identified_terms_say_why():
    taus = np.logspace(-2, 3, 25)
    adev = 1e-4 / np.sqrt(taus)
    r = identify_noise_terms(taus, adev)
    assert r.terms["N"].status == "identified"
    for t in ("Q", "K", "R"):
        assert r.terms[t].status == "not identified" and r.terms[t].value is None
        assert "leading term" in r.terms[t].reason
    assert r.terms["B"].status == "upper bound"
    assert "no floor" in r.terms["B"].reason


def test_interval_bounds_are_validated():
    with pytest.raises(ValueError, match="adev_high: below adev_low"):
        identify_noise_terms([1, 2, 4], [1, 1, 1], adev_low=[0.9, 1.1, 0.9],
                             adev_high=[1.1, 1.0, 1.1])
    with pytest.raises(ValueError, match="both bounds"):
        identify_noise_terms([1, 2, 4], [1, 1, 1], adev_low=[0.9, 0.9, 0.9])


# ---------------------------------------------------------------------------------------------
# Real FOG curves
FOGS = {   # file, README's ARW reading at tau = 1 s (deg/sqrt(h)), per axis low/high
    "kvh1750": ("kvh1750_gyro_oadev.csv", 0.0025, 0.0037, math.pi / 180.0),
    "ln200": ("ln200_gyro_oadev.csv", 0.034, 0.048, 1.0),
    "imar": ("imar_gyro_oadev.csv", 0.08, 0.13, 1.0),
}


@pytest.fixture(scope="module")
def fog_curves():
    need_realdata(FOG_DIR)
    import pandas as pd

    out = {}
    for name, (fname, lo, hi, to_rad) in FOGS.items():
        df = pd.read_csv(FOG_DIR / fname, comment="#")
        for ax, g in df.groupby("axis"):
            v = g.to_numpy()[:, 1:].astype(float)
            out[(name, ax)] = (v[:, 0], v[:, 1] * to_rad, v[:, 2] * to_rad, v[:, 3] * to_rad)
    return out


def test_fog_arw_in_readme_class_and_bias_instability_reported(fog_curves):
    for (name, ax), (t, a, lo, hi) in fog_curves.items():
        r = identify_noise_terms(t, a, adev_low=lo, adev_high=hi, ci=0.95)
        n = r.terms["N"]
        arw = n.value / DEG * 60.0
        _, arw_lo, arw_hi, _ = FOGS[name]
        assert n.status == "identified" and arw_lo <= arw <= arw_hi, (name, ax, arw)
        assert n.sigma / n.value < 0.05
        # The -1/2 line read at tau = 1 s by hand (interpolating the curve) agrees to 10 %.
        read = np.exp(np.interp(0.0, np.log(t), np.log(a))) / DEG * 60.0
        assert arw == pytest.approx(read, rel=0.10), (name, ax)
        b = r.terms["B"]
        assert b.status in ("identified", "upper bound"), (name, ax, b.reason)
        if name == "kvh1750":                 # the KVH curve turns up inside its reliable part
            assert b.status == "identified" and 0.03 < b.value / DEG * 3600 < 0.15
        if b.status == "identified":
            assert b.sigma > 0
        else:
            # an upper bound is at least the lowest reliable point / 0.664
            assert b.value / DEG * 3600 > 0.01


def test_fog_model_inside_confidence_bounds_where_terms_apply(fog_curves):
    # "Where the terms apply": where the statistical 95 % bound is wider than the 5 % model
    # mismatch the fit allows for (below that, at short taus, the curves show the sensors'
    # output filtering and correlated noise, which the five-term model has no term for).
    inside = total = 0
    for (name, ax), (t, a, lo, hi) in fog_curves.items():
        r = identify_noise_terms(t, a, adev_low=lo, adev_high=hi, ci=0.95)
        m = r.model_adev(t)
        apply = (hi - a) / a > 0.05
        inside += int(np.sum((m >= lo) & (m <= hi) & apply))
        total += int(apply.sum())
    assert total > 60
    assert inside / total >= 0.9, (inside, total)
