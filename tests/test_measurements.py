"""Measurement CSV: round trip, one test per class of bad input, summary, selection, axisymmetric mapping."""

import math

import numpy as np
import pytest

from frictionid.data import Measurements, map_to_axisymmetric, read_measurements, write_measurements
from frictionid.errors import InputError

HEADER = "point,x,y,z,stage,force,uy,sigma_uy"
#: lines 1-2 comments, line 3 header, lines 4-5 data
GOOD = ["# units: mm, N", "# provenance: test", HEADER, "P1,9.0,80.0,0.0,1,1000,0.01,0.001",
        "P2,9.5,82.5,0.0,1,1000,0.02,"]


def write(tmp_path, lines, name="m.csv"):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def read_error(tmp_path, lines) -> tuple[str, str]:
    path = write(tmp_path, lines)
    with pytest.raises(InputError) as info:
        read_measurements(path)
    return str(info.value), str(path)


def table(**values) -> Measurements:
    """Two rows at points in the x-y plane; stage 1; no force."""
    return Measurements(points=("A", "B"), coordinates=[[1.0, 2.0, 0.0], [3.0, 4.0, 0.0]], stage=[1, 1],
                        force=[np.nan, np.nan], values=values)


def test_round_trip_keeps_comments_missing_cells_sigma_and_exact_floats(tmp_path):
    third = 0.1 + 0.2  # 0.30000000000000004: repr must keep every digit
    m = Measurements(
        points=("P1", "P,2", "P1"), coordinates=[[9.0, 80.0, -0.0], [1 / 3, 82.5, 1e-300], [9.0, 80.0, -0.0]],
        stage=[1, 1, 2], force=[1000.0, 1000.0, np.nan],
        values={"uy": [third, np.nan, -1.5e-3], "exx": [np.nan, 2e-4, 3e-4], "ux": [0.0, 1.0, 2.0]},
        sigma={"uy": [1e-3, np.nan, 2e-3]}, comments=("units: mm, N", "", "## provenance: DIC"), source="memory")
    path = tmp_path / "out.csv"
    write_measurements(path, m)
    back = read_measurements(path)
    assert back == m
    assert back.source == str(path) and back.quantities == ("ux", "uy", "exx")
    assert back.values["uy"][0] == third and back.coordinates[1, 0] == 1 / 3
    assert back.comments == ("units: mm, N", "", "provenance: DIC")
    lines = path.read_text().splitlines()
    assert lines[:4] == ["# units: mm, N", "#", "# provenance: DIC", "point,x,y,z,stage,force,ux,uy,sigma_uy,exx"]
    assert lines[5] == '"P,2",0.3333333333333333,82.5,1e-300,1,1000.0,1.0,,,0.0002'
    write_measurements(tmp_path / "again.csv", back)
    assert (tmp_path / "again.csv").read_text() == path.read_text()


def test_equality_sees_a_changed_value_and_ignores_the_source():
    assert table(uy=[1.0, np.nan]) == table(uy=[1.0, np.nan])
    assert table(uy=[1.0, np.nan]) != table(uy=[1.0, 2.0])
    assert table(uy=[1.0, 2.0]) != table(ux=[1.0, 2.0])
    with_sigma = Measurements(("A",), [[1, 2, 0]], [1], [np.nan], {"uy": [1.0]}, sigma={"uy": [0.1]})
    assert with_sigma != Measurements(("A",), [[1, 2, 0]], [1], [np.nan], {"uy": [1.0]}, sigma={"uy": [0.2]})


def test_reads_columns_in_any_order_with_spaces_blank_lines_and_a_byte_order_mark(tmp_path):
    path = tmp_path / "excel.csv"
    path.write_text("\ufeff# from a spreadsheet\nstage, point ,z,y,x,uy\n\n2, P1 ,0,80,9,0.5\n", encoding="utf-8")
    m = read_measurements(path)
    assert m.points == ("P1",) and m.stage.tolist() == [2] and m.coordinates.tolist() == [[9.0, 80.0, 0.0]]
    assert m.comments == ("from a spreadsheet",) and np.isnan(m.force[0]) and m.values["uy"].tolist() == [0.5]


