"""Models of the analytical verification benchmarks (docs/design.md, verification) on conforming node-to-node interfaces."""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..model import ContactInterface, Displacement, Material, Mesh, Model, Pressure, Stage, Support, SurfaceForce
from .arcs import cylinders_mesh
from .arguments import count, positive
from .collar import shaft_and_collar_mesh




# ------------------------------------------------------------------------------------------ two cylinders

def _cylinders(R_upper: float, R_lower: float, half_width: float, contact_size: float, size: float) -> Mesh:
    half_width = positive("half_width_refined", half_width)
    if not half_width < min(R_upper, R_lower):
        raise InputError(f"`half_width_refined` must be smaller than the radii, got {half_width}")
    return cylinders_mesh(R_upper, R_lower, half_width, positive("contact_size", contact_size),
                          positive("size", size))

def _cylinder_interface(R_upper: float, R_lower: float, half_width: float) -> ContactInterface:
    """The arcs' interface; its gap tolerance is the geometry's: twice the gap at the zones' ends (x = half_width)."""
    return ContactInterface("contact", ("left", "right"), "lower_contact", discretisation="node-to-node",
                            gap_tolerance=2.0 * float(hertz_gap(half_width, R_upper, R_lower)))


def hertz_model(E1: float = 30000.0, nu1: float = 0.25, R1: float = 10.0, E2: float = 29120.0, nu2: float = 0.3,
                R2: float = 13.0, force: float = 3200.0, contact_size: float = 0.05, size: float = 1.0,
                half_width_refined: float = 2.5, n_increments: int = 5) -> Model:
    """Hertz line contact of two half-cylinders in plane strain (Ansys VM191 data: half-width b = 1.20 mm).

    The upper half-disc (E1, nu1, R1, centre (0, R1)) touches the lower one (E2, nu2, R2, centre (0, -R2)) at
    the origin. For |x| <= half_width_refined both arcs have nodes at the same abscissae (spacing at most
    contact_size, one quadratic element per spacing, mid-nodes at the mean abscissa); the initial gap is the
    vertical distance of the arcs (:func:`hertz_gap`), about x^2 / (2 R), positive (open).
    Zones "left" and "right" (upper arc, x < 0 / x > 0), target "lower_contact".

    Supports: "lower_flat" fixed; "upper_axis" (x = 0 inside the upper body, a symmetry line) held in x, which
    removes the upper body's x-translation and rotation (a line held in x at the top face would leave the
    rotation about its centre free); the axis ends at the contact node x = 0, whose x-displacement is zero by
    symmetry anyway. The upper body's y-translation is restrained by the contact only. Load: total force
    ``force`` [N/mm] downward on "upper_flat" in one stage "load" of n_increments.

    >>> model = hertz_model(contact_size=0.5, size=3.0)
    >>> model.zone_names
    ('left', 'right')
    """
    materials = {"upper": Material(E1, nu1, "upper"), "lower": Material(E2, nu2, "lower")}
    mesh = _cylinders(positive("R1", R1), positive("R2", R2), half_width_refined, contact_size, size)
    return Model(mesh=mesh, kind="plane_strain", materials=materials,
                 supports=(Support("lower_flat", (0, 1)), Support("upper_axis", (0,))),
                 loads=(SurfaceForce("upper_flat", 1, (-positive("force", force),)),),
                 stages=(Stage("load", count("n_increments", n_increments)),),
                 interfaces=(_cylinder_interface(R1, R2, half_width_refined),))


def hertz_gap(x, R1: float, R2: float):
    """Initial vertical gap [mm] between the arcs of the Hertz/Mindlin models at abscissa x (about x^2 / (2 R)).

    This is the distance at equal x; the gap along the lower arc's normal is sqrt(1 - x^2/R2^2) times it.
    """
    x = np.asarray(x, dtype=float)
    return R1 - np.sqrt(R1 ** 2 - x ** 2) + R2 - np.sqrt(R2 ** 2 - x ** 2)


def _effective(E1, nu1, R1, E2, nu2, R2) -> tuple[float, float]:
    """(E*, R) with 1/E* = (1-nu1^2)/E1 + (1-nu2^2)/E2, 1/R = 1/R1 + 1/R2 (docs/design.md, verification)."""
    return 1.0 / ((1 - nu1 ** 2) / E1 + (1 - nu2 ** 2) / E2), 1.0 / (1.0 / R1 + 1.0 / R2)


