"""What the fit-adequacy report says about input mistakes (docs/fit-quality.md, "Input mistakes the misfit names").

The twin of docs/getting-started.md (examples/first: data simulated on the 0.5 mm mesh at A 0.30, B 0.15, fitted
on the 1 mm mesh with u noise 0.5 um), its data file broken in one way per run:

- force_N: the machine force observed (noise 0.05 N/mm) but written 10 times too large, as a load cell's N for
  a 10 mm thick specimen where the plane-strain model's force is per mm of thickness;
- ux_um: the ux column in um where mm are meant (times 1000);
- swapped: the ux and uy columns exchanged (the header names them the other way round);
- noise_um: the data as made, the noise stated 1000 times too large (0.5 where 0.0005 mm is meant).

Each run is the command line as a user runs it; the script prints per run the reduced chi-square, the verdict
(consistent / too_small) and the start of fit.hint, and the wall time.

    python benchmarks/input_mistakes.py            # about 4 minutes on one core
"""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def frictionid(*args: str, cwd: Path) -> None:
    subprocess.run([sys.executable, "-m", "frictionid.cli", *args], cwd=cwd, check=True, capture_output=True,
                   timeout=1800)


def write(path: Path, header: list[str], rows: list[list[str]]) -> None:
    with path.open("w", newline="") as handle:
        handle.write("# broken on purpose by benchmarks/input_mistakes.py\n")
        csv.writer(handle, lineterminator="\n").writerows([header, *rows])


def variants(folder: Path) -> dict[str, tuple[str, str]]:
    """name -> (data file, config text) of each broken run."""
    lines = [line for line in (folder / "measured.csv").read_text().splitlines() if not line.startswith("#")]
    header, *rows = list(csv.reader(lines))
    force, ux, uy = header.index("force"), header.index("ux"), header.index("uy")
    write(folder / "force_N.csv", header, [r[:force] + [repr(10 * float(r[force]))] + r[force + 1:] for r in rows])
    write(folder / "ux_um.csv", header, [r[:ux] + [repr(1000 * float(r[ux]))] + r[ux + 1:] for r in rows])
    swapped = list(header)
    swapped[ux], swapped[uy] = header[uy], header[ux]
    write(folder / "swapped.csv", swapped, rows)
    text = (folder / "identify.toml").read_text()
    return {"force_N": ("force_N.csv", text.replace('["ux", "uy"]', '["ux", "uy", "force"]')
                        .replace("noise = { u = 0.0005 }", "noise = { u = 0.0005, force = 0.05 }")),
            "ux_um": ("ux_um.csv", text), "swapped": ("swapped.csv", text),
            "noise_um": ("measured.csv", text.replace("noise = { u = 0.0005 }", "noise = { u = 0.5 }"))}


def main() -> None:
    with tempfile.TemporaryDirectory(prefix="frictionid-mistakes-") as tmp:
        folder = Path(tmp) / "first"
        shutil.copytree(ROOT / "examples" / "first", folder)
        frictionid("simulate", "truth.toml", "--out", "measured.csv", cwd=folder)
        print(f"{'run':<10}{'reduced chi2':>14}  {'verdict':<11}{'time [s]':>9}  hint")
        for name, (data, text) in variants(folder).items():
            config = folder / f"{name}.toml"
            config.write_text(text.replace("measured.csv", data).replace("runs/first", f"runs/{name}"))
            start = time.perf_counter()
            frictionid("identify", config.name, cwd=folder)
            wall = time.perf_counter() - start
            fit = json.loads((folder / "runs" / name / "result.json").read_text())["fit"]
            verdict = "too small" if fit["too_small"] else "explained" if fit["consistent"] else "misfit"
            print(f"{name:<10}{fit['reduced_chi2']:>14.4g}  {verdict:<11}{wall:>9.1f}  {fit['hint'][:300]}")


if __name__ == "__main__":
    main()
