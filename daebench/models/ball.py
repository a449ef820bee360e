"""A point mass on a line striking a rigid wall: the bouncing ball and the spring–wall
oscillator, with exact solutions (independent truth for contact schemes).

One coordinate x (height above the ground, or position along the spring axis), mass m,
gravity g along −x, an optional linear spring of stiffness k about x_r::

    m ẍ = −m g − k (x − x_r),        gap g(x) = x − x_w ≥ 0   (wall or ground at x_w)

Scenes: ``cases/ball.toml`` (k = 0: dropped from rest at height h0 above the ground,
restitution e) and ``cases/spring-wall.toml`` (g = 0, k > 0: a mass oscillating about
x_r strikes a wall at x_w < x_r with e = 1, so its energy is conserved).

Closed forms (:func:`ball_impacts` for the dropped ball): impact k (k = 1, 2, …) at
t_k = t_1 + (2 v_1/g) Σ_{j=1}^{k−1} e^j with t_1 = √(2 h0/g), v_1 = √(2 g h0); the apex
after impact k is e^{2k} h0; the impacts accumulate at t_1 + 2 e v_1 / (g (1−e)). For any
(k, g, e, start) :func:`exact_motion` propagates the piecewise analytic solution (parabola or
harmonic arc between impacts, v⁺ = −e v⁻ at each), used for trajectory errors.

Energy: E = ½ m v² + m g x + ½ k (x − x_r)², conserved between impacts.
"""

from __future__ import annotations

import math
from typing import Callable, NamedTuple

import numpy as np
from numba import njit

from daebench.core import kernels
from daebench.core.contact import contact_schema, make_contact_law
from daebench.core.observables import Observable
from daebench.core.params import Param
from daebench.core.scene import Scene, SceneError
from daebench.core.system import KernelSystem

DESCRIPTION = "point mass striking a wall: bouncing ball (restitution e) or spring–wall oscillator; exact solutions"

#: the history's columns as the scorer reads them (daebench.core.observables)
OBSERVABLES = (
    Observable("x", "m", "position", derivative="v", summary=True),
    Observable("v", "m/s", "velocity"),
    Observable("gap", "m", "gap", height=True),
)

#: ``penalty`` (F = k δ + c δ̇, :mod:`daebench.core.contact`) is the like-for-like law of a
#: compliant peer code; it has no exact solution here, so it is scored against an IDA reference.
#: Its defaults: k = 1e5 N/m (a contact lasting π √(m/k) ≈ 10 ms at m = 1 kg) and c = 45 N s/m,
#: the damping ratio ζ = c / (2 √(k m)) ≈ 0.071 whose linear-oscillator restitution
#: exp(−ζπ/√(1−ζ²)) ≈ 0.80 is the scene's default e
CONTACT = contact_schema(("constraint", "penalty", "complementarity"), restitution=0.8, penalty_stiffness=1e5,
                         penalty_damping=45.0)

SCHEMA: dict[str, Param] = {
    p.name: p
    for p in (
        Param("ball.mass", float, 1.0, "mass", low=1e-9, high=1e9, unit="kg"),
        Param("gravity.g", float, 9.81, "gravitational acceleration along −x", low=0.0, high=1e4, unit="m/s²"),
        Param("spring.stiffness", float, 0.0, "stiffness of the spring (0: none)", low=0.0, high=1e12, unit="N/m"),
        Param("spring.rest", float, 0.0, "position where the spring is relaxed", low=-1e6, high=1e6, unit="m"),
        Param("start.x", float, 1.0, "initial position (height above the ground)", low=-1e6, high=1e6, unit="m"),
        Param("start.v", float, 0.0, "initial velocity", low=-1e6, high=1e6, unit="m/s"),
        Param("effects.contact", bool, True, "the wall (off: the mass passes through)"),
        *CONTACT.params,
        Param("contact.wall", float, 0.0, "position of the wall (ground); gap = x − wall", low=-1e6, high=1e6,
              unit="m"),
    )
}


class BallData(NamedTuple):
    """Kernel data (:mod:`daebench.core.kernels`)."""

    m: float
    g: float
    k: float
    x_rest: float
    wall: float


