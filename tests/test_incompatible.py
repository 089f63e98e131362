"""Hex8 with incompatible modes: patch test, cantilever bending (analytical and CalculiX C3D8I), the block model
with its sensitivities, and bad element options."""

import shutil

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from frictionid.backends.calculix.deck import ContactSettings, write_deck
from frictionid.backends.calculix.elements import element_type
from frictionid.backends.calculix.parse import read_dat, reals
from frictionid.backends.calculix.runner import JOB, remove_work, run_ccx
from frictionid.builders.block import block_model
from frictionid.errors import InputError
from frictionid.fem import incompatible
from frictionid.fem.assembly import load_channels, stiffness
from frictionid.fem.contact import SLIP, STICK
from frictionid.fem.points import point_operator
from frictionid.fem.problem import Problem
from frictionid.fem.space import Space
from frictionid.model import Material, Mesh, Model, Support, SurfaceForce
from helpers import central_difference, needs_ccx

#: cantilever [0, L] x [-b/2, b/2] x [-h/2, h/2] [mm], E [MPa], nu = 0 (no Poisson coupling at the clamp)
L, B, H, E = 10.0, 1.0, 1.0, 1000.0
INERTIA = B * H ** 3 / 12                      # [mm^4]
BEAM = Material(E, 0.0, "beam")


