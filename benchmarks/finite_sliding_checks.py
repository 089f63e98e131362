"""The figures of docs/solver.md's finite-sliding verification table, on the cases of tests/test_sliding.py:
gross-slip reaction, base pressure centroid, tiny-pull limit, mu = 0, sensitivities against central differences.

Run: PYTHONPATH=src .venv/bin/python benchmarks/finite_sliding_checks.py
"""


import numpy as np

import _tests  # noqa: F401  (tests/ importable)
from sliding_case import block_on_base
from frictionid.fem.problem import Problem

MU = np.array([0.3, 0.2])
POINTS = np.array([[0.5, 1.5], [9.5, 2.5], [15.0, -1.0], [-3.0, -1.5]])


def centroid(model, forces) -> float:
    target = np.unique(model.mesh.boundary("target"))
    fy = forces.reshape(-1, 2)[target, 1]
    return float(model.mesh.points[target, 0] @ fy / fy.sum())


def slid(model):
    problem, small = Problem.build(model, points=POINTS, sliding="finite"), Problem.build(model)
    s, a = problem.solve(MU, sensitivities=True), small.solve(MU, max_slip=None)
    pull = problem.reaction_labels.index("block_top.x")
    print(f"  gross slip: T / sum mu N - 1 = {s.reactions[-1, pull] / (MU @ s.zone_normal_force[-1]) - 1:.2e}; "
          f"sum lam_N / F - 1 = {s.zone_normal_force[-1].sum() / 1000 - 1:.2e}")
    f = np.zeros(problem.space.n_dofs)
    f[problem.interface_dofs] = s.interface_forces[-1]
    u = problem.displacement(s, -1)
    nodes, lam = s.pairs.nodes, s.lam[-1, :, 0]
    block = (model.mesh.points[nodes, 0] + u[nodes, 0]) @ lam / lam.sum()
    shift = centroid(model, f) - centroid(model, small.pairs.B.T @ a.lam[-1].ravel())
    print(f"  base centroid - block pressure centroid: {abs(centroid(model, f) - block) / 2:.1e} of the pull; "
          f"(finite - small) base centroid - slide: {abs(shift - u[nodes, 0].mean()) / 2:.1e} of the pull")
    zero = problem.solve([0.0, 0.0])
    print(f"  mu = 0: max |lam_T| {np.abs(zero.lam[:, :, 1]).max():.1e} N, pull reaction "
          f"{zero.reactions[-1, pull]:.1e} N")
    return problem, s


def central_differences(problem, s, step=1e-6):
    worst = {"reactions": 0.0, "observations": 0.0}
    for z in range(len(MU)):
        shift = np.eye(len(MU))[z] * step
        plus, minus = problem.solve(MU + shift), problem.solve(MU - shift)
        for name, got, fd in (("reactions", s.d_reactions[:, :, z], (plus.reactions - minus.reactions) / (2 * step)),
                              ("observations", np.asarray(s.d_observations)[:, :, z],
                               (np.asarray(plus.observations) - np.asarray(minus.observations)) / (2 * step))):
            worst[name] = max(worst[name], np.abs(got - fd).max() / np.abs(fd).max())
    print("  sensitivities vs central differences (max error / largest derivative): "
          + ", ".join(f"{k} {v:.1e}" for k, v in worst.items()))


def main():
    print("block slid 2 mm, 5 pull increments (tests/test_sliding.py):")
    problem, s = slid(block_on_base(n_block=10, n_base=41, pull=2.0, n_pull=5))
    central_differences(problem, s)
    print("pressed in 2 increments, pulled 4 um in 4 (stick, partial, gross slip):")
    model = block_on_base(n_block=10, n_base=41, pull=0.004, n_press=2, n_pull=4)
    problem = Problem.build(model, points=POINTS, sliding="finite")
    central_differences(problem, problem.solve(MU, sensitivities=True))
    model = block_on_base(n_block=10, n_base=41, force=1e-6, pull=1e-9, n_pull=3)
    a, b = Problem.build(model, sliding="finite").solve(MU), Problem.build(model).solve(MU)
    print(f"tiny pull (1e-9 mm, 1e-6 N): finite vs small, max difference / largest value: reactions "
          f"{np.abs(a.reactions - b.reactions).max() / np.abs(b.reactions).max():.1e}, "
          f"lam {np.abs(a.lam - b.lam).max() / np.abs(b.lam).max():.1e}")
    for n_pull in (5, 10, 20):
        model = block_on_base(n_block=10, n_base=41, pull=2.0, n_pull=n_pull)
        s = Problem.build(model, points=POINTS, sliding="finite").solve(MU)
        print(f"{n_pull:2d} pull increments: pull reaction {s.reactions[-1, 2]:.6f} N, "
              f"observations {np.asarray(s.observations)[-1].round(7).tolist()}")


if __name__ == "__main__":
    main()
