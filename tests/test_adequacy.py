"""Fit adequacy: the chi-square verdict, where the misfit sits, and which zones a misfit moves."""

import re

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


def test_a_misfit_below_the_lower_quantile_says_the_noise_is_too_large_never_explained():
    """The noise stated in um where mm is meant: residuals 1000 times smaller than the stated noise."""
    from frictionid.report.tables import _adequacy_lines

    jac, r, x, _, labels, y, f = linear_fit(bias=0.0)
    adequacy = assess(r / 1000, jac / 1000, labels, y, f, noise_known=True)
    assert adequacy.too_small and adequacy.reduced_chi2 < adequacy.low_threshold < 1.0
    assert "the stated noise is too large or the data were smoothed" in adequacy.hint
    assert "ux residuals are 0.00" in adequacy.hint and "a factor 1000: noise given in um" in adequacy.hint
    text = "\n".join(_adequacy_lines({**adequacy.as_dict(("A", "B")), "error_scale": 1.0}))
    assert "explains" not in text and "SMALLER THAN THE STATED NOISE" in text and "too wide" in text
    assert not assess(r, jac, labels, y, f, noise_known=True).too_small


def test_the_lower_tail_is_tested_at_its_stated_confidence():
    """Under pure noise about 1 % of fits fall below the 1 % quantile."""
    low = [assess(*linear_fit(0.0, seed)[1::-1], *linear_fit(0.0, seed)[4:7], True).too_small for seed in range(200)]
    assert sum(low) <= 8


def unit_mistake(factor_ux=1.0, factor_force=1.0, swap=False, seed=RNG_SEED):
    """A fitted model f of ux, uy at N points and a machine force at 3 stages, and data y made from it with one
    input mistake: ux times ``factor_ux``, the force times ``factor_force``, or ux and uy exchanged; noise sigma
    0.0005 mm and 0.05 N. Returns (r, jac, labels, y, f, sigma)."""
    rng = np.random.default_rng(seed)
    f_ux, f_uy = rng.uniform(0.005, 0.05, N), rng.uniform(-0.05, -0.005, N)
    f_force = np.array([20.0, 40.0, 60.0])
    y_ux, y_uy = (f_uy, f_ux) if swap else (factor_ux * f_ux, f_uy)
    sigma = np.concatenate([np.full(2 * N, 0.0005), np.full(3, 0.05)])
    f = np.concatenate([f_ux, f_uy, f_force])
    y = np.concatenate([y_ux, y_uy, factor_force * f_force]) + sigma * rng.normal(size=f.size)
    labels = [f"{i}:ux@2" for i in range(N)] + [f"{i}:uy@2" for i in range(N)] + [f"force@{s}" for s in (1, 2, 3)]
    jac = rng.normal(size=(f.size, 2))
    return (f - y) / sigma, jac, labels, y, f, sigma


@pytest.mark.parametrize("factor, words", [(1000.0, "in um where mm"), (1 / 25.4, "in inches where mm"),
                                           (10.0, "close to 10,"), (0.001, "in m where mm")])
def test_a_unit_mistake_in_one_quantity_is_named_with_its_factor(factor, words):
    r, jac, labels, y, f, sigma = unit_mistake(factor_ux=factor)
    adequacy = assess(r, jac, labels, y, f, True, sigma=sigma)
    assert adequacy.consistent is False and adequacy.by_quantity["ux"].share > 0.99
    scale = float(re.search(r"the measured ux values are (\S+) times the model's", adequacy.hint).group(1))
    assert scale == pytest.approx(factor, rel=0.1) and words in adequacy.hint
    assert "refine the mesh" not in adequacy.hint


def test_a_load_cell_in_newton_on_a_plane_strain_model_is_named():
    r, jac, labels, y, f, sigma = unit_mistake(factor_force=12.0)
    hint = assess(r, jac, labels, y, f, True, sigma=sigma, model_kind="plane_strain").hint
    assert "the measured force values are 12 times the model's" in hint and "per mm of thickness (N/mm)" in hint
    assert "suggests 12 mm or more" in hint
    assert "per mm of thickness" not in assess(r, jac, labels, y, f, True, sigma=sigma, model_kind="3d").hint


def test_swapped_components_are_named():
    r, jac, labels, y, f, sigma = unit_mistake(swap=True)
    hint = assess(r, jac, labels, y, f, True, sigma=sigma).hint
    assert hint.startswith("ux and uy look swapped:") and "check [data] columns" in hint
    assert "refine the mesh" not in hint


def test_a_model_error_is_not_called_a_unit_mistake():
    jac, r, x, _, labels, y, f = linear_fit(bias=0.5)
    hint = assess(r, jac, labels, y, f, noise_known=True).hint
    assert "times the model's" not in hint and "swapped" not in hint and "strains carry most" in hint


def test_numbered_points_are_grouped_by_region_not_one_group_each():
    """DIC subset ids as labels: the misfit table has one row per region, and the hint names the region."""
    jac, r, x, _, labels, y, f = linear_fit(bias=0.5)
    numbered = [label.replace("P", "") for label in labels]
    regions = {str(i): "block" if i < N // 2 else "base" for i in range(N)}
    adequacy = assess(r, jac, numbered, y, f, True, regions=regions)
    assert set(adequacy.by_group) == {"region block", "region base"}
    assert sum(g.n for g in adequacy.by_group.values()) == 2 * N
    assert any(s.group == "the points of region block" for s in adequacy.shifts)
    assert set(assess(r, jac, numbered, y, f, True).by_group) == {"numbered points"}
    assert set(assess(r, jac, labels, y, f, True).by_group) == {"P"}


def test_a_few_observations_beyond_their_noise_make_the_fit_inconsistent_though_the_whole_chi2_passes():
    """Two machine forces about 5 noise levels off among 5,000 displacements that fit: the whole chi-square passes
    (an excess of about 50 in 5,000), the force's own does not, and the zone the forces pull is not claimed."""
    rng = np.random.default_rng(RNG_SEED)
    n = 5000
    jac = np.vstack([rng.normal(size=(n, 2)), [[40.0, 1.0], [40.0, 1.0]]])
    x_true = np.array([0.35, 0.2])
    y = jac @ x_true + 0.9 * rng.normal(size=n + 2)               # the noise a little smaller than stated
    y[n:] += 8.0                                    # A absorbs 40 % of it: the forces stay about 5 noise levels off
    x = np.linalg.lstsq(jac, y, rcond=None)[0]
    r = jac @ x - y
    labels = [f"P{i}:ux@2" for i in range(n)] + ["force@1", "force@2"]
    adequacy = assess(r, jac, labels, y, jac @ x, noise_known=True)
    assert adequacy.reduced_chi2 <= adequacy.threshold              # the whole passes ...
    assert adequacy.by_quantity["force"].rms > 3.0
    assert adequacy.kinds_beyond == ("force",) and adequacy.consistent is False   # ... the force does not
    assert "not every quantity on its own: force" in adequacy.hint
    assert adequacy.as_dict(("A", "B"))["kinds_beyond_noise"] == ["force"]
    force_shift = next(s for s in adequacy.shifts if s.group == "the force values")
    assert force_shift.z[0] > SHIFT_LIMIT and adequacy.affected[0]
    unc = estimate(jac, r, x, np.zeros(2), np.ones(2), True, 0.5, ("A", "B"), adequacy)
    assert not unc.identifiable[0] and "leaving out the force values" in unc.why[0]
    assert adequacy.reduced_chi2 < 1.0 and unc.scale == 1.0          # never narrower than the stated noise's
