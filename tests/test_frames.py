"""Frames (issue 15, item 2): [data] transform maps a DIC frame onto the model's (given, or fitted to reference points
or to the model's surface, reported with its residual); bad transforms exit 2 naming the key."""

import sys
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from frictionid.cli import main
from frictionid.data import read_measurements, write_measurements
from frictionid.data.frame_fit import fit_to_surface
from frictionid.data.frames import Frame, frame_spec, in_model_frame, rotation_from_degrees
from frictionid.data.sources import read_sources
from frictionid.data.table import Measurements
from frictionid.fem.surface import mesh_surface
from frictionid.options import DataSpec
from fixtures.dic import generate

ROOT = Path(__file__).parents[1]
FIXTURES = ROOT / "tests" / "fixtures" / "dic"

#: the frame of the tests' DIC files: turned about all three axes, shifted [mm]
ANGLES, SHIFT = [20.0, -35.0, 110.0], [12.5, -4.0, 30.0]


def tensor(m: Measurements, row: int) -> np.ndarray:
    e = {q: m.values[q][row] for q in ("exx", "eyy", "ezz", "exy", "eyz", "exz")}
    return np.array([[e["exx"], e["exy"], e["exz"]], [e["exy"], e["eyy"], e["eyz"]], [e["exz"], e["eyz"], e["ezz"]]])


def full_fields(n: int = 12) -> Measurements:
    """The fixtures' surface patch with every displacement and strain component (model frame)."""
    m = generate.synthetic(n)
    x, y, _ = m.coordinates.T
    values = {**m.values, "ezz": -4e-4 + 1e-5 * x, "eyz": 1e-4 * np.ones(n), "exz": -2e-4 + 1e-6 * y}
    return Measurements(m.points, m.coordinates, m.stage, m.force, values)


def in_dic_frame(m: Measurements, rotation: np.ndarray, shift) -> Measurements:
    """``m`` as a DIC system in a frame with p_model = R p_dic + t would give it, by explicit formulas."""
    coordinates = (m.coordinates - shift) @ rotation           # R^T (p - t), row by row
    u = np.column_stack([m.values[q] for q in ("ux", "uy", "uz")]) @ rotation
    values = {q: u[:, k] for k, q in enumerate(("ux", "uy", "uz"))}
    strains = [rotation.T @ tensor(m, i) @ rotation for i in range(m.n_rows)]
    for q, (a, b) in zip(("exx", "eyy", "ezz", "exy", "eyz", "exz"), ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))):
        values[q] = np.array([e[a, b] for e in strains])
    return Measurements(m.points, coordinates, m.stage, m.force, values)


def read(data: dict, model=None):
    return read_sources(DataSpec.from_table({"observables": ["ux"], "stages": [1], **data}), Path, model=model)


def test_a_frame_fitted_to_a_rotated_and_shifted_copy_recovers_the_transform(tmp_path):
    truth = full_fields()
    rotation = rotation_from_degrees(ANGLES)
    write_measurements(tmp_path / "dic.csv", in_dic_frame(truth, rotation, SHIFT))
    points = {p: xyz.tolist() for p, xyz in zip(truth.points, truth.coordinates)}
    sources = read({"file": str(tmp_path / "dic.csv"), "transform": {"fit": "points", "points": points}})
    frame = sources.frames[0]
    m = sources.measurements
    # measured: the recovered frame moves every point within ~1e-14 mm of where it belongs
    assert np.abs(m.coordinates - truth.coordinates).max() < 1e-6
    assert np.abs(np.array(frame["rotation"]) - rotation).max() < 1e-9
    assert np.abs(np.array(frame["translation"]) - SHIFT).max() < 1e-6
    np.testing.assert_allclose(frame["rotation_deg"], ANGLES, atol=1e-9)
    assert frame["residual_max_mm"] < 1e-6 and frame["n_points"] == truth.n_rows and frame["scale"] == 1.0
    for q in truth.quantities:                                  # vectors and tensors turned back as well
        np.testing.assert_allclose(m.values[q], truth.values[q], rtol=0, atol=1e-15, err_msg=q)


