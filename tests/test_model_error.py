"""Discretisation-error estimate: refined builder options, Richardson's formula, the estimate against a much finer
mesh on the plane-strain block, the inflated standard deviations and bad input."""

import dataclasses
import json

import numpy as np
import pytest

from frictionid.backends import embedded
from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.bolt import default_sizes
from frictionid.builders.registry import build_model, refined
from frictionid.errors import InputError
from frictionid.inverse import model_error
from frictionid.inverse.model_error import (STRAIN_ORDER, ModelError, convergence_orders, estimate_model_error,
                                            inflated_sigma, observation_kinds, richardson)
from frictionid.inverse.observations import Observations
from frictionid.options import ModelSpec

# ------------------------------------------------------------------------------------------ refined options


def test_block_refines_its_mesh_size_and_given_divisions_only():
    options = {"builder": "block", "mesh_size": 2.5, "block_divisions": 6, "order": 2, "grading": 3}
    assert refined(ModelSpec.from_table(options)).table() == {"builder": "block", "mesh_size": 1.25,
                                                              "block_divisions": 12, "order": 2,
                                "grading": 3}
    assert refined(ModelSpec.from_table({"builder": "block"}), 4).table() == {"builder": "block",
                                                                              "mesh_size": 0.25}   # default 1.0
    assert options["mesh_size"] == 2.5                                                    # caller's table kept


def test_block2d_refines_mesh_and_contact_size_and_leaves_an_absent_contact_size_to_follow():
    assert refined(ModelSpec.from_table({"builder": "block2d", "mesh_size": 2.0, "contact_size": 0.5,
                                         "n_zones": 3})).table() == {
        "builder": "block2d", "mesh_size": 1.0, "contact_size": 0.25, "n_zones": 3}
    assert refined(ModelSpec.from_table({"builder": "block2d", "order": 1})).table() == {"builder": "block2d",
                                                                                         "order": 1, "mesh_size": 0.5}


def test_bolt_refines_all_three_sizes_with_the_builders_defaults_when_absent():
    m24 = default_sizes("M24")
    assert refined(ModelSpec.from_table({"builder": "bolt", "size": "M24", "forces": [1.0]})).table() == {
        "builder": "bolt", "size": "M24", "forces": [1.0], "flank_size": 0.05,             # default 0.1
        "contact_size": m24["contact_size"] / 2, "mesh_size": m24["mesh_size"] / 2}
    assert refined(ModelSpec.from_table({"builder": "bolt", "flank_size": 0.2, "contact_size": 0.4, "mesh_size": 2.0}),
                   4).table() == {
        "builder": "bolt", "flank_size": 0.05, "contact_size": 0.1, "mesh_size": 0.5}


@pytest.mark.parametrize("options", [
    {"builder": "block2d", "mesh_size": 4.0, "n_zones": 3},
    {"builder": "block", "mesh_size": 5.0, "block_divisions": 2},
    {"builder": "bolt", "size": "M8", "flank_size": 0.3},
], ids=["block2d", "block", "bolt"])
def test_the_refined_model_has_the_coarse_ones_zones_and_stages_and_more_nodes(options):
    coarse, fine = build_model(ModelSpec.from_table(options)), build_model(refined(ModelSpec.from_table(options)))
    assert fine.zone_names == coarse.zone_names
    assert fine.stages == coarse.stages
    assert fine.mesh.n_nodes > 2 * coarse.mesh.n_nodes


@pytest.mark.parametrize("options, factor, key", [
    ({"builder": "mesh", "file": "part.msh"}, 3, "power of 2"),
    ({"builder": "mesh", "file": "part.msh", "refine": -1}, 2, "refine = -1"),
    ({"mesh_size": 1.0}, 2, "builder = None"),
    ({"builder": "block", "mesh_size": "fine"}, 2, "mesh_size"),
    ({"builder": "block"}, 1, "factor"),
    ({"builder": "block"}, 1.5, "factor"),
])
def test_what_cannot_be_refined_is_refused_naming_the_key(options, factor, key):
    with pytest.raises(InputError, match="refine") as info:
        refined(ModelSpec.from_table(options), factor)
    assert key in str(info.value)


# ------------------------------------------------------------------------------------------ the estimate


def test_richardson_recovers_the_error_of_a_sequence_with_known_order():
    for p, factor in ((1, 2), (2, 2), (3, 4), (0.5, 2)):
        coarse, fine = 7.0 + 0.3, 7.0 + 0.3 / factor ** p          # f(h) = 7 + 0.3 (h / h0)^p at h0 and h0 / factor
        assert richardson(np.array([coarse]), np.array([fine]), p, factor)[0] == pytest.approx(0.3, rel=1e-12)


