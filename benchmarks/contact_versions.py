"""Contact solves of two versions of the code side by side in one process: a commit's frictionid (imported as
frictionid_<commit>, copied by `git archive` into a temporary folder) against the working tree's, the two taking
turns as in benchmarks/contact_solves.py, both with the updated Jacobian solves (the default).

Prints per model the median CPU time of each version's forward + sensitivity solve, the median of the per-repeat
ratios (old / new) and the largest differences of the results relative to each field's largest value. Models and
coefficients are those of benchmarks/contact_solves.py (clamp, block, bolt).

Run: .venv/bin/python benchmarks/contact_versions.py COMMIT [repeats] [model ...] [--rtol R]

``--rtol R``: both versions' Newton tolerance (default 1e-10, relative to the increment's largest force) set to R,
so that the comparison shows whether they solve the same equations (differences at the round-off) rather than
where each one's Newton happened to stop within its tolerance. Each model also prints how far each version's
own results move when mu changes by 1e-15 of itself: the floor below which no two versions can agree.
"""

import importlib
import re
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CLAMP = ROOT / "tests" / "fixtures" / "clamp" / "clamp.toml"
MU = {"clamp": [0.15, 0.2, 0.25, 0.18, 0.22, 0.3], "block": [0.3, 0.2, 0.4, 0.25], "bolt": None}


def install(commit: str, folder: Path) -> str:
    """The package of ``commit`` written to ``folder`` as frictionid_<commit>, its imports renamed; its name."""
    name = "frictionid_" + re.sub(r"\W", "_", commit)
    archive = subprocess.run(["git", "archive", commit, "src/frictionid"], cwd=ROOT, check=True,
                             capture_output=True, timeout=120).stdout
    with tarfile.open(fileobj=BytesIO(archive)) as tar:
        tar.extractall(folder, filter="data")
    package = folder / name
    (folder / "src" / "frictionid").rename(package)
    for path in package.rglob("*.py"):
        text = path.read_text()
        text = re.sub(r"\bfrictionid\.", name + ".", text)
        text = re.sub(r"^(from|import) frictionid\b", rf"\1 {name}", text, flags=re.M)
        path.write_text(text)
    sys.path.insert(0, str(folder))
    return name


def problem(package: str, model: str):
    """(Problem, coefficients) of ``model`` built by ``package``, its stuck inverse made by a first solve."""
    def module(name):
        return importlib.import_module(f"{package}.{name}")
    if model == "clamp":
        config = module("config").read_config(CLAMP)
        spec = config.model_spec if hasattr(config, "model_spec") else config.model_options  # older commits
        built = module("builders.registry").build_model(spec)
    elif model == "block":
        built = module("builders.block").block_model()
    else:
        built = module("builders.bolt").bolt_model(forces=module("studies.bolt").FORCES)
    solved = module("fem.problem").Problem.build(built)
    mu = np.full(built.n_zones, 0.15) if MU[model] is None else np.asarray(MU[model])
    solved.solve(mu, sensitivities=True)
    return solved, mu


def difference(a, b) -> str:
    out = []
    for field in ("lam", "w", "reactions", "d_reactions"):
        x, y = np.asarray(getattr(a, field)), np.asarray(getattr(b, field))
        out.append(f"{field} {np.max(np.abs(x - y), initial=0.0) / max(np.max(np.abs(x), initial=0.0), 1e-300):.1e}")
    return ", ".join(out)


def compare(old: str, model: str, repeats: int) -> None:
    problems = {old: problem(old, model), "frictionid": problem("frictionid", model)}
    cpu = {name: [] for name in problems}
    solutions = {}
    for k in range(repeats):
        for name in (list(problems) if k % 2 == 0 else list(problems)[::-1]):
            solved, mu = problems[name]
            start = time.process_time()
            solutions[name] = solved.solve(mu, sensitivities=True)
            cpu[name].append(time.process_time() - start)
    ratios = [a / b for a, b in zip(cpu[old], cpu["frictionid"])]
    print(f"{model}: CPU median {old} {statistics.median(cpu[old]):.3f} s, working tree "
          f"{statistics.median(cpu['frictionid']):.3f} s; ratio {statistics.median(ratios):.2f} "
          f"(per repeat {', '.join(f'{r:.2f}' for r in ratios)})")
    print(f"  Newton iterations {int(solutions[old].n_newton.sum())} / {int(solutions['frictionid'].n_newton.sum())};"
          f" largest difference / largest value: {difference(solutions[old], solutions['frictionid'])}")
    for name, (solved, mu) in problems.items():
        moved = solved.solve(mu * (1 + 1e-15), sensitivities=True)
        print(f"  {name} with mu x (1 + 1e-15) against itself: {difference(solutions[name], moved)}")


def newton_tolerance(package: str, rtol: float) -> None:
    """Every load-path solver of ``package`` made from here on stops Newton at ``rtol``."""
    solver = importlib.import_module(f"{package}.fem.loadpath").LoadPathSolver
    made = solver.__init__

    def __init__(self, *args, **kwargs):
        made(self, *args, **kwargs)
        self.rtol = rtol

    solver.__init__ = __init__


def main(argv: list[str]) -> None:
    rtol = None
    if "--rtol" in argv:
        at = argv.index("--rtol")
        rtol, argv = float(argv[at + 1]), argv[:at] + argv[at + 2:]
    commit, repeats = argv[0], int(argv[1]) if len(argv) > 1 else 6
    with tempfile.TemporaryDirectory() as folder:
        old = install(commit, Path(folder))
        if rtol is not None:
            for package in (old, "frictionid"):
                newton_tolerance(package, rtol)
        for model in argv[2:] or list(MU):
            compare(old, model, repeats)


if __name__ == "__main__":
    main(sys.argv[1:])