def hertz_reference(E1: float = 30000.0, nu1: float = 0.25, R1: float = 10.0, E2: float = 29120.0,
                    nu2: float = 0.3, R2: float = 13.0, force: float = 3200.0) -> dict:
    """Hertz line contact: half-width a = sqrt(4 P R / (pi E*)), peak pressure p0 = 2 P / (pi a).

    Returns dict(a [mm], p0 [MPa], E_star [MPa], R [mm]); p(x) = p0 sqrt(1 - x^2/a^2).

    >>> round(hertz_reference()["a"], 3)      # Ansys VM191: b = 1.20 mm
    1.2
    """
    E_star, R = _effective(E1, nu1, R1, E2, nu2, R2)
    a = math.sqrt(4 * force * R / (math.pi * E_star))
    return dict(a=a, p0=2 * force / (math.pi * a), E_star=E_star, R=R)


def mindlin_model(R: float = 8.0, E: float = 200.0, nu: float = 0.3, P: float = 10.0, shift: float = 0.0285,
                  Q_expected: float = 0.936, contact_size: float = 0.02, size: float = 0.5,
                  half_width_refined: float = 1.2, n_tangential: int = 10, n_press: int = 1,
                  balance_moment: bool = True) -> Model:
    """Cattaneo-Mindlin partial slip of two identical half-cylinders in plane strain (docs/design.md, verification).

    Geometry and conforming arcs as :func:`hertz_model` (R1 = R2 = R, one material). Stage "press": normal
    force P [N/mm] on "upper_flat" (n_press increments); stage "shift": P held, "upper_flat" moved by ``shift``
    [mm] in +x (n_tangential increments); the tangential force Q is its reaction "upper_flat.x", and the
    theory is to be evaluated at that Q. Both flat faces are held laterally ("lower_flat" fixed, "upper_flat"
    held in x while pressing), so the two bodies are mirror images: pressing then causes no slip (the
    half-space theory's assumption for identical materials). With the upper flat face free laterally instead,
    pressing slipped by up to 5e-4 mm and the stick zone came out 9 % too large. The defaults give Q = 0.936
    within 0.5 % for mu = 0.2 and 0.3 (the verification data of docs/design.md).

    Q at the flat face, a height R above the contact, is a moment Q R about it. With balance_moment (default)
    the normal force is shared unequally between "upper_flat_left" and "upper_flat_right",
    P/2 + Q_expected and P/2 - Q_expected, whose couple cancels Q_expected R: the contact then carries P and
    Q with (almost) no moment, as in the half-space theory.
    """
    mesh = _cylinders(positive("R", R), R, half_width_refined, contact_size, size)
    P, Q = positive("P", P), float(Q_expected)
    if balance_moment:
        loads = (SurfaceForce("upper_flat_left", 1, (-P / 2, -(P / 2 + Q))),
                 SurfaceForce("upper_flat_right", 1, (-P / 2, -(P / 2 - Q))))
    else:
        loads = (SurfaceForce("upper_flat", 1, (-P, -P)),)
    return Model(mesh=mesh, kind="plane_strain",
                 materials={"upper": Material(E, nu, "upper"), "lower": Material(E, nu, "lower")},
                 supports=(Support("lower_flat", (0, 1)),),
                 loads=loads + (Displacement("upper_flat", 0, (0.0, positive("shift", shift))),),
                 stages=(Stage("press", count("n_press", n_press)),
                         Stage("shift", count("n_tangential", n_tangential))),
                 interfaces=(_cylinder_interface(R, R, half_width_refined),))


