"""[data] regions through the command line: patterns, exact names over patterns, bad keys and values exit 2."""

import csv
import shutil
from pathlib import Path

import pytest

from block2d_case import MODEL_TABLE
from frictionid.cli import main
from helpers import write_config

#: B1, B2 on the block-base interface (y = 0, on both bodies); Q1 on the base's top beside the block
POINTS = {"B1": (0.5, 0.0), "B2": (2.3, 0.0), "Q1": (-7.0, 0.0)}


def _config(folder: Path, name: str, regions: str, points: dict = POINTS) -> Path:
    rows = "".join(f"{label},{x!r},{y!r},0.0,2,0.0,0.0\n" for label, (x, y) in points.items())
    (folder / f"{name}.csv").write_text("point,x,y,z,stage,ux,uy\n" + rows)
    return write_config(folder / f"{name}.toml", model=MODEL_TABLE,
                        friction={"zones": {"A": 0.32, "B": 0.18, "C": 0.41}},
                        data=f'file = "{name}.csv"\nobservables = ["ux", "uy"]\nstages = [2]\nnoise = {{ u = 0.0005 }}\n'
                        f"regions = {{ {regions} }}\n", run={"fields": False, "dir": f"runs/{name}"})


def _simulated(folder: Path, name: str, regions: str, points: dict = POINTS) -> dict:
    """{label: (ux, uy)} [mm] at the end of stage 2, from `frictionid simulate`."""
    config = _config(folder, name, regions, points)
    assert main(["simulate", str(config), "--out", str(folder / f"{name}.out.csv")]) == 0
    with open(folder / f"{name}.out.csv") as f:
        rows = [r for r in csv.DictReader(line for line in f if not line.startswith("#")) if r["stage"] == "2"]
    return {r["point"]: (float(r["ux"]), float(r["uy"])) for r in rows}


def _same(values: dict) -> dict:
    """The values up to the solver's round-off (another point set condenses onto other dofs); a point read
    from the wrong body is off by 0.1 mm or more."""
    return {label: pytest.approx(v, rel=1e-9, abs=1e-12) for label, v in values.items()}


@pytest.fixture(scope="module")
def bodies(tmp_path_factory):
    """The values with every point read from the block, and from the base: they differ where the block slides."""
    folder = tmp_path_factory.mktemp("regions")
    block = _simulated(folder, "block", 'B1 = "block", B2 = "block", Q1 = "base"')
    base = _simulated(folder, "base", '"*" = "base"')
    # the block slides on the base at stage 2 (ux 0.19 mm against 0.014 mm at B1): a wrong body shows
    assert abs(block["B1"][0] - base["B1"][0]) > 0.1
    return folder, block, base


def test_a_pattern_names_the_points_it_matches(bodies):
    folder, block, _ = bodies
    assert _simulated(folder, "pattern", '"B*" = "block", "*" = "base"') == _same(block)


def test_an_exact_name_wins_over_a_pattern_and_the_longer_pattern_over_the_shorter(bodies):
    folder, block, base = bodies
    got = _simulated(folder, "exact", '"*" = "block", "B*" = "block", B2 = "base", "Q?" = "base"')
    assert got == _same({"B1": block["B1"], "B2": base["B2"], "Q1": base["Q1"]})


@pytest.mark.parametrize("command", ["identify", "simulate"])
@pytest.mark.parametrize("regions, message", [
    ('"b*" = "block", "*" = "base"', "data.regions: key 'b*' matches no point of the data (points: B1, B2, Q1)"),
    ('P9 = "block"', "data.regions: key 'P9' matches no point of the data"),
    ('B1 = "blok"', "data.regions.B1: 'blok' is not a region of the model (did you mean 'block'?); the model has"),
    ('"B*" = "block", "*1" = "base"', "point 'B1' matches the patterns ['B*', '*1'], equally specific"),
])
def test_a_key_matching_no_point_or_an_unknown_region_exits_2(tmp_path, capsys, command, regions, message):
    config = _config(tmp_path, "bad", regions)
    extra = ["--out", str(tmp_path / "unused.csv")] if command == "simulate" else []
    assert main([command, str(config), *extra]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "unused.csv").exists() and not (tmp_path / "runs").exists()


def _relative(got: dict, expected: dict) -> float:
    return max(abs(g - e) / max(map(abs, expected[label])) for label in expected
               for g, e in zip(got[label], expected[label]))


def test_points_just_off_a_face_are_read_on_it(tmp_path):
    """1e-7 mm beside the block's side and below its bottom (inside the base there): read on the block's faces."""
    on = {"S1": (5.0, 1.5), "B1": (0.5, 0.0)}
    off = {"S1": (5.0 + 1e-7, 1.5), "B1": (0.5, -1e-7)}
    regions = '"*" = "block"'
    expected, got = _simulated(tmp_path, "on", regions, on), _simulated(tmp_path, "off", regions, off)
    assert _relative(got, expected) < 1e-9
    # read from the base instead, B1 moves 0.18 mm less: the check above sees the body
    assert abs(_simulated(tmp_path, "base", 'S1 = "block", B1 = "base"', off)["B1"][0] - got["B1"][0]) > 0.1


@pytest.mark.parametrize("command", ["identify", "simulate"])
def test_a_point_half_a_millimetre_off_its_region_exits_2_naming_it(tmp_path, capsys, command):
    config = _config(tmp_path, "off", '"*" = "block"', {"S1": (5.0, 1.5), "S2": (5.5, 1.5)})
    extra = ["--out", str(tmp_path / "unused.csv")] if command == "simulate" else []
    assert main([command, str(config), *extra]) == 2
    err = capsys.readouterr().err
    assert "off.csv: point 'S2' at [5.5, 1.5] [mm] is outside region 'block' by 0.5 mm" in err
    assert "'S1'" not in err and "Traceback" not in err



def test_crosscheck_refuses_a_misspelt_region_before_running_ccx(tmp_path, capsys):
    """crosscheck's points without fitted data take their regions by the same rules (a misspelt region was
    silently ignored there); the error comes before any ccx run, so this needs no ccx."""
    folder = tmp_path / "first"
    shutil.copytree(Path(__file__).parents[1] / "examples" / "first", folder)
    text = (folder / "truth.toml").read_text().replace('"*" = "base"', '"*" = "bse"')
    (folder / "bad.toml").write_text(text)
    assert main(["crosscheck", str(folder / "bad.toml")]) == 2
    err = capsys.readouterr().err
    assert "'bse' is not a region of the model (did you mean 'base'?)" in err and "Traceback" not in err
