"""A strain window built for the strain components each point observes (issue 31 item 2): the block's four side
faces each give their in-plane strains (x = +-5: eyy, ezz, eyz; y = +-5: exx, ezz, exz), and a fit of all four
under one window runs, instead of refusing exx at a point of face x = 5 whose window cannot span x."""

import numpy as np
import pytest

from frictionid.builders.block import block_model
from frictionid.errors import InputError
from frictionid.fem.points import StrainWindow, point_operator
from frictionid.fem.space import Space

QUANTITIES = ("exx", "eyy", "ezz", "eyz", "exz")
#: in-plane strains of a face by its normal axis
IN_PLANE = {0: ("eyy", "ezz", "eyz"), 1: ("exx", "ezz", "exz")}
WINDOW = 2.5        # [mm] circle; the face grid below is 1.125 mm, so a window holds its 8 neighbours


def _four_faces() -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 3) [mm] on the faces x = -5, x = 5, y = -5, y = 5 and the normal axis (n,) of each."""
    s, z = np.meshgrid(np.linspace(-4.5, 4.5, 9), np.linspace(0.5, 9.5, 9))
    s, z = s.ravel(), z.ravel()
    points, normal = [], []
    for axis in (0, 1):
        for side in (-5.0, 5.0):
            face = np.column_stack([s, s, z])
            face[:, axis] = side
            points.append(face)
            normal.append(np.full(len(s), axis))
    return np.concatenate(points), np.concatenate(normal)


def _observed_rows(normal: np.ndarray) -> list[int]:
    return [p * len(QUANTITIES) + QUANTITIES.index(q) for p, axis in enumerate(normal) for q in IN_PLANE[axis]]


def test_the_window_is_built_for_the_observed_strains_only():
    model = block_model(mesh_size=5.0, n_pull=1)
    space = Space.build(model.mesh, model.kind, model.element)
    points, normal = _four_faces()
    regions = ["block"] * len(points)
    with pytest.raises(InputError, match=r"exx at point \d+ .* gradient along x"):      # every row: refused
        point_operator(space, points, QUANTITIES, regions, model.materials, StrainWindow(WINDOW, "circle"))
    rows = _observed_rows(normal)
    window = StrainWindow(WINDOW, "circle").with_observed(rows)
    operator = point_operator(space, points, QUANTITIES, regions, model.materials, window)
    # a linear displacement field: every observed windowed strain is its strain, exactly
    A = np.random.default_rng(3).normal(0.0, 1e-3, (3, 3))
    u = (model.mesh.points @ A.T).ravel()
    strain = 0.5 * (A + A.T)
    axis = {"x": 0, "y": 1, "z": 2}
    expected = np.array([[strain[axis[q[1]], axis[q[2]]] for q in QUANTITIES]] * len(points)).ravel()
    np.testing.assert_allclose((operator @ u)[rows], expected[rows], rtol=0, atol=1e-12)
    # a row not observed whose window cannot give it is the strain at the point
    pointwise = point_operator(space, points, QUANTITIES, regions, model.materials)
    at_point = [p * len(QUANTITIES) for p in np.flatnonzero(normal == 0)]          # exx on the faces x = +-5
    np.testing.assert_allclose((operator @ u)[at_point], (pointwise @ u)[at_point], rtol=0, atol=1e-15)


@pytest.mark.slow
def test_a_windowed_fit_of_all_four_block_faces_runs(tmp_path):
    """Data windowed as the fit windows them (circle 2.5 mm, each face's in-plane strains), fitted from the
    coefficients that made them: the fit runs and starts at no misfit."""
    from frictionid.backends.embedded import EmbeddedBackend
    from frictionid.config import config_from_dict
    from frictionid.data.measurements import Measurements, write_measurements
    from frictionid.identification import identify_config

    options = {"builder": "block", "mesh_size": 5.0, "n_pull": 2}
    model = block_model(mesh_size=5.0, n_pull=2)
    points, normal = _four_faces()
    n = len(points)
    truth = np.array([0.35, 0.2, 0.45, 0.15])
    window = StrainWindow(WINDOW, "circle").with_observed(_observed_rows(normal))
    values = EmbeddedBackend(model, points, QUANTITIES, ["block"] * n, keep=False,
                             window=window).predict(truth).values[-1][:n * len(QUANTITIES)].reshape(n, -1)
    columns = {q: np.where([q in IN_PLANE[a] for a in normal], values[:, k], np.nan)
               for k, q in enumerate(QUANTITIES)}
    write_measurements(tmp_path / "m.csv", Measurements(
        points=tuple(f"P{k}" for k in range(n)), coordinates=points, stage=np.full(n, 2), force=np.full(n, np.nan),
        values=columns))
    config = config_from_dict({
        "model": options, "friction": {"zones": dict(zip("ABCD", truth.tolist()))},
        "data": {"file": "m.csv", "observables": list(QUANTITIES), "stages": [2], "regions": {"*": "block"},
                 "noise": {"e": 1e-6}, "strain_window": WINDOW, "strain_window_shape": "circle"},
        "identify": {"suggestions": 0, "max_iterations": 1}, "run": {"dir": "run"}},
        need=("model", "friction", "data", "run"), base=tmp_path)
    fit = identify_config(config, write_files=False).to_dict()
    assert fit["objective"]["initial"] < 1e-12
    assert fit["data"]["strain_window"]["size_mm"] == WINDOW


def test_simulate_windows_the_strains_the_data_file_gives(tmp_path):
    """`simulate` with [data] strain_window writes what a fit of the same config compares with: each face's
    in-plane strains through the window (the cells its data file gives), the others empty."""
    from frictionid.backends.embedded import EmbeddedBackend
    from frictionid.config import config_from_dict
    from frictionid.data.measurements import Measurements, read_measurements, write_measurements
    from frictionid.simulation import simulate

    points, normal = _four_faces()
    n = len(points)
    given = {q: np.where([q in IN_PLANE[a] for a in normal], 0.0, np.nan) for q in QUANTITIES}
    write_measurements(tmp_path / "points.csv", Measurements(
        points=tuple(f"P{k}" for k in range(n)), coordinates=points, stage=np.full(n, 1), force=np.full(n, np.nan),
        values=given))
    truth = [0.35, 0.2, 0.45, 0.15]
    config = config_from_dict({
        "model": {"builder": "block", "mesh_size": 5.0, "n_pull": 1}, "friction": {"zones": dict(zip("ABCD", truth))},
        "data": {"file": "points.csv", "observables": list(QUANTITIES), "regions": {"*": "block"},
                 "strain_window": WINDOW, "strain_window_shape": "circle"}, "run": {"fields": False}},
        need=("model", "friction"), base=tmp_path)
    written = read_measurements(simulate(config, tmp_path / "measured.csv"))
    window = StrainWindow(WINDOW, "circle").with_observed(_observed_rows(normal))
    expected = EmbeddedBackend(block_model(mesh_size=5.0, n_pull=1), points, QUANTITIES, ["block"] * n, keep=False,
                               window=window).predict(np.array(truth)).values[:, :n * len(QUANTITIES)]
    for stage in (1, 2):
        rows = written.stage == stage
        got = np.column_stack([written.values[q][rows] for q in QUANTITIES])
        assert np.array_equal(np.isnan(got), np.isnan(np.column_stack([given[q] for q in QUANTITIES])))
        want = expected[stage - 1].reshape(n, -1)
        seen = ~np.isnan(got)
        np.testing.assert_allclose(got[seen], want[seen], rtol=1e-9, atol=1e-12)
