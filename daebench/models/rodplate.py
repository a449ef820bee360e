"""A steel rod with a hemispherical tip striking the centre of a free aluminium plate —
planar analog (case ``rod-plate``; seed 001 §4, docs/sources.md §B).

The experiment (seed 001): a steel rod swings onto a suspended square aluminium plate,
normal and central impact, both free during contact; contact lasted ≈ 1.7 ms
(measured electrically). The paper's Table 1 (dimensions, materials, speed) did not
survive extraction, and the companion paper (Wang, Liu & Hong, Shock and Vibration
2017, 6720186) could not be read beyond its abstract here. The values below are this
project's choice, stated in the scene file: steel rod 100 mm long, 10 mm diameter,
hemispherical tip R = 5 mm, speed 1 m/s; aluminium plate 200 mm square, 5 mm thick.

Planar analog (plane stress): the rod is its axial section (10 mm high, 10 mm thick out
of plane), the plate a strip — its cross-section through the impact point, 200 mm long
and 5 mm thick, with the plate's side (200 mm) as out-of-plane thickness so that its
mass is the plate's. A strip bends as a beam, not as a plate, so its contact duration
is an analog's, not a prediction of the 1.7 ms.

Meshes: the rod by :func:`._planar_mesh.rounded_bar` (graded to ``mesh.contact_size``
at the tip), the strip by a tensor grid graded from ``mesh.contact_size`` at its centre
to ``mesh.size`` at its ends. Frames: rod origin at its tail centre, axis through the
tip's centre; strip origin at its lower front corner, axis along its front face (long
baselines, so that local indentation does not turn the frames). Contact points: the
tip's arc nodes (slaves) against the strip's front face within ±``mesh.contact_zone``
of the centre (master, flexible): the rod moves along its axis.
"""

from __future__ import annotations

import math

import numpy as np

from daebench.models._planar_mesh import graded, rectangle, rounded_bar
from daebench.models.planar import (CONTACT_SCHEMA, Body, Layout, PlanarBodies, Surface, check_contact,
                                    hertz_line_halfwidth)
from daebench.core.params import Param
from daebench.core.scene import Scene, SceneError

DESCRIPTION = "steel rod with a round tip strikes a free aluminium plate strip (planar FE analog of seed 001's test)"

SCHEMA: dict[str, Param] = {
    **CONTACT_SCHEMA,
    **{p.name: p for p in (
        Param("rod.length", float, 0.1, "rod length", low=1e-4, high=10.0, unit="m"),
        Param("rod.diameter", float, 0.01, "rod diameter (height in the plane; tip radius = diameter/2)",
              low=1e-5, high=1.0, unit="m"),
        Param("rod.thickness", float, 0.01, "rod out-of-plane thickness", low=1e-5, high=1.0, unit="m"),
        Param("rod.E", float, 2.1e11, "rod Young's modulus (steel)", low=1.0, high=1e13, unit="Pa"),
        Param("rod.nu", float, 0.3, "rod Poisson's ratio", low=0.0, high=0.49),
        Param("rod.density", float, 7850.0, "rod density", low=1e-3, high=1e5, unit="kg/m³"),
        Param("plate.side", float, 0.2, "plate side (strip length; also its out-of-plane thickness)",
              low=1e-4, high=10.0, unit="m"),
        Param("plate.thickness", float, 5e-3, "plate thickness", low=1e-5, high=1.0, unit="m"),
        Param("plate.E", float, 7e10, "plate Young's modulus (aluminium)", low=1.0, high=1e13, unit="Pa"),
        Param("plate.nu", float, 0.33, "plate Poisson's ratio", low=0.0, high=0.49),
        Param("plate.density", float, 2700.0, "plate density", low=1e-3, high=1e5, unit="kg/m³"),
        Param("mesh.size", float, 10e-3, "element size away from the contact", low=1e-6, high=1.0, unit="m"),
        Param("mesh.contact_size", float, 1e-3, "element size at the contact", low=1e-6, high=1.0, unit="m"),
        Param("mesh.contact_zone", float, 5e-3, "half-width of the strip's master face", low=1e-6, high=1.0, unit="m"),
        Param("start.speed", float, 1.0, "rod speed towards the plate", low=0.0, high=1e3, unit="m/s"),
        Param("start.gap", float, 1e-5, "gap between tip and plate at t = 0", low=0.0, high=1.0, unit="m"),
    )},
}


