"""Condensation time and peak memory against dofs, SuperLU, CHOLMOD and MUMPS side by side (3-D block, builder defaults).

Each model size and factorisation runs in a process of its own, as a user runs it (no thread settings), so that
its peak memory is its own. Printed per run: dofs, contact unknowns n_w, condensation time (the call of
fem.condense.condense, wall clock, and the CPU time of all the process's threads: less than the wall time when
other work shares the cores), the process's resident memory before condensing and its peak while
condensing (sampled every 10 ms), and where both factorisations ran the largest difference of their operators
(as tests/test_condense.py measures it).

Run: .venv/bin/python benchmarks/condensation.py [--sizes 1.0 0.7 0.5 0.4 0.34] [--superlu-max-dofs 60000] [--mumps]
SuperLU is skipped above --superlu-max-dofs (default 60,000: it took 220 s at 89k dofs on an idle machine).
--mumps adds factorisation = "mumps" (fem/mumps_schur.py) and its largest difference from CHOLMOD.
"""

import argparse
import json
import os
import pickle
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from types import SimpleNamespace

HERE = Path(__file__).resolve().parent
PAGE = os.sysconf("SC_PAGE_SIZE")


def resident_mb() -> float:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * PAGE / 2**20


class PeakMemory:
    """Largest resident memory of this process [MB] while the block runs, sampled every 10 ms."""

    def __enter__(self):
        self.peak, self._stop = resident_mb(), threading.Event()
        self._thread = threading.Thread(target=self._sample, daemon=True)
        self._thread.start()
        return self

    def _sample(self):
        while not self._stop.wait(0.01):
            self.peak = max(self.peak, resident_mb())

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        self.peak = max(self.peak, resident_mb())


def condensation_inputs(mesh_size: float):
    """The arguments Problem.build passes to condense for the default 3-D block at ``mesh_size`` [mm]."""
    from frictionid.builders.block import block_model
    from frictionid.fem import problem

    class Captured(Exception):
        pass

    def capture(*args, **kwargs):
        raise Captured(args)

    original, problem.condense = problem.condense, capture
    try:
        problem.Problem.build(block_model(mesh_size=mesh_size))
    except Captured as captured:
        return captured.args[0]
    finally:
        problem.condense = original


def one(mesh_size: float, factorisation: str, keep: str | None) -> dict:
    """Condense once in this process; the operators are pickled to ``keep`` for the comparison."""
    from frictionid.fem.condense import condense
    args = condensation_inputs(mesh_size)
    before = resident_mb()
    with PeakMemory() as memory:
        start, cpu = time.perf_counter(), time.process_time()
        condensed = condense(*args, factorisation=factorisation)
        seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    if keep:
        from test_condense import reaction_terms
        operators = SimpleNamespace(**{name: getattr(condensed, name) for name in (
            "gap_ops", "obs_ops", "reac_ops", "equilibrium", "particular")})
        with open(keep, "wb") as file:
            pickle.dump((operators, reaction_terms(condensed, args)), file)
    return {"dofs": args[0].shape[0], "n_w": args[1].shape[0], "seconds": seconds, "cpu": cpu, "before_mb": before,
            "peak_mb": memory.peak}


def difference(first: str, second: str) -> float:
    """Largest difference of two runs' operators, as tests/test_condense.py measures it: relative to each
    operator's largest entry, the reactions' channels relative to the nodal reactions they add up at least."""
    from test_condense import relative_difference
    with open(first, "rb") as a, open(second, "rb") as b:
        (a, floor), (b, _) = pickle.load(a), pickle.load(b)
    return relative_difference(a, b, floor)


def run(mesh_size: float, factorisation: str, keep: str) -> dict:
    out = subprocess.run([sys.executable, __file__, "--one", str(mesh_size), factorisation, keep],
                         capture_output=True, text=True, check=True, timeout=7200)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=float, nargs="+", default=[1.0, 0.7, 0.5, 0.4, 0.34])
    parser.add_argument("--superlu-max-dofs", type=int, default=60000)
    parser.add_argument("--mumps", action="store_true")
    parser.add_argument("--one", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:
        print(json.dumps(one(float(args.one[0]), args.one[1], args.one[2] or None)))
        return
    print("3-D block, builder defaults (graded, incompatible modes); condensation wall time and resident memory "
          f"({os.cpu_count()} cores, machine as it is, no thread settings)")
    print(f"{'mesh':>5} {'dofs':>8} {'n_w':>5} | {'SuperLU s':>9} {'cpu s':>7} {'peak MB':>8} | {'CHOLMOD s':>9} "
          f"{'cpu s':>7} {'peak MB':>8} {'before MB':>9} | {'max rel diff':>12}"
          + (f" | {'MUMPS s':>9} {'cpu s':>7} {'peak MB':>8} {'diff CHOLMOD':>12}" if args.mumps else ""))
    with tempfile.TemporaryDirectory() as folder:
        for size in args.sizes:
            chol = run(size, "cholmod", f"{folder}/cholmod.pkl")
            lu_cells, diff = f"{'skipped':>9} {'':>7} {'':>8}", ""
            if chol["dofs"] <= args.superlu_max_dofs:
                lu = run(size, "superlu", f"{folder}/superlu.pkl")
                lu_cells = f"{lu['seconds']:9.2f} {lu['cpu']:7.2f} {lu['peak_mb']:8.0f}"
                diff = f"{difference(f'{folder}/superlu.pkl', f'{folder}/cholmod.pkl'):12.1e}"
            mumps_cells = ""
            if args.mumps:
                mumps = run(size, "mumps", f"{folder}/mumps.pkl")
                mumps_cells = (f" | {mumps['seconds']:9.2f} {mumps['cpu']:7.2f} {mumps['peak_mb']:8.0f} "
                               f"{difference(f'{folder}/cholmod.pkl', f'{folder}/mumps.pkl'):12.1e}")
            print(f"{size:5.2f} {chol['dofs']:8d} {chol['n_w']:5d} | {lu_cells} | {chol['seconds']:9.2f} "
                  f"{chol['cpu']:7.2f} {chol['peak_mb']:8.0f} {chol['before_mb']:9.0f} | {diff:>12}{mumps_cells}",
                  flush=True)


if __name__ == "__main__":
    sys.path[:0] = [str(HERE), str(HERE.parent / "tests")]
    main()
