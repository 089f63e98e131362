"""Calibration of the include mode's intervals over a population of references whose model errors differ.

A systematic error is the same in every noise replicate of one reference, so the coverage over one reference's
replicates is all or none per zone when an interval is mostly systematic (the dense reference's 107 of 107). A
population of plane-strain references (population_case.py: truth, loads, fitted and data meshes, points, quantities
drawn per reference) measures it instead, each reference's data mesh the one its convergence check chose (0.25 noise
levels RMS per quantity, or the reference redrawn; CHOSEN below; population_case.reference: data of an unconverged
mesh share the fitted mesh's error and hide part of it; docs/fit-quality.md, "A reference's own discretisation
error"). This test fits a smaller population of its own seed (20 of its 30 references redrawn): its 36 claimed
intervals all hold the truth (the median claim 0.31 standard errors off, the largest 1.86), and the statistical part
alone holds 33 of them (91.7 %). With the references as drawn, unchecked, 43 of 46 held (93.5 %), one 4.5 standard
errors off: seed 3 reference 6, whose quadratic 0.375 mm data differed from the same mesh's at 0.094 mm by 0.73
noise levels RMS in uy.
"""

import numpy as np
import pytest

from population_case import clean_data, identify_case, noisy, reference

pytestmark = pytest.mark.slow           # 60 identifications

SEED, N_REFERENCES, N_REPLICATES = 3, 30, 2
#: {reference: (attempt, data mesh size [mm])} the convergence check chose (population_case.reference; 9 min of CPU,
#: so not made again here; tests/test_population_case.py tests the rule). Remade by
#: ``PYTHONPATH=src:tests python tests/population_case.py 3 30``; the references' noise-free data on those meshes
#: (163 s of CPU) are stored too (tests/fixtures/population, remade by its generate.py) and checked against
#: ``frictionid simulate`` on two of them (:func:`test_stored_references_are_what_simulate_writes`)
CHOSEN = {0: (3, 0.125), 1: (2, 0.16666666666666666), 2: (2, 0.125), 3: (1, 0.08333333333333333),
          4: (4, 0.16666666666666666), 5: (1, 0.0625), 6: (0, 0.09375), 7: (3, 0.08333333333333333), 8: (0, 0.0625),
          9: (0, 0.125), 10: (1, 0.25), 11: (1, 0.125), 12: (1, 0.1875), 13: (0, 0.125), 14: (1, 0.0625),
          15: (6, 0.125), 16: (3, 0.125), 17: (0, 0.08333333333333333), 18: (0, 0.08333333333333333),
          19: (5, 0.16666666666666666), 20: (0, 0.125), 21: (11, 0.08333333333333333), 22: (0, 0.125),
          23: (1, 0.16666666666666666), 24: (0, 0.0625), 25: (2, 0.046875), 26: (1, 0.16666666666666666),
          27: (2, 0.125), 28: (0, 0.125), 29: (5, 0.125)}


@pytest.fixture(scope="module")
def claims():
    """(reference, |error|, stderr, systematic part, interval holds the truth) of every claimed zone."""
    rows = []
    for index in range(N_REFERENCES):
        case, clean = reference(index, SEED, None, chosen=CHOSEN[index], stored=True)
        for replicate in range(1, N_REPLICATES + 1):
            result = identify_case(case, noisy(clean, case, replicate, SEED))
            for zone, truth in zip("ABC", case["truth"]):
                p = result["parameters"][zone]
                if p["identifiable"]:
                    low, high = p["ci95"]
                    rows.append((index, abs(p["value"] - truth), p["stderr"], p["stderr_systematic"],
                                 low <= truth <= high))
    return rows


def test_claimed_intervals_hold_the_truth_over_a_population_of_references(claims):
    """At least 90 % of the claimed 95 % intervals hold the truth, from several references (not one reference's
    all-or-none); without the systematic part fewer would; and the intervals are not so wide that a claim says
    little (the median claim is more than 0.15 standard errors from its truth: 0.30-0.35 over the benchmark's
    populations)."""
    reference, error, stderr, systematic, inside = (np.array(column) for column in zip(*claims))
    assert len(claims) >= 20 and len(set(reference.tolist())) >= 8            # not vacuous
    assert inside.mean() >= 0.90, (inside.sum(), len(inside))
    statistical = np.sqrt(np.maximum(stderr ** 2 - systematic ** 2, 0.0))
    assert np.mean(error <= 1.959964 * statistical) < inside.mean()
    assert np.median(error / stderr) > 0.15


#: references whose data mesh is among the cheapest to solve (about 3 and 5 s of CPU), one of each element order
CHECKED = (1, 3)


@pytest.mark.parametrize("index", CHECKED)
def test_stored_references_are_what_simulate_writes(tmp_path, index):
    """The stored data are the data mesh's solution as ``frictionid simulate`` makes it now (to 1e-9 of each
    quantity's largest value: the factorisation's threads may change the last bits): a change of the solver or
    the builder that moves them shows here, and the store is remade (tests/fixtures/population/generate.py)."""
    case, stored = reference(index, SEED, None, chosen=CHOSEN[index], stored=True)
    fresh = clean_data(case, tmp_path)
    assert fresh.points == stored.points and np.array_equal(fresh.stage, stored.stage)
    np.testing.assert_array_equal(fresh.coordinates, stored.coordinates)
    np.testing.assert_allclose(fresh.force, stored.force, rtol=0, atol=1e-9 * np.abs(fresh.force).max())
    assert set(fresh.values) == set(stored.values) == {q for q in case["quantities"] if q != "force"}
    for quantity, values in fresh.values.items():
        np.testing.assert_allclose(values, stored.values[quantity], rtol=0, atol=1e-9 * np.abs(values).max())
