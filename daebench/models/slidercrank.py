"""Slider-crank with a clearance in the slider's translational joint (case
``slider-crank-clearance``): a showcase of chattering contact, with and without friction.

Source: P. Flores, R. Leine, C. Glocker, "Modeling and analysis of planar rigid multibody
systems with translational clearance joints based on the non-smooth dynamics approach",
Multibody Syst. Dyn. 23 (2010) 165–190 (docs/sources.md §S). The parameter values are those
of the example Siconos ships for that paper (siconos/siconos,
``examples/Mechanics/SliderCrank/SliderCrankMoreauJeanOSI.cpp`` and
``SliderCrankPlugin/SliderCrankPlugin.cpp``, "parameters according to Table 1"):

=====================  ===================  ===================================
crank                  l1 = 0.1530 m        m1 = 0.038 kg, J1 = 7.4e-5 kg m²
connecting rod         l2 = 0.3060 m        m2 = 0.038 kg, J2 = 5.9e-4 kg m²
slider                 2a × 2b = 0.10 × 0.05 m   m3 = 0.076 kg, J3 = 2.7e-6 kg m²
radial clearance       c = 0.001 m          (the slot's half-height is b + c)
gravity                g = 9.81 m/s² along −y
restitution            e = 0.1 at the four corners (the example sets 0.4, then 0.1)
friction (optional)    μ = 0.01 at the four corners (its ``WITH_FRICTION`` variant)
start                  θ1 = θ2 = θ3 = 0; θ̇1 = 150 rad/s, θ̇2 = −75 rad/s, θ̇3 = 0
=====================  ===================  ===================================

The crank is not driven: it turns freely from its initial rate (as in the example).
J1, J2, J3 are moments of inertia about each body's centre of mass, the crank's and the
rod's centre at their mid-length, the slider's centre at the rod's end (a pin).

Coordinates q = (θ1, θ2, θ3): the crank angle, the rod angle (both from the slot's axis
x), the slider's rotation. The crank pivot is the origin, the slot's axis the x axis; the
slider's centre is at (x3, y3) = (l1 cos θ1 + l2 cos θ2, l1 sin θ1 + l2 sin θ2). With
k = (m2/2 + m3) l1 l2::

    M = [[J1 + (m1/4 + m2 + m3) l1²,  k cos(θ2 − θ1),            0 ],
         [k cos(θ2 − θ1),             J2 + (m2/4 + m3) l2²,      0 ],
         [0,                          0,                         J3]]
    Q = (−k sin(θ1 − θ2) θ̇2² − (m1/2 + m2 + m3) g l1 cos θ1,
         +k sin(θ1 − θ2) θ̇1² − (m2/2 + m3) g l2 cos θ2,   0)
    V = (m1/2 + m2 + m3) g l1 sin θ1 + (m2/2 + m3) g l2 sin θ2

Contacts: the slider's four corners (body frame (p, r)) against the slot's walls
y = ±(b + c): 0 = (−a, +b) and 1 = (+a, +b) against the upper wall (side s = +1), 2 = (−a,
−b) and 3 = (+a, −b) against the lower one (s = −1). With y_c = y3 + p sin θ3 + r cos θ3::

    g = (b + c) − s y_c,     g_q = −s (l1 cos θ1, l2 cos θ2, p cos θ3 − r sin θ3),
    γ_g = −s (l1 sin θ1 θ̇1² + l2 sin θ2 θ̇2² + (p sin θ3 + r cos θ3) θ̇3²)   (g̈ = g_q q̈ − γ_g)

and the slip velocity along x is t_q v with t_q = (−l1 sin θ1, −l2 sin θ2, −(p sin θ3 +
r cos θ3)). Coulomb friction μ = ``contact.friction`` at every corner (the ``tangent``
kernel); the integrators that apply it declare ``capabilities.friction``. Laws:
``constraint`` (Newton restitution e: the event-driven driver, and the e of the capturing
schemes), ``complementarity`` (left to an integrator that resolves contacts, e = 0).

``clearance.c = 0`` squeezes the slider in the slot: y3 = 0 and θ3 = 0 are then held by
the contacts, the classic rigid slider-crank (1 DOF; tests/models/test_slidercrank.py checks it
against that equation solved by scipy).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from daebench.core import kernels
from daebench.core.contact import contact_schema
from daebench.core.observables import Observable
from daebench.core.params import Param
from daebench.core.scene import Scene, SceneError
from daebench.core.system import KernelSystem

DESCRIPTION = ("slider-crank with a clearance in the slider's joint (Flores, Leine & Glocker 2010; Siconos' "
               "values): chattering slider, 4 corners, Coulomb friction")

CONTACT = contact_schema(("constraint", "complementarity"), friction=True, restitution=0.1)

OBSERVABLES = (
    Observable("theta", "rad", "θ crank", derivative="omega", impact_windows=True, summary=True),
    Observable("omega", "rad/s", "ω crank", impact_windows=True),
    Observable("y", "m", "slider y", derivative="vy", impact_windows=True, summary=True),
    Observable("psi", "rad", "slider ψ", derivative="psidot", summary=True),
    Observable("x", "m", "slider x", derivative="vx"),
    Observable("rod", "rad", "rod θ2"),
    Observable("vx", "m/s", "slider ẋ"),
    Observable("vy", "m/s", "slider ẏ"),
    Observable("psidot", "rad/s", "slider ψ̇"),
    Observable("gap", "m", "gap", height=True),
)

SCHEMA: dict[str, Param] = {
    p.name: p
    for p in (
        Param("crank.length", float, 0.153, "crank length l1 (pivot to rod pin)", low=1e-4, high=1e2, unit="m"),
        Param("crank.mass", float, 0.038, "crank mass m1 (centre at mid-length)", low=1e-9, high=1e6, unit="kg"),
        Param("crank.inertia", float, 7.4e-5, "crank inertia J1 about its centre", low=0.0, high=1e6, unit="kg m²"),
        Param("rod.length", float, 0.306, "connecting-rod length l2", low=1e-4, high=1e2, unit="m"),
        Param("rod.mass", float, 0.038, "rod mass m2 (centre at mid-length)", low=1e-9, high=1e6, unit="kg"),
        Param("rod.inertia", float, 5.9e-4, "rod inertia J2 about its centre", low=0.0, high=1e6, unit="kg m²"),
        Param("slider.mass", float, 0.076, "slider mass m3 (centre at the rod's pin)", low=1e-9, high=1e6,
              unit="kg"),
        Param("slider.inertia", float, 2.7e-6, "slider inertia J3 about its centre", low=1e-12, high=1e6,
              unit="kg m²"),
        Param("slider.half_length", float, 0.05, "slider half-length a (corners at ±a along the slot)", low=1e-6,
              high=1e2, unit="m"),
        Param("slider.half_width", float, 0.025, "slider half-width b (corners at ±b across)", low=1e-6, high=1e2,
              unit="m"),
        Param("clearance.c", float, 0.001, "radial clearance c: the slot's half-height is b + c (0: no play)",
              low=0.0, high=1e2, unit="m"),
        Param("gravity.g", float, 9.81, "gravitational acceleration (along −y)", low=0.0, high=1e4, unit="m/s²"),
        Param("start.theta", float, 0.0, "initial crank angle θ1 (the slider starts centred, level)", low=-89.0,
              high=89.0, unit="deg"),
        Param("start.omega", float, 150.0, "initial crank rate θ̇1 (θ̇2 from the rigid kinematics)", low=-1e4,
              high=1e4, unit="rad/s"),
        Param("effects.contact", bool, True, "the slot's walls (off: the slider flies free, θ3 spins free)"),
        *CONTACT.params,   # contact.law, contact.restitution, contact.friction (μ at every corner)
    )
}


class SliderCrankData(NamedTuple):
    """Kernel data (:mod:`daebench.core.kernels`)."""

    l1: float
    l2: float
    M00: float        # J1 + (m1/4 + m2 + m3) l1²
    M11: float        # J2 + (m2/4 + m3) l2²
    J3: float
    k: float          # (m2/2 + m3) l1 l2
    w1: float         # (m1/2 + m2 + m3) g l1
    w2: float         # (m2/2 + m3) g l2
    half_slot: float  # b + c
    mu: float
    points: np.ndarray  # 4 × 3: corners (p, r, side)


@njit(cache=True)
def _mass_force(md, t, q, v, M, Q):
    c21 = math.cos(q[1] - q[0])
    s12 = math.sin(q[0] - q[1])
    for i in range(3):
        for j in range(3):
            M[i, j] = 0.0
    M[0, 0] = md.M00
    M[0, 1] = md.k * c21
    M[1, 0] = md.k * c21
    M[1, 1] = md.M11
    M[2, 2] = md.J3
    Q[0] = -md.k * s12 * v[1] * v[1] - md.w1 * math.cos(q[0])
    Q[1] = md.k * s12 * v[0] * v[0] - md.w2 * math.cos(q[1])
    Q[2] = 0.0


@njit(cache=True)
def _force_jacobian(md, t, q, v, Kq, Kv):
    c12 = math.cos(q[0] - q[1])
    s12 = math.sin(q[0] - q[1])
    for i in range(3):
        for j in range(3):
            Kq[i, j] = 0.0
            Kv[i, j] = 0.0
    Kq[0, 0] = -md.k * c12 * v[1] * v[1] + md.w1 * math.sin(q[0])
    Kq[0, 1] = md.k * c12 * v[1] * v[1]
    Kq[1, 0] = md.k * c12 * v[0] * v[0]
    Kq[1, 1] = -md.k * c12 * v[0] * v[0] + md.w2 * math.sin(q[1])
    Kv[0, 1] = -2.0 * md.k * s12 * v[1]
    Kv[1, 0] = 2.0 * md.k * s12 * v[0]


@njit(cache=True)
def _mass_jacobian_product(md, q, a, K):
    s21 = math.sin(q[1] - q[0])
    for i in range(3):
        for j in range(3):
            K[i, j] = 0.0
    K[0, 0] = md.k * s21 * a[1]
    K[0, 1] = -md.k * s21 * a[1]
    K[1, 0] = md.k * s21 * a[0]
    K[1, 1] = -md.k * s21 * a[0]


@njit(cache=True)
def _gap(md, i, q, v, gq):
    p, r, side = md.points[i, 0], md.points[i, 1], md.points[i, 2]
    s1, c1 = math.sin(q[0]), math.cos(q[0])
    s2, c2 = math.sin(q[1]), math.cos(q[1])
    s3, c3 = math.sin(q[2]), math.cos(q[2])
    yc = md.l1 * s1 + md.l2 * s2 + p * s3 + r * c3
    gq[0] = -side * md.l1 * c1
    gq[1] = -side * md.l2 * c2
    gq[2] = -side * (p * c3 - r * s3)
    gam = -side * (md.l1 * s1 * v[0] * v[0] + md.l2 * s2 * v[1] * v[1] + (p * s3 + r * c3) * v[2] * v[2])
    return md.half_slot - side * yc, gam


@njit(cache=True)
def _tangent(md, i, q, v, tq):
    p, r = md.points[i, 0], md.points[i, 1]
    tq[0] = -md.l1 * math.sin(q[0])
    tq[1] = -md.l2 * math.sin(q[1])
    tq[2] = -(p * math.sin(q[2]) + r * math.cos(q[2]))
    return md.mu


kernels.register(SliderCrankData, mass_force=_mass_force, force_jacobian=_force_jacobian,
                 mass_jacobian_product=_mass_jacobian_product, gap=_gap, tangent=_tangent)


def corners(a: float, b: float) -> np.ndarray:
    """The slider's corners (p, r, side): upper wall first (−a, +a), then the lower one."""
    return np.array([[-a, b, 1.0], [a, b, 1.0], [-a, -b, -1.0], [a, -b, -1.0]])


