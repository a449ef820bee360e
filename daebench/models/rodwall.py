"""Elastic rod striking a rigid wall end-on (case ``rod-wall``; docs/sources.md §A).

The rod is a planar body (:mod:`daebench.models.planar`): ``rod.elements`` bilinear
quadrilaterals along its length, ``rod.elements_across`` across its height. With
ν = 0 (the default) and one element across, each cross-section's nodes move together
under an end-on impact and the model *is* the 2-node lumped-mass bar of docs/sources.md §A.3
(axial stiffness E A / l per element, nodal masses ρ A l/2 and ρ A l at the ends and
inside). Floating frame: origin at the struck end's lowest node, axis along the lower
edge. The wall is the line x = 0 (a fixed master segment, outward normal +x); the slave
nodes are the struck end's nodes (a fixed list: the rod moves along its axis).

Exact (1-D wave theory, c = √(E/ρ), Z = ρ c A): the contact lasts 2L/c under the
constant force Z v₀; the rod leaves at v₀, undeformed, without vibration
(:func:`exact`).

Mass redistribution (``rod.contact_mass = "redistributed"``; Khenous, Laborde & Renard,
Eur. J. Mech. A 27, 2008; Doyen, Ern & Piperno, SIAM J. Sci. Comput. 33, 2011): the
struck end's nodes carry no inertia, their lumped mass and the first element's go to the
next cross-section (total mass kept), and the Signorini condition holds on massless
nodes. A massless node is in equilibrium at every instant, so it is condensed exactly:
free, it leaves the first element unstressed; on the wall, that element (axial
stiffness E A / l, half on each of its two nodes across) pushes the next cross-section.
The first element thus *is* a unilateral linear spring of rest length l between the wall
and the second cross-section, and the semi-discrete system is an ODE with a Lipschitz
force: no impact, no velocity jump, its energy conserved. With ``contact.law = "penalty"``
the penalty spring k_p sits in series with the element: k = k_e k_p / (k_e + k_p) per
node. The condensation is exact for what this case does (ν = 0, one element across, the
end's nodes moving together along the axis) and the keys refuse anything else. The
redistributed system has one cross-section less; its observables are the struck end's
(x_end = max(0, x₁ − l), v_end = v₁ while the end is free, 0 on the wall).
"""

from __future__ import annotations

import math

import numpy as np

from daebench.core.contact import PenaltyLaw
from daebench.models._planar_mesh import graded, rectangle
from daebench.models.planar import CONTACT_SCHEMA, Body, Layout, PlanarBodies, Surface, check_contact
from daebench.core.params import Param
from daebench.core.scene import Scene, SceneError

DESCRIPTION = "elastic rod (planar FE, lumped mass) striking a rigid wall end-on: exact 2L/c, Z·v0"

SCHEMA: dict[str, Param] = {
    **CONTACT_SCHEMA,
    **{p.name: p for p in (
        Param("rod.length", float, 1.0, "rod length L", low=1e-6, high=1e3, unit="m"),
        Param("rod.height", float, 0.01, "rod height (in the plane)", low=1e-6, high=1e3, unit="m"),
        Param("rod.thickness", float, 0.01, "out-of-plane thickness (plane stress)", low=1e-6, high=1e3, unit="m"),
        Param("rod.elements", int, 50, "elements along the rod", low=1, high=2000),
        Param("rod.elements_across", int, 1, "elements across the height", low=1, high=50),
        Param("rod.E", float, 2.1e11, "Young's modulus", low=1.0, high=1e13, unit="Pa"),
        Param("rod.nu", float, 0.0, "Poisson's ratio (0: the 1-D bar exactly)", low=0.0, high=0.49),
        Param("rod.density", float, 7850.0, "density", low=1e-3, high=1e5, unit="kg/m³"),
        Param("rod.contact_mass", str, "lumped", "inertia of the struck end's nodes: lumped (their "
              "elements' share) or redistributed (none: moved to the next cross-section, the massless end "
              "condensed exactly; needs nu = 0, one element across, contact.law constraint or penalty)",
              choices=("lumped", "redistributed")),
        Param("start.speed", float, 1.0, "speed v0 towards the wall", low=1e-9, high=1e4, unit="m/s"),
        Param("start.gap", float, 1e-6, "gap between the rod's end and the wall at t = 0", low=0.0, high=1.0,
              unit="m"),
    )},
}


