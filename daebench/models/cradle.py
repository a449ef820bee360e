"""Newton's cradle on a line: N equal balls, the first strikes the row of the others at
rest and touching — the simultaneous-impact benchmark.

Coordinates: the displacements u_i of the balls from their places in the row (ball i
at rest at i·d, d the diameter; the striker starts at −s, s the initial gap), so the gaps
are exactly zero where balls touch::

    M = m I,   Q = 0,   g_0 = u_1 − u_0 (+ s),   g_i = u_{i+1} − u_i   (i = 1 … N − 2)

When the striker arrives every contact of the row is closed at once: the outcome depends
on the impact law, not on the equations of motion. With e = 1 and equal masses:

* the **simultaneous** Newton law (all contacts of the row at once, complementarity
  U_i⁺ + e U_i⁻ ≥ 0 ⟂ P_i ≥ 0 — the LCP of the event-capturing schemes): for N = 3 the
  balls leave at (−1/3, 2/3, 2/3) v (kinetic energy and momentum conserved, the last two
  together);
* the **sequential** law (one contact after the other, each a two-ball impact): the
  striker stops and the last ball leaves at v — what a real cradle shows.

Closed forms: :func:`simultaneous_outcome` (the LCP solved by enumeration, any N, e) and
:func:`sequential_outcome`. Scene: ``cases/newton-cradle.toml``.
"""

from __future__ import annotations

import itertools
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from daebench.core import kernels
from daebench.core.contact import contact_schema
from daebench.core.observables import Observable
from daebench.core.params import Param
from daebench.core.scene import Scene
from daebench.core.system import KernelSystem

DESCRIPTION = "Newton's cradle: N equal balls on a line, one strikes the touching row (simultaneous impacts)"

CONTACT = contact_schema(("constraint", "complementarity"), restitution=1.0, impact_law=True)
MAX_BALLS = 12

SCHEMA: dict[str, Param] = {
    p.name: p
    for p in (
        Param("cradle.balls", int, 3, "number of balls N (the striker and the row)", low=2, high=MAX_BALLS),
        Param("cradle.mass", float, 0.1, "mass of each ball", low=1e-9, high=1e9, unit="kg"),
        Param("cradle.diameter", float, 0.05, "diameter of the balls", low=1e-6, high=1e3, unit="m"),
        Param("start.gap", float, 0.01, "initial gap between the striker and the row", low=0.0, high=1e3,
              unit="m"),
        Param("start.speed", float, 1.0, "initial speed of the striker towards the row", low=0.0, high=1e4,
              unit="m/s"),
        Param("effects.contact", bool, True, "the contacts (off: the balls pass through each other)"),
        *CONTACT.params,
    )
}


class CradleData(NamedTuple):
    m: float
    gap0: float


@njit(cache=True)
def _mass_force(md, t, q, v, M, Q):
    n = q.shape[0]
    for i in range(n):
        Q[i] = 0.0
        for j in range(n):
            M[i, j] = md.m if i == j else 0.0


@njit(cache=True)
def _force_jacobian(md, t, q, v, Kq, Kv):
    Kq[:, :] = 0.0
    Kv[:, :] = 0.0


@njit(cache=True)
def _gap(md, i, q, v, gq):
    gq[:] = 0.0
    gq[i] = -1.0
    gq[i + 1] = 1.0
    return q[i + 1] - q[i] + (md.gap0 if i == 0 else 0.0), 0.0


kernels.register(CradleData, mass_force=_mass_force, force_jacobian=_force_jacobian,
                 mass_jacobian_product=kernels.constant_mass, gap=_gap)


def _observables(n: int) -> tuple[Observable, ...]:
    out = []
    for i in range(1, n + 1):
        out += [Observable(f"x{i}", "m", f"u{i}", derivative=f"v{i}"), Observable(f"v{i}", "m/s", f"v{i}")]
    return tuple(out)


OBSERVABLES = _observables(MAX_BALLS)


class Cradle(KernelSystem):
    """N equal balls on a line (module docstring)."""

    n_bilateral = 0
    power_free = True

    def __init__(self, balls: int = 3, mass: float = 0.1, diameter: float = 0.05, gap: float = 0.01,
                 speed: float = 1.0, contact: bool = True, law: Any = None, restitution: float = 1.0) -> None:
        self.n = int(balls)
        self.m, self.d, self.s, self.v0 = float(mass), float(diameter), float(gap), float(speed)
        self.coordinate_names = tuple(f"u{i}" for i in range(1, self.n + 1))
        self.n_contacts = self.n - 1 if contact else 0
        self.contact_law = law if contact else None
        self.contact_restitution = float(restitution)
        self.data = CradleData(self.m, self.s)

    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {"kinetic": 0.5 * self.m * float(np.dot(v, v))}

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        out = {}
        for i in range(self.n):
            out[f"x{i + 1}"] = float(q[i])
            out[f"v{i + 1}"] = float(v[i])
        return out

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        v = np.zeros(self.n)
        v[0] = self.v0
        return np.zeros(self.n), v


def build(scene: Scene) -> Cradle:
    s = scene
    n = s["cradle.balls"]
    return Cradle(balls=n, mass=s["cradle.mass"], diameter=s["cradle.diameter"], gap=s["start.gap"],
                  speed=s["start.speed"], contact=s["effects.contact"], law=CONTACT.law(s, n - 1),
                  restitution=s["contact.restitution"])


def check_scene(scene: Scene) -> None:
    CONTACT.check(scene)


# -- closed forms -------------------------------------------------------------------------
def simultaneous_outcome(n: int, v0: float, e: float) -> np.ndarray:
    """Velocities after the simultaneous Newton impact of a striker at v0 on a touching row
    of n − 1 equal balls at rest: the LCP 0 ≤ U⁺ + e U⁻ ⟂ P ≥ 0 (U_i = v_{i+1} − v_i),
    solved by enumerating the active sets (exact for the few balls of a cradle)."""
    vm = np.zeros(n)
    vm[0] = v0
    G = np.zeros((n - 1, n))
    for i in range(n - 1):
        G[i, i], G[i, i + 1] = -1.0, 1.0
    A = G @ G.T              # M = I (equal masses: the outcome does not depend on m)
    b = G @ vm + e * (G @ vm)
    for k in range(n):
        for act in itertools.combinations(range(n - 1), k):
            P = np.zeros(n - 1)
            if act:
                idx = list(act)
                P[idx] = np.linalg.solve(A[np.ix_(idx, idx)], -b[idx])
            w = A @ P + b
            if P.min() >= -1e-12 and w.min() >= -1e-12:
                return vm + G.T @ P
    raise ValueError("no solution of the simultaneous impact LCP")


def sequential_outcome(n: int, v0: float, e: float = 1.0) -> np.ndarray:
    """Velocities after the sequential law (two-ball impacts in turn, along the row, and
    again until no pair approaches)."""
    v = np.zeros(n)
    v[0] = v0
    for _ in range(10 * n * n):
        approaching = [i for i in range(n - 1) if v[i] - v[i + 1] > 1e-14]
        if not approaching:
            return v
        i = approaching[0]
        vc = 0.5 * (v[i] + v[i + 1])
        v[i], v[i + 1] = vc - e * (v[i] - vc), vc - e * (v[i + 1] - vc)
    raise ValueError("sequential impacts did not end")
