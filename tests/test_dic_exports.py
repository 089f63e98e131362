"""DIC exports (issue 15, item 1): each flavour reads to the values of the generic CSV, invalid points dropped and
counted; bad exports exit 2 with a message saying what would work; per-stage exports identify like the CSV."""

import dataclasses
import json
import shutil
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from frictionid.cli import main
from frictionid.data import read_measurements, write_measurements
from frictionid.data.dic import read_export
from frictionid.data.sources import read_data
from frictionid.errors import InputError
from frictionid.options import DataSpec
from fixtures.dic import generate
from helpers.config import with_data

ROOT = Path(__file__).parents[1]
FIXTURES = ROOT / "tests" / "fixtures" / "dic"

#: exports carry values to 17 digits; unit and strain-measure conversions cost a few ulp
RTOL = 1e-12


def relative_error(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300)))


def test_the_fixtures_are_what_the_generator_writes(tmp_path):
    generate.main(tmp_path)
    for name in ["generic.csv"] + [file for _, file, _, _ in generate.WRITERS.values()]:
        assert (tmp_path / name).read_bytes() == (FIXTURES / name).read_bytes(), name


@pytest.mark.parametrize("flavour", list(generate.WRITERS))
def test_each_export_reads_to_the_generic_values_with_invalid_points_dropped(flavour, tmp_path):
    writer, file, strain, n_invalid = generate.WRITERS[flavour]
    generic = read_measurements(FIXTURES / "generic.csv")
    labels = writer(tmp_path / file, generic)                  # the labels the reader must give
    m, report = read_export(FIXTURES / file, stage=1, strain=strain)
    assert report.flavour == flavour                          # recognised from the header, no format given
    assert m.points == tuple(labels)
    assert report.n_rows == generic.n_rows + n_invalid and report.n_valid == generic.n_rows
    assert sum(report.dropped.values()) == n_invalid
    assert relative_error(m.coordinates, generic.coordinates) < RTOL
    assert m.quantities == generic.quantities
    for q in generic.quantities:
        assert relative_error(m.values[q], generic.values[q]) < RTOL, q
    assert np.all(m.stage == 1) and np.all(np.isnan(m.force))


def test_check_data_says_what_it_recognised(capsys):
    assert main(["check-data", str(FIXTURES / "gom_correlate.csv")]) == 0
    out = capsys.readouterr().out
    assert "gom export (';'-separated, decimal comma, latin-1" in out
    assert "ux <- 'dx'" in out and "ux [µm]" in out and "exx [%]" in out
    assert "engineering (technical) strain" in out
    assert "12 valid of 14 rows; dropped: 1 without any value; 1 with empty or NaN coordinates" in out
    assert "points: 12, rows: 12" in out                       # the measurements' summary follows


def test_dice_invalid_markers_are_dropped_and_counted_each(capsys):
    """DICe marks a failed point by SIGMA = -1 and MATCH = -1 (record_failed_step) and by its STATUS_FLAG; each marker
    alone drops the row and check-data counts it under that marker."""
    m, report = read_export(FIXTURES / "DICe_solution_0001.txt", stage=1)
    assert report.dropped == {"with SIGMA = -1 (correlation failed)": 1, "with MATCH = -1 (correlation failed)": 1,
                              "with a STATUS_FLAG of failure (not 0-4, 6, 18 or 26: DICe's Status_Flag)": 1}
    assert "2" not in m.points and "8" not in m.points and "12" not in m.points and len(m.points) == 12
    assert main(["check-data", str(FIXTURES / "DICe_solution_0001.txt")]) == 0
    out = capsys.readouterr().out
    assert "12 valid of 15 rows; dropped: 1 with SIGMA = -1 (correlation failed); 1 with a STATUS_FLAG" in out
    assert "1 with MATCH = -1" in out


