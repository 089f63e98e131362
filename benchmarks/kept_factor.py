"""`frictionid simulate` on the block twin's set-up (frictionid.studies.block) as tests/test_block_twin.py's fixture
runs it: wall and CPU time, the process's peak and the CHOLMOD factorisations made (docs/solver.md, "Condensation of
large models"). Usage: kept_factor.py id|data [FOLDER]; "data" is the finer data mesh (49.9k dofs), "id" the
identification mesh."""

import resource
import sys
import tempfile
import time
from pathlib import Path

from frictionid.config import read_config
from frictionid.fem import cholesky
from frictionid.simulation import simulate
from frictionid.studies import block as twin


def main(mesh: str, folder: Path) -> None:
    made = []
    original = cholesky.Cholesky._factor

    def counted(self):
        start = time.process_time()
        factor = original(self)
        made.append(time.process_time() - start)
        return factor

    cholesky.Cholesky._factor = counted
    folder.mkdir(parents=True, exist_ok=True)
    twin.write_points(folder / "points.csv")
    config = twin.config(folder, "truth", twin.DATA_MESH if mesh == "data" else twin.ID_MESH,
                         twin.goal_coefficients(), "points.csv")
    wall, cpu = time.perf_counter(), time.process_time()
    simulate(read_config(config), folder / "simulated.csv", print)
    print(f"simulate ({mesh} mesh): {time.perf_counter() - wall:.1f} s wall, {time.process_time() - cpu:.1f} s CPU, "
          f"peak {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6:.2f} GB; CHOLMOD factorisations "
          f"{len(made)} ({', '.join(f'{t:.1f}' for t in made)} s CPU)")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "id",
         Path(sys.argv[2]) if len(sys.argv) > 2 else Path(tempfile.mkdtemp(prefix="kept_factor_")))
