"""Rules the readers own (issue 24 items 3 and 4, issue 27 item 5): out-of-plane scatter of a plane model's data,
pixel columns mapped as lengths, fitted frames far from the points; and bad DIC input: exit 2 naming the file and
the key, line or column, no traceback, nothing written."""

import shutil
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from frictionid.cli import main
from frictionid.data import read_measurements, write_measurements
from frictionid.data.frames import Frame
from frictionid.data.sources import read_sources
from frictionid.errors import InputError
from frictionid.options import DataSpec
from fixtures.dic import generate
from helpers.config import with_data

ROOT = Path(__file__).parents[1]
FIXTURES = ROOT / "tests" / "fixtures" / "dic"


_config = with_data


def _scattered(first: Path, name: str, amplitude: float, at=None) -> Path:
    """examples/first's twin with z scattered by up to ``amplitude`` [mm] (a stereo export of the plane face);
    ``at``: only that row, by that much."""
    m = read_measurements(first / "measured.csv")
    z = np.random.default_rng(3).uniform(-amplitude, amplitude, m.n_rows) if at is None else \
        np.where(np.arange(m.n_rows) == at, amplitude, 0.0)
    path = first / name
    write_measurements(path, _with_coordinates(m, np.c_[m.coordinates[:, :2], z]))
    return path


def _with_coordinates(m, coordinates):
    return replace(m, coordinates=coordinates)


def test_out_of_plane_scatter_within_the_tolerance_is_projected_and_reported(first, block2d):
    """1 um of scatter (a stereo export of a plane face): the points are read on the plane, counted and the
    largest |z| reported; the coordinates are those of the flat data."""
    _scattered(first, "scattered.csv", 1e-3)
    flat = read_measurements(first / "measured.csv")
    sources = read_sources(DataSpec.from_table({"file": str(first / "scattered.csv")}), Path, model=block2d)
    assert np.array_equal(sources.measurements.coordinates, flat.coordinates)
    largest = np.abs(read_measurements(first / "scattered.csv").coordinates[:, 2]).max()
    assert sources.plane.startswith(f"{flat.n_rows} of {flat.n_rows} point rows projected onto the plane z = 0")
    assert f"largest |z| {largest:.3g} mm" in sources.plane and "plane_tolerance = 0.005 mm" in sources.plane


def test_scatter_beyond_the_tolerance_is_refused_with_both_numbers_and_nothing_written(first, capsys):
    _scattered(first, "off_plane.csv", 0.02, at=7)
    config = _config(first, "off_plane", file="off_plane.csv")
    assert main(["identify", str(config)]) == 2
    err = capsys.readouterr().err
    assert "off_plane.csv: a plane-strain model needs points on its plane z = 0: 1 of" in err
    assert "plane_tolerance = 0.005 mm, the largest |z| 0.02 mm (point" in err and "transform" in err
    assert "Traceback" not in err and not (first / "runs" / "off_plane").exists()
    config = _config(first, "off_plane_wide", file="off_plane.csv", plane_tolerance=0.05)
    assert main(["check-data", str(config)]) == 0                    # a wider tolerance takes it (no model read)


@pytest.mark.parametrize("value, message", [
    (-0.001, "[data] plane_tolerance must be a length >= 0 [mm]"),
    ("5um", "plane_tolerance"),
])
def test_a_bad_plane_tolerance_is_refused_naming_the_key(first, capsys, value, message):
    config = _config(first, "bad_tolerance", plane_tolerance=value)
    assert main(["identify", str(config)]) == 2
    err = capsys.readouterr().err
    assert message in err and "bad_tolerance.toml" in err and "Traceback" not in err
    assert not (first / "runs" / "bad_tolerance").exists()


