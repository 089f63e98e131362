"""The small plane-strain case several end-to-end tests fit (test_identify, test_parallel, test_html_report): the
3-zone block2d model at 1 mm, six uy/ux observation points on the block's sides and the base top, its true
coefficients, and the [model] / regions lines of its configs."""

from pathlib import Path

from helpers.config import config_text, toml_value

#: the coefficients the twin data are simulated with
TRUE = {"A": 0.32, "B": 0.18, "C": 0.41}
#: the six observation points: four on the block's sides, two on the base top (plane strain, z = 0)
XY = {"P1": (-5.0, 0.5), "P2": (-5.0, 1.5), "P3": (5.0, 0.5), "P4": (5.0, 1.5), "P5": (-7.0, 0.0), "P6": (7.0, 0.0)}


def points_csv(stage: int = 1, quantities: tuple[str, ...] = ("uy",)) -> str:
    """A measurement file template of the six points at ``stage`` with ``quantities`` columns (values are
    placeholders; `frictionid simulate` fills them)."""
    rows = "".join(f"{p},{x},{y},0.0,{stage}" + ",0.0" * len(quantities) + "\n" for p, (x, y) in XY.items())
    return ("# observation points on the block's sides and the base top (plane strain, z = 0)\n"
            f"point,x,y,z,stage{''.join(',' + q for q in quantities)}\n" + rows)


POINTS = points_csv()
#: the [model] table
MODEL_TABLE = {"builder": "block2d", "mesh_size": 1.0, "height": 4.0, "n_zones": 3}
MODEL = config_text(model=MODEL_TABLE)
#: [data] regions: P1-P4 on the block, P5, P6 on the base
REGION_TABLE = {"P1": "block", "P2": "block", "P3": "block", "P4": "block", "P5": "base", "P6": "base"}
REGIONS = f"regions = {toml_value(REGION_TABLE)}\n"


def data_table(file: str, noise: float = 0.0005, observables=("ux", "uy")) -> dict:
    """The [data] table of a fit of ``file`` at stage 2 with a displacement noise [mm]."""
    return {"file": file, "observables": list(observables), "stages": [2], "noise": {"u": noise},
            "regions": REGION_TABLE}


#: the two-zone case of the discretisation control's tests: linear triangles, data from a mesh 8 times finer
CONTROL_TRUE = {"A": 0.32, "B": 0.18}


def control_config(folder: Path, name: str, mesh: float, zones: dict, data: str, identify: str = "") -> Path:
    """``folder``/<name>.toml: the two-zone block2d (height 4, linear triangles of ``mesh`` mm) fitted to ``data``
    (ux, uy of stage 2 at the six points, noise 0.2 um), [identify] lines ``identify``, run.dir runs/<name>."""
    path = folder / f"{name}.toml"
    table = ", ".join(f"{k} = {v}" for k, v in zones.items())
    path.write_text(f'[model]\nbuilder = "block2d"\nheight = 4.0\norder = 1\nmesh_size = {mesh}\n'
                    f"[friction]\nzones = {{ {table} }}\n"
                    f'[data]\nfile = "{data}"\nobservables = ["ux", "uy"]\nstages = [2]\nnoise = {{ u = 0.0002 }}\n'
                    + REGIONS + f"[identify]\n{identify}" + f'[run]\ndir = "runs/{name}"\n')
    return path


def control_data(folder: Path) -> Path:
    """``folder`` with points.csv and measured.csv: noise-free data of the six points at CONTROL_TRUE from linear
    triangles of 0.25 mm."""
    from frictionid.cli import main

    (folder / "points.csv").write_text(points_csv(stage=2, quantities=("ux", "uy")))
    assert main(["simulate", str(control_config(folder, "truth", 0.25, CONTROL_TRUE, "points.csv")),
                 "--out", str(folder / "measured.csv")]) == 0
    return folder
