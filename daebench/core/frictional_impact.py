"""The impact law of the event-driven driver: Newton's law for one contact as for several at
once, with planar Coulomb friction, as one linear complementarity problem.

At an impact at (t, q) with velocities v⁻ the contacts taking part (rows G_N of their gap
Jacobians, G_T of their tangent Jacobians) receive impulses P_N ≥ 0 (normal) and P_T
(tangential) and the system's bilateral constraints B v = 0 their own; then

    M (v⁺ − v⁻) = G_Nᵀ P_N + G_Tᵀ P_T + Bᵀ κ,     B v⁺ = 0,

so that U⁺ = U⁻ + W P with the constrained Delassus matrix W = G M_B⁻¹ Gᵀ (G = [G_N; G_T],
M_B⁻¹ the inverse of M on B v = 0, from the augmented system). The laws, per contact:

* Newton (normal): 0 ≤ U_N⁺ + e U_N⁻ ⟂ P_N ≥ 0 — unilateral: a contact that separates
  (U_N⁻ ≥ 0) receives no impulse; for several contacts at once the *simultaneous* Newton
  law. Its LCP (matrix W_NN, a P-matrix for independent contacts) is solved by Murty's
  method (:func:`daebench.core.lcp.solve_lcp`; one contact: P_N = max(0, −(1 + e) U_N⁻/W));
* Coulomb (tangential, e_T = 0), at contacts with μ > 0, in the manner of Pfeiffer &
  Glocker (1996, §7.3): the planar friction cone |P_T| ≤ μ P_N is split into two
  complementarity rows. With the friction saturations λ_0R = μ P_N + P_T ≥ 0 (zero when
  the friction impulse sits on the edge that opposes slip to the right) and
  λ_0L = μ P_N − P_T = 2 μ P_N − λ_0R ≥ 0, and the slip split U_T⁺ = U_TR − U_TL::

      0 ≤ U_TR ⟂ λ_0R ≥ 0,     0 ≤ λ_0L ⟂ U_TL ≥ 0

  (slip to the right: P_T = −μ P_N; to the left: P_T = +μ P_N; stick: U_T⁺ = 0 inside
  the cone). With x = (P_N, λ_0R, U_TL), y = (U_N⁺ + e U_N⁻, U_TR, λ_0L)::

      y = [[W_NN − W_NT μ S,  W_NT,  0],      x + [(1 + e) U_N⁻,
           [W_TN − W_TT μ S,  W_TT,  I],           U_T⁻,
           [2 μ S,            −I,    0]]           0           ]

  (S selects the frictional contacts' normal impulses), solved by Lemke's method
  (:func:`daebench.core.lcp.solve_lcp_lemke`; the matrix is not a P-matrix). Where
  Lemke's method ends on a secondary ray — which degenerate data (zero rows of b, a
  grazing contact) can cause although a solution exists — every complementary basis is
  tried (:func:`daebench.core.lcp.enumerate_lcp`, up to :data:`ENUMERATE_MAX` unknowns); an LCP without
  solution is returned as ``status = LCP_RAY``: an inconsistent or indeterminate
  frictional contact (Painlevé), which the driver names.

The impact map is exact: no time step enters, so a closed form (the falling rod's
impulse, the cradle's outcome) is met to round-off.

References
----------
F. Pfeiffer, C. Glocker, Multibody Dynamics with Unilateral Contacts, Wiley (1996), §7.
C. Glocker, Set-Valued Force Laws, Springer (2001), §8.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from daebench.core.lcp import LCP_FAILURES, LCP_RAY, enumerate_lcp, lcp, lemke_work, solve_lcp_lemke
from daebench.core.linalg import DiagonalMass, solve_structured

#: the names of the impact laws, as the run record gives them
ENUMERATE_MAX = 12     # unknowns up to which a failed Lemke run is checked by enumerating the bases
LAW_NEWTON = "newton"
LAW_NEWTON_COULOMB = "newton-coulomb (Pfeiffer–Glocker LCP)"
PAINLEVE = ("frictional impact LCP without a solution (Lemke's method ended on a ray): an inconsistent or "
            "indeterminate frictional contact (Painlevé's paradox)")


@dataclass
class FrictionalImpact:
    """The outcome of :func:`frictional_impact` (per taking part contact: P_N, P_T, U_N⁻, U_N⁺, U_T⁺)."""

    v_plus: np.ndarray
    impulse_n: np.ndarray
    impulse_t: np.ndarray
    vn_minus: np.ndarray
    vn_plus: np.ndarray
    vt_plus: np.ndarray
    energy_loss: float           # T⁻ − T⁺ ≥ 0
    status: int = 0              # ≥ 0: solved; LCP_RAY / other LCP failures (core.lcp)

    @property
    def ok(self) -> bool:
        return self.status >= 0


def law_name(mu: np.ndarray) -> str:
    """The name of the law applied at contacts with coefficients ``mu``."""
    return LAW_NEWTON_COULOMB if np.any(np.asarray(mu) > 0.0) else LAW_NEWTON


def constrained_inverse(M: "np.ndarray | DiagonalMass", B: np.ndarray, G: np.ndarray) -> np.ndarray:
    """M_B⁻¹ Gᵀ: the velocity change per unit impulse along the rows of G with B v = 0 kept
    (the augmented system [[M, Bᵀ], [B, 0]])."""
    n, mb = M.shape[0], B.shape[0]
    if mb == 0:
        return solve_structured(M, G.T)
    if isinstance(M, DiagonalMass):   # the Schur complement on B: O(n (k + mb)) instead of a dense (n + mb)² system
        X, Y = M.solve(G.T), M.solve(B.T)
        return X - Y @ np.linalg.solve(B @ Y, B @ X)
    A = np.zeros((n + mb, n + mb))
    A[:n, :n], A[:n, n:], A[n:, :n] = M, B.T, B
    rhs = np.zeros((n + mb, G.shape[0]))
    rhs[:n] = G.T
    return solve_structured(A, rhs, n)[:n]


def frictional_impact(M: np.ndarray, GN: np.ndarray, GT: np.ndarray, mu: np.ndarray, v_minus: np.ndarray,
                      e: float | np.ndarray, B: np.ndarray | None = None) -> FrictionalImpact:
    """Newton's law with restitution ``e`` (one for every contact, or one per contact) and
    planar Coulomb friction (coefficients ``mu``, 0: frictionless) at the contacts whose
    normal / tangent Jacobian rows are ``GN`` / ``GT``, with bilateral velocity constraints
    ``B v = 0`` kept (module docstring). A contact that does not approach (U_N⁻ ≥ 0) gets
    no impulse unless another contact's impulse pushes it into its surface."""
    n = M.shape[0]
    GN, GT = np.atleast_2d(GN), np.atleast_2d(GT)
    k = GN.shape[0]
    mu = np.asarray(mu, float).reshape(k)
    B = np.zeros((0, n)) if B is None else np.atleast_2d(B)
    F = np.flatnonzero(mu > 0.0)
    nf = F.size
    G = np.vstack([GN, GT[F]]) if nf else GN
    X = constrained_inverse(M, B, G)          # n × (k + nf)
    W = G @ X
    un, ut = GN @ v_minus, GT[F] @ v_minus
    if nf == 0:
        pn, status = lcp(W, (1.0 + e) * un)
        pt = np.zeros(0)
    else:
        S = np.zeros((nf, k))
        S[np.arange(nf), F] = 1.0
        muS = mu[F][:, None] * S
        Wnn, Wnt, Wtn, Wtt = W[:k, :k], W[:k, k:], W[k:, :k], W[k:, k:]
        A = np.block([[Wnn - Wnt @ muS, Wnt, np.zeros((k, nf))],
                      [Wtn - Wtt @ muS, Wtt, np.eye(nf)],
                      [2.0 * muS, -np.eye(nf), np.zeros((nf, nf))]])
        b = np.concatenate([(1.0 + e) * un, ut, np.zeros(nf)])
        m = k + 2 * nf
        z, w = np.zeros(m), np.zeros(m)
        status = int(solve_lcp_lemke(np.ascontiguousarray(A), np.ascontiguousarray(b), m, z, w, lemke_work(m)))
        if status < 0 and m <= ENUMERATE_MAX:
            # Lemke's pivoting can end on a ray, or at a point that is not a solution, in a
            # degenerate LCP that has one (zero rows of b, a grazing contact, one tangent row
            # shared by two contacts): the complementary bases, all of them, decide
            found = enumerate_lcp(A, b)
            if found is not None:
                z, status = found, 0
        pn = z[:k]
        pt = z[k:k + nf] - mu[F] * pn[F]
    if status < 0:
        nan = np.full(k, np.nan)
        return FrictionalImpact(v_minus.copy(), nan, nan, un, nan, nan, np.nan, status)
    P = np.concatenate([pn, pt])
    v_plus = v_minus + X @ P
    pt_all = np.zeros(k)
    pt_all[F] = pt
    loss = 0.5 * float(v_minus @ M @ v_minus - v_plus @ M @ v_plus)
    return FrictionalImpact(v_plus, pn, pt_all, un, GN @ v_plus, GT @ v_plus, loss, status)


def failure_message(status: int) -> str:
    """What an LCP failure of :func:`frictional_impact` means."""
    return PAINLEVE if status == LCP_RAY else LCP_FAILURES.get(status, f"impact LCP failed (status {status})")
