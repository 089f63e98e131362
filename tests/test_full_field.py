"""Full fields (issue 15 item 4): many observed points condensed through the dofs they touch, the same values as
the rows themselves; the fast reader path."""

import numpy as np
import pytest

from frictionid.builders.block import block_model, block_model_2d
from frictionid.fem.points import point_operator
from frictionid.fem.problem import Problem, compressed
from frictionid.fem.solution import ExpandedRows
from frictionid.fem.space import Space


def _face_points(n_side: int) -> np.ndarray:
    x, z = np.meshgrid(np.linspace(-4.9, 4.9, n_side), np.linspace(0.1, 9.9, n_side))
    return np.column_stack([x.ravel(), np.full(x.size, -5.0), z.ravel()])


@pytest.mark.parametrize("build, points, quantities, regions", [
    (lambda: block_model(mesh_size=5.0, n_pull=2), _face_points(15), ("ux", "uy", "uz", "exx", "ezz", "exz"),
     "block"),
    (lambda: block_model_2d(mesh_size=2.0, n_pull=2),
     np.column_stack([np.linspace(-4.9, 4.9, 300), np.tile(np.linspace(0.1, 9.9, 30), 10)]),
     ("ux", "uy", "exx", "exy"), "block"),
])
def test_condensing_the_touched_dofs_gives_the_rows_values(build, points, quantities, regions):
    model = build()
    regions = [regions] * len(points)
    full = Problem.build(model, points=points, quantities=quantities, regions=regions, compress=False)
    kept = Problem.build(model, points=points, quantities=quantities, regions=regions)
    assert full.expand is None and kept.expand is not None
    assert kept.expand.shape == (len(points) * len(quantities), kept.condensed.obs_ops.on_lam.shape[0])
    assert kept.expand.shape[1] < kept.expand.shape[0] / 3          # far fewer condensed rows than observations
    mu = np.linspace(0.2, 0.4, len(model.zone_names))
    a, b = full.solve(mu, sensitivities=True), kept.solve(mu, sensitivities=True)
    scale = np.abs(a.observations).max()
    assert np.abs(np.asarray(b.observations) - a.observations).max() <= 1e-10 * scale
    ends = [a.stage_end(s) for s in range(model.n_stages)]
    assert np.abs(b.observations[ends] - a.observations[ends]).max() <= 1e-10 * scale
    d_scale = np.abs(a.d_observations).max()
    assert np.abs(b.d_observations[ends] - a.d_observations[ends]).max() <= 1e-10 * d_scale
    assert np.abs(np.asarray(b.d_observations) - a.d_observations).max() <= 1e-10 * d_scale


def test_expanded_rows_index_like_the_array():
    rng = np.random.default_rng(0)
    operator = point_operator(Space.build(block_model_2d(mesh_size=2.0).mesh, "plane_strain"),
                              np.column_stack([np.linspace(-4, 4, 50), np.full(50, 5.0)]), ("ux", "eyy"))
    select, expand = compressed(operator)
    assert select.shape[0] == expand.shape[1] < operator.shape[0]
    kept = rng.normal(size=(4, expand.shape[1], 3))
    rows, dense = ExpandedRows(kept, expand), np.stack([expand @ k for k in kept])
    assert rows.shape == dense.shape and len(rows) == 4
    for index in ([1, 3], 2, slice(1, 3), (2, 5), ([0, 3], slice(None), 1)):
        np.testing.assert_allclose(rows[index], dense[index], rtol=1e-14, atol=0)
    np.testing.assert_allclose(np.asarray(rows), dense, rtol=1e-14, atol=0)
    assert compressed(operator[:5])[1] is None                      # few rows: the rows themselves