@pytest.mark.parametrize("writer, columns, pixel", [
    (generate.write_dice, {"x": "COORDINATE_X", "y": "COORDINATE_Y", "ux": "MODEL_DISPLACEMENT_X"}, "COORDINATE_X"),
    (generate.write_dice, {"x": "MODEL_COORDINATES_X", "y": "MODEL_COORDINATES_Y", "ux": "DISPLACEMENT_X"},
     "DISPLACEMENT_X"),
    (generate.write_vic3d, {"x": "x", "y": "y", "ux": "U", "uy": "V"}, "x"),
])
def test_pixel_columns_mapped_as_lengths_are_refused_by_name(tmp_path, capsys, writer, columns, pixel):
    export = tmp_path / "export.csv"
    writer(export, generate.synthetic())
    config = tmp_path / "check.toml"
    config.write_text(tomli_w.dumps({"data": {"file": "export.csv", "columns": columns, "observables": ["ux"],
                                              "stages": [1]}}))
    assert main(["check-data", str(config)]) == 2
    err = capsys.readouterr().err
    header = 10 if writer is generate.write_dice else 1
    assert f"export.csv:{header}: column {pixel!r} (for " in err and "holds image pixels" in err
    assert "Traceback" not in err
    with pytest.raises(InputError, match="holds image pixels"):
        read_sources(DataSpec.from_table({"file": str(export), "columns": columns, "format": writer.__name__[6:]}),
                     Path)


def _face_points(model_frame: Frame):
    """DIC points on the plane block's face (inside the block and the base), in a camera frame turned by 8.5 deg."""
    x, y = np.meshgrid(np.linspace(-4, 4, 5), np.linspace(1, 9, 5))
    bx, by = np.meshgrid(np.linspace(-18, -8, 6), np.linspace(-4, -1, 3))
    xyz = np.c_[np.r_[x.ravel(), bx.ravel()], np.r_[y.ravel(), by.ravel()], np.zeros(x.size + bx.size)]
    return model_frame.inverse().points(xyz)


def test_a_surface_frame_on_a_flat_face_says_it_cannot_fix_the_in_plane_rotation(tmp_path, block2d, block3d):
    truth = Frame.of([0.0, 0.0, 8.5], [0.3, -0.2, 0.0])
    file_xyz = _face_points(truth)
    n = len(file_xyz)
    m = generate.synthetic(n)
    path = tmp_path / "face.csv"
    write_measurements(path, _with_coordinates(m, file_xyz))
    data = DataSpec(file=str(path), transform={"fit": "surface"}, noise={"u": 0.0005})
    with pytest.raises(InputError, match=r"residual RMS .* times the displacement noise 0.0005 mm: in a plane model .*"
                                         r"a flat face cannot fix the in-plane rotation: use fit = \"points\""):
        read_sources(data, Path, model=block2d)
    top = np.c_[file_xyz[:, :2] * 0.4, np.full(n, 10.0)]            # the 3-D block's top face
    write_measurements(path, _with_coordinates(m, Frame.of([0.0, 0.0, 8.5]).inverse().points(top)))
    with pytest.raises(InputError, match=r"lie on one plane .* a flat face cannot fix the in-plane rotation"):
        read_sources(data, Path, model=block3d)


def test_a_fitted_frame_far_from_the_points_is_a_warning_with_the_number(tmp_path, capsys):
    """Reference points given in um instead of mm: the frame fits, its residual RMS is thousands of noises."""
    m = read_measurements(FIXTURES / "generic.csv")
    xyz = {p: m.coordinates[i] for i, p in enumerate(m.points)}
    points = {p: (1000 * xyz[p]).tolist() for p in ("P1", "P2", "P3", "P4")}
    shutil.copy(FIXTURES / "generic.csv", tmp_path / "generic.csv")
    config = tmp_path / "check.toml"
    config.write_text(tomli_w.dumps({"data": {"file": "generic.csv", "observables": ["ux"], "stages": [1],
                                              "noise": {"u": 0.0005},
                                              "transform": {"fit": "points", "points": points}}}))
    assert main(["check-data", str(config)]) == 0
    out = capsys.readouterr().out
    assert "warning: the fitted frame's residual RMS" in out and "times the displacement noise 0.0005 mm" in out
    points = {p: xyz[p].tolist() for p in ("P1", "P2", "P3", "P4")}        # in mm: no warning
    config.write_text(tomli_w.dumps({"data": {"file": "generic.csv", "observables": ["ux"], "stages": [1],
                                              "noise": {"u": 0.0005},
                                              "transform": {"fit": "points", "points": points}}}))
    assert main(["check-data", str(config)]) == 0
    assert "warning" not in capsys.readouterr().out


NODEMAP = ("# SIGNALS:\n# force                         : value_element       : {force}\n#\n"
           "#{:>9}; {:>20}; {:>20}; {:>20}; {:>20}; {:>20}\n"
           "{:10d}; {:20.10f}; {:20.10f}; {:20.10f}; {:20.15f}; {:20.15f}\n")


