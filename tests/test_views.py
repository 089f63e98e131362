"""Several camera views of one stage (issue 15, item 5), each an export in its own frame with its transform, identify
like the generic CSV; relative_to removes a rigid motion the views see."""

import json
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from frictionid.cli import main
from frictionid.data import read_measurements
from frictionid.data.frames import Frame, rotation_from_degrees
from frictionid.data.sources import read_sources
from frictionid.data.table import Measurements
from frictionid.inverse.observations import Observations
from frictionid.options import DataSpec
from fixtures.dic import generate

ROOT = Path(__file__).parents[1]

#: view -> (points of examples/first it sees, writer, its frame: rotation_deg, translation [mm])
VIEWS = {"left": ("L", generate.write_gom, 90.0, [-5.0, 2.0, 0.0]),
         "right": ("R", generate.write_vic3d, -63.5, [5.0, 2.5, 0.0]),
         "base": ("B", generate.write_matchid, [180.0, 0.0, 17.25], [0.5, -0.25, 0.0])}   # MatchID: y down


def part(m: Measurements, prefix: str, offset=(0.0, 0.0)) -> Measurements:
    """The rows of points labelled prefix*, displacements shifted by ``offset`` [mm] (a rigid motion)."""
    rows = np.array([p.startswith(prefix) for p in m.points])
    values = {"ux": m.values["ux"][rows] + offset[0], "uy": m.values["uy"][rows] + offset[1]}
    return Measurements(tuple(np.array(m.points)[rows]), m.coordinates[rows], m.stage[rows], m.force[rows], values)


def in_view_frame(m: Measurements, angles, shift) -> Measurements:
    """``m`` as the view's DIC system gives it: p_file = R^T (p_model - t), u_file = R^T u_model."""
    rotation = rotation_from_degrees(angles)
    u = np.column_stack([m.values["ux"], m.values["uy"], np.zeros(m.n_rows)]) @ rotation
    return Measurements(m.points, (m.coordinates - shift) @ rotation, m.stage, m.force,
                        {"ux": u[:, 0], "uy": u[:, 1]})


def write_views(folder: Path, offsets=None) -> tuple[list[dict], dict]:
    """Stage 2 of the twin data as one export per view in its own frame; [data] file tables and regions."""
    measured = read_measurements(folder / "measured.csv").select(stages=[2])
    entries, regions = [], {}
    for view, (prefix, writer, angles, shift) in VIEWS.items():
        m = in_view_frame(part(measured, prefix, (offsets or {}).get(view, (0.0, 0.0))), angles, shift)
        labels = writer(folder / f"{view}_2.csv", m)
        entry = {"path": f"{view}_2.csv", "stage": 2, "view": view,
                 "transform": {"rotation_deg": angles, "translation": shift}}
        entries.append({**entry, "first_label": labels[0]})
        regions[f"{view}/*"] = "base" if view == "base" else "block"
    return entries, regions


def identified(folder: Path, name: str, **data) -> dict:
    """result.json of examples/first's identify.toml with [data] changed, on a 2 mm mesh, run into runs/<name>."""
    config = tomllib.loads((folder / "identify.toml").read_text())
    config["model"]["mesh_size"] = 2.0
    config["data"].update(data)
    config["run"] = {"dir": f"runs/{name}", "fields": False}
    path = folder / f"{name}.toml"
    path.write_text(tomli_w.dumps(config))
    assert main(["identify", str(path)]) == 0
    return json.loads((folder / "runs" / name / "result.json").read_text())


def values(result: dict) -> dict:
    return {zone: p["value"] for zone, p in result["parameters"].items()}


def assert_same(a: dict, b: dict, rtol: float = 1e-8):
    assert a.keys() == b.keys()
    for zone in a:
        assert abs(a[zone] - b[zone]) <= rtol * max(abs(b[zone]), 1.0), (zone, a[zone], b[zone])


