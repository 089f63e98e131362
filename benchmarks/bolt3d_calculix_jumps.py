"""The normal relative displacement across the thread's mortar pairs of a ccx solution on the separately meshed
M6 nut of tests/fixtures/bolt3d_calculix (mesh_separate.npz): B u for ccx's last displacement field, per zone, at
corner and mid-side nodes, against the pairs' initial (unadjusted) gaps.

Run from the repository's root: .venv/bin/python benchmarks/bolt3d_calculix_jumps.py DIR, DIR the --work folder
of `generate.py ccx --nut-mesh separate` (one kept ccx work directory inside it); --embedded prints the same for
the embedded solver's field (MUMPS, mu 0.15) as a control of the reading.
"""

import dataclasses
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from fixtures.bolt3d_calculix import MU, generate, mesh_file, options, stored_model  # noqa: E402
from frictionid.backends.calculix.parse import read_frd                         # noqa: E402
from frictionid.fem.interface import interface_pairs                             # noqa: E402
from frictionid.fem.problem import Problem                                       # noqa: E402
from frictionid.fem.space import Space                                           # noqa: E402


def report(label: str, model, pairs, u: np.ndarray, thread) -> np.ndarray:
    """Prints and returns the normal jumps [um] of the displacement field ``u`` (n_nodes, 3) [mm] at the thread's
    pairs (the mortar's B u: weighted means over each node's dual shape function, not pointwise gaps)."""
    jump = 1e3 * np.einsum("pk,pk->p", (pairs.B @ u.reshape(-1)).reshape(-1, 3), pairs.frames[:, 0, :])   # [um]
    gap = 1e3 * pairs.gap
    print(f"{label}: {pairs.n_pairs} thread pairs; initial gaps {gap.min():.3f} .. {gap.max():.3f} um; normal jump "
          f"{jump.min():.3f} .. {jump.max():.3f} um (positive open), mean {jump.mean():+.3f} um; correlation with "
          f"the initial gap {np.corrcoef(jump, gap)[0, 1]:+.3f}")
    zone = pairs.zone_share.argmax(axis=1)
    for z in np.unique(zone):
        m = zone == z
        print(f"  zone {model.zone_names[z]}: {m.sum()} pairs, jump mean {jump[m].mean():+.3f}, min "
              f"{jump[m].min():+.3f}, max {jump[m].max():+.3f} um, open by > 0.01 um: {(jump[m] > 0.01).sum()}")
    facets = np.vstack([model.mesh.boundaries[z] for z in thread.zones])
    for name, nodes in (("corner", facets[:, :3]), ("mid-side", facets[:, 3:])):
        m = np.isin(pairs.nodes, nodes)
        print(f"  {name} nodes: {m.sum()} pairs, jump RMS {np.sqrt(np.mean(jump[m] ** 2)):.3f} um")
    return jump


def main(work: Path, embedded: bool) -> None:
    model = stored_model(generate.calculix.layout_of(options("separate")), mesh_file("separate"))
    thread = dataclasses.replace(model.interfaces[0], adjust=False)
    raw = dataclasses.replace(model, interfaces=(thread,) + model.interfaces[1:])
    pairs, _ = interface_pairs(Space.build(raw.mesh, raw.kind), raw, 0)
    frd = read_frd(next(work.glob("*/job.frd")))
    last = [b for b in frd.blocks if b.name.startswith("DISP")][-1]
    u = np.zeros((raw.mesh.n_nodes, 3))
    u[last.nodes - 1] = last.values[:, :3]
    ccx = report("ccx", model, pairs, u, thread)
    if embedded:
        problem = Problem.build(model, factorisation="mumps")
        own = report("embedded", model, pairs, problem.displacement(problem.solve(np.full(model.n_zones, MU))), thread)
        zone = pairs.zone_share.argmax(axis=1)
        for z in np.unique(zone):
            d = (ccx - own)[zone == z]
            print(f"  ccx - embedded, zone {model.zone_names[z]}: mean {d.mean():+.3f}, "
                  f"RMS {np.sqrt(np.mean(d ** 2)):.3f}, min {d.min():+.3f}, max {d.max():+.3f} um")


if __name__ == "__main__":
    main(Path(sys.argv[1]), "--embedded" in sys.argv[2:])