def test_a_fitted_scale_and_a_point_given_in_both_frames(tmp_path):
    truth = full_fields()
    rotation = rotation_from_degrees(ANGLES)
    dic = in_dic_frame(truth, rotation, SHIFT)
    scaled = Measurements(dic.points, dic.coordinates / 1.002, dic.stage, dic.force, dic.values)
    write_measurements(tmp_path / "dic.csv", scaled)
    points = {p: xyz.tolist() for p, xyz in list(zip(truth.points, truth.coordinates))[:3]}
    points["M1"] = {"file": [0.0, 0.0, 0.0], "model": (1.002 * rotation @ [0.0, 0.0, 0.0] + SHIFT).tolist()}
    frame = read({"file": str(tmp_path / "dic.csv"),
                  "transform": {"fit": "points", "points": points, "scale": True}}).frames[0]
    assert abs(frame["scale"] - 1.002) < 1e-12 and frame["n_points"] == 4
    assert np.abs(np.array(frame["translation"]) - SHIFT).max() < 1e-6


def test_a_given_transform_maps_coordinates_vectors_and_tensors(tmp_path):
    truth = full_fields()
    write_measurements(tmp_path / "dic.csv", in_dic_frame(truth, rotation_from_degrees(ANGLES), SHIFT))
    sources = read({"file": [{"path": str(tmp_path / "dic.csv"), "transform": {"rotation_deg": ANGLES,
                                                                                "translation": SHIFT}}]})
    m = sources.measurements
    assert np.abs(m.coordinates - truth.coordinates).max() < 1e-12
    for q in truth.quantities:
        np.testing.assert_allclose(m.values[q], truth.values[q], rtol=0, atol=1e-15, err_msg=q)
    assert sources.frames[0]["fit"] is None and "frame given" in sources.lines[-1]


def test_components_a_view_does_not_measure_stay_unknown():
    """A 2-D DIC view of the block's front face (file x = model x, file y = model z): the file's exx, eyy, exy are
    the model's exx, ezz, exz; eyy, exy, eyz and uy (out of the view's plane) are unknown, not zero."""
    m = Measurements(("P",), [[1.0, 2.0, 0.0]], [1], [np.nan], {"ux": [0.1], "uy": [0.2], "exx": [1e-3],
                                                                  "eyy": [2e-3], "exy": [3e-4]})
    front = in_model_frame(m, Frame.of([90, 0, 0], [0, -5, 0]), "front")
    np.testing.assert_allclose(front.coordinates, [[1.0, -5.0, 2.0]], atol=1e-15)
    got = {q: float(v[0]) for q, v in front.values.items()}
    assert got["ux"] == 0.1 and got["uz"] == 0.2 and np.isnan(got["uy"])
    assert got["exx"] == 1e-3 and got["ezz"] == 2e-3 and got["exz"] == 3e-4
    assert np.isnan(got["eyy"]) and np.isnan(got["exy"]) and "eyz" not in got    # no column of nothing but nan


def test_a_frame_fitted_to_the_model_surface_recovers_the_transform(block3d):
    rng = np.random.default_rng(3)
    n = 30
    faces = [np.c_[np.full(n, -5.0), rng.uniform(-5, 5, n), rng.uniform(0.5, 9.5, n)],      # block's side
             np.c_[rng.uniform(-5, 5, n), np.full(n, -5.0), rng.uniform(0.5, 9.5, n)],      # block's front
             np.c_[rng.uniform(-5, 5, n), rng.uniform(-5, 5, n), np.full(n, 10.0)],         # block's top
             np.c_[rng.uniform(-19, -6, n), rng.uniform(-19, 19, n), np.zeros(n)]]          # plate's top
    model_xyz = np.concatenate(faces)
    truth = Frame.of([4.0, -3.0, 6.0], [0.5, -0.4, 0.3])
    file_xyz = truth.inverse().points(model_xyz)
    spec = frame_spec({"fit": "surface"}, "transform")          # starts from no turn, no shift
    fit = fit_to_surface(spec, [str(i) for i in range(len(file_xyz))], file_xyz, mesh_surface(block3d.mesh), "f")
    assert np.abs(fit.frame.points(file_xyz) - model_xyz).max() < 1e-6
    assert np.abs(fit.frame.rotation - truth.rotation).max() < 1e-9 and fit.largest < 1e-6


