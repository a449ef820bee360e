"""Two spring–mass chains striking each other (case ``chain-impact``).

Layout (this project's reading of the source's figure)::

    wall –k– m1 –k– m2 –k– m3 | m4 –k– m5 –k– m6 –k– wall

q = (x1, …, x6) are the displacements of the six masses from rest; at rest m3 and
m4 touch with zero force. The one contact point has the gap

    g(q) = x4 − x3 ≥ 0   (open),   g_q = [0, 0, −1, 1, 0, 0],   γ_g = 0,

so that a compressive normal force F ≥ 0 acts as g_qᵀ F (it pushes m3 left and m4
right). The spring forces are linear, Q = −K q, with K the stiffness matrix of the
two chains (no spring between m3 and m4). Start: m3 is pulled ``chain.pull`` to the
left and held; m1, m2 sit in the static equilibrium of the left chain (with equal
springs x1 = −pull/3, x2 = −2 pull/3); released at rest, or with the optional
velocity ``chain.velocity`` of m3 towards m4.

Energy: E = ½ m |v|² + ½ qᵀ K q + contact potential (Hertz: K_c δ^{n+1}/(n+1)).

Contact models (``contact.law``):

* ``hertz``: F = K_c δⁿ (1 + χ δ̇), damping law LN / HC / Flores / none (contact.py);
* ``penalty``: F = k δ + c δ̇;
* ``constraint``: unilateral constraint + Newton impact law, through the driver;
* ``complementarity``: the time-stepping linear-complementarity model of
  :mod:`daebench.integrators.lcp` (integrator ``lcp`` only). No continuous law is
  set (``contact_law = None``, the driver watches nothing); the integrator reads the
  gaps itself. The system says so in ``contact_model``. Other integrators would
  integrate this scene *without* contact; ``check_complementarity`` lets a caller
  refuse that (see the report to the driver's owner).

:func:`effective_restitution` turns a run's contact episodes into effective
coefficients of restitution.
"""

from __future__ import annotations

import math
from typing import Iterable

import numpy as np

from daebench.core.contact import contact_schema, make_contact_law
from daebench.core.observables import Observable
from daebench.core.params import Param
from daebench.core.scene import Scene, SceneError
from daebench.core.system import MechanicalSystem

DESCRIPTION = "two spring-mass chains (3 + 3 masses) striking each other: Hertz/penalty/constraint/LCP contact"

#: the history's columns as the scorer reads them (daebench.core.observables)
OBSERVABLES = (Observable("gap", "m", "gap between the chains", height=True),)

CONTACT = contact_schema(("hertz", "penalty", "constraint", "complementarity"), exponent=True, law="hertz",
                         restitution=0.8, hertz_stiffness=140e6)

SCHEMA: dict[str, Param] = {
    p.name: p
    for p in (
        Param("chain.mass", float, 1.0, "mass of each of the six bodies", low=1e-9, high=1e9, unit="kg"),
        Param("chain.stiffness", float, 1e4, "stiffness of each spring (0: free masses)", low=0.0, high=1e15,
              unit="N/m"),
        Param("chain.pull", float, 0.03, "m3 pulled this far to the left, held in static equilibrium, released",
              low=0.0, high=1e3, unit="m"),
        Param("chain.velocity", float, 0.0, "initial velocity of m3 towards m4 (the paper: 0)", low=-1e6,
              high=1e6, unit="m/s"),
        Param("effects.contact", bool, True, "contact between m3 and m4 (off: they pass through)"),
        *CONTACT.params,
    )
}


def check_scene(scene: Scene) -> None:
    """Cross-key checks; raise :class:`SceneError` naming the key and the fix."""
    CONTACT.check(scene)


def build(scene: Scene) -> "Chain":
    """The chain system a scene describes."""
    s = scene
    return Chain(mass=s["chain.mass"], stiffness=s["chain.stiffness"], pull=s["chain.pull"],
                 velocity=s["chain.velocity"], contact=s["effects.contact"], law=s["contact.law"],
                 restitution=s["contact.restitution"], hertz_stiffness=s["contact.hertz_stiffness"],
                 hertz_exponent=s["contact.hertz_exponent"], hertz_damping=s["contact.hertz_damping"],
                 penalty_stiffness=s["contact.penalty_stiffness"], penalty_damping=s["contact.penalty_damping"])


def stiffness_matrix(k: float) -> np.ndarray:
    """K of wall–k–m1–k–m2–k–m3 and m4–k–m5–k–m6–k–wall (6 × 6)."""
    K = np.zeros((6, 6))
    for i, j in ((0, 1), (1, 2), (3, 4), (4, 5)):
        K[i, i] += k
        K[j, j] += k
        K[i, j] -= k
        K[j, i] -= k
    K[0, 0] += k  # wall spring of m1
    K[5, 5] += k  # wall spring of m6
    return K


