"""CPU time per phase of a run, read from cProfile's counts with the process's CPU time as its clock (all threads:
MUMPS's and BLAS's work included). A phase is a function's cumulative time, optionally only where one caller
called it; the profiler adds a little to Python-heavy code (the kernels that dominate run in C)."""

import cProfile
import pstats
import time
from contextlib import contextmanager

#: (label, [(path suffix, function name, caller's function name or None), ...]) per part of a bolt3d.py run; the
#: label's leading spaces mark a part of the row above (rows of one level are disjoint as far as the code goes)
PHASES = {
    "build": [
        ("bolt_model: gmsh CAD and meshing, curved nodes, model", [("builders/bolt.py", "bolt_model", None)]),
        ("  gmsh meshing (generate)", [("gmsh.py", "generate", None)]),
        ("  gmsh CAD (cut, fragment)", [("gmsh.py", "cut", None), ("gmsh.py", "fragment", None)]),
        ("  curved mid-side nodes", [("builders/curved.py", "curved_where_valid", None)]),
    ],
    "Problem.build": [
        ("space (scikit-fem bases, dof maps)", [("fem/space.py", "build", "model_space")]),
        ("stiffness assembly", [("fem/assembly.py", "stiffness", None)]),
        ("contact pairs", [("fem/interface.py", "contact_pairs", None)]),
        ("observation operator", [("fem/points.py", "point_operator", None)]),
        ("load channels", [("fem/assembly.py", "load_channels", None)]),
        ("condensation", [("fem/condense.py", "condense", None)]),
        ("  partition of K", [("fem/condense.py", "partition", None)]),
        ("  MUMPS analysis + factorisation", [("fem/mumps_schur.py", "_call", "_factor_timed")]),
        ("  Schur complements' Cholesky", [("scipy/linalg/_decomp_cholesky.py", "cholesky", None)]),
        ("  particular solutions (MUMPS solves)", [("fem/condense.py", "solve", "condense")]),
        ("  W, G from the Schur factors", [("fem/condense.py", "_from_schur", None)]),
        ("    S^-1 (potri)", [("fem/cholesky.py", "inverse", None)]),
        ("    triangular solves (before: L^-1 T^T)", [("scipy/linalg/_basic.py", "solve_triangular", None)]),
    ],
    "solve": [
        ("stuck inverse (once per model)", [("fem/loadpath.py", "stuck_inverses", None)]),
        ("Newton (contact.newton)", [("fem/contact.py", "newton", None)]),
        ("predictors", [("fem/loadpath.py", "_predictor", None)]),
        ("sensitivities (DDM solves)", [("fem/loadpath.py", "_sensitivity", None)]),
        ("small-sliding check", [("fem/problem.py", "check_small_sliding", None)]),
        ("outputs (Solution)", [("fem/problem.py", "_solution", None)]),
        ("kernels across the above:", []),
        ("  capacitance LU (fresh)", [("fem/capacitance.py", "factorise", None)]),
        ("  capacitance updates", [("fem/capacitance.py", "build", None)]),
        ("  GMRES (iterated solves)", [("fem/capacitance.py", "gmres", None)]),
        ("  forming capacitance matrices", [("fem/replaced_rows.py", "capacitance", None)]),
        ("  products with A or W", [("fem/updated_jacobian.py", "times", None)]),
        ("  linearisations", [("fem/contact.py", "linearise", None)]),
    ],
}


class Phases:
    """Profiles of the parts of a run, each its own (:meth:`part`), and their table (:meth:`table`)."""

    def __init__(self):
        self.parts: dict[str, tuple[pstats.Stats, float, float]] = {}

    @contextmanager
    def part(self, name: str):
        """Profile the block as part ``name`` (its CPU and wall time kept beside)."""
        profile = cProfile.Profile(time.process_time)
        cpu, wall = time.process_time(), time.perf_counter()
        profile.enable()
        try:
            yield
        finally:
            profile.disable()
            self.parts[name] = (pstats.Stats(profile), time.process_time() - cpu, time.perf_counter() - wall)

    @staticmethod
    def cumulative(stats: pstats.Stats, path: str, function: str, caller: str | None) -> tuple[float, int]:
        """CPU seconds in ``function`` of a file ending in ``path`` (all its callers, or only ``caller``) and its
        number of calls."""
        total, calls = 0.0, 0
        for (filename, _, name), (_, nc, _, ct, callers) in stats.stats.items():
            if not (filename.endswith(path) and name == function):
                continue
            if caller is None:
                total, calls = total + ct, calls + nc
            else:
                edges = [edge for (_, _, called_by), edge in callers.items() if called_by == caller]
                total, calls = total + sum(e[3] for e in edges), calls + sum(e[1] for e in edges)
        return total, calls

    def table(self, spec: dict = PHASES, kinds: dict | None = None) -> str:
        """One line per phase: CPU seconds, share of its part and calls; ``kinds`` maps a part's name to its spec
        key."""
        lines = []
        for name, (stats, cpu, wall) in self.parts.items():
            lines.append(f"{name}: {cpu:.2f} s CPU ({wall:.2f} s wall)")
            for label, functions in spec[(kinds or {}).get(name, name)]:
                if not functions:
                    lines.append(f"    {label}")
                    continue
                found = [self.cumulative(stats, *f) for f in functions]
                seconds, calls = sum(f[0] for f in found), sum(f[1] for f in found)
                if seconds > 0:
                    lines.append(f"    {label:<48} {seconds:8.2f} s  {100 * seconds / max(cpu, 1e-12):5.1f} %  "
                                 f"{calls:6d} calls")
        return "\n".join(lines)
