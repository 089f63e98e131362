"""Files of a finished run: result.json, history.csv and convergence.png in the run directory."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def write_outputs(run_dir: Path, result: dict, store=None) -> list[Path]:
    """Write the run's files; returns their paths."""
    run_dir = Path(run_dir)
    paths = [run_dir / "result.json", run_dir / "history.csv", run_dir / "convergence.png"]
    if result.get("fit", {}).get("points"):
        paths.append(run_dir / "residuals.png")
        residual_plot(result, paths[3])
    paths[0].write_text(json.dumps(result, indent=2) + "\n")
    names = list(result["parameters"])
    history = result.get("history", {})
    with paths[1].open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["iteration", "objective", *names])
        for k, (objective, mu) in enumerate(zip(history.get("objective", []), history.get("coefficients", []))):
            writer.writerow([k, repr(objective), *map(repr, mu)])
    convergence_plot(result, paths[2])
    return paths


def convergence_plot(result: dict, path: Path) -> None:
    """Objective (log scale) and coefficients per iteration."""
    history = result.get("history", {})
    objective, coefficients = history.get("objective", []), history.get("coefficients", [])
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    left.semilogy(range(len(objective)), objective, "o-")
    left.set(xlabel="iteration", ylabel="objective J", title=f"{result['method']} ({result['jacobian']} Jacobian)")
    for k, name in enumerate(result["parameters"]):
        right.plot(range(len(coefficients)), [mu[k] for mu in coefficients], "o-", label=name)
    right.set(xlabel="iteration", ylabel="friction coefficient", title="coefficients")
    right.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def residual_plot(result: dict, path: Path) -> None:
    """Each measurement point at its model position, coloured by its RMS residual in units of the noise."""
    points = result["fit"]["points"]
    xyz = [p["xyz"] for p in points]
    rms = [p["rms"] for p in points]
    three_d = len(xyz[0]) == 3
    fig = plt.figure(figsize=(7, 5.5))
    axes = fig.add_subplot(projection="3d" if three_d else None)
    columns = list(zip(*xyz))
    shown = axes.scatter(*columns, c=rms, cmap="viridis", vmin=0.0, s=18)
    labels = ("x [mm]", "y [mm]", "z [mm]") if three_d else ("x (r) [mm]", "y [mm]")
    axes.set(**{f"{axis}label": text for axis, text in zip("xyz", labels)})
    fit = result["fit"]
    verdict = {True: "explained by the noise", False: "NOT explained by the noise", None: "no stated noise"}
    axes.set_title(f"RMS residual / noise per point; reduced chi-square {fit['reduced_chi2']:.3g} "
                   f"({verdict[fit.get('consistent')]})", fontsize=9)
    fig.colorbar(shown, ax=axes, label="RMS residual / noise", shrink=0.8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
