"""How the thread load shares of the M20 model depend on what the nut bears on (the load-share check of the thread model).

docs/models.md's set-up pulls plate 1 at its outer rim (r = 40) while the nut bears on it next to the hole; the classic
25-35 % first-thread share (Sopwith, lam P about 0.3-0.45) assumes a nut on a stiff, radially holding bearing.
This study solves the default model (thread zones 0.1, head-plate 0.15) for three supports of the nut's plate
and three nut-plate friction coefficients and prints the per-thread shares with the fitted lam P:

- "DESIGN": plate 2's rim held, the machine force on plate 1's rim (the default model);
- "backed": plate 1's bottom face held, the machine force on plate 2's rim (a plate on a rigid table);
- "rigid": as DESIGN, plate 1 a thousand times stiffer (the paper's Ansys model held the nut's plate fixed).

With --calculix it also solves the default model with one zone per engaged flank in CalculiX (CAX6, same mesh)
and prints both backends' per-flank normal-force shares.

Run: .venv/bin/python examples/bolt-m20/load_shares.py [--flank-size 0.25] [--calculix]
"""

import argparse
import dataclasses

import numpy as np

from frictionid.builders.bolt import PLATE_MU, STEEL, bolt_model
from frictionid.fem.problem import Problem
from frictionid.model import Material, Support
from frictionid.report.bolt import thread_loads

FLANK_MU = 0.1


def variants(flank_size: float) -> dict:
    model = bolt_model(flank_size=flank_size)
    force = model.loads[0]
    backed = dataclasses.replace(
        model, supports=(Support("plate1_bottom", (0, 1)),),
        loads=(dataclasses.replace(force, boundary="plate2_rim", values=tuple(-v for v in force.values)),))
    stiff = Material(E=1000 * STEEL.E, nu=STEEL.nu, name="rigid steel")
    rigid = dataclasses.replace(model, materials={**model.materials, "plate1": stiff})
    return {"DESIGN": model, "backed": backed, "rigid": rigid}


def coefficients(model, nut_plate: float) -> dict:
    mu = {zone: FLANK_MU for zone in model.zone_names}
    mu.update(head_plate=PLATE_MU, nut_plate=nut_plate)
    return mu


def share_table(flank_size: float) -> str:
    rows = ["| nut's plate | nut-plate mu | shares of threads 1-7 [%] | lam P | monotone |", "|---|---|---|---|---|"]
    for name, model in variants(flank_size).items():
        problem = Problem.build(model)
        for nut_plate in (0.0, PLATE_MU, 1.0):
            loads = thread_loads(model, problem.solve(coefficients(model, nut_plate)))
            shares = " / ".join(f"{100 * s:.1f}" for s in loads.share)
            monotone = "yes" if np.all(np.diff(loads.share) < 0) else "no"
            rows.append(f"| {name} | {nut_plate:g} | {shares} | {loads.lam_p:.3f} | {monotone} |")
    return "\n".join(rows)


def calculix_table(flank_size: float) -> str:
    from frictionid.backends.calculix.backend import CalculixBackend, CalculixSettings

    model = bolt_model(flank_size=flank_size, n_radial=1, n_axial=7)
    mu = coefficients(model, PLATE_MU)
    x = np.array([mu[zone] for zone in model.zone_names])
    solution = Problem.build(model).solve(x)
    embedded = solution.zone_normal_force[solution.stage_end(model.n_stages - 1)][:7]
    ccx = CalculixBackend(model, None, ("uy",), None, CalculixSettings()).solve(x, full_field=False)
    other = ccx.zone_normal_force[-1][:7]
    rows = ["| flank | embedded N [N] | CalculiX N [N] | embedded share [%] | CalculiX share [%] |",
            "|---|---|---|---|---|"]
    rows += [f"| {i + 1} | {a:.0f} | {b:.0f} | {100 * a / embedded.sum():.2f} | {100 * b / other.sum():.2f} |"
             for i, (a, b) in enumerate(zip(embedded, other))]
    return "\n".join(rows) + f"\n\nCalculiX: {ccx.wall_time:.0f} s per solve, {model.mesh.n_nodes} nodes."


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--flank-size", type=float, default=0.25, help="[mm] element size on the engaged flanks")
    parser.add_argument("--calculix", action="store_true", help="also compare per-flank loads with CalculiX")
    args = parser.parse_args()
    print(f"M20, 30 kN, thread zones mu = {FLANK_MU}, head-plate {PLATE_MU}, flank size {args.flank_size} mm\n")
    print(share_table(args.flank_size))
    if args.calculix:
        print("\nDESIGN set-up, nut-plate 0.15, one zone per engaged flank: flank normal forces\n")
        print(calculix_table(args.flank_size))
