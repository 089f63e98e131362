"""Point observation operators: exact reproduction of polynomial fields, hoop strain, regions, ordering, errors."""

import numpy as np
import pytest

from frictionid.builders.gmsh_mesh import gmsh_session, mesh_from_gmsh
from frictionid.errors import InputError
from frictionid.fem.points import locate, point_operator
from frictionid.fem.space import Space
from frictionid.model import Mesh

# every polynomial of the element's order is in the discrete space on straight-sided cells, so nodal
# interpolation and evaluation are exact up to round-off
EXACT = dict(rtol=0, atol=1e-10)
BOX = {2: (3.0, 2.0), 3: (3.0, 2.0, 1.5)}   # [mm]
ORDER = {"triangle": 1, "triangle6": 2, "quad": 1, "quad9": 2,
         "tetra": 1, "tetra10": 2, "hexahedron": 1, "hexahedron27": 2}
DIM = {"triangle": 2, "triangle6": 2, "quad": 2, "quad9": 2,
       "tetra": 3, "tetra10": 3, "hexahedron": 3, "hexahedron27": 3}
STRAINS = {"exx": (0, 0), "eyy": (1, 1), "ezz": (2, 2), "exy": (0, 1), "eyz": (1, 2), "exz": (0, 2)}


def box_mesh(cell_type: str, size: float = 0.6) -> Mesh:
    """A meshed box [0, BOX] (one region "body"); hexahedra structured, everything else unstructured."""
    dim = DIM[cell_type]
    with gmsh_session() as gmsh:
        tag = gmsh.model.occ.addRectangle(0, 0, 0, *BOX[2]) if dim == 2 else gmsh.model.occ.addBox(0, 0, 0, *BOX[3])
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(dim, [tag], name="body")
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        if cell_type.startswith("quad"):
            gmsh.option.setNumber("Mesh.RecombineAll", 1)
        if cell_type.startswith("hexahedron"):
            gmsh.model.mesh.setTransfiniteAutomatic(recombine=True)
        gmsh.model.mesh.generate(dim)
        if ORDER[cell_type] == 2:
            gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
            gmsh.model.mesh.setOrder(2)
        mesh = mesh_from_gmsh()
    assert mesh.cell_type == cell_type
    return mesh


def trilinear_distortion(x: np.ndarray) -> np.ndarray:
    """A global trilinear map: keeps axis-parallel edges straight, turns the bricks into general hexahedra."""
    return x + 0.08 * np.stack([x[:, 1] * x[:, 2], x[:, 0] * x[:, 2], x[:, 0] * x[:, 1]], axis=1)


def with_points(mesh: Mesh, points: np.ndarray) -> Mesh:
    return Mesh(points=points, cell_type=mesh.cell_type, cells=mesh.cells, regions=mesh.regions,
                boundaries=mesh.boundaries)


class Polynomial:
    """u_c(x) = b_c + A_c . x + x . B_c . x with random coefficients of order one (B = 0 for degree 1)."""

    def __init__(self, dim: int, degree: int, seed: int):
        rng = np.random.default_rng(seed)
        self.b = rng.uniform(-1, 1, dim)
        self.A = rng.uniform(-1, 1, (dim, dim))
        B = rng.uniform(-1, 1, (dim, dim, dim)) if degree == 2 else np.zeros((dim, dim, dim))
        self.B = (B + B.transpose(0, 2, 1)) / 2

    def value(self, x):                       # (n, dim) -> (n, dim)
        return self.b + x @ self.A.T + np.einsum("ni,cij,nj->nc", x, self.B, x)

    def gradient(self, x):                    # (n, dim) -> (n, dim, dim), [n, c, j] = du_c/dx_j
        return self.A + 2 * np.einsum("cij,nj->nci", self.B, x)

    def dofs(self, mesh: Mesh) -> np.ndarray:  # node-major, dof = dim * node + component
        return self.value(mesh.points).ravel()


