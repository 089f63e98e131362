"""The population's references are converged (tests/population_case.py): a reference's data mesh is halved until its
data differ from its halving's by at most REFERENCE_ERROR noise levels RMS, the finer kept, and a draw that cannot get
there above FINEST_SPACING is redrawn. Checked with the FE solves replaced by data whose discretisation error is
c h^p by construction, so that the sizes the rule must keep are known (worked out in each case's comment)."""

import numpy as np
import pytest

import population_case
from frictionid.data.table import Measurements


def synthetic(c: float, p: float):
    """clean_data's stand-in: uy = 1e-3 + c h^p [mm] at two points (with u_noise 1e-3: c h^p / 1e-3 noise levels)."""
    def clean(case, folder):
        h = case["data"]["mesh_size"]
        return Measurements(points=("P1", "P2"), coordinates=np.zeros((2, 3)), stage=np.array([2, 2]),
                            force=np.array([100.0, 100.0]), values={"uy": np.full(2, 1e-3 + c * h ** p)})
    return clean


def case(size: float) -> dict:
    return {"quantities": ["uy"], "stages": [2], "u_noise": 1e-3, "data": {"order": 1, "mesh_size": size}}


# differences between h and h / 2: 1e3 c h^p (1 - 2^-p) noise levels; FINEST_SPACING 0.05 below
@pytest.mark.parametrize("c, p, drawn, kept", [
    (1e-3, 2, 0.4, 0.2),     # 0.4 / 0.2: 0.12
    (1e-2, 2, 0.4, 0.05),    # 1.2; 0.3; 0.075
    (2e-3, 1, 0.4, 0.1),     # 0.4; 0.2
    (1e-3, 2, 0.08, 0.08),   # 0.04 is too fine: the drawn mesh checked against 0.16 (0.019) and kept
    (1e-2, 1, 0.4, None),    # 2.0; 1.0; 0.5 at the finest pair: refused
    (1e-1, 1, 0.4, None),    # 20: refused at once (20 / 4^2 is still above 0.25)
])
def test_a_reference_keeps_the_first_halving_within_the_tolerance(monkeypatch, c, p, drawn, kept):
    monkeypatch.setattr(population_case, "clean_data", synthetic(c, p))
    monkeypatch.setattr(population_case, "FINEST_SPACING", 0.05)
    found = population_case.converged(case(drawn), None)
    if kept is None:
        assert found is None
        return
    checked, data = found
    assert checked["data"]["mesh_size"] == pytest.approx(kept)
    assert data.values["uy"][0] == pytest.approx(1e-3 + c * kept ** p)
    rms = [r["rms"]["uy"] for r in checked["data_check"]]
    assert rms[-1] <= population_case.REFERENCE_ERROR and all(r > population_case.REFERENCE_ERROR for r in rms[:-1])
    assert rms[-1] == pytest.approx(1e3 * c * (2 * kept) ** p * (1 - 2.0 ** -p))


def test_a_reference_that_does_not_converge_is_redrawn_reproducibly(monkeypatch):
    """Attempt 0 is the draw of (seed, index) itself; a refused draw is followed by the next attempt's."""
    monkeypatch.setattr(population_case, "converged", lambda drawn, folder: None if drawn["attempt"] < 2 else
                        (drawn, None))
    found, _ = population_case.reference(5, 3, None)
    assert found == population_case.draw(5, 3, 2) and found["attempt"] == 2
    assert population_case.draw(5, 3, 0) == population_case.draw(5, 3)
    assert population_case.draw(5, 3, 1)["truth"] != population_case.draw(5, 3)["truth"]
    monkeypatch.setattr(population_case, "converged", lambda drawn, folder: None)
    with pytest.raises(RuntimeError, match="reference 5 of seed 3"):
        population_case.reference(5, 3, None)
