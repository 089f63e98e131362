"""Where a forward + sensitivities solve of the dense contact path spends its time, against the number of contact
dofs n_w: the product's load path (fem/loadpath.py, its stuck inverses and corrected solves) on the synthetic
half-space interface of benchmarks/halfspace.py (a flat punch pressed on a flat at zero gap, then pulled into gross
slip: stick, partial slip, gross slip and an open rim; four zones), one size per process.

Each solve runs as Problem.solve runs it (one BLAS thread; the model's stuck inverse made at the first solve and
kept). Printed per size: the interface's states and its checks (sum lam_N against the press force P; in gross slip
sum |lam_T| against mu sum lam_N), then per solve the CPU time of
each part (own time, without the parts it calls) and the process's peak resident memory. ``--solves 2`` solves
twice with the same model: the second is what each later solve of a fit costs. ``--paths old new`` solves with
each path in turn, the model's stuck inverse made anew for each, and prints the largest differences of their
results relative to each field's largest value: "old" the stuck inverse by LU and every capacitance matrix that
no low-rank update serves factorised afresh (fem/updated_jacobian.py ``STUCK = "lu"``, ``ITERATE = "never"``),
"new" the product's default (the stuck inverse from the Cholesky factor, iterated capacitance solves, capacitance
factorisations of many rows in single precision with refined solves: fem/capacitance.py ``PRECISION = "mixed"``),
"double" the same in double precision, "cholesky" the new stuck inverse with fresh double factorisations,
"one-thread" the new path with every factorisation on one BLAS thread (fem/threads.py ``LARGE`` raised: the
product gives factorisations of ``LARGE`` rows or more the threads the process had before the solve).

Run: .venv/bin/python benchmarks/contact_loadpath.py 3000 6000 9000 [--solves 2] [--paths old new]
"""

from __future__ import annotations

import argparse
import collections
import functools
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from halfspace import Interface  # noqa: E402

from frictionid.fem import capacitance, contact, loadpath, threads, updated_jacobian  # noqa: E402
from frictionid.fem.contact import OPEN, SLIP  # noqa: E402
from frictionid.fem.memory import process_peak  # noqa: E402
from frictionid.fem.threads import one_blas_thread  # noqa: E402

#: the parts timed: (owner, attribute, label)
PARTS = (
    (updated_jacobian.StuckInverse, "build", "stuck inverse (per model)"),
    (capacitance.Fresh, "factorise", "capacitance LU factorisations"),
    (capacitance.Fresh, "solve", "capacitance solves (single factors refined)"),
    (capacitance.Fresh, "double", "capacitance double factorisations after single"),
    (capacitance.Updated, "build", "capacitance updates"),
    (capacitance, "gmres", "capacitance iterated solves (GMRES)"),
    (updated_jacobian.UpdatedSolver, "_factorised", "capacitance matrices: gathers, other"),
    (updated_jacobian.UpdatedSolver, "_corrected", "corrected solves: products with A, C solves"),
    (contact, "linearise", "linearising (a product with W each)"),
    (updated_jacobian.UpdatedSolver, "product", "residual checks (a product with W)"),
    (loadpath.LoadPathSolver, "_sensitivity", "sensitivity right-hand sides"),
    (loadpath.LoadPathSolver, "step", "the rest of the load path"),
)


class Parts:
    """CPU time of each part, its own only (the parts it calls subtracted), by wrapping the methods."""

    def __init__(self):
        self.own = collections.defaultdict(float)
        self.calls = collections.Counter()
        self._inner: list[float] = []
        self._originals = []

    def __enter__(self):
        for owner, attr, label in PARTS:
            method = owner.__dict__[attr]
            self._originals.append((owner, attr, method))
            setattr(owner, attr, self._timed(method, label))
        return self

    def __exit__(self, *exc):
        for owner, attr, method in self._originals:
            setattr(owner, attr, method)

    def _timed(self, method, label):
        is_class = isinstance(method, classmethod)
        function = method.__func__ if is_class else method

        @functools.wraps(function)
        def wrapper(*args, **kwargs):
            start = time.process_time()
            self._inner.append(0.0)
            try:
                return function(*args, **kwargs)
            finally:
                spent = time.process_time() - start
                self.own[label] += spent - self._inner.pop()
                self.calls[label] += 1
                if self._inner:
                    self._inner[-1] += spent
        return classmethod(wrapper) if is_class else wrapper


def solve(interface: Interface, mu_zone: np.ndarray, stuck) -> dict:
    """Forward + sensitivities along the interface's load path, as Problem._solve runs it."""
    c, pairs = interface.condensed, interface.pairs
    with one_blas_thread():
        if stuck is None:
            stuck = loadpath.stuck_inverses(c, pairs)
        solver = loadpath.LoadPathSolver(c, pairs, stuck=stuck)
        path, previous, mu = solver.start(), np.zeros(2), pairs.mu(mu_zone)
        xs, states, S, newton = [], [], [], []
        for i, amp in enumerate(interface.amplitudes):
            step = solver.step(path, previous, amp, mu, True, f"increment {i + 1}")
            xs.append(path.x.copy())
            states.append(step.state)
            S.append(path.S.copy())
            newton.append(step.n_newton)
            previous = amp
    return dict(x=np.array(xs), state=np.array(states), S=np.array(S), newton=newton, stuck=stuck,
                solver=solver.updated)