def random_interior(n: int, dim: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(0.01, 0.99, (n, dim)) * np.array(BOX[dim])


def evaluate(space, points, quantities, u, regions=None) -> np.ndarray:
    """Operator applied to u, as (n_points, n_quantities)."""
    return (point_operator(space, points, quantities, regions) @ u).reshape(len(points), len(quantities))


@pytest.mark.parametrize("cell_type", sorted(ORDER))
def test_reproduces_polynomial_displacements_and_strains(cell_type):
    mesh = box_mesh(cell_type)
    dim = mesh.dim
    points = random_interior(200, dim, seed=1)
    if cell_type.startswith("hexahedron"):
        mesh, points = with_points(mesh, trilinear_distortion(mesh.points)), trilinear_distortion(points)
    field = Polynomial(dim, ORDER[cell_type], seed=2)
    space = Space.build(mesh)
    displacement = ["ux", "uy", "uz"][:dim]
    strains = [name for name, (a, b) in STRAINS.items() if max(a, b) < dim]
    got = evaluate(space, points, displacement + strains, field.dofs(mesh))
    np.testing.assert_allclose(got[:, :dim], field.value(points), **EXACT)
    gradient = field.gradient(points)
    for q, name in enumerate(strains, start=dim):
        a, b = STRAINS[name]
        np.testing.assert_allclose(got[:, q], (gradient[:, a, b] + gradient[:, b, a]) / 2, **EXACT,
                                   err_msg=name)


@pytest.mark.parametrize("cell_type", ["triangle", "triangle6", "quad9"])
def test_plane_strain_ezz_is_zero_and_out_of_plane_quantities_are_errors(cell_type):
    mesh = box_mesh(cell_type)
    space = Space.build(mesh, kind="plane_strain")
    operator = point_operator(space, random_interior(5, 2, seed=3), ["ezz", "exx"])
    assert operator[0::2].nnz == 0
    assert operator[1::2].count_nonzero() > 0
    for name in ("uz", "eyz", "exz"):
        with pytest.raises(InputError, match=f"'{name}'.*plane_strain"):
            point_operator(space, [[1.0, 1.0]], [name])


def axisymmetric_field(order: int):
    """(u_r, u_y) and (e_rr, e_yy, e_tt, e_ry) as functions of (r, y); u_r vanishes on the axis as it must."""
    a, b, c, d, e = (0.3, -0.7, 0.4, 0.9, -0.2) if order == 2 else (0.3, 0.0, 0.0, 0.9, -0.2)
    if order == 2:   # u_r = r (a + b y + c r), u_y = d r y + e r
        def displacement(r, y): return np.stack([r * (a + b * y + c * r), d * r * y + e * r], axis=1)
        def strain(r, y): return np.stack([a + b * y + 2 * c * r, d * r, a + b * y + c * r,
                                           (b * r + d * y + e) / 2], axis=1)
    else:            # u_r = a r, u_y = d y + e r
        def displacement(r, y): return np.stack([a * r, d * y + e * r], axis=1)
        def strain(r, y): return np.stack([a + 0 * r, d + 0 * r, a + 0 * r, e / 2 + 0 * r], axis=1)
    return displacement, strain


@pytest.mark.parametrize("cell_type", ["triangle", "triangle6", "quad", "quad9"])
def test_axisymmetric_strains_with_hoop_strain(cell_type):
    # x = r, y = axis: e_rr = du_r/dr, e_yy = du_y/dy, e_tt = u_r / r, e_ry = (du_r/dy + du_y/dr) / 2
    displacement, strain = axisymmetric_field(ORDER[cell_type])
    mesh = box_mesh(cell_type)
    space = Space.build(mesh, kind="axisymmetric")
    points = np.vstack([random_interior(100, 2, seed=4), [[0.0, 0.7], [0.0, 1.3]]])   # two on the axis
    got = evaluate(space, points, ["ux", "uy", "exx", "eyy", "ezz", "exy"], displacement(*mesh.points.T).ravel())
    np.testing.assert_allclose(got[:, :2], displacement(*points.T), **EXACT)
    np.testing.assert_allclose(got[:, 2:], strain(*points.T), **EXACT)   # on the axis e_tt -> du_r/dr


def test_hoop_strain_is_u_r_over_r_and_not_a_gradient():
    # u_r = 1 everywhere (no gradient at all): e_rr = 0 but e_tt = 1 / r
    mesh = box_mesh("triangle")
    u = np.zeros(2 * mesh.n_nodes)
    u[0::2] = 1.0
    space = Space.build(mesh, kind="axisymmetric")
    points = random_interior(20, 2, seed=5)
    got = evaluate(space, points, ["exx", "ezz"], u)
    np.testing.assert_allclose(got[:, 0], 0.0, **EXACT)
    np.testing.assert_allclose(got[:, 1], 1.0 / points[:, 0], **EXACT)


def test_rows_are_point_major():
    mesh = box_mesh("quad9")
    field = Polynomial(2, 2, seed=6)
    space = Space.build(mesh)
    points = np.array([[0.5, 0.5], [2.5, 1.5], [1.2, 0.3]])
    values = point_operator(space, points, ["uy", "ux"]) @ field.dofs(mesh)
    expected = field.value(points)[:, ::-1].ravel()          # uy(p0), ux(p0), uy(p1), ux(p1), ...
    np.testing.assert_allclose(values, expected, **EXACT)
    assert point_operator(space, points, ["uy", "ux"]).shape == (6, space.n_dofs)


@pytest.mark.parametrize("cell_type", ["triangle", "quad9", "tetra10", "hexahedron"])
def test_point_outside_the_mesh_names_index_and_coordinates(cell_type):
    mesh = box_mesh(cell_type, size=1.0)
    dim = mesh.dim
    points = np.vstack([random_interior(3, dim, seed=7), np.full((1, dim), -0.01)])
    space = Space.build(mesh)
    with pytest.raises(InputError, match=r"point 3 at \[-0\.01, -0\.01.*outside the mesh"):
        point_operator(space, points, ["ux"])


def test_points_on_the_mesh_boundary_are_inside():
    mesh = box_mesh("quad9")
    field = Polynomial(2, 2, seed=8)
    corners_and_edges = np.array([[0.0, 0.0], [3.0, 2.0], [3.0, 0.77], [1.31, 0.0], [0.0, 2.0]])
    got = evaluate(Space.build(mesh), corners_and_edges, ["ux", "uy"], field.dofs(mesh))
    np.testing.assert_allclose(got, field.value(corners_and_edges), **EXACT)


def touching_rectangles(cell_type: str) -> Mesh:
    """"left" [0,1]x[0,1] and "right" [1,2]x[0,1], meshed separately: separate nodes on x = 1."""
    with gmsh_session() as gmsh:
        left = gmsh.model.occ.addRectangle(0, 0, 0, 1, 1)
        right = gmsh.model.occ.addRectangle(1, 0, 0, 1, 1)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(2, [left], name="left")
        gmsh.model.addPhysicalGroup(2, [right], name="right")
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.3)
        gmsh.model.mesh.generate(2)
        if ORDER[cell_type] == 2:
            gmsh.model.mesh.setOrder(2)
        return mesh_from_gmsh()