def test_fast_column_reading_equals_cell_by_cell(tmp_path):
    from frictionid.data import measurements as reader

    rng = np.random.default_rng(3)
    values = [float(v) for v in rng.normal(size=200) * 10.0 ** rng.integers(-9, 4, 200)]
    lines = ["point,x,y,z,stage,uy,sigma_uy"] + [f"P{k},{k * 0.1!r},-5,1.5,2,{v!r},{0.5 + k % 3}"
                                                 for k, v in enumerate(values)]
    lines[7] = lines[7].replace(f",{values[6]!r},", ",,")                 # an empty cell: the cell-by-cell path
    path = tmp_path / "m.csv"
    path.write_text("\n".join(lines) + "\n")
    m = reader.read_measurements(path)
    expected = np.array(values)
    expected[6] = np.nan
    np.testing.assert_array_equal(m.values["uy"], expected)
    np.testing.assert_array_equal(m.coordinates[:, 0], [float(f"{k * 0.1!r}") for k in range(200)])
    np.testing.assert_array_equal(m.sigma["uy"], [0.5 + k % 3 for k in range(200)])


def test_plain_table_reads_like_row_by_row(tmp_path):
    """A plain table (no comment, blank line, quote or white space after the header) is split in one pass; the
    same file with a blank line (row by row) reads equal, and the whole-table path names a bad line as the row
    by row one does (width, a cell that is no number, a duplicated point, two forces at one stage)."""
    from frictionid.data import measurements as reader
    from frictionid.errors import InputError

    rng = np.random.default_rng(7)
    header = "point,stage,x,y,z,force,ux,uy,sigma_uy"
    rows = [f"P{k % 40},{1 + k // 40},{x!r},-5.0,{z!r},{100.0 * (1 + k // 40)!r},{u!r},{v!r},{s!r}"
            for k, (x, z, u, v, s) in enumerate(rng.uniform(0.1, 1.0, (120, 5)).tolist())]
    plain, spaced = tmp_path / "plain.csv", tmp_path / "spaced.csv"
    plain.write_text("# units\n" + header + "\n" + "\n".join(rows) + "\n")
    spaced.write_text("# units\n" + header + "\n" + "\n".join(rows[:50] + [""] + rows[50:]) + "\n")
    a, b = reader.read_measurements(plain), reader.read_measurements(spaced)
    assert a == b and a.n_rows == 120 and a.stages == (1, 2, 3)
    table = reader._plain_columns(plain.read_text().splitlines()[2:], 9)[0]              # the one-pass path ran
    assert table is not None and reader._plain_columns(spaced.read_text().splitlines()[2:], 9)[0] is None
    columns = {name: k for k, name in enumerate(header.split(","))}
    numbers = reader._numbers(table, columns)                                           # numpy's text reader
    assert set(numbers) == set(columns) - {"point", "stage"} and table.few(0) == table[0] == list(a.points)
    for name, k in columns.items():
        if name in numbers:
            np.testing.assert_array_equal(numbers[name], [float(r.split(",")[k]) for r in rows])
    np.testing.assert_array_equal(a.values["uy"], [float(r.split(",")[7]) for r in rows])
    np.testing.assert_array_equal(a.stage, [1 + k // 40 for k in range(120)])
    for k, (old, bad, message) in enumerate([
            (rows[10], rows[10] + ",1.0", r"plain\d?.csv:13: 10 fields, but the header \(line 2\) has 9"),
            (rows[10], rows[10].replace(",-5.0,", ",-5.0.1,"), r":13: column 'y': '-5.0.1' is not a number"),
            (rows[10], rows[10].replace(",-5.0,", ",-5_0,"), r":13: column 'y': '-5_0' is not a number"),
            (rows[11], rows[10], r":14: column 'point': point 'P10' at stage 1 is already on line 13"),
            (rows[45], rows[45].replace(",200.0,", ",201.0,"), r":48: column 'force': 201.0 N differs from 200.0 N "
                                                               r"of stage 2 on line 43")]):
        path = tmp_path / f"plain{k}.csv"
        path.write_text("# units\n" + header + "\n" + "\n".join(rows).replace(old, bad, 1) + "\n")
        with pytest.raises(InputError, match=message):
            reader.read_measurements(path)


def _grid(spacing: float, n: int) -> np.ndarray:
    x, y = np.meshgrid(np.arange(n) * spacing, np.arange(n) * spacing)
    return np.column_stack([x.ravel(), y.ravel()])


def test_window_gradient_leaves_a_linear_field_unchanged():
    from frictionid.fem.points import window_gradients

    rng = np.random.default_rng(5)
    points = _grid(0.1, 15) + rng.normal(0.0, 0.01, (225, 2))          # irregular, edges and corners included
    gradient, spanned = window_gradients(points, 0.45)
    g, c = np.array([0.3, -1.7]), 2.5
    for a in range(2):
        np.testing.assert_allclose(gradient[a] @ (c + points @ g), g[a], rtol=0, atol=1e-12)
    assert spanned.all()


def test_window_gradient_of_a_cubic_is_the_analytic_windowed_value():
    """f = x^3 (its derivative 3 x^2 quadratic) on a grid of spacing s, window 2 m s: inside, the fitted slope is
    3 x_i^2 + s^2 sum k^4 / sum k^2 (k = -m..m), not the point value 3 x_i^2 (tolerance: round-off)."""
    from frictionid.fem.points import window_gradients

    s, m = 0.05, 3
    points = _grid(s, 21)
    gradient, _ = window_gradients(points, 2 * m * s)
    slope = gradient[0] @ points[:, 0] ** 3
    k = np.arange(-m, m + 1)
    inside = np.all((points >= m * s - 1e-9) & (points <= (20 - m) * s + 1e-9), axis=1)
    expected = 3 * points[:, 0] ** 2 + s ** 2 * np.sum(k ** 4.0) / np.sum(k ** 2.0)
    np.testing.assert_allclose(slope[inside], expected[inside], rtol=1e-11)
    assert np.abs(slope - 3 * points[:, 0] ** 2)[inside].min() > 0.01           # it differs from the point value
    np.testing.assert_allclose(gradient[1] @ points[:, 0] ** 3, 0.0, atol=1e-11)


@pytest.mark.parametrize("kind", ["plane_strain", "3d"])
def test_windowed_strains_of_a_linear_displacement_are_its_strains(kind):
    from frictionid.fem.points import point_operator

    if kind == "3d":
        model = block_model(mesh_size=5.0, n_pull=1)
        points, quantities = _face_points(12), ("ux", "exx", "ezz", "exz")
    else:
        model = block_model_2d(mesh_size=2.0)
        x, y = np.meshgrid(np.linspace(-4.5, 4.5, 20), np.linspace(1.0, 9.0, 10))
        points, quantities = np.column_stack([x.ravel(), y.ravel()]), ("ux", "exx", "eyy", "exy")
    space = Space.build(model.mesh, model.kind, model.element)
    A = np.random.default_rng(2).normal(0.0, 1e-3, (space.dim, space.dim))
    u = (model.mesh.points[:, :space.dim] @ A.T + 0.01).ravel()
    strain = 0.5 * (A + A.T)
    regions = ["block"] * len(points)
    windowed = (point_operator(space, points, quantities, regions, model.materials, window=2.0) @ u)
    pointwise = (point_operator(space, points, quantities, regions, model.materials) @ u)
    expected = [points @ A[0] + 0.01] + [np.full(len(points), strain[_AX[q[1]], _AX[q[2]]]) for q in quantities[1:]]
    np.testing.assert_allclose(windowed.reshape(-1, len(quantities)), np.column_stack(expected), rtol=0, atol=1e-12)
    np.testing.assert_allclose(windowed, pointwise, rtol=0, atol=1e-12)


_AX = {"x": 0, "y": 1, "z": 2}


def test_a_window_that_cannot_give_a_strain_is_an_error():
    from frictionid.errors import InputError
    from frictionid.fem.points import point_operator

    model = block_model(mesh_size=5.0, n_pull=1)
    space = Space.build(model.mesh, model.kind, model.element)
    points = _face_points(6)
    with pytest.raises(InputError, match=r"strain_window = 1.5 mm: eyy at point 0 .* gradient along y"):
        point_operator(space, points, ["eyy"], ["block"] * len(points), model.materials, window=1.5)
    with pytest.raises(InputError, match="strain_window = 0.1 mm: exx .* 1 point"):
        point_operator(space, points, ["exx"], ["block"] * len(points), model.materials, window=0.1)
    with pytest.raises(InputError, match="positive length"):
        point_operator(space, points, ["exx"], None, model.materials, window=-1.0)


@pytest.mark.slow
def test_strain_window_reaches_the_fit(tmp_path):
    """[data] strain_window: data whose strains were windowed (w = 2 mm), fitted from the coefficients that made
    them: no misfit with the window, a large one without it; the calculix backend refuses a window."""
    from frictionid.backends import make_backend
    from frictionid.options import SolverOptions
    from frictionid.backends.embedded import EmbeddedBackend
    from frictionid.config import config_from_dict
    from frictionid.data.measurements import Measurements, write_measurements
    from frictionid.errors import InputError
    from frictionid.identification import identify_config

    options = {"builder": "block2d", "mesh_size": 2.0, "n_pull": 2}
    model = block_model_2d(mesh_size=2.0, n_pull=2)
    x, y = np.meshgrid(np.linspace(-4.5, 4.5, 10), np.linspace(0.5, 9.5, 10))
    points = np.column_stack([x.ravel(), y.ravel()])
    truth = np.array([0.25, 0.4])
    values = EmbeddedBackend(model, points, ("exx", "exy"), ["block"] * 100, keep=False,
                             window=2.0).predict(truth).values[-1]
    write_measurements(tmp_path / "m.csv", Measurements(
        points=tuple(f"P{k}" for k in range(100)), coordinates=np.column_stack([points, np.zeros(100)]),
        stage=np.full(100, 2), force=np.full(100, np.nan), values={"exx": values[0::2], "exy": values[1::2]}))
    fits = {}
    for window in (2.0, None):
        config = config_from_dict({
            "model": options, "friction": {"zones": {"A": 0.25, "B": 0.4}},
            "data": {"file": "m.csv", "observables": ["exx", "exy"], "stages": [2], "regions": {"*": "block"},
                     "noise": {"e": 1e-6}, "strain_window": window},
            "identify": {"suggestions": 0, "max_iterations": 1}, "run": {"dir": f"run{window}"}},
            need=("model", "friction", "data", "run"),
            base=tmp_path)
        fits[window] = identify_config(config, write_files=False).to_dict()
    assert fits[2.0]["objective"]["initial"] < 1e-12 and fits[None]["objective"]["initial"] > 1.0
    with pytest.raises(InputError, match="strain_window needs the embedded backend"):
        make_backend(model, points, ("exx",), solver=SolverOptions(backend="calculix"), window=2.0)


def test_point_misfit_groups_by_point_in_one_pass():
    """result.json's per-point RMS residual: the same as point by point (it was O(points x observations), hours for
    1e5 points), the machine force belonging to no point."""
    from types import SimpleNamespace

    from frictionid.inverse.statistics import point_misfit

    rng = np.random.default_rng(4)
    names = [f"P{k}" for k in range(300)]
    labels = [f"{names[k]}:{q}@{s}" for s in (1, 2) for k in rng.permutation(300)[:250] for q in ("ux", "uy")]
    labels.append("force@2")
    index = {name: k for k, name in enumerate(names)}
    point = np.array([index.get(label.rpartition(":")[0], -1) for label in labels])     # Observations.point
    obs = SimpleNamespace(point=point, point_labels=tuple(names), points=rng.normal(size=(300, 2)))
    r = rng.normal(size=len(labels))
    got = {row["point"]: row["rms"] for row in point_misfit(obs, r)}
    point_of = np.array([label.rpartition(":")[0] for label in labels])
    expected = {p: float(np.sqrt(np.mean(r[point_of == p] ** 2))) for p in names if np.any(point_of == p)}
    assert got.keys() == expected.keys()
    np.testing.assert_allclose([got[p] for p in expected], list(expected.values()), rtol=1e-13)
