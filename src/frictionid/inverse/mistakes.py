"""Input mistakes a misfit points at: a quantity off by a unit factor, two components swapped, a noise level in
the wrong unit.

A model error leaves a misfit of the size of the error; a unit mistake leaves one of the size of the data, in
one quantity, that a single factor removes. So for each quantity that carries much of the misfit the best-fitting
scale s of measured = s * model (weighted least squares, s = sum(y f / sigma^2) / sum(f^2 / sigma^2)) is
compared with the factors of common unit mistakes (10, 100, 1000, 25.4 mm per inch, 2 for engineering shear, a
plane-strain model's force per mm of thickness); for pairs of components (ux, uy), ... the misfit with the
measured columns exchanged (and either sign) is compared with the misfit as read.
"""

from __future__ import annotations

import numpy as np

#: likely mistakes by kind of quantity and factor measured / model
FACTORS = {
    "u": {1000.0: "displacements in um where mm are meant", 1e-3: "displacements in m where mm are meant",
          0.1: "displacements in cm where mm are meant", 10.0: "a factor 10 (a decimal or scale setting)",
          1 / 25.4: "displacements in inches where mm are meant", 25.4: "mm where the file should be in inches"},
    "e": {100.0: "strains in % where plain strain is meant", 1e6: "strains in microstrain where plain strain is "
          "meant", 1000.0: "strains in mm/m (per mille) where plain strain is meant",
          2.0: "engineering shear strain (gamma = 2 exy) where the tensor component is meant", 10.0: "a factor 10"},
    "force": {1000.0: "N and kN mixed (the file 1000 times the model)", 1e-3: "kN where N are meant",
              10.0: "a factor 10", 0.1: "a factor 10"},
    "torque": {1000.0: "N mm where N m is meant", 1e-3: "N m where N mm is meant"},
    "clamp": {1000.0: "N and kN mixed", 1e-3: "kN where N are meant"},
}
#: a scale s counts as the factor F when log s / log F lies in this range: a fit moves the coefficients towards
#: the wrong data, so the scale left is smaller than the mistake's (measured: 475 for 1000, 8.3 for 10,
#: docs/fit-quality.md)
MATCH = (0.8, 1.1)
#: a stated noise counts as off by a factor within this many decades of it
MATCH_DECADES = 0.3
#: a scale or swap must remove at least this share of its quantities' misfit to be reported
EXPLAINED = 0.75
#: scales within this factor of 1 are not a unit mistake
NEAR_ONE = 1.5
#: component pairs a `columns` mapping or a camera frame can exchange
PAIRS = (("ux", "uy"), ("ux", "uz"), ("uy", "uz"), ("exx", "eyy"), ("exx", "ezz"), ("eyy", "ezz"))


def kind_of(quantity: str) -> str:
    """"u", "e", or the per-stage channel ("force", "torque", "clamp") of an observation's quantity.

    >>> kind_of("uy"), kind_of("exy"), kind_of("S2/force")
    ('u', 'e', 'force')
    """
    name = quantity.rpartition("/")[2]
    return name if name in ("force", "torque", "clamp") else name[0] if name[:1] in ("u", "e") else name


def named_factor(scale: float, kind: str) -> tuple[float, str] | None:
    """(factor, likely mistake) of the listed factor of ``kind`` closest to ``scale``, if it is close enough.

    >>> named_factor(475.0, "u")
    (1000.0, 'displacements in um where mm are meant')
    >>> named_factor(3.0, "u") is None
    True
    """
    best = None
    for factor, mistake in FACTORS.get(kind, {}).items():
        ratio = np.log(scale) / np.log(factor) if scale > 0 else -1.0
        off = abs(np.log(ratio)) if ratio > 0 else np.inf
        if MATCH[0] <= ratio <= MATCH[1] and (best is None or off < best[0]):
            best = (off, factor, mistake)
    return None if best is None else best[1:]


def best_scale(y: np.ndarray, f: np.ndarray, sigma: np.ndarray) -> tuple[float, float]:
    """(s, share of the misfit it removes) of measured = s * model, weighted by 1 / sigma^2."""
    w = 1.0 / sigma ** 2
    ff = float(np.sum(w * f * f))
    if ff <= 0:
        return float("nan"), 0.0
    s = float(np.sum(w * y * f)) / ff
    before, after = float(np.sum(w * (y - f) ** 2)), float(np.sum(w * (y - s * f) ** 2))
    return s, (1.0 - after / before) if before > 0 else 0.0