def mindlin_reference(mu: float, R: float = 8.0, E: float = 200.0, nu: float = 0.3, P: float = 10.0,
                      Q: float = 0.936) -> dict:
    """Cattaneo-Mindlin for elastically similar cylinders: c/a = sqrt(1 - Q / (mu P)) (Johnson 1985, ch. 7).

    Returns dict(a, p0, c [mm], E_star, R (effective), q) with q(x) [MPa] the magnitude of the shear traction:
    mu p0 sqrt(1 - x^2/a^2) in the slip zone c < |x| < a, minus mu p0 (c/a) sqrt(1 - x^2/c^2) in the stick
    zone |x| < c; 0 outside the contact. Q >= mu P is gross slip: c = 0.

    >>> ref = mindlin_reference(0.2)
    >>> round(ref["c"] / ref["a"], 3)      # docs/design.md, verification
    0.729
    """
    hertz = hertz_reference(E, nu, R, E, nu, R, P)
    a, p0 = hertz["a"], hertz["p0"]
    c = a * math.sqrt(max(0.0, 1.0 - abs(Q) / (positive("mu", mu) * P)))

    def q(x):
        x = np.abs(np.asarray(x, dtype=float))
        slip = mu * p0 * np.sqrt(np.clip(1 - (x / a) ** 2, 0.0, None))
        stick = mu * p0 * (c / a) * np.sqrt(np.clip(1 - (x / c) ** 2, 0.0, None)) if c > 0 else 0.0 * x
        return slip - np.where(x < c, stick, 0.0)

    return dict(a=a, p0=p0, c=c, E_star=hertz["E_star"], R=hertz["R"], q=q)




# ---------------------------------------------------------------------------------- axisymmetric fits

def _zone_edges(y0: float, length: float, n_zones: int) -> np.ndarray:
    return np.linspace(y0, y0 + length, count("n_zones", n_zones) + 1)


def interference_model(a: float = 10.0, b: float = 20.0, delta: float = 0.01, length: float = 20.0,
                       hub_length: float = 10.0, E: float = 210000.0, nu: float = 0.3, size: float = 0.5,
                       contact_size: float | None = None, push: float = 0.05, n_zones: int = 2,
                       n_push: int = 10) -> Model:
    """Axisymmetric shrink fit and push-out (x = r, y = axis; docs/design.md, verification).

    A solid shaft r <= a + delta (delta: radial interference), y in [-(length - hub_length)/2,
    (length + hub_length)/2], carries a hub a <= r <= b, 0 <= y <= hub_length, on its middle; one material.
    Bore and "shaft_surface" nodes pair at equal y with gap -delta (the shaft's outward normal is +r).
    Zones "Z1".."Zn": the bore split axially into n_zones equal parts, bottom up.

    Supports: "shaft_bottom" held in y (the axis r = 0 is the solver's business). Stage "fit" (1 increment,
    nothing applied: the interference closes; "hub_top" is held at y = 0); stage "push": "hub_top" moved by
    -push in y in n_push increments. push must exceed the elastic travel before gross slip (about 3e-3 mm
    for the defaults with mu = 0.2, so 0.05 is ample).
    """
    a, b, delta = positive("a", a), positive("b", b), positive("delta", delta)
    length, hub_length = positive("length", length), positive("hub_length", hub_length)
    if not (a < b and hub_length < length):
        raise InputError(f"need a < b and hub_length < length, got a={a}, b={b}, hub_length={hub_length}, "
                         f"length={length}")
    y0 = -(length - hub_length) / 2
    zones = [f"Z{k + 1}" for k in range(count("n_zones", n_zones))]
    mesh = shaft_and_collar_mesh(a + delta, a, b, (y0, y0 + length), _zone_edges(0.0, hub_length, n_zones),
                                 zones, "hub", positive("size", size),
                                 positive("contact_size", contact_size or size))
    return Model(mesh=mesh, kind="axisymmetric",
                 materials={"shaft": Material(E, nu, "shaft"), "hub": Material(E, nu, "hub")},
                 supports=(Support("shaft_bottom", (1,)),),
                 loads=(Displacement("hub_top", 1, (0.0, -positive("push", push))),),
                 stages=(Stage("fit", 1), Stage("push", count("n_push", n_push))),
                 interfaces=(ContactInterface("fit", tuple(zones), "shaft_surface", "node-to-node"),))


