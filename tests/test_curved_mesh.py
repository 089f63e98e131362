"""Second-order tetrahedra on curved faces: mid-side nodes kept on the geometry where the cells stay valid
(builders/curved.py), and the facet bases of such cells (fem/space.py's inverse map started inside the cell)."""

import math

import gmsh
import meshio
import numpy as np
import pytest
import skfem
from skfem.io.meshio import from_meshio

from frictionid.builders.curved import DET_RANGE, EDGES, SAGITTA, curved_where_valid, determinant_ratios
from frictionid.builders.gmsh_mesh import gmsh_session, mesh_from_gmsh
from frictionid.fem.space import Space, _FacetMapping

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


def test_mid_side_nodes_kept_where_valid_and_put_back_elsewhere():
    cells = np.arange(10)[None]
    mild = straight()
    mild[9] += 0.05 * np.array([0.0, 1, 1]) / math.sqrt(2)        # edge (2, 3), length sqrt(2): well within SAGITTA
    kept, n = curved_where_valid(mild, cells)
    assert n == 0 and np.array_equal(kept, mild)
    far = straight()
    far[5] += (SAGITTA + 0.05) * math.sqrt(2) * np.array([1.0, 1, 0]) / math.sqrt(2)   # edge (1, 2) beyond SAGITTA
    back, n = curved_where_valid(far, cells)
    assert n == 1 and np.allclose(back, straight())
    folded = straight()
    folded[4] += [0.0, 0.25, 0.0]                    # edge (0, 1) of 1 mm: within SAGITTA, but the cell folds
    assert determinant_ratios(folded, cells).min() < DET_RANGE[0]
    back, n = curved_where_valid(folded, cells)
    assert n == 6 and np.allclose(back, straight())


def test_facet_basis_of_a_curved_cell_whose_inverse_map_needs_a_start_inside():
    mesh = from_meshio(meshio.Mesh(FOLDING, [("tetra10", np.arange(10)[None])]))
    element = skfem.ElementTetP2()
    with pytest.raises(Exception, match="Newton"):
        skfem.FacetBasis(mesh, element, mapping=skfem.MappingIsoparametric(mesh, mesh.elem(), mesh.bndelem))
    mapping = _FacetMapping(mesh, mesh.elem(), mesh.bndelem)
    basis = skfem.FacetBasis(mesh, element, mapping=mapping)
    x = mapping.G(basis.X, find=basis.find)                  # the faces' quadrature points, mapped
    assert np.allclose(mapping.F(mapping.invF(x, tind=basis.tind), basis.tind), x, atol=1e-9)


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
