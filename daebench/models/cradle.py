"""Newton's cradle and granular chains on a line: N balls, the first strikes the row of the
others at rest and touching — the simultaneous- and multiple-impact benchmark.

Coordinates: the displacements u_i of the balls from their places in the row (ball i
at rest touching its neighbours; the striker starts at −s, s the initial gap), so the
gaps are exactly zero where balls touch::

    M = diag(m_i),   Q = 0,   g_0 = u_1 − u_0 (+ s),   g_i = u_{i+1} − u_i   (i = 1 … N − 2)

Balls: radius R_1 = ``cradle.diameter``/2 for the striker and R_{i+1} = r R_i along the
chain (``cradle.ratio`` r; r < 1 a tapered chain); masses ``cradle.mass`` for the first
and in proportion to the volume for the others, or ρ (4/3)π R_i³ when ``cradle.density``
ρ > 0. Equal balls (r = 1) are the cradle's default.

When the striker arrives every contact of the row is closed at once: the outcome depends
on the impact law, not on the equations of motion. With e = 1 and equal masses:

* the **simultaneous** Newton law (all contacts of the row at once, complementarity
  U_i⁺ + e U_i⁻ ≥ 0 ⟂ P_i ≥ 0 — the LCP of the event-capturing schemes): for N = 3 the
  balls leave at (−1/3, 2/3, 2/3) v (kinetic energy and momentum conserved, the last two
  together);
* the **sequential** law (one contact after the other, each a two-ball impact): the
  striker stops and the last ball leaves at v — what a Newton's cradle shows;
* the **compliant** chain (``contact.law = hertz``): each contact a Hertz spring
  F_i = K_i δ_i^{3/2} (1 + χ δ̇_i), integrated in time; a wave runs down the chain and
  leaves most of the energy in the last ball (Nesterenko's solitary wave);
* the **LZB** multiple-impact law (``contact.impact_law = lzb``, :mod:`daebench.core.lzb`):
  the same wave at the impulse level, from the contacts' stiffness ratios.

Hertz stiffness of the contact of balls i and i + 1 (same material)::

    K_i = (4/3) E* √R*_i,   1/E* = 2 (1 − ν²)/E,   1/R*_i = 1/R_i + 1/R_{i+1}

from ``cradle.modulus`` E and ``cradle.poisson`` ν, or ``contact.hertz_stiffness`` for
every contact when it is > 0 (:func:`hertz_stiffness`; :attr:`Cradle.contact_stiffness`).
The compliant law's force takes one K (:mod:`daebench.core.phase`); contacts of a tapered
chain, whose K_i differ, measure their gap in units scaled by s_i = (K_i/K_0)^{1/(n+1)}, so
that K_0 (s_i δ_i)ⁿ s_i = K_i δ_iⁿ is their force and K_i δ_i^{n+1}/(n+1) their potential
(the hysteresis term χ δ̇ is unchanged by the scaling); their ġ in the episode records is
scaled alike. Under the constraint law gaps are unscaled.

The LZB law's accuracy target is ``contact.lzb_accuracy`` (relative to the striker's speed;
it sets the law's step in impulse). A chain is scored per ball (x_i, v_i) and on its final
velocity distribution (:func:`final_velocities`).

Closed forms: :func:`simultaneous_outcome` (the LCP solved by enumeration, any N, e),
:func:`sequential_outcome` and :func:`two_ball_outcome` (Newton's law of two balls).
Scenes: ``cases/newton-cradle.toml``, ``cases/hertz-chain.toml``, ``cases/tapered-chain.toml``.
"""

from __future__ import annotations

import itertools
import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from daebench.core import kernels
from daebench.core.contact import contact_schema
from daebench.core.lzb import ACCURACY
from daebench.core.observables import Observable
from daebench.core.params import Param
from daebench.core.scene import Scene
from daebench.core.system import KernelSystem

