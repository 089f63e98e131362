"""The 3-D block's forward + sensitivity solve run through the `frictionid` command as a user runs it (the
console script of this venv, a subprocess each, the user's environment), against the same run with one BLAS /
OpenMP thread (OPENBLAS_NUM_THREADS = OMP_NUM_THREADS = MKL_NUM_THREADS = 1): idle, with another process keeping
one core busy, and with `run.workers = 2`.

Two CLI paths, both on the default 3-D block (`builder = "block"`, mesh 1.0 mm, 23,595 dofs, 121 contact pairs):

- `frictionid demo --block`: exactly one forward + sensitivity solve; it prints the solve's time ("forward +
  sensitivities X s"), read here (best of 4 runs each way). Cases: idle, one core busy.
- `frictionid identify` of twin data (made by `frictionid simulate` at known coefficients, 704 DIC points ux, uy,
  uz at the end of the pull) with `identify.jacobian = "analytic"` (every solve a forward + sensitivity solve)
  and `identify.starts = 2`, 3 iterations per start: with `run.workers = 2` the two starts run side by side in
  two forked worker processes, so two forward + sensitivity solves run at once on the two cores, which is what
  a multi-start (or several specimens) does to a user's machine. Finite differences would run two solves at
  once too, but forward solves without sensitivities, not the solve the comparison is about. The per-solve time
  is the median wall time of the run's forward + sensitivity solves (about 30) as measured where they ran, read
  from result.json's `timings` (not the interpreter's start-up, the model build or the condensation); the
  fastest solve is printed too. Cases: idle (workers 1), one core busy (workers 1), workers 2 (better of 2 runs
  each way).

Each case runs with the default environment and with one thread, taking turns, and prints both, their ratio
(default / one thread; the target is 1.5 at most) and the wall time of each command. The last line compares
workers 2 (default environment) with one thread and workers 1: two solves sharing the two cores, with whatever
else the machine runs, against one. Run: .venv/bin/python benchmarks/cli_threads.py (about 12 min).
"""

import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from frictionid.studies import block as twin

FRICTIONID = Path(sys.executable).with_name("frictionid")
ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
TRUE = {"A": 0.35, "B": 0.2, "C": 0.45, "D": 0.15}
TARGET = 1.5


def environment(one_thread: bool) -> dict:
    """The user's environment, or the same with one BLAS / OpenMP thread."""
    return {**os.environ, **ONE_THREAD} if one_thread else dict(os.environ)


def run(args: list[str], one_thread: bool, cwd: Path) -> tuple[str, float]:
    """(stdout, wall time [s]) of `frictionid ARGS`; fails loudly if the command does."""
    start = time.perf_counter()
    done = subprocess.run([str(FRICTIONID), *args], cwd=cwd, env=environment(one_thread), capture_output=True,
                          text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"frictionid {' '.join(args)} exited {done.returncode}:\n{done.stdout}\n{done.stderr}")
    return done.stdout, wall


class Busy:
    """Another process keeping one core busy for the duration of a ``with`` block."""

    def __enter__(self):
        self.process = subprocess.Popen([sys.executable, "-c", "while True: sum(range(10000))"])
        time.sleep(0.5)
        return self

    def __exit__(self, *exc):
        self.process.kill()
        self.process.wait()
        return False


def _turn(k: int) -> tuple[bool, bool]:
    """Which runs first in turn ``k`` (one thread or not): alternately, so that an order effect (the first of two
    runs after a pause) falls on both."""
    return (False, True) if k % 2 == 0 else (True, False)


def demo_block(cwd: Path, repeat: int = 3) -> tuple[tuple[float, float], tuple[float, float]]:
    """(best solve time [s] that `frictionid demo --block` reports, best wall time [s]) of ``repeat`` runs with the
    default environment and of as many with one thread, taking turns, each first in every other turn (a
    change in the machine's other load falls on both)."""
    figures = {False: ([], []), True: ([], [])}
    for k in range(repeat):
        for one_thread in _turn(k):
            out, wall = run(["demo", "--block"], one_thread, cwd)
            figures[one_thread][0].append(float(re.search(r"forward \+ sensitivities ([0-9.]+) s", out).group(1)))
            figures[one_thread][1].append(wall)
    return tuple((min(figures[k][0]), min(figures[k][1])) for k in (False, True))