@njit(cache=True)
def _mass_force(md, t, q, v, M, Q):
    if M.shape[0]:  # an M with no rows: the force only (central differences, with lumped_mass)
        M[0, 0] = md.m
    Q[0] = -md.m * md.g - md.k * (q[0] - md.x_rest)


@njit(cache=True)
def _force_jacobian(md, t, q, v, Kq, Kv):
    Kq[0, 0] = -md.k
    Kv[0, 0] = 0.0



@njit(cache=True)
def _gap(md, i, q, v, gq):
    gq[0] = 1.0
    return q[0] - md.wall, 0.0


kernels.register(BallData, mass_force=_mass_force, force_jacobian=_force_jacobian,
                 mass_jacobian_product=kernels.constant_mass, gap=_gap)


class Ball(KernelSystem):
    """Point mass on a line with gravity, an optional spring and a wall (module docstring)."""

    n = 1
    n_bilateral = 0
    coordinate_names = ("x",)
    power_free = True  # gravity and spring only

    def __init__(self, mass: float = 1.0, g: float = 9.81, stiffness: float = 0.0, rest: float = 0.0,
                 x0: float = 1.0, v0: float = 0.0, contact: bool = True, law: str = "constraint",
                 restitution: float = 0.8, wall: float = 0.0, penalty_stiffness: float = 0.0,
                 penalty_damping: float = 0.0) -> None:
        self.m, self.g, self.k, self.x_rest = float(mass), float(g), float(stiffness), float(rest)
        self.x0, self.v0, self.wall, self.e = float(x0), float(v0), float(wall), float(restitution)
        self.n_contacts = 1 if contact else 0
        self.contact_restitution = self.e
        self.contact_law = make_contact_law(law, self.e, 1, penalty_stiffness=penalty_stiffness,
                                            penalty_damping=penalty_damping) if contact else None
        self.data = BallData(self.m, self.g, self.k, self.x_rest, self.wall)

    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        x = float(q[0])
        return {"kinetic": 0.5 * self.m * float(v[0]) ** 2, "gravity": self.m * self.g * x,
                "elastic": 0.5 * self.k * (x - self.x_rest) ** 2}

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {"x": float(q[0]), "v": float(v[0]), "gap": float(q[0]) - self.wall}

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        return np.array([self.x0]), np.array([self.v0])

    @property
    def lumped_mass(self) -> np.ndarray:
        """The constant diagonal of M (the mass_force kernel accepts an M with no rows)."""
        return np.array([self.m])

    def _check_exact(self) -> None:
        """The closed forms hold for a rigid wall (Newton's law) only: a compliant law is
        scored against a reference (ValueError: the pipeline's 'no exact solution here')."""
        if self.n_contacts and getattr(self.contact_law, "continuous", False):
            raise ValueError(f"no exact solution for contact.law = '{self.contact_law.name}'")

    def exact_observables(self, t: np.ndarray) -> dict[str, np.ndarray]:
        """The observables' exact values at times ``t`` (:func:`exact_motion`; free flight
        without the wall): what runs are scored against."""
        t = np.asarray(t, float)
        self._check_exact()
        if self.n_contacts:
            _, at = exact_motion(self, float(t.max(initial=0.0)))
            x, v = at(t)
        else:
            x, v = _free(self, self.x0, self.v0, t)
        return {"x": x, "v": v, "gap": x - self.wall}

    def exact_impacts(self, t_end: float) -> list[float]:
        """The exact impact times up to ``t_end`` [s]."""
        self._check_exact()
        return [t for t, _, _ in exact_motion(self, t_end)[0]] if self.n_contacts else []


def build(scene: Scene) -> Ball:
    s = scene
    return Ball(mass=s["ball.mass"], g=s["gravity.g"], stiffness=s["spring.stiffness"], rest=s["spring.rest"],
                x0=s["start.x"], v0=s["start.v"], contact=s["effects.contact"], law=s["contact.law"],
                restitution=s["contact.restitution"], wall=s["contact.wall"],
                penalty_stiffness=s["contact.penalty_stiffness"], penalty_damping=s["contact.penalty_damping"])


