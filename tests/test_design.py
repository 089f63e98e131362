"""Experiment design: point selection, the finest resolvable partition, merged zones, `frictionid design`."""

import json

import matplotlib.image
import numpy as np
import pytest

from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.registry import build_model, refined
from frictionid import planning
from frictionid.cli import main
from frictionid.inverse.design import finest_partition, information_of, merged_stderr, select_points
from frictionid.inverse.resolution import predicted_stderr
from frictionid.model.merge import merge_zones
from helpers import write_config
from frictionid.options import ModelSpec

# ------------------------------------------------------------------------------------------ selection


def test_greedy_a_optimal_selection_beats_every_other_pair_or_ties():
    rng = np.random.default_rng(3)
    rows = rng.normal(size=(12, 2, 3)) * rng.uniform(0.1, 3.0, size=(12, 1, 3))
    chosen = select_points(rows, 3)
    best = np.sum(predicted_stderr(information_of(rows, chosen)) ** 2)
    # the greedy choice is no optimum, but it must beat a random triple on the sum of variances
    random = [np.sum(predicted_stderr(information_of(rows, rng.choice(12, 3, replace=False))) ** 2)
              for _ in range(200)]
    assert best <= np.percentile(random, 10)
    assert len(set(chosen)) == 3


def test_selection_first_covers_a_zone_nothing_else_sees():
    rows = np.zeros((5, 1, 2))
    rows[:4, 0, 0] = [1.0, 2.0, 3.0, 4.0]                      # four points see only zone 0
    rows[4, 0, 1] = 0.1                                        # one point sees zone 1, weakly
    assert 4 in select_points(rows, 2) and 4 in select_points(rows, 2, "D")


@pytest.mark.parametrize("n, criterion, message", [(0, "A", "design.points = 0"), (6, "A", "design.points = 6"),
                                                   (2, "E", "design.criterion")])
def test_bad_selection_arguments(n, criterion, message):
    from frictionid.errors import InputError
    with pytest.raises(InputError, match=message):
        select_points(np.ones((5, 1, 2)), n, criterion)


# ------------------------------------------------------------------------------------------ partitions


def test_merged_stderr_is_the_sum_of_the_columns():
    jac = np.array([[1.0, 2.0, 0.0], [0.5, 1.0, 3.0], [0.0, 1.0, 1.0]])
    info = jac.T @ jac
    merged = np.column_stack([jac[:, 0] + jac[:, 1], jac[:, 2]])
    np.testing.assert_allclose(merged_stderr(info, [[0, 1], [2]]), predicted_stderr(merged.T @ merged),
                               rtol=1e-12)


def test_partition_keeps_resolved_zones_and_merges_neighbours_first():
    # zones 0..3 on a line: 1 and 2 seen only together, 3 barely seen; 0 resolved on its own
    jac = np.array([[10.0, 0, 0, 0], [0, 1.0, 1.0, 0.01], [0, 1.0, 1.0001, 0.0], [0, 0, 0.0, 0.0]])
    info = jac.T @ jac + np.diag([0, 0, 0, 1e-6])
    neighbours = {frozenset((0, 1)), frozenset((1, 2)), frozenset((2, 3))}
    p = finest_partition(info, ["A", "B", "C", "D"], 2.0, neighbours)
    assert p.groups[0] == ("A",) and p.resolved.all()
    assert ("B", "C") in p.groups or ("B", "C", "D") in p.groups
    assert p.merge_table() and all(len(g) > 1 for g in p.merge_table().values())
    # zones on different interfaces never merge: nothing resolves B alone, so it stays unresolved
    q = finest_partition(info, ["A", "B", "C", "D"], 2.0, neighbours, interface_of=[0, 1, 2, 3])
    assert len(q.groups) == 4 and not q.resolved.all()


# ------------------------------------------------------------------------------------------ merged zones

BLOCK2D = {"builder": "block2d", "mesh_size": 2.0, "n_zones": 4}
POINTS = np.array([[-5.0, 1.0], [5.0, 1.0], [-7.0, 0.0], [7.0, 0.0]])
REGIONS = ["block", "block", "base", "base"]


def test_a_merged_zone_solves_like_its_members_at_one_coefficient():
    model = build_model(ModelSpec.from_table(BLOCK2D))
    merged = merge_zones(model, {"BC": ["B", "C"]})
    assert merged.zone_names == ("A", "BC", "D")
    one = EmbeddedBackend(model, POINTS, ("ux", "uy"), REGIONS).predict(np.array([0.2, 0.3, 0.3, 0.4]), True)
    two = EmbeddedBackend(merged, POINTS, ("ux", "uy"), REGIONS).predict(np.array([0.2, 0.3, 0.4]), True)
    np.testing.assert_allclose(two.values, one.values, rtol=0, atol=1e-12)
    np.testing.assert_allclose(two.derivatives[..., 1], one.derivatives[..., 1] + one.derivatives[..., 2],
                               rtol=0, atol=1e-12)
    assert np.abs(two.derivatives[..., 1]).max() > 1e-3        # the merged zone is seen: the check is not empty