def test_orders_are_capped_by_the_contact_edge_singularity():
    assert convergence_orders(1) == convergence_orders(2) == {"u": 1, "force": 1, "e": STRAIN_ORDER}
    assert convergence_orders(1, singular=False) == {"u": 2, "force": 2, "e": 1}
    assert convergence_orders(2, singular=False) == {"u": 3, "force": 3, "e": 2}


#: the plane-strain block at a pull of 0.1 mm (the 0.5 mm mesh refuses 0.2 mm as finite sliding)
BLOCK2D = {"builder": "block2d", "mesh_size": 4.0, "order": 2, "pull": 0.1}
FACE = [(side * 5.0, y) for side in (-1, 1) for y in (0.5, 1.0, 2.0, 3.0, 5.0, 7.0)]
TOP = [(x, 0.0) for x in (-16.0, -12.0, -9.0, -7.0, -6.0, 6.0, 7.0, 9.0, 12.0, 16.0)]
QUANTITIES = ("ux", "uy", "exx", "eyy", "exy")
SIGMA = {"u": 0.0005, "e": 2e-5, "force": 0.1}
MU = [np.array([0.2, 0.2]), np.array([0.3, 0.15])]


def block2d_observations() -> Observations:
    """ux uy and strains at the faces and the base top, and the machine force, at the end of the pull (stage 2)."""
    n_rows = len(FACE + TOP) * len(QUANTITIES) + 1
    obs = Observations(points=np.array(FACE + TOP), point_regions=("block",) * len(FACE) + ("base",) * len(TOP),
                       quantities=QUANTITIES, row=np.arange(n_rows), stage=np.ones(n_rows, int), y=np.zeros(n_rows),
                       sigma=np.ones(n_rows), labels=tuple(f"row{r}" for r in range(n_rows)), noise_known=True,
                       reactions=("block_top.x",))
    return dataclasses.replace(obs, sigma=np.array([SIGMA[k] for k in observation_kinds(obs)]))


@pytest.fixture(scope="module")
def block2d():
    obs = block2d_observations()
    return obs, estimate_model_error(ModelSpec.from_table(BLOCK2D), obs, MU)


def test_estimate_is_within_a_factor_2_of_the_difference_to_a_much_finer_mesh(block2d):
    obs, error = block2d
    finest = build_model(ModelSpec.from_table({**BLOCK2D, "mesh_size": 0.5}))        # h / 8
    backend = EmbeddedBackend(finest, obs.points, obs.quantities, obs.point_regions, obs.reactions, keep=False)
    coarse = EmbeddedBackend(build_model(ModelSpec.from_table(BLOCK2D)), obs.points, obs.quantities, obs.point_regions,
                             obs.reactions)
    actual = np.max([np.abs(obs.predicted(coarse.predict(mu).values) - obs.predicted(backend.predict(mu).values))
                     for mu in MU], axis=0)
    for kind in ("u", "e", "force"):
        group = error.kinds == kind
        ratio = np.sqrt(np.mean(error.estimate[group] ** 2) / np.mean(actual[group] ** 2))
        assert 0.5 < ratio < 2.0, (kind, ratio)       # measured 1.16 (u), 1.32 (e), 1.04 (force)
    assert error.summary["kind u"]["rms"] > 1.0       # the coarse mesh is worse than the noise: it must show


def test_estimate_keeps_the_largest_error_over_the_coefficient_sets(block2d):
    obs, error = block2d
    each = [estimate_model_error(ModelSpec.from_table(BLOCK2D), obs, [mu]).estimate for mu in MU]
    np.testing.assert_allclose(error.estimate, np.maximum(*each), rtol=1e-12)
    assert np.any(each[0] != each[1])


def test_given_coarse_values_give_the_same_estimate(block2d):
    obs, error = block2d
    backend = EmbeddedBackend(build_model(ModelSpec.from_table(BLOCK2D)), obs.points, obs.quantities, obs.point_regions,
                              obs.reactions)
    given = estimate_model_error(ModelSpec.from_table(BLOCK2D), obs, MU,
                                 coarse_values=[obs.predicted(backend.predict(mu).values)
                                                                   for mu in MU])
    np.testing.assert_allclose(given.estimate, error.estimate, rtol=1e-12)


def test_the_refined_condensation_is_not_kept_and_pushes_no_kept_one_out():
    obs = block2d_observations()
    EmbeddedBackend(build_model(ModelSpec.from_table({**BLOCK2D, "mesh_size": 6.0})), obs.points, obs.quantities,
                    obs.point_regions)
    kept = list(embedded._RECENT)
    estimate_model_error(ModelSpec.from_table({**BLOCK2D, "mesh_size": 5.0}), obs, MU[:1],
                         coarse_values=[np.zeros(obs.n_obs)])
    assert list(embedded._RECENT) == kept