def test_points_on_one_face_do_not_fix_a_surface_frame(block3d):
    xyz = np.c_[np.linspace(-4, 4, 9), np.linspace(-3, 3, 9) ** 2 / 3, np.full(9, 10.0)]
    with pytest.raises(Exception, match=r"transform: the 9 points of f do not fix the frame .* left free"):
        fit_to_surface(frame_spec({"fit": "surface"}, "transform"), list("abcdefghi"), xyz,
                       mesh_surface(block3d.mesh), "f")


def check_data_config(tmp_path, capsys, data: dict) -> tuple[int, str]:
    config = tmp_path / "check.toml"
    config.write_text(tomli_w.dumps({"model": {"builder": "block", "mesh_size": 5.0},
                                     "data": {"observables": ["ux"], "stages": [1], **data}}))
    status = main(["check-data", str(config)])
    out = capsys.readouterr()
    return status, out.out + out.err


BAD = [
    ({"transform": {"rotation": [[1, 0, 0], [0, 1, 0.1], [0, 0, 1]]}},
     "[data] transform.rotation is not a rotation: R^T R differs from the identity by 0.1"),
    ({"transform": {"rotation": [[1, 0, 0], [0, -1, 0], [0, 0, 1]]}},
     "[data] transform.rotation is not a rotation: det R = -1, a mirror"),
    ({"transform": {"rotation": [[1, 0], [0, 1], [0, 0]]}}, "[data] transform.rotation must be a 3x3 matrix"),
    ({"transform": {"rotation_deg": [10, 20]}}, "[data] transform.rotation_deg must be 1 or 3 finite numbers"),
    ({"transform": {"translation": [1, 2, 3, 4]}}, "[data] transform.translation must be 2 or 3 finite numbers"),
    ({"transform": {"rotate": [0, 0, 1]}}, "[data] transform: unknown key 'rotate'"),
    ({"transform": {"fit": "points", "points": {"P1": [0, 0, 0], "Q7": [1, 0, 0], "P3": [0, 1, 0]}}},
     "[data] transform.points.Q7: no point 'Q7' in"),
    ({"transform": {"fit": "points", "points": {"P1": [0, 0, 0], "P2": [1, 0, 0]}}},
     "[data] transform.points: 2 reference point(s) do not fix a frame"),
    ({"transform": {"fit": "surface", "regions": ["blok"]}}, "[data] transform.regions ['blok'] are not regions"),
    ({"transform": {"fit": "sphere"}}, "[data] transform.fit must be one of 'points', 'surface'"),
    ({"relative_to": "Q7"}, "relative_to = 'Q7' is not a point of this file"),
]


@pytest.mark.parametrize("data, message", BAD, ids=[m.split(":")[-1][:30] for _, m in BAD])
def test_a_bad_transform_exits_2_naming_the_key(tmp_path, capsys, data, message):
    status, out = check_data_config(tmp_path, capsys, {"file": str(FIXTURES / "generic.csv"), **data})
    assert status == 2 and message in out and "Traceback" not in out, out


def test_a_bad_transform_in_a_file_entry_names_the_entry(tmp_path, capsys):
    entry = {"path": str(FIXTURES / "vic3d.csv"), "transform": {"rotation": [[2, 0, 0], [0, 1, 0], [0, 0, 1]]}}
    status, out = check_data_config(tmp_path, capsys, {"file": [entry]})
    assert status == 2 and "[data] file entry 1 transform.rotation is not a rotation" in out


def test_check_data_on_a_config_reports_the_fitted_frame_and_its_residual(tmp_path, capsys):
    truth = full_fields()
    write_measurements(tmp_path / "dic.csv", in_dic_frame(truth, rotation_from_degrees(ANGLES), SHIFT))
    points = {p: xyz.tolist() for p, xyz in list(zip(truth.points, truth.coordinates))[:5]}
    status, out = check_data_config(tmp_path, capsys, {"file": str(tmp_path / "dic.csv"),
                                                       "transform": {"fit": "points", "points": points}})
    assert status == 0, out
    assert "frame fitted to reference points (5 points): rotation_deg = [20.000000, -35.000000, 110.000000]" in out
    assert "translation = [12.500000, -4.000000, 30.000000] mm" in out and "residual RMS" in out


