"""identify.profile: profile-likelihood intervals by refits with one zone held, through the command line."""

import json

import numpy as np
import pytest

from block2d_case import points_csv
from frictionid.cli import main
from helpers import write_config
from frictionid.inverse.profile import CHI2_95, CHI2_BOUND_95, bound_verdict, grid, interval

POINTS = points_csv(stage=2, quantities=("ux", "uy"))
REGIONS = {"P[1-4]": "block", "P[56]": "base"}


def _config(folder, name, zones: str, data: str, identify: str = "") -> str:
    return str(write_config(folder / f"{name}.toml", f'[run]\ndir = "runs/{name}"\n',
                            model={"builder": "block2d", "mesh_size": 2.0, "order": 1},
                            friction=f"zones = {{ {zones} }}\n",
                            data={"file": data, "observables": ["ux", "uy", "force"], "stages": [2],
                                  "noise": {"u": 0.0005, "force": 0.5}, "regions": REGIONS},
                            identify=identify))


def _measured(folder, name: str, truth: str, seed: int) -> str:
    """Data simulated at ``truth`` with 0.5 um and 0.5 N/mm of seeded noise."""
    assert main(["simulate", _config(folder, f"{name}_truth", truth, "points.csv"),
                 "--out", str(folder / f"{name}_exact.csv")]) == 0
    lines = (folder / f"{name}_exact.csv").read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("point,"))
    names = lines[header].split(",")
    rng = np.random.default_rng(seed)
    force_noise = rng.normal(0.0, 0.5)                        # one machine force per stage (all in stage 2)
    out = lines[:header + 1]
    for line in lines[header + 1:]:
        cells = line.split(",")
        for q in ("ux", "uy"):
            cells[names.index(q)] = repr(float(cells[names.index(q)]) + rng.normal(0.0, 0.0005))
        cells[names.index("force")] = repr(float(cells[names.index("force")]) + force_noise)
        out.append(",".join(cells))
    (folder / f"{name}.csv").write_text("\n".join(out) + "\n")
    return f"{name}.csv"


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("profile")
    (folder / "points.csv").write_text(POINTS)
    return folder


def _profiled(folder, data: str, name: str) -> dict:
    assert main(["identify", _config(folder, name, "A = 0.2, B = 0.2", data,
                                     "profile = true\nprofile_points = 9\n")]) == 0
    return json.loads((folder / f"runs/{name}/result.json").read_text())


@pytest.mark.slow                                               # two identifications with 20 refits: 10 s
def test_inside_the_bounds_the_profile_interval_is_close_to_the_linear_one(folder, capsys):
    result = _profiled(folder, _measured(folder, "inside", "A = 0.3, B = 0.15", seed=5), "inside")
    assert "[[Profiles]]" in capsys.readouterr().out and set(result["profiles"]) == {"A", "B"}
    for zone in "AB":
        p, prof = result["parameters"][zone], result["profiles"][zone]
        low, high = prof["interval"]
        assert low < p["value"] < high and prof["open"] == [False, False]
        assert (high - low) / 2 == pytest.approx(np.sqrt(CHI2_95) * p["stderr"], rel=0.25)
        # the held fitted value refits to the fit itself: the profile's minimum is the fit's chi-square
        assert min(c for c in prof["chi2"] if c is not None) == pytest.approx(result["fit"]["chi2"], rel=1e-6)
        # the held zone really is held: the other zone is refitted along the profile
        other = next(iter(prof["others"].values()))
        assert max(other) - min(other) > 0.01


@pytest.mark.slow
def test_a_zone_on_its_bound_gets_a_one_sided_profile_and_bends_its_partners(folder):
    result = _profiled(folder, _measured(folder, "bound", "A = 0.3, B = 0.0", seed=5), "bound")
    a, prof = result["parameters"]["A"], result["profiles"]
    # B (true 0) ends on its bound: its interval starts there
    assert prof["B"]["interval"][0] == 0.0 and prof["B"]["open"][0] is False
    assert prof["B"]["interval"][1] > result["parameters"]["B"]["value"]
    # above its fit A cannot be offset by B < 0, so its profile rises faster there than below: the interval
    # is asymmetric, shorter above the fitted value, unlike the symmetric linear one
    low, high = prof["A"]["interval"]
    assert low < a["value"] < high and high - a["value"] < 0.5 * (a["value"] - low)