def test_dice_header_geometry_is_reported_and_the_window_source_said(capsys, tmp_path):
    """DICe's preamble gives the subset, step and VSG strain window in image pixels: check-data reports them, and the
    window in mm at the pixel size fitted between the pixel and the model coordinates, with the residual (the
    fixture's points lie on a curved patch, so the map is no uniform scale: said to be approximate); check-data
    CONFIG says where the fit's window comes from."""
    from frictionid.config import config_from_dict
    from frictionid.data.sources import check_config_data

    assert main(["check-data", str(FIXTURES / "DICe_solution_0001.txt")]) == 0
    out = capsys.readouterr().out
    assert "DICe header: subset 41 px, step 10 x 10 px, VSG strain window 61 px (a circle in the image)" in out
    assert "strain window 61 px from the header = " in out and "the scale fitted between the pixel and the " \
        "physical coordinates of 12 points: residual RMS" in out and "the window in mm is approximate" in out
    _, report = read_export(FIXTURES / "vic3d.csv", stage=1)
    assert report.notes == () and report.window is None
    shutil.copy(FIXTURES / "DICe_solution_0001.txt", tmp_path)
    for window, said in ((None, "mm (circle, diameter), from the header of"),
                         (1.5, "strain window: 1.5 mm (square), from [data] strain_window")):
        config = config_from_dict({"data": {"file": "DICe_solution_0001.txt", "observables": ["ux"], "stages": [1],
                                            "strain_window": window}}, need=("data",), base=tmp_path)
        assert said in check_config_data(config.data, config.resolve, config.where)
    shutil.copy(FIXTURES / "vic3d.csv", tmp_path)
    config = config_from_dict({"data": {"file": "vic3d.csv", "observables": ["ux"], "stages": [1]}}, need=("data",),
                              base=tmp_path)
    assert "strain window: none ([data] strain_window not set, no strain window in the exports' headers)" in \
        check_config_data(config.data, config.resolve, config.where)


