"""Calibration of the include mode's intervals over a population of references whose model errors differ.

A systematic error is the same in every noise replicate of one reference, so the coverage over one reference's
replicates is all or none per zone when an interval is mostly systematic (the dense reference's 107 of 107). A
population of plane-strain references (population_case.py: truth, loads, fitted and data meshes, points,
quantities drawn per reference) measures it instead, each reference's data mesh checked to be converged to 0.25
noise levels RMS per quantity or the reference redrawn (population_case.reference: data of an unconverged mesh
share the fitted mesh's error and hide part of it; docs/fit-quality.md, "A reference's own discretisation
error"). This test fits a smaller population of its own seed (20 of its 30 references redrawn): its 36 claimed
intervals all hold the truth (the median claim 0.31 standard errors off, the largest 1.86), and the statistical
part alone holds 33 of them (91.7 %). With the references as drawn, unchecked, 43 of 46 held (93.5 %), one 4.5
standard errors off: seed 3 reference 6, whose quadratic 0.375 mm data differed from the same mesh's at 0.094 mm
by 0.73 noise levels RMS in uy.
"""

import numpy as np
import pytest

from population_case import identify_case, noisy, reference

pytestmark = pytest.mark.slow           # the references' checks and 60 identifications: 9.3 min user CPU

SEED, N_REFERENCES, N_REPLICATES = 3, 30, 2


@pytest.fixture(scope="module")
def claims(tmp_path_factory):
    """(reference, |error|, stderr, systematic part, interval holds the truth) of every claimed zone."""
    rows = []
    for index in range(N_REFERENCES):
        case, clean = reference(index, SEED, tmp_path_factory.mktemp(f"reference{index}"))
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