@pytest.mark.slow
def test_views_with_transforms_identify_like_the_generic_csv(first):
    """Left and base views with their frames given, the right view's fitted to one of its points and two markers
    given in both frames (the view's points alone lie on one line)."""
    entries, regions = write_views(first)
    files = [{k: v for k, v in e.items() if k != "first_label"} for e in entries]
    _, _, angles, shift = VIEWS["right"]
    frame = Frame.of(angles, shift)
    markers = {f"M{k}": {"file": frame.inverse().points([xyz])[0].tolist(), "model": xyz}
               for k, xyz in enumerate([[8.0, 3.0, 0.0], [12.0, -2.0, 0.0]])}
    r1 = read_measurements(first / "measured.csv").select(stages=[2])
    files[1]["transform"] = {"fit": "points", "points": {entries[1]["first_label"]: r1.coordinates[
        r1.points.index("R1")].tolist(), **markers}}
    reference = identified(first, "views_generic", stages=[2])
    by_views = identified(first, "views", file=files, regions=regions, stages=[2])
    assert_same(values(by_views), values(reference))
    frames = by_views["data"]["frames"]
    assert [f["view"] for f in frames] == list(VIEWS) and [f["fit"] for f in frames] == [None, "points", None]
    assert frames[1]["residual_max_mm"] < 1e-9 and abs(frames[1]["rotation_deg"][2] - angles) < 1e-9
    assert by_views["fit"]["n_obs"] == reference["fit"]["n_obs"] == 40


def test_a_view_without_its_transform_is_not_the_same_data(first):
    """The views' files really are in other frames: read without the transforms, they are off the model."""
    entries, _ = write_views(first)
    files = [{k: v for k, v in e.items() if k not in ("first_label", "transform")} for e in entries]
    m = read_sources(DataSpec.from_table({"file": files, "observables": ["ux"], "stages": [2]}),
                     lambda p: first / p).measurements
    truth = read_measurements(first / "measured.csv").select(stages=[2])
    assert np.abs(m.coordinates[:, :2] - truth.coordinates[:, :2]).max() > 1.0
    assert m.points[0] == "left/L1" and m.points[-1].startswith("base/")


def test_two_views_of_a_stage_without_view_names_are_refused(first, capsys):
    entries, _ = write_views(first)
    files = [{"path": entries[0]["path"], "stage": 2}, {"path": entries[0]["path"], "stage": 2}]
    with pytest.raises(Exception, match="each with view = \"name\""):
        read_sources(DataSpec.from_table({"file": files, "observables": ["ux"], "stages": [2]}), lambda p: first / p)


@pytest.mark.slow
def test_relative_to_removes_the_rigid_motion_each_view_sees(first):
    """Each view's points carry a rigid displacement of their own (the machine's motion seen by that camera):
    relative to a point of each view, the fit is the one without the motion; without relative_to it is not."""
    offsets = {"left": (0.004, -0.003), "right": (-0.002, 0.005), "base": (0.003, 0.002)}
    plain, regions = write_views(first)
    files = [{k: v for k, v in e.items() if k != "first_label"} | {"relative_to": e["first_label"]} for e in plain]
    still = identified(first, "relative_still", file=files, regions=regions, stages=[2])
    write_views(first, offsets)
    moved = identified(first, "relative_moved", file=files, regions=regions, stages=[2])
    assert_same(values(moved), values(still))
    assert moved["data"]["relative_to"] == sorted(f"{e['view']}/{e['first_label']}" for e in plain)
    assert moved["fit"]["n_obs"] == 40 - 2 * len(VIEWS)              # the references' own motion is not fitted
    absolute = identified(first, "relative_ignored", file=[{k: v for k, v in f.items() if k != "relative_to"}
                                                           for f in files], regions=regions, stages=[2])
    assert absolute["fit"]["reduced_chi2"] > 30 * moved["fit"]["reduced_chi2"]     # measured: 34.4 vs 0.277


def test_relative_observations_predict_the_difference_of_two_rows():
    obs = Observations(points=np.zeros((2, 2)), point_regions=(None, None), quantities=("ux",),
                       row=np.array([0, 1]), stage=np.array([0, 0]), y=np.zeros(2), sigma=np.ones(2),
                       labels=("P:ux@1", "Q:ux@1"), noise_known=True, minus_row=np.array([-1, 0]))
    values = np.array([[3.0, 5.0]])
    np.testing.assert_array_equal(obs.predicted(values), [3.0, 2.0])
    np.testing.assert_array_equal(obs.derivatives(values[..., None] * [1.0, 10.0])[:, 1], [30.0, 20.0])