def write_twin(folder: Path) -> None:
    """points.csv, truth.toml and measured.csv (simulated at TRUE on the default 3-D block)."""
    twin.write_points(folder / "points.csv")
    (folder / "truth.toml").write_text(config("points.csv", TRUE, "truth"))
    run(["simulate", "truth.toml", "--out", "measured.csv"], True, folder)


def config(data: str, zones: dict, name: str, workers: int = 1) -> str:
    table = ", ".join(f"{z} = {v}" for z, v in zones.items())
    return (f'[model]\nbuilder = "block"\n[friction]\nzones = {{ {table} }}\n'
            f'[data]\nfile = "{data}"\nobservables = ["ux", "uy", "uz"]\nstages = [2]\nnoise = {{ u = 0.0005 }}\n'
            f'[identify]\njacobian = "analytic"\nstarts = 2\nseed = 0\nmax_iterations = 3\n'
            f'[run]\ndir = "runs/{name}"\nworkers = {workers}\nfields = false\n')


def identify(folder: Path, name: str, workers: int, one_thread: bool) -> tuple[float, int, float]:
    """(median and fastest forward + sensitivity solve [s], number of such solves, wall time [s]) of one identify
    run."""
    (folder / f"{name}.toml").write_text(config("measured.csv", dict.fromkeys(TRUE, 0.1), name, workers))
    _, wall = run(["identify", f"{name}.toml"], one_thread, folder)
    timings = json.loads((folder / "runs" / name / "result.json").read_text())["timings"]
    solves = timings["solves"]["forward+sensitivities"]
    return solves["median_s"], solves["min_s"], solves["n"], wall


def identify_pair(folder: Path, name: str, workers: int, repeat: int = 2) -> tuple[tuple, tuple]:
    """:func:`identify` with the default environment and with one thread, taking turns ``repeat`` times; the
    run with the smaller median solve of each."""
    runs = {False: [], True: []}
    for k in range(repeat):
        for one_thread in _turn(k):
            runs[one_thread].append(identify(folder, f"{name}{k}{'-1' if one_thread else ''}", workers, one_thread))
    return min(runs[False]), min(runs[True])


def line(case: str, default: tuple, one: tuple, what: str) -> float:
    ratio = default[0] / one[0]
    fastest = f"; fastest solve {default[1]:.3f} / {one[1]:.3f} s" if len(default) == 4 else ""
    print(f"  {case:<24} default {default[0]:7.3f} s   one thread {one[0]:7.3f} s   ratio {ratio:5.2f}"
          f"{'  > ' + str(TARGET) if ratio > TARGET else ''}   ({what}{fastest}; wall {default[-1]:.1f} s / "
          f"{one[-1]:.1f} s; load average {os.getloadavg()[0]:.1f})")
    return ratio


def main() -> None:
    from threadpoolctl import threadpool_info

    print("BLAS of numpy here:", ", ".join(f"{d['internal_api']} {d['num_threads']} threads"
                                           for d in threadpool_info()), f"; {os.cpu_count()} cores;",
          "load average %.1f %.1f %.1f" % os.getloadavg())
    ratios = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        print("frictionid demo --block (one forward + sensitivity solve, the time it prints, best of 4):")
        ratios.append(line("idle", *demo_block(folder, 4), "solve"))
        with Busy():
            ratios.append(line("one core busy", *demo_block(folder, 4), "solve"))
        write_twin(folder)
        print("frictionid identify, 2 starts, analytic Jacobian (median forward + sensitivity solve of result.json "
              "timings, the better of 2 runs):")
        default, single = identify_pair(folder, "idle", 1)
        ratios.append(line("idle, workers 1", default, single, "median solve"))
        with Busy():
            ratios.append(line("one core busy, workers 1", *identify_pair(folder, "busy", 1), "median solve"))
        two, two_single = identify_pair(folder, "two", 2)
        ratios.append(line("workers 2", two, two_single, "median solve"))
        ratios.append(line("workers 2 / 1 thread w 1", two, single, "median solve, against workers 1"))
    print(f"largest ratio {max(ratios):.2f} (target {TARGET}); load average at the end "
          "%.1f %.1f %.1f" % os.getloadavg())


if __name__ == "__main__":
    main()
