"""Problem: observations at points and the full field agree with the condensed operators; bad input."""

import numpy as np
import pytest

from frictionid.builders.block import block_model_2d
from frictionid.errors import InputError, SolverError
from frictionid.fem.points import point_operator
from frictionid.fem.problem import Problem
from frictionid.model import ContactInterface, Material, Model, Pressure, Stage, Support, SurfaceForce
from helpers import central_difference

QUANTITIES = ("ux", "uy", "exx", "eyy", "exy")


@pytest.fixture(scope="module")
def observed():
    model = block_model_2d("plane_strain", pull=0.1, height=4.0, mesh_size=1.0)
    points = np.array([[-4.0, 1.0], [0.5, 3.5], [2.0, -1.0], [-15.0, -4.0]])
    regions = ["block", "block", "base", None]
    problem = Problem.build(model, points=points, quantities=QUANTITIES, regions=regions)
    return problem, problem.solve([0.2, 0.3], sensitivities=True), points, regions


def test_observations_equal_the_point_operator_on_the_reconstructed_field(observed):
    problem, solution, points, regions = observed
    rows = point_operator(problem.space, points, QUANTITIES, regions)
    for increment in (0, 5, -1):
        u = problem.displacement(solution, increment).ravel()
        np.testing.assert_allclose(rows @ u, solution.observations[increment], rtol=1e-9,
                                   atol=1e-9 * np.abs(solution.observations).max())
    assert solution.observation_labels[:2] == ("P0.ux", "P0.uy")


def test_the_models_reaction_labels_are_the_solvers(observed):
    """Model.reaction_labels (which the CalculiX backend and the machine force use) name the embedded solver's
    reaction sums in its order: the supports' components, then the driven one."""
    problem, solution, _, _ = observed
    assert problem.model.reaction_labels == solution.reaction_labels == ("base_bottom.x", "base_bottom.y",
                                                                        "block_top.x")


def test_reconstructed_field_meets_the_supports_and_the_pull(observed):
    problem, solution, _, _ = observed
    u = problem.displacement(solution)
    mesh = problem.model.mesh
    np.testing.assert_allclose(u[mesh.boundary_nodes("base_bottom")], 0.0, atol=1e-14)
    np.testing.assert_allclose(u[mesh.boundary_nodes("block_top"), 0], 0.1, rtol=1e-12)


def test_observation_sensitivities_match_central_differences(observed):
    problem, solution, _, _ = observed
    mu, h = np.array([0.2, 0.3]), 1e-6
    central = central_difference(lambda m: problem.solve(m).observations, mu, h)
    for zone in range(2):
        np.testing.assert_allclose(solution.d_observations[:, :, zone], central[..., zone], rtol=1e-6,
                                   atol=1e-6 * np.abs(central[..., zone]).max())


def _block(**changes):
    model = block_model_2d("plane_strain", mesh_size=2.0)
    fields = dict(mesh=model.mesh, kind=model.kind, materials=model.materials, supports=model.supports,
                  loads=model.loads, stages=model.stages, interfaces=model.interfaces)
    fields.update(changes)
    return Model(**fields)


def test_a_boundary_the_mesh_does_not_have_is_named():
    with pytest.raises(InputError, match="no boundary named 'plate_top'.*base_top"):
        _block(interfaces=(ContactInterface("i", ("A", "B"), "plate_top"),))


def test_overlapping_zones_are_refused():
    with pytest.raises(InputError, match="zones 'A' and 'A2' overlap"):
        model = block_model_2d("plane_strain", mesh_size=2.0)
        boundaries = dict(model.mesh.boundaries, A2=model.mesh.boundary("A"))
        mesh = type(model.mesh)(model.mesh.points, model.mesh.cell_type, model.mesh.cells, model.mesh.regions,
                                boundaries)
        _block(mesh=mesh, interfaces=(ContactInterface("i", ("A", "B", "A2"), "base_top"),))


def test_a_region_without_material_is_named():
    with pytest.raises(InputError, match=r"region\(s\) \['base'\] have no material"):
        _block(materials={"block": Material(71000.0, 0.33)})


def test_unknown_zone_and_negative_coefficient_are_refused():
    problem = Problem.build(_block())
    with pytest.raises(InputError, match=r"unknown zone\(s\) \['C'\]"):
        problem.solve({"A": 0.1, "B": 0.1, "C": 0.2})
    with pytest.raises(InputError, match="non-negative"):
        problem.solve([0.1, -0.1])


@pytest.mark.parametrize("mu, message", [({"A": 0.1, "B": 0.1, "C": 0.2}, r"unknown zone\(s\) \['C'\]"),
                                         ({"A": 0.1}, r"no coefficient for zone\(s\) \['B'\]"),
                                         ([0.1, -0.1], "2 finite non-negative coefficients"),
                                         ([0.1, float("nan")], "finite non-negative"), ([0.1], "need 2 ")])
def test_the_models_coefficient_check_refuses_what_a_solver_cannot_take(mu, message):
    """Model.coefficients, the check the CalculiX backend uses, refuses what the embedded solver refuses."""
    model = _block()
    for check in (model.coefficients, Problem.build(model).solve):
        with pytest.raises(InputError, match=message):
            check(mu)


def test_a_body_pulled_off_its_contact_reports_the_increment():
    """Lifting the block with a force leaves it held by nothing: no increment can converge."""
    model = _block(loads=(SurfaceForce("block_top", 1, (50.0,)),), stages=(Stage("lift", 2),),
                   supports=(Support("base_bottom", (0, 1)),))
    with pytest.raises(SolverError, match=r"did not converge in stage 1 \(lift\), increment 1: residual"):
        Problem.build(model).solve([0.2, 0.2])


def test_a_model_without_contact_is_plain_elasticity():
    """Block held at its top, base loaded by 20 MPa on its 40 mm top: the base's support carries 800 N/mm."""
    model = _block(interfaces=(), supports=(Support("base_bottom", (0, 1)), Support("block_top", (0, 1))),
                   loads=(Pressure("base_top", (20.0,)),), stages=(Stage("load", 1),))
    solution = Problem.build(model).solve([], sensitivities=True)
    reactions = dict(zip(solution.reaction_labels, solution.reactions[-1]))
    assert reactions["base_bottom.y"] == pytest.approx(800.0, rel=1e-10)
    assert reactions["block_top.y"] == pytest.approx(0.0, abs=1e-9)
    assert solution.lam.shape == (1, 0, 2)


def test_reprs_are_one_line_summaries(block2d):
    """print(model / problem / solution) says what it is in a line, not megabytes of arrays."""
    model = block2d
    problem = Problem.build(model)
    solution = problem.solve({"A": 0.2, "B": 0.3}, sensitivities=True)
    for obj, start in [(model.mesh, "Mesh("), (model, "Model(plane_strain, "), (problem, "Problem(Model("),
                       (solution, "Solution(A=0.2, B=0.3; 11 increments, ")]:
        text = repr(obj)
        assert text.startswith(start) and "\n" not in text and len(text) < 300, text