@pytest.mark.slow
def test_two_specimens_with_their_own_frames_and_forces_share_the_coefficients(first):
    """Specimen S1 (the generic CSV) and S2 (the same twin seen by three views in their frames, its force from the
    config): one identification fits both with the same coefficients; the data twice give the same minimum, so the
    coefficients equal those of S1 alone, and each specimen's machine force is an observation of its own."""
    force = read_measurements(first / "measured.csv").stage_force(2)
    views, regions = write_views(first)
    s2 = [{k: v for k, v in e.items() if k != "first_label"} | {"specimen": "S2", "force": force} for e in views]
    regions = {f"S2/{k}": v for k, v in regions.items()} | {"S1/L*": "block", "S1/R*": "block", "S1/*": "base"}
    fit = {"observables": ["ux", "uy", "force"], "noise": {"u": 0.0005, "force": 1.0}, "stages": [2]}
    alone = identified(first, "specimen_alone", **fit)
    both = identified(first, "specimens", file=[{"path": "measured.csv", "specimen": "S1"}, *s2], regions=regions,
                      **fit)
    assert_same(values(both), values(alone))
    assert both["fit"]["n_obs"] == 2 * alone["fit"]["n_obs"] == 2 * 41
    labels = [o["label"] for o in both["fit"]["observations"]]
    assert "S1/force@2" in labels and "S2/force@2" in labels


def test_views_of_one_specimen_giving_two_forces_are_refused(first, capsys):
    views, regions = write_views(first)
    files = [{k: v for k, v in e.items() if k != "first_label"} | {"force": 100.0 + k} for k, e in enumerate(views)]
    config = tomllib.loads((first / "identify.toml").read_text())
    config["data"].update(file=files, regions=regions, observables=["ux", "force"], noise={"u": 5e-4, "force": 1.0})
    path = first / "two_forces.toml"
    path.write_text(tomli_w.dumps(config))
    assert main(["identify", str(path)]) == 2
    err = capsys.readouterr().err
    assert "stage 2 has the machine forces 100, 101, 102 N from different files" in err and "Traceback" not in err


#: views of the 3-D block's faces: (points on the face, its DIC frame: rotation R, translation [mm]); a view's file
#: x, y lie in the face (turned in it by an angle of its own), so that its in-plane strains are the face's
def _face_frame(place, turn_deg):
    return (rotation_from_degrees(place) @ rotation_from_degrees(turn_deg)).tolist()


FACES = {"front": (lambda u, v: [u, -5.0, v], _face_frame([90, 0, 0], 7.0), [0.0, -5.0, 5.0]),
         "side": (lambda u, v: [5.0, u, v], _face_frame([90, 0, 90], 37.0), [5.0, 0.0, 5.0]),
         "top": (lambda u, v: [u, v, 10.0], _face_frame([0, 0, 0], -31.0), [0.0, 0.0, 10.0])}
STRAINS = ("exx", "eyy", "ezz", "exy", "eyz", "exz")


def strain_tensor(values: dict, i: int) -> np.ndarray:
    e = {q: values[q][i] for q in STRAINS}
    return np.array([[e["exx"], e["exy"], e["exz"]], [e["exy"], e["eyy"], e["eyz"]], [e["exz"], e["eyz"], e["ezz"]]])


def as_seen(m: Measurements, rotation, shift) -> tuple[Measurements, Measurements]:
    """What a view's DIC system gives (its frame; displacements and in-plane strains exx, eyy, exy only) and the
    same information in the model's frame (the strain components of the face's plane; the others empty)."""
    rotation = np.array(rotation)
    u = np.column_stack([m.values[q] for q in ("ux", "uy", "uz")])
    seen, known = {q: (u @ rotation)[:, k] for k, q in enumerate(("ux", "uy", "uz"))}, dict(m.values)
    tensors = [rotation.T @ strain_tensor(m.values, i) @ rotation for i in range(m.n_rows)]
    for q, (a, b) in zip(("exx", "eyy", "exy"), ((0, 0), (1, 1), (0, 1))):
        seen[q] = np.array([t[a, b] for t in tensors])
    in_face = {a for a in range(3) if np.hypot(rotation[a, 0], rotation[a, 1]) > 1 - 1e-12}   # model axes
    for q, (a, b) in zip(STRAINS, ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))):
        known[q] = m.values[q] if {a, b} <= in_face else np.full(m.n_rows, np.nan)
    return (Measurements(m.points, (m.coordinates - shift) @ rotation, m.stage, m.force, seen),
            Measurements(m.points, m.coordinates, m.stage, m.force, known))


