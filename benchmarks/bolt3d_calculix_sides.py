"""Which side of the M6 thread carries the contact unknowns, in both codes, on the moved separate-nut mesh
(benchmarks/bolt3d_calculix_moved.py): the embedded dual mortar with its multipliers on the nut's flank (the
builder's choice) or on the bolt's, ccx's SURFACE TO SURFACE pair with the nut's flank or the bolt's as slave.

mu is the same everywhere, so the thread's four zones can be one: with the bolt's side as the embedded contact
side the interface has one zone ("bolt_contact", coefficient A) on the target "nut_flank" (the nut's four zones'
facets); ccx's bolt-slave deck has one thread pair (slave "bolt_contact", master the nut's four zones as one
surface). Prints the ten points' uy and the machine's displacement of each solution, their differences (largest,
as % of the ten points' uy range), and with ``--gaps`` the thread's pointwise gaps after the load (at 7 points per
nut flank facet, as benchmarks/bolt3d_calculix_moved.py's ``pointwise_gaps`` places them): how far each solution
lets the two quadratic flanks overlap or open between their nodes.

Run (from the repository's root):
    nice -n 10 /usr/bin/time -v .venv/bin/python benchmarks/bolt3d_calculix_sides.py [--flank F]
    [--stiffness S] [--ccx nut bolt] [--work DIR] [--gaps]
--flank F builds the separate-nut model at flank_size F (gmsh; the fixture's other options) and moves it as
``moved_model`` does; default the stored mesh_moved.npz (flank 0.5). --ccx: the slave sides to run ccx with (none
by default; each run 15-30 min on this machine).
"""

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import bolt3d_calculix as calculix                       # noqa: E402
import bolt3d_calculix_moved as moved                    # noqa: E402
from fixtures import bolt3d_calculix as fixture          # noqa: E402
from frictionid.backends.calculix.backend import CalculixBackend, CalculixSettings     # noqa: E402
from frictionid.fem import space                         # noqa: E402
from frictionid.fem.problem import Problem               # noqa: E402

NUT_FLANK = "nut_flank"


def bolt_side_model(model):
    """The model with the thread's mortar multipliers on the bolt's flank: one zone "bolt_contact" (coefficient A),
    target the nut's four flank zones' facets as one boundary; for one mu on the whole flank only."""
    thread = model.interfaces[0]
    nut = np.vstack([model.mesh.boundaries[z] for z in thread.zones])
    mesh = dataclasses.replace(model.mesh, boundaries={**model.mesh.boundaries, NUT_FLANK: nut})
    swapped = dataclasses.replace(thread, zones=(thread.target,), target=NUT_FLANK, coefficients=(thread.zones[0],))
    return dataclasses.replace(model, mesh=mesh, interfaces=(swapped, *model.interfaces[1:]))


def bolt_slave(deck: str) -> str:
    """ccx's deck with the thread's four zone pairs (slave SZ1-SZ4, master ST1) replaced by one pair, slave the
    bolt's flank ST1 and master SNUT (the four zones' faces), with the first zone's interaction; the contact prints
    likewise."""
    lines = deck.split("\n")
    zones = {f"SZ{k}" for k in range(1, 5)}
    faces, out, k = [], [], 0
    while k < len(lines):
        line = lines[k]
        name = line.split("NAME=")[1].split(",")[0] if line.startswith("*SURFACE, NAME=") else None
        if name in zones:                               # keep the zone's surface, collect its faces
            out.append(line)
            k += 1
            while not lines[k].startswith("*"):
                faces.append(lines[k])
                out.append(lines[k])
                k += 1
            continue
        if line.startswith("*MATERIAL") and faces:
            out += ["** the nut's flank zones as one master surface", "*SURFACE, NAME=SNUT, TYPE=ELEMENT", *faces]
            faces = []
        if line.startswith("*CONTACT PAIR") and lines[k + 1].split(",")[0] in zones:
            if lines[k + 1].startswith("SZ1,"):
                out += [line, "ST1, SNUT"]
            k += 2
            continue
        if line.startswith("*CONTACT PRINT, SLAVE=") and line.split("SLAVE=")[1].split(",")[0] in zones:
            if "SLAVE=SZ1," in line:
                out += ["*CONTACT PRINT, SLAVE=ST1, MASTER=SNUT", lines[k + 1]]
            k += 2
            continue
        out.append(line)
        k += 1
    if "ST1, SNUT" not in out:
        raise ValueError("the deck has no contact pair SZ1, ST1 to turn around")
    return "\n".join(out)


class _BoltSlave(CalculixBackend):
    def deck(self, mu) -> str:
        return bolt_slave(super().deck(mu))


def embedded(model, points, regions):
    """Ten points and rim points (n, 3) [mm] and the displacement field at the load's end, ccx's 4-point rule."""
    product = space.INTORDER["tetra10"]
    space.INTORDER["tetra10"] = 2
    try:
        problem = Problem.build(model, points=points, quantities=calculix.QUANTITIES, regions=regions,
                                factorisation="mumps")
        solution = problem.solve(np.full(model.n_zones, fixture.MU))
    finally:
        space.INTORDER["tetra10"] = product
    end = solution.stage_end(model.n_stages - 1)
    return solution.observations[end].reshape(len(points), 3), problem.displacement(solution, end)


