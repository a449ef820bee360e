"""Linear stability of the fixed-step steppers on a system: the system's undamped
frequencies at the start, from the assembled mass and tangent stiffness, and each method's
amplification on the undamped oscillator — the one rule behind the stability map
(:mod:`daebench.workflows.stability`, which measures it against whole runs) and the check
of an explicit method's step before its first step (:mod:`daebench.harness.running.checks`).

*The system* (:func:`linearize_system`): the undamped frequencies ω_k at the start, from
K φ = ω² M φ with the tangent stiffness K = ∂(M q̈0)/∂q − ∂Q/∂q + ∂(C_qᵀλ0)/∂q (symmetric
part) and M = M(q0), restricted to the tangent space of the bilateral constraints when the
model has any (:func:`tangent_matrices`). The suddenly applied load Q(q0) starts mode k with
the oscillation energy E_k = f_k²/(2ω_k²), f_k = φ_kᵀQ(q0) (φ mass-normalized) — the seed an
unstable mode grows from. All modes (dense eigensolver), or only the fastest few: the same
matrices, the largest eigenpairs by Lanczos (ARPACK) once the system is large.

*The method*: its spectral radius ρ(Ω) at Ω = hω on the undamped oscillator —
ABM4-PECE (:class:`AbmPece`): the largest root of its characteristic polynomial on
y′ = iωy; the Newmark family (:class:`NewmarkMember`, central differences
:data:`CENTRAL` among them): the largest eigenvalue of the amplification matrix of
ẍ = −ω²x — and the amplitude factor g_n(Ω) after n steps from the method's own start
(:func:`log_growth`: ρⁿ for the Newmark family, whose start is consistent; for ABM4-PECE the
RK4-started history expanded on the polynomial's roots, since that start seeds the
parasitic roots only weakly). A run diverges when a mode's energy E_k g_n² passes the
driver's divergence threshold × the energy scale. So the method's stability interval *for
a run of n steps* is

    Ω*(n, G) = sup{Ω : g_n(Ω') ≤ G for all Ω' ≤ Ω},   G = √(threshold · E_scale / E_k),

and the predicted h_max = min_k h with h ω_k = Ω*(t_end/h, G_k) (:func:`predict`, a fixed
point in h). The strict interval {ρ ≤ 1} (:func:`strict_interval`) is ∞ for the
unconditionally stable Newmark members, 2 for central differences; for ABM4-PECE it is
empty — its principal root exceeds 1 by ≈ 0.16 Ω⁶ for small Ω (order 4, no damping on the
imaginary axis) and a parasitic root crosses |ζ| = 1 near Ω ≈ 0.93, beyond which growth is
≥ 3.6 % a step. On a short run the weak growth below 0.93 cannot reach the threshold and
Ω* sits at that crossing; on long runs Ω* drops towards 0.5.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.linalg as sl

from daebench.core.energyscale import energy_scale
from daebench.core.linalg import solve_structured
from daebench.core.problem import Problem
from daebench.stepping import abm

OMEGA_GRID = np.concatenate([np.linspace(1e-3, 4.0, 4000), np.geomspace(4.0, 1e7, 600)[1:]])
STRICT_SLACK = 1e-12    # ρ ≤ 1 + this counts as |ρ| ≤ 1 (round-off of the eigenvalue solver)
DENSE_MODES = 600       # up to this many coordinates the modes come from the dense eigensolver
LANCZOS_TOL = 1e-10     # relative accuracy of the fastest modes of a large system (ARPACK)


@dataclass(frozen=True)
class AbmPece:
    """Adams–Bashforth–Moulton 4, PECE mode (the stepper :mod:`daebench.stepping.abm`, its
    coefficients): y_{n+1} = y_n + z[AM0 (y_n + z Σ AB_j y_{n−j}) + AM1 y_n + AM2 y_{n−1}
    + AM3 y_{n−2}] on y′ = λy, z = hλ, i.e. the characteristic polynomial
    ζ⁴ − c1 ζ³ − c2 ζ² − c3 ζ − c4 with c1 = 1 + z(AM0 + AM1) + z²AM0·AB0,
    c2 = z AM2 + z²AM0·AB1, c3 = z AM3 + z²AM0·AB2, c4 = z²AM0·AB3. The history is started by
    three RK4 steps, y_k = R(z)^k y_0 with R(z) = 1 + z + z²/2 + z³/6 + z⁴/24: this start
    seeds the parasitic roots, which decide the boundary near hω ≈ 0.93 (:meth:`log_growth`)."""

    name: str = "ABM4-PECE"
    #: no interval of ρ ≤ 1 (its principal root exceeds 1 by ≈ 0.16 Ω⁶): its limit is the run's, :func:`predict`
    strict: bool = False

    def coefficients(self, z: np.ndarray) -> tuple[np.ndarray, ...]:
        a0 = abm.AM0
        return (1.0 + z * (a0 + abm.AM1) + z * z * a0 * abm.AB0, z * abm.AM2 + z * z * a0 * abm.AB1,
                z * abm.AM3 + z * z * a0 * abm.AB2, z * z * a0 * abm.AB3)

    def radius_z(self, z: complex) -> float:
        c1, c2, c3, c4 = self.coefficients(np.complex128(z))
        return float(np.abs(np.roots([1.0, -c1, -c2, -c3, -c4])).max())

    def radius(self, omega: float) -> float:
        return self.radius_z(1j * omega)

    def start_modes(self, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Roots ζ_k (len(omega) × 4) and the weights α_k of the RK4-started history
        (y3, y2, y1, y0) = Σ_k α_k (ζ_k³, ζ_k², ζ_k, 1), so that y_{3+m} = Σ_k α_k ζ_k^{3+m}."""
        z = 1j * np.asarray(omega, float)
        c1, c2, c3, c4 = self.coefficients(z)
        R = 1.0 + z + z**2 / 2.0 + z**3 / 6.0 + z**4 / 24.0
        roots = np.empty((z.size, 4), complex)
        alpha = np.empty((z.size, 4), complex)
        for i in range(z.size):
            C = np.array([[c1[i], c2[i], c3[i], c4[i]], [1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]], complex)
            lam, V = np.linalg.eig(C)
            roots[i] = lam
            alpha[i] = np.linalg.solve(V, np.array([R[i] ** 3, R[i] ** 2, R[i], 1.0])) * V[0]
        return roots, alpha


