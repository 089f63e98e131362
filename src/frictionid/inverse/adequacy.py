"""Fit adequacy: does the stated noise explain the misfit, where does the misfit sit, and which zones does it move.

With residuals weighted by stated standard deviations, chi^2 = ||r||^2 follows a chi-square distribution with
n_obs - n_free degrees of freedom when the model is right. A chi^2 beyond its 99 % quantile means the model
does not explain the data at that noise (model error: discretisation, physics the model lacks, a wrong frame
or noise level); then the standard errors computed from the stated noise describe the noise only, not the
error of the coefficients.

Which coefficients such a misfit moves is measured by leaving observation groups out (one quantity, one stage,
one point group at a time) and refitting the linearised problem: with J^T r = 0 at the fit, leaving out group
g moves x by dx = (J_-^T J_-)^-1 J_g^T r_g, whose variance under the stated noise alone is
(J_-^T J_-)^-1 - (J^T J)^-1 (the nested-estimator difference). A zone that moves by more than
:data:`SHIFT_LIMIT` such standard deviations is one the data contradict themselves about. With the model error
included in the weights (identify.model_error = "include") that error is one fixed field, which moves a zone by up
to its systematic standard error whichever group is left out: the moves are then measured against
sqrt(var + systematic^2) (:meth:`Adequacy.with_systematic`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from .mistakes import noise_hint, scale_hints, swap_hints
from .observations import label_parts

#: chi-square quantile above which the stated noise does not explain the misfit
CONFIDENCE = 0.99
#: chi-square quantile below which the misfit is too small for the stated noise (noise overstated, data smoothed)
LOW = 0.01
#: standard deviations (under the stated noise) a leave-group-out refit may move a zone before it counts as
#: contradicted by the data
SHIFT_LIMIT = 3.0
#: worst observations listed
N_WORST = 10


@dataclass(frozen=True)
class GroupMisfit:
    """Misfit of one observation group: count, RMS weighted residual (in units of the noise), share of chi^2."""

    n: int
    rms: float
    share: float


@dataclass(frozen=True)
class Shift:
    """How far leaving out one observation group moves each zone, in standard deviations of that move: ``z``
    = |``move``| / ``sd`` (all (n_free,); nan where not measurable)."""

    group: str
    z: np.ndarray
    move: np.ndarray | None = None
    sd: np.ndarray | None = None


@dataclass(frozen=True)
class Adequacy:
    """The misfit of a fit against its stated noise.

    Attributes
    ----------
    chi2, dof : ||r||^2 of the weighted residuals and n_obs - n_free
    reduced_chi2 : chi2 / dof
    threshold : the 99 % quantile of chi2 / dof under the stated noise
    p_value : probability of a chi2 at least this large if the model were right
    consistent : chi2 within its 99 % quantile, and so is each quantity's own (:func:`kinds_beyond_noise`); None
        when no noise was stated (nothing to test against)
    low_threshold : the 1 % quantile of chi2 / dof
    too_small : chi2 below its 1 % quantile: the stated noise is too large or the data were smoothed (the
        standard errors stay those of the stated noise: too wide, never too narrow)
    by_quantity, by_stage, by_group : {name: GroupMisfit}
    worst : [(label, weighted residual, measured, model)] largest |residual| first
    shifts : leave-group-out moves per group (only for an inconsistent fit)
    affected : (n_free,) bool, zones a leave-group-out refit moves by more than SHIFT_LIMIT
    hint : what to do about an inconsistent fit ("" when consistent)
    kinds_beyond : the quantities whose own misfit the stated noise does not explain (:func:`kinds_beyond_noise`)
    model_error_weighted : the weights include a model error (mode "include"): the reasons say so
    """

    chi2: float
    dof: int
    reduced_chi2: float
    threshold: float
    p_value: float
    consistent: bool | None
    by_quantity: dict
    by_stage: dict
    by_group: dict
    worst: list
    shifts: tuple[Shift, ...]
    affected: np.ndarray
    hint: str
    low_threshold: float = 0.0
    too_small: bool = False
    kinds_beyond: tuple[str, ...] = ()
    #: the weights hold the stated noise and an included model error (``check_groups``), not the noise alone
    model_error_weighted: bool = False

    def why_affected(self, k: int, names) -> str:
        """A zone's reason for being contradicted by the data: the group whose omission moves it most."""
        best = max(self.shifts, key=lambda s: s.z[k] if np.isfinite(s.z[k]) else -1.0)
        return (f"the data contradict each other: leaving out {best.group} moves {names[k]} by "
                f"{best.z[k]:.0f} standard deviations of " + ("the stated noise and the included model error, "
                                                              "its systematic part counted"
                                                              if self.model_error_weighted else
                                                              "the stated noise (model error)"))

    def with_systematic(self, systematic: np.ndarray) -> "Adequacy":
        """The leave-group-out moves measured against the move's statistical deviation and the coefficients'
        systematic standard error together, sqrt(sd^2 + systematic^2) (include mode: the model error is one
        fixed field, so leaving a group out moves a zone by up to its systematic part even where the groups
        agree), and the zones they move by more than SHIFT_LIMIT of that."""
        systematic = np.nan_to_num(np.asarray(systematic, dtype=float), nan=0.0)
        shifts = []
        for shift in self.shifts:
            if shift.move is None:
                shifts.append(shift)
                continue
            with np.errstate(invalid="ignore", divide="ignore"):
                z = np.abs(shift.move) / np.hypot(shift.sd, systematic)
            shifts.append(replace(shift, z=z))
        affected = np.zeros_like(self.affected)
        for shift in shifts:
            affected |= np.nan_to_num(shift.z, nan=0.0) > SHIFT_LIMIT
        return replace(self, shifts=tuple(shifts), affected=affected)

    def as_dict(self, names) -> dict:
        """JSON-ready summary; names are the free zones, in the order of the Jacobian's columns."""
        def groups(table):
            return {key: {"n": g.n, "rms": g.rms, "share": g.share} for key, g in table.items()}
        return {"reduced_chi2": self.reduced_chi2, "chi2_99": self.threshold, "chi2_01": self.low_threshold,
                "p_value": self.p_value, "consistent": self.consistent, "too_small": self.too_small,
                "kinds_beyond_noise": list(self.kinds_beyond),
                "misfit": {"by_quantity": groups(self.by_quantity), "by_stage": groups(self.by_stage),
                           "by_group": groups(self.by_group)},
                "worst": [{"observation": label, "residual": float(r), "measured": float(y), "model": float(f)}
                          for label, r, y, f in self.worst],
                "shifts": {s.group: {n: (None if not np.isfinite(z) else float(z)) for n, z in zip(names, s.z)}
                           for s in self.shifts},
                "hint": self.hint}