def ccx(model, points, regions, stiffness: float, slave: str, work: str | None):
    settings = CalculixSettings(normal_stiffness=stiffness, stick_slope=stiffness, timeout=9000, work_dir=work,
                                keep_work=work is not None)
    kind = CalculixBackend if slave == "nut" else _BoltSlave
    backend = kind(model, points, calculix.QUANTITIES, regions, settings)
    solution = backend.solve(np.full(model.n_zones, fixture.MU), full_field=True)
    print(f"  ccx, slave the {slave}'s flank, S = {stiffness:g}: {solution.wall_time:.0f} s wall", flush=True)
    return solution.observations[-1].reshape(len(points), 3), solution.displacement[-1]


def deformed_gaps(model, fields: dict, degree: int = 5) -> dict:
    """The thread's normal gaps [mm] at ``degree``'s triangle points on each nut flank facet after the load: the
    initial pointwise gap (``pointwise_gaps``) plus the relative displacement of the bolt's flank (at the point's
    projection along the nut facet's normal) and the nut's, along that normal; per field of ``fields``."""
    found = moved.flank_projection(model, degree)
    target = model.mesh.boundaries[model.interfaces[0].target]
    on_bolt = moved._shape(found["at"])
    out = {"initial": found["gap"]}
    for name, u in fields.items():
        u_nut = np.einsum("qk,fkd->fqd", found["N"], u[found["nut"]]).reshape(-1, 3)
        u_bolt = np.einsum("qk,qkd->qd", on_bolt, u[target[found["facet"]]])
        out[name] = found["gap"] + np.einsum("qd,qd->q", u_bolt - u_nut, found["normal"])
    return out


def main(flank: float | None, stiffness: float, slaves: list[str], work: str | None, gaps: bool) -> None:
    start = time.process_time()
    if flank is None:
        model = fixture.nut_model(calculix.layout_of(fixture.OPTIONS), "moved")
    else:
        from frictionid.builders.bolt import bolt_model
        model = moved.moved_model(model=bolt_model(**{**fixture.options("separate"), "flank_size": flank}))
    print(f"moved separate-nut M6, flank_size {flank or fixture.OPTIONS['flank_size']}: {model.mesh.n_nodes:,} nodes "
          f"({time.process_time() - start:.0f} s CPU), mu {fixture.MU} everywhere, 1,500 N", flush=True)
    points, regions = calculix.observed(fixture.OPTIONS)
    results, fields = {}, {}
    for name, case in (("embedded, nut side", model), ("embedded, bolt side", bolt_side_model(model))):
        start = time.process_time()
        results[name], fields[name] = embedded(case, points, regions)
        print(f"  {name}: {time.process_time() - start:.0f} s CPU", flush=True)
    for slave in slaves:
        name = f"ccx {stiffness:g}, {slave} slave"
        results[name], fields[name] = ccx(model, points, regions, stiffness, slave, work)
    print("uy [um] at the ten points (P1-P5 of flanks 1 and 2) and the machine's displacement (plate 1's rim):")
    for name, u in results.items():
        print(f"  {name:22s}" + "".join(f"{1e3 * v:8.4f}" for v in u[:10, 1]) + f" | {1e3 * u[10:, 1].mean():8.4f}")
    names = list(results)
    for k, a in enumerate(names):
        for b in names[k + 1:]:
            d = results[b][:10, 1] - results[a][:10, 1]
            span = np.ptp(results[a][:10, 1])
            machine = results[b][10:, 1].mean() / results[a][10:, 1].mean() - 1
            print(f"  {b} - {a}: {1e6 * d.min():+.1f} .. {1e6 * d.max():+.1f} nm, largest "
                  f"{100 * np.abs(d).max() / span:.2f} % of the range ({1e3 * span:.3f} um); machine "
                  f"{100 * machine:+.3f} %")
    if gaps:
        found = deformed_gaps(model, fields)
        ok = np.isfinite(found["initial"])
        print("the thread's pointwise gaps [nm] at 7 points per nut flank facet, percentiles 0 / 1 / 5 / 50 / 95 / 99 "
              "/ 100 (negative: overlap):")
        for name, g in found.items():
            print(f"  {name:22s}" + " ".join(f"{v:+7.1f}" for v in np.percentile(1e6 * g[ok], [0, 1, 5, 50, 95, 99,
                                                                                            100])))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--flank", type=float, default=None, help="flank_size [mm] of a fresh build (default: the "
                        "stored mesh_moved.npz, 0.5)")
    parser.add_argument("--stiffness", type=float, default=1e8, help="ccx's normal and stick slope [N/mm^3]")
    parser.add_argument("--ccx", nargs="*", default=[], choices=("nut", "bolt"), help="ccx's slave sides to run")
    parser.add_argument("--work", default=None, help="keep ccx's work directories in this folder")
    parser.add_argument("--gaps", action="store_true", help="the pointwise gaps after the load of each solution")
    a = parser.parse_args()
    main(a.flank, a.stiffness, a.ccx, a.work, a.gaps)