@dataclass(frozen=True)
class NewmarkMember:
    """A Newmark-family member (α_m, α_f, β, γ; force or acceleration averaging, as in
    :mod:`daebench.stepping.newmark`) on ẍ + ω²x = 0 with Ω = hω."""

    alpha_m: float
    alpha_f: float
    beta: float
    gamma: float
    accel_avg: bool = False
    name: str = "Newmark family"
    #: ρ ≤ 1 up to :func:`strict_interval` (∞: unconditionally stable): a hard limit on h ω_max
    strict: bool = True

    def matrix(self, omega: float) -> np.ndarray:
        """The amplification matrix: state (x, h v, h² a) [and h² ẍ with acceleration averaging]."""
        am, af, b, g, w2 = self.alpha_m, self.alpha_f, self.beta, self.gamma, omega * omega
        # unknowns u = (x1, v1, a1[, ẍ1]); rows: equation of motion, x update, v update[, ẍ1 = −Ω² x1]
        if not self.accel_avg:
            L = np.array([[(1 - af) * w2, 0.0, 1 - am], [1.0, 0.0, -b], [0.0, 1.0, -g]])
            R = np.array([[-af * w2, 0.0, -am], [1.0, 1.0, 0.5 - b], [0.0, 1.0, 1 - g]])
        else:
            L = np.array([[0.0, 0.0, 1 - am, -(1 - af)], [1.0, 0.0, -b, 0.0], [0.0, 1.0, -g, 0.0],
                          [w2, 0.0, 0.0, 1.0]])
            R = np.array([[0.0, 0.0, -am, af], [1.0, 1.0, 0.5 - b, 0.0], [0.0, 1.0, 1 - g, 0.0],
                          [0.0, 0.0, 0.0, 0.0]])
        return np.linalg.solve(L, R)

    def radius(self, omega: float) -> float:
        return float(np.abs(np.linalg.eigvals(self.matrix(omega))).max())

#: explicit central differences (velocity Verlet, :mod:`daebench.stepping.central`): β = 0, γ = ½
CENTRAL = NewmarkMember(0.0, 0.0, 0.0, 0.5, name="central differences")


@functools.lru_cache(maxsize=64)
def _log_radius(method: AbmPece | NewmarkMember) -> np.ndarray:
    """ln ρ on :data:`OMEGA_GRID` (computed once per method)."""
    return np.log(np.maximum([method.radius(float(w)) for w in OMEGA_GRID], 1e-300))