def scale_hints(quantities, y, f, sigma, shares: dict, model_kind: str | None = None, skip=()) -> list[str]:
    """A hint per quantity carrying at least half the misfit whose best-fitting scale is far from 1 and either
    a listed unit factor or a removal of most of its misfit; ``quantities`` (n_obs,) names each row's quantity,
    ``shares`` each quantity's share of chi-square; ``skip``: quantities already explained (swapped)."""
    quantities = np.asarray(quantities)
    hints = []
    for name, share in shares.items():
        rows = quantities == name
        if share < 0.5 or rows.sum() < 1 or name in skip:
            continue
        s, removed = best_scale(y[rows], f[rows], sigma[rows])
        if not np.isfinite(s) or 1 / NEAR_ONE < abs(s) < NEAR_ONE:
            continue
        kind = kind_of(name)
        found = named_factor(abs(s), kind)
        plane = kind == "force" and model_kind == "plane_strain" and abs(s) > NEAR_ONE
        if found is None and not plane and removed < EXPLAINED:
            continue
        head = (f"the measured {name} values are {s:.4g} times the model's (best-fitting scale; it removes "
                f"{removed:.0%} of their misfit, {share:.0%} of chi-square)")
        if plane:
            hints.append(f"{head}: a load cell in N where the plane-strain model's force is per mm of thickness "
                         f"(N/mm); divide the force by the specimen's thickness in mm (this scale suggests "
                         f"{abs(s):.3g} mm or more: a fit moves the coefficients towards the data)")
        elif found is not None:
            hints.append(f"{head}: close to {found[0]:g}, {found[1]}; check the unit of that column")
        else:
            hints.append(f"{head}: a unit or scale mistake? check the unit of that column")
    return hints


def swap_hints(keys, quantities, y, f, sigma, chi2: float) -> dict[tuple[str, str], str]:
    """A hint for each pair of components whose measured columns, exchanged (with either sign), fit the model
    far better than as read, where the pair carries at least half of ``chi2``: pair -> hint. ``keys``: the
    (point, stage) of each observation, ``quantities`` its quantity."""
    keys = list(keys)
    index = {(k, q): i for i, (k, q) in enumerate(zip(keys, quantities))}
    hints = {}
    for a, b in PAIRS:
        both = [(index[k, a], index[k, b]) for k in dict.fromkeys(keys) if (k, a) in index and (k, b) in index]
        if not both:
            continue
        i, j = (np.array(c) for c in zip(*both))
        read = np.sum(((y[i] - f[i]) / sigma[i]) ** 2 + ((y[j] - f[j]) / sigma[j]) ** 2)
        if chi2 <= 0 or read < 0.5 * chi2:
            continue
        signs = [(sa, sb) for sa in (1, -1) for sb in (1, -1)]
        swapped = [np.sum(((sa * y[j] - f[i]) / sigma[i]) ** 2 + ((sb * y[i] - f[j]) / sigma[j]) ** 2)
                   for sa, sb in signs]
        k = int(np.argmin(swapped))
        if swapped[k] > (1 - EXPLAINED) * read:
            continue
        sa, sb = ("" if sign > 0 else "-" for sign in signs[k])
        how = "" if signs[k] == (1, 1) else f" (as {sa}{b} -> {a}, {sb}{a} -> {b})"
        n = 2 * len(i)
        hints[a, b] = (f"{a} and {b} look swapped{how}: read the other way round their misfit falls from "
                       f"{read / n:.3g} to {swapped[k] / n:.3g} (mean square / noise^2); check [data] columns "
                       "(or the frame's rotation)")
    return hints


#: a stated noise in the wrong unit, by kind: factor stated / fitted -> the likely mistake
NOISE_UNITS = {"u": {1000.0: "given in um where mm are meant"},
               "e": {1e6: "given in microstrain where plain strain is meant", 100.0: "given in % where plain "
                     "strain is meant"}}


def noise_hint(rms: dict) -> str:
    """For a chi-square below its lower quantile: how much smaller than the stated noise each quantity's residuals
    are (``rms``: quantity -> RMS residual / noise), naming a unit where the ratio is one's factor.

    >>> noise_hint({"ux": 0.001}).split(";")[0].split(": ", 1)[1]
    'the ux residuals are 0.001 of the stated noise (RMS), a factor 1000: noise given in um where mm are meant?'
    """
    parts = []
    for name, value in rms.items():
        if not value > 0:
            continue
        units = NOISE_UNITS.get(kind_of(name), {})
        found = [(f, m) for f, m in units.items() if abs(np.log10(value * f)) < MATCH_DECADES]
        unit = f", a factor {found[0][0]:g}: noise {found[0][1]}?" if found else ""
        parts.append(f"the {name} residuals are {value:.3g} of the stated noise (RMS){unit}")
    return ("the stated noise is too large or the data were smoothed (or carry no noise, as data made by "
            "`frictionid simulate`): " + "; ".join(parts)
            + "; the standard errors, computed from the stated noise, are then too wide: state the noise of the "
              "data as fitted (docs/fit-quality.md)")
