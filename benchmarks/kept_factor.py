"""Displacements after the condensation without factorising the stiffness again (docs/solver.md, "Condensation of
large models"): the factorisations a run makes, its times and its peak.

Usage: kept_factor.py MODE [FOLDER]
- "id" / "data": `frictionid simulate` on the block twin's set-up (frictionid.studies.block) as
  tests/test_block_twin.py's fixture runs it, on the identification mesh / the finer data mesh (49.9k dofs);
- "m6": the M6 3-D bolt of tests/test_bolt3d_verification.py (SMALL) with `factorisation = "mumps"` through the
  embedded backend: build, predict with sensitivities, the small-sliding check, fields;
- "m6-keep": the same with MUMPS's factors of the interiors never freed (what keeping them costs);
- "m6-simulate-mumps" / "m6-simulate-cholmod": `frictionid simulate` on that M6 with 3 points, fields written.
"""

import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from frictionid.fem import cholesky, mumps_schur

#: tests/test_bolt3d_verification.py's SMALL
M6 = {"size": "M6", "model": "3d", "length": 24.0, "engaged_length": 2.0, "thread_length": 9.5, "n_axial": 2,
      "flank_size": 1.0, "contact_size": 3.0, "root_size": 0.3, "mesh_size": 4.0, "forces": [1500.0],
      "n_increments": 1, "cutout": False, "jaws": False}


def _counted(made: list) -> None:
    """Record every factorisation: CHOLMOD's ("cholmod", s CPU), MUMPS's (dofs, Schur dofs, s CPU)."""
    cholmod, mumps = cholesky.Cholesky._factor, mumps_schur.SchurFactor._factor_timed

    def cholmod_counted(self):
        start = time.process_time()
        factor = cholmod(self)
        made.append(("cholmod", round(time.process_time() - start, 2)))
        return factor

    def mumps_counted(self):
        start = time.process_time()
        out = mumps(self)
        made.append((self.n, len(self.schur_dofs), round(time.process_time() - start, 2)))
        return out

    cholesky.Cholesky._factor, mumps_schur.SchurFactor._factor_timed = cholmod_counted, mumps_counted


def _peak() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6


def twin(mesh: str, folder: Path, made: list) -> None:
    from frictionid.config import read_config
    from frictionid.simulation import simulate
    from frictionid.studies import block as study
    folder.mkdir(parents=True, exist_ok=True)
    study.write_points(folder / "points.csv")
    config = study.config(folder, "truth", study.DATA_MESH if mesh == "data" else study.ID_MESH,
                          study.goal_coefficients(), "points.csv")
    wall, cpu = time.perf_counter(), time.process_time()
    simulate(read_config(config), folder / "simulated.csv", print)
    print(f"simulate ({mesh} mesh): {time.perf_counter() - wall:.1f} s wall, {time.process_time() - cpu:.1f} s CPU, "
          f"peak {_peak():.2f} GB; factorisations {made}")


def m6(keep: bool, made: list) -> None:
    from frictionid.backends.embedded import EmbeddedBackend
    from frictionid.builders.bolt import bolt_model
    if keep:
        mumps_schur.SchurFactor.free = lambda self, schur=False: None
    model = bolt_model(**M6)
    cpu = time.process_time()
    backend = EmbeddedBackend(model, None, (), factorisation="mumps", keep=False)
    print(f"M6, {model.mesh.n_nodes} nodes: build {time.process_time() - cpu:.1f} s CPU, factorisations {made}, "
          f"peak {_peak():.2f} GB")
    mu, seen = np.full(len(model.zone_names), 0.15), len(made)
    for what, call in (("predict", lambda: backend.predict(mu, sensitivities=True)),
                       ("check", lambda: backend.check_sliding(mu)), ("fields", lambda: backend.fields(mu))):
        wall, cpu = time.perf_counter(), time.process_time()
        call()
        print(f"{what}: {time.process_time() - cpu:.1f} s CPU, {time.perf_counter() - wall:.1f} s wall, "
              f"factorisations {made[seen:]}, peak {_peak():.2f} GB")
        seen = len(made)


def m6_simulate(factorisation: str, folder: Path, made: list) -> None:
    from frictionid.cli import main
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "points.csv").write_text("point,x,y,z,stage\nP1,0.5,5.0,0.0,1\nP2,0.0,10.0,0.5,1\nP3,0.5,15.0,0.5,1\n")
    model = "\n".join(f"{k} = {str(v).lower() if isinstance(v, bool) else repr(v)}" for k, v in M6.items())
    (folder / "m6.toml").write_text(
        f'[model]\nbuilder = "bolt"\n{model}\n[friction]\nzones = {{ A = 0.15, B = 0.15, C = 0.15, D = 0.15 }}\n'
        f'fixed = {{ head_plate = 0.15, nut_plate = 0.15 }}\n[solver]\nfactorisation = "{factorisation}"\n'
        '[data]\nfile = "points.csv"\nobservables = ["ux", "uy", "uz"]\nstages = [1]\n')
    wall, cpu = time.perf_counter(), time.process_time()
    assert main(["simulate", str(folder / "m6.toml"), "--out", str(folder / "simulated.csv")]) == 0
    print(f"simulate (M6, {factorisation}): {time.perf_counter() - wall:.1f} s wall, "
          f"{time.process_time() - cpu:.1f} s CPU, peak {_peak():.2f} GB; factorisations {made}")


if __name__ == "__main__":
    mode = sys.argv[1] if len(sys.argv) > 1 else "id"
    factorisations = []
    _counted(factorisations)
    if mode in ("id", "data"):
        twin(mode, Path(sys.argv[2]) if len(sys.argv) > 2 else Path(tempfile.mkdtemp(prefix="kept_factor_")),
             factorisations)
    elif mode in ("m6", "m6-keep"):
        m6(mode == "m6-keep", factorisations)
    elif mode.startswith("m6-simulate-"):
        m6_simulate(mode.rsplit("-", 1)[1], Path(sys.argv[2]) if len(sys.argv) > 2 else
                    Path(tempfile.mkdtemp(prefix="kept_factor_")), factorisations)
    else:
        sys.exit(f"unknown mode {mode!r}: id, data, m6, m6-keep, m6-simulate-mumps or m6-simulate-cholmod")