@functools.lru_cache(maxsize=8)
def _abm_start_modes() -> tuple[np.ndarray, np.ndarray]:
    return AbmPece().start_modes(OMEGA_GRID)


def log_growth(method: AbmPece | NewmarkMember, steps: float, omega: float | None = None) -> np.ndarray:
    """ln of the amplitude factor of a mode after ``steps`` steps from the method's start, on
    :data:`OMEGA_GRID` (or at one Ω): for ABM4-PECE |y_n/y_0| from the RK4-started history
    (parasitic roots included); for the Newmark family, whose start a_0 = q̈_0 is consistent,
    n ln ρ(Ω)."""
    if isinstance(method, AbmPece):
        roots, alpha = method.start_modes(np.array([omega])) if omega is not None else _abm_start_modes()
        m = max(float(steps) - 3.0, 0.0)
        with np.errstate(over="ignore", divide="ignore"):
            logs = np.log(np.abs(alpha)) + m * np.log(np.abs(roots))  # per root, then a stable log-sum
            top = logs.max(axis=1, keepdims=True)
            val = np.abs(np.sum(alpha * np.exp(m * np.log(roots + 0j) - top), axis=1))
            out = top[:, 0] + np.log(np.maximum(val, 1e-300))
        return out
    if omega is not None:
        return np.array([steps * math.log(max(method.radius(omega), 1e-300))])
    return steps * _log_radius(method)


@functools.lru_cache(maxsize=64)
def strict_interval(method: AbmPece | NewmarkMember) -> float:
    """sup{Ω : ρ(ω') ≤ 1 for all ω' ≤ Ω}: the first crossing on :data:`OMEGA_GRID`, refined by
    bisection between its neighbours (∞ if ρ ≤ 1 up to 1e7; central differences: 2)."""
    return _first_crossing(_log_radius(method) > math.log1p(STRICT_SLACK),
                           lambda w: method.radius(w) > 1.0 + STRICT_SLACK, 48)


def run_interval(method: AbmPece | NewmarkMember, steps: float, log_budget: float) -> float:
    """Ω*(n, G) = sup{Ω : growth over n steps ≤ G for all Ω' ≤ Ω} (∞ if never exceeded up to 1e7)."""
    return _first_crossing(log_growth(method, steps) > log_budget,
                           lambda w: log_growth(method, steps, w)[0] > log_budget, 40)


def _first_crossing(bad_on_grid: np.ndarray, bad_at: Callable[[float], bool], bisections: int) -> float:
    """The Ω where a condition first holds: the first point of :data:`OMEGA_GRID` where
    ``bad_on_grid`` is true, refined by bisecting ``bad_at`` between it and the point below
    (∞ when it holds nowhere on the grid)."""
    bad = np.flatnonzero(bad_on_grid)
    if not bad.size:
        return math.inf
    i = int(bad[0])
    lo, hi = (float(OMEGA_GRID[i - 1]) if i else 0.0), float(OMEGA_GRID[i])
    for _ in range(bisections):
        mid = 0.5 * (lo + hi)
        if bad_at(mid):
            hi = mid
        else:
            lo = mid
    return lo


# -- the system at the start ----------------------------------------------------------------------
@dataclass
class Linearization:
    """Undamped frequencies ω_k [rad/s] at the start (ascending), the oscillation energy
    E_k [J] the start load gives each mode, and the run's energy scale [J]."""

    omega: np.ndarray
    seed_energy: np.ndarray
    energy_scale: float


