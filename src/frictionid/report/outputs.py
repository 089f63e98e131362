"""Files of a run: result.json, history.csv, convergence.png, residuals.png and report.html in the run directory."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from ..inverse.observations import label_parts
from .html import write_html


def write_outputs(run_dir: Path, result: dict, store=None, config_text: str | None = None,
                  data_file: Path | None = None) -> list[Path]:
    """Write the run's files, also for a run that stopped early (with what it has); returns their paths.

    ``store``: the run's :class:`~frictionid.run.store.RunStore`, whose iterations give the history of a run
    without one in ``result``; ``config_text`` and ``data_file`` go into report.html's provenance.
    """
    run_dir = Path(run_dir)
    if not result.get("history") and store is not None:
        result = {**result, "history": stored_history(result, store)}
    paths = [run_dir / "result.json", run_dir / "history.csv", run_dir / "convergence.png"]
    paths[0].write_text(json.dumps(result, indent=2) + "\n")
    names = list(result["parameters"])
    history = result.get("history", {})
    with paths[1].open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["iteration", "objective", *names])
        for k, (objective, mu) in enumerate(zip(history.get("objective", []), history.get("coefficients", []))):
            writer.writerow([k, repr(objective), *map(repr, mu)])
    save(convergence_figure(result), paths[2])
    if result.get("fit", {}).get("points"):
        paths.append(run_dir / "residuals.png")
        residual_plot(result, paths[-1])
    figures = {path.stem: path.read_bytes() for path in paths[2:]}
    if result.get("fit", {}).get("observations"):
        paths.append(write_observations(run_dir / "observations.csv", result["fit"]["observations"]))
        stream = io.BytesIO()
        save(fit_figure(result["fit"]["observations"]), stream)
        figures["fit"] = stream.getvalue()
    paths.append(write_html(run_dir, result, figures, config_text, data_file))
    return paths


def write_observations(path: Path, observations: list[dict]) -> Path:
    """Measured against fitted, one row per observation: point, quantity, stage, measured, model, residual
    (model - measured, in the quantity's unit), sigma and the residual in units of sigma (empty without noise)."""
    with Path(path).open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["point", "quantity", "stage", "measured", "model", "residual", "sigma", "residual_sigma"])
        for row in observations:
            point, quantity, stage = label_parts(row["label"])
            residual, sigma = row["model"] - row["measured"], row.get("sigma")
            writer.writerow([point, quantity, stage, repr(row["measured"]), repr(row["model"]), repr(residual),
                             "" if sigma is None else repr(sigma), "" if not sigma else repr(residual / sigma)])
    return Path(path)


def stored_history(result: dict, store) -> dict:
    """Objective and coefficients (all zones, fixed ones at their value) per stored iteration."""
    rows = store.iterations()
    free = [k for k, p in enumerate(result["parameters"].values()) if not p["fixed"]]
    coefficients = []
    for row in rows:
        mu = [p["value"] for p in result["parameters"].values()]
        for k, v in zip(free, row.x):
            mu[k] = float(v)
        coefficients.append(mu)
    return {"objective": [float(row.objective) for row in rows], "coefficients": coefficients}


# Figures are matplotlib.figure.Figure objects, not pyplot ones: they need no backend (savefig renders with Agg)
# and leave the caller's pyplot state and backend alone; nothing holds them once they are saved.
def save(fig: Figure, path) -> None:
    """Write a figure (PNG, 100 dpi) to a path or binary stream."""
    fig.savefig(path, dpi=100, format="png")


