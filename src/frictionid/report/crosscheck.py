"""The cross-check's markdown: observation differences per stage, forces, times and the coefficient shift."""

from __future__ import annotations

import numpy as np

from ..backends.comparison import CrossCheck
from ..inverse.observations import DISPLACEMENTS
from ..inverse.shift import CoefficientShift


#: below the forces of an axisymmetric model (measured: docs/calculix.md, "Element types, the default 2-D block and
#: your own mesh")
RADIAL_REACTIONS = ("Axisymmetric: ccx 2.20's radial (x) reaction totals are too small and converge only at first "
                    "order in the element size (a ring against Lame's solution: -5.7 % at 1 mm, -3.0 % at 0.5 mm; the "
                    "embedded solver within 0.04 %); compare the axial (y) reactions, displacements and strains.")


def _differences(reference: np.ndarray, other: np.ndarray) -> str:
    diff = other - reference
    rms = float(np.sqrt(np.mean(diff ** 2)))
    span = float(np.ptp(reference))
    relative = f"{100 * rms / span:.2f} %" if span > 0 else "-"
    return f"{np.abs(diff).max():.3e} | {rms:.3e} | {relative}"


def _observation_rows(check: CrossCheck) -> list[str]:
    n_q = len(check.quantities)
    groups = [("displacements [mm]", [k for k, q in enumerate(check.quantities) if q in DISPLACEMENTS]),
              ("strains", [k for k, q in enumerate(check.quantities) if q not in DISPLACEMENTS])]
    rows = ["| stage | quantities | max abs diff | RMS diff | RMS / range |", "|---|---|---|---|---|"]
    for stage in range(len(check.embedded)):
        a, b = check.embedded[stage].reshape(-1, n_q), check.calculix[stage].reshape(-1, n_q)
        for label, columns in groups:
            if columns:
                rows.append(f"| {stage + 1} | {label} | {_differences(a[:, columns], b[:, columns])} |")
    return rows


def _relative(a: float, b: float) -> str:
    """(b - a) / a: negative when calculix's value is smaller in size than the embedded one."""
    return f"{100 * (b - a) / a:+.2f} %" if abs(a) > 1e-9 * max(abs(b), 1.0) else "-"


def _force_rows(check: CrossCheck) -> list[str]:
    last = len(check.embedded) - 1
    rows = [f"| force at the end of stage {last + 1} [N] | embedded | calculix | difference |", "|---|---|---|---|"]
    for k, label in enumerate(check.reaction_labels):
        a, b = check.reactions_embedded[last, k], check.reactions_calculix[last, k]
        rows.append(f"| reaction {label} | {a:.4g} | {b:.4g} | {_relative(a, b)} |")
    for z, zone in enumerate(check.zone_names):
        for kind, emb, ccx in (("N", check.normal_embedded, check.normal_calculix),
                               ("abs(T)", check.tangential_embedded, check.tangential_calculix)):
            a, b = emb[last, z], ccx[last, z]
            rows.append(f"| zone {zone} {kind} (mu = {check.mu[z]:g}) | {a:.4g} | {b:.4g} | {_relative(a, b)} |")
    if check.kind == "axisymmetric":
        rows += ["", RADIAL_REACTIONS]
    return rows


def _shift_rows(check: CrossCheck, shift: CoefficientShift) -> list[str]:
    groups: dict[float, list[str]] = {}
    for q, value in shift.noise.items():
        groups.setdefault(value, []).append(q)
    noise = "; ".join(f"{', '.join(qs)} {value:g}" if np.isfinite(value) else f"{', '.join(qs)} as in the file"
                      for value, qs in groups.items())
    rows = [f"What the differences mean for an identification from these observations (linearised; stages "
            f"{list(shift.stages)}, {shift.n_rows} rows, weighted by the noise {noise}): a fit with CalculiX "
            "reaches each coefficient shifted from the embedded fit by", "",
            "| zone | mu | calculix - embedded | embedded fit's standard error | shift / standard error |",
            "|---|---|---|---|---|"]
    for zone, mu, delta, se in zip(check.zone_names, check.mu, shift.shift, shift.stderr):
        if np.isfinite(se):
            rows.append(f"| {zone} | {mu:g} | {delta:+.4f} | {se:.4f} | {delta / se:+.1f} |")
        else:
            rows.append(f"| {zone} | {mu:g} | not resolved | - | - |")
    return rows + ["", f"RMS of the differences: {shift.rms:.2f} noise levels."]


def cross_check_table(check: CrossCheck, shift: CoefficientShift | None = None, note: str = "") -> str:
    """Markdown tables: observation differences per stage, reactions and zone forces, time per forward solve,
    and (given ``shift``) the coefficient shift of an identification, else ``note``."""
    lines = [f"## {check.model_name}: {check.n_nodes} nodes, {len(check.points)} points "
             f"({', '.join(check.quantities)}), mu = {np.round(check.mu, 4).tolist()}",
             f"CalculiX penalty: normal {check.penalty[0]:.3g} N/mm^3, stick slope {check.penalty[1]:.3g} N/mm^3; "
             "differences are calculix - embedded; RMS / range uses the embedded values' range."]
    if check.load_scale != 1:
        lines.append(f"CalculiX solved at {check.load_scale:g} times the loads, its results divided by that "
                     "(the small-sliding limit, [solver] load_scale).")
    lines.append("")
    lines += _observation_rows(check) + [""] + _force_rows(check) + [""]
    lines += ["| backend | time per forward solve [s] |", "|---|---|",
              f"| embedded | {check.time_embedded:.3f} (+ {check.setup_embedded:.2f} s condensation once per geometry) |",
              f"| calculix | {check.time_calculix:.2f} |",
              f"| ratio calculix / embedded | {check.time_calculix / max(check.time_embedded, 1e-9):.0f} |"]
    if shift is not None:
        lines += [""] + _shift_rows(check, shift)
    elif note:
        lines += ["", note]
    return "\n".join(lines) + "\n"