@pytest.mark.parametrize("lines, where, words", [
    (GOOD[:2] + [HEADER.replace(",z", "")] + ["P1,9,80,1,1000,0.01,0.001"], ":3: ", ["'z'", "missing required"]),
    (GOOD[:2] + [HEADER + ",uxx"] + [row + ",1" for row in GOOD[3:]], ":3: ", ["'uxx'", "did you mean 'ux'"]),
    (GOOD[:2] + [HEADER + ",UY"] + [row + ",1" for row in GOOD[3:]], ":3: ", ["'UY'", "did you mean 'uy'"]),
    (GOOD[:2] + [HEADER + ",uy"] + [row + ",1" for row in GOOD[3:]], ":3: column 'uy': ", ["twice", "7 and 9"]),
    (GOOD[:2] + ["point,x,y,z,stage,sigma_uz"] + ["P1,9,80,0,1,0.1"], ":3: column 'sigma_uz': ", ["'uz'"]),
    (GOOD[:4] + ["P2,9.5,82.5,0.0,1,1000,0.02"], ":5: ", ["7 fields", "line 3", "has 8"]),
    (GOOD[:4] + ["P2,9.5,abc,0.0,1,1000,0.02,"], ":5: column 'y': ", ["'abc' is not a number"]),
    (GOOD[:4] + ["P2,9.5,82.5,0.0,1,1000,nan,"], ":5: column 'uy': ", ["'nan' is not allowed", "empty"]),
    (GOOD[:4] + ["P2,9.5,82.5,0.0,1,1000,-inf,"], ":5: column 'uy': ", ["'-inf' is not a finite number"]),
    (GOOD[:4] + ["P2,9.5,82.5,0.0,1,1000,1e999,"], ":5: column 'uy': ", ["not a finite number"]),
    (GOOD[:4] + ["P2,9.5,82.5,,1,1000,0.02,"], ":5: column 'z': ", ["value is required"]),
    (GOOD[:4] + [",9.5,82.5,0,1,1000,0.02,"], ":5: column 'point': ", ["label is required"]),
    (GOOD[:4] + ["P2,9.5,82.5,0.0,0,1000,0.02,"], ":5: column 'stage': ", ["positive integer", "'0'"]),
    (GOOD[:4] + ["P2,9.5,82.5,0.0,1.5,1000,0.02,"], ":5: column 'stage': ", ["positive integer", "'1.5'"]),
    (GOOD[:4] + ["P2,9.5,82.5,0.0,1,1000,0.02,-0.001"], ":5: column 'sigma_uy': ", ["positive", "-0.001"]),
    (GOOD[:4] + ["P2,9.5,82.5,0.0,1,1000,0.02,0"], ":5: column 'sigma_uy': ", ["positive"]),
    (GOOD[:4] + ["P1,9.5,82.5,0.0,1,1000,0.02,"], ":5: column 'point': ", ["'P1' at stage 1", "line 4"]),
    (GOOD[:4] + ["P2,9.5,82.5,0.0,1,1001,0.02,"], ":5: column 'force': ", ["1001.0 N", "1000.0 N", "line 4"]),
    (GOOD[:4] + ["P2,9.5,82.5,0.0,1,1000.000002,0.02,"], ":5: column 'force': ", ["differs"]),  # 2e-9 relative
    (GOOD[:3] + ["P1,9,80,0,1,1000,,0.001", "P2,9,81,0,1,1000,,"], ":3: column 'uy': ", ["no row has a value"]),
    (GOOD[:3], ":3: ", ["no data rows"]),
])
def test_bad_input_names_file_line_and_column(tmp_path, lines, where, words):
    message, path = read_error(tmp_path, lines)
    assert message.startswith(path + where), message
    for word in words:
        assert word in message, message


def test_forces_equal_to_1e_9_relative_are_one_force_and_stages_may_differ(tmp_path):
    m = read_measurements(write(tmp_path, GOOD[:4] + ["P2,9.5,82.5,0.0,1,1000.0000001,0.02,",
                                                        "P1,9.0,80.0,0.0,2,2000,0.03,"]))
    assert m.stage_force(1) == 1000.0 and m.stage_force(2) == 2000.0


@pytest.mark.parametrize("text, words", [
    ("", ["no header"]),
    ("# only a comment\n\n", ["no header"]),
])
def test_empty_files(tmp_path, text, words):
    path = tmp_path / "empty.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=words[0]) as info:
        read_measurements(path)
    assert str(info.value).startswith(f"{path}: ")