def convergence_figure(result: dict) -> Figure:
    """Objective (log scale) and the free zones' coefficients per iteration (integer ticks), with the final
    standard errors as error bars and, when ``result["truth"]`` gives them, the true values dashed."""
    history = result.get("history", {})
    objective, coefficients = history.get("objective", []), history.get("coefficients", [])
    fig = Figure(figsize=(10, 4))
    left, right = fig.subplots(1, 2)
    if objective:
        left.semilogy(range(len(objective)), objective, "o-")
    left.set(xlabel="iteration", ylabel="objective J", title=f"{result['method']} ({result['jacobian']} Jacobian)")
    truth = result.get("truth") or {}
    free = [(k, name, p) for k, (name, p) in enumerate(result["parameters"].items()) if not p["fixed"]]
    for j, (k, name, p) in enumerate(free):
        values = [mu[k] for mu in coefficients]
        line, = right.plot(range(len(values)), values, "o-", ms=4, label=name)
        if values and p.get("stderr") is not None:
            right.errorbar([len(values) - 1 + 0.08 * (j - (len(free) - 1) / 2)], [values[-1]],
                           yerr=error_bar(values[-1], p), color=line.get_color(), capsize=3)
        if name in truth:
            right.axhline(truth[name], color=line.get_color(), ls="--", lw=1)
    fixed = [name for name, p in result["parameters"].items() if p["fixed"]]
    notes = (["bars: +/- 1 stderr at the end, within the bounds"] if any(p.get("stderr") is not None
                                                                        for _, _, p in free) else []) \
        + (["dashed: true values"] if truth else []) + ([f"fixed: {', '.join(fixed)}"] if fixed else [])
    right.set(xlabel="iteration", ylabel="friction coefficient", title="coefficients of the free zones")
    for axes in (left, right):
        axes.xaxis.set_major_locator(MaxNLocator(integer=True))
    if right.lines:
        right.legend(fontsize=8, title="\n".join(notes) or None, title_fontsize=7, alignment="left")
    fig.tight_layout()
    return fig


def error_bar(value: float, p: dict) -> list[list[float]]:
    """Lower and upper length of a +/- 1 stderr bar at ``value``, cut at the 95 % interval (which lies within
    the bounds), so that no bar reaches a negative coefficient."""
    low, high = p["ci95"] if p.get("ci95") else (value - p["stderr"], value + p["stderr"])
    return [[value - max(value - p["stderr"], low)], [min(value + p["stderr"], high) - value]]


def residual_plot(result: dict, path: Path) -> None:
    """Each measurement point at its model position, coloured by its RMS residual in units of the noise."""
    points = result["fit"]["points"]
    xyz = [p["xyz"] for p in points]
    rms = [p["rms"] for p in points]
    three_d = len(xyz[0]) == 3
    fig = Figure(figsize=(7, 5.5))
    axes = fig.add_subplot(projection="3d" if three_d else None)
    columns = list(zip(*xyz))
    shown = axes.scatter(*columns, c=rms, cmap="viridis", vmin=0.0, s=18)
    labels = ("x [mm]", "y [mm]", "z [mm]") if three_d else ("x (r) [mm]", "y [mm]")
    axes.set(**{f"{axis}label": text for axis, text in zip("xyz", labels)})
    fit = result["fit"]
    verdict = {True: "explained by the noise", False: "NOT explained by the noise", None: "no stated noise"}
    axes.set_title(f"RMS residual / noise per point; reduced chi-square {fit['reduced_chi2']:.3g} "
                   f"({'below the stated noise' if fit.get('too_small') else verdict[fit.get('consistent')]})",
                   fontsize=9)
    fig.colorbar(shown, ax=axes, label="RMS residual / noise", shrink=0.8)
    fig.tight_layout()
    save(fig, path)


def fit_figure(observations: list[dict]) -> Figure:
    """Measured (with +/- sigma) and fitted value per observation, one panel per quantity; ``observations``
    as in result.json's ``fit.observations`` (label "point:quantity@stage" or "force@stage")."""
    panels: dict[str, list[dict]] = {}
    for o in observations:
        quantity = label_parts(o["label"])[1]
        panels.setdefault(quantity, []).append(o)
    fig = Figure(figsize=(10, 2.6 * len(panels)))
    axes = fig.subplots(len(panels), 1, squeeze=False)
    for ax, (quantity, rows) in zip(axes[:, 0], panels.items()):
        index = range(len(rows))
        sigma = [o["sigma"] if o.get("sigma") is not None else 0.0 for o in rows]
        ax.errorbar(index, [o["measured"] for o in rows], yerr=sigma, fmt="o", ms=3, capsize=2, label="measured")
        ax.plot(index, [o["model"] for o in rows], "x", color="C3", label="fitted model")
        ax.set(ylabel=quantity, title=f"{quantity}: {len(rows)} observations", xlabel="observation")
        if len(rows) <= 40:
            ax.set_xticks(index, [o["label"].replace(f":{quantity}", "") for o in rows], rotation=60, fontsize=7)
        else:
            ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
