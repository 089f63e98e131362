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


def result_summary(result: dict) -> str:
    """lmfit-style report of an identification: fit statistics and adequacy, variables, correlations,
    identifiability. Interval figures always come with the verdict on whether the stated noise explains the
    misfit, since they mean little when it does not."""
    fit = result["fit"]
    lines = ["[[Fit Statistics]]",
             f"    status             {result['status']} ({result['method']}, {result['jacobian']} Jacobian, "
             f"{result['backend']} backend)",
             f"    iterations         {result['n_iterations']}",
             f"    forward solves     {result['n_forward_solves']} (+ {result['n_sensitivity_solves']} with "
             f"sensitivities, {result['n_replayed']} replayed from the store)",
             f"    observations       {fit['n_obs']}",
             f"    objective          {result['objective']['initial']:.6e} -> {result['objective']['final']:.6e}",
             f"    chi-square / dof   {fit['chi2']:.4g} / {fit['dof']} = {fit['reduced_chi2']:.4g}"
             + ("" if fit["noise_known"] else " (no stated noise: errors scaled by the residual)"),
             f"    wall time          {result['wall_time_s']:.2f} s"]
    lines += _adequacy_lines(fit)
    lines += discretisation_lines(result.get("model", {}).get("discretisation"))
    lines.append("[[Variables]]")
    for name, p in result["parameters"].items():
        if p["fixed"]:
            lines.append(f"    {name:<10} {p['value']:.6f} (fixed)")
            continue
        spread = "+/- (cannot be estimated)" if p["stderr"] is None else f"+/- {p['stderr']:.6f}"
        interval = "" if p.get("ci95") is None else \
            f" 95 % [{p['ci95'][0]:.4f}, {p['ci95'][1]:.4f}]" + (" one-sided" if p["at_bound"] else "")
        flags = (" at boundary" if p["at_bound"] else "") + ("" if p["identifiable"] else " NOT RESOLVED")
        lines.append(f"    {name:<10} {p['value']:.6f} {spread}{interval} (init = {p['initial']:.4f}){flags}")
        if p.get("why"):
            lines.append(f"               why: {p['why']}")
        if p.get("bound_check", {}).get("passed"):
            profile = ("the profile, its systematic part counted," if p["bound_check"].get("systematic")
                       else "the profile")
            lines.append(f"               on its bound: {profile} excludes values beyond {p['ci95'][1]:.4f} "
                         "(one-sided 95 %)" if p["ci95"][0] == p["bounds"][0] else
                         f"               on its bound: {profile} excludes values below {p['ci95'][0]:.4f} "
                         "(one-sided 95 %)")
        if p.get("stderr_systematic"):
            lines.append(f"               includes {p['stderr_systematic']:.4f} systematic (the model error's "
                         "effect on it)")
    ident = result["identifiability"]
    lines.append("[[Identifiability]]")
    lines.append("    singular values of the weighted Jacobian: "
                 + ", ".join(f"{v:.3g}" for v in ident["singular_values"]))
    if ident["message"]:
        lines.append(f"    {ident['message']}")
    names = [n for n, p in result["parameters"].items() if not p["fixed"]]
    pairs = [(names[i], names[j], c) for i, row in enumerate(ident["correlation"]) for j, c in enumerate(row)
             if j > i and c is not None and abs(c) > 0.1]
    if pairs:
        lines.append("[[Correlations]] (|C| > 0.1)")
        lines += [f"    C({a}, {b}) = {c:+.3f}" for a, b, c in sorted(pairs, key=lambda t: -abs(t[2]))]
    lines += starts_lines(result.get("starts"))
    if result.get("profiles"):
        lines += [profile_summary(result["profiles"])]
    return "\n".join(lines)


def profile_summary(profiles: dict) -> str:
    """[[Profiles]] (identify.profile): per zone the profile-likelihood 95 % interval and its grid."""
    lines = ["[[Profiles]] (the zone held, the others refitted; 95 %: chi2 within the threshold of its minimum)"]
    for zone, p in profiles.items():
        low, high = p["interval"]
        ends = [f"{'<' if p['open'][0] else ''}{low:.4f}", f"{high:.4f}{'>' if p['open'][1] else ''}"]
        lines.append(f"    {zone}: [{ends[0]}, {ends[1]}] from {len(p['values'])} values in "
                     f"[{min(p['values']):.4f}, {max(p['values']):.4f}] (threshold {p['threshold']:.3g}"
                     f"{'; < or >: the interval goes beyond the grid' if any(p['open']) else ''})")
    return "\n".join(lines)


