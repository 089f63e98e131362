"""The paper's block study (section 4.1, reference test 1 (docs/models.md)) with frictionid, from one command.

Goal coefficients drawn at random in [0.1, 0.5] (fixed seed), reference data computed on a finer mesh than the
one identified with (no inverse crime), start 0.1 everywhere; the paper's algorithm (gradient descent, Armijo
step, forward differences) and ours (bounded trust-region Gauss-Newton, analytic sensitivities) side by side:
the paper's Fig. 5 (|mu_k - mu| / |mu_0 - mu| and the relative misfit per iteration) and a table. The
observation set and meshes are those of frictionid.studies.block (README.md here explains them); with ``--noise``
the data carry 0.5 um displacement noise and 1 N force noise (fixed seed).

Run: .venv/bin/python examples/block/run.py [--gd-iterations 60] [--noise]
Outputs in examples/block/out/: points.csv, measured.csv, runs/<method>/ (result.json, history.csv, ...),
fig5.png, table.txt
"""

import argparse
import os
import shutil
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from frictionid.cli import main as cli  # noqa: E402
from frictionid.studies import block as twin  # noqa: E402

HERE = Path(__file__).parent

METHODS = {"gradient-descent": "forward", "trf": "analytic"}
def fig5(curves: dict, path: Path) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, (method, (mu_err, misfit)) in zip(axes, curves.items()):
        ax.semilogy(mu_err, "o-", ms=3, label="|mu_k - mu| / |mu_0 - mu|")
        ax.semilogy(misfit, "s-", ms=3, label="|W (f_k - y)| / |W (f_0 - y)|")
        ax.set(title=f"{method} ({METHODS[method]} Jacobian)", xlabel="iteration k")
        ax.legend()
    axes[0].set_ylabel("relative error")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def table(rows: list, mu_true: dict, noise: bool) -> list[str]:
    lines = ["goal coefficients: " + ", ".join(f"{z} = {v:.4f}" for z, v in mu_true.items()),
             f"data mesh {twin.DATA_MESH}, identification mesh {twin.ID_MESH}, start 0.1",
             f"observed: {', '.join(twin.OBSERVABLES)} at stages {list(twin.STAGES)} (pull 0.04 and 0.2 mm); "
             + ("noise 0.5 um / 1 N added" if noise else "noise-free"),
             f"{'method':<18}{'status':<16}{'iter':>5}{'solves':>8}{'time [s]':>10}{'to < 0.01':>18}"
             "   " + "  ".join(f"{z:<16}" for z in mu_true)]
    for method, r in rows:
        res = r["result"]
        reached = f"{r['reached'][0]} / {r['reached'][1]:.1f} s" if r["reached"] else "not reached"
        cells = []
        for z in mu_true:
            p = res["parameters"][z]
            se = f"+-{p['stderr']:.4f}" if p.get("stderr") is not None else "(no se)"
            flag = "" if p.get("identifiable", True) else "?"
            cells.append(f"{p['value']:.4f}{se}{flag}".ljust(16))
        lines.append(f"{method:<18}{res['status']:<16}{res['n_iterations']:>5}"
                     f"{res['n_forward_solves'] + res['n_sensitivity_solves']:>8}{res['wall_time_s']:>10.1f}"
                     f"{reached:>18}   " + "  ".join(cells))
        lines.append(f"{'  error':<18}{'':<57}   " + "  ".join(
            f"{res['parameters'][z]['value'] - v:+.4f}".ljust(16) for z, v in mu_true.items()))
    lines.append("'?': standard error above identify.resolution (the zone is not resolved by these data to that "
                 "precision); solves: forward + with sensitivities; 'to < 0.01': solves / seconds after the start "
                 "point's evaluation until |mu - mu_true| < 0.01 in every zone")
    return lines


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gd-iterations", type=int, default=60)
    parser.add_argument("--noise", action="store_true", help="add 0.5 um / 1 N noise (fixed seed)")
    args = parser.parse_args(argv)
    out = HERE / "out"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir()
    mu_true = twin.goal_coefficients()
    twin.write_points(out / "points.csv")
    truth = twin.config(out, "truth", twin.DATA_MESH, mu_true, "points.csv")
    assert cli(["simulate", str(truth), "--out", str(out / "simulated.csv")]) == 0
    twin.as_measured(out / "simulated.csv", out / "measured.csv",
                     np.random.default_rng(20240) if args.noise else None)
    goal = np.array(list(mu_true.values()))
    rows, curves = [], {}
    for method in METHODS:
        r = twin.identify_traced(out, method, method, METHODS[method],
                                 args.gd_iterations if method == "gradient-descent" else 50, goal)
        history = r["result"]["history"]
        mus = np.array(history["coefficients"])
        objective = np.array(history["objective"])
        curves[method] = (np.linalg.norm(mus - goal, axis=1) / np.linalg.norm(mus[0] - goal),
                          np.sqrt(objective / objective[0]))
        rows.append((method, r))
    lines = table(rows, mu_true, args.noise)
    (out / "table.txt").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    fig5(curves, out / "fig5.png")
    print(f"results in {out}")


if __name__ == "__main__":
    main()
