"""One rigid body in the plane on a (possibly inclined) rigid ground, with Coulomb friction
at its contact points: the block on an incline, the rocking block, the falling rod.

Coordinates q = (x, y, θ) of the centre of mass in the ground's frame — x along the
ground (up the slope), y normal to it — and the body's rotation θ (counter-clockwise;
θ = 0: the body's height axis normal to the ground). Mass m, moment of inertia about the
centre J = m (w² + h²)/12 (a uniform rectangle w × h; a rod is w = 0, h its length). The
ground is inclined at φ, so gravity has components (−g sin φ, −g cos φ)::

    M = diag(m, m, J),      Q = (−m g sin φ, −m g cos φ, 0)

Contact points (body frame (p, r)): the four corners (±w/2, ±h/2) of a ``box``, the two
ends (0, ±h/2) of a ``rod``. For a point (p, r)::

    gap    g = y + p sin θ + r cos θ                    g_q = (0, 1, p cos θ − r sin θ)
    slip   U_T = ẋ − (p sin θ + r cos θ) θ̇              t_q = (1, 0, −(p sin θ + r cos θ))
    γ_g = (p sin θ + r cos θ) θ̇²                        (g̈ = g_q q̈ − γ_g)

Friction: Coulomb with coefficient μ = ``contact.friction`` at every contact point (the
``tangent`` kernel of :mod:`daebench.core.kernels`); the integrators that apply it
declare ``capabilities.friction`` (event-capturing Moreau–Jean). Restitution e of the
``constraint`` law (Newton, normal direction); ``complementarity`` leaves the contacts to
the integrator with e = 0; ``penalty`` and ``hertz`` are compliant ground contacts with
regularised Coulomb friction (:mod:`daebench.core.phase`), which every driver integrator runs.

Scenes: ``cases/block-incline.toml``, ``cases/rocking-block.toml``,
``cases/falling-rod.toml``; their closed forms are in :mod:`daebench.models.rigid2d_exact`.
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

DESCRIPTION = ("planar rigid body (box or rod) on inclined rigid ground with Coulomb friction: block on an "
               "incline, rocking block, falling rod; closed forms")

SHAPES = ("box", "rod")

CONTACT = contact_schema(("constraint", "complementarity", "hertz", "penalty"), friction=True)

OBSERVABLES = (
    Observable("x", "m", "x", derivative="vx", summary=True),
    Observable("y", "m", "y", derivative="vy", summary=True),
    Observable("theta", "rad", "θ", derivative="omega", impact_windows=True, summary=True),
    Observable("vx", "m/s", "ẋ"),
    Observable("vy", "m/s", "ẏ"),
    Observable("omega", "rad/s", "ω", impact_windows=True),
    Observable("gap", "m", "gap", height=True),
)

SCHEMA: dict[str, Param] = {
    p.name: p
    for p in (
        Param("body.shape", str, "box", "box: four corners touch; rod: its two ends", choices=SHAPES),
        Param("body.mass", float, 1.0, "mass", low=1e-9, high=1e9, unit="kg"),
        Param("body.width", float, 0.2, "width (box; a rod has none)", low=0.0, high=1e3, unit="m"),
        Param("body.height", float, 1.0, "height of the box, length of the rod", low=1e-6, high=1e3, unit="m"),
        Param("gravity.g", float, 9.81, "gravitational acceleration", low=0.0, high=1e4, unit="m/s²"),
        Param("ground.incline", float, 0.0, "inclination φ of the ground (x runs up the slope)", low=-80.0,
              high=80.0, unit="deg"),
        Param("start.x", float, 0.0, "centre of mass along the ground", low=-1e6, high=1e6, unit="m"),
        Param("start.gap", float, 0.0, "initial gap of the lowest contact point (sets y)", low=0.0, high=1e6,
              unit="m"),
        Param("start.theta", float, 0.0, "initial rotation θ (counter-clockwise)", low=-180.0, high=180.0,
              unit="deg"),
        Param("start.vx", float, 0.0, "initial velocity along the ground", low=-1e6, high=1e6, unit="m/s"),
        Param("start.vy", float, 0.0, "initial velocity normal to the ground", low=-1e6, high=1e6, unit="m/s"),
        Param("start.omega", float, 0.0, "initial angular velocity", low=-1e6, high=1e6, unit="rad/s"),
        Param("effects.contact", bool, True, "the ground (off: free flight)"),
        *CONTACT.params,   # contact.law, contact.restitution, contact.friction (μ at every contact point)
    )
}


class Rigid2dData(NamedTuple):
    """Kernel data (:mod:`daebench.core.kernels`)."""

    m: float
    J: float
    gx: float          # gravity components in the ground frame (m/s²)
    gy: float
    mu: float
    points: np.ndarray  # nc × 2: contact points (p, r) in the body frame


@njit(cache=True)
def _mass_force(md, t, q, v, M, Q):
    for i in range(3):
        for j in range(3):
            M[i, j] = 0.0
    M[0, 0] = md.m
    M[1, 1] = md.m
    M[2, 2] = md.J
    Q[0] = md.m * md.gx
    Q[1] = md.m * md.gy
    Q[2] = 0.0


@njit(cache=True)
def _force_jacobian(md, t, q, v, Kq, Kv):
    for i in range(3):
        for j in range(3):
            Kq[i, j] = 0.0
            Kv[i, j] = 0.0


@njit(cache=True)
def _gap(md, i, q, v, gq):
    p, r = md.points[i, 0], md.points[i, 1]
    s, c = math.sin(q[2]), math.cos(q[2])
    gq[0] = 0.0
    gq[1] = 1.0
    gq[2] = p * c - r * s
    lever = p * s + r * c
    return q[1] + lever, lever * v[2] * v[2]


@njit(cache=True)
def _tangent(md, i, q, v, tq):
    p, r = md.points[i, 0], md.points[i, 1]
    tq[0] = 1.0
    tq[1] = 0.0
    tq[2] = -(p * math.sin(q[2]) + r * math.cos(q[2]))
    return md.mu


kernels.register(Rigid2dData, mass_force=_mass_force, force_jacobian=_force_jacobian,
                 mass_jacobian_product=kernels.constant_mass, gap=_gap, tangent=_tangent)


def contact_points(shape: str, width: float, height: float) -> np.ndarray:
    """Body-frame contact points: a box's four corners (bottom two first), a rod's ends."""
    b, h = 0.5 * width, 0.5 * height
    if shape == "rod":
        return np.array([[0.0, -h], [0.0, h]])
    return np.array([[-b, -h], [b, -h], [b, h], [-b, h]])


class Rigid2d(KernelSystem):
    """A planar rigid body on inclined ground (module docstring)."""

    n = 3
    n_bilateral = 0
    coordinate_names = ("x", "y", "theta")
    power_free = True  # gravity only

    def __init__(self, shape: str = "box", mass: float = 1.0, width: float = 0.2, height: float = 1.0,
                 g: float = 9.81, incline_deg: float = 0.0, x0: float = 0.0, gap0: float = 0.0,
                 theta0_deg: float = 0.0, vx0: float = 0.0, vy0: float = 0.0, omega0: float = 0.0,
                 contact: bool = True, law: Any = None, restitution: float = 0.0,
                 friction: float = 0.0) -> None:
        self.shape = shape
        self.m = float(mass)
        self.width = 0.0 if shape == "rod" else float(width)
        self.height = float(height)
        self.J = self.m * (self.width ** 2 + self.height ** 2) / 12.0
        self.g = float(g)
        self.phi = math.radians(incline_deg)
        self.mu = float(friction)
        self.e = float(restitution)
        self.points = contact_points(shape, self.width, self.height)
        th = math.radians(theta0_deg)
        lowest = min(p * math.sin(th) + r * math.cos(th) for p, r in self.points)
        self.q0 = np.array([float(x0), float(gap0) - lowest, th])
        self.v0 = np.array([float(vx0), float(vy0), float(omega0)])
        self.n_contacts = len(self.points) if contact else 0
        self.contact_law = law if contact else None   # a ContactLaw (None: complementarity)
        self.contact_restitution = self.e
        self.data = Rigid2dData(self.m, self.J, -self.g * math.sin(self.phi), -self.g * math.cos(self.phi),
                                self.mu if contact else 0.0, self.points)

    def gaps(self, q: np.ndarray) -> np.ndarray:
        """Gap of every contact point (whether or not contacts are on)."""
        s, c = math.sin(q[2]), math.cos(q[2])
        return q[1] + self.points[:, 0] * s + self.points[:, 1] * c

    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        kin = 0.5 * self.m * (float(v[0]) ** 2 + float(v[1]) ** 2) + 0.5 * self.J * float(v[2]) ** 2
        pot = self.m * self.g * (float(q[0]) * math.sin(self.phi) + float(q[1]) * math.cos(self.phi))
        return {"kinetic": kin, "gravity": pot, "contact": self.contact_potential(q)}

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {"x": float(q[0]), "y": float(q[1]), "theta": float(q[2]), "vx": float(v[0]),
                "vy": float(v[1]), "omega": float(v[2]), "gap": float(self.gaps(q).min())}

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.q0.copy(), self.v0.copy()


def build(scene: Scene) -> Rigid2d:
    s = scene
    return Rigid2d(shape=s["body.shape"], mass=s["body.mass"], width=s["body.width"], height=s["body.height"],
                   g=s["gravity.g"], incline_deg=s["ground.incline"], x0=s["start.x"], gap0=s["start.gap"],
                   theta0_deg=s["start.theta"], vx0=s["start.vx"], vy0=s["start.vy"], omega0=s["start.omega"],
                   contact=s["effects.contact"], law=CONTACT.law(s, 2 if s["body.shape"] == "rod" else 4),
                   restitution=s["contact.restitution"], friction=s["contact.friction"])


def check_scene(scene: Scene) -> None:
    CONTACT.check(scene)
    if scene["body.shape"] == "box" and scene["body.width"] <= 0.0:
        raise SceneError(f"scene key 'body.width' = {scene['body.width']}: a box needs a width > 0 "
                         f"(or `--set body.shape=rod`)")
