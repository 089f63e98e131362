"""A synthetic 3-D contact interface of any size for the dense contact benchmarks: a flat punch with a rounded rim
pressed on a flat, both elastic half-spaces (steel on aluminium), discretised at the nodes of a square lattice
inside a disc; the punch's flat face touches at zero gap, as the 3-D bolt's node-to-node pairs do.

W is the relative surface displacement of the two half-spaces per unit point force (Boussinesq and Cerruti,
Johnson, Contact Mechanics, ch. 3): normal 1/rho, tangential 2(1-nu)/rho + 2 nu x^2/rho^3, the normal-tangential
coupling (1-2nu)(1+nu)/(2 pi E) x/rho^2 of the two bodies' difference (non-zero: the materials differ), the
diagonal from a uniform traction on the node's square cell (int 1/rho over a square of side h = 4 h ln(1 + sqrt 2)).
Dense, symmetric, positive definite: the operator the condensation gives for two bodies, at any n_w, without a mesh.

The load path is the product's (fem/loadpath.py): the normal force P (a mean pressure of 400 MPa on the flat face)
held by the punch's rigid approach (one floating mode, equilibrium row sum lam_N = P) in ``n_press`` increments,
then a tangential displacement of the punch in ``n_pull`` increments to 1.1 times Mindlin's gross-slip
displacement of a Hertz contact of the same radius and force, so that the interface passes through stick, partial
slip and gross slip with an open rim (the flat face's radius 0.92 of the disc's, the rim's radius of curvature
``radius``).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from frictionid.fem.condense import Affine, Condensed
from frictionid.fem.pairs import ContactPairs

STEEL, ALUMINIUM = (200000.0, 0.3), (70000.0, 0.33)    # E [MPa], nu
SQUARE = 4.0 * np.log(1.0 + np.sqrt(2.0))                 # int over the unit square of 1/rho about its centre


def lattice(n_c: int, h: float) -> np.ndarray:
    """(n_c, 2) [mm] the n_c nodes of the square lattice of spacing ``h`` nearest the origin."""
    half = int(np.ceil(np.sqrt(n_c / np.pi))) + 2
    x, y = np.meshgrid(np.arange(-half, half + 1) * h, np.arange(-half, half + 1) * h)
    points = np.column_stack([x.ravel(), y.ravel()])
    order = np.lexsort((points[:, 1], points[:, 0], np.hypot(points[:, 0], points[:, 1]).round(9)))
    return points[order[:n_c]]


def compliance(points: np.ndarray, h: float, bodies=(STEEL, ALUMINIUM), chunk: int = 500) -> np.ndarray:
    """(3 n_c, 3 n_c) [mm/N] W, pair-major rows (n, t1 = x, t2 = y), made in chunks of rows."""
    n_c = len(points)
    normal = sum((1 - nu ** 2) / (np.pi * E) for E, nu in bodies)
    shear = [sum((1 + nu) / (2 * np.pi * E) * c(nu) for E, nu in bodies)
             for c in (lambda nu: 2 * (1 - nu), lambda nu: 2 * nu)]
    couple = np.diff([(1 - 2 * nu) * (1 + nu) / (2 * np.pi * E) for E, nu in bodies])[0]
    W = np.empty((3 * n_c, 3 * n_c))
    blocks = W.reshape(n_c, 3, n_c, 3)
    for start in range(0, n_c, chunk):
        rows = slice(start, min(start + chunk, n_c))
        dx = points[rows, None, 0] - points[None, :, 0]
        dy = points[rows, None, 1] - points[None, :, 1]
        rho = np.hypot(dx, dy)
        self_ = rho == 0.0
        rho[self_] = 1.0
        inv = 1.0 / rho
        blocks[rows, 0, :, 0] = normal * inv
        blocks[rows, 1, :, 1] = shear[0] * inv + shear[1] * dx * dx * inv ** 3
        blocks[rows, 2, :, 2] = shear[0] * inv + shear[1] * dy * dy * inv ** 3
        blocks[rows, 1, :, 2] = blocks[rows, 2, :, 1] = shear[1] * dx * dy * inv ** 3
        for t, d in ((1, dx), (2, dy)):
            blocks[rows, 0, :, t] = couple * d * inv ** 2
            blocks[rows, t, :, 0] = -couple * d * inv ** 2
        i, j = np.nonzero(self_)
        i += start
        blocks[i, 0, j, 0] = normal * SQUARE / h
        blocks[i, 1, j, 1] = blocks[i, 2, j, 2] = (shear[0] + 0.5 * shear[1]) * SQUARE / h
        blocks[i, 1, j, 2] = blocks[i, 2, j, 1] = blocks[i, 0, j, 1:] = blocks[i, 1:, j, 0] = 0.0
        del dx, dy, rho, inv
    return W


def mindlin_gross_slip(P: float, mu: float, a: float, bodies=(STEEL, ALUMINIUM)) -> float:
    """Tangential displacement [mm] at which a Hertz contact slides as a whole (Johnson eq. 7.44 at Q = mu P)."""
    return 3 * mu * P / (16 * a) * sum((2 - nu) / (E / (2 * (1 + nu))) for E, nu in bodies)


class Interface:
    """The synthetic interface of ``n_w`` contact dofs: its Condensed operators, pairs and load path.

    Four friction zones by quadrant (A x<0 y<0, B x>0 y<0, C x<0 y>0, D x>0 y>0)."""

    def __init__(self, n_w: int, mu: float = 0.3, radius: float = 0.05, h: float = 0.05, n_press: int = 1,
                 n_pull: int = 3):
        n_c = n_w // 3
        self.points = lattice(n_c, h)
        extent = np.max(np.hypot(*self.points.T)) + 0.5 * h
        self.a = 0.92 * extent
        self.P = 400.0 * np.pi * self.a ** 2
        self.slide = 1.1 * mindlin_gross_slip(self.P, mu, self.a)
        rho = np.hypot(*self.points.T)
        W = compliance(self.points, h)
        n_w = 3 * n_c
        Wa = np.zeros((n_w, 1))
        Wa[0::3, 0] = 1.0                                  # the sphere's approach moves every normal gap
        gap_channels = np.zeros((2, n_w))
        gap_channels[1, 1::3] = 1.0                        # the pull: a tangential displacement along x
        eq_channels = np.array([[-self.P], [0.0]])        # sum lam_N = P amplitude_press
        obs = W[::max(1, n_w // 30)][:30].copy()          # 30 observed relative displacements
        reac = np.zeros((2, n_w))
        reac[0, 0::3], reac[1, 1::3] = 1.0, 1.0           # the total normal and tangential force [N]
        self.condensed = Condensed(
            free=np.arange(n_w), prescribed=np.zeros(0, int), modes=np.zeros((n_w, 1)), inverse=None,
            particular=np.zeros((2, n_w)),
            gap_ops=Affine.sharing(gap_channels * self.slide, W, Wa),
            obs_ops=Affine(np.zeros((2, len(obs))), obs, np.zeros((len(obs), 1))),
            reac_ops=Affine(np.zeros((2, 2)), reac, np.zeros((2, 1))),
            equilibrium=Affine(eq_channels, Wa.T, np.zeros((1, 1))))
        frames = np.broadcast_to(np.eye(3), (n_c, 3, 3)).copy()
        zone = (self.points[:, 0] > 0).astype(int) + 2 * (self.points[:, 1] > 0)
        self.pairs = ContactPairs(
            nodes=np.arange(n_c), position=np.column_stack([self.points, np.zeros(n_c)]), frames=frames,
            weight=np.full(n_c, h * h), zone_share=np.eye(4)[zone],
            gap=np.maximum(rho - self.a, 0.0) ** 2 / (2 * radius), B=sp.identity(n_w, format="csr"),
            interface=np.zeros(n_c, int))
        self.amplitudes = [np.array([k / n_press, 0.0]) for k in range(1, n_press + 1)] + \
            [np.array([1.0, k / n_pull]) for k in range(1, n_pull + 1)]
