"""Second-order tetrahedra on curved faces: mid-side nodes kept on the geometry where the cells stay valid
(builders/curved.py), and the facet bases of such cells (fem/space.py's inverse map started inside the cell)."""

import math

from skfem.quadrature import get_quadrature
from skfem.refdom import RefTet

import gmsh
import meshio
import numpy as np
import pytest
import skfem
from skfem.io.meshio import from_meshio

from frictionid.builders.curved import EDGES, SAGITTA, curved_where_valid, determinant_ratios, jacobian_bounds
from frictionid.builders.gmsh_mesh import gmsh_session, mesh_from_gmsh
from frictionid.fem.space import INTORDER, Space, _FacetMapping
from helpers import benchmark

CORNERS = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
#: a valid curved tetra10 (det J / straight det in [0.07, 3]) on whose faces scikit-fem's inverse map, started at 0.5
#: in every reference coordinate (outside the tetrahedron), does not converge
FOLDING = np.array([[0.4722, -1.8321, -0.1273], [0.2055, 0.1472, -0.4812], [-1.6638, 0.549, 0.129],
                    [-0.0213, -1.7254, 0.6663], [0.7659, -0.8746, -0.2569], [-0.9699, 0.6256, -0.4401],
                    [-0.5438, -0.614, -0.2137], [0.4066, -2.0679, 0.1299], [0.0863, -0.8734, 0.1881],
                    [-0.6538, -0.6482, 0.2871]])


def straight(corners=CORNERS):
    return np.vstack([corners, [(corners[a] + corners[b]) / 2 for a, b in EDGES]])


def test_determinant_ratios_are_one_on_straight_cells_and_see_a_fold():
    cells = np.arange(10)[None]
    assert np.allclose(determinant_ratios(straight(), cells), 1.0, atol=1e-12)
    folded = straight()
    folded[4] += [0.0, 0.6, 0.0]                     # edge (0, 1)'s mid-side node pushed across the cell
    assert determinant_ratios(folded, cells).min() < 0


def dense_ratios(points, cells, n=4000):
    """det J / straight at the corners and n random points of each cell (a sampled minimum, not a bound)."""
    inside = np.random.default_rng(1).dirichlet(np.ones(4), n)
    return determinant_ratios(points, cells, np.vstack([np.eye(4), inside]))


def test_jacobian_bounds_are_the_corners_and_bound_the_cell():
    """The Bernstein bounds of det J: equal to it at a corner where it is smallest there, below (above) every
    sampled value elsewhere, and one on a straight cell."""
    cells = np.arange(10)[None]
    assert np.allclose(jacobian_bounds(straight(), cells), 1.0, atol=1e-12)
    rng = np.random.default_rng(0)
    for _ in range(20):
        curved = straight() + np.r_[np.zeros((4, 3)), rng.uniform(-0.15, 0.15, (6, 3))]
        lower, upper = (b[0] for b in jacobian_bounds(curved, cells))
        sampled = dense_ratios(curved, cells)[0]
        assert lower <= sampled.min() + 1e-12 and upper >= sampled.max() - 1e-12
        if sampled[:4].min() == sampled.min():
            assert lower == pytest.approx(sampled.min(), abs=1e-12)


def test_mid_side_nodes_kept_where_valid_and_moved_back_where_the_cell_folds():
    cells = np.arange(10)[None]
    mild = straight()
    mild[9] += 0.05 * np.array([0.0, 1, 1]) / math.sqrt(2)        # edge (2, 3), length sqrt(2): well within SAGITTA
    kept, n = curved_where_valid(mild, cells)
    assert n == 0 and np.array_equal(kept, mild)
    far = straight()
    far[5] += (SAGITTA + 0.05) * math.sqrt(2) * np.array([1.0, 1, 0]) / math.sqrt(2)   # edge (1, 2) beyond SAGITTA
    back, n = curved_where_valid(far, cells)
    assert n == 1 and np.allclose(back, straight())
    thin = straight()
    thin[4] += [-0.2475, 0.0, 0.0]                  # along edge (0, 1): det J / straight 1 - 4 x 0.2475 at corner 0
    assert 0 < dense_ratios(thin, cells).min() < 0.02
    kept, n = curved_where_valid(thin, cells)       # valid, if barely: kept (a bound of 0.02 put it back)
    assert n == 0 and np.array_equal(kept, thin)
    folded = straight()
    folded[4] += [0.0, 0.28, 0.0]                    # edge (0, 1) of 1 mm: within SAGITTA, but the cell folds
    assert jacobian_bounds(folded, cells)[0][0] < 0 and dense_ratios(folded, cells).min() < 0
    back, n = curved_where_valid(folded, cells)      # only that node moves, towards its midpoint, far enough
    offset = back[4] - straight()[4]
    assert n == 1 and np.array_equal(back[5:], folded[5:]) and np.array_equal(back[:4], folded[:4])
    assert np.allclose(np.cross(offset, [0.0, 1, 0]), 0) and 0 <= offset[1] < 0.28
    assert jacobian_bounds(back, cells)[0][0] > 0


