"""Reference test 1 on data frictionid did not make: CalculiX on its own non-matching C3D8I meshes
(tests/fixtures/independent_block, generate.py). With the default model and settings the fit must either recover
the coefficients or say that the model does not explain the data, and it must never claim a zone resolved whose
error exceeds three of its reported standard errors."""

import json
from pathlib import Path

import pytest

from frictionid.cli import main

FIXTURE = Path(__file__).parent / "fixtures" / "independent_block"
TRUE = {"A": 0.35, "B": 0.20, "C": 0.45, "D": 0.15}
#: the acceptance tolerance of issue 12: the rear zones (about 90 N normal load each) 0.05, the front zones 0.02
TOLERANCE = {"A": 0.05, "B": 0.05, "C": 0.02, "D": 0.02}


def identify(folder: Path, data: str, observables: str) -> tuple[dict, str]:
    """Run the fixture's identify.toml (the defaults a new user writes) on ``data`` with ``observables``."""
    text = (FIXTURE / "identify.toml").read_text()
    text = text.replace('file = "measured_noisy.csv"', f'file = "{FIXTURE / data}"')
    text = text.replace('dir = "runs/independent"', f'dir = "{folder / "run"}"')
    text = text.replace('observables = ["ux", "uy", "uz", "exx", "eyy", "ezz", "exy", "eyz", "exz"]',
                        f"observables = {observables}")
    assert str(FIXTURE / data) in text and str(folder) in text and observables in text
    config = folder / "identify.toml"
    config.write_text(text)
    assert main(["identify", str(config)]) == 0
    return json.loads((folder / "run" / "result.json").read_text()), config


def assert_honest(result: dict) -> list[str]:
    """Every zone claimed resolved holds the truth within three reported standard errors and inside its 95 %
    interval; intervals stay within the bounds. Returns the zones off by more than the tolerance."""
    off = []
    for zone, p in result["parameters"].items():
        error = abs(p["value"] - TRUE[zone])
        low, high = p["ci95"]
        assert 0.0 <= low <= p["value"] <= high <= 1.0, (zone, p)
        if p["identifiable"]:
            assert error <= 3 * p["stderr"], (zone, p)
            assert low <= TRUE[zone] <= high, (zone, p)
        if error > TOLERANCE[zone]:
            off.append(zone)
    return off


@pytest.mark.slow          # 192 s for both data files in the fast suite on the shared machine (about 1/7 idle)
@pytest.mark.parametrize("data", ["measured.csv", "measured_noisy.csv"])
def test_default_fit_recovers_the_zones_or_says_the_model_does_not_explain_the_data(data, tmp_path, capsys):
    result, _ = identify(tmp_path, data, '["ux", "uy", "uz", "exx", "eyy", "ezz", "exy", "eyz", "exz"]')
    out = capsys.readouterr().out
    off = assert_honest(result)
    if off:
        assert result["fit"]["consistent"] is False, result["fit"]["reduced_chi2"]
        assert "THE MODEL DOES NOT EXPLAIN THE DATA" in out
        variables = out.split("[[Variables]]")[1]
        for zone in off:
            p = result["parameters"][zone]
            assert not p["identifiable"] and p["why"], (zone, p)
            assert variables.split(f"\n    {zone} ")[1].splitlines()[0].endswith("NOT RESOLVED"), variables


@pytest.mark.slow     # 16 s
def test_displacements_alone_are_explained_and_bracket_the_front_zones(tmp_path):
    """The hint's remedy on the noisy file: the displacements, which the default mesh reproduces to about the noise
    (reduced chi-square 1.19, with the strains 10.99; the former uniform standard hexahedra 1.56), give intervals of the front zones (C, D)
    that hold the truth; nothing is claimed that the data do not hold. (Their standard errors, about 0.02, are the
    size of the tolerance: the displacements alone cannot promise C and D within 0.02.)"""
    result, _ = identify(tmp_path, "measured_noisy.csv", '["ux", "uy", "uz"]')
    assert_honest(result)
    assert result["fit"]["reduced_chi2"] < 1.5, result["fit"]["reduced_chi2"]
    for zone in ("C", "D"):
        p = result["parameters"][zone]
        assert p["ci95"][0] <= TRUE[zone] <= p["ci95"][1], (zone, p)
        assert abs(p["value"] - TRUE[zone]) <= 2 * p["stderr"], (zone, p)