def starts_lines(starts: list[dict] | None) -> list[str]:
    """[[Starts]] of a multi-start run (identify.starts): per start its start and end point, objective and
    status; the reported one marked *. No lines for a single start."""
    if not starts:
        return []
    lines = ["[[Starts]] (* reported: the lowest objective)"]
    for s in starts:
        initial = ", ".join(f"{k}={v:.4f}" for k, v in s["initial"].items())
        if s["status"] == "failed":
            lines.append(f"   {s['start']:3d}  from {initial}: failed: {s['message']}")
            continue
        final = ", ".join(f"{k}={v:.4f}" for k, v in s["value"].items())
        lines.append(f" {'*' if s['best'] else ' '} {s['start']:3d}  from {initial} -> {final}  "
                     f"J={s['objective']:.6e}  {s['status']}, {s['n_iterations']} iterations")
    return lines


def discretisation_lines(record: dict | None) -> list[str]:
    """What the discretisation control did before the fit (result.json ``model.discretisation``), one line."""
    if not record:
        return []
    if record["status"] in ("off", "skipped"):
        return [f"    discretisation control: {record['status']}" + (f" ({record['why']})" if record.get("why") else "")]
    rms = ", ".join(f"{kind} {value:.2f}" for kind, value in record["error_as_given"].items())
    factors = ", ".join(f"{name} x{k}" for name, k in record["factors"].items() if k != 1) or "none"
    predicted = ", ".join(f"{kind} {value:.2f}" for kind, value in record["predicted_error"].items())
    return [f"    discretisation control: estimated error of the mesh as given {rms} noise levels RMS (target "
            f"{record['target']:g}); refined: {factors} ({record['n_nodes']:,} nodes), predicted {predicted}: "
            f"target {record['status']}; {record['seconds']:.0f} s"] + [_at_fitted_line(r)
                                                                        for r in record.get("at_fitted", [])]


def _at_fitted_line(row: dict) -> str:
    """One round of the control at the fitted values (``model.discretisation.at_fitted``)."""
    fitted = ", ".join(f"{kind} {value:.2f}" for kind, value in row.get("error_fitted", {}).items())
    line = (f"    at the fitted values (round {row['round']}): " + (f"estimated error of the model fitted {fitted} "
            "noise levels RMS: " if fitted else "") + f"{row['status']}; {row['seconds']:.0f} s")
    if "refit" in row:
        factors = ", ".join(f"{name} x{k}" for name, k in row["factors"].items() if k != 1)
        line += (f"; refitted on {factors} ({row['n_nodes']:,} nodes) from the fitted values in "
                 f"{row['refit']['n_iterations']} iterations, {row['refit']['seconds']:.0f} s")
    return line


