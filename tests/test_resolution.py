"""Resolution before fitting: predicted standard errors, unresolved zones, and the observations that resolve them."""

import json
import re

import numpy as np
import pytest

from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.block import block_model_2d
from frictionid.cli import main
from frictionid.inverse.evaluator import Evaluator
from frictionid.inverse.observations import Observations
from frictionid.inverse.parameters import Parameters
from frictionid.inverse.resolution import predicted_stderr, resolution, suggest
from frictionid.inverse.prefit import candidate_points, prefit


def test_predicted_stderr_is_the_textbook_covariance_diagonal():
    J = np.array([[1.0, 0.5], [0.0, 2.0], [1.0, 1.0]])
    expected = np.sqrt(np.diag(np.linalg.inv(J.T @ J)))
    np.testing.assert_allclose(predicted_stderr(J.T @ J), expected, rtol=1e-12)


def test_a_zone_no_row_sees_and_two_indistinguishable_zones_are_not_seen():
    blind = np.array([[1.0, 0.0], [2.0, 0.0]])
    assert predicted_stderr(blind.T @ blind)[0] == pytest.approx(1 / np.sqrt(5))
    assert np.isinf(predicted_stderr(blind.T @ blind)[1])
    twins = np.array([[1.0, 1.0, 0.0], [2.0, 2.0, 0.0], [0.0, 0.0, 3.0]])
    stderr = predicted_stderr(twins.T @ twins)
    assert np.isinf(stderr[:2]).all() and stderr[2] == pytest.approx(1 / 3)


def test_a_well_seen_zone_with_a_trace_in_an_unseen_direction_keeps_its_standard_error():
    """Seven zones whose data see every direction but one, the difference of zones 1 and 2 (singular value 1e-7
    of the largest, eigenvalue 1e-14: unseen), in which zone 7 has a trace of 1e-6 (as the nut bearing next to
    six thread zones in the bolt's tightening test): zones 1 and 2 are not seen, zone 7 keeps the standard error
    of the seen directions (its trace would add 1e-12 / 1e-12 of 1 / top to its variance: less than it has)."""
    rng = np.random.default_rng(7)
    null = np.zeros(7)
    null[[0, 1, 6]] = 1.0, -1.0, 1e-6
    basis, _ = np.linalg.qr(np.column_stack([null, rng.normal(size=(7, 6))]))
    singular = np.array([1e-7, 0.3, 0.5, 0.7, 0.9, 1.0, 0.1])
    J = np.linalg.qr(rng.normal(size=(20, 7)))[0] @ np.diag(singular) @ basis.T
    information = J.T @ J
    stderr = predicted_stderr(information)
    assert np.isinf(stderr[:2]).all() and np.isfinite(stderr[2:]).all()
    seen = np.sqrt(np.diag(np.linalg.pinv(information, rcond=1e-12, hermitian=True)))
    np.testing.assert_allclose(stderr[2:], seen[2:], rtol=1e-6)


def test_resolution_flags_and_correlation():
    J = np.array([[10.0, 9.9], [10.0, 10.1], [0.0, 0.0]])       # two nearly equal columns: strongly correlated
    found = resolution(J, ("A", "B"), tolerance=0.05)
    assert found.unresolved_names == ("A", "B")
    assert found.correlation[0, 1] == pytest.approx(-1.0, abs=1e-3)
    assert resolution(100 * np.eye(2), ("A", "B"), 0.05).resolved.all()


def test_suggest_picks_the_row_that_sees_the_unresolved_zone_and_stops_when_resolved():
    J = np.array([[100.0, 0.0, 0.0], [0.0, 0.0, 100.0]])           # zone B unseen
    candidates = [("sees A", [[50.0, 0.0, 0.0]]), ("sees nothing", [[0.0, 0.0, 0.0]]),
                  ("sees B weakly", [[0.0, 10.0, 0.0]]), ("sees B", [[0.0, 100.0, 0.0]])]
    chosen = suggest(J, candidates, tolerance=0.02)
    assert [c.label for c in chosen] == ["sees B"]
    assert chosen[0].stderr[1] == pytest.approx(0.01)
    assert suggest(np.eye(3) * 100, candidates, tolerance=0.02) == []
    assert suggest(J, [("sees nothing", [[0.0, 0.0, 0.0]])], tolerance=0.02) == []


def test_surface_nodes_lie_on_the_region_outline(block2d):
    mesh = block2d.mesh
    xy = mesh.points[mesh.surface_nodes("block")]
    on_outline = (np.isclose(np.abs(xy[:, 0]), 5.0) | np.isclose(xy[:, 1], 0.0) | np.isclose(xy[:, 1], 10.0))
    assert on_outline.all() and len(xy) >= 4 * 5


@pytest.fixture(scope="module")
def block():
    return block_model_2d(mesh_size=1.0, n_zones=3)


def _planned(model, points, quantities=("ux", "uy"), sigma=5e-4, stage=1, regions=None):
    n = len(points) * len(quantities)
    regions = tuple(regions or ["block"] * len(points))
    obs = Observations(points=np.asarray(points, float), point_regions=regions, quantities=quantities,
                       row=np.arange(n), stage=np.full(n, stage), y=np.zeros(n), sigma=np.full(n, sigma),
                       labels=tuple(map(str, range(n))), noise_known=True)
    params = Parameters.from_config(model.zone_names, {z: 0.1 for z in model.zone_names})
    return Evaluator(EmbeddedBackend(model, obs.points, quantities, obs.point_regions), obs, params), obs