@pytest.mark.parametrize("text, message", [
    (NODEMAP.format("ID", "x_undef [mm]", "y_undef [mm]", "z_undef [mm]", "u [mm]", "v [mm]", 1, 1.0, 2.0, 0.0,
                    0.001, 0.002, force="n/a"),
     "nodemap.txt: metadata line '# force : value_element : n/a': the force must be a finite number [N]"),
    (NODEMAP.format("ID", "x_undef [mm]", "y_undef [mm]", "z_undef [in]", "u [mm]", "v [mm]", 1, 1.0, 2.0, 0.0,
                    0.001, 0.002, force=5.0),
     "nodemap.txt: column 'z_undef': unit 'in' cannot be converted to mm"),
    ("Project;p\r\nUnit;mm;%\r\nx;y;z;displacement_x;epsilon_x\r\n1,0;2,0;0,0;0,0;0,1\r\n",
     "nodemap.txt:3: gom: the coordinates are deformed positions (ZEISS Correlate's x, y, z are the points' "
     "positions at the exported stage); the reference position needs the displacement column of y"),
    ("x_pic,y_pic,x,y,z,u,v,w\n1,2,1.0,2.0,0.0,0.001,abc,0\n", "nodemap.txt:2: column 'v': 'abc' is not a number"),
    ("Project;p\r\nUnit;inch;%\r\nx;y;z;displacement_x;displacement_y\r\n1,0;2,0;0,0;0,0;0,1\r\n",
     "nodemap.txt: column 'x': unit 'inch' cannot be converted to mm"),
    (NODEMAP.format("ID", "x_undef [mm]", "y_undef [mm]", "z_undef [mm]", "u [mm]", "v [mm]", 1, 1.0, 2.0, 0.0,
                    0.001, 0.002, force=5.0) + "         1;  2.0;  2.0;  0.0;  0.001;  0.002\n",
     "nodemap.txt: point id '1' appears twice"),
])
def test_bad_exports_of_the_new_layouts_exit_2_naming_file_and_line(tmp_path, capsys, text, message):
    path = tmp_path / "nodemap.txt"
    path.write_bytes(text.encode("utf-8"))
    before = sorted(tmp_path.iterdir())
    assert main(["check-data", str(path)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert sorted(tmp_path.iterdir()) == before


def test_check_data_of_a_config_lists_what_its_identification_needs(tmp_path, capsys):
    """A config whose export does not state its strain measure: check-data reads it and names the key (exit 0);
    the machine force is listed only where force is observed; identify's reading refuses."""
    shutil.copy(FIXTURES / "corpus" / "matchid2024_1.csv", tmp_path / "m.csv")
    config = tmp_path / "check.toml"
    for observables, force in ((["ux", "exx"], False), (["ux", "exx", "force"], True)):
        config.write_text(tomli_w.dumps({"data": {"file": "m.csv", "observables": observables, "stages": [1]}}))
        assert main(["check-data", str(config)]) == 0
        out = capsys.readouterr().out
        assert "needed to identify: [data] strain" in out and ("[data] forces" in out) == force
    with pytest.raises(InputError, match="does not say which strain measure"):
        read_sources(DataSpec.from_table({"file": str(tmp_path / "m.csv")}), Path)


def test_a_config_force_that_contradicts_the_nodemap_metadata_is_refused(tmp_path, capsys):
    shutil.copy(FIXTURES / "corpus" / "aramis_nodemap_1.txt", tmp_path / "n.txt")
    config = tmp_path / "check.toml"
    config.write_text(tomli_w.dumps({"data": {"file": [{"path": "n.txt", "force": 990.0}], "observables": ["ux"],
                                              "stages": [1]}}))
    assert main(["check-data", str(config)]) == 2
    err = capsys.readouterr().err
    assert "n.txt: stage 1: the file gives the force 1000.0 N, the config 990.0 N" in err and "Traceback" not in err


def test_coordinates_states_what_an_exports_coordinate_columns_hold(tmp_path):
    """[data] coordinates = "deformed": a MatchID 2024.1 export written with the positions at the stage reads to
    the reference positions; "reference" reads a MatchID 2023 export's coordinates as written."""
    from fixtures.dic import corpus
    generic = read_measurements(FIXTURES / "corpus" / "generic.csv").select(stages=[2])
    u = np.column_stack([generic.values[q] for q in ("ux", "uy", "uz")])
    corpus.write_matchid_2024(tmp_path / "m2024.csv", _with_coordinates(generic, generic.coordinates + u))
    read = read_sources(DataSpec.from_table({"file": str(tmp_path / "m2024.csv"), "strain": "green-lagrange",
                         "coordinates": "deformed"}), Path)
    assert np.abs(read.measurements.coordinates - generic.coordinates).max() < 1e-12
    assert read.files[0]["coordinates"].startswith('deformed positions ([data] coordinates = "deformed")')
    corpus.write_matchid_2023(tmp_path / "m2023.csv", generic)
    read = read_sources(DataSpec.from_table({"file": [{"path": str(tmp_path / "m2023.csv"),
                                                       "coordinates": "reference"}],
                         "strain": "log"}), Path)
    assert np.abs(read.measurements.coordinates - (generic.coordinates + u)).max() < 1e-12


@pytest.mark.parametrize("data, message", [
    ({"file": "generic.csv", "coordinates": "current"},
     "[data] file entry 1: coordinates must be \"reference\" or \"deformed\""),
    ({"file": "generic.csv", "coordinates": "deformed"}, "[data] coordinates = \"deformed\" is for DIC exports"),
    ({"file": "generic.csv", "coordinates": 1}, "coordinates"),
])
def test_a_bad_coordinates_key_is_refused(tmp_path, capsys, data, message):
    shutil.copy(FIXTURES / "generic.csv", tmp_path / "generic.csv")
    config = tmp_path / "check.toml"
    config.write_text(tomli_w.dumps({"data": {"observables": ["ux"], "stages": [1], **data}}))
    assert main(["check-data", str(config)]) == 2
    err = capsys.readouterr().err
    assert message in err and "check.toml" in err and "Traceback" not in err


def test_a_preamble_padded_by_a_spreadsheet_reads_like_the_export(tmp_path):
    """A Correlate export saved again by a spreadsheet: every preamble line padded with ';' to the header's width."""
    lines = (FIXTURES / "corpus" / "gom_correlate_1.csv").read_bytes().decode().split("\r\n")
    width = lines[5].count(";")
    padded = [line + ";" * (width - line.count(";")) if k < 5 else line for k, line in enumerate(lines)]
    (tmp_path / "padded.csv").write_bytes("\r\n".join(padded).encode())
    one, two = (read_sources(DataSpec.from_table({"file": str(path)}), Path).measurements
                for path in (FIXTURES / "corpus" / "gom_correlate_1.csv", tmp_path / "padded.csv"))
    assert padded[0] == "Project;corpus" + ";" * (width - 1)
    assert one.points == two.points and np.array_equal(one.coordinates, two.coordinates)
    assert all(np.array_equal(one.values[q], two.values[q], equal_nan=True) for q in one.quantities)


def test_a_plane_surface_frame_a_little_off_the_edges_is_a_warning_not_a_refusal(tmp_path, block2d):
    """Points on three edges of the plane block, the upper half of one edge 0.03 mm inside (a specimen edge off
    the model's): far above the noise, far below the section's size: fitted, with the warning."""
    rng = np.random.default_rng(7)
    n = 10
    side = rng.uniform(0.5, 9.5, n)
    edges = np.concatenate([np.c_[np.where(side > 5, -4.97, -5.0), side, np.zeros(n)],
                            np.c_[rng.uniform(-4, 4, n), np.full(n, 10.0), np.zeros(n)],
                            np.c_[rng.uniform(6, 18, n), np.zeros(n), np.zeros(n)]])
    m = generate.synthetic(3 * n)
    write_measurements(tmp_path / "edges.csv", _with_coordinates(m, Frame.of([0, 0, 5.0]).inverse().points(edges)))
    data = DataSpec(file=str(tmp_path / "edges.csv"), transform={"fit": "surface"}, noise={"u": 0.0005})
    frame = read_sources(data, Path, model=block2d).frames[0]
    assert frame["warning"].startswith(f"warning: the fitted frame's residual RMS {frame['residual_rms_mm']:.3g} mm")
    assert 0.005 < frame["residual_rms_mm"] < 0.03