def checks(interface: Interface, out: dict, mu: float) -> str:
    """Equilibrium and gross-slip checks of the last increment's solution."""
    n_w = 3 * interface.pairs.n_pairs
    lam = out["x"][-1][:n_w].reshape(-1, 3)
    last = out["state"][-1]
    gross = np.all(last[last != OPEN] == SLIP)
    return (f"  at the end: sum lam_N {lam[:, 0].sum():.9g} N against P {interface.P:.9g} N; "
            f"{'gross slip' if gross else 'NOT gross slip'}: sum |lam_T| {np.hypot(*lam[:, 1:].T).sum():.9g} N "
            f"against mu sum lam_N {mu * lam[:, 0].sum():.9g} N (sum lam_x {lam[:, 1].sum():.6g} N)")


def difference(a: dict, b: dict) -> str:
    """Largest difference of each result relative to its largest value."""
    parts = []
    for name in ("x", "S"):
        scale = np.max(np.abs(a[name]))
        parts.append(f"{name} {np.max(np.abs(a[name] - b[name])) / scale:.1e}")
    parts.append("states " + ("equal" if np.array_equal(a["state"], b["state"]) else "DIFFER"))
    parts.append("Newton iterations " + ("equal" if a["newton"] == b["newton"] else f"{a['newton']} / {b['newton']}"))
    return ", ".join(parts)


#: path name -> (STUCK, ITERATE) of fem/updated_jacobian.py, PRECISION of fem/capacitance.py, LARGE of
#: fem/threads.py (the rows from which a solve's factorisations take the process's BLAS threads)
PATHS = {"old": ("lu", "never", "double", threads.LARGE), "cholesky": ("auto", "never", "double", threads.LARGE),
         "double": ("auto", "auto", "double", threads.LARGE), "new": ("auto", "auto", "mixed", threads.LARGE),
         "one-thread": ("auto", "auto", "mixed", np.inf)}


def one(n_w: int, n_solves: int, path_names: list[str]) -> None:
    mu = 0.3
    cpu = time.process_time()
    interface = Interface(n_w, mu=mu)
    n_w = 3 * interface.pairs.n_pairs
    print(f"n_w {n_w} (n_c {n_w // 3}, m 1): interface made in {time.process_time() - cpu:.1f} s CPU, "
          f"P {interface.P:.1f} N, pull to {interface.slide * 1e3:.3f} um, {len(interface.amplitudes)} increments",
          flush=True)
    results = {}
    for name in path_names:
        updated_jacobian.STUCK, updated_jacobian.ITERATE, capacitance.PRECISION, threads.LARGE = PATHS[name]
        stuck = None
        for k in range(n_solves):
            wall, start = time.perf_counter(), time.process_time()
            with Parts() as parts:
                out = solve(interface, np.full(4, mu), stuck)
            total, wall = time.process_time() - start, time.perf_counter() - wall
            stuck = out["stuck"]
            counts = [np.bincount(s, minlength=3).tolist() for s in out["state"]]
            if k == 0:
                print(checks(interface, out, mu))
                print(f"  states per increment (open, stick, slip): {counts}")
            s = out.pop("solver")             # its kept factorisations: not held into the next solve
            print(f"  [{name}] solve {k + 1}: {total:.1f} s CPU ({wall:.1f} s wall), Newton {out['newton']}, "
                  f"capacitance: {s.n_factorisations} LU factorisations, {s.n_updates} updates, {s.n_iterated} "
                  f"iterated ({sum(s.krylov_iterations)} Krylov iterations in {len(s.krylov_iterations)} solves), "
                  f"{s.n_dense} dense solves, {s.n_switches} switches; peak so far {process_peak() / 2**30:.2f} GB = "
                  f"{process_peak() / (8.0 * n_w ** 2):.1f} n_w^2 doubles", flush=True)
            del s
            for label, spent in sorted(parts.own.items(), key=lambda kv: -kv[1]):
                print(f"      {spent:8.2f} s CPU {100 * spent / total:5.1f} %  {label} ({parts.calls[label]} calls)")
            results[name] = out
        del stuck, out
        results[name].pop("stuck")
    if len(results) > 1:
        first, *others = results
        for other in others:
            print(f"  {other} against {first}: {difference(results[first], results[other])}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("sizes", nargs="*", type=int, default=[3000, 6000])
    parser.add_argument("--solves", type=int, default=1)
    parser.add_argument("--paths", nargs="*", default=["new"], choices=sorted(PATHS))
    parser.add_argument("--one", action="store_true")
    args = parser.parse_args()
    if args.one:
        one(args.sizes[0], args.solves, args.paths)
    else:
        for n in args.sizes:
            subprocess.run([sys.executable, __file__, str(n), "--one", "--solves", str(args.solves), "--paths",
                            *args.paths], check=True)