def test_the_registry_merges_and_refines_alike():
    options = {**BLOCK2D, "merge": {"AB": ["A", "B"]}}
    assert build_model(ModelSpec.from_table(options)).zone_names == ("AB", "C", "D")
    assert build_model(refined(ModelSpec.from_table(options))).zone_names == ("AB", "C", "D")


# ------------------------------------------------------------------------------------------ the commands

CSV = "point,x,y,z,stage,ux,uy\n" + "".join(f"P{k},{x},{y},0.0,2,0.0,0.0\n" for k, (x, y) in enumerate(POINTS))


def _config(folder, zones="A = 0.3, B = 0.3", extra="", design="", noise="noise = { u = 0.0005 }\n"):
    (folder / "points.csv").write_text(CSV)
    regions = ", ".join(f'P{k} = "{r}"' for k, r in enumerate(REGIONS))
    return write_config(folder / "plan.toml", model={"builder": "block2d", "mesh_size": 2.0},
                        friction=f"zones = {{ {zones} }}\n{extra}",
                        data=f'file = "points.csv"\nobservables = ["ux", "uy"]\nstages = [2]\n{noise}'
                        f"regions = {{ {regions} }}\n", design=f"n_candidates = 60\n{design}", run={"dir": "runs/plan"})


def test_design_writes_the_chosen_points_and_the_partitions(tmp_path, capsys):
    assert main(["design", str(_config(tmp_path)), "--points", "6"]) == 0
    out = capsys.readouterr().out
    result = json.loads((tmp_path / "runs/plan/design/design.json").read_text())
    assert result["chosen"]["n_points"] == 6 and len(result["chosen"]["points"]) == 6
    planned, chosen = result["planned"]["stderr"], result["chosen"]["stderr"]
    assert sum(chosen[z] ** 2 for z in "AB") < sum(planned[z] ** 2 for z in "AB")
    assert "predicted standard errors" in out
    # the plot: one panel per zone side by side, the chosen points circled red over the viridis candidates
    image = matplotlib.image.imread(tmp_path / "runs/plan/design/sensitivity.png")[:, :, :3]
    red = (image[:, :, 0] > 0.8) & (image[:, :, 1] < 0.3) & (image[:, :, 2] < 0.3)
    coloured = np.ptp(image, axis=2) > 0.2                  # neither white, grey nor black
    assert image.shape[1] > image.shape[0] and red.sum() > 6 and coloured.sum() > 20 * red.sum() / 6
    assert red[:, : image.shape[1] // 2].any() and red[:, image.shape[1] // 2:].any()      # in both panels
    # the chosen points file is a points file `simulate` takes
    (tmp_path / "points.csv").write_text((tmp_path / "runs/plan/design/chosen_points.csv").read_text())
    regions = ", ".join(f'"{k}" = "{v}"' for k, v in result["chosen"]["regions"].items())
    assert f"regions = {{ {regions} }}" in out
    config = (tmp_path / "plan.toml").read_text().splitlines()
    config = [f"regions = {{ {regions} }}" if line.startswith("regions =") else line for line in config]
    (tmp_path / "plan.toml").write_text("\n".join(config) + "\n")
    assert main(["simulate", str(tmp_path / "plan.toml"), "--out", str(tmp_path / "sim.csv")]) == 0


def test_identify_runs_on_a_merged_partition(tmp_path):
    (tmp_path / "truth.toml").write_text(_config(tmp_path, "A = 0.25, B = 0.25").read_text())
    assert main(["simulate", str(tmp_path / "truth.toml"), "--out", str(tmp_path / "measured.csv")]) == 0
    path = _config(tmp_path, "AB = 0.1", 'merge = { AB = ["A", "B"] }\n')
    path.write_text(path.read_text().replace("points.csv", "measured.csv").replace("[design]\nn_candidates = 60\n",
                                                                                  ""))
    assert main(["identify", str(path)]) == 0
    result = json.loads((tmp_path / "runs/plan/result.json").read_text())
    assert list(result["parameters"]) == ["AB"]
    assert result["parameters"]["AB"]["value"] == pytest.approx(0.25, abs=1e-6)


@pytest.mark.parametrize("extra, design, noise, message", [
    ('merge = { AB = ["A", "X"] }\n', "", None, "friction.merge.AB: unknown zone"),
    ('merge = { AB = ["A"] }\n', "", None, "friction.merge.AB must list at least two"),
    ('merge = { AB = ["A", "B"], BA = ["B", "A"] }\n', "", None, "zone 'B' is in both"),
    ("", 'candidates = "everywhere"\n', None, "design.candidates"),
    ("", 'regions = ["bolt"]\n', None, "design.regions: unknown region"),
    ("", "points = 100\n", None, "design.n_candidates = 60 is fewer"),
    ("", "", "", "design needs the noise"),
])
def test_bad_design_or_merge_input_exits_2_naming_the_key(tmp_path, capsys, extra, design, noise, message):
    zones = "AB = 0.3" if "AB" in extra and "X" not in extra and '["A"]' not in extra else "A = 0.3, B = 0.3"
    path = _config(tmp_path, zones, extra, design, "" if noise == "" else "noise = { u = 0.0005 }\n")
    assert main(["design", str(path)]) == 2
    assert message in capsys.readouterr().err


def test_design_takes_a_plain_points_file_and_prints_regions_as_valid_toml(tmp_path, capsys):
    """A points file of point,x,y,z only (no stage, no values: a plan has none), points on the block's sides
    (region from [data] regions) and on the base (no region given); the printed regions suggestion is TOML whose
    values are the model's regions, and no chosen point is labelled after a missing region."""
    import tomllib

    points = {"L1": (-5.0, 0.5), "L2": (-5.0, 1.5), "R1": (5.0, 0.5), "R2": (5.0, 1.5), "B1": (-12.0, 0.0),
              "B2": (12.0, 0.0), "B3": (-16.0, -2.0), "B4": (16.0, -2.0)}
    (tmp_path / "points.csv").write_text("# planned DIC points [mm]\npoint,x,y,z\n"
                                         + "".join(f"{p},{x},{y},0.0\n" for p, (x, y) in points.items()))
    (tmp_path / "plan.toml").write_text(
        '[model]\nbuilder = "block2d"\nmesh_size = 2.0\n[friction]\nzones = { A = 0.3, B = 0.3 }\n'
        '[data]\nfile = "points.csv"\nobservables = ["ux", "uy"]\nstages = [2]\nnoise = { u = 0.0005 }\n'
        'regions = { "L*" = "block", "R*" = "block" }\n[design]\nn_candidates = 8\n[run]\ndir = "runs"\n')
    assert main(["design", str(tmp_path / "plan.toml"), "--points", "8"]) == 0
    out = capsys.readouterr().out
    suggestion = out.split("[data] regions = ", 1)[1].split("), sensitivity.png")[0]
    regions = tomllib.loads(f"regions = {suggestion}")["regions"]
    assert regions and set(regions.values()) <= {"block", "base"}
    chosen = (tmp_path / "runs/design/chosen_points.csv").read_text()
    assert "None" not in chosen and "null" not in suggestion
    labels = [line.split(",")[0] for line in chosen.splitlines()[2:]]
    assert set(labels) & set(points)                      # planned points chosen keep their labels
    assert json.loads((tmp_path / "runs/design/design.json").read_text())["chosen"]["regions"] == regions


def test_design_condenses_the_model_once(tmp_path, monkeypatch):
    """The candidates' sensitivities come from the planned points' condensation and solve
    (EmbeddedBackend.point_sensitivities), and equal those of a condensation that observes the candidates."""
    from frictionid.backends import embedded
    from frictionid.fem import problem as problem_module

    monkeypatch.setattr(embedded, "_RECENT", {})                # no condensation kept by an earlier test
    builds, rows = [], []
    build = problem_module.Problem.build.__func__
    monkeypatch.setattr(problem_module.Problem, "build",
                        classmethod(lambda cls, *a, **k: builds.append(1) or build(cls, *a, **k)))
    weighted = planning.weighted_rows
    monkeypatch.setattr(planning, "weighted_rows", lambda *args: rows.append(args) or weighted(*args))
    assert main(["design", str(_config(tmp_path)), "--points", "6"]) == 0
    assert len(builds) == 1
    backend, points, regions, quantities, stages, sigma, mu, free = rows[0]
    separate = EmbeddedBackend(backend.model, points, tuple(quantities), list(regions), keep=False)
    expected = separate.predict(mu, True).derivatives[[s - 1 for s in stages]][..., free]
    n_q = len(quantities)
    expected = (expected / np.tile(np.asarray(sigma, float), len(points))[None, :, None]).reshape(
        len(stages), len(points), n_q, -1).transpose(1, 0, 2, 3).reshape(len(points), len(stages) * n_q, -1)
    found = weighted(*rows[0])
    np.testing.assert_allclose(found, expected, rtol=0, atol=1e-8 * np.abs(expected).max())
