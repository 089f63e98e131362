"""Plain-text tables of a forward solution for the terminal."""

from __future__ import annotations

import numpy as np

from ..fem.solution import Solution


def solution_summary(solution: Solution, increment: int = -1) -> str:
    """Per-zone forces, stick/slip shares and sensitivities, and reactions, at one increment.

    >>> print(solution_summary(solution))  # doctest: +SKIP
    """
    normal = solution.zone_normal_force[increment]
    tangential = np.linalg.norm(solution.zone_tangential_force[increment], axis=1)
    states = solution.zone_state(increment)
    lines = [f"{'zone':<10}{'mu':>8}{'N [N]':>12}{'|T| [N]':>12}{'stick':>8}{'slip':>8}{'open':>8}"]
    for z, zone in enumerate(solution.zone_names):
        s = states[zone]
        lines.append(f"{zone:<10}{solution.mu[z]:>8.3f}{normal[z]:>12.3f}{tangential[z]:>12.3f}"
                     f"{s['stick']:>8.0%}{s['slip']:>8.0%}{s['open']:>8.0%}")
    lines.append("")
    header = f"{'reaction':<22}{'value [N]':>14}"
    if solution.d_reactions is not None:
        header += "".join(f"{'d/d' + z:>12}" for z in solution.zone_names)
    lines.append(header)
    for r, label in enumerate(solution.reaction_labels):
        row = f"{label:<22}{solution.reactions[increment, r]:>14.4f}"
        if solution.d_reactions is not None:
            row += "".join(f"{v:>12.4f}" for v in solution.d_reactions[increment, r])
        lines.append(row)
    return "\n".join(lines)
