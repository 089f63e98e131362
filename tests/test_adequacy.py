"""Fit adequacy: the chi-square verdict, where the misfit sits, and which zones a misfit moves."""

import numpy as np
import pytest

from frictionid.inverse.adequacy import SHIFT_LIMIT, assess
from frictionid.inverse.uncertainty import estimate

RNG_SEED = 11
N = 100                                          # observations per quantity


def linear_fit(bias: float, seed: int = RNG_SEED):
    """y = J x_true + noise (sigma 1) on two quantities; the exx rows also carry ``bias`` times zone A's
    sensitivity plus a smooth offset, the pattern of a model error that only the strains see (part of it
    looks like a change of A). Returns the weighted fit."""
    rng = np.random.default_rng(seed)
    jac = np.vstack([rng.normal(size=(N, 2)) * [1.0, 0.5], rng.normal(size=(N, 2)) * [2.0, 0.3]]) * 10.0
    x_true = np.array([0.35, 0.2])
    y = jac @ x_true + rng.normal(size=2 * N)
    y[N:] += bias * (jac[N:, 0] + 20.0 * np.sin(np.linspace(0.0, 6.0, N)))
    x = np.linalg.lstsq(jac, y, rcond=None)[0]
    r = jac @ x - y
    labels = [f"P{i}:ux@2" for i in range(N)] + [f"P{i}:exx@2" for i in range(N)]
    return jac, r, x, x_true, labels, y, jac @ x


def test_noise_alone_is_consistent_and_moves_no_zone():
    jac, r, x, _, labels, y, f = linear_fit(bias=0.0)
    adequacy = assess(r, jac, labels, y, f, noise_known=True)
    assert adequacy.consistent is True
    assert adequacy.reduced_chi2 == pytest.approx(float(r @ r) / (2 * N - 2))
    assert not adequacy.affected.any() and adequacy.hint == ""
    assert set(adequacy.by_quantity) == {"ux", "exx"}
    assert sum(g.share for g in adequacy.by_quantity.values()) == pytest.approx(1.0)


def test_a_strain_only_model_error_is_found_and_blamed_on_the_zone_it_moves():
    jac, r, x, x_true, labels, y, f = linear_fit(bias=0.5)
    adequacy = assess(r, jac, labels, y, f, noise_known=True)
    assert adequacy.consistent is False and adequacy.reduced_chi2 > adequacy.threshold
    assert adequacy.by_quantity["exx"].share > 0.7              # the misfit sits in the strains
    assert adequacy.worst[0][0].endswith("exx@2")
    assert "strains carry most of the misfit" in adequacy.hint
    strain_shift = next(s for s in adequacy.shifts if s.group == "the exx values")
    assert strain_shift.z[0] > 10 * SHIFT_LIMIT and strain_shift.z[1] < SHIFT_LIMIT   # A moves, B barely
    assert adequacy.affected[0]
    unc = estimate(jac, r, x, np.zeros(2), np.ones(2), True, 0.02, ("A", "B"), adequacy)
    assert not unc.identifiable[0] and abs(x[0] - x_true[0]) > 0.3       # A is far off and not claimed
    assert "leaving out the ux values moves A by 42" in unc.why[0]
    # the error is scaled by sqrt(reduced chi-square), not taken from the stated noise
    assert unc.scale == pytest.approx(adequacy.reduced_chi2)


def test_without_stated_noise_nothing_is_tested():
    jac, r, x, _, labels, y, f = linear_fit(bias=0.5)
    adequacy = assess(r, jac, labels, y, f, noise_known=False)
    assert adequacy.consistent is None and not adequacy.shifts and not adequacy.affected.any()


def test_consistency_is_claimed_at_the_stated_confidence():
    """Under pure noise the 99 % test calls about 1 % of fits inconsistent."""
    verdicts = [assess(*linear_fit(0.0, seed)[1::-1], linear_fit(0.0, seed)[4], linear_fit(0.0, seed)[5],
                       linear_fit(0.0, seed)[6], True).consistent for seed in range(200)]
    assert 190 <= sum(verdicts) <= 200