@pytest.mark.slow
def test_per_face_views_of_the_3d_block_identify_like_the_generic_csv(tmp_path):
    """Twin data on three faces of the 3-D block (displacements and surface strains at 0.2 mm pull), seen by one
    DIC view per face in its own frame (GOM exports: in-plane strains exx, eyy, exy of the view), identify like the
    generic CSV that holds the same values in the model frame: the vectors and the strain tensors turned right."""
    rng = np.random.default_rng(11)
    labels, xyz = [], []
    for face, (place, _, _) in FACES.items():
        for k, (u, v) in enumerate(zip(rng.uniform(-4, 4, 6), rng.uniform(1, 9, 6) if face != "top"
                                       else rng.uniform(-4, 4, 6))):
            labels.append(f"{face[0].upper()}{k + 1}")
            xyz.append(place(u, v))
    points = Measurements(tuple(labels), xyz, np.full(len(xyz), 2), np.full(len(xyz), np.nan), {})
    from frictionid.data import write_measurements
    write_measurements(tmp_path / "points.csv", points)
    model = {"builder": "block", "mesh_size": 5.0}
    observables = ["ux", "uy", "uz", *STRAINS]
    truth = {"model": model, "friction": {"zones": {"A": 0.3, "B": 0.15, "C": 0.25, "D": 0.2}},
             "data": {"file": "points.csv", "observables": observables, "stages": [2], "regions": {"*": "block"}},
             "run": {"dir": "runs/truth", "fields": False}}
    (tmp_path / "truth.toml").write_text(tomli_w.dumps(truth))
    assert main(["simulate", str(tmp_path / "truth.toml"), "--out", str(tmp_path / "measured.csv")]) == 0
    measured = read_measurements(tmp_path / "measured.csv").select(stages=[2])
    files, known = [], []
    for face, (_, rotation, shift) in FACES.items():
        seen, in_model = as_seen(part_of(measured, face[0].upper()), rotation, shift)
        generate.write_gom(tmp_path / f"{face}.csv", seen)
        files.append({"path": f"{face}.csv", "stage": 2, "view": face,
                      "transform": {"rotation": rotation, "translation": shift}})
        known.append(in_model)
    write_measurements(tmp_path / "generic.csv", joined(known))
    data = {"observables": observables, "stages": [2], "noise": {"u": 5e-4, "e": 1e-5}}
    start = {"zones": {"A": 0.1, "B": 0.1, "C": 0.1, "D": 0.1}}

    def run(name, **more):
        config = {"model": model, "friction": start, "data": {**data, **more}, "run": {"dir": f"runs/{name}",
                                                                                       "fields": False}}
        (tmp_path / f"{name}.toml").write_text(tomli_w.dumps(config))
        assert main(["identify", str(tmp_path / f"{name}.toml")]) == 0
        return json.loads((tmp_path / "runs" / name / "result.json").read_text())

    reference = run("generic", file="generic.csv", regions={"*": "block"})
    by_views = run("views", file=files, regions={"*": "block"})
    assert_same(values(by_views), values(reference))
    assert by_views["fit"]["n_obs"] == reference["fit"]["n_obs"] == 18 * 3 + 18 * 3   # u, and 3 surface strains
    assert abs(values(reference)["C"] - 0.25) < 1e-3                               # the twin's truth is found


def part_of(m: Measurements, prefix: str) -> Measurements:
    rows = np.array([p.startswith(prefix) for p in m.points])
    return Measurements(tuple(np.array(m.points)[rows]), m.coordinates[rows], m.stage[rows], m.force[rows],
                        {q: v[rows] for q, v in m.values.items()})


def joined(parts) -> Measurements:
    return Measurements(sum((p.points for p in parts), ()), np.vstack([p.coordinates for p in parts]),
                        np.concatenate([p.stage for p in parts]), np.concatenate([p.force for p in parts]),
                        {q: np.concatenate([p.values[q] for p in parts]) for q in parts[0].values})