def test_a_matchid_file_without_transform_gets_a_note_on_its_y_axis(capsys):
    assert main(["check-data", str(FIXTURES / "matchid.csv"), "--strain", "engineering"]) == 0
    assert "MatchID writes Y (and V) downwards" in capsys.readouterr().out


def test_rotation_deg_is_exact_at_right_angles():
    """[180, 0, 0] (MatchID's image frame) keeps z = 0 of a plane exactly: no round-off from sin(pi)."""
    r = rotation_from_degrees([180, 0, 90])
    assert set(np.unique(r)) <= {-1.0, 0.0, 1.0}
    assert Frame(r, np.zeros(3)).points([[1.0, 2.0, 0.0]])[0, 2] == 0.0


def test_the_generic_fixture_is_unchanged_by_the_identity(tmp_path):
    m = read({"file": str(FIXTURES / "generic.csv"), "transform": {"rotation_deg": 0}}).measurements
    plain = read_measurements(FIXTURES / "generic.csv")
    assert np.array_equal(m.coordinates, plain.coordinates)
    for q in plain.quantities:
        assert np.array_equal(m.values[q], plain.values[q], equal_nan=True)


def test_check_data_fits_a_frame_to_the_model_surface(tmp_path, capsys):
    """check-data CONFIG.toml builds the model when a frame is fitted to its surface: points on three faces of the
    3-D block and the plate, in a frame turned by (2, -1, 3) deg and shifted, come back onto the surface."""
    rng = np.random.default_rng(5)
    n = 8
    xyz = np.concatenate([np.c_[np.full(n, 5.0), rng.uniform(-4, 4, n), rng.uniform(1, 9, n)],
                          np.c_[rng.uniform(-4, 4, n), np.full(n, -5.0), rng.uniform(1, 9, n)],
                          np.c_[rng.uniform(-4, 4, n), rng.uniform(-4, 4, n), np.full(n, 10.0)],
                          np.c_[rng.uniform(8, 18, n), rng.uniform(-18, 18, n), np.zeros(n)]])
    file_xyz = Frame.of([2.0, -1.0, 3.0], [0.3, 0.2, -0.1]).inverse().points(xyz)
    m = Measurements(tuple(f"P{i}" for i in range(len(xyz))), file_xyz, np.ones(len(xyz)), np.full(len(xyz), np.nan),
                     {"ux": np.zeros(len(xyz))})
    write_measurements(tmp_path / "dic.csv", m)
    status, out = check_data_config(tmp_path, capsys, {"file": str(tmp_path / "dic.csv"),
                                                       "transform": {"fit": "surface"}})
    assert status == 0, out
    assert "frame fitted to the model surface (32 points): rotation_deg = [2.000000, -1.000000, 3.000000]" in out
    assert "translation = [0.300000, 0.200000, -0.100000] mm" in out


def test_the_run_fingerprint_sees_a_file_tables_transform(tmp_path):
    from frictionid.data.sources import data_digest
    path = str(FIXTURES / "generic.csv")
    plain = data_digest(DataSpec(file=path), Path)
    table = data_digest(DataSpec(file=[{"path": path}]), Path)
    turned = data_digest(DataSpec(file=[{"path": path, "transform": {"rotation_deg": 90}}]), Path)
    assert plain == read_digest(path) and len({plain, table, turned}) == 3


def read_digest(path) -> str:
    import hashlib
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def test_a_surface_frame_on_an_axisymmetric_model_is_refused(tmp_path):
    from types import SimpleNamespace

    from frictionid.errors import InputError
    model = SimpleNamespace(kind="axisymmetric", mesh=None)
    with pytest.raises(InputError, match=r"\[data\] transform: fit = \"surface\" is not available for an axisym"):
        read({"file": str(FIXTURES / "generic.csv"), "transform": {"fit": "surface"}}, model=model)