def check_scene(scene: Scene) -> None:
    check_contact(scene)
    if scene["mesh.contact_size"] > scene["mesh.size"]:
        raise SceneError("scene key 'mesh.contact_size' must not exceed 'mesh.size'")
    if scene["rod.length"] <= scene["rod.diameter"]:
        raise SceneError("scene key 'rod.length' must exceed 'rod.diameter'")


def build(scene: Scene) -> PlanarBodies:
    hc, hf = scene["mesh.contact_size"], scene["mesh.size"]
    L, d = scene["rod.length"], scene["rod.diameter"]
    R = 0.5 * d
    rod_mesh = rounded_bar(L, d, hf, h_tip=hc, h_across=max(hc, d / 6.0))
    rp = rod_mesh.p
    x_end = L - R
    tail = _nearest(rp, 0.0, 0.0)
    rod_axis = _nearest(rp, x_end, 0.0)
    tol = 1e-6 * d
    arc = np.flatnonzero((rp[:, 0] >= x_end + tol) & (np.abs(np.hypot(rp[:, 0] - x_end, rp[:, 1]) - R) < tol))
    S, th = scene["plate.side"], scene["plate.thickness"]
    right = graded(0.5 * hc, 0.5 * S, hc, hf)              # no node at the centre: the tip's axis node
    ys = np.concatenate([-right[::-1], right])              # meets a segment, not a kink between two
    xs = graded(0.0, th, hc, max(hc, th / 4.0))
    plate_mesh = rectangle(xs, ys)
    pp = plate_mesh.p
    corner_lo = _nearest(pp, 0.0, -0.5 * S)
    corner_hi = _nearest(pp, 0.0, 0.5 * S)
    back = _nearest(pp, th, 0.0)
    face = np.flatnonzero((np.abs(pp[:, 0]) < 1e-9 * S) & (np.abs(pp[:, 1]) <= scene["mesh.contact_zone"] + 1e-12))
    face = face[np.argsort(-pp[face, 1])]                   # top to bottom: outward normal −x
    v0, gap = scene["start.speed"], scene["start.gap"]
    rod = Body("rod", rod_mesh, scene["rod.E"], scene["rod.nu"], scene["rod.density"], scene["rod.thickness"],
               (tail, rod_axis), origin=(-gap - L, 0.0), velocity=(v0, 0.0))
    plate = Body("plate", plate_mesh, scene["plate.E"], scene["plate.nu"], scene["plate.density"], S,
                 (corner_lo, corner_hi), origin=(0.0, -0.5 * S))
    master = Surface([("plate", int(i)) for i in face])
    E_rod, rho = scene["rod.E"], scene["rod.density"]
    Z = rho * math.sqrt(E_rod / rho) * d * scene["rod.thickness"]
    radius = hertz_line_halfwidth(Z * v0, scene["rod.thickness"], R, E_rod, scene["rod.nu"],
                                  scene["plate.E"], scene["plate.nu"])

    def observe(sys_: PlanarBodies, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        kb, kt = sys_.node("plate", back), sys_.node("rod", tail)
        return {"v_P1": float(v[2 * kb]), "v_rod_end": float(v[2 * kt]),
                "v_rod_cm": sys_.body_momentum_velocity(v, "rod")[0],
                "v_plate_cm": sys_.body_momentum_velocity(v, "plate")[0]}

    layout = Layout([rod, plate], [master], [("rod", int(i), 0) for i in arc], observe, imm_radius=radius)
    return PlanarBodies(layout, scene)


def _nearest(p: np.ndarray, x: float, y: float) -> int:
    return int(np.argmin(np.hypot(p[:, 0] - x, p[:, 1] - y)))