def test_candidates_avoid_hidden_contact_surfaces(block):
    points, regions = candidate_points(block, observed=np.array([[-5.0, 2.0]]), n_max=80)
    assert set(regions) == {"block", "base"} and len(points) <= 80
    block_bottom = np.isclose(points[:, 1], 0.0) & (np.abs(points[:, 0]) < 5 - 1e-9)      # the contact zones
    assert not block_bottom.any()
    beside, _ = candidate_points(block, observed=np.array([[-7.0, 0.0]]), n_max=800)   # on the visible base top
    under_block = np.isclose(beside[:, 1], 0.0) & (np.abs(beside[:, 0]) < 5 - 1e-9)
    assert not under_block.any() and np.any(np.isclose(beside[:, 1], 0.0) & (np.abs(beside[:, 0]) > 5.5))
    on_contact, _ = candidate_points(block, observed=np.array([[1.0, 0.0]]), n_max=800)
    assert np.any(np.isclose(on_contact[:, 1], 0.0) & (np.abs(on_contact[:, 0]) < 5 - 1e-9))


def test_prefit_names_unresolved_zones_and_its_suggestions_lower_their_errors_as_claimed(block):
    evaluator, obs = _planned(block, [[-5.0, 2.0], [-5.0, 3.0]])
    report = prefit(evaluator, block, tolerance=0.05, max_additions=5, backend_factory=EmbeddedBackend)
    assert report.resolution.unresolved_names, "two points on one side face should not resolve three zones"
    steps = np.array([report.resolution.stderr] + [a.stderr for a in report.additions])
    assert len(steps) == 6 and np.all(np.diff(steps, axis=0) <= 1e-12) and np.all(steps[-1] < 0.5 * steps[0])
    # check the claim independently: re-plan with the suggested points and compute the Jacobian afresh
    chosen = [re.search(r"at \(([^)]*)\) in (\w+), stage (\d)", a.label).groups() for a in report.additions]
    assert all(stage == "2" for *_, stage in chosen)
    extra = [list(map(float, where.split(","))) for where, *_ in chosen]
    replanned, _ = _planned(block, [[-5.0, 2.0], [-5.0, 3.0]] + extra, regions=["block"] * 2 + [r for _, r, _ in chosen])
    J = replanned.jacobian(replanned.params.x0)
    np.testing.assert_allclose(predicted_stderr(J.T @ J), report.additions[-1].stderr, rtol=1e-6)


def test_identify_prints_and_stores_the_resolution(tmp_path, capsys):
    (tmp_path / "points.csv").write_text("point,x,y,z,stage,uy\nP1,-5.0,0.5,0.0,2,0.0\nP2,5.0,0.5,0.0,2,0.0\n")
    model = '[model]\nbuilder = "block2d"\nmesh_size = 1.0\nheight = 4.0\nn_zones = 3\n'
    truth = tmp_path / "truth.toml"
    truth.write_text(model + '[friction]\nzones = { A = 0.3, B = 0.2, C = 0.4 }\n[data]\nfile = "points.csv"\n'
                     'observables = ["uy"]\nstages = [2]\nregions = { "*" = "block" }\n')
    assert main(["simulate", str(truth), "--out", str(tmp_path / "measured.csv")]) == 0
    config = tmp_path / "fit.toml"
    config.write_text(model + '[friction]\nzones = { A = 0.1, B = 0.1, C = 0.1 }\n[data]\nfile = "measured.csv"\n'
                      'observables = ["uy"]\nstages = [2]\nnoise = { u = 0.0005 }\nregions = { "*" = "block" }\n'
                      '[identify]\nsuggestions = 2\n[run]\ndir = "run"\n')
    assert main(["identify", str(config)]) == 0
    out = capsys.readouterr().out
    assert "[[Resolution before fitting]]" in out and "warning: the data cannot resolve zone(s)" in out
    assert out.index("[[Resolution before fitting]]") < out.index("iter   0")
    result = json.loads((tmp_path / "run/result.json").read_text())
    planned = result["identifiability"]["prefit"]
    assert not all(planned["resolved"].values()) and 1 <= len(planned["suggestions"]) <= 2
    for name, ok in planned["resolved"].items():
        if not ok:
            assert not result["parameters"][name]["identifiable"]


def test_bad_resolution_settings_exit_2(tmp_path, capsys):
    (tmp_path / "m.csv").write_text("point,x,y,z,stage,uy\nP1,-5.0,0.5,0.0,2,0.0\n")
    config = tmp_path / "c.toml"
    config.write_text('[model]\nbuilder = "block2d"\n[friction]\nzones = { A = 0.1, B = 0.1, C = 0.1, D = 0.1 }\n'
                      '[data]\nfile = "m.csv"\nobservables = ["uy"]\nstages = [2]\n[identify]\nresolution = 0\n'
                      '[run]\ndir = "run"\n')
    assert main(["identify", str(config)]) == 2
    assert "identify.resolution must be > 0" in capsys.readouterr().err