def parts(label: str) -> tuple[str, str, str]:
    """(point group, quantity, stage) of an observation label "point:quantity@stage" or "force@stage".

    The point group is the point label without its trailing number ("F12" -> "F").

    >>> parts("F12:exx@2"), parts("force@3")
    (('F', 'exx', '2'), ('force', 'force', '3'))
    """
    point, quantity, stage = label_parts(label)
    if not point:
        return quantity, quantity, stage
    return re.sub(r"\d+$", "", point) or point, quantity, stage


def _table(keys: list[str], r: np.ndarray, chi2: float) -> dict:
    out = {}
    for key in dict.fromkeys(keys):
        rows = np.array([k == key for k in keys])
        out[key] = GroupMisfit(int(rows.sum()), float(np.sqrt(np.mean(r[rows] ** 2))),
                               float(np.sum(r[rows] ** 2) / chi2) if chi2 > 0 else 0.0)
    return out


def point_group(label: str, regions: dict | None = None) -> str:
    """The group of an observation's point in the misfit tables: the label without its trailing number ("F12":
    "F", a view's "front/12": "front/"); a label that is only a number (a DIC subset id) has no such prefix and
    is grouped by its region ("region block"), else with the other numbered points.

    >>> point_group("F12:exx@2"), point_group("823:ux@2", {"823": "block"}), point_group("force@2")
    ('F', 'region block', 'force')
    """
    group, _, _ = parts(label)
    point = label_parts(label)[0]
    if group != point or not point.isdigit():
        return group
    region = (regions or {}).get(point)
    return f"region {region}" if region else "numbered points"