def check_scene(scene: Scene) -> None:
    CONTACT.check(scene)
    if scene["effects.contact"] and scene["start.x"] < scene["contact.wall"]:
        raise SceneError(f"scene key 'start.x' = {scene['start.x']} is behind the wall at contact.wall = "
                         f"{scene['contact.wall']}; start at or above it")


# -- exact solutions ------------------------------------------------------------------------
def ball_impacts(h0: float, e: float, g: float, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Impact times t_k and apex heights e^{2k} h0 (k = 1 … count) of a ball dropped from
    rest at height h0 above the ground (closed form, module docstring)."""
    t1 = math.sqrt(2.0 * h0 / g)
    v1 = math.sqrt(2.0 * g * h0)
    k = np.arange(1, count + 1)
    flights = np.array([(2.0 * v1 / g) * e**j for j in range(1, count)])
    times = t1 + np.concatenate(([0.0], np.cumsum(flights)))
    return times, e ** (2 * k) * h0


def _free(ball: Ball, x0: float, v0: float, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Free motion from (x0, v0) after time t."""
    t = np.asarray(t, float)
    if ball.k == 0.0:
        return x0 + v0 * t - 0.5 * ball.g * t * t, v0 - ball.g * t
    w = math.sqrt(ball.k / ball.m)
    xe = ball.x_rest - ball.m * ball.g / ball.k
    y0 = x0 - xe
    return xe + y0 * np.cos(w * t) + v0 / w * np.sin(w * t), -y0 * w * np.sin(w * t) + v0 * np.cos(w * t)


def _next_impact(ball: Ball, x0: float, v0: float) -> float:
    """Time to the next arrival at the wall from (x0, v0) (inf if never)."""
    d = x0 - ball.wall
    if ball.k == 0.0:
        if ball.g == 0.0:
            return -d / v0 if v0 < 0.0 else math.inf
        disc = v0 * v0 + 2.0 * ball.g * d
        return (v0 + math.sqrt(max(disc, 0.0))) / ball.g
    w = math.sqrt(ball.k / ball.m)
    xe = ball.x_rest - ball.m * ball.g / ball.k
    y0, yw = x0 - xe, ball.wall - xe
    R = math.hypot(y0, v0 / w)
    if R == 0.0 or abs(yw) > R:
        return math.inf
    phi = math.atan2(v0 / w, y0)
    t = (phi + math.acos(max(-1.0, min(1.0, yw / R)))) / w
    while t <= 1e-12 / w:
        t += 2.0 * math.pi / w
    return t


def exact_motion(ball: Ball, t_end: float) -> tuple[list[tuple[float, float, float]], Callable]:
    """The exact piecewise motion up to t_end: impacts [(t, v⁻, v⁺)] and a function
    t ↦ (x, v) (arrays). A mass that stops on the wall (v⁺ = 0 under a force into it)
    rests there."""
    pieces = [(0.0, ball.x0, ball.v0)]
    impacts = []
    t, x, v = 0.0, ball.x0, ball.v0
    rest_at = math.inf
    while t < t_end and len(impacts) < 100000:
        dt = _next_impact(ball, x, v)
        if not math.isfinite(dt) or t + dt > t_end:
            break
        t += dt
        _, vm = _free(ball, x, v, dt)
        vm = float(vm)
        vp = -ball.e * vm
        impacts.append((t, vm, vp))
        x, v = ball.wall, vp
        pieces.append((t, x, v))
        force = -ball.m * ball.g - ball.k * (ball.wall - ball.x_rest)
        if vp < 1e-12 and force <= 0.0:
            rest_at = t
            break
    starts = np.array([p[0] for p in pieces])

    def at(times):
        times = np.atleast_1d(np.asarray(times, float))
        xs, vs = np.empty_like(times), np.empty_like(times)
        for j, tj in enumerate(times):
            if tj >= rest_at:
                xs[j], vs[j] = ball.wall, 0.0
                continue
            p = pieces[max(int(np.searchsorted(starts, tj, side="right")) - 1, 0)]
            xs[j], vs[j] = _free(ball, p[1], p[2], tj - p[0])
        return xs, vs

    return impacts, at
