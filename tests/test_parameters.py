"""Parameters: start values, bounds and held zones in the model's order; every mistake an InputError naming it."""

import numpy as np
import pytest

from frictionid.errors import InputError
from frictionid.inverse.parameters import DEFAULT_BOUNDS, Parameter, Parameters


def test_free_and_held_zones_map_to_the_optimiser_vector_and_back():
    params = Parameters.from_config(("A", "nut", "B"), {"B": 0.2, "A": 0.1}, bounds={"A": [0.0, 0.6], "*": [0.05, 0.9]},
                                    fixed={"nut": 0.15})
    assert params.names == ("A", "nut", "B") and params.free_names == ("A", "B")
    assert params.free.tolist() == [True, False, True]
    assert params.x0.tolist() == [0.1, 0.2]
    assert params.lower.tolist() == [0.0, 0.05] and params.upper.tolist() == [0.6, 0.9]
    np.testing.assert_array_equal(params.full(np.array([0.3, 0.4])), [0.3, 0.15, 0.4])


def test_default_bounds_apply_to_zones_not_named():
    params = Parameters.from_dict({"A": 0.1, "B": 0.2}, bounds={"A": (0.0, 0.5)})
    assert (params.items[1].min, params.items[1].max) == DEFAULT_BOUNDS
    assert (params.items[0].min, params.items[0].max) == (0.0, 0.5)


@pytest.mark.parametrize("zones, bounds, fixed, words", [
    ({"A": 1.2}, DEFAULT_BOUNDS, None, ["zones.A = 1.2", "outside bounds [0.0, 1.0]"]),
    ({"A": 0.1}, DEFAULT_BOUNDS, {"A": 0.2}, ["['A']", "both in 'zones' and in 'fixed'"]),
    ({"A": 0.1}, DEFAULT_BOUNDS, {"B": -0.1}, ["fixed.B = -0.1", "cannot be negative"]),
    ({}, DEFAULT_BOUNDS, {"B": 0.1}, ["every zone is fixed"]),
    ({"A": "x"}, DEFAULT_BOUNDS, None, ["zones.A"]),
], ids=["outside bounds", "free and held", "negative held", "all held", "not a number"])
def test_bad_parameters_name_the_key(zones, bounds, fixed, words):
    with pytest.raises(InputError) as error:
        Parameters.from_dict(zones, bounds, fixed, where="[friction]")
    assert all(word in str(error.value) for word in words), str(error.value)


def test_zones_must_match_the_model():
    with pytest.raises(InputError, match=r"unknown zone\(s\) \['C'\]; the model's zones are \['A', 'B'\]"):
        Parameters.from_config(("A", "B"), {"A": 0.1, "B": 0.1, "C": 0.1})
    with pytest.raises(InputError, match=r"no start value for zone\(s\) \['B'\]"):
        Parameters.from_config(("A", "B"), {"A": 0.1})


def test_a_zone_given_twice_or_a_start_outside_its_own_bounds_is_refused():
    with pytest.raises(InputError, match=r"zone\(s\) \['A'\] given more than once"):
        Parameters([Parameter("A", 0.1), Parameter("A", 0.2)])
    with pytest.raises(InputError, match="'A'"):
        Parameter("A", 0.7, max=0.6)


def test_ordering_keeps_each_parameter_unchanged():
    params = Parameters([Parameter("B", 0.2, max=0.5), Parameter("A", 0.1, vary=False)])
    ordered = params.ordered_as(("A", "B"))
    assert ordered.names == ("A", "B") and ordered.items[1] == params.items[0] and ordered.items[0] == params.items[1]