def test_facet_basis_of_a_curved_cell_whose_inverse_map_needs_a_start_inside():
    mesh = from_meshio(meshio.Mesh(FOLDING, [("tetra10", np.arange(10)[None])]))
    element = skfem.ElementTetP2()
    with pytest.raises(Exception, match="Newton"):
        skfem.FacetBasis(mesh, element, mapping=skfem.MappingIsoparametric(mesh, mesh.elem(), mesh.bndelem))
    mapping = _FacetMapping(mesh, mesh.elem(), mesh.bndelem)
    basis = skfem.FacetBasis(mesh, element, mapping=mapping)
    x = mapping.G(basis.X, find=basis.find)                  # the faces' quadrature points, mapped
    assert np.allclose(mapping.F(mapping.invF(x, tind=basis.tind), basis.tind), x, atol=1e-9)



#: a cell of the M6 full nut's mesh with roots at 0.1 mm (bolt3d builder, zone B where the grooves meet): a sliver
#: (corner 3 near edge (0, 1)'s midpoint) made valid by its curved mid-side nodes; the straight inverse of its face
#: (2, 0, 1)'s points lies far outside the reference cell, at (2.40, 1.22, -3.88) for one of them
SLIVER = np.array([[-2.825221407707259, 19.244097086190667, 0.0], [-2.5714457394408803, 19.201963405931714,
                    0.7376077219485109], [-2.6752404735808355, 19.157505553499465, 0.0],
                   [-2.6522945631255834, 19.203330590485937, 0.3919437330614486],
                   [-2.7050953880276443, 19.211043338327858, 0.3704374558771588],
                   [-2.6490769772992984, 19.179735207898336, 0.3724223708659796],
                   [-2.7502309406440473, 19.200801319845066, 0.0], [-2.738757985416421, 19.223713838338302,
                                                                     0.19597186653072377],
                   [-2.611870151283232, 19.202646998208827, 0.5647757275049797],
                   [-2.663767518353209, 19.1804180719927, 0.19597186653072396]])


def test_facet_basis_of_a_valid_sliver_whose_clipped_newton_stalls_at_a_corner():
    """The clipped Newton iteration holds this cell's points at a corner of the unit cube (residual 0.14 mm); from
    the same start without the clip they converge inside the reference tetrahedron, where the basis reads the
    cell's coordinate field back at its quadrature points."""
    cells = np.arange(10)[None]
    assert jacobian_bounds(SLIVER, cells)[0][0] > 0
    mesh = from_meshio(meshio.Mesh(SLIVER, [("tetra10", cells)]))
    mapping = _FacetMapping(mesh, mesh.elem(), mesh.bndelem)
    basis = skfem.FacetBasis(mesh, skfem.ElementTetP2(), mapping=mapping, intorder=5)
    x = mapping.G(basis.X, find=basis.find)
    X = mapping.invF(x, tind=basis.tind)
    assert np.allclose(mapping.F(X, basis.tind), x, atol=1e-9)
    assert X.min() > -1e-8 and X.sum(axis=0).max() < 1 + 1e-8
    scalar = skfem.FacetBasis(mesh, skfem.ElementTetP2(), mapping=mapping, intorder=5)
    for k in range(3):                                       # the cell's own coordinate field, read by the basis
        field = scalar.interpolate(scalar.project(lambda x: x[k]))
        assert np.allclose(field, scalar.global_coordinates()[k], atol=1e-9)