def rigid_rod_rate(l1: float, l2: float, theta1: float, omega1: float) -> tuple[float, float]:
    """(θ2, θ̇2) of the rigid slider-crank (slider centre on the slot's axis, y3 = 0):
    θ2 = asin(−l1 sin θ1 / l2), θ̇2 = −l1 cos θ1 θ̇1 / (l2 cos θ2)."""
    th2 = math.asin(-l1 * math.sin(theta1) / l2)
    return th2, -l1 * math.cos(theta1) * omega1 / (l2 * math.cos(th2))


class SliderCrank(KernelSystem):
    """The slider-crank with a clearance joint (module docstring)."""

    n = 3
    n_bilateral = 0
    coordinate_names = ("theta1", "theta2", "theta3")
    power_free = True  # gravity only
    #: the reference is a fine Moreau–Jean run (daebench.harness.refcapture), also at μ = 0: the
    #: corners' bounces accumulate (e = 0.1) into chattering, which an event-driven run cuts off
    #: by closing the contact after an accumulation, an approximation of its own
    capturing_reference = ("chattering corners (e < 1): their accumulating impacts are resolved by event "
                           "capturing; an event-driven run closes the contact after an accumulation")

    def __init__(self, l1: float = 0.153, l2: float = 0.306, m1: float = 0.038, m2: float = 0.038,
                 m3: float = 0.076, J1: float = 7.4e-5, J2: float = 5.9e-4, J3: float = 2.7e-6, a: float = 0.05,
                 b: float = 0.025, c: float = 0.001, g: float = 9.81, theta0_deg: float = 0.0,
                 omega0: float = 150.0, contact: bool = True, law: Any = None, restitution: float = 0.1,
                 friction: float = 0.0) -> None:
        self.l1, self.l2, self.m1, self.m2, self.m3 = float(l1), float(l2), float(m1), float(m2), float(m3)
        self.J1, self.J2, self.J3 = float(J1), float(J2), float(J3)
        self.a, self.b, self.c, self.g = float(a), float(b), float(c), float(g)
        self.mu = float(friction)
        self.points = corners(self.a, self.b)
        th1 = math.radians(theta0_deg)
        th2, om2 = rigid_rod_rate(self.l1, self.l2, th1, float(omega0))
        self.q0 = np.array([th1, th2, 0.0])
        self.v0 = np.array([float(omega0), om2, 0.0])
        self.n_contacts = 4 if contact else 0
        self.contact_law = law if contact else None
        self.contact_restitution = float(restitution)
        self.data = SliderCrankData(
            self.l1, self.l2, self.J1 + (0.25 * self.m1 + self.m2 + self.m3) * self.l1 ** 2,
            self.J2 + (0.25 * self.m2 + self.m3) * self.l2 ** 2, self.J3, (0.5 * self.m2 + self.m3) * self.l1 * self.l2,
            (0.5 * self.m1 + self.m2 + self.m3) * self.g * self.l1, (0.5 * self.m2 + self.m3) * self.g * self.l2,
            self.b + self.c, self.mu if contact else 0.0, self.points)

    def corner_gaps(self, q: np.ndarray) -> np.ndarray:
        """Gap of every corner (whether or not contacts are on)."""
        s3, c3 = math.sin(q[2]), math.cos(q[2])
        y3 = self.l1 * math.sin(q[0]) + self.l2 * math.sin(q[1])
        yc = y3 + self.points[:, 0] * s3 + self.points[:, 1] * c3
        return self.b + self.c - self.points[:, 2] * yc

    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        d = self.data
        kin = 0.5 * float(v @ self.mass(q) @ v)
        pot = d.w1 * math.sin(q[0]) + d.w2 * math.sin(q[1])
        return {"kinetic": kin, "gravity": pot}

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        l1, l2 = self.l1, self.l2
        s1, c1, s2, c2 = math.sin(q[0]), math.cos(q[0]), math.sin(q[1]), math.cos(q[1])
        return {"theta": float(q[0]), "omega": float(v[0]), "rod": float(q[1]), "psi": float(q[2]),
                "x": l1 * c1 + l2 * c2, "y": l1 * s1 + l2 * s2,
                "vx": -l1 * s1 * float(v[0]) - l2 * s2 * float(v[1]),
                "vy": l1 * c1 * float(v[0]) + l2 * c2 * float(v[1]), "psidot": float(v[2]),
                "gap": float(self.corner_gaps(q).min())}

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.q0.copy(), self.v0.copy()


