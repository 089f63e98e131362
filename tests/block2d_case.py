"""The small plane-strain case several end-to-end tests fit (test_identify, test_parallel, test_html_report): the
3-zone block2d model at 1 mm, six uy/ux observation points on the block's sides and the base top, its true
coefficients, and the [model] / regions lines of its configs."""

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
