"""report.html: one self-contained page per run (figures inline as base64 PNG, CSS inline, no scripts, no links out)."""

from __future__ import annotations

import base64
import hashlib
import html
import importlib.metadata
import platform
from datetime import datetime, timezone
from pathlib import Path

#: distributions whose versions the provenance lists (the numbers come from them)
PACKAGES = ("frictionid", "numpy", "scipy", "scikit-fem", "matplotlib", "gmsh")
#: a coefficient this close to a bound (relative to the bounds' width) prints as the bound at 4 decimals
NEAR_BOUND = 1e-4
#: rows of the per-observation table shown before it is cut (the figure shows them all)
MAX_ROWS = 2000

_CSS = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 70em; color: #222; line-height: 1.35; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; border-bottom: 1px solid #ccc; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: right; vertical-align: top; }
th { background: #eee; } td { white-space: nowrap; } td.text, th.text { text-align: left; white-space: normal; }
.bad { color: #a00; font-weight: bold; } .good { color: #070; } .note { color: #555; }
img { max-width: 100%; border: 1px solid #ddd; }
pre { background: #f6f6f6; padding: 0.6em; overflow-x: auto; font-size: 0.85em; }
"""


def write_html(run_dir: Path, result: dict, figures: dict[str, bytes] | None = None, config_text: str | None = None,
               data_file: Path | None = None) -> Path:
    """Write ``<run_dir>/report.html`` from a result (result.json's dict, complete or of a stopped run).

    ``figures``: PNG bytes by name ("convergence", "residuals", "fit"); ``config_text`` and ``data_file`` (its
    sha256 is computed here) for the provenance. Returns the path.
    """
    path = Path(run_dir) / "report.html"
    path.write_text(report_html(result, figures or {}, config_text, data_file, Path(run_dir).name), encoding="utf-8")
    return path


def report_html(result: dict, figures: dict[str, bytes], config_text: str | None = None,
                data_file: Path | None = None, title: str = "") -> str:
    """The page as a string; every section says so when the run did not get far enough to fill it."""
    sections = [_summary(result), _coefficients(result), *_starts(result.get("starts")), _adequacy(result.get("fit")),
                _figure("Convergence", figures.get("convergence"), "objective and free coefficients per iteration"),
                _fit(result.get("fit"), figures.get("fit")),
                _figure("Residual map", figures.get("residuals"),
                        "each measurement point at its model position, coloured by its RMS residual / noise"),
                _identifiability(result), _contact(result.get("model")), _statistics(result),
                _provenance(config_text, data_file)]
    head = f"frictionid report: {title}" if title else "frictionid report"
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{_e(head)}</title><style>{_CSS}</style></head>\n<body>\n<h1>{_e(head)}</h1>\n"
            + "\n".join(sections) + "\n</body></html>\n")


def _e(value) -> str:
    return html.escape(str(value))


def _num(value, fmt: str = ".4g") -> str:
    return "&ndash;" if value is None else format(value, fmt)


def _table(header, rows, text_columns=()) -> str:
    """An HTML table; cells are HTML already (escape text with :func:`_e`); columns in ``text_columns``
    are left-aligned."""
    def cell(tag, k, value):
        align = ' class="text"' if k in text_columns else ""
        return f"<{tag}{align}>{value}</{tag}>"
    lines = ["<table>", "<tr>" + "".join(cell("th", k, h) for k, h in enumerate(header)) + "</tr>"]
    lines += ["<tr>" + "".join(cell("td", k, v) for k, v in enumerate(row)) + "</tr>" for row in rows]
    return "\n".join(lines + ["</table>"])


def _section(title: str, body: str) -> str:
    return f"<section><h2>{_e(title)}</h2>\n{body}\n</section>"


def _missing(what: str) -> str:
    return f"<p class=\"note\">{_e(what)}</p>"


def _summary(result: dict) -> str:
    status = result.get("status", "unknown")
    ok = status == "converged"
    lines = [f"<p>Status: <span class=\"{'good' if ok else 'bad'}\">{_e(status)}</span>"
             + (f" &mdash; {_e(result['message'])}" if result.get("message") else "") + "</p>",
             f"<p>Method {_e(result.get('method'))}, {_e(result.get('jacobian'))} Jacobian, "
             f"{_e(result.get('backend'))} backend.</p>"]
    if status in ("interrupted", "failed"):
        lines.append(_missing("The run did not finish: the coefficients are its last iterate; fit statistics, "
                              "uncertainties and identifiability were not computed. Continue it with --resume."))
    return "\n".join(lines)


def _bound_flag(p: dict) -> str:
    if p.get("at_bound"):
        return "<span class=\"bad\">at bound</span>"
    bounds = p.get("bounds")
    if bounds is not None:
        width = bounds[1] - bounds[0]
        gap = min(abs(p["value"] - bounds[0]), abs(bounds[1] - p["value"]))
        if gap <= NEAR_BOUND * width:
            return f"<span class=\"bad\">at bound</span> (within {gap:.2g})"
    return "no" if "at_bound" in p else "&ndash;"


def _verdict(p: dict) -> str:
    if p["fixed"]:
        return "fixed"
    if "identifiable" not in p:
        return "not assessed"
    return "<span class=\"good\">resolved</span>" if p["identifiable"] else "<span class=\"bad\">NOT RESOLVED</span>"


def _coefficients(result: dict) -> str:
    truth = result.get("truth") or {}
    header = ["zone", "value", "stderr", "95 % interval", "initial", *(["true"] if truth else []), "bounds",
              "at bound", "verdict", "why"]
    rows = []
    for name, p in result["parameters"].items():
        ci = p.get("ci95")
        interval = "&ndash;" if ci is None else \
            f"[{ci[0]:.4f}, {ci[1]:.4f}]" + (" one-sided" if p.get("at_bound") else "")
        stderr = "cannot be estimated" if not p["fixed"] and "stderr" in p and p["stderr"] is None else _num(
            p.get("stderr"), ".4g")
        rows.append([_e(name), f"{p['value']:.6f}", stderr, interval, _num(p.get("initial"), ".4f"),
                     *([_num(truth.get(name), ".4f")] if truth else []),
                     "&ndash;" if p.get("bounds") is None else f"[{p['bounds'][0]:g}, {p['bounds'][1]:g}]",
                     "&ndash;" if p["fixed"] else _bound_flag(p), _verdict(p), _e(p.get("why", ""))])
    text = [header.index(h) for h in ("zone", "at bound", "verdict", "why")]
    return _section("Coefficients", _table(header, rows, text_columns=text))


def _starts(starts: list[dict] | None) -> list[str]:
    """The starts of a multi-start run (none for a single start)."""
    if not starts:
        return []
    zones = list(starts[0]["initial"])
    header = ["start", *(f"{z} from" for z in zones), *(f"{z} to" for z in zones), "objective", "status",
              "iterations", "reported"]
    rows = [[str(s["start"]), *(f"{v:.4f}" for v in s["initial"].values()),
             *((f"{v:.4f}" for v in s["value"].values()) if "value" in s else ["&ndash;"] * len(zones)),
             _num(s.get("objective"), ".6e"), _e(s["status"] + (f": {s['message']}" if s.get("message") else "")),
             _num(s.get("n_iterations"), "d"), "yes" if s["best"] else ""] for s in starts]
    return [_section("Starts", "<p>The fit from each start point (identify.starts); the one with the lowest "
                               "objective is reported above.</p>\n" + _table(header, rows, (len(header) - 3,)))]


def _group_table(title: str, table: dict) -> str:
    rows = [[_e(key), _num(g.get("rms"), ".3g"), str(g.get("n", "")), f"{g.get('share', 0):.0%}"]
            for key, g in sorted(table.items(), key=lambda t: -t[1].get("share", 0))]
    return f"<h3>Misfit by {_e(title)}</h3>" + _table([title, "RMS / noise", "count", "share of chi2"], rows, (0,))


def _adequacy(fit: dict | None) -> str:
    if not fit:
        return _section("Fit adequacy", _missing("not computed (the run did not finish)"))
    verdict = {True: ("good", "the stated noise explains the misfit"),
               False: ("bad", "THE MODEL DOES NOT EXPLAIN THE DATA at the stated noise"),
               None: ("note", "no stated noise: whether the model explains the data cannot be tested")}
    css, text = verdict[fit.get("consistent")] if not fit.get("too_small") else \
        ("bad", "THE MISFIT IS SMALLER THAN THE STATED NOISE ALLOWS: the stated noise is too large or the data "
                "were smoothed")
    rows = [["observations", str(fit["n_obs"])], ["chi-square", f"{fit['chi2']:.4g}"], ["dof", str(fit["dof"])],
            ["reduced chi-square", _num(fit.get("reduced_chi2"))], ["its 99 % quantile", _num(fit.get("chi2_99"))],
            ["its 1 % quantile", _num(fit.get("chi2_01"))],
            ["p-value", _num(fit.get("p_value"))], ["error scale", _num(fit.get("error_scale"))],
            ["loss", _e(fit.get("loss", "linear"))], ["down-weighted", str(fit.get("n_downweighted", 0))],
            ["RMS residual (data units)", _num(fit.get("rms_residual"))]]
    parts = [f"<p class=\"{css}\">{_e(text)}</p>", _table(["statistic", "value"], rows, (0,))]
    misfit = fit.get("misfit", {})
    for title, key in (("quantity", "by_quantity"), ("stage", "by_stage"), ("point group", "by_group")):
        if misfit.get(key):
            parts.append(_group_table(title, misfit[key]))
    if fit.get("worst"):
        parts.append("<h3>Worst observations</h3>" + _table(
            ["observation", "residual / noise", "measured", "model"],
            [[_e(w["observation"]), f"{w['residual']:+.3g}", f"{w['measured']:.5g}", f"{w['model']:.5g}"]
             for w in fit["worst"]], (0,)))
    if fit.get("hint") and (fit.get("consistent") is False or fit.get("too_small")):
        parts.append(f"<p>What to try: {_e(fit['hint'])}</p>")
    parts.append(_model_error(fit.get("model_error")))
    return _section("Fit adequacy", "\n".join(parts))


def _model_error(error: dict | None) -> str:
    if not (error or {}).get("summary"):
        why = f" {error['why']}." if (error or {}).get("requested") == "auto" else ""
        return _missing(f"Discretisation error not checked (identify.model_error = \"estimate\" checks it).{why}")
    rows = [[_e(key), _num(v.get("rms"), ".3g"), _num(v.get("max"), ".3g")]
            for key, v in error.get("summary", {}).items()]
    shift = {zone: v for zone, v in (error.get("shift") or {}).items() if v is not None}
    how = ("the discretisation control's prediction for the fitted model" if error.get("source") ==
           "discretisation control" else f"model refined x{error.get('factor', '?')}")
    text = (f"<h3>Estimated model (discretisation) error</h3><p>mode {_e(error.get('mode'))}"
            + (f" ({_e(error['why'])})" if error.get("requested") == "auto" else "")
            + f", {_e(how)}; in noise levels:</p>" + _table(["where", "RMS", "max"], rows, (0,)))
    if shift:
        text += "<p>Corrected for it the coefficients would move by (linearised): " + ", ".join(
            f"{_e(zone)} {v:+.3g}" for zone, v in shift.items()) + "</p>"
    return text


def _figure(title: str, png: bytes | None, caption: str) -> str:
    if not png:
        return _section(title, _missing("no figure: the run has no data for it"))
    data = base64.b64encode(png).decode("ascii")
    return _section(title, f"<figure><img alt=\"{_e(title)}\" src=\"data:image/png;base64,{data}\">"
                           f"<figcaption class=\"note\">{_e(caption)}</figcaption></figure>")


def _fit(fit: dict | None, png: bytes | None) -> str:
    figure = _figure("Measured and fitted", png, "measured +/- sigma and the fitted model's value per observation")
    observations = (fit or {}).get("observations")
    if not observations:
        return figure
    rows = [[_e(o["label"]), f"{o['measured']:.6g}", f"{o['model']:.6g}", _num(o.get("sigma"), ".3g"),
             "&ndash;" if not o.get("sigma") else f"{(o['model'] - o['measured']) / o['sigma']:+.3g}"]
            for o in observations[:MAX_ROWS]]
    cut = f" (first {MAX_ROWS} of {len(observations)})" if len(observations) > MAX_ROWS else ""
    table = _table(["observation", "measured", "model", "sigma", "(model - measured) / sigma"], rows, (0,))
    return figure.replace("</section>", f"<details><summary>all observations{cut}</summary>\n{table}\n</details>"
                                        "\n</section>")


def _identifiability(result: dict) -> str:
    ident = result.get("identifiability")
    if not ident:
        return _section("Identifiability", _missing("not computed (the run did not finish)"))
    names = [n for n, p in result["parameters"].items() if not p["fixed"]]
    parts = ["<p>Singular values of the weighted Jacobian: "
             + ", ".join(_num(v, ".3g") for v in ident["singular_values"]) + "</p>"]
    if ident.get("message"):
        parts.append(f"<p class=\"bad\">{_e(ident['message'])}</p>")
    matrix = [[_e(a)] + [_num(c, "+.3f") for c in row] for a, row in zip(names, ident.get("correlation", []))]
    parts.append("<h3>Correlations</h3>" + _table(["", *map(_e, names)], matrix, (0,)))
    prefit = ident.get("prefit")
    if prefit:
        rows = [[_e(n), _num(prefit["stderr"][n], ".4f"), "yes" if prefit["resolved"][n] else
                 "<span class=\"bad\">NO</span>"] for n in prefit["stderr"]]
        parts.append("<h3>Resolution before fitting (at the start values)</h3>"
                     + _table(["zone", "predicted stderr", "resolved"], rows, (0,)))
    return _section("Identifiability", "\n".join(parts))


def _adjusted(meshed) -> str:
    """The note on an interface whose initial gaps were set to zero (``adjust``), naming the gaps as meshed."""
    return "" if meshed is None else f" (set to zero from {meshed[0]:.3g} to {meshed[1]:.3g} as meshed)"


def _contact(model: dict | None) -> str:
    """The contact map checked at model build (result.json ``model.contact``): per interface its pairs, initial
    gaps, facing check and state, then its zones."""
    interfaces = (model or {}).get("contact")
    if not interfaces:
        return _section("Contact set-up", _missing("no contact map in this result"))
    rows = [[_e(c["name"]), _e(c["target"]), _e(c["discretisation"]), c["n_pairs"], c["n_left_out"],
             f"{_num(c['gap'][0], '.3g')} to {_num(c['gap'][1], '.3g')}" + _adjusted(c.get("adjusted_from")),
             _num(c["gap_tolerance"], ".3g"),
             _num(c["facing_deg"], ".3g"), _e(", ".join(f"{n} {k}" for k, n in c["state"].items() if n))]
            for c in interfaces]
    zones = [[_e(c["name"]), _e(zone), _e(z["coefficient"]), z["pairs"], _num(z["area"], ".4g"),
              "&ndash;" if z["gap"] is None else f"{z['gap'][0]:.3g} to {z['gap'][1]:.3g}"]
             for c in interfaces for zone, z in c["zones"].items()]
    return _section("Contact set-up", "<p>Checked at model build, before any solve.</p>" + _table(
        ["interface", "target", "discretisation", "pairs", "nodes not covered", "initial gap [mm]",
         "gap tolerance [mm]", "facing within [deg]", "initial state"], rows, (0, 1, 2, 8))
        + _table(["interface", "zone", "coefficient", "pairs", "area [mm&sup2;]", "initial gap [mm]"], zones,
                 (0, 1, 2)))


def _statistics(result: dict) -> str:
    objective = result.get("objective") or {}
    rows = [["iterations", result.get("n_iterations")], ["forward solves", result.get("n_forward_solves")],
            ["solves with sensitivities", result.get("n_sensitivity_solves")],
            ["replayed from the store", result.get("n_replayed")], ["failed solves", result.get("n_failed_solves")],
            ["objective at the start", _num(objective.get("initial"), ".6e")],
            ["objective at the end", _num(objective.get("final"), ".6e")],
            ["wall time [s]", _num(result.get("wall_time_s"), ".2f")]]
    cells = [[k, "&ndash;" if v is None else v] for k, v in rows]
    return _section("Solver statistics", _table(["count", "value"], cells, (0,)))


def _version(package: str) -> str:
    try:
        return importlib.metadata.version(package)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def _provenance(config_text: str | None, data_file: Path | None) -> str:
    rows = [[_e(p), _e(_version(p))] for p in PACKAGES]
    rows += [["Python", _e(platform.python_version())], ["platform", _e(platform.platform())],
             ["report written", datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")]]
    if data_file is not None and Path(data_file).is_file():
        content = Path(data_file).read_bytes()
        rows += [["data file", _e(data_file)], ["data sha256", hashlib.sha256(content).hexdigest()],
                 ["data size [bytes]", str(len(content))]]
    else:
        rows.append(["data file", "not given" if data_file is None else f"{_e(data_file)} (missing)"])
    config = "<h3>Configuration</h3><pre>" + _e(config_text) + "</pre>" if config_text is not None else \
        _missing("configuration not given")
    return _section("Provenance", _table(["item", "value"], rows, (0, 1)) + config)