def check_scene(scene: Scene) -> None:
    CONTACT.check(scene)
    if scene["crank.length"] >= scene["rod.length"]:
        raise SceneError(f"scene key 'crank.length' = {scene['crank.length']} m must be shorter than 'rod.length' "
                         f"= {scene['rod.length']} m (the crank could not turn a full revolution)")
    a, b, c = scene["slider.half_length"], scene["slider.half_width"], scene["clearance.c"]
    if c > 0.5 * b or c > 0.5 * a:
        raise SceneError(f"scene key 'clearance.c' = {c} m is not small beside the slider (a = {a} m, b = {b} m): "
                         f"the corner contacts describe a slider that cannot turn in its slot; keep c ≤ "
                         f"{0.5 * min(a, b):g} m")


def build(scene: Scene) -> SliderCrank:
    s = scene
    check_scene(s)
    return SliderCrank(l1=s["crank.length"], l2=s["rod.length"], m1=s["crank.mass"], m2=s["rod.mass"],
                       m3=s["slider.mass"], J1=s["crank.inertia"], J2=s["rod.inertia"], J3=s["slider.inertia"],
                       a=s["slider.half_length"], b=s["slider.half_width"], c=s["clearance.c"], g=s["gravity.g"],
                       theta0_deg=s["start.theta"], omega0=s["start.omega"], contact=s["effects.contact"],
                       law=CONTACT.law(s, 4), restitution=s["contact.restitution"], friction=s["contact.friction"])