DESCRIPTION = ("Newton's cradle and granular chains: N balls on a line, one strikes the touching row "
               "(simultaneous and multiple impacts; Hertz contacts, LZB law)")

CONTACT = contact_schema(("constraint", "hertz", "complementarity"), exponent=True, restitution=1.0,
                         impact_law=True, hertz_rule="Hertz's formula from the radii of the two balls, "
                         "cradle.modulus and cradle.poisson")
MAX_BALLS = 100
MAX_MASS_RATIO = 1e9     # heaviest over lightest ball (check_scene): 7 of float64's 16 digits are left
MAX_MASS_DECADES = math.log10(MAX_MASS_RATIO)

SCHEMA: dict[str, Param] = {
    p.name: p
    for p in (
        Param("cradle.balls", int, 3, "number of balls N (the striker and the row)", low=2, high=MAX_BALLS),
        Param("cradle.mass", float, 0.1, "mass of each ball (with cradle.ratio ≠ 1: of the striker, the others "
              "in proportion to their volume); unused when cradle.density > 0", low=1e-9, high=1e9, unit="kg"),
        Param("cradle.diameter", float, 0.05, "diameter of the balls (with cradle.ratio ≠ 1: of the striker); "
              "the radius R = diameter/2", low=1e-6, high=1e3, unit="m"),
        Param("cradle.ratio", float, 1.0, "radius of each ball over that of the one before it (< 1: a tapered "
              "chain)", low=0.05, high=20.0),
        Param("cradle.density", float, 0.0, "density ρ of the balls: masses ρ (4/3)π R³ (0: from cradle.mass)",
              low=0.0, high=1e6, unit="kg/m^3"),
        Param("cradle.modulus", float, 203e9, "Young's modulus E of the balls (Hertz stiffness)", low=1.0,
              high=1e15, unit="Pa"),
        Param("cradle.poisson", float, 0.3, "Poisson's ratio ν of the balls (Hertz stiffness)", low=0.0,
              high=0.4999),
        Param("start.gap", float, 0.01, "initial gap between the striker and the row", low=0.0, high=1e3,
              unit="m"),
        Param("start.speed", float, 1.0, "initial speed of the striker towards the row", low=0.0, high=1e4,
              unit="m/s"),
        Param("effects.contact", bool, True, "the contacts (off: the balls pass through each other)"),
        *CONTACT.params,
        Param("contact.lzb_accuracy", float, ACCURACY, "contact.impact_law = lzb: accuracy target of the "
              "post-impact velocities relative to the fastest approach speed (sets the step in impulse, "
              "daebench.core.lzb)", low=1e-13, high=0.1),
    )
}


class CradleData(NamedTuple):
    m: np.ndarray      # mass per ball
    gap0: float        # initial gap of contact 0
    scale: np.ndarray  # gap scale s_i per contact (1 but for a tapered chain's compliant contacts)


@njit(cache=True)
def _mass_force(md, t, q, v, M, Q):
    n = q.shape[0]
    for i in range(n):
        Q[i] = 0.0
        for j in range(n):
            M[i, j] = md.m[i] if i == j else 0.0


@njit(cache=True)
def _force_jacobian(md, t, q, v, Kq, Kv):
    Kq[:, :] = 0.0
    Kv[:, :] = 0.0


@njit(cache=True)
def _gap(md, i, q, v, gq):
    s = md.scale[i]
    gq[:] = 0.0
    gq[i] = -s
    gq[i + 1] = s
    return s * (q[i + 1] - q[i] + (md.gap0 if i == 0 else 0.0)), 0.0


kernels.register(CradleData, mass_force=_mass_force, force_jacobian=_force_jacobian,
                 mass_jacobian_product=kernels.constant_mass, gap=_gap)


def _observables(n: int) -> tuple[Observable, ...]:
    out = []
    for i in range(1, n + 1):
        out += [Observable(f"x{i}", "m", f"u{i}", derivative=f"v{i}"), Observable(f"v{i}", "m/s", f"v{i}")]
    return tuple(out)


