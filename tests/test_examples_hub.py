"""examples/hub end to end: twin data on hub_fine.geo at Z1 0.12, Z2 0.18, Z3 0.25, identified on hub.geo."""

import json
import shutil
from pathlib import Path

import pytest

from frictionid.builders import verification as bm
from frictionid.cli import main

ROOT = Path(__file__).parents[1]
TRUTH = {"Z1": 0.12, "Z2": 0.18, "Z3": 0.25}        # examples/hub/truth.toml [friction]


@pytest.fixture(scope="module")
def hub(tmp_path_factory):
    """A copy of examples/hub (without runs or data) after `frictionid simulate` and `frictionid identify`."""
    folder = tmp_path_factory.mktemp("hub") / "hub"
    shutil.copytree(ROOT / "examples" / "hub", folder,
                    ignore=shutil.ignore_patterns("runs", "measured.*", "__pycache__"))
    assert main(["simulate", str(folder / "truth.toml"), "--out", str(folder / "measured.csv")]) == 0
    assert main(["identify", str(folder / "identify.toml")]) == 0
    return folder


def _result(folder: Path) -> dict:
    return json.loads((folder / "runs" / "hub" / "result.json").read_text())


@pytest.mark.slow          # 55 s in the fast suite on the shared machine (about 1/7 idle)
def test_every_zone_is_within_its_interval_and_the_fit_is_consistent(hub):
    result = _result(hub)
    assert result["fit"]["consistent"] is True
    for zone, truth in TRUTH.items():
        low, high = result["parameters"][zone]["ci95"]
        assert low <= truth <= high, f"{zone}: truth {truth} outside [{low:.4f}, {high:.4f}]"


def test_the_zone_next_to_the_free_end_is_resolved_and_the_other_two_trade_off(hub):
    """README: Z1 resolved (standard error 0.0076 measured), Z2 and Z3 correlated at r = -1.00."""
    parameters = _result(hub)["parameters"]
    assert parameters["Z1"]["identifiable"] is True
    assert parameters["Z1"]["value"] == pytest.approx(TRUTH["Z1"], abs=0.01)
    assert not parameters["Z2"]["identifiable"] and not parameters["Z3"]["identifiable"]


def test_push_out_force_is_near_the_lame_coulomb_estimate(hub):
    """Lame (plane strain, a 10, b 20, delta 0.01, steel): p_c 86.54 MPa, F = sum mu_i p_c 2 pi a L_i = 29,906 N;
    the 30 mm hub's force measured 28,341 N, 5.2 % below (its mean contact pressure 84.1 MPa, edge effects)."""
    lines = [line for line in (hub / "measured.csv").read_text().splitlines() if not line.startswith("#")]
    header = lines[0].split(",")
    last = [dict(zip(header, line.split(","))) for line in lines[1:] if line.split(",")[4] == "3"][0]
    force = abs(float(last["force"]))
    p_c = bm.lame_reference(10.0, 20.0, 0.01, 210000.0, 0.3)["p_c"]
    lame = bm.pushout_force(list(TRUTH.values()), p_c, 10.0, [10.0, 10.0, 10.0])
    assert force == pytest.approx(28341.0, rel=1e-3)
    assert force / lame == pytest.approx(0.948, abs=0.01)