def cylinder_mesh(radius: float, length: float, size: float, curved: bool):
    with gmsh_session("cylinder"):
        gmsh.model.occ.addCylinder(0, 0, 0, 0, 0, length, radius)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(3, [1], name="bar")
        gmsh.model.addPhysicalGroup(2, [s for _, s in gmsh.model.getEntities(2)], name="skin")
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.MeshSizeMin", size)
        gmsh.model.mesh.generate(3)
        gmsh.option.setNumber("Mesh.SecondOrderLinear", 0 if curved else 1)
        gmsh.model.mesh.setOrder(2)
        mesh = mesh_from_gmsh("cylinder")
    if curved:
        points, _ = curved_where_valid(mesh.points, mesh.cells)
        mesh = type(mesh)(points=points, cell_type=mesh.cell_type, cells=mesh.cells, regions=dict(mesh.regions),
                          boundaries=dict(mesh.boundaries))
    return mesh


def test_a_coarse_curved_cylinder_keeps_its_volume_and_skin():
    """Mesh size equal to the radius (the 3-D bolt's shank): straight-sided tetrahedra lose several per cent of
    the volume, curved ones keep it within 1 %; the skin's facet basis builds and integrates to its area."""
    r, length = 3.0, 6.0
    exact_volume, exact_skin = math.pi * r ** 2 * length, 2 * math.pi * r * (r + length)
    volumes = {}
    for curved in (False, True):
        mesh = cylinder_mesh(r, length, r, curved)
        space = Space.build(mesh, "3d")
        volumes[curved] = float(space.scalar.dx.sum())
        skin = space.facet_basis("skin", vector=False)
        area = float(skin.dx.sum())
        if curved:
            assert area == pytest.approx(exact_skin, rel=0.01)
    assert volumes[False] < 0.97 * exact_volume
    assert volumes[True] == pytest.approx(exact_volume, rel=0.01)


#: the M6 full nut of tests/test_bolt3d_verification.py at coarse sizes (roots 0.3 mm, no head_size), at mesh_size 2
#: and at roots 0.125 mm: meshes with cells whose curved faces leave det J small at a corner (mesh_size 2) or fold
#: it (both)
M6 = {"size": "M6", "model": "3d", "length": 24.0, "thread_length": 9.5, "n_axial": 2, "flank_size": 1.0,
      "contact_size": 3.0, "root_size": 0.3, "mesh_size": 4.0, "forces": [1500.0], "n_increments": 1,
      "cutout": False, "jaws": False, "nut_mesh": "conforming", "root_refinement": "engaged"}


@pytest.mark.slow
@pytest.mark.parametrize("change, tolerance", [({"mesh_size": 2.0}, 0.002), ({"root_size": 0.125}, 0.02)])
def test_bolt_meshes_keep_valid_cells_and_the_shank_cylinder(change, tolerance):
    """Every cell of the 3-D M6 bolt-nut mesh has det J > 0 in the whole cell (its Bernstein lower bound), so at
    its nodes and at the product's quadrature points; the shank between y 3 and 9.8 mm holds its cylinder's volume
    (benchmarks/shank_section.py's measure, 24^3 points per cell). Measured -0.09 % at mesh_size 2 (every lateral
    mid-side node there on the circle but three, moved 0.06-0.10 mm in) and -1.37 % at roots 0.125 mm (two cells
    with an edge across the section fold when curved: three lateral nodes moved 0.12-0.35 mm in); straightening
    every mid-side node of a rejected cell, with det J >= 0.02 of the straight cell's asked at 15 points, gave
    -3.30 % and -4.36 %."""
    from frictionid.builders.bolt import bolt_model
    mesh = bolt_model(**{**M6, **change}).mesh
    lower, _ = jacobian_bounds(mesh.points, mesh.cells)
    q, _ = get_quadrature(RefTet, INTORDER["tetra10"])
    at_points = determinant_ratios(mesh.points, mesh.cells, np.vstack([np.eye(4), np.c_[1 - q.sum(0), q.T]]))
    assert lower.min() > 0 and at_points.min() >= lower.min()
    measure = benchmark("shank_section")
    cells, radius = measure.shank_cells(mesh, 3.0, 9.8)
    shank = measure.shank_measures(mesh.points, cells, 3.0, 9.8, radius, 24)
    assert shank["volume"] == pytest.approx(shank["bar"], rel=tolerance)