def test_summaries_in_noise_and_json(block2d):
    obs, error = block2d
    np.testing.assert_allclose(error.in_noise, error.estimate / obs.sigma)
    u = error.kinds == "u"
    assert error.summary["kind u"] == pytest.approx({"n": u.sum(), "rms": np.sqrt(np.mean(error.in_noise[u] ** 2)),
                                                    "max": error.in_noise[u].max()})
    assert set(error.summary) == {"all", "kind u", "kind e", "kind force", "stage 2"}
    assert error.orders == {"u": 1, "force": 1, "e": STRAIN_ORDER}
    data = json.loads(json.dumps(error.as_dict()))
    assert data["refined_options"]["mesh_size"] == 2.0 and len(data["in_noise"]) == obs.n_obs


def test_inflated_sigma_adds_the_error_as_variance(block2d):
    obs, error = block2d
    np.testing.assert_allclose(inflated_sigma(obs, error) ** 2, obs.sigma ** 2 + error.estimate ** 2, rtol=1e-12)
    three = ModelError(estimate=np.array([0.0, 3e-4, 1.2e-3]), in_noise=np.zeros(3), kinds=np.array(["u"] * 3),
                       stages=np.ones(3, int), orders={"u": 1}, factor=2, refined_options={}, n_points=1,
                       seconds=0.0)
    obs3 = dataclasses.replace(obs, sigma=np.full(3, 5e-4), y=np.zeros(3), row=np.arange(3), stage=np.ones(3, int))
    np.testing.assert_allclose(inflated_sigma(obs3, three), [5e-4, 5.830951894845301e-4, 1.3e-3], rtol=1e-12)
    with pytest.raises(InputError, match="3 estimates"):
        inflated_sigma(obs, three)


# ------------------------------------------------------------------------------------------ bad input


def test_an_unrefinable_builder_is_refused_before_anything_is_built():
    with pytest.raises(InputError, match="builder = None: the model cannot be refined"):
        estimate_model_error(ModelSpec.from_table({"mesh_size": 1.0}), block2d_observations(), MU)


def test_a_refined_model_with_other_zones_is_refused(monkeypatch):
    monkeypatch.setattr(model_error, "refined", lambda options, factor: options.with_options(n_zones=3))
    with pytest.raises(InputError, match=r"zones \['A', 'B', 'C'\].*differ"):
        estimate_model_error(ModelSpec.from_table({**BLOCK2D, "mesh_size": 5.0}), block2d_observations(), MU)


@pytest.mark.parametrize("mu_points, coarse_values, message", [
    ([], None, "mu_points"),
    ([np.zeros(3)], None, "mu_points"),
    ([np.zeros(2)], [np.zeros(5)], "coarse_values"),
    ([np.zeros(2)], [], "coarse_values"),
])
def test_bad_coefficients_or_coarse_values_are_refused(mu_points, coarse_values, message):
    with pytest.raises(InputError, match=message):
        estimate_model_error(ModelSpec.from_table({**BLOCK2D, "mesh_size": 5.0}), block2d_observations(), mu_points,
                             coarse_values)


@pytest.mark.parametrize("orders", [{"u": 0}, {"e": -1.0}, {"force": "2"}])
def test_bad_orders_are_refused_naming_the_kind(orders):
    with pytest.raises(InputError, match=f"`orders` '{next(iter(orders))}' must be a positive number"):
        estimate_model_error(ModelSpec.from_table({**BLOCK2D, "mesh_size": 5.0}), block2d_observations(), MU,
                             orders=orders)


def test_the_strain_factor_is_within_sqrt2_of_the_richardson_factor_of_every_order_from_1():
    factor = 2.0 ** STRAIN_ORDER / (2.0 ** STRAIN_ORDER - 1.0)
    assert factor == pytest.approx(np.sqrt(2.0), rel=1e-14)
    for p in (1.0, 1.5, 2.6, 40.0):                            # the true factor 2^p / (2^p - 1) lies in (1, 2]
        true = 2.0 ** p / (2.0 ** p - 1.0)
        assert 1 / np.sqrt(2.0) - 1e-12 <= factor / true <= np.sqrt(2.0) + 1e-12


def test_given_orders_replace_the_defaults(block2d):
    obs, error = block2d
    twice = estimate_model_error(ModelSpec.from_table(BLOCK2D), obs, MU, orders={"u": 2})
    u = error.kinds == "u"
    np.testing.assert_allclose(twice.estimate[u], error.estimate[u] * (4 / 3) / 2, rtol=1e-12)
    np.testing.assert_array_equal(twice.estimate[~u], error.estimate[~u])
    assert twice.orders == {"u": 2, "e": STRAIN_ORDER, "force": 1}
