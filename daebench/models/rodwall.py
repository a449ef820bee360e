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
"""

from __future__ import annotations

import math

import numpy as np

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


def exact(scene: Scene) -> dict[str, float]:
    """Saint-Venant's solution: wave speed c, impedance Z, contact time 2L/c, force Z v0,
    rod mass, and the time of first touch start.gap / v0."""
    E, rho = scene["rod.E"], scene["rod.density"]
    A = scene["rod.height"] * scene["rod.thickness"]
    c = math.sqrt(E / rho)
    v0 = scene["start.speed"]
    return {"c": c, "Z": rho * c * A, "T": 2.0 * scene["rod.length"] / c, "F": rho * c * A * v0,
            "mass": rho * A * scene["rod.length"], "v0": v0, "t_touch": scene["start.gap"] / v0}


def build(scene: Scene) -> PlanarBodies:
    L, H = scene["rod.length"], scene["rod.height"]
    xs = graded(0.0, L, L / scene["rod.elements"])
    ys = graded(-0.5 * H, 0.5 * H, H / scene["rod.elements_across"])
    mesh = rectangle(xs, ys)
    p = mesh.p
    tol = 1e-9 * L
    struck = np.flatnonzero(np.abs(p[:, 0]) < tol)
    free = np.flatnonzero(np.abs(p[:, 0] - L) < tol)
    a = int(struck[np.argmin(p[struck, 1])])
    b = int(free[np.argmin(p[free, 1])])
    v0 = scene["start.speed"]
    rod = Body("rod", mesh, scene["rod.E"], scene["rod.nu"], scene["rod.density"], scene["rod.thickness"],
               (a, b), origin=(scene["start.gap"], -0.5 * H), velocity=(-v0, 0.0))
    wall = Surface([(0.0, -10.0 * (L + H)), (0.0, 10.0 * (L + H))])      # x = 0, normal +x

    def observe(sys_: PlanarBodies, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        ks = [sys_.node("rod", i) for i in struck]
        kf = [sys_.node("rod", i) for i in free]
        return {"x_end": float(np.mean(q[[2 * k for k in ks]])), "v_end": float(np.mean(v[[2 * k for k in ks]])),
                "v_free": float(np.mean(v[[2 * k for k in kf]])),
                "v_cm": sys_.body_momentum_velocity(v, "rod")[0]}

    return PlanarBodies(Layout([rod], [wall], [("rod", int(i), 0) for i in struck], observe), scene)