def tangent_matrices(system, q0: np.ndarray, v0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(M, K, Q0) at the start (module docstring): M = M(q0), the symmetric tangent stiffness
    K = ∂(M q̈0)/∂q − ∂Q/∂q + ∂(C_qᵀλ0)/∂q at the consistent (q̈0, λ0), and Q(q0) — all
    restricted to the null space of C_q when the model has bilateral constraints (a
    pendulum's stiffness is all in the last term)."""
    prob = Problem(system)
    M = system.mass(q0)
    Q0 = np.asarray(system.applied_force(0.0, q0, v0), float)
    if system.n_bilateral:
        a0, lam0 = prob.acceleration(0.0, q0, v0)
    else:   # M q̈0 = Q0 through the band a large model's mass has (no dense O(n³) solve)
        a0, lam0 = solve_structured(M, Q0), np.zeros(0)
    Kq, _ = system.force_jacobian(0.0, q0, v0)
    Kt = system.mass_jacobian_product(q0, a0) - Kq + prob.constraint_force_jacobian(0.0, q0, lam0)
    K = 0.5 * (Kt + Kt.T)
    if system.n_bilateral:
        N = sl.null_space(np.asarray(system.constraint_jacobian(0.0, q0)).reshape(system.n_bilateral, -1))
        M, K, Q0 = N.T @ M @ N, N.T @ K @ N, N.T @ Q0
    return M, K, Q0


def _fastest_modes(M: np.ndarray, K: np.ndarray, top: int) -> tuple[np.ndarray, np.ndarray]:
    """(ω², φ) of the ``top`` largest eigenpairs of K φ = ω² M φ, φᵀ M φ = I: the dense
    solver for a small system, Lanczos on M^{-1/2} K M^{-1/2} for a large one with a
    diagonal mass (FE models' lumped mass)."""
    n = M.shape[0]
    top = min(top, n)
    d = np.diag(M)
    if n <= DENSE_MODES or top >= n - 1 or np.count_nonzero(M - np.diag(d)) or (d <= 0.0).any():
        return sl.eigh(K, M, subset_by_index=[n - top, n - 1])
    from scipy.sparse.linalg import eigsh
    s = 1.0 / np.sqrt(d)
    w2, psi = eigsh(K * s[:, None] * s[None, :], k=top, which="LA", tol=LANCZOS_TOL)
    order = np.argsort(w2)
    return w2[order], s[:, None] * psi[:, order]


def linearize_system(system, top: int | None = None) -> Linearization:
    """Frequencies of K φ = ω² M φ at the start (:func:`tangent_matrices`), the start load's
    energy in each mode and the energy scale; every mode, or only the ``top`` fastest."""
    q0, v0 = system.initial_state()
    q0, v0 = np.asarray(q0, float), np.asarray(v0, float)
    M, K, Q0 = tangent_matrices(system, q0, v0)
    w2, phi = sl.eigh(K, M) if top is None else _fastest_modes(M, K, top)   # φᵀ M φ = I
    keep = w2 > 0.0
    omega = np.sqrt(w2[keep])
    f = phi[:, keep].T @ Q0
    scale = energy_scale(system, q0, v0)  # the driver's rule (core.energyscale)
    seed = np.maximum(f * f / (2.0 * omega * omega), (1e-16) ** 2 * scale)   # round-off seeds every mode
    return Linearization(omega, seed, scale)


def predict(method: AbmPece | NewmarkMember, lin: Linearization, t_trial: float,
            divergence_energy: float) -> dict[str, float]:
    """Predicted h_max and the interval behind it: for each mode the fixed point
    h ω_k = Ω*(t_trial/h, G_k) with G_k = √(divergence_energy · E_scale / E_k) (the driver's
    divergence threshold, :data:`daebench.driver.history.divergence_energy`); the smallest h
    over the modes."""
    best = {"h_pred": math.inf, "interval": math.inf, "omega_limiting": float(lin.omega.max(initial=0.0))}
    for w, e0 in zip(lin.omega[::-1], lin.seed_energy[::-1]):
        log_g = 0.5 * math.log(divergence_energy * lin.energy_scale / e0)
        h = run_interval(method, 500.0, log_g) / w
        for _ in range(8):                        # n = t_end/h depends on h: iterate to the fixed point
            if not math.isfinite(h):
                break
            h_new = run_interval(method, max(t_trial / h, 1.0), log_g) / w
            if abs(h_new - h) <= 1e-6 * h:
                h = h_new
                break
            h = h_new
        if h < best["h_pred"]:
            best = {"h_pred": h, "interval": h * w, "omega_limiting": float(w)}
    return best


def divergence_time(method: AbmPece | NewmarkMember, lin: Linearization, h: float,
                    divergence_energy: float) -> float:
    """Predicted time [s] at which a run at fixed step h crosses the divergence threshold in
    free flight: min_k h ln G_k / ln ρ(h ω_k) (∞ if no mode grows)."""
    best = math.inf
    for w, e0 in zip(lin.omega, lin.seed_energy):
        growth = math.log(max(method.radius(h * w), 1e-300))
        if growth > 0.0:
            best = min(best, h * 0.5 * math.log(divergence_energy * lin.energy_scale / e0) / growth)
    return best
