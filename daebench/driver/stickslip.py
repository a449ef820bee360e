"""Stick and slip of the driver's closed contacts with Coulomb friction (μ > 0): the phase an
integrator sees while such contacts are closed, and the rules that switch them.

The mechanism, and why it is this one
-------------------------------------
A closed contact is already a constraint row of the phase (C = −g, :mod:`daebench.core.phase`);
friction adds, per closed frictional contact, either

* **stick** — a second constraint row, the contact point's tangential position held at
  its place at the start of the stick phase: C_T(q) = s(q) − s(q*), whose Jacobian is the
  model's tangent row t_q (kernel ``tangent``). The position s is not a kernel; it is the
  line integral of t_q from the anchor q* to q (Gauss–Legendre, :data:`QUAD_NODES` nodes,
  exact to round-off for the smooth rows of a point sliding on a fixed surface, whose
  t_q is the gradient of that point's tangential coordinate), so C_T = 0, C_q = t_q and
  γ_T = −(t_q)_q[v] v hold like any bilateral row; or
* **slip** — a force −μ λ_N s t_qᵀ along the tangent row (s = sign of the slip velocity
  t_q v, fixed for the phase), λ_N the contact's normal force. λ_N is the consistent
  multiplier of the phase at (t, q, v): the augmented system with the friction columns,
  [[M, C_qᵀ + μ s t_qᵀ e_Nᵀ], [C_q, 0]] [a; λ] = [Q; γ], solved wherever the force is
  evaluated, so the phase is one smooth DAE (a force that depends on the state).

Both are written once, here, as a :class:`FrictionPhase` — a :class:`MechanicalSystem`
wrapping the model, with the stick rows appended to its bilateral constraints and the
slip force added to its applied force — so every integrator that takes constraints runs
the frictional phases unchanged, through the one Python protocol (the compiled
integrators call it back); nothing in the steppers, the compiled phase or the models
changes, and a frictionless phase is not touched at all. The price is speed: a
frictional phase runs through Python callbacks (``daebench perf`` reports it).

The switches (:mod:`daebench.driver.events` locates them on the dense output like every
other event):

* slip → stick: the slip velocity t_q v of a slipping contact reaches zero ("stop");
  the contact sticks, anchored there; at the start of the next phase the cone is checked;
* stick → slip: the stick force leaves the cone, |λ_T| > μ λ_N ("slide", or found at a
  phase start): the contact slips in the direction s = sign(λ_T) (the friction force
  −λ_T can no longer hold it).

Contacts whose stick rows are parallel (the two bottom corners of a block flat on the
ground) keep one row; the group's cone is |Σ λ_T| ≤ μ Σ λ_N, the one test that does not
depend on the statically indeterminate split of the tangential force. A stick row that is
dependent but parallel to none is refused (StepFailure, named).

A slipping contact that would pull (λ_N < 0) while opening it would let it penetrate
(g̈ < 0) has no consistent motion — Painlevé's paradox: the run ends with that verdict
(:data:`PAINLEVE_SLIP`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from daebench.core import kernels
from daebench.core.problem import Problem
from daebench.core.system import MechanicalSystem

QUAD_NODES = 6            # Gauss–Legendre nodes of the tangential-position line integral
GAMMA_STEP = 1e-3         # rad-scale step of the 4-point difference for γ_T = −(t_q)_q[v] v
PARALLEL_COS = 1.0 - 1e-9  # two tangent rows with |cos| above this are parallel (one stick row)
CONE_TOL = 1e-9           # |λ_T| ≤ μ λ_N (1 + CONE_TOL) + round-off: still sticking
SLIP_MIN = 1e-9           # m/s: a slip velocity below this after an impact sticks

PAINLEVE_SLIP = ("a slipping contact would pull (λ_N < 0) while opening it lets it penetrate: no consistent "
                 "motion — an inconsistent frictional contact (Painlevé's paradox)")

_GL_X, _GL_W = np.polynomial.legendre.leggauss(QUAD_NODES)
_GL_X, _GL_W = 0.5 * (_GL_X + 1.0), 0.5 * _GL_W


def tangent_row(md: Any, j: int, q: np.ndarray, v: np.ndarray | None = None) -> np.ndarray:
    """The tangent Jacobian row t_q of contact j at q (the model's ``tangent`` kernel)."""
    tq = np.zeros(q.shape[0])
    kernels.tangent(md, int(j), np.ascontiguousarray(q, float),
                    np.zeros(q.shape[0]) if v is None else np.ascontiguousarray(v, float), tq)
    return tq


@njit(cache=True)
def _tangent_rows(md, j, Q, out):
    """The tangent rows of contact j at each row of Q (one compiled call for many points)."""
    z = np.zeros(Q.shape[1])
    for r in range(Q.shape[0]):
        kernels.tangent(md, j, Q[r], z, out[r])


class FrictionPhase(MechanicalSystem):
    """One phase of ``base`` with closed frictional contacts (module docstring).

    Parameters
    ----------
    base : the model
    active : the closed contacts, in the phase's row order
    stick : {contact: anchor q*} of the stick rows kept (one per parallel group)
    slip : {contact: s} of the slipping contacts (s = ±1, the slip direction)
    mu : friction coefficient per contact
    """

    def __init__(self, base: MechanicalSystem, active: tuple[int, ...], stick: dict[int, np.ndarray],
                 slip: dict[int, float], mu: np.ndarray):
        self.base = base
        self.n = base.n
        self.n_contacts = base.n_contacts
        self.n_bilateral = base.n_bilateral + len(stick)
        self.coordinate_names = base.coordinate_names
        self.contact_law = base.contact_law
        self.contact_restitution = base.contact_restitution
        self._bp = Problem(base)
        self._md = base.kernel_handle()
        self.stick = dict(stick)
        self.active = tuple(active)
        self.slip = [(self.active.index(j), j, float(s), float(mu[j])) for j, s in slip.items()]
        self._memo: dict[tuple, Any] = {}

    def _cached(self, what: str, fun, *arrays: np.ndarray | None):
        """``fun()`` memoized on the bytes of ``arrays`` (the compiled callbacks ask for the
        rows of one point several times: C, C_q, γ, each contact's gap separately)."""
        key = (what, *(None if a is None else a.tobytes() for a in arrays))
        out = self._memo.get(key)
        if out is None:
            if len(self._memo) > 64:
                self._memo.clear()
            out = self._memo[key] = fun()
        return out

    # -- the model, unchanged ----------------------------------------------------------------
    def mass(self, q: np.ndarray) -> np.ndarray:
        return self._bp.mass(q)

    def mass_jacobian_product(self, q: np.ndarray, a: np.ndarray) -> np.ndarray:
        return self._bp.mass_jacobian_product(q, a)

    def gap(self, q: np.ndarray) -> np.ndarray:
        return self._cached("g", lambda: self._bp.gap_rows(q), q)[0]

    def gap_jacobian(self, q: np.ndarray) -> np.ndarray:
        return self._cached("g", lambda: self._bp.gap_rows(q), q)[1]

    def gap_gamma(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._cached("gv", lambda: self._bp.gap_rows(q, v), q, v)[2]

    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return self.base.energy(q, v)

    def power(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return self.base.power(t, q, v)

    @property
    def power_free(self) -> bool:
        return self.base.power_free

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return self.base.observables(t, q, v)

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.base.initial_state()

    # -- slip: the friction force ---------------------------------------------------------------
    def applied_force(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        M, Q = self._bp.mass_force(t, q, v)
        if self.slip:
            lam_n = self.normal_forces(t, q, v, M, Q)
            for k, j, s, mu in self.slip:
                Q = Q - mu * s * lam_n[k] * tangent_row(self._md, j, q, v)
        return Q

    def force_jacobian(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if not self.slip:
            return self._bp.force_jacobian(t, q, v)
        return super().force_jacobian(t, q, v)   # central differences of the force with friction

    def friction_power(self, t: float, q: np.ndarray, v: np.ndarray) -> float:
        """Power of the slip friction forces, −Σ μ λ_N |t_q v| ≤ 0."""
        if not self.slip:
            return 0.0
        M, Q = self._bp.mass_force(t, q, v)
        lam_n = self.normal_forces(t, q, v, M, Q)
        return float(sum(-mu * s * lam_n[k] * (tangent_row(self._md, j, q, v) @ v) for k, j, s, mu in self.slip))

    def normal_forces(self, t: float, q: np.ndarray, v: np.ndarray, M: np.ndarray | None = None,
                      Q: np.ndarray | None = None) -> np.ndarray:
        """λ_N of the closed contacts (in ``active`` order) consistent at (t, q, v), the slip
        friction included (the nonsymmetric augmented system of the module docstring)."""
        if M is None or Q is None:
            M, Q = self._bp.mass_force(t, q, v)
        n, nb = self.n, self.n_bilateral
        C, Cq, gam = self._rows(t, q, v)
        m = Cq.shape[0]
        A = np.zeros((n + m, n + m))
        A[:n, :n], A[:n, n:], A[n:, :n] = M, Cq.T, Cq
        for k, j, s, mu in self.slip:
            A[:n, n + nb + k] += mu * s * tangent_row(self._md, j, q, v)
        sol = np.linalg.solve(A, np.concatenate([Q, gam]))
        return sol[n + nb:]

    # -- stick: the rows ------------------------------------------------------------------------
    def _stick_rows(self, q: np.ndarray, v: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        ns, n = len(self.stick), self.n
        C, T, gam = np.zeros(ns), np.zeros((ns, n)), np.zeros(ns)
        scale = float(np.max(np.abs(v))) if v is not None else 0.0
        e = GAMMA_STEP / scale if scale > 0.0 else 0.0
        for r, (j, qa) in enumerate(self.stick.items()):
            d = q - qa
            # one compiled call: q, the quadrature nodes on [q*, q], and q ± e v, q ± 2e v
            pts = np.vstack([q, qa + np.outer(_GL_X, d)] + ([q + k * e * v for k in (1, -1, 2, -2)] if e else []))
            rows = np.empty_like(pts)
            _tangent_rows(self._md, int(j), pts, rows)
            T[r] = rows[0]
            C[r] = float(_GL_W @ (rows[1:1 + QUAD_NODES] @ d))
            if e:   # γ_T = −d/dε [t_q(q + ε v) v] by the 4-point central difference
                f = rows[1 + QUAD_NODES:] @ v
                gam[r] = -(8.0 * (f[0] - f[1]) - (f[2] - f[3])) / (12.0 * e)
        return C, T, gam

    def _rows(self, t: float, q: np.ndarray, v: np.ndarray | None = None):
        """(C, C_q, γ) of all rows of the phase: bilateral, stick, closed normals (C = −g)."""
        Cb, Bq, _, gb = self._bp.constraint_rows(t, q, v)
        Cs, T, gs = self._stick_rows(q, v)
        g, G, gg = self._bp.gap_rows(q, v)
        idx = list(self.active)
        return (np.concatenate([Cb, Cs, -g[idx]]), np.vstack([Bq, T, -G[idx]]),
                np.concatenate([gb, gs, -gg[idx]]))

    def constraint(self, t: float, q: np.ndarray) -> np.ndarray:
        return np.concatenate([self._bp.constraint(t, q), self._cached("s", lambda: self._stick_rows(q, None), q)[0]])

    def constraint_jacobian(self, t: float, q: np.ndarray) -> np.ndarray:
        return np.vstack([self._bp.constraint_jacobian(t, q),
                          self._cached("s", lambda: self._stick_rows(q, None), q)[1]])

    def constraint_t(self, t: float, q: np.ndarray) -> np.ndarray:
        return np.concatenate([self._bp.constraint_t(t, q), np.zeros(len(self.stick))])

    def constraint_gamma(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.concatenate([self._bp.constraint_gamma(t, q, v),
                               self._cached("sv", lambda: self._stick_rows(q, v), q, v)[2]])


def stick_groups(base: Problem, md: Any, t: float, q: np.ndarray, active: list[int],
                 sticking: list[int]) -> dict[int, list[int]]:
    """{kept contact: its parallel group} of the sticking contacts: a row is kept when it
    is independent of the bilateral, normal and kept rows; a dependent row joins the kept
    row it is parallel to. Raises ValueError for a dependent row parallel to none."""
    _, Bq, _, _ = base.constraint_rows(t, q)
    G = base.gap_jacobian(q)[active] if active else np.zeros((0, q.size))
    rows = np.vstack([Bq, G])
    groups: dict[int, list[int]] = {}
    kept_rows: dict[int, np.ndarray] = {}
    for j in sorted(sticking):
        tj = tangent_row(md, j, q)
        trial = np.vstack([rows, *kept_rows.values(), tj])
        if np.linalg.matrix_rank(trial) == trial.shape[0]:
            groups[j], kept_rows[j] = [j], tj
            continue
        for k, tk in kept_rows.items():
            if abs(tj @ tk) >= PARALLEL_COS * np.linalg.norm(tj) * np.linalg.norm(tk):
                groups[k].append(j)
                break
        else:
            raise ValueError(f"statically indeterminate stick: the tangent row of contact {j} depends on the "
                             f"other constraint rows but is parallel to no stick row")
    return groups
