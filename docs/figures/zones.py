"""Draw docs/figures/zones.png: the friction zones of the three built-in models, from the models themselves.

Run: .venv/bin/python docs/figures/zones.py   (a few seconds)
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from frictionid.builders.registry import build_model  # noqa: E402
from frictionid.options import ModelSpec  # noqa: E402

COLOURS = plt.get_cmap("tab10").colors


def _zone_facets(model):
    for interface in model.interfaces:
        for k, zone in enumerate(interface.zones):
            yield zone, model.mesh.points[model.mesh.boundaries[zone]]


def block(ax):
    model = build_model(ModelSpec.from_table({"builder": "block", "mesh_size": 2.5}))
    for k, (zone, facets) in enumerate(_zone_facets(model)):
        xy = facets[:, :, :2].reshape(-1, 2)
        ax.fill([xy[:, 0].min(), xy[:, 0].max(), xy[:, 0].max(), xy[:, 0].min()],
                [xy[:, 1].min(), xy[:, 1].min(), xy[:, 1].max(), xy[:, 1].max()], color=COLOURS[k], alpha=0.6)
        ax.text(xy[:, 0].mean(), xy[:, 1].mean(), zone, ha="center", va="center", fontsize=14)
    ax.add_patch(plt.Rectangle((-20, -20), 40, 40, fill=False, ls="--"))
    ax.annotate("", (0, 9), (0, 5.5), arrowprops={"arrowstyle": "->"})
    ax.text(0.6, 7.5, "pull (+y)")
    ax.set(title="block: block bottom seen from above\n(plate top dashed)", xlabel="x [mm]", ylabel="y [mm]",
           xlim=(-21, 21), ylim=(-21, 21), aspect="equal")


def block2d(ax):
    model = build_model(ModelSpec.from_table({"builder": "block2d", "mesh_size": 2.0, "n_zones": 3}))
    ax.add_patch(plt.Rectangle((-20, -5), 40, 5, color="0.85"))
    ax.add_patch(plt.Rectangle((-5, 0), 10, 10, color="0.65"))
    for k, (zone, facets) in enumerate(_zone_facets(model)):
        x = facets[:, :, 0]
        ax.plot([x.min(), x.max()], [0, 0], lw=6, color=COLOURS[k], solid_capstyle="butt")
        ax.text(x.mean(), 1.0, zone, ha="center", fontsize=14)
    ax.annotate("", (8.5, 10), (5, 10), arrowprops={"arrowstyle": "->"})
    ax.text(5.5, 10.7, "pull (+x)")
    ax.set(title="block2d (3 zones): side view", xlabel="x [mm]", ylabel="y [mm]", xlim=(-21, 21), ylim=(-6, 13),
           aspect="equal")


def bolt(ax):
    model = build_model(ModelSpec.from_table({"builder": "bolt", "flank_size": 0.2}))
    mesh = model.mesh
    for name in ("bolt_free", "bolt_root", "bolt_crest", "nut_free", "nut_thread", "nut_load"):
        for facet in mesh.points[mesh.boundaries[name]][:, [0, 1]] if name in mesh.boundaries else []:
            ax.plot(facet[:, 0], facet[:, 1], color="0.6", lw=0.8)
    for k, (zone, facets) in enumerate(_zone_facets(model)):
        if zone in ("head_plate", "nut_plate"):
            continue
        for facet in facets[:, [0, 1]]:
            ax.plot(facet[:, 0], facet[:, 1], color=COLOURS[k], lw=3)
        centre = facets.reshape(-1, 2).mean(axis=0)
        ax.text(centre[0] + (0.5 if zone in "ABC" else -0.55), centre[1], zone, fontsize=12, ha="center")
    bearing = mesh.points[mesh.boundaries["nut_plate"]].reshape(-1, 2)
    ax.axhline(bearing[:, 1].max(), color="k", lw=0.8, ls=":")
    ax.text(7.7, bearing[:, 1].max() + 0.3, "nut bearing face")
    ax.set(title="bolt (M20): thread flanks (r-y)", xlabel="r [mm]", ylabel="y [mm]",
           xlim=(7.6, 11.0), ylim=(bearing[:, 1].max() - 0.5, bearing[:, 1].max() + 18.5))


def main():
    fig, axes = plt.subplots(1, 3, figsize=(15, 5.5), gridspec_kw={"width_ratios": [1, 1.1, 0.7]})
    block(axes[0])
    block2d(axes[1])
    bolt(axes[2])
    fig.tight_layout()
    out = Path(__file__).with_name("zones.png")
    fig.savefig(out, dpi=90)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
