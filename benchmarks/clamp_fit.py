"""The six-zone clamp fit (tests/fixtures/clamp) as a user runs it: `frictionid simulate` makes twin data on a finer
mesh (contact size 0.25 mm instead of 0.5, bodies 2 mm instead of 4: model error, so the minimum has a nonzero
residual), then `frictionid identify` fits all six zones with trf from several starts and with several x_scale
options. Prints per run: iterations, solves with sensitivities, final objective, wall time, and the largest
coefficient difference from the default run from the same start.

Data: ux, uy at 42 points (22 on the strip's side, 10 on each pad) at the ends of stages 2-4, noise 0.5 um for the
weights; truth U1..L3 = 0.15, 0.2, 0.25, 0.18, 0.22, 0.3.

Run: .venv/bin/python benchmarks/clamp_fit.py [start ...]   (default starts 0.1 0.02 0.6; about 2 min per fit)
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
#: [identify] options compared; the first is the default
VARIANTS = {"default (x_scale jac)": "", "x_scale 1.0": "options = { x_scale = 1.0 }\n"}


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


def run(args, cwd) -> None:
    subprocess.run([FRICTIONID, *args], cwd=cwd, check=True, capture_output=True, timeout=3600)


def main(starts: list[float]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        shutil.copy(CLAMP / "clamp.geo", work)
        (work / "clamp_fine.geo").write_text('h = 2.0;\nc = 0.25;\nInclude "clamp.geo";\n')
        (work / "points.csv").write_text(points_csv())
        zones = ", ".join(f"{k} = {v}" for k, v in TRUTH.items())
        (work / "truth.toml").write_text(model_table("clamp_fine.geo") + f"[friction]\nzones = {{ {zones} }}\n"
                                         + data_table("points.csv"))
        run(["simulate", "truth.toml", "--out", "measured.csv"], work)
        for start in starts:
            reference = None
            for name, options in VARIANTS.items():
                tag = f"{start}_{len(options)}"
                zones = ", ".join(f"{k} = {start}" for k in TRUTH)
                (work / f"fit_{tag}.toml").write_text(
                    model_table("clamp.geo") + f"[friction]\nzones = {{ {zones} }}\nbounds = [0.0, 1.0]\n"
                    + data_table("measured.csv") + f'[identify]\nmethod = "trf"\n{options}[run]\ndir = "runs/{tag}"\n')
                run(["identify", f"fit_{tag}.toml"], work)
                result = json.loads((work / "runs" / tag / "result.json").read_text())
                mu = {k: v["value"] for k, v in result["parameters"].items()}
                reference = reference or mu
                print(f"start {start}, {name}: {result['status']}, {result['n_iterations']} iterations, "
                      f"{result['n_sensitivity_solves']} solves, objective {result['objective']['final']:.6g}, "
                      f"{result['wall_time_s']:.0f} s; largest difference from the default "
                      f"{max(abs(mu[k] - reference[k]) for k in mu):.1e}; "
                      + ", ".join(f"{k} {v:.4f}" for k, v in mu.items()), flush=True)


if __name__ == "__main__":
    main([float(a) for a in sys.argv[1:]] or [0.1, 0.02, 0.6])