def check_scene(scene: Scene) -> None:
    check_contact(scene)
    if scene["contact.law"] == "complementarity" and scene["start.gap"] <= 0.0:
        raise SceneError("scene key 'start.gap' must be > 0 for contact.law = 'complementarity' "
                         "(the integrator must see the contact close)")
    if scene["rod.contact_mass"] == "redistributed":
        why = {"rod.nu": (scene["rod.nu"] == 0.0, "rod.nu=0"),
               "rod.elements_across": (scene["rod.elements_across"] == 1, "rod.elements_across=1"),
               "rod.elements": (scene["rod.elements"] >= 2, "rod.elements=2 or more"),
               "contact.law": (scene["contact.law"] in ("constraint", "penalty"),
                               "contact.law=constraint (or penalty)"),
               "contact.penalty_damping": (scene["contact.law"] != "penalty" or scene["contact.penalty_damping"] == 0.0,
                                           "contact.penalty_damping=0")}
        for key, (ok, fix) in why.items():
            if not ok:
                raise SceneError(f"scene key '{key}' = {scene[key]!r} does not go with rod.contact_mass = "
                                 f"'redistributed', whose massless end is condensed exactly only for the 1-D bar "
                                 f"under a spring or Signorini contact; set `--set {fix}` or rod.contact_mass=lumped")


def exact(scene: Scene) -> dict[str, float]:
    """Saint-Venant's solution: wave speed c, impedance Z, contact time 2L/c, force Z v0,
    rod mass, and the time of first touch start.gap / v0."""
    E, rho = scene["rod.E"], scene["rod.density"]
    A = scene["rod.height"] * scene["rod.thickness"]
    c = math.sqrt(E / rho)
    v0 = scene["start.speed"]
    return {"c": c, "Z": rho * c * A, "T": 2.0 * scene["rod.length"] / c, "F": rho * c * A * v0,
            "mass": rho * A * scene["rod.length"], "v0": v0, "t_touch": scene["start.gap"] / v0}


def condensed_stiffness(scene: Scene) -> float:
    """Stiffness per contact node of the redistributed end (module docstring): the first
    element's axial stiffness E A / l shared by its two nodes across, in series with the
    penalty spring under ``contact.law = "penalty"`` [N/m]."""
    A = scene["rod.height"] * scene["rod.thickness"]
    k_e = 0.5 * scene["rod.E"] * A * scene["rod.elements"] / scene["rod.length"]
    if scene["contact.law"] != "penalty":
        return k_e
    k_p = scene["contact.penalty_stiffness"]
    return k_e * k_p / (k_e + k_p)


def build(scene: Scene) -> PlanarBodies:
    L, H = scene["rod.length"], scene["rod.height"]
    l = L / scene["rod.elements"]
    redistributed = scene["rod.contact_mass"] == "redistributed"
    x1 = l if redistributed else 0.0        # the first cross-section the mesh keeps
    xs = graded(x1, L, l)
    ys = graded(-0.5 * H, 0.5 * H, H / scene["rod.elements_across"])
    mesh = rectangle(xs, ys)
    p = mesh.p
    tol = 1e-9 * L
    struck = np.flatnonzero(np.abs(p[:, 0] - x1) < tol)
    free = np.flatnonzero(np.abs(p[:, 0] - L) < tol)
    a = int(struck[np.argmin(p[struck, 1])])
    b = int(free[np.argmin(p[free, 1])])
    v0 = scene["start.speed"]
    rod = Body("rod", mesh, scene["rod.E"], scene["rod.nu"], scene["rod.density"], scene["rod.thickness"],
               (a, b), origin=(scene["start.gap"] + x1, -0.5 * H), velocity=(-v0, 0.0))
    # x = x1, normal +x: the wall itself, or (redistributed) where the first element's spring engages
    wall = Surface([(x1, -10.0 * (L + H)), (x1, 10.0 * (L + H))])

    def observe(sys_: PlanarBodies, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        ks = [sys_.node("rod", i) for i in struck]
        kf = [sys_.node("rod", i) for i in free]
        x, u = float(np.mean(q[[2 * k for k in ks]])), float(np.mean(v[[2 * k for k in ks]]))
        if redistributed:   # the condensed end: free while the first element is unstressed, else on the wall
            x, u = (x - x1, u) if x > x1 else (0.0, 0.0)
        return {"x_end": x, "v_end": u, "v_free": float(np.mean(v[[2 * k for k in kf]])),
                "v_cm": sys_.body_momentum_velocity(v, "rod")[0]}

    extra: dict = {}
    if redistributed:
        rho_A_l = scene["rod.density"] * H * scene["rod.thickness"] * l
        # the struck end's nodes (ρAl/4 each) and the removed element's other corners (ρAl/4 each)
        extra = {"added_mass": [("rod", int(i), 0.5 * rho_A_l) for i in struck],
                 "contact_law": PenaltyLaw(scene["contact.restitution"], condensed_stiffness(scene), 0.0, len(struck))}
    return PlanarBodies(Layout([rod], [wall], [("rod", int(i), 0) for i in struck], observe, **extra), scene)