def test_missing_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="no such measurement file") as info:
        read_measurements(tmp_path / "absent.csv")
    assert str(info.value).startswith(str(tmp_path / "absent.csv"))


def test_write_refuses_what_would_not_read_back(tmp_path):
    with pytest.raises(InputError, match="point label '#P'"):
        write_measurements(tmp_path / "x.csv", Measurements(("#P",), [[0, 0, 0]], [1], [np.nan], {"ux": [1.0]}))
    with pytest.raises(InputError, match="values must be finite|ux must be finite"):
        write_measurements(tmp_path / "x.csv", table(ux=[1.0, np.inf]))


def test_select_keeps_the_chosen_rows_and_columns_and_names_what_exists(tmp_path):
    m = read_measurements(write(tmp_path, GOOD[:3] + [
        "P1,9,80,0,1,1000,0.01,0.001", "P1,9,80,0,2,2000,0.02,", "P2,9,81,0,2,2000,0.03,0.002"]))
    selected = m.select(quantities=["uy"], stages=[2])
    assert selected.points == ("P1", "P2") and selected.stage.tolist() == [2, 2]
    assert selected.values["uy"].tolist() == [0.02, 0.03] and np.isnan(selected.sigma["uy"][0])
    assert m.select(quantities=[]).quantities == () and m.select(stages=[1]).n_rows == 1
    with pytest.raises(InputError, match=r"no measured quantity 'ux'; the measured quantities are uy"):
        m.select(quantities=["ux"])
    with pytest.raises(InputError, match=r"no rows at stage 3; the stages measured are 1, 2"):
        m.select(stages=[3])
    assert m.observations() == [(0, "uy", 0.01, 0.001), (1, "uy", 0.02, pytest.approx(math.nan, nan_ok=True)),
                                (2, "uy", 0.03, 0.002)]


def test_summary_states_file_points_stages_forces_quantities_sigma_and_missing_cells(tmp_path):
    path = write(tmp_path, GOOD[:3] + ["P1,9,80,0,1,1000,0.01,0.001", "P1,9,80,0,2,2000,,",
                                       "P2,9,81,0,2,2000,-0.03,0.002"])
    lines = read_measurements(path).summary().splitlines()
    assert lines[0] == f"file: {path}"
    assert "comments: 2 lines" in lines and "points: 2, rows: 3" in lines
    assert "stages: 1 (1 rows, force 1000 N), 2 (2 rows, force 2000 N)" in lines
    uy = next(line for line in lines if line.startswith("uy")).split()
    assert uy == ["uy", "mm", "2", "1", "-0.03", "0.01", "-0.01"]
    assert "sigma columns: sigma_uy (2 given)" in lines and "missing cells: 1 of 3" in lines


def rotated(point_rz, u_r, u_theta, angle_deg):
    """A point (r, y) of the x-y plane and a displacement (u_r, uy, u_theta) rotated by angle about y."""
    a = math.radians(angle_deg)
    radial, tangential = np.array([math.cos(a), 0, math.sin(a)]), np.array([-math.sin(a), 0, math.cos(a)])
    return point_rz[0] * radial + [0, point_rz[1], 0], u_r * radial + u_theta * tangential


def test_axisymmetric_mapping_of_points_rotated_about_y():
    angles = [0.0, 37.0, 90.0, 200.0]
    geometry = [rotated((9.0 + k, 80.0 + k), 0.01 * (k + 1), 0.5, angle) for k, angle in enumerate(angles)]
    xyz, u = np.array([g[0] for g in geometry]), np.array([g[1] for g in geometry])
    m = Measurements(points=tuple("ABCD"), coordinates=xyz, stage=[1] * 4, force=[5.0] * 4,
                     values={"ux": u[:, 0], "uy": [1.0, 2.0, 3.0, 4.0], "uz": u[:, 2], "eyy": [1e-4] * 4},
                     sigma={"ux": [1e-3] * 4, "uz": [1e-3] * 4})
    a = map_to_axisymmetric(m)
    np.testing.assert_allclose(a.coordinates, [[9 + k, 80 + k, 0] for k in range(4)], rtol=1e-14, atol=1e-13)
    np.testing.assert_allclose(a.values["ux"], [0.01, 0.02, 0.03, 0.04], rtol=1e-12)
    # independent errors of equal size: the radial projection keeps the size
    np.testing.assert_allclose(a.sigma["ux"], 1e-3, rtol=1e-12)
    assert a.quantities == ("ux", "uy", "eyy") and a.values["uy"].tolist() == [1.0, 2.0, 3.0, 4.0]
    assert "mapped to axisymmetric" in a.comments[-1]


