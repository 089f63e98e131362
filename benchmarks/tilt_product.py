"""The block's tilt at the truth in frictionid's embedded solver on a mesh sequence (issue 31; see tilt_ccx.py).

Reference test 1 at A 0.35, B 0.20, C 0.45, D 0.15 (20 MPa, pull 0.2 mm), ``block`` builder options per
candidate (``key=value,...``, "" the default). Printed per candidate (one JSON line, also appended to ``--out``):
nodes, condensation time and peak memory of its own process, and at the end of the pull

- tilt: uz(0, -5, 5) - uz(0, 5, 5) [um]; N_A, N_B, N_C, N_D: zone normal forces [N];
- uy at (+-5, 0, 1) [um]; the machine force [N].

Run (each candidate in a fresh process, one at a time):
    .venv/bin/python benchmarks/tilt_product.py "" "mesh_size=0.7" "mesh_size=0.5"
"""

from __future__ import annotations

import argparse
import multiprocessing
import sys
from pathlib import Path

import numpy as np

from _measure import emit, peak_memory_mb, timed
from block_strains import options_of
from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.registry import build_model
from frictionid.options import ModelSpec

MU = np.array([0.35, 0.20, 0.45, 0.15])
POINTS = np.array([[0.0, -5.0, 5.0], [0.0, 5.0, 5.0], [-5.0, 0.0, 1.0], [5.0, 0.0, 1.0]])
QUANTITIES = ("uy", "uz")
REACTION = "block_top.y"
#: the plane-strain analogue (builder block2d: x the pull, y up; zones A rear, B front): the 3-D zones' means
MU_2D = np.array([0.275, 0.30])
POINTS_2D = np.array([[-5.0, 5.0], [5.0, 5.0], [-5.0, 1.0], [5.0, 1.0]])
QUANTITIES_2D = ("ux", "uy")
REACTION_2D = "block_top.x"


def evaluate(spec: str, ccx_scale: float | None = None) -> dict:
    """The figures of one candidate: embedded, or ccx on the same mesh at ``ccx_scale`` of the loads."""
    from frictionid.backends.calculix.backend import CalculixBackend, CalculixSettings

    figures = {}
    model = build_model(ModelSpec.from_table(options_of(spec)))
    flat = model.kind != "3d"
    points, quantities, reaction = (POINTS_2D, QUANTITIES_2D, REACTION_2D) if flat else (POINTS, QUANTITIES, REACTION)
    mu = MU_2D if flat else MU
    with timed(figures, "condensation"):
        if ccx_scale is None:
            backend = EmbeddedBackend(model, points, quantities, ["block"] * len(points), (reaction,), keep=False)
        else:
            backend = CalculixBackend(model, points, quantities, ["block"] * len(points),
                                      CalculixSettings(load_scale=ccx_scale), reactions=(reaction,))
    if ccx_scale is None:
        values = backend.predict(mu).values[-1]          # the last stage: end of the pull
        normal = [v["normal_force"] for v in backend.contact_states(mu)[-1].values()]
    else:
        solution = backend.solve(mu, full_field=False)
        values = np.append(solution.observations[-1], solution.reactions[-1][backend._reaction_rows])
        normal = solution.zone_normal_force[-1].tolist()
    along, up = values[0:-1:2], values[1:-1:2]
    return {"spec": spec, "code": "embedded" if ccx_scale is None else f"ccx x{ccx_scale:g}",
            "nodes": model.mesh.n_nodes, "seconds": round(figures["condensation"], 1),
            "peak_mb": round(peak_memory_mb()), "tilt_um": 1e3 * (up[0] - up[1]),
            "N": dict(zip(model.zone_names, np.round(normal, 2).tolist())),
            "u_along_rear_z1_um": 1e3 * along[2], "u_along_front_z1_um": 1e3 * along[3],
            "force": float(values[-1])}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("candidates", nargs="+", help="block builder options key=value,... ('' the default)")
    parser.add_argument("--out", type=Path, help="append each result as a JSON line here")
    parser.add_argument("--ccx", type=float, nargs="*", default=[],
                        help="also ccx on each candidate's own mesh at these load scales (0.01: small sliding)")
    args = parser.parse_args(argv)
    for spec in args.candidates:
        for scale in [None, *args.ccx]:
            with multiprocessing.get_context("spawn").Pool(1) as pool:
                result = pool.apply(evaluate, (spec, scale))
            emit(result, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