def lame_reference(a: float, b: float, delta: float, E: float, nu: float, shaft_inner: float = 0.0,
                   condition: str = "plane_strain") -> dict:
    """Contact pressure of an elastic shrink fit, shaft and hub of one material (Lame thick cylinders).

    With radial interference delta at the bore radius a, hub outer radius b, shaft bore c = shaft_inner:

        p_c = delta / (a/E' * [(b^2 + a^2)/(b^2 - a^2) + (a^2 + c^2)/(a^2 - c^2)])

    E' = E / (1 - nu^2) for plane strain (eps_z = 0: hub and shaft long compared with b), E' = E for plane
    stress; for a solid shaft p_c = E' delta (b^2 - a^2) / (2 a b^2). (The nu terms of hub and shaft cancel
    because the material is the same.) A hub of length comparable with b is neither: p_c rises towards its
    ends (edge effect) and its mean differs from Lame by several per cent.

    Returns dict(p_c [MPa], E_prime [MPa]).

    >>> round(lame_reference(10.0, 20.0, 0.01, 210000.0, 0.3)["p_c"], 2)
    86.54
    """
    if condition not in ("plane_strain", "plane_stress"):
        raise InputError(f"`condition` must be 'plane_strain' or 'plane_stress', got {condition!r}")
    if not 0.0 <= shaft_inner < a < b:
        raise InputError(f"need 0 <= shaft_inner < a < b, got {shaft_inner}, {a}, {b}")
    E_prime = E / (1 - nu ** 2) if condition == "plane_strain" else E
    hub = (b ** 2 + a ** 2) / (b ** 2 - a ** 2)
    shaft = (a ** 2 + shaft_inner ** 2) / (a ** 2 - shaft_inner ** 2)
    return dict(p_c=delta * E_prime / (a * (hub + shaft)), E_prime=E_prime)


def pushout_force(mu, p_c, a: float, lengths) -> float:
    """Gross-slip axial force [N] of a fit, whole ring: F = sum_i mu_i p_c,i 2 pi a L_i (docs/design.md, verification).

    mu, p_c and lengths (zone lengths [mm]) are scalars or per-zone sequences.

    >>> round(pushout_force([0.1, 0.2], 50.0, 10.0, [5.0, 5.0]), 1)
    4712.4
    """
    mu, p_c, lengths = np.broadcast_arrays(np.asarray(mu, float), np.asarray(p_c, float), np.asarray(lengths, float))
    return float(np.sum(mu * p_c * 2 * np.pi * a * lengths))


def sleeve_model(inner: float = 10.0, outer: float = 14.0, sleeve_length: float = 10.0,
                 shaft_length: float = 20.0, pressure: float = 100.0, push: float = 0.05, E: float = 210000.0,
                 nu: float = 0.3, size: float = 0.5, contact_size: float | None = None, n_press: int = 1,
                 n_push: int = 10) -> Model:
    """Axisymmetric gross-slip case: a sleeve pressed onto a shaft, then pushed along it (x = r, y = axis).

    Sleeve inner <= r <= outer, 0 <= y <= sleeve_length, on a solid shaft r <= inner,
    y in [-(shaft_length - sleeve_length)/2, (shaft_length + sleeve_length)/2], zero initial gap, one
    material. Zones "lower" (y < sleeve_length/2) and "upper" on the bore, target "shaft_surface", nodes at
    equal y. Stage "press": pressure [MPa] on "sleeve_outer" ("sleeve_top" held at y = 0); stage "push":
    pressure held, "sleeve_top" moved by -push in y (n_push increments). "shaft_bottom" is held in y.

    For one material and zero gap the assembly is a solid cylinder under external pressure, so p_c = pressure
    away from the sleeve's ends, and the gross-slip force is about :func:`pushout_force` (mu, pressure,
    inner, zone lengths); the ends of the short sleeve make it differ by a few per cent.
    """
    inner, outer = positive("inner", inner), positive("outer", outer)
    sleeve_length, shaft_length = positive("sleeve_length", sleeve_length), positive("shaft_length", shaft_length)
    if not (inner < outer and sleeve_length < shaft_length):
        raise InputError("need inner < outer and sleeve_length < shaft_length")
    y0 = -(shaft_length - sleeve_length) / 2
    mesh = shaft_and_collar_mesh(inner, inner, outer, (y0, y0 + shaft_length), _zone_edges(0.0, sleeve_length, 2),
                                 ["lower", "upper"], "sleeve", positive("size", size),
                                 positive("contact_size", contact_size or size))
    pressure = positive("pressure", pressure)
    return Model(mesh=mesh, kind="axisymmetric",
                 materials={"shaft": Material(E, nu, "shaft"), "sleeve": Material(E, nu, "sleeve")},
                 supports=(Support("shaft_bottom", (1,)),),
                 loads=(Pressure("sleeve_outer", (pressure, pressure)),
                        Displacement("sleeve_top", 1, (0.0, -positive("push", push)))),
                 stages=(Stage("press", count("n_press", n_press)), Stage("push", count("n_push", n_push))),
                 interfaces=(ContactInterface("fit", ("lower", "upper"), "shaft_surface", "node-to-node"),))