def _adequacy_lines(fit: dict) -> list[str]:
    """[[Fit Adequacy]]: the chi-square verdict, where the misfit sits, the worst observations, a hint."""
    lines = ["[[Fit Adequacy]]"]
    if fit.get("consistent") is None:
        return lines + ["    no stated noise: whether the model explains the data cannot be tested; standard "
                        "errors are scaled by the residual"]
    if fit.get("too_small"):
        lines.append(f"    THE MISFIT IS SMALLER THAN THE STATED NOISE ALLOWS: reduced chi-square "
                     f"{fit['reduced_chi2']:.3g} < {fit['chi2_01']:.3g} (1 % quantile). The stated noise is too large or the data were "
                     "smoothed (or carry none); standard errors below use the stated noise, so they are too wide.")
    elif fit["consistent"]:
        lines.append(f"    the stated noise explains the misfit (reduced chi-square {fit['reduced_chi2']:.3g} "
                     f"<= {fit['chi2_99']:.3g}, its 99 % quantile)")
    else:
        lines.append(f"    THE MODEL DOES NOT EXPLAIN THE DATA at the stated noise: reduced chi-square "
                     f"{fit['reduced_chi2']:.4g} > {fit['chi2_99']:.3g} (99 % quantile). Standard errors below are "
                     f"scaled by {fit['error_scale']:.3g}; they hold only if the misfit is noise-like. Zones the "
                     "data contradict each other about are not reported as resolved.")
    if fit.get("loss", "linear") != "linear":
        lines.append(f"    robust loss {fit['loss']}: {fit['n_downweighted']} observation(s) kept less than half their "
                     "weight; chi-square and standard errors use the weights the fit ends with, so they treat "
                     "the down-weighted observations as outliers (too narrow if those are model error)")
    error = fit.get("model_error") or {}
    if error.get("requested") == "auto":
        lines.append(f"    model error {error['mode']}: {error['why']}")
    if error.get("summary"):
        all_ = error["summary"]["all"]
        kinds = ", ".join(f"{key[5:]} {v['rms']:.3g}" for key, v in error["summary"].items() if key.startswith("kind "))
        how = ("the discretisation control's prediction for the fitted model" if error.get("source") ==
               "discretisation control" else f"model refined x{error['factor']}, Richardson")
        lines.append(f"    estimated discretisation error ({how}): "
                     f"{all_['rms']:.3g} noise levels RMS, max {all_['max']:.3g} (by kind: {kinds})"
                     + (f"; included in the weights scaled per quantity by {_scales(error)} (the size each "
                        "quantity's misfit shows)" if error["mode"] == "include" else
                        "; not included in the weights (identify.model_error = \"include\" does)"))
        shift = {zone: v for zone, v in error.get("shift", {}).items() if v is not None}
        if shift:
            lines.append("    corrected for that error the coefficients would move by (linearised): "
                         + ", ".join(f"{zone} {v:+.3g}" for zone, v in shift.items()))
    elif fit["consistent"] is not False:
        lines.append("    not checked: the mesh's discretisation error, which a coefficient can absorb without leaving "
                     "a misfit (identify.model_error = \"estimate\" checks it)")
    misfit = fit["misfit"]
    for title, table in (("quantity", misfit["by_quantity"]), ("stage", misfit["by_stage"]),
                         ("point group", misfit["by_group"])):
        if len(table) > 1 or title == "quantity":
            cells = ", ".join(f"{key} {g['rms']:.3g} ({g['share']:.0%})"
                              for key, g in sorted(table.items(), key=lambda t: -t[1]["share"]))
            lines.append(f"    RMS misfit / noise by {title} (share of chi-square): {cells}")
    if not fit["consistent"]:
        lines.append("    worst observations (residual / noise, measured, model): "
                     + "; ".join(f"{w['observation']} {w['residual']:+.3g} ({w['measured']:.4g}, {w['model']:.4g})"
                                 for w in fit["worst"][:5]))
        lines.append(f"    what to try: {fit['hint']}")
    elif fit.get("too_small"):
        lines.append(f"    what to try: {fit['hint']}")
    return lines


def _scales(error: dict) -> str:
    """fit.model_error's per-quantity scales of mode "include" ("ux 1.2, exy 0.4"; one number without them)."""
    scales = error.get("scales")
    return ", ".join(f"{q} {k:.3g}" for q, k in scales.items()) if scales else f"{error['scale']:.3g}"


def _se(value) -> str:
    return "not seen" if value is None else f"{value:.4f}"


def prefit_summary(prefit: dict) -> str:
    """What the planned data can resolve before fitting (the "prefit" entry of result.json).

    >>> print(prefit_summary(result["identifiability"]["prefit"]))  # doctest: +SKIP
    """
    names = list(prefit["stderr"])
    lines = ["[[Resolution before fitting]] (linearised at the start values, at the stated noise)",
             "    singular values of the weighted Jacobian: "
             + ", ".join("0" if v is None else f"{v:.3g}" for v in prefit["singular_values"]),
             f"    {'zone':<10}{'predicted stderr':>18}  {'resolved':<9}most correlated with"]
    for i, name in enumerate(names):
        row = [abs(c) if c is not None and j != i else -1.0 for j, c in enumerate(prefit["correlation"][i])]
        j = max(range(len(row)), key=row.__getitem__) if row else 0
        partner = f"{names[j]} ({prefit['correlation'][i][j]:+.2f})" if row and row[j] >= 0 else "-"
        lines.append(f"    {name:<10}{_se(prefit['stderr'][name]):>18}  "
                     f"{'yes' if prefit['resolved'][name] else 'NO':<9}{partner}")
    missing = [n for n in names if not prefit["resolved"][n]]
    if not missing:
        return "\n".join(lines)
    lines.append(f"    warning: the data cannot resolve zone(s) {', '.join(missing)} to +/- {prefit['tolerance']:g}; "
                 "their fitted values will be reported as not resolved")
    if prefit["note"]:
        lines.append(f"    {prefit['note']}")
    if prefit["suggestions"]:
        lines.append("    observations that would resolve them (added in this order; predicted stderr after):")
    for s in prefit["suggestions"]:
        after = ", ".join(f"{n} {_se(s['stderr_after'][n])}" for n in missing)
        lines.append(f"      + {s['observation']}: {after}")
    return "\n".join(lines)
