"""The paper's block study (section 4.1, DESIGN.md reference test 1) with frictionid, from one command.

Goal coefficients drawn at random in [0.1, 0.5] (fixed seed), reference strains computed on a finer mesh than the
one identified with (no inverse crime), start 0.1 everywhere; the paper's algorithm (gradient descent, Armijo
step, forward differences) and ours (bounded trust-region Gauss-Newton, analytic sensitivities) side by side:
the paper's Fig. 5 (|mu_k - mu| / |mu_0 - mu| and |eps_k - eps| / |eps_0 - eps| per iteration) and a table.

Run: .venv/bin/python examples/block/run.py [--data-mesh 1.25] [--mesh 2.5] [--gd-iterations 200]
Outputs in examples/block/out/: measured.csv, runs/<method>/ (result.json, history.csv, ...), fig5.png, table.txt
"""

import argparse
import shutil
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from frictionid.backends.embedded import EmbeddedBackend  # noqa: E402
from frictionid.cli import main as cli  # noqa: E402
from frictionid.config import read_config  # noqa: E402
from frictionid.identify import identify, prepare  # noqa: E402

HERE = Path(__file__).parent
STRAINS = '["exx", "eyy", "ezz", "exy", "eyz", "exz"]'
METHODS = {"gradient-descent": "forward", "trf": "analytic"}


def points_file(path: Path) -> None:
    """Strain gauges on the block's four side faces, 0.5 and 1.5 mm above the contact."""
    rows, k = ["# strain observation points on the block's side faces (undeformed, mm)", "point,x,y,z,stage,exx"], 0
    for z in (0.5, 1.5):
        for s in (-3.0, 3.0):
            for x, y in ((-5.0, s), (5.0, s), (s, -5.0), (s, 5.0)):
                k += 1
                rows.append(f"P{k},{x},{y},{z},2,0.0")
    path.write_text("\n".join(rows) + "\n")


def config(out: Path, name: str, mesh: float, zones: dict, data: str, extra: str = "") -> Path:
    path = out / f"{name}.toml"
    table = ", ".join(f"{z} = {float(v)!r}" for z, v in zones.items())
    path.write_text(f'[model]\nbuilder = "block"\nmesh_size = {mesh}\n[friction]\nzones = {{ {table} }}\n'
                    f'[data]\nfile = "{data}"\nobservables = {STRAINS}\nstages = [2]\nnoise = {{ e = 1e-5 }}\n'
                    f'regions = {{ "*" = "block" }}\n{extra}[run]\ndir = "runs/{name}"\n')
    return path


def relative_errors(result: dict, config_path: Path, mu_true, eps_true):
    """|mu_k - mu| / |mu_0 - mu| and |eps_k - eps| / |eps_0 - eps| over the history (one solve per iterate)."""
    setup = prepare(read_config(config_path, need=("model", "friction", "data", "run")))
    obs = setup.observations
    backend = EmbeddedBackend(setup.model, obs.points, obs.quantities, obs.point_regions)
    mus = np.array(result["history"]["coefficients"])
    eps = np.array([obs.predicted(backend.predict(mu).values) for mu in mus])
    return (np.linalg.norm(mus - mu_true, axis=1) / np.linalg.norm(mus[0] - mu_true),
            np.linalg.norm(eps - eps_true, axis=1) / np.linalg.norm(eps[0] - eps_true))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-mesh", type=float, default=1.25, help="mesh size of the reference data [mm]")
    parser.add_argument("--mesh", type=float, default=2.5, help="mesh size identified with [mm]")
    parser.add_argument("--gd-iterations", type=int, default=200)
    args = parser.parse_args(argv)
    out = HERE / "out"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir()
    mu_true = dict(zip("ABCD", np.random.default_rng(2024).uniform(0.1, 0.5, 4)))
    points_file(out / "points.csv")
    truth = config(out, "truth", args.data_mesh, mu_true, "points.csv")
    assert cli(["simulate", str(truth), "--out", str(out / "measured.csv")]) == 0
    rows, curves = [], {}
    for method, jacobian in METHODS.items():
        iterations = args.gd_iterations if method == "gradient-descent" else 50
        path = config(out, method, args.mesh, dict.fromkeys("ABCD", 0.1), "measured.csv",
                      f'[identify]\nmethod = "{method}"\njacobian = "{jacobian}"\nmax_iterations = {iterations}\n')
        result = identify(read_config(path, need=("model", "friction", "data", "run")))
        setup = prepare(read_config(path, need=("model", "friction", "data", "run")))
        curves[method] = relative_errors(result, path, np.array(list(mu_true.values())), setup.observations.y)
        values = [result["parameters"][z]["value"] for z in "ABCD"]
        rows.append((method, jacobian, result["status"], result["n_iterations"],
                     result["n_forward_solves"] + result["n_sensitivity_solves"], result["wall_time_s"], values))
    table = ["goal coefficients: " + ", ".join(f"{z} = {v:.4f}" for z, v in mu_true.items()),
             f"data mesh {args.data_mesh} mm, identification mesh {args.mesh} mm, start 0.1",
             f"{'method':<18}{'jacobian':<10}{'status':<16}{'iter':>5}{'solves':>8}{'time [s]':>10}   A       B       C       D"]
    for method, jacobian, status, n_iter, solves, wall, values in rows:
        table.append(f"{method:<18}{jacobian:<10}{status:<16}{n_iter:>5}{solves:>8}{wall:>10.2f}   "
                     + "  ".join(f"{v:.4f}" for v in values))
    (out / "table.txt").write_text("\n".join(table) + "\n")
    print("\n".join(table))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, (method, (mu_err, eps_err)) in zip(axes, curves.items()):
        ax.semilogy(mu_err, "o-", ms=3, label="|mu_k - mu| / |mu_0 - mu|")
        ax.semilogy(eps_err, "s-", ms=3, label="|eps_k - eps| / |eps_0 - eps|")
        ax.set(title=f"{method} ({METHODS[method]} Jacobian)", xlabel="iteration k")
        ax.legend()
    axes[0].set_ylabel("relative error")
    fig.tight_layout()
    fig.savefig(out / "fig5.png", dpi=110)
    print(f"results in {out}")


if __name__ == "__main__":
    main()