def test_axisymmetric_strains_pass_only_in_the_x_y_plane():
    a = map_to_axisymmetric(table(exx=[1e-4, 2e-4], ezz=[3e-4, np.nan], exy=[5e-5, 6e-5]))
    assert a.values["exx"].tolist() == [1e-4, 2e-4] and a.values["ezz"][0] == 3e-4
    off_plane = Measurements(("A", "B"), [[1, 2, 0], [3, 4, 1]], [1, 1], [np.nan] * 2, {"exx": [1e-4, 2e-4]})
    with pytest.raises(InputError, match=r"point 'B' \(stage 1, x = 3, y = 4, z = 1 mm\): column 'exx'"):
        map_to_axisymmetric(off_plane)
    negative_x = Measurements(("A",), [[-3, 4, 0]], [1], [np.nan], {"ezz": [1e-4]})
    with pytest.raises(InputError, match=r"point 'A' .* column 'ezz' .* x > 0"):
        map_to_axisymmetric(negative_x)
    with pytest.raises(InputError, match="column 'exz' has no counterpart"):
        map_to_axisymmetric(table(exz=[1e-4, np.nan]))


def test_axisymmetric_mapping_refuses_points_on_the_axis_and_half_given_displacements():
    on_axis = Measurements(("A", "B"), [[1, 2, 0], [0, 4, 0]], [1, 1], [np.nan] * 2, {"ux": [1e-2, 2e-2]})
    with pytest.raises(InputError, match=r"point 'B'.*on the axis"):
        map_to_axisymmetric(on_axis)
    assert map_to_axisymmetric(on_axis.select(quantities=[])).coordinates[1].tolist() == [0.0, 4.0, 0.0]
    off_plane = Measurements(("A",), [[3, 2, 4]], [1], [np.nan], {"ux": [1e-2]})
    with pytest.raises(InputError, match=r"point 'A'.*needs uz, which is missing"):
        map_to_axisymmetric(off_plane)


# 10 DIC points on the first two engaged bolt flanks (reference test 2 (docs/models.md)), two stages
DIC = """# M20 bolt-nut connection, DIC (synthetic values for the test)
# units: x, y, z, uy, sigma_uy [mm]; force [N]
point,x,y,z,stage,force,uy,sigma_uy,ux
{rows}"""


def dic_rows():
    rows = []
    for stage, force in ((1, 20000), (2, 40000)):
        for k in range(10):
            turn, step = divmod(k, 5)
            y, x = 94.5 - 2.5 * turn - 0.2 * step, 8.9 + 0.12 * step
            ux = "" if k == 3 else f"{-1e-4 * stage * (k + 1):.6g}"
            rows.append(f"F{turn + 1}.{step + 1},{x:.4g},{y:.4g},0,{stage},{force},{0.004 * stage * (10 - k):.6g},"
                        f"0.0005,{ux}")
    return "\n".join(rows) + "\n"


def test_a_realistic_dic_file_of_10_points_over_2_stages(tmp_path):
    path = tmp_path / "dic.csv"
    path.write_text(DIC.format(rows=dic_rows()))
    m = read_measurements(path)
    assert (m.n_points, m.n_rows, m.stages, m.quantities) == (10, 20, (1, 2), ("ux", "uy"))
    assert m.stage_force(2) == 40000.0 and len(m.comments) == 2
    summary = m.summary()
    assert "points: 10, rows: 20" in summary and "2 (10 rows, force 40000 N)" in summary
    assert "missing cells: 2 of 40" in summary
    stage2 = m.select(quantities=["uy"], stages=[2])
    assert len(stage2.observations()) == 10 and stage2.points[0] == "F1.1"
    assert stage2.values["uy"][0] == pytest.approx(0.08, rel=1e-12)
    a = map_to_axisymmetric(m)
    np.testing.assert_array_equal(a.coordinates[:, 0], m.coordinates[:, 0])
    assert np.isnan(a.values["ux"][3]) and a.values["ux"][4] == m.values["ux"][4]
    write_measurements(tmp_path / "back.csv", m)
    assert read_measurements(tmp_path / "back.csv") == m