def brick(n: tuple[int, int, int], size=(L, B, H)) -> Mesh:
    """Structured hexahedra (meshio order) on [0, Lx] x [-Ly/2, Ly/2] x [-Lz/2, Lz/2]; region "body",
    boundaries "root" (x = 0) and "tip" (x = Lx)."""
    axes = [np.linspace(lo, lo + s, k + 1) for lo, s, k in zip((0.0, -size[1] / 2, -size[2] / 2), size, n)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    index = np.arange(len(points)).reshape(tuple(k + 1 for k in n))
    i, j, k = (a.ravel() for a in np.meshgrid(*(np.arange(m) for m in n), indexing="ij"))
    cells = np.stack([index[i + a, j + b, k + c] for a, b, c in incompatible.CORNERS.astype(int).clip(0)], axis=1)
    face = [(0, 0), (1, 0), (1, 1), (0, 1)]
    faces = {name: np.stack([index[end][a:a + n[1], b:b + n[2]].ravel() for a, b in face], axis=1)
             for name, end in (("root", 0), ("tip", -1))}
    return Mesh(points=points, cell_type="hexahedron", cells=cells, regions={"body": np.arange(len(cells))},
                boundaries=faces)


def solved(model: Model, forces: np.ndarray, prescribed: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Nodal dof vector of a linear elastic model under nodal forces and prescribed dofs."""
    space = Space.build(model.mesh, model.kind, model.element)
    K = stiffness(space, model).tocsc()
    free = np.setdiff1d(np.arange(space.n_dofs), prescribed)
    u = np.zeros(space.n_dofs)
    u[prescribed] = values
    u[free] = spla.spsolve(K[free][:, free], forces[free] - K[free][:, prescribed] @ values)
    return u


# ------------------------------------------------------------------------------------------------ element

def test_nodal_block_is_the_standard_hexahedron():
    """K_uu of the element matrices, assembled, is scikit-fem's Q1 stiffness (same 2x2x2 rule): this fixes the
    dof order and the B matrices the modes are coupled with."""
    model = block_model(mesh_size=5.0, element="standard")
    mesh = model.mesh
    K = incompatible.element_matrices(mesh.points[mesh.cells], incompatible.cell_lame(mesh, model.materials))
    dofs = incompatible.cell_dofs(mesh.cells)
    ours = np.zeros((3 * mesh.n_nodes,) * 2)
    np.add.at(ours, (dofs[:, :, None], dofs[:, None, :]), K[:, :24, :24])
    reference = stiffness(Space.build(mesh, "3d"), model).toarray()
    np.testing.assert_allclose(ours, reference, rtol=0, atol=1e-12 * np.abs(reference).max())


def test_condensed_stiffness_is_symmetric_and_has_the_rigid_modes(block3d):
    model = block3d
    assert model.element == "incompatible"
    K = stiffness(Space.build(model.mesh, "3d", "incompatible"), model)
    x = model.mesh.points
    scale = abs(K).max() * np.abs(x).max()
    assert abs(K - K.T).max() <= 1e-14 * abs(K).max()
    for mode in (np.tile([1.0, 0.0, 0.0], len(x)), np.column_stack([-x[:, 1], x[:, 0], 0 * x[:, 0]]).ravel()):
        assert np.abs(K @ mode).max() <= 1e-12 * scale


def distorted_cube(seed: int = 1) -> tuple[Mesh, np.ndarray]:
    """3 x 3 x 3 hexahedra on the unit cube with every node moved randomly by up to 0.1 mm (no cell is a
    parallelepiped), and the indices of the boundary nodes."""
    mesh = brick((3, 3, 3), size=(1.0, 1.0, 1.0))
    rng = np.random.default_rng(seed)
    points = mesh.points + rng.uniform(-0.1, 0.1, mesh.points.shape)
    grid = np.stack(np.meshgrid(*[np.arange(4)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    boundary = np.flatnonzero(np.any((grid == 0) | (grid == 3), axis=1))
    return Mesh(points=points, cell_type="hexahedron", cells=mesh.cells, regions=mesh.regions,
                boundaries=mesh.boundaries), boundary


def test_patch_test_on_distorted_hexahedra():
    """A linear displacement prescribed on the boundary is reproduced inside, with constant strain: Taylor's
    factor det J0 / det J makes the modes' gradients integrate to zero on any cell."""
    mesh, boundary = distorted_cube()
    rng = np.random.default_rng(2)
    A, b = rng.uniform(-1, 1, (3, 3)), rng.uniform(-1, 1, 3)
    exact = b + mesh.points @ A.T
    model = Model(mesh, "3d", {"body": Material(1000.0, 0.3)}, element="incompatible")
    prescribed = (3 * boundary[:, None] + np.arange(3)).ravel()
    u = solved(model, np.zeros(exact.size), prescribed, exact.ravel()[prescribed])
    np.testing.assert_allclose(u, exact.ravel(), rtol=0, atol=1e-12)        # round-off of O(1) values
    points = rng.uniform(0.15, 0.85, (40, 3)) - [0.0, 0.5, 0.5]           # inside, 0.05 mm from any face
    space = Space.build(mesh, "3d", "incompatible")
    values = (point_operator(space, points, ("ux", "uy", "uz", "exx", "eyy", "ezz", "exy", "eyz", "exz"),
                             materials=model.materials) @ u).reshape(-1, 9)
    strain = (A + A.T) / 2
    np.testing.assert_allclose(values[:, :3], b + points @ A.T, rtol=0, atol=1e-10)
    np.testing.assert_allclose(values[:, 3:], np.tile(strain[[0, 1, 2, 0, 1, 0], [0, 1, 2, 1, 2, 2]], (40, 1)),
                               rtol=0, atol=1e-10)


# ------------------------------------------------------------------------------------------------ cantilever

def end_moment(element: str, moment: float = 1.0, n_x: int = 5):
    """Cantilever clamped at x = 0, end moment about y from nodal forces +-M / (2 H) in x on the tip corners
    (the consistent forces of a linear traction): tension on top, tip deflection -M L^2 / (2 E I)."""
    mesh = brick((n_x, 1, 1))
    model = Model(mesh, "3d", {"body": BEAM}, supports=(Support("root"),), element=element)
    forces = np.zeros(3 * mesh.n_nodes)
    tip = np.unique(mesh.boundary("tip"))
    forces[3 * tip] = np.sign(mesh.points[tip, 2]) * moment / (2 * H)
    root = (3 * np.unique(mesh.boundary("root"))[:, None] + np.arange(3)).ravel()
    return model, solved(model, forces, root, np.zeros(len(root)))


def test_end_moment_is_exact_with_incompatible_modes_and_locks_without():
    """nu = 0, pure bending: u_x = k x z, u_z = -k x^2 / 2, e_xx = k z with k = M / (E I) is the exact 3-D
    solution and lies in the incompatible element's space on rectangular cells (exact to round-off)."""
    kappa = 1.0 / (E * INERTIA)
    exact_tip = -kappa * L ** 2 / 2                                         # -M L^2 / (2 E I) = -0.6 mm
    model, u = end_moment("incompatible")
    points = np.array([[x, y, z] for x in (0.3, 3.7, 6.0, 9.1) for y in (-0.5, 0.2) for z in (-0.5, 0.1, 0.5)])
    values = (point_operator(Space.build(model.mesh, "3d", "incompatible"), points, ("ux", "uz", "exx", "exz"),
                             materials=model.materials) @ u).reshape(-1, 4)
    x, z = points[:, 0], points[:, 2]
    np.testing.assert_allclose(u[2::3][model.mesh.points[:, 0] == L], exact_tip, rtol=1e-10)
    # between the nodes u_z is quadratic in x: only the modes' displacement N_a alpha makes it exact there
    np.testing.assert_allclose(values, np.column_stack([kappa * x * z, -kappa * x ** 2 / 2, kappa * z, 0 * x]),
                               rtol=0, atol=1e-10 * abs(exact_tip))
    _, standard = end_moment("standard")
    assert standard[2::3][model.mesh.points[:, 0] == L].max() > 0.8 * exact_tip   # locked: < 80 % of it


@pytest.fixture(scope="module")
def tip_shear():
    """Cantilever of 5 cells (aspect 2), tip force P = 1 N in z spread over the tip face, both elements;
    observes e_xx on top (z = H/2) at the cells' centres x = 1, 3, ..., 9 and u_z at the tip centre."""
    points = np.array([[x, 0.0, H / 2] for x in (1.0, 3.0, 5.0, 7.0, 9.0)] + [[L, 0.0, 0.0]])
    out = {}
    for element in ("standard", "incompatible"):
        model = Model(brick((5, 1, 1)), "3d", {"body": BEAM}, supports=(Support("root"),),
                      loads=(SurfaceForce("tip", "z", (1.0,)),), element=element)
        problem = Problem.build(model, points=points, quantities=("exx", "uz"))
        out[element] = problem.solve([]).observations[-1].reshape(-1, 2)
    return points, out


def test_tip_shear_deflection_against_timoshenko(tip_shear):
    # Timoshenko beam: P L^3 / (3 E I) + P L / (k G A), k = 5/6, G = E / 2 (nu = 0): 4.0 + 0.024 = 4.024 mm
    timoshenko = L ** 3 / (3 * E * INERTIA) + L / (5 / 6 * E / 2 * B * H)
    _, values = tip_shear
    assert values["incompatible"][-1, 1] == pytest.approx(timoshenko, rel=0.02)   # measured 0.9891
    assert values["standard"][-1, 1] < 0.8 * timoshenko                          # measured 0.333: locked


def test_tip_shear_bending_strain_at_cell_centres(tip_shear):
    """Euler-Bernoulli e_xx = -P (L - x) (H / 2) / (E I) on top: the element's bending strain is constant along
    each cell and equal to the beam's at the cell centre (measured to 1e-9; standard hex8: a third of it)."""
    points, values = tip_shear
    beam = -(L - points[:-1, 0]) * (H / 2) / (E * INERTIA)
    np.testing.assert_allclose(values["incompatible"][:-1, 0], beam, rtol=1e-6)
    assert np.all(np.abs(values["standard"][:-1, 0]) < 0.8 * np.abs(beam))


# ------------------------------------------------------------------------------------------------ CalculiX

def cantilever_deck(mesh: Mesh, material: Material, tip_force: float) -> str:
    """A C3D8I cantilever: root clamped, the tip force in z shared equally by the tip nodes (one tip cell)."""
    def data(rows):
        return [", ".join(f"{v:.12g}" if isinstance(v, float) else str(v) for v in row) for row in rows]
    tip, root = np.unique(mesh.boundary("tip")), np.unique(mesh.boundary("root"))
    return "\n".join(
        ["*NODE, NSET=NALL", *data([(i + 1, *map(float, p)) for i, p in enumerate(mesh.points)]),
         "*ELEMENT, TYPE=C3D8I, ELSET=EALL", *data([(e + 1, *(c + 1)) for e, c in enumerate(mesh.cells)]),
         "*NSET, NSET=TIP", *data([(n + 1,) for n in tip]), "*NSET, NSET=ROOT", *data([(n + 1,) for n in root]),
         "*MATERIAL, NAME=M", "*ELASTIC", f"{material.E:.12g}, {material.nu:.12g}",
         "*SOLID SECTION, ELSET=EALL, MATERIAL=M", "*STEP", "*STATIC", "*BOUNDARY", "ROOT, 1, 3, 0.",
         "*CLOAD", *data([(n + 1, 3, tip_force / len(tip)) for n in tip]),
         "*NODE PRINT, NSET=TIP", "U", "*EL PRINT, ELSET=EALL", "E", "*END STEP", ""])


def ccx_strains(path) -> np.ndarray:
    """(n_cells * 8, 6) integration point strains exx, eyy, ezz, exy, exz, eyz of the .dat's EL PRINT E."""
    lines = path.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip().startswith("strains"))
    return np.array([reals(line.split(None, 2)[2]) for line in lines[start + 2:] if line.strip()])


@needs_ccx
def test_cantilever_against_calculix_c3d8i():
    """nu = 0.3 tip-loaded cantilever on rectangular cells: ccx's C3D8I and ours agree to ccx's print precision
    (7 digits) in the tip displacement and at the 2x2x2 integration points (ccx order: xi fastest).

    (On non-parallelepiped cells they differ: ccx 2.20 omits Taylor's det J0 / det J, see
    :func:`frictionid.backends.calculix.elements.element_type`.)"""
    mesh, material = brick((5, 1, 1)), Material(E, 0.3)
    work = run_ccx(cantilever_deck(mesh, material, 1.0), shutil.which("ccx"), timeout=60)
    try:
        dat = read_dat(work / f"{JOB}.dat")
        strains = ccx_strains(work / f"{JOB}.dat")
    finally:
        remove_work(work)
    tip = np.unique(mesh.boundary("tip"))
    ccx_tip = np.array([dat.nodal[("displacements (vx,vy,vz)", "TIP")][1.0][n + 1][2] for n in tip])
    N, _ = incompatible.trilinear(incompatible.GAUSS[[0, 1, 3, 2, 4, 5, 7, 6]])   # ccx's point order
    gauss_points = np.einsum("qk,eka->eqa", N, mesh.points[mesh.cells]).reshape(-1, 3)
    model = Model(mesh, "3d", {"body": material}, supports=(Support("root"),),
                  loads=(SurfaceForce("tip", "z", (1.0,)),), element="incompatible")
    quantities = ("uz", "exx", "eyy", "ezz", "exy", "exz", "eyz")
    problem = Problem.build(model, points=np.vstack([mesh.points[tip], gauss_points]), quantities=quantities)
    ours = problem.solve([]).observations[-1].reshape(-1, 7)
    np.testing.assert_allclose(ours[:len(tip), 0], ccx_tip, rtol=2e-6)             # ccx prints 7 digits
    np.testing.assert_allclose(ours[len(tip):, 1:], strains, rtol=0, atol=2e-6 * np.abs(strains).max())


def test_the_deck_of_an_incompatible_model_has_c3d8i(block3d):
    model = block3d
    assert model.element == "incompatible"
    channels = load_channels(Space.build(model.mesh, model.kind, model.element), model)
    deck = write_deck(model, [0.3] * 4, ContactSettings(1e6, 2e6), channels.forces, channels.amplitudes)
    assert deck.count("*ELEMENT, TYPE=C3D8I") == 2 and "TYPE=C3D8," not in deck
    assert element_type("3d", "hexahedron") == "C3D8"


# ------------------------------------------------------------------------------------------------ block model

#: points on the block's side faces, 0.5 and 1.5 mm above the contact
SIDE_POINTS = np.array([[x, y, z] for z in (0.5, 1.5) for x, y in ((-5.0, 2.0), (5.0, -2.0), (2.0, -5.0), (-2.0, 5.0))])


@pytest.mark.parametrize("pull", [0.02, 0.2], ids=["partial-slip", "gross-slip"])
def test_block_sensitivities_match_central_differences(pull):
    model = block_model(mesh_size=2.5, pull=pull, n_pull=4, element="incompatible")
    problem = Problem.build(model, points=SIDE_POINTS, quantities=("ezz", "eyz", "exz"),
                            regions=["block"] * len(SIDE_POINTS))
    mu, h = np.array([0.3, 0.2, 0.4, 0.25]), 1e-6
    solution = problem.solve(mu, sensitivities=True)
    states = np.bincount(solution.state[-1], minlength=3)
    assert states[SLIP] > 0 and (pull > 0.1 or states[STICK] > 0)          # the regime the id claims
    for name in ("reactions", "observations"):
        central = central_difference(lambda m: getattr(problem.solve(m), name), mu, h)
        for zone in range(4):
            np.testing.assert_allclose(getattr(solution, f"d_{name}")[:, :, zone], central[..., zone], rtol=1e-6,
                                       atol=1e-6 * np.abs(central[..., zone]).max())


def test_block_model_carries_the_element_into_its_fingerprint():
    standard, modes = block_model(mesh_size=5.0, element="standard"), block_model(mesh_size=5.0, element="incompatible")
    assert modes.element == "incompatible" and standard.element == "standard"
    assert standard.fingerprint() != modes.fingerprint()
    assert standard.with_element("incompatible").fingerprint() == modes.fingerprint()


# ------------------------------------------------------------------------------------------------ bad input

@pytest.mark.parametrize("options, message", [
    ({"element": "wilson"}, "`element` must be one of 'standard', 'incompatible', got 'wilson'"),
    ({"element": "incompatible", "order": 2}, "`element` 'incompatible' needs `order` 1"),
])
def test_bad_builder_element(options, message):
    with pytest.raises(InputError, match=message):
        block_model(mesh_size=5.0, **options)


def test_incompatible_modes_need_linear_hexahedra_and_points_need_materials():
    quadratic = block_model(mesh_size=5.0, order=2)
    with pytest.raises(InputError, match="element 'incompatible' needs linear hexahedra .* 'hexahedron27'"):
        quadratic.with_element("incompatible")
    with pytest.raises(InputError, match=r"space: element 'c3d8i' is not one of \('standard', 'incompatible'\)"):
        Space.build(quadratic.mesh, "3d", "c3d8i")
    mesh = brick((2, 1, 1))
    with pytest.raises(InputError, match="needs `materials`"):
        point_operator(Space.build(mesh, "3d", "incompatible"), [[1.0, 0.0, 0.0]], ("exx",))