@pytest.mark.parametrize("cell_type", ["triangle", "triangle6"])
def test_region_picks_the_body_on_a_shared_boundary(cell_type):
    mesh = touching_rectangles(cell_type)
    in_right = np.zeros(mesh.n_nodes, dtype=bool)
    in_right[mesh.cells[mesh.regions["right"]]] = True
    assert np.unique(mesh.points[in_right, 0]).min() == pytest.approx(1.0)   # right body has its own x = 1 nodes
    u = np.where(in_right[:, None], [5.0, 6.0], [1.0, 2.0]).ravel()       # rigid shifts, one per body
    space = Space.build(mesh)
    on_both = np.array([[1.0, 0.37], [1.0, 0.81], [1.0, 0.37]])
    got = evaluate(space, on_both, ["ux", "uy"], u, regions=["left", "right", "right"])
    np.testing.assert_allclose(got, [[1.0, 2.0], [5.0, 6.0], [5.0, 6.0]], **EXACT)
    cells, _ = locate(space, on_both, ["left", "right", None])
    assert list(mesh.cell_region[cells[:2]]) == [mesh.region_names.index("left"), mesh.region_names.index("right")]


def test_point_outside_its_region_is_an_error():
    mesh = touching_rectangles("triangle")
    space = Space.build(mesh)
    with pytest.raises(InputError, match=r"point 1 at \[1\.5, 0\.5\] \[mm\] is outside region 'left'"):
        point_operator(space, [[0.5, 0.5], [1.5, 0.5]], ["ux"], regions=["left", "left"])


