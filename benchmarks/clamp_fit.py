"""The six-zone clamp fit (tests/fixtures/clamp) as a user runs it: `frictionid simulate` makes twin data on a finer
mesh (contact size 0.25 mm instead of 0.5, bodies 2 mm instead of 4: model error, so the minimum has a nonzero
residual), then `frictionid identify` fits all six zones from several starts with trf's default and its options
(x_scale 1.0, x_scale "se": the standard errors the start's Jacobian predicts, tr_solver "lsmr"), with
Levenberg-Marquardt ("lm", unbounded), without the final Gauss-Newton step at the se_step stop (final_step false),
without the start at the stick thresholds of the zones that stick along the whole load path (stick_start false),
with the stop on the step left tightened (se_step 0.01, 0.001, without the final step), and with it off
(se_step 0: scipy's own tests at tol 1e-10) as the reference minimum.
Prints per run: iterations, solves with sensitivities, final objective, wall time, the largest coefficient
difference from the reference run from the same start and why the fit stopped; then the table of all runs side by
side.

Data: ux, uy at 42 points (22 on the strip's side, 10 on each pad) at the ends of stages 2-4, noise 0.5 um for the
weights; truth U1..L3 = 0.15, 0.2, 0.25, 0.18, 0.22, 0.3.

Run: .venv/bin/python benchmarks/clamp_fit.py [--variants N,...] [start ...]   (default starts 0.1 0.02 0.6, every
variant; --variants 0,1,2: the reference, the default and the default without its final step, by their position
below; 5 to 30 s per fit measured on 2 shared cores)
"""

import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

CLAMP = Path(__file__).resolve().parents[1] / "tests" / "fixtures" / "clamp"
FRICTIONID = str(Path(sys.executable).with_name("frictionid"))
TRUTH = {"U1": 0.15, "U2": 0.2, "U3": 0.25, "L1": 0.18, "L2": 0.22, "L3": 0.3}
#: [identify] method and options compared; the first is the reference (no stop on the step left), the second
#: the default
VARIANTS = {
    "reference (se_step 0)": ("trf", "options = { se_step = 0.0 }\n"),
    "default (trf, x_scale jac, se_step 0.1, final step)": ("trf", ""),
    "no final step": ("trf", "options = { final_step = false }\n"),
    "se_step 0.01, no final step": ("trf", "options = { se_step = 0.01, final_step = false }\n"),
    "se_step 0.001, no final step": ("trf", "options = { se_step = 0.001, final_step = false }\n"),
    "x_scale 1.0": ("trf", "options = { x_scale = 1.0 }\n"),
    'x_scale "se"': ("trf", 'options = { x_scale = "se" }\n'),
    'tr_solver "lsmr"': ("trf", 'options = { tr_solver = "lsmr" }\n'),
    "lm": ("lm", ""),
    "no stick start": ("trf", "options = { stick_start = false }\n"),
}


def points_csv() -> str:
    rows = ["point,x,y,z,stage"]
    strip = [(x, y) for x in (2, 10, 18, 25, 33, 40, 47, 55, 62, 70, 78) for y in (-1.0, 1.0)]
    pads = [(x, y) for x in (22, 30, 40, 50, 58) for y in (4.0, 8.0)]
    for prefix, xy in (("S", strip), ("U", pads), ("L", [(x, -y) for x, y in pads])):
        rows += [f"{prefix}{k + 1},{x},{y},0.0,{s}" for k, (x, y) in enumerate(xy) for s in (2, 3, 4)]
    return "\n".join(rows) + "\n"


def model_table(geo: str) -> str:
    text = (CLAMP / "clamp.toml").read_text()
    return text[text.index("[model]"):text.index("[friction]")].replace('file = "clamp.geo"', f'file = "{geo}"')


def data_table(file: str) -> str:
    return (f'[data]\nfile = "{file}"\nobservables = ["ux", "uy"]\nstages = [2, 3, 4]\nnoise = {{ u = 0.0005 }}\n'
            'regions = { "S*" = "strip", "U*" = "upper_pad", "L*" = "lower_pad" }\n')


def run(args, cwd, check: bool = True) -> str:
    """The command's last line of standard error where it exits with status > 0 (``check``: raise), else ''."""
    done = subprocess.run([FRICTIONID, *args], cwd=cwd, check=check, capture_output=True, text=True, timeout=3600)
    return done.stderr.strip().splitlines()[-1] if done.returncode else ""


def main(starts: list[float], variants: dict = VARIANTS) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        shutil.copy(CLAMP / "clamp.geo", work)
        (work / "clamp_fine.geo").write_text('h = 2.0;\nc = 0.25;\nInclude "clamp.geo";\n')
        (work / "points.csv").write_text(points_csv())
        zones = ", ".join(f"{k} = {v}" for k, v in TRUTH.items())
        (work / "truth.toml").write_text(model_table("clamp_fine.geo") + f"[friction]\nzones = {{ {zones} }}\n"
                                         + data_table("points.csv"))
        run(["simulate", "truth.toml", "--out", "measured.csv"], work)
        table = {}
        for start in starts:
            reference = None
            for v, (name, (method, options)) in enumerate(variants.items()):
                tag = f"{start}_{v}"
                zones = ", ".join(f"{k} = {start}" for k in TRUTH)
                (work / f"fit_{tag}.toml").write_text(
                    model_table("clamp.geo") + f"[friction]\nzones = {{ {zones} }}\nbounds = [0.0, 1.0]\n"
                    + data_table("measured.csv")
                    + f'[identify]\nmethod = "{method}"\n{options}[run]\ndir = "runs/{tag}"\n')
                error = run(["identify", f"fit_{tag}.toml"], work, check=False)
                if error:
                    table[start, name] = "exit > 0"
                    print(f"start {start}, {name}: exit status > 0: {error}", flush=True)
                    continue
                result = json.loads((work / "runs" / tag / "result.json").read_text())
                mu = {k: v["value"] for k, v in result["parameters"].items()}
                reference = reference or mu
                difference = max(abs(mu[k] - reference[k]) for k in mu)
                table[start, name] = (f"{result['n_iterations']}, {result['n_sensitivity_solves']}, {difference:.0e}"
                                      + ("" if result["status"] == "converged" else f" ({result['status']})"))
                print(f"start {start}, {name}: {result['status']}, {result['n_iterations']} iterations, "
                      f"{result['n_sensitivity_solves']} solves, objective {result['objective']['final']:.8g}, "
                      f"{result['wall_time_s']:.0f} s; largest difference from the reference {difference:.1e}; "
                      + ", ".join(f"{k} {v:.6f}" for k, v in mu.items()) + f"; stop: {result['message']}",
                      flush=True)
        print("\niterations, solves with sensitivities, largest coefficient difference from the reference")
        print("| start | " + " | ".join(variants) + " |")
        print("|---" * (len(variants) + 1) + "|")
        for start in starts:
            print(f"| {start} | " + " | ".join(table[start, name] for name in variants) + " |")


if __name__ == "__main__":
    args = sys.argv[1:]
    chosen = VARIANTS
    if args[:1] == ["--variants"]:
        names = list(VARIANTS)
        chosen = {names[int(k)]: VARIANTS[names[int(k)]] for k in args[1].split(",")}
        args = args[2:]
    main([float(a) for a in args] or [0.1, 0.02, 0.6], chosen)
