"""A round-headed slider launched into a smooth slot (case ``slider-slot``; seed 001 §5,
docs/sources.md §C).

Stated by the paper: PVC for both parts (E = 3 GPa, ν = 0.3, ρ = 1800 kg/m³), 1 mm
thick (plane stress), smooth contact, the slot fixed to the ground, the slider's
floating frame at the midpoint of its tail starting at (0, −1.7) mm, the slider at 10°
to the slot, launched at 20 m/s along its own axis; four impacts at different places.
Everything else was in the paper's lost Fig. 8 and is this project's choice, stated
here and in the scene file: slider 12 mm long (tail to head tip) and 3 mm wide, its head
a semicircle of radius 1.5 mm; slot 7 mm wide, centred on y = 0 (walls y = ±3.5 mm),
long enough for the run; the slot is rigid (its walls are fixed master segments: the
issue's "fixed slot"; the paper meshed it too).

Mesh: linear triangles of size ``slider.mesh_size`` (:func:`._planar_mesh.rounded_bar`).
Floating frame: origin at the tail midpoint (the paper's), axis through the head
centre. Point P, whose trajectory is plotted, is the head tip ("end point").

Contact points (a fixed list): the slider's boundary nodes of its upper half (sides and
head, body frame y ≥ 0) against the upper wall, those of its lower half against the
lower wall. This holds while the slider turns by less than 90° in the slot (it turns by
a few degrees); tail-edge nodes other than the corners are left out (they could touch a
wall only broadside).
"""

from __future__ import annotations

import math

import numpy as np

from daebench.models._planar_mesh import rounded_bar
from daebench.models.planar import (CONTACT_SCHEMA, Body, Layout, PlanarBodies, Surface, check_contact,
                                    hertz_line_halfwidth)
from daebench.core.params import Param
from daebench.core.scene import Scene, SceneError

DESCRIPTION = "round-headed PVC slider launched at 20 m/s, 10 deg into a smooth slot (planar FE): multi-point impacts"

SCHEMA: dict[str, Param] = {
    **CONTACT_SCHEMA,
    **{p.name: p for p in (
        Param("slider.length", float, 12e-3, "slider length, tail to head tip", low=1e-5, high=10.0, unit="m"),
        Param("slider.width", float, 3e-3, "slider width (= head diameter)", low=1e-5, high=10.0, unit="m"),
        Param("slider.thickness", float, 1e-3, "out-of-plane thickness (plane stress)", low=1e-6, high=1.0, unit="m"),
        Param("slider.mesh_size", float, 0.5e-3, "element size", low=1e-6, high=1.0, unit="m"),
        Param("slider.E", float, 3e9, "Young's modulus (PVC)", low=1.0, high=1e13, unit="Pa"),
        Param("slider.nu", float, 0.3, "Poisson's ratio", low=0.0, high=0.49),
        Param("slider.density", float, 1800.0, "density", low=1e-3, high=1e5, unit="kg/m³"),
        Param("slot.width", float, 7e-3, "slot width (walls at y = ±width/2)", low=1e-5, high=10.0, unit="m"),
        Param("slot.length", float, 0.2, "slot length from x = −length/10", low=1e-4, high=100.0, unit="m"),
        Param("start.x", float, 0.0, "initial x of the tail midpoint (frame origin)", low=-10.0, high=10.0, unit="m"),
        Param("start.y", float, -1.7e-3, "initial y of the tail midpoint (frame origin)", low=-10.0, high=10.0,
              unit="m"),
        Param("start.angle_deg", float, 10.0, "initial angle of the slider's axis to the slot", low=-89.0, high=89.0,
              unit="deg"),
        Param("start.speed", float, 20.0, "launch speed along the slider's axis", low=0.0, high=1e4, unit="m/s"),
    )},
}


def check_scene(scene: Scene) -> None:
    check_contact(scene)
    if scene["slider.width"] >= scene["slot.width"]:
        raise SceneError("scene key 'slider.width' must be below 'slot.width' (the slider must fit the slot)")
    if scene["slider.length"] <= scene["slider.width"]:
        raise SceneError("scene key 'slider.length' must exceed 'slider.width' (a bar with a round head)")


def build(scene: Scene) -> PlanarBodies:
    L, w, t = scene["slider.length"], scene["slider.width"], scene["slider.thickness"]
    E, nu, rho = scene["slider.E"], scene["slider.nu"], scene["slider.density"]
    mesh = rounded_bar(L, w, scene["slider.mesh_size"])
    p = mesh.p
    R = 0.5 * w
    x_end = L - R
    tol = 1e-6 * w
    a = _nearest(p, 0.0, 0.0)
    b = _nearest(p, x_end, 0.0)
    tip = _nearest(p, L, 0.0)
    on_side = (np.abs(np.abs(p[:, 1]) - R) < tol) & (p[:, 0] <= x_end + tol)
    on_cap = (p[:, 0] >= x_end - tol) & (np.abs(np.hypot(p[:, 0] - x_end, p[:, 1]) - R) < tol)
    boundary = np.flatnonzero(on_side | on_cap)
    upper = boundary[p[boundary, 1] >= -tol]
    lower = boundary[p[boundary, 1] <= tol]
    ang = math.radians(scene["start.angle_deg"])
    v = scene["start.speed"]
    slider = Body("slider", mesh, E, nu, rho, t, (a, b), origin=(scene["start.x"], scene["start.y"]), angle=ang,
                  velocity=(v * math.cos(ang), v * math.sin(ang)))
    half, x0, x1 = 0.5 * scene["slot.width"], -0.1 * scene["slot.length"], 0.9 * scene["slot.length"]
    upper_wall = Surface([(x0, half), (x1, half)])      # traversed +x: outward normal −y
    lower_wall = Surface([(x1, -half), (x0, -half)])    # traversed −x: outward normal +y
    contacts = [("slider", int(i), 0) for i in upper] + [("slider", int(i), 1) for i in lower]
    c = math.sqrt(E / rho)
    radius = hertz_line_halfwidth(rho * c * w * t * v * abs(math.sin(ang)), t, R, E, nu)

    def observe(sys_: PlanarBodies, q: np.ndarray, vv: np.ndarray) -> dict[str, float]:
        Px, Py = sys_.xy(q, "slider", tip)
        Ox, Oy = sys_.xy(q, "slider", a)
        vx, vy = sys_.body_momentum_velocity(vv, "slider")
        return {"P_x": Px, "P_y": Py, "O_x": Ox, "O_y": Oy, "angle_deg": math.degrees(sys_.body_angle(q, "slider")),
                "v_x": vx, "v_y": vy}

    layout = Layout([slider], [upper_wall, lower_wall], contacts, observe, imm_radius=radius,
                    notes={"tip_node": tip, "frame_nodes": (a, b)})
    return PlanarBodies(layout, scene)


def _nearest(p: np.ndarray, x: float, y: float) -> int:
    return int(np.argmin(np.hypot(p[:, 0] - x, p[:, 1] - y)))
