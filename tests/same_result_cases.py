"""Small identifications whose result.json must not change when the code is reorganised: examples/first with
its options varied (robust loss and starts, profiles, central differences, the model-error estimate, the Python
interface, a run interrupted). ``python tests/same_result_cases.py OUT`` writes each case's
result.json to OUT/<case>.json; tests/test_same_result.py runs the cases and compares them with the files in
tests/fixtures/same_result, made so (the discretisation control off, as tests/conftest.py has it) after the split of
identification.py by job and the contact solver's capacitance updates (which moved these results by at most
2.4e-10 relative, 1e-12 in the coefficients, from those of 5aa774a, before the split). The example cases
(examples/hub, examples/parts3d and examples/bolt-m20/tightening run as their READMEs say) were written by the code
of 087f188, before the config tables became typed option objects (``PYTHONPATH=<that checkout>/src:tests python
tests/same_result_cases.py tests/fixtures/same_result example_hub example_parts3d example_tightening``); example_parts3d's again after the
3-D mortar was batched (its sums in another order): its noise-free twin data moved by at most 4.2e-12 (mm or N,
against values up to 800), and with them the misfit of round-off size and its shares; the coefficients and their
standard errors agree to 1e-12. All were written again after trf's final Gauss-Newton step (final_step) and the
contact solver's batched capacitance products and column-by-column products: the fits that stop by se_step with
a step left worth a solve (first, api, model_error, model_error_include, example_hub, profile_central's refits)
take one more iteration, which moved their coefficients by at most 2.2e-3 relative (0.015 standard errors); the
others (interrupted, max_iterations, robust_starts with its robust loss, example_parts3d, example_tightening) moved
by round-off: coefficients and standard errors at most 2.6e-13 relative, example_parts3d's misfit of round-off
size and its shares again. profile_central, example_hub and example_tightening were written again when the facet
bases' inverse map on triangles and tetrahedra began to start from the straight cell's inverse (exact on straight
cells, where Newton from scikit-fem's start stopped within 1e-10): coefficients and standard errors moved by at
most 5.5e-12 relative, misfits by at most 2.7e-10, and example_tightening's round-off-size torque misfit share by
1.2e-5. Every case's ``fit`` then got ``kinds_beyond_noise`` (the quantities whose own chi-square fails), empty in
all of them, with nothing else changed (checked by running the cases against the files with the key added).
model_error and model_error_include were written again when include's error scale became one per quantity: their
``fit.model_error`` got ``scales`` (null; {"ux": 0, "uy": 0} in include, whose misfit the noise explains), and
include's ``fit.shifts`` the leave-group-out moves now made for every include fit; nothing else changed. When
identify.model_error = "auto" became the default, every case's ``fit.model_error`` got the mode used, the mode
requested and why ("off" for "auto" here, the control being off; null before), added to the files by a script and
checked by running the cases against them; nothing else changed."""

from __future__ import annotations

import json
import shutil
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).parents[1]

#: [identify] keys added to examples/first/identify.toml, per case
CASES = {
    "first": {},
    "robust_starts": {"loss": "soft_l1", "starts": 2, "seed": 3},
    "profile_central": {"jacobian": "central", "profile": ["A"], "profile_points": 3, "max_iterations": 4},
    "model_error": {"model_error": "estimate"},
    "model_error_include": {"model_error": "include"},
    "max_iterations": {"max_iterations": 2},
    "interrupted": {},
}

#: keys of result.json that measure time, not the result
TIMES = {"wall_time_s", "timings", "seconds", "backend_s"}


def make_data(folder: Path) -> None:
    """examples/first copied into ``folder`` with its twin data (measured.csv) made."""
    from frictionid.cli import main

    shutil.copytree(ROOT / "examples" / "first", folder, dirs_exist_ok=True)
    assert main(["simulate", str(folder / "truth.toml"), "--out", str(folder / "measured.csv")]) == 0


def run_case(folder: Path, name: str) -> dict:
    """result.json of case ``name`` run in ``folder`` (which holds make_data's files)."""
    from frictionid.config import read_config
    from frictionid.identification import identify, identify_config

    if name.startswith("example_"):
        return run_example(folder, name.removeprefix("example_"))
    text = (folder / "identify.toml").read_text().replace('dir = "runs/first"', f'dir = "runs/{name}"')
    extra = "".join(f"{key} = {json.dumps(value)}\n" for key, value in CASES.get(name, {}).items())
    path = folder / f"{name}.toml"
    path.write_text(text.replace('method = "trf"\n', 'method = "trf"\n' + extra))
    if name == "api":
        table = tomllib.loads(text)
        result = identify(table["model"], folder / "measured.csv", {"A": 0.1, "B": 0.1},
                          observables=table["data"]["observables"], stages=table["data"]["stages"],
                          noise=table["data"]["noise"], regions=table["data"]["regions"], method="trf")
        return result.to_dict()
    if name == "interrupted":               # stopped at the second iteration: result.json of a stopped run
        def stop(iteration, mu, objective, evaluator):
            if iteration == 1:
                raise KeyboardInterrupt
        try:
            identify_config(read_config(path, need=("model", "friction", "data", "run")), on_iteration=stop)
        except KeyboardInterrupt:
            pass
    else:
        identify_config(read_config(path, need=("model", "friction", "data", "run")))
    return json.loads((folder / "runs" / name / "result.json").read_text())


#: the other examples with an identify.toml, run as their READMEs run them (in a copy: ``python mesh.py`` where the
#: example has one, simulate truth.toml, identify identify.toml): case name -> the example's folder under examples/
#: and the run folder its config names
EXAMPLES = {"hub": ("hub", "runs/hub"), "parts3d": ("parts3d", "runs/parts3d"),
            "tightening": ("bolt-m20/tightening", "runs/tightening")}

NAMES = (*CASES, "api", *(f"example_{name}" for name in EXAMPLES))


def run_example(folder: Path, name: str) -> dict:
    """result.json of the example of case ``name`` run in a copy of it under ``folder``, with its documented
    commands."""
    from frictionid.cli import main

    source, run = EXAMPLES[name]
    copy = folder / name
    shutil.copytree(ROOT / "examples" / source, copy, dirs_exist_ok=True)
    if (copy / "mesh.py").exists():
        _run_in(copy)
    assert main(["simulate", str(copy / "truth.toml"), "--out", str(copy / "measured.csv")]) == 0
    assert main(["identify", str(copy / "identify.toml")]) == 0
    text = (copy / run / "result.json").read_text()
    return json.loads(text.replace(json.dumps(str(copy))[1:-1], "<example>"))      # the copy's folder named alike


def _run_in(folder: Path) -> None:
    """``python mesh.py`` in ``folder`` (the script writes into its working folder)."""
    import os
    import runpy

    here = os.getcwd()
    os.chdir(folder)
    try:
        runpy.run_path("mesh.py", run_name="__main__")
    finally:
        os.chdir(here)


def without_times(value):
    """``value`` with the keys that measure time left out (at any depth)."""
    if isinstance(value, dict):
        return {k: without_times(v) for k, v in value.items() if k not in TIMES}
    if isinstance(value, list):
        return [without_times(v) for v in value]
    return value


if __name__ == "__main__":
    from frictionid import config

    config.SCHEMA["identify"]["refine_target"] = 0.0         # as tests/conftest.py: the references fit the mesh given
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        make_data(Path(tmp))
        for name in sys.argv[2:] or NAMES:
            (out / f"{name}.json").write_text(json.dumps(without_times(run_case(Path(tmp), name)), indent=1))
            print(name, "written")