def test_a_plane_frame_and_a_scale_fitted_to_the_surface(block2d, block3d):
    """A plane model's frame is fitted in its plane (turn about z, shift in x, y); a 3-D one with a scale."""
    rng = np.random.default_rng(7)
    n = 10
    plane = np.concatenate([np.c_[np.full(n, -5.0), rng.uniform(0.5, 9.5, n), np.zeros(n)],
                            np.c_[rng.uniform(-4, 4, n), np.full(n, 10.0), np.zeros(n)],
                            np.c_[rng.uniform(6, 18, n), np.zeros(n), np.zeros(n)]])
    truth = Frame.of(5.0, [0.4, -0.3, 0.0])
    file_xyz = truth.inverse().points(plane)
    fit = fit_to_surface(frame_spec({"fit": "surface"}, "t"), list(map(str, range(3 * n))), file_xyz,
                         mesh_surface(block2d.mesh), "f")
    assert np.abs(fit.frame.points(file_xyz) - plane).max() < 1e-6 and fit.frame.points(file_xyz)[:, 2].max() == 0
    solid = np.concatenate([np.c_[np.full(n, -5.0), rng.uniform(-4, 4, n), rng.uniform(1, 9, n)],
                            np.c_[rng.uniform(-4, 4, n), np.full(n, 5.0), rng.uniform(1, 9, n)],
                            np.c_[rng.uniform(-4, 4, n), rng.uniform(-4, 4, n), np.full(n, 10.0)],
                            np.c_[rng.uniform(6, 18, n), rng.uniform(-18, 18, n), np.zeros(n)]])
    truth = Frame(rotation_from_degrees([-2.0, 3.0, 1.0]), np.array([0.2, 0.1, -0.3]), 1.003)
    file_xyz = truth.inverse().points(solid)
    fit = fit_to_surface(frame_spec({"fit": "surface", "scale": True}, "t"), list(map(str, range(4 * n))),
                         file_xyz, mesh_surface(block3d.mesh), "f")
    assert np.abs(fit.frame.points(file_xyz) - solid).max() < 1e-6 and abs(fit.frame.scale - 1.003) < 1e-9


def test_standard_deviations_are_turned_as_independent_errors():
    m = Measurements(("P",), [[1.0, 2.0, 0.0]], [1], [np.nan], {"ux": [0.1], "uy": [0.2]},
                     sigma={"ux": [0.001], "uy": [0.002]})
    quarter = in_model_frame(m, Frame.of(90), "")
    assert quarter.sigma["ux"][0] == 0.002 and quarter.sigma["uy"][0] == 0.001
    eighth = in_model_frame(m, Frame.of(45), "")
    np.testing.assert_allclose([eighth.sigma["ux"][0], eighth.sigma["uy"][0]], np.sqrt(2.5e-6), rtol=1e-12)


def test_a_surface_frame_is_fitted_to_a_sample_and_reported_over_all_points(block3d, monkeypatch):
    import frictionid.data.frame_fit as frame_fit
    monkeypatch.setattr(frame_fit, "FIT_POINTS", 16)          # 40 points: every 3rd is fitted
    rng = np.random.default_rng(9)
    n = 10
    xyz = np.concatenate([np.c_[np.full(n, -5.0), rng.uniform(-4, 4, n), rng.uniform(1, 9, n)],
                          np.c_[rng.uniform(-4, 4, n), np.full(n, 5.0), rng.uniform(1, 9, n)],
                          np.c_[rng.uniform(-4, 4, n), rng.uniform(-4, 4, n), np.full(n, 10.0)],
                          np.c_[rng.uniform(6, 18, n), rng.uniform(-18, 18, n), np.zeros(n)]])
    shifted = xyz + [0.0, 0.0, 0.02]
    shifted[5, 0] -= 0.3                                      # a point the sample leaves out, 0.3 mm off its face
    fit = fit_to_surface(frame_spec({"fit": "surface"}, "t"), list(map(str, range(4 * n))), shifted,
                         mesh_surface(block3d.mesh), "f")
    assert fit.n_points == 4 * n and fit.worst == "5" and abs(fit.largest - 0.3) < 1e-9
    assert np.abs(fit.frame.translation - [0.0, 0.0, -0.02]).max() < 1e-9
