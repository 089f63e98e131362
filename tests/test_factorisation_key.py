"""[solver] factorisation: the condensation's factorisation chosen in the config reaches condense(), CHOLMOD and
SuperLU and MUMPS give the same identification, and an unknown name exits 2 naming the key."""

import json

import pytest

from frictionid.cli import main
from frictionid.fem import problem as problem_module
from helpers import write_config

TRUE = {"A": 0.32, "B": 0.18, "C": 0.41, "D": 0.25}
MODEL = {"builder": "block", "mesh_size": 5.0, "block_divisions": 2}
# points on the block's side faces (the block spans [-5, 5] x [-5, 5] x [0, 10] above the plate)
POINTS = "point,x,y,z,stage\n" + "".join(
    f"P{k},{x},{y},{z},2\n" for k, (x, y, z) in enumerate(
        [(-5.0, s, z) for s in (-2.5, 2.5) for z in (2.5, 5.0)] + [(5.0, s, z) for s in (-2.5, 2.5) for z in (2.5, 5.0)]
        + [(s, -5.0, z) for s in (-2.5, 2.5) for z in (2.5, 5.0)] + [(s, 5.0, z) for s in (-2.5, 2.5) for z in (2.5, 5.0)]))


def _config(folder, name: str, zones: dict, data: str, solver: str = "") -> str:
    return str(write_config(folder / f"{name}.toml", f'{solver}[run]\ndir = "runs/{name}"\nfields = false\n',
                            model=MODEL, friction={"zones": zones},
                            data={"file": data, "observables": ["ux", "uy", "uz"], "stages": [2],
                                  "noise": {"u": 0.0005}, "regions": {"*": "block"}}))


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    folder = tmp_path_factory.mktemp("factorisation")
    (folder / "points.csv").write_text(POINTS)
    assert main(["simulate", _config(folder, "truth", TRUE, "points.csv"), "--out", str(folder / "measured.csv")]) == 0
    return folder


@pytest.mark.slow          # 35 s in the fast suite on the shared machine (about 1/7 idle)
def test_cholmod_and_superlu_give_the_same_fit(measured, monkeypatch):
    used = []
    condense = problem_module.condense

    def spy(*args, **kwargs):
        used.append(kwargs.get("factorisation", "auto"))
        return condense(*args, **kwargs)

    monkeypatch.setattr(problem_module, "condense", spy)
    results = {}
    for name in ("cholmod", "superlu", "mumps"):
        config = _config(measured, name, dict.fromkeys(TRUE, 0.2), "measured.csv",
                         f'[solver]\nfactorisation = "{name}"\n')
        used.clear()
        assert main(["identify", config]) == 0
        assert used[0] == name                  # the run's model was condensed with the factorisation it named
        results[name] = json.loads((measured / "runs" / name / "result.json").read_text())
    cholmod = results["cholmod"]
    for other in (results["superlu"], results["mumps"]):
        assert cholmod["status"] == other["status"] == "converged"
        for zone, truth in TRUE.items():
            assert cholmod["parameters"][zone]["value"] == pytest.approx(truth, abs=1e-6)
            assert abs(cholmod["parameters"][zone]["value"] - other["parameters"][zone]["value"]) < 1e-9
            assert abs(cholmod["parameters"][zone]["stderr"] - other["parameters"][zone]["stderr"]) < 1e-9
    assert cholmod["timings"]["solves"]["forward+sensitivities"]["n"] == cholmod["n_sensitivity_solves"]


def test_an_unknown_factorisation_exits_2_naming_the_key(measured, capsys):
    config = _config(measured, "bad", TRUE, "measured.csv", '[solver]\nfactorisation = "cholesky"\n')
    status = main(["identify", config])
    out = capsys.readouterr()
    text = out.out + out.err
    assert status == 2 and "Traceback" not in text
    assert 'solver.factorisation must be "auto", "cholmod", "superlu" or "mumps", got \'cholesky\'' in text