def test_unknown_region_and_bad_input_are_errors():
    space = Space.build(touching_rectangles("triangle"))
    with pytest.raises(InputError, match="region 'bolt'"):
        point_operator(space, [[0.5, 0.5]], ["ux"], regions=["bolt"])
    with pytest.raises(InputError, match="quantity 'exy2'"):
        point_operator(space, [[0.5, 0.5]], ["exy2"])
    with pytest.raises(InputError, match=r"shape \(n, 2\)"):
        point_operator(space, [[0.5, 0.5, 0.0]], ["ux"])
    with pytest.raises(InputError, match="`regions`"):
        point_operator(space, [[0.5, 0.5]], ["ux"], regions=["left", "right"])


def test_locate_finds_every_cell_of_a_strongly_graded_mesh():
    # cells from 0.02 mm to 1 mm: a large cell next to many small ones must still be found
    with gmsh_session() as gmsh:
        tag = gmsh.model.occ.addRectangle(0, 0, 0, 10, 4)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(2, [tag], name="body")
        field = gmsh.model.mesh.field.add("MathEval")
        gmsh.model.mesh.field.setString(field, "F", "0.02 + 0.1 * x")
        gmsh.model.mesh.field.setAsBackgroundMesh(field)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        mesh = mesh_from_gmsh()
    space = Space.build(mesh)
    centroids = mesh.points[mesh.cells[:, :3]].mean(axis=1)
    cells, reference = locate(space, centroids)
    np.testing.assert_array_equal(cells, np.arange(mesh.n_cells))
    np.testing.assert_allclose(reference, 1 / 3, rtol=0, atol=1e-9)


@pytest.mark.parametrize("cell_type", ["triangle6", "quad9"])
def test_points_in_the_bulge_of_curved_boundary_cells(cell_type):
    # points between a curved (quadratic) boundary edge and its chord: inside the cell, possibly outside the
    # box of its nodes. Isoparametric cells reproduce linear fields exactly even when curved.
    with gmsh_session() as gmsh:
        disk = gmsh.model.occ.addDisk(0, 0, 0, 5, 5)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(2, [disk], name="body")
        gmsh.model.addPhysicalGroup(1, [c for _, c in gmsh.model.getBoundary([(2, disk)])], name="rim")
        gmsh.option.setNumber("Mesh.MeshSizeMax", 1.5)
        gmsh.option.setNumber("Mesh.RecombineAll", int(cell_type == "quad9"))
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        mesh = mesh_from_gmsh()
    start, end, middle = (mesh.points[mesh.boundary("rim")[:, k]] for k in range(3))
    t = np.linspace(0.05, 0.95, 7)[:, None, None]
    on_edge = (2 * (t - 0.5) * (t - 1) * start + 2 * t * (t - 0.5) * end - 4 * t * (t - 1) * middle).reshape(-1, 2)
    points = on_edge * (1 - 1e-9)                                  # a nanometre inside the disk
    field = Polynomial(2, 1, seed=9)
    got = evaluate(Space.build(mesh), points, ["ux", "uy", "exx", "eyy", "exy"], field.dofs(mesh))
    gradient = field.gradient(points)
    np.testing.assert_allclose(got[:, :2], field.value(points), **EXACT)
    np.testing.assert_allclose(got[:, 2:], np.stack([gradient[:, 0, 0], gradient[:, 1, 1],
                                                     (gradient[:, 0, 1] + gradient[:, 1, 0]) / 2], axis=1), **EXACT)