def assess(r: np.ndarray, jac: np.ndarray, labels, y, f, noise_known: bool, inner=None, sigma=None,
           regions: dict | None = None, model_kind: str | None = None, check_groups: bool = False) -> Adequacy:
    """Adequacy of a fit from its weighted residuals r (n_obs,) and weighted Jacobian (n_obs, n_free).

    ``labels``, ``y``, ``f``: observation labels, measured and fitted values; ``inner``: (n_free,) bool, the
    zones not held at a bound (the leave-group-out refits move only these; default all); ``sigma`` (n_obs,): the
    stated standard deviations (for the unit and column hints; default |f - y| / |r|); ``regions``: point label ->
    region, grouping points whose labels are plain numbers (:func:`point_group`); ``model_kind``: the model's
    kind ("plane_strain": a force per mm of thickness); ``check_groups``: the leave-group-out refits also for a
    consistent fit (weights with the model error included, scaled per quantity: each quantity's own test then
    passes by construction, and whether the groups agree about each zone is what is left to test).
    """
    r, jac = np.asarray(r, dtype=float), np.asarray(jac, dtype=float)
    n_obs, n_free = jac.shape
    dof = max(n_obs - n_free, 1)
    chi2 = float(r @ r)
    reduced = chi2 / dof
    threshold = float(stats.chi2.ppf(CONFIDENCE, dof) / dof)
    low_threshold = float(stats.chi2.ppf(LOW, dof) / dof)
    p_value = float(stats.chi2.sf(chi2, dof))
    split = [parts(label) for label in labels]
    by_group = _table([point_group(label, regions) for label in labels], r, chi2)
    by_quantity = _table([q for _, q, _ in split], r, chi2)
    beyond = kinds_beyond_noise(by_quantity) if noise_known else ()
    consistent = None if not noise_known else bool(reduced <= threshold and not beyond)
    too_small = bool(noise_known and reduced < low_threshold)
    by_stage = _table([s for _, _, s in split], r, chi2)
    order = np.argsort(-np.abs(r))[:N_WORST]
    worst = [(labels[i], r[i], y[i], f[i]) for i in order]
    inner = np.ones(n_free, dtype=bool) if inner is None else np.asarray(inner, dtype=bool)
    shifts: tuple[Shift, ...] = ()
    if consistent is False or (check_groups and consistent is not None):
        of_group = [point_group(label, regions) for label in labels]
        groups = {**{f"the {q} values": [s[1] == q for s in split] for q in by_quantity},
                  **{f"stage {s}": [t[2] == s for t in split] for s in by_stage},
                  **{_group_name(g): [t == g for t in of_group] for g in by_group if g not in by_quantity}}
        shifts = tuple(Shift(name, *_shift(jac, r, np.array(rows), inner))
                       for name, rows in groups.items() if 0 < sum(rows) < n_obs)
    affected = np.zeros(n_free, dtype=bool)
    for shift in shifts:
        affected |= np.nan_to_num(shift.z, nan=0.0) > SHIFT_LIMIT
    hint = ""
    if consistent is False:
        y, f = np.asarray(y, dtype=float), np.asarray(f, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            sigma = np.where(r != 0, np.abs(f - y) / np.abs(r), 1.0) if sigma is None else np.asarray(sigma, float)
        quantities = [q for _, q, _ in split]
        swapped = swap_hints([(point, stage) for point, _, stage in map(label_parts, labels)], quantities, y, f,
                             sigma, chi2)
        mistakes = list(swapped.values()) + scale_hints(quantities, y, f, sigma,
                                                        {q: g.share for q, g in by_quantity.items()}, model_kind,
                                                        {q for pair in swapped for q in pair})
        hint = "; ".join(mistakes + [_hint(by_quantity, by_group, r, bool(mistakes))])
        if reduced <= threshold:
            hint = _beyond_hint(beyond, by_quantity) + "; " + hint
    elif too_small:
        hint = noise_hint({q: g.rms for q, g in by_quantity.items()})
    return Adequacy(chi2, dof, reduced, threshold, p_value, consistent, by_quantity, by_stage, by_group, worst,
                    shifts, affected, hint, low_threshold, too_small, beyond, check_groups)


def kinds_beyond_noise(by_quantity: dict) -> tuple[str, ...]:
    """The quantities whose own chi-square, n rms^2 over their n observations, exceeds its quantile at the level
    1 - CONFIDENCE shared among the quantities (Bonferroni): a kind the stated noise (and an included model error)
    does not explain, even where the whole chi-square passes because that kind is few observations among many
    (two machine forces among 10^4 displacements) or a small excess over many (one strain component 1.3 noise
    levels RMS).

    >>> kinds_beyond_noise({"ux": GroupMisfit(3504, 1.01, 0.5), "force": GroupMisfit(2, 5.7, 0.01)})
    ('force',)
    >>> kinds_beyond_noise({"ux": GroupMisfit(3504, 1.01, 0.5), "force": GroupMisfit(2, 2.0, 0.01)})
    ()
    """
    level = (1.0 - CONFIDENCE) / max(len(by_quantity), 1)
    return tuple(q for q, g in by_quantity.items() if stats.chi2.sf(g.n * g.rms ** 2, g.n) < level)


def _beyond_hint(beyond: tuple[str, ...], by_quantity: dict) -> str:
    """Why a fit whose whole chi-square passes is not consistent: the quantities beyond their noise."""
    told = ", ".join(f"{q} {by_quantity[q].rms:.3g} noise levels RMS over {by_quantity[q].n}" for q in beyond)
    return (f"the whole chi-square passes, but not every quantity on its own: {told} (each tested at the 99 % "
            "level shared among the quantities); the model, the data or the stated noise is wrong for these")


def _group_name(group: str) -> str:
    return f"the points of {group}" if group.startswith("region ") or group == "numbered points" \
        else f"the points {group}*"


def _shift(jac: np.ndarray, r: np.ndarray, out: np.ndarray, inner: np.ndarray):
    """(z, dx, sd), each (n_free,): the linearised refit without the rows ``out`` moves the coefficients by dx,
    whose statistical deviation is sd, z = |dx| / sd (nan: not measurable)."""
    z, move, sd = (np.full(jac.shape[1], np.nan) for _ in range(3))
    J, keep = jac[:, inner], ~out
    full = J.T @ J
    rest = J[keep].T @ J[keep]
    if np.linalg.matrix_rank(rest) < J.shape[1] or np.linalg.matrix_rank(full) < J.shape[1]:
        return z, move, sd
    rest_inv = np.linalg.inv(rest)
    dx = rest_inv @ (J[out].T @ r[out])
    variance = np.diag(rest_inv - np.linalg.inv(full))
    move[inner] = dx
    sd[inner] = np.where(variance > 0, np.sqrt(np.maximum(variance, 0.0)), np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        z[inner] = np.abs(dx) / sd[inner]
    return z, move, sd


def bias_shift(jac: np.ndarray, bias: np.ndarray, inner=None) -> np.ndarray:
    """(n_free,) linearised change of the fitted coefficients if the model's weighted values were corrected by
    -``bias`` (e.g. the estimated discretisation error over the noise): dx = (J^T J)^-1 J^T bias over the
    ``inner`` zones (not held at a bound) that the data see (least squares of minimum norm where they see only
    combinations); nan for the others.

    A model error along the sensitivities is absorbed by the coefficients and leaves no misfit, so the
    chi-square test cannot see it; this shift is how far it moved them.

    >>> jac = np.array([[1.0, 0.0], [0.0, 2.0], [1.0, 1.0]])
    >>> bias_shift(jac, jac @ np.array([0.1, -0.2])).round(12).tolist()
    [0.1, -0.2]
    """
    jac, bias = np.asarray(jac, dtype=float), np.asarray(bias, dtype=float)
    inner = np.ones(jac.shape[1], dtype=bool) if inner is None else np.asarray(inner, dtype=bool)
    dx = np.full(jac.shape[1], np.nan)
    norms = np.linalg.norm(jac, axis=0)
    seen = inner & (norms > 1e-12 * max(norms.max(initial=0.0), 1e-300))
    if seen.any():
        dx[seen] = np.linalg.lstsq(jac[:, seen], bias, rcond=None)[0]
    return dx


def _hint(by_quantity: dict, by_group: dict, r: np.ndarray, mistaken: bool = False) -> str:
    """What to try when the stated noise does not explain the misfit; ``mistaken``: an input mistake was
    named (then refining the mesh is not advised)."""
    advice = []
    if mistaken:
        return "correct the input and fit again; until then the coefficients are not meaningful"
    strains = {q: g for q, g in by_quantity.items() if q.startswith("e")}
    others = {q: g for q, g in by_quantity.items() if not q.startswith("e")}
    if strains and others and sum(g.share for g in strains.values()) > 0.7:
        advice.append("the strains carry most of the misfit: strains next to contact edges need a finer or "
                      "higher-order mesh there; fit the displacements only, or raise the strain noise to what "
                      "the model can reproduce")
    worst_group = max(by_group, key=lambda g: by_group[g].share)
    if len(by_group) > 1 and by_group[worst_group].share > 0.6:
        advice.append(f"{_group_name(worst_group)} carry {by_group[worst_group].share:.0%} of the misfit: refine "
                      "the mesh near them or leave them out")
    top = np.sort(r ** 2)[::-1]
    n_top = max(1, len(r) // 20)
    if top.sum() > 0 and top[:n_top].sum() / top.sum() > 0.5:
        advice.append(f"the worst {n_top} observations carry {top[:n_top].sum() / top.sum():.0%} of the misfit: "
                      "check them (listed below) or fit with a robust loss (identify.loss = \"soft_l1\")")
    advice.append("estimate the model's discretisation error (identify.model_error) and check the stated noise")
    return "; ".join(advice)