def test_a_format_is_recognised_from_the_head_or_past_a_long_preamble(tmp_path):
    """The reader is chosen from the file's first 64 kB; a preamble longer than that is read whole."""
    from frictionid.data.dic.text import HEAD_BYTES, read_text

    generic = (FIXTURES / "generic.csv").read_text()
    long = tmp_path / "long.csv"
    long.write_text("# provenance ...\n" * (HEAD_BYTES // 17 + 10) + generic)
    assert read_text(long, n_rows=50).names[:2] == ("point", "x")
    read = read_data(DataSpec.from_table({"file": "long.csv"}), lambda p: tmp_path / p)
    assert read.digest() == read_measurements(FIXTURES / "generic.csv").digest() and len(read.comments) > 3000


def test_check_data_reads_a_generic_csv_as_before(capsys):
    assert main(["check-data", str(FIXTURES / "generic.csv")]) == 0
    out = capsys.readouterr().out
    assert "generic CSV, stages 1 from its stage column" in out and "points: 12, rows: 12" in out


def check_data_error(capsys, path, *options) -> str:
    assert main(["check-data", str(path), *options]) == 2
    err = capsys.readouterr().err
    assert err.startswith("frictionid: error:") and "Traceback" not in err
    return err


def test_a_header_no_flavour_knows_lists_what_was_found_and_what_is_expected(capsys, tmp_path):
    path = tmp_path / "unknown.csv"
    path.write_text("Id;Xpos [mm];Ypos [mm];Ux [mm]\n1;0,5;1,5;0,001\n", encoding="utf-8")
    err = check_data_error(capsys, path)
    assert "no known layout in this header: 'Id', 'Xpos [mm]', 'Ypos [mm]', 'Ux [mm]'" in err
    for flavour in generate.WRITERS:
        assert f"  {flavour}" in err
    assert "generic" in err and "[data] columns = { x = " in err


def test_a_forced_format_without_a_coordinate_column_is_refused(capsys, tmp_path):
    path = tmp_path / "davis.csv"
    path.write_text("x [mm];Vx [mm];Vy [mm]\n0,5;0,001;0,002\n", encoding="utf-8")
    err = check_data_error(capsys, path, "--format", "davis")
    assert "no coordinate column for y" in err and "'x [mm]', 'Vx [mm]', 'Vy [mm]'" in err


def test_a_mix_of_strain_measures_is_refused(capsys, tmp_path):
    path = tmp_path / "gom.csv"
    path.write_text("x [mm];y [mm];dx [mm];epsX [%];phiY [%]\n1;2;0,001;0,1;0,2\n", encoding="latin-1")
    err = check_data_error(capsys, path)
    assert "a mix of strain measures: epsX, phiY" in err


@pytest.mark.parametrize("header, unit", [("x [px];y [px];dx [px];dy [px]", "'px'"),
                                          ("x [mm];y [mm];dx [in];dy [mm]", "'in'")])
def test_a_unit_that_cannot_be_converted_is_refused(capsys, tmp_path, header, unit):
    path = tmp_path / "gom.csv"
    path.write_text(f"{header}\n1;2;0,001;0,002\n", encoding="utf-8")
    err = check_data_error(capsys, path)
    assert f"unit {unit} cannot be converted to mm" in err


def test_dice_pixels_alone_are_refused(capsys, tmp_path):
    path = tmp_path / "DICe_solution_0.txt"
    path.write_text("***\nSUBSET_ID,COORDINATE_X,COORDINATE_Y,DISPLACEMENT_X,DISPLACEMENT_Y,SIGMA\n"
                    "0,100,200,0.5,0.25,0.01\n", encoding="utf-8")
    assert "unit 'px' cannot be converted to mm" in check_data_error(capsys, path)


def test_strains_of_unstated_measure_need_the_strain_key(capsys):
    """check-data reads the file and names the key; an identification's reading refuses without it."""
    assert main(["check-data", str(FIXTURES / "davis.txt")]) == 0
    out = capsys.readouterr().out
    assert "needed to identify: [data] strain" in out and 'strain = "engineering"' in out
    with pytest.raises(InputError, match="does not say which strain measure"):
        read_data(DataSpec.from_table(config_data(file=str(FIXTURES / "davis.txt"))), Path)


def config_data(**data):
    return {"observables": ["ux"], "stages": [1], **data}


def test_columns_map_an_unknown_layout(tmp_path):
    generic = read_measurements(FIXTURES / "generic.csv")
    path = tmp_path / "own.csv"
    rows = [f"{p};{float(x)!r};{float(y)!r};{float(ux)!r}".replace(".", ",") for p, (x, y, _), ux in
            zip(generic.points, generic.coordinates, generic.values["ux"])]
    path.write_text("\n".join(["Id;Xpos [µm];Ypos [µm];Ux [mm]"] + rows) + "\n", encoding="latin-1")
    columns = {"point": "Id", "x": "Xpos [µm]", "y": "Ypos", "ux": "Ux [mm]"}     # with or without the unit
    m = read_data(DataSpec.from_table(config_data(file=str(path), columns=columns)), Path)
    assert m.points == generic.points and np.all(m.coordinates[:, 2] == 0)
    assert relative_error(m.coordinates[:, :2], generic.coordinates[:, :2] * 1e-3) < RTOL
    assert relative_error(m.values["ux"], generic.values["ux"]) < RTOL
    with pytest.raises(InputError, match="'uu' not among point, x, y, z"):
        read_data(DataSpec.from_table(config_data(file=str(path), columns={**columns, "uu": "Ux"})), Path)


def _sigma_export(path, rows):
    path.write_text("Id;X [mm];Y [mm];U [mm];sU [µm];Exx [%];sExx [%]\n"
                    + "".join(";".join(r) + "\n" for r in rows), encoding="latin-1")
    return path


SIGMA_COLUMNS = {"point": "Id", "x": "X", "y": "Y", "ux": "U", "sigma_ux": "sU", "exx": "Exx", "sigma_exx": "sExx"}


def test_sigma_columns_of_an_export_weight_the_values(tmp_path):
    """[data] columns maps per-point standard deviations (sigma_<quantity>): converted with their own unit (µm,
    %), a strain's through the slope of the measure's conversion (log: d e / d l = exp(l)), an empty cell left to
    [data] noise; the observations carry them as the generic CSV's sigma columns do."""
    from frictionid.builders.block import block_model_2d
    from frictionid.inverse.observations import observations_from

    rows = [["A", "1.0", "2.0", "0.01", "0.5", "0.2", "0.01"], ["B", "-1.5", "4.0", "-0.02", "", "0.3", "0.02"],
            ["C", "2.0", "6.0", "0.005", "2.0", "", "0.05"]]
    path = _sigma_export(tmp_path / "s.csv", [[c.replace(".", ",") for c in r] for r in rows])
    m, report = read_export(path, stage=2, columns=SIGMA_COLUMNS, strain="log")
    np.testing.assert_array_equal(m.sigma["ux"], [0.5e-3, np.nan, 2.0e-3])
    np.testing.assert_allclose(m.sigma["exx"], [1e-4 * np.exp(2e-3), 2e-4 * np.exp(3e-3), np.nan], rtol=1e-15)
    assert "sigma_ux <- 'sU'" in "\n".join(report.lines()) and report.units["sigma_ux"] == "µm"
    measured = read_data(DataSpec.from_table({"file": [{"path": "s.csv", "stage": 2, "force": 10.0}],
                                              "columns": SIGMA_COLUMNS,
                          "strain": "log"}), lambda p: tmp_path / p)
    obs = observations_from(measured, block_model_2d(mesh_size=2.0), DataSpec(observables=["ux", "exx"], stages=[2],
                                                                              noise={"u": 0.007, "e": 0.003}))
    sigma = dict(zip(obs.labels, obs.sigma))
    assert sigma["A:ux@2"] == 0.5e-3 and sigma["B:ux@2"] == 0.007 and sigma["C:ux@2"] == 2.0e-3
    assert sigma["A:exx@2"] == m.sigma["exx"][0] and "C:exx@2" not in sigma


@pytest.mark.parametrize("columns, rows, message", [
    ({"x": "X", "y": "Y", "sigma_ux": "sU"}, [["A", "1", "2", "0.1", "0.5", "0.2", "0.01"]],
     "sigma_ux without the column of ux"),
    (SIGMA_COLUMNS, [["A", "1", "2", "0.1", "0.5", "0.2", "0.01"], ["B", "1", "3", "0.1", "-0.5", "0.2", "0.01"]],
     r"s.csv:3: column 'sU': a standard deviation of ux must be positive"),
])
def test_bad_sigma_columns_are_refused(tmp_path, columns, rows, message):
    with pytest.raises(InputError, match=message):
        read_export(_sigma_export(tmp_path / "s.csv", rows), stage=1, columns=columns, strain="log")


def test_a_pixel_sigma_is_not_taken_as_a_standard_deviation_in_mm():
    """VIC-3D's sigma and DICe's SIGMA are a correlation's confidence in pixels: mapped as sigma_ux, refused."""
    for file, flavour, column in (("vic3d.csv", "vic3d", "sigma"), ("DICe_solution_0001.txt", "dice", "SIGMA")):
        with pytest.raises(InputError, match=f"unit 'px' cannot be converted to mm.*pixels \\(column '{column}'\\)"):
            read_export(FIXTURES / file, stage=1, format=flavour, columns={"sigma_ux": column})


def _force_export(path, forces):
    rows = [f"{x!r};{y!r};{1e-3 * x!r};{f}" for (x, y), f in zip([(1.0, 2.0), (-1.5, 4.0), (2.0, 6.0)], forces)]
    path.write_text("X [mm];Y [mm];U [mm];Force [kN]\n" + "\n".join(r.replace(".", ",") for r in rows) + "\n",
                    encoding="utf-8")
    return path


FORCE_COLUMNS = {"x": "X", "y": "Y", "ux": "U", "force": "Force"}


def test_a_load_cell_column_of_an_export_is_the_stage_force(tmp_path, capsys):
    """[data] columns = { force = "..." }: the export's load-cell channel (kN here) is its stage's machine force, read
    in N; a row without it is fine; rows that disagree, or a force the config also gives differently, are refused."""
    path = _force_export(tmp_path / "f.csv", ["1.25", "", "1.25"])
    m, report = read_export(path, stage=2, columns=FORCE_COLUMNS)
    assert np.all(m.force == 1250.0) and m.stage_force(2) == 1250.0 and report.units["force"] == "kN"
    measured = read_data(DataSpec.from_table({"file": [{"path": "f.csv", "stage": 2}], "columns": FORCE_COLUMNS}),
                         lambda p: tmp_path / p)
    assert measured.stage_force(2) == 1250.0
    with pytest.raises(InputError, match="the file gives the force 1250.0 N, the config 1300.0 N"):
        read_data(DataSpec.from_table({"file": [{"path": "f.csv", "stage": 2, "force": 1300.0}],
                                       "columns": FORCE_COLUMNS}),
                  lambda p: tmp_path / p)
    _force_export(tmp_path / "g.csv", ["1.25", "1.5", "1.25"])
    with pytest.raises(InputError, match=r"g.csv:3: column 'Force': force 1500.0 N differs from 1250.0 N on line 2"):
        read_export(tmp_path / "g.csv", stage=2, columns=FORCE_COLUMNS)
    _force_export(tmp_path / "h.csv", ["1.25", "1.25", "1.25"])
    (tmp_path / "h.csv").write_text((tmp_path / "h.csv").read_text().replace("[kN]", "[kp]"))
    with pytest.raises(InputError, match="force unit 'kp' cannot be converted to N"):
        read_export(tmp_path / "h.csv", stage=2, columns=FORCE_COLUMNS)


def test_a_list_is_one_file_per_stage_and_tables_give_stage_and_force():
    files = [str(FIXTURES / "vic3d.csv"), {"path": str(FIXTURES / "DICe_solution_0001.txt"), "stage": 3,
                                            "force": 1500.0}]
    m = read_data(DataSpec.from_table(config_data(file=files, forces=[1000.0, 1200.0, 1400.0])), Path)
    assert m.stages == (1, 3) and m.stage_force(1) == 1000.0 and m.stage_force(3) == 1500.0
    assert m.n_rows == 24
    with pytest.raises(InputError, match="point '2' at stage 1 is also in"):
        read_data(DataSpec.from_table(config_data(file=[{"path": files[0]}, {"path": files[0], "stage": 1}])), Path)


def identified(folder: Path, name: str, **data) -> dict:
    """Coefficients of examples/first's identify.toml with [data] changed, run into runs/<name>."""
    assert main(["identify", str(with_data(folder, name, **data))]) == 0
    result = json.loads((folder / "runs" / name / "result.json").read_text())
    return {zone: p["value"] for zone, p in result["parameters"].items()}


@pytest.mark.slow          # 62 s in the fast suite on the shared machine (about 1/7 idle)
def test_per_stage_exports_of_two_flavours_identify_like_the_generic_csv(first):
    measured = read_measurements(first / "measured.csv")
    assert measured.stages == (1, 2)
    regions = tomllib.loads((first / "identify.toml").read_text())["data"]["regions"]
    stages = [measured.select(stages=[s]) for s in measured.stages]
    vic_labels = [generate.write_vic3d(first / f"vic_{k}.csv", m) for k, m in enumerate(stages, start=1)]
    gom_labels = [generate.write_gom(first / f"gom_{k}.csv", m) for k, m in enumerate(stages, start=1)]
    assert vic_labels[0] == vic_labels[1] and gom_labels[0] == list(stages[0].points)
    renamed = {new: regions.get(old, regions["*"]) for old, new in zip(stages[0].points, vic_labels[0])}
    reference = identified(first, "generic")
    by_vic = identified(first, "vic", file=["vic_1.csv", "vic_2.csv"], regions=renamed)
    by_gom = identified(first, "gom", file=["gom_1.csv", {"path": "gom_2.csv", "stage": 2}])
    for result in (by_vic, by_gom):
        assert result.keys() == reference.keys()
        for zone, value in reference.items():
            assert abs(result[zone] - value) <= 1e-8 * max(abs(value), 1.0), (zone, result[zone], value)
    assert abs(reference["B"] - 0.15) < 0.05                   # the fit itself found the twin's B


@pytest.mark.parametrize("flavour, header, units", [
    # DaVis 10 StrainMaster strain export, as public DaVis readers name its columns (Green-Lagrange, "[S]")
    ("davis", "x[mm];y[mm];z[mm];x-displacement[mm];y-displacement[mm];z-displacement[mm];"
              "Transverse strain Exx - GL[S];Axial strain Eyy - GL[S];Shear strain Exy - GL[S]", None),
    # MatchID 2024 names (strain.Strain-global frame: ...), with the [ ] of a pure number
    ("matchid", "coor.X [mm];coor.Y [mm];coor.Z [mm];disp.Horizontal Displacement U [mm];"
                "disp.Vertical Displacement V [mm];disp.Out-Of-Plane: W [mm];strain.Strain-global frame: Exx [ ];"
                "strain.Strain-global frame: Eyy [ ];strain.Strain-global frame: Exy [ ]", "engineering"),
])
def test_export_headers_seen_in_public_readers_are_recognised(flavour, header, units, tmp_path):
    """Headers as public readers of DaVis 10 and MatchID 2024 exports spell them: every column lands where it
    belongs; a Green-Lagrange normal strain E becomes the small strain sqrt(1 + 2 E) - 1."""
    rows = ["1.0;2.0;0.5;0.001;-0.002;0.0005;0.0101;-0.002;0.0003", "1.5;2.0;0.5;0.0011;-0.0021;0.0004;0.01;0;0"]
    path = tmp_path / "stage2.csv"
    path.write_text("\n".join([header, *rows]) + "\n", encoding="latin-1")
    m, report = read_export(path, stage=2, strain=units)
    assert report.flavour == flavour and m.n_rows == 2
    np.testing.assert_allclose(m.coordinates[0], [1.0, 2.0, 0.5], rtol=1e-15)
    np.testing.assert_allclose([m.values[q][0] for q in ("ux", "uy", "uz")], [0.001, -0.002, 0.0005], rtol=1e-15)
    exx = np.sqrt(1 + 2 * 0.0101) - 1 if flavour == "davis" else 0.0101
    np.testing.assert_allclose([m.values["exx"][0], m.values["exy"][0]], [exx, 0.0003], rtol=1e-12)


def test_simulate_reads_data_file_like_identify(tmp_path):
    """[data] file as a list (and an export) reaches simulate's points as it reaches identify's (a list was a
    traceback before)."""
    folder = tmp_path / "first"
    shutil.copytree(ROOT / "examples" / "first", folder)
    text = (folder / "truth.toml").read_text()
    assert main(["simulate", str(folder / "truth.toml"), "--out", str(folder / "one.csv")]) == 0
    (folder / "listed.toml").write_text(text.replace('file = "points.csv"', 'file = ["points.csv"]'))
    assert main(["simulate", str(folder / "listed.toml"), "--out", str(folder / "listed.csv")]) == 0
    listed, one = (dataclasses.replace(read_measurements(folder / f), comments=()) for f in ("listed.csv", "one.csv"))
    assert listed == one          # the comments name the config


# --- DIC levelling: the strain window of DICe's header ------------------------------------------------------------

#: the grid of a DICe run on the 2-D block's face: step 10 px at 40 px/mm (0.25 mm), window 61 px = 1.525 mm
PX_PER_MM, WINDOW_PX = 40.0, 61


def _grid(stage: int = 1):
    """DIC-like points on the block (a regular grid, step 0.25 mm), smooth displacements and strains."""
    from frictionid.data import Measurements

    x, y = np.meshgrid(np.arange(-4.5, 4.51, 0.25), np.arange(1.0, 9.01, 0.25))
    x, y = x.ravel(), y.ravel()
    values = {"ux": 1e-3 * x * y, "uy": -2e-4 * x ** 2, "exx": 1e-3 * y, "eyy": 2e-5 * x, "exy": 1e-4 * x}
    return Measurements(points=tuple(f"P{k}" for k in range(len(x))), coordinates=np.column_stack(
        [x, y, np.zeros(len(x))]), stage=np.full(len(x), stage), force=np.full(len(x), np.nan), values=values)


def _checked(config):
    """check_config_data's arguments for a config."""
    return config.data, config.resolve, config.where


def _window_config(folder, **data):
    from frictionid.config import config_from_dict

    return config_from_dict({
        "model": {"builder": "block2d", "mesh_size": 2.0, "n_pull": 1}, "friction": {"zones": {"A": 0.2, "B": 0.2}},
        "data": {"observables": ["ux", "exx", "eyy", "exy"], "stages": [1], "regions": {"*": "block"},
                 "noise": {"u": 5e-4, "e": 1e-4}, **data},
        "identify": {"suggestions": 0}, "run": {"dir": "run"}}, need=("model", "friction", "data", "run"), base=folder)


def _operator(setup):
    """The fit's observation operator of a setup, its rows ordered by the points' coordinates (labels differ)."""
    from frictionid.fem.space import Space
    from frictionid.preparation import strain_window

    model, obs = setup.model, setup.observations
    space = Space.build(model.mesh, model.kind, model.element)
    H = point_operator_of(space, obs, model, strain_window(setup.window))
    order = np.lexsort(np.asarray(obs.points).T[::-1])
    n_q = len(obs.quantities)
    return H[(order[:, None] * n_q + np.arange(n_q)).ravel()].toarray()


def point_operator_of(space, obs, model, window):
    from frictionid.fem.points import point_operator

    return point_operator(space, obs.points, obs.quantities, obs.point_regions, model.materials, window)


@pytest.fixture(scope="module")
def window_files(tmp_path_factory):
    """The grid as the generic CSV and as DICe exports: calibrated with the image's y down, without the pixel
    columns, and at stage 2 with another window."""
    folder = tmp_path_factory.mktemp("window")
    m = _grid()
    write_measurements(folder / "generic.csv", m)
    generate.write_dice(folder / "dice.txt", m, px_per_mm=PX_PER_MM, y_down=True, window=WINDOW_PX)
    generate.write_dice(folder / "no_pixels.txt", m, pixels=False, window=WINDOW_PX)
    generate.write_dice(folder / "dice_41.txt", _grid(stage=2), px_per_mm=PX_PER_MM, y_down=True, window=41)
    return folder


def test_a_dice_header_window_gives_the_operator_of_the_equivalent_config_window(window_files):
    """DICe's VSG window (61 px) converted with the pixel size fitted between COORDINATE_X/Y and MODEL_COORDINATES
    (the image's y down: a turn, exactly fitted) is a circle of 1.525 mm: the fit's operator is the generic CSV's
    with strain_window = 1.525, strain_window_shape = "circle"; it is neither the square of that side nor pointwise.
    check-data and result.json's data.strain_window say where it came from."""
    from frictionid.data.sources import check_config_data
    from frictionid.preparation import prepare
    from frictionid.result import data_section

    dice = prepare(_window_config(window_files, file="dice.txt"))
    size = WINDOW_PX / PX_PER_MM
    assert dice.window.origin == "export header" and dice.window.shape == "circle"
    assert abs(dice.window.size - size) <= 1e-12 * size
    record = dice.window.files[0]
    assert abs(record["mm_per_pixel"] - 1 / PX_PER_MM) < 1e-15 and record["scale_residual_max_mm"] < 1e-12
    generic = {shape: prepare(_window_config(window_files, file="generic.csv", strain_window=size,
                                             strain_window_shape=shape)) for shape in ("circle", "square")}
    pointwise = prepare(_window_config(window_files, file="generic.csv"))
    H = _operator(dice)
    scale = np.abs(H).max()
    assert np.abs(H - _operator(generic["circle"])).max() <= 1e-12 * scale
    assert np.abs(H - _operator(generic["square"])).max() > 1e-3 * scale
    assert np.abs(H - _operator(pointwise)).max() > 1e-3 * scale
    said = check_config_data(*_checked(_window_config(window_files, file="dice.txt")))
    assert "strain window 61 px from the header = 1.525 mm (circle, diameter) at 0.025 mm/px" in said
    assert f"strain window: 1.525 mm (circle, diameter), from the header of {window_files / 'dice.txt'}" in said
    section = data_section([], dice.observations, dice.window)["strain_window"]
    assert section["origin"] == "export header" and section["shape"] == "circle"
    assert section["files"][0]["pixels"] == WINDOW_PX and section["files"][0]["file"].endswith("dice.txt")


def test_without_pixel_coordinates_the_header_window_is_not_used(window_files, capsys):
    """An export without the pixel coordinates gives no pixel size: the window is not converted, check-data says
    why, a fit of strains needs [data] strain_window (exit 2), a fit of displacements runs without a window."""
    from frictionid.data.sources import check_config_data
    from frictionid.preparation import prepare

    said = check_config_data(*_checked(_window_config(window_files, file="no_pixels.txt")))
    assert "strain window 61 px from the header, not converted to mm: the file has no pixel coordinates" in said
    assert "strain window: none; " in said
    with pytest.raises(InputError, match=r"no_pixels.txt: the header's strain window \(61 px\) cannot be converted "
                                         r"to mm: .*; give \[data\] strain_window in mm"):
        prepare(_window_config(window_files, file="no_pixels.txt"))
    assert prepare(_window_config(window_files, file="no_pixels.txt", observables=["ux"])).window.size is None
    given = prepare(_window_config(window_files, file="no_pixels.txt", strain_window=1.5))
    assert given.window.size == 1.5 and given.window.origin == "[data] strain_window"


def test_the_config_window_overrides_the_header(window_files):
    """[data] strain_window is the fit's window (a square unless strain_window_shape says circle) whatever the
    headers say; check-data names the header's window as overridden."""
    from frictionid.data.sources import check_config_data
    from frictionid.preparation import prepare

    dice = prepare(_window_config(window_files, file="dice.txt", strain_window=2.0))
    generic = prepare(_window_config(window_files, file="generic.csv", strain_window=2.0))
    assert (dice.window.size, dice.window.shape, dice.window.origin) == (2.0, "square", "[data] strain_window")
    H = _operator(dice)
    assert np.abs(H - _operator(generic)).max() <= 1e-12 * np.abs(H).max()
    said = check_config_data(*_checked(_window_config(window_files, file="dice.txt", strain_window=2.0)))
    assert "strain window: 2 mm (square), from [data] strain_window" in said
    assert "gives 61 px = 1.525 mm, a circle; overridden" in said


def test_two_files_with_different_header_windows_are_refused(window_files):
    """A fit has one window: two exports whose headers give different windows are refused naming both (and a
    config window settles it)."""
    from frictionid.preparation import prepare

    files = ["dice.txt", "dice_41.txt"]
    with pytest.raises(InputError, match=r"dice.txt and .*dice_41.txt give different strain windows in their "
                                         r"headers \(61 px at 0.025 mm/px = 1.525 mm and 41 px .* = 1.025 mm\)"):
        prepare(_window_config(window_files, file=files, stages=[1, 2]))
    assert prepare(_window_config(window_files, file=files, stages=[1, 2], strain_window=1.0)).window.size == 1.0
    with pytest.raises(InputError, match=r"strain_window_shape = 'round' is not one of square, circle"):
        prepare(_window_config(window_files, file="dice.txt", strain_window=1.0, strain_window_shape="round"))
    with pytest.raises(InputError, match=r"strain_window_shape needs \[data\] strain_window"):
        prepare(_window_config(window_files, file="dice.txt", strain_window_shape="circle"))


def test_the_circular_window_is_dices_vsg_computation():
    """The circle of diameter window x pixel size on the specimen holds the subsets DICe's VSG post-processor takes
    (those within half the window of the point in the image, DICe_PostProcessor.cpp's radius search) and the
    plane fitted to them gives its gradient: computed here as DICe computes it, point by point, for a
    nonlinear field on the grid, the same to 1e-12."""
    from frictionid.fem.points import window_gradients

    m = _grid()
    xy = m.coordinates[:, :2]
    uv = np.column_stack([PX_PER_MM * xy[:, 0] + 500, 400 - PX_PER_MM * xy[:, 1]])   # generate.write_dice, y down
    f = np.sin(xy[:, 0]) * xy[:, 1] ** 2
    gradient, _ = window_gradients(xy, WINDOW_PX / PX_PER_MM, shape="circle")
    ours = np.column_stack([g @ f for g in gradient])
    radius2 = (WINDOW_PX / 2) ** 2 + 1e-5                         # DICe: neighborhood_radius^2 + tiny, in pixels
    dice = np.empty_like(ours)
    for i in range(len(xy)):
        near = np.sum((uv - uv[i]) ** 2, axis=1) <= radius2
        X = np.column_stack([np.ones(near.sum()), xy[near] - xy[i]])
        dice[i] = np.linalg.lstsq(X, f[near], rcond=None)[0][1:]
    assert np.abs(ours - dice).max() <= 1e-12 * np.abs(dice).max()


def test_a_frame_scale_enlarges_the_header_window_and_a_file_without_one_is_refused(window_files):
    """The window is in the model's frame: a transform's scale multiplies it. Files with strains of which one gives
    a header window and one none leave the fit's window undecided: refused once strains are fitted."""
    from frictionid.data.sources import read_sources

    resolve = lambda p: window_files / p                                       # noqa: E731
    scaled = read_sources(DataSpec.from_table({"file": [{"path": "dice.txt", "transform": {"rotation_deg": 0,
                                                                                           "scale": 2.0}}]}),
                          resolve).window
    assert abs(scaled.size - 2 * WINDOW_PX / PX_PER_MM) <= 1e-12 and scaled.files[0]["frame_scale"] == 2.0
    mixed = read_sources(DataSpec.from_table({"file": ["dice.txt", "generic.csv"]}), resolve).window
    assert mixed.size is None and mixed.for_fit(["ux"]) is mixed
    with pytest.raises(InputError, match=r"dice.txt gives a strain window in its header \(1.525 mm\) and .*"
                                         r"generic.csv none"):
        mixed.for_fit(["ux", "exx"])


def test_identify_fits_over_the_header_window(tmp_path):
    """End to end: strains the model made over DICe's circular window (41 px at 20 px/mm), exported by DICe with
    that window in its header, identify to the coefficients that made them (no misfit at the start) and like the
    generic CSV with the equivalent strain_window; without a window the same data do not fit."""
    from frictionid.backends.embedded import EmbeddedBackend
    from frictionid.builders.block import block_model_2d
    from frictionid.data import Measurements
    from frictionid.fem.points import StrainWindow
    from frictionid.identification import identify_config

    x, y = np.meshgrid(np.arange(-4.5, 4.51, 0.5), np.arange(1.0, 9.01, 0.5))
    points = np.column_stack([x.ravel(), y.ravel()])
    n, truth, window = len(points), np.array([0.25, 0.4]), StrainWindow(41 / 20.0, "circle")
    model = block_model_2d(mesh_size=2.0, n_pull=1)
    values = EmbeddedBackend(model, points, ("ux", "exx", "exy"), ["block"] * n, keep=False,
                             window=window).predict(truth).values[-1]
    m = Measurements(points=tuple(f"P{k}" for k in range(n)), coordinates=np.column_stack([points, np.zeros(n)]),
                     stage=np.full(n, 2), force=np.full(n, np.nan),
                     values={q: values[k::3] for k, q in enumerate(("ux", "exx", "exy"))})
    write_measurements(tmp_path / "generic.csv", m)
    generate.write_dice(tmp_path / "dice.txt", m, invalid_at=(), px_per_mm=20.0, window=41)
    fits = {}
    for name, data in (("dice", {"file": [{"path": "dice.txt", "stage": 2}]}), ("none", {"file": "generic.csv"}),
                       ("generic", {"file": "generic.csv", "strain_window": 2.05, "strain_window_shape": "circle"})):
        config = _window_config(tmp_path, observables=["ux", "exx", "exy"], stages=[2], **data)
        config.friction["zones"] = {"A": 0.25, "B": 0.4}
        config = dataclasses.replace(config, identify=config.identify.with_values(max_iterations=3),
                                     run=config.run.with_values(dir=f"run_{name}"))
        fits[name] = identify_config(config, write_files=False).to_dict()
    assert fits["dice"]["objective"]["initial"] < 1e-12 < 1.0 < fits["none"]["objective"]["initial"]
    for zone, p in fits["generic"]["parameters"].items():
        assert abs(fits["dice"]["parameters"][zone]["value"] - p["value"]) <= 1e-8
    assert fits["dice"]["data"]["strain_window"]["origin"] == "export header"
    assert fits["generic"]["data"]["strain_window"]["origin"] == "[data] strain_window"