def test_grid_and_interval_helpers():
    assert grid(0.5, None, 0.0, 1.0, 3).tolist() == [0.0, 0.5, 1.0]
    values = np.linspace(0.0, 1.0, 21)
    one_sided = interval(values, (values / 0.1) ** 2, CHI2_95, 0.0, 1.0)   # minimum on the lower bound
    assert one_sided["interval"][0] == 0.0 and one_sided["interval"][1] == pytest.approx(0.196, abs=0.01)
    flat = interval(values, np.zeros(21), CHI2_95, 0.0, 2.0)           # the data do not see it: open above
    assert flat["open"] == [False, True]


@pytest.mark.parametrize("identify, message", [('profile = ["C"]\n', "identify.profile: ['C'] are not free"),
                                               ("profile = true\nprofile_points = 2\n", "profile_points"),
                                               ('profile = "A"\n', "identify.profile must be")])
def test_bad_profile_keys_exit_2(folder, capsys, identify, message):
    assert main(["identify", _config(folder, "bad", "A = 0.2, B = 0.2", "points.csv", identify)]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.slow                                               # identification and 7 refits: 25 s
def test_a_zone_claimed_on_its_bound_carries_its_profile_check(folder, capsys):
    """B's true value is 0 and the fit is consistent: B is claimed on its bound only with the profile's proof,
    stored in result.json: chi-square refitted at held values from the bound, the one-sided 95 % level with the
    misfit's scale, and the interval it gives."""
    data = _measured(folder, "claim", "A = 0.3, B = 0.0", seed=5)
    assert main(["identify", _config(folder, "claim", "A = 0.2, B = 0.2", data, "profile_points = 7\nresolution = 0.05\n")]) == 0
    out = capsys.readouterr().out
    result = json.loads((folder / "runs/claim/result.json").read_text())
    b = result["parameters"]["B"]
    assert result["fit"]["consistent"] is True and b["at_bound"] and b["value"] == pytest.approx(0.0, abs=1e-6)
    check = b["bound_check"]
    assert b["identifiable"] and check["passed"] and check["level"] == 0.95
    assert check["threshold"] == pytest.approx(CHI2_BOUND_95 * result["fit"]["error_scale"] ** 2)
    assert check["values"][0] == 0.0 and len(check["values"]) == 7
    # the bound's refit is the fit itself; chi-square rises into the interior past the threshold
    assert check["chi2"][0] == pytest.approx(result["fit"]["chi2"], rel=1e-6)
    assert max(check["chi2"]) - check["chi2"][0] > check["threshold"]
    assert b["ci95"] == check["interval"] and 0.0 == b["ci95"][0] < b["ci95"][1] <= 1.645 * 0.05
    assert "bound check of B" in out and "on its bound: the profile excludes values beyond" in out
    assert "bound_check" not in result["parameters"]["A"]


def test_the_bound_verdict_refuses_a_dip_a_flat_profile_and_a_wide_one():
    values = np.linspace(0.0, 0.08, 9)
    parabola = 50.0 + (values / 0.01) ** 2                      # one-sided 95 % end at sqrt(2.706) 0.01
    assert bound_verdict(values, parabola, 0.0, CHI2_BOUND_95, 0.02)["passed"]
    dip = bound_verdict(values, parabola - 30.0 * np.sin(values / 0.08 * np.pi), 0.0, CHI2_BOUND_95, 0.02)
    assert not dip["passed"] and "falls into the interior" in dip["why"]
    flat = bound_verdict(values, 50.0 + values, 0.0, CHI2_BOUND_95, 0.02)
    assert not flat["passed"] and "do not exclude the interior" in flat["why"]
    wide = bound_verdict(values, 50.0 + (values / 0.03) ** 2, 0.0, CHI2_BOUND_95, 0.02)   # end 0.049 > 0.033
    assert not wide["passed"] and "only beyond" in wide["why"]
    # the threshold scales with the misfit's s^2: the same profile with s^2 = 4 is twice as wide
    scaled = bound_verdict(values, parabola, 0.0, 4 * CHI2_BOUND_95, 0.02)
    assert scaled["interval"][1] == pytest.approx(2 * np.sqrt(CHI2_BOUND_95) * 0.01, rel=0.05)
    # from an upper bound the interval runs downwards
    upper = bound_verdict(1.0 - values, parabola, 1.0, CHI2_BOUND_95, 0.02)
    assert upper["passed"] and upper["interval"][1] == 1.0 and upper["interval"][0] < 1.0


def test_the_bound_verdict_counts_the_systematic_part_as_a_claim_inside_the_bounds_does():
    """A profile of the weighted chi-square does not see the model error's systematic part: with it counted in
    quadrature, hypot(h, 1.645 systematic) for the profile's half-width h = 1.645 s, a zone on its bound passes
    exactly when a zone inside with statistical standard error s would be claimed, hypot(s, systematic) <= limit,
    and its interval widens by as much."""
    values = np.linspace(0.0, 0.08, 81)
    s = 0.01                                       # the statistical standard error: the profile rises by 2.706
    parabola = 50.0 + (values / s) ** 2            # at sqrt(2.706) s = 1.645 s
    plain = bound_verdict(values, parabola, 0.0, CHI2_BOUND_95, 0.02)
    assert plain["passed"] and plain["interval"][1] == pytest.approx(1.6448536 * s, rel=2e-3)
    for systematic in (0.015, 0.0175, 0.02):
        check = bound_verdict(values, parabola, 0.0, CHI2_BOUND_95, 0.02, systematic)
        assert check["passed"] == (np.hypot(s, systematic) <= 0.02)
        assert check["interval"][1] == pytest.approx(1.6448536 * np.hypot(s, systematic), rel=2e-3)
        assert check["systematic"] == systematic
    failed = bound_verdict(values, parabola, 0.0, CHI2_BOUND_95, 0.02, 0.02)
    assert "with the systematic part 0.02 of its standard error counted" in failed["why"]
    upper = bound_verdict(1.0 - values, parabola, 1.0, CHI2_BOUND_95, 0.02, 0.015)
    assert upper["interval"][0] == pytest.approx(1.0 - 1.6448536 * np.hypot(s, 0.015), rel=2e-3)


@pytest.mark.slow                                               # identification and 7 refits: 25 s
def test_a_zone_that_fails_its_bound_check_is_not_claimed_and_says_why(folder, monkeypatch):
    """The identification acts on a failed check: the zone is not claimed, its why names the check's reason, and
    the check (with its values) stays in result.json."""
    from frictionid.inverse import profile as module
    checks = module.bound_checks

    def failing(*args, **kwargs):
        out = checks(*args, **kwargs)
        return {zone: {**check, "passed": False, "why": "made to fail"} for zone, check in out.items()}

    monkeypatch.setattr(module, "bound_checks", failing)
    data = _measured(folder, "fail", "A = 0.3, B = 0.0", seed=5)
    assert main(["identify", _config(folder, "fail", "A = 0.2, B = 0.2", data,
                                     "profile_points = 7\nresolution = 0.05\n")]) == 0
    b = json.loads((folder / "runs/fail/result.json").read_text())["parameters"]["B"]
    assert b["at_bound"] and not b["identifiable"] and b["why"] == "on its bound, but made to fail"
    assert len(b["bound_check"]["chi2"]) == 7                            # the interval stays the linearised one
    assert b["ci95"][1] == pytest.approx(b["ci95"][0] + 1.6448536 * b["stderr"], rel=1e-6)


@pytest.mark.parametrize("systematic, wording", [(0.012, "the profile, its systematic part counted, excludes"),
                                                 (0.0, "on its bound: the profile excludes")])
def test_the_text_report_says_whether_a_bound_claim_counts_a_systematic_part(systematic, wording):
    """The text report of a zone claimed on its bound names the systematic part where its profile check counted
    one (result.json ``bound_check.systematic``), and the interval's end the check gave."""
    from pathlib import Path
    from frictionid.report.tables import result_summary
    fixture = Path(__file__).parent / "fixtures" / "same_result" / "model_error_include.json"
    result = {**json.loads(fixture.read_text()), "wall_time_s": 1.0}
    result["parameters"]["B"].update(value=0.0, at_bound=True, identifiable=True, why="", ci95=[0.0, 0.031],
                                     bound_check={"passed": True, "systematic": systematic})
    line = next(t for t in result_summary(result).splitlines() if "on its bound" in t)
    assert wording in line and "beyond 0.0310 (one-sided 95 %)" in line
    assert ("systematic part" in line) == (systematic > 0)
