"""Which friction zones a tensile test and a tightening test of the M20 bolt resolve.

Linearised standard errors sqrt(diag((J^T W J)^-1)) from the analytic sensitivities at the coefficients below, for
the partitions "six thread zones" (A-F, head and nut bearing known) and "thread + nut bearing" (A-F merged: summed
columns), per experiment and observation set:

- DIC: ux, uy (and uz = u_t when tightening) at the ten default flank points, 0.5 um;
- gauges: eyy (and the shank shear eyz = e_yt when tightening) at two shank points, 2e-5;
- torque and clamp force of the tightening test (wrench torque 0.5 % of its value, load cell 50 N; assumed).

Both stages each (tension 10 and 30 kN, tightening 4 and 12 deg). The tightening model holds the head rigidly
against turning, so the clamp force at a given nut angle carries the bolt's torsional wind-up (thread torque):
it is that, not the torque alone, which separates thread from bearing friction in a test driven by angle.

Run: .venv/bin/python examples/bolt-m20/tightening_resolution.py [flank_size]
"""

import sys

import numpy as np

from frictionid.builders.bolt import bolt_layout, bolt_model, measurement_points
from frictionid.fem.problem import Problem

MU = {"A": 0.12, "B": 0.15, "C": 0.1, "D": 0.18, "E": 0.11, "F": 0.14, "head_plate": 0.15, "nut_plate": 0.13}
DIC, GAUGE, TORQUE, CLAMP = 0.5e-3, 2e-5, 0.005, 50.0          # noise: mm, strain, relative, N
THREAD = list("ABCDEF")


def rows(load: str, flank: float) -> dict[str, np.ndarray]:
    """Weighted sensitivity rows (n, n_zones) of each observation set of one experiment."""
    points = measurement_points(bolt_layout("M20"))
    gauges = np.array([[9.979, 40.0], [9.979, 50.0]])                 # shank surface, r = d/2 - |es|/2
    twist = load == "tightening"
    displacements, strains = ("ux", "uy", "uz") if twist else ("ux", "uy"), ("eyy", "eyz") if twist else ("eyy",)
    model = bolt_model(load=load, flank_size=flank, angles=(4.0, 12.0), forces=(10000.0, 30000.0))
    problem = Problem.build(model, points=np.vstack([points, gauges]), quantities=displacements + strains,
                            regions=["bolt"] * (len(points) + 2))
    solution = problem.solve([MU[z] for z in model.zone_names], sensitivities=True)
    ends = [solution.stage_end(s) for s in range(model.n_stages)]
    n_q = len(displacements) + len(strains)
    d = np.asarray(solution.d_observations)[ends].reshape(len(ends), len(points) + 2, n_q, model.n_zones)
    out = {"DIC": d[:, :len(points), :len(displacements)].reshape(-1, model.n_zones) / DIC,
           "gauges": d[:, len(points):, len(displacements):].reshape(-1, model.n_zones) / GAUGE}
    if twist:
        label = solution.reaction_labels.index
        torque = solution.reactions[ends, label("nut_outer.torque")]
        out["torque + clamp"] = np.vstack([solution.d_reactions[ends, label("nut_outer.torque")] / (TORQUE * torque[:, None]),
                                           solution.d_reactions[ends, label("plate1_rim.y")] / CLAMP])
    return out


def standard_errors(J: np.ndarray, columns: list[list[int]]) -> np.ndarray:
    """Standard errors of the merged partition; inf for all when the observations do not determine it (fewer
    independent rows than unknowns: torque and clamp force of two stages cannot give six zones)."""
    merged = np.column_stack([J[:, c].sum(axis=1) for c in columns])
    singular = np.linalg.svd(merged, compute_uv=False)
    if len(singular) < merged.shape[1] or singular[-1] <= 1e-12 * singular[0]:
        return np.full(merged.shape[1], np.inf)
    return np.sqrt(np.diag(np.linalg.inv(merged.T @ merged)))


def main(flank: float = 0.2) -> None:
    zones = list(MU)
    partitions = {"A-F": [[zones.index(z)] for z in THREAD],
                  "thread, nut bearing": [[zones.index(z) for z in THREAD], [zones.index("nut_plate")]]}
    print(f"standard errors of mu (flank size {flank} mm); resolved: below 0.02")
    for load in ("tension", "tightening"):
        sets = rows(load, flank)
        combos = [["DIC"], ["DIC", "gauges"]] + ([["torque + clamp"], ["DIC", "gauges", "torque + clamp"]]
                                                  if load == "tightening" else [])
        for combo in combos:
            J = np.vstack([sets[k] for k in combo])
            for name, columns in partitions.items():
                if load == "tension" and name != "A-F":
                    continue                                 # the tensile test does not load the bearing in turn
                se = standard_errors(J, columns)
                labels = THREAD if name == "A-F" else ["thread", "nut_plate"]
                text = ", ".join(f"{z} {s:.3g}" for z, s in zip(labels, se))
                print(f"  {load:<10} {' + '.join(combo):<30} {name:<20} {text}")


if __name__ == "__main__":
    main(*[float(a) for a in sys.argv[1:2]])