OBSERVABLES = _observables(MAX_BALLS)


def radii(balls: int, diameter: float, ratio: float = 1.0) -> np.ndarray:
    """R_i = (diameter/2) ratio^(i−1), i = 1 … N."""
    return 0.5 * diameter * ratio ** np.arange(balls, dtype=float)


def masses(r: np.ndarray, mass: float, density: float = 0.0) -> np.ndarray:
    """ρ (4/3)π R_i³ for density ρ > 0, else ``mass`` for the first ball and the others in
    proportion to their volume."""
    if density > 0.0:
        return density * 4.0 / 3.0 * math.pi * r ** 3
    return mass * (r / r[0]) ** 3


def hertz_stiffness(r: np.ndarray, modulus: float, poisson: float) -> np.ndarray:
    """K_i = (4/3) E* √R*_i of the contacts of neighbouring balls of radii ``r`` (module docstring)."""
    e_star = modulus / (2.0 * (1.0 - poisson ** 2))
    r_star = r[:-1] * r[1:] / (r[:-1] + r[1:])
    return 4.0 / 3.0 * e_star * np.sqrt(r_star)


class Cradle(KernelSystem):
    """N balls on a line (module docstring). ``mass`` and ``diameter``: of each ball (a
    number) or per ball (an array); ``stiffness``: the Hertz K_i per contact (a number for
    all, or an array; 0: none declared); ``exponent``: the Hertz exponent n; ``lzb_accuracy``:
    the LZB law's accuracy target."""

    n_bilateral = 0
    power_free = True

    def __init__(self, balls: int = 3, mass: Any = 0.1, diameter: Any = 0.05, gap: float = 0.01,
                 speed: float = 1.0, contact: bool = True, law: Any = None, restitution: float = 1.0,
                 stiffness: Any = 0.0, exponent: float = 1.5, lzb_accuracy: float = ACCURACY) -> None:
        self.n = int(balls)
        self.masses = np.broadcast_to(np.asarray(mass, float), (self.n,)).copy()
        self.diameters = np.broadcast_to(np.asarray(diameter, float), (self.n,)).copy()
        self.m, self.d = float(self.masses[0]), float(self.diameters[0])
        self.s, self.v0 = float(gap), float(speed)
        self.coordinate_names = tuple(f"u{i}" for i in range(1, self.n + 1))
        self.n_contacts = self.n - 1 if contact else 0
        self.contact_law = law if contact else None
        self.contact_restitution = float(restitution)
        #: Hertz stiffness K_i per contact and exponent n (the LZB law's stiffness ratios)
        self.contact_stiffness = np.broadcast_to(np.asarray(stiffness, float), (self.n - 1,)).copy()
        self.contact_exponent = float(exponent)
        self.lzb_accuracy = float(lzb_accuracy)  # the LZB law's accuracy target (daebench.core.lzb)
        scale = np.ones(self.n - 1)
        if law is not None and law.continuous and self.contact_stiffness[0] > 0.0:
            scale = (self.contact_stiffness / law.stiffness) ** (1.0 / (law.exponent + 1.0))
        self.data = CradleData(self.masses, self.s, scale)

    def output_rows(self, t: np.ndarray, q: np.ndarray, v: np.ndarray) -> tuple[dict[str, np.ndarray],
                                                                               dict[str, np.ndarray]]:
        """(observables, energy terms) as columns over the rows of (q, v): the one rule of
        :meth:`observables` and :meth:`energy` (:class:`~daebench.core.system.MechanicalSystem`)."""
        q, v = np.atleast_2d(q), np.atleast_2d(v)
        obs = {}
        for i in range(self.n):
            obs[f"x{i + 1}"] = q[:, i]
            obs[f"v{i + 1}"] = v[:, i]
        terms = {"kinetic": 0.5 * ((v * v) @ self.masses)}
        if self.contact_law is not None and self.contact_law.continuous:
            terms["contact"] = self.contact_potential_rows(q)
        return obs, terms

    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {k: float(x[0]) for k, x in self.output_rows(np.zeros(1), q, v)[1].items()}

    def momentum(self, v: np.ndarray) -> float:
        """Σ m_i v_i (conserved: no force acts on the chain from outside)."""
        return float(self.masses @ v)

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {k: float(x[0]) for k, x in self.output_rows(np.full(1, float(t)), q, v)[0].items()}

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        v = np.zeros(self.n)
        v[0] = self.v0
        return np.zeros(self.n), v