class Chain(MechanicalSystem):
    """Six masses on a line in two chains, one contact point between m3 and m4."""

    n = 6
    n_bilateral = 0
    coordinate_names = ("x1", "x2", "x3", "x4", "x5", "x6")
    power_free = True  # springs only; contact dissipation is the law's, booked by the driver

    def __init__(self, mass: float = 1.0, stiffness: float = 1e4, pull: float = 0.03, velocity: float = 0.0,
                 contact: bool = True, law: str = "hertz", restitution: float = 0.8,
                 hertz_stiffness: float = 140e6, hertz_exponent: float = 1.5,
                 hertz_damping: str = "lankarani-nikravesh", penalty_stiffness: float = 0.0,
                 penalty_damping: float = 0.0) -> None:
        self.m = float(mass)
        self.k = float(stiffness)
        self.pull = float(pull)
        self.velocity = float(velocity)
        self.K = stiffness_matrix(self.k)
        self._M = self.m * np.eye(6)
        self._G = np.array([[0.0, 0.0, -1.0, 1.0, 0.0, 0.0]])
        self._zero = np.zeros((6, 6))
        self.n_contacts = 1 if contact else 0
        # "law": a continuous force or the driver's constraint; "integrator": an integrator
        # that treats the contact itself (complementarity); "none": no contact
        self.contact_model = "none" if not contact else law
        self.contact_restitution = float(restitution)
        self.contact_law = make_contact_law(law, restitution, 1, hertz_stiffness=hertz_stiffness,
                                            hertz_damping=hertz_damping, hertz_exponent=hertz_exponent,
                                            penalty_stiffness=penalty_stiffness,
                                            penalty_damping=penalty_damping) if contact else None

    # -- dynamics ---------------------------------------------------------------
    def mass(self, q: np.ndarray) -> np.ndarray:
        return self._M

    def applied_force(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return -(self.K @ q)

    def force_jacobian(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(∂Q/∂q, ∂Q/∂v) = (−K, 0): linear springs (the contact force is the phase's)."""
        return -self.K, self._zero

    def mass_jacobian_product(self, q: np.ndarray, a: np.ndarray) -> np.ndarray:
        return self._zero

    # -- contact -------------------------------------------------------------------
    def gap(self, q: np.ndarray) -> np.ndarray:
        if not self.n_contacts:
            return np.zeros(0)
        return np.array([q[3] - q[2]])

    def gap_jacobian(self, q: np.ndarray) -> np.ndarray:
        return self._G.copy() if self.n_contacts else np.zeros((0, 6))

    def gap_gamma(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.zeros(self.n_contacts)

    # -- bookkeeping -------------------------------------------------------------------
    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {"kinetic": 0.5 * self.m * float(v @ v), "elastic": 0.5 * float(q @ self.K @ q),
                "contact": self.contact_potential(q)}

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        """x1..x6, v3, v4 and the gap. The contact force is recorded by the driver:
        ``contact_force_0`` for a continuous law, ``lambda_0`` for the constraint law."""
        out = {f"x{i + 1}": float(q[i]) for i in range(6)}
        out.update(v3=float(v[2]), v4=float(v[3]), gap=float(q[3] - q[2]))
        return out

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        q = np.zeros(6)
        q[2] = -self.pull
        if self.k > 0.0:
            # static equilibrium of m1, m2 with x3 held: K[:2,:2] x12 = −K[:2,2] x3
            q[:2] = np.linalg.solve(self.K[:2, :2], -self.K[:2, 2] * q[2])
        else:
            q[:2] = q[2] * np.array([1.0, 2.0]) / 3.0  # any placement is in equilibrium; keep the spring one
        v = np.zeros(6)
        v[2] = self.velocity
        return q, v


def effective_restitution(impacts: Iterable, episode: int = 0) -> float:
    """Effective coefficient of restitution e_eff = ġ⁺ / (−ġ⁻) of one contact episode.

    Parameters
    ----------
    impacts : iterable of :class:`daebench.driver.simulate.Impact`
        ``RunResult.impacts`` (continuous laws: ġ⁻ at first touch, ġ⁺ at separation;
        constraint law: before/after the impact map) or the ``impacts`` list of the
        ``lcp`` integrator (ġ at the start of the first and the end of the last step
        with a positive contact impulse).
    episode : int
        Which episode (0: the first).

    Returns
    -------
    float
        NaN if there is no such complete episode. Here ġ = v4 − v3: the relative
        velocity of m4 with respect to m3.
    """
    imps = [i for i in impacts if i.contact == 0]
    if len(imps) <= episode:
        return math.nan
    imp = imps[episode]
    if not (math.isfinite(imp.vn_minus) and math.isfinite(imp.vn_plus)) or imp.vn_minus >= 0.0:
        return math.nan
    return float(imp.vn_plus / -imp.vn_minus)


def energetic_restitution(impact, m_eff: float) -> float:
    """e_E = √(1 − D / (½ m_eff ġ⁻²)) from the energy D dissipated in a contact episode:
    free of the work the chain springs do while the contact lasts (m_eff = m/2 for two
    equal masses)."""
    T = 0.5 * m_eff * impact.vn_minus**2
    if not (T > 0.0 and math.isfinite(impact.energy_loss)):
        return math.nan
    return float(math.sqrt(max(0.0, 1.0 - impact.energy_loss / T)))