def build(scene: Scene) -> Cradle:
    s = scene
    n = s["cradle.balls"]
    r = radii(n, s["cradle.diameter"], s["cradle.ratio"])
    k = s["contact.hertz_stiffness"] or hertz_stiffness(r, s["cradle.modulus"], s["cradle.poisson"])
    k = np.broadcast_to(np.asarray(k, float), (n - 1,))
    return Cradle(balls=n, mass=masses(r, s["cradle.mass"], s["cradle.density"]), diameter=2.0 * r,
                  gap=s["start.gap"], speed=s["start.speed"], contact=s["effects.contact"],
                  law=CONTACT.law(s, n - 1, hertz_stiffness=float(k[0])), restitution=s["contact.restitution"],
                  stiffness=k, exponent=s["contact.hertz_exponent"], lzb_accuracy=s["contact.lzb_accuracy"])


def check_scene(scene: Scene) -> None:
    """The contact keys' checks, and masses that float64 arithmetic survives: the heaviest
    ball at most :data:`MAX_MASS_RATIO` times the lightest (the masses go as ratio^(3(i−1)):
    ratio 20 with 100 balls overflowed, 0.05 underflowed to a singular mass matrix)."""
    from daebench.core.scene import SceneError  # core: the scene module reads models' schemas

    CONTACT.check(scene)
    n, ratio = scene["cradle.balls"], scene["cradle.ratio"]
    decades = 3.0 * (n - 1) * abs(math.log10(ratio))
    if decades > MAX_MASS_DECADES:
        most = 1 + int(MAX_MASS_DECADES / (3.0 * abs(math.log10(ratio))))
        lo, hi = 10.0 ** (-MAX_MASS_DECADES / (3.0 * (n - 1))), 10.0 ** (MAX_MASS_DECADES / (3.0 * (n - 1)))
        raise SceneError(f"cradle.ratio = {ratio:g} with cradle.balls = {n} makes the last ball's mass "
                         f"1e{'-' if ratio < 1 else ''}{decades:.0f} times the striker's (ratio^(3(N−1))); at most "
                         f"{MAX_MASS_RATIO:.0e} either way is computed (beyond it the impact laws' solves lose more "
                         f"than 9 of float64's 16 digits; beyond 1e308 the masses overflow): with {n} balls keep cradle.ratio in [{lo:.4g}, {hi:.4g}], "
                         f"or with ratio {ratio:g} use at most {most} balls")


def final_velocities(history: Any) -> np.ndarray:
    """The balls' velocities v1 … vN in the last row of a run's history: the final velocity
    distribution a chain is scored on (every ball's, against the reference's)."""
    n = sum(1 for c in history.columns if c.startswith("v") and c[1:].isdigit())
    return history[[f"v{i}" for i in range(1, n + 1)]].values[-1].astype(float)


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


def two_ball_outcome(m1: float, m2: float, v1: float, v2: float, e: float) -> tuple[float, float]:
    """Newton's law for two balls on a line (restitution e, the energetic one too: with no
    friction the two coincide): the velocities after the impact of ball 1 at v1 on ball 2 at v2."""
    vc = (m1 * v1 + m2 * v2) / (m1 + m2)
    return vc - e * (v1 - vc), vc - e * (v2 - vc)
