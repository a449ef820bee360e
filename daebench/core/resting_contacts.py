"""Which contacts at rest on their surfaces stay closed: the unilateral contact law at
acceleration level, as a linear complementarity problem.

At a state (t, q, v) where the candidate contacts touch (g = 0) and do not move apart or
into each other (ġ = 0), the contact forces λ_N and the gap accelerations g̈ satisfy

    M a = Q + Bᵀκ + G_Nᵀ λ_N,     B a = γ_B          (bilateral constraints kept)
    g̈ = G_N a − γ_N,     0 ≤ g̈ ⟂ λ_N ≥ 0

(Pfeiffer & Glocker 1996, §6.2; the "smooth acceleration" one-step problem of Siconos'
event-driven simulation). With a_B the acceleration of the bilateral problem alone and
X = M_B⁻¹ G_Nᵀ (the velocity change per unit impulse, bilateral constraints kept):

    g̈ = W λ_N + b,     W = G_N X,     b = G_N a_B − γ_N,

an LCP whose matrix is symmetric positive definite for independent contacts (a P-matrix:
unique solution, Murty's method, :func:`daebench.core.lcp.solve_lcp`). A contact with
λ_N > 0 stays (or becomes) closed; one with λ_N = 0 opens (g̈ ≥ 0: it lifts off, or
stays in tangency without force). The decision depends on the state only — never on the
multiplier an integrator's step produced, which for an index-3 step at small h is
dominated by its position correction (∝ C/(βh²)) and changes sign from step to step.

Degenerate solutions (λ_N and g̈ both zero, as at the instant a closed contact's force
passes through zero) are read as open: a contact whose release was just located is closed
again only where its force exceeds :data:`CLOSED_FORCE_REL` of the problem's force scale (the force that would cancel the
largest of the gap accelerations' own terms, max_i (|G_i| |a_B| + |γ_i|) / W_ii). That keeps the decision at a located
release (λ_N = 0 to within the event tolerance) stable: the contact opens, and does not
close again at the same instant.

References
----------
F. Pfeiffer, C. Glocker, Multibody Dynamics with Unilateral Contacts, Wiley (1996), §6.
V. Acary, B. Brogliato, Numerical Methods for Nonsmooth Dynamical Systems, Springer (2008), §7.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from daebench.core.frictional_impact import constrained_inverse
from daebench.core.lcp import LCP_FAILURES, lcp
from daebench.core.linalg import DiagonalMass

CLOSED_FORCE_REL = 1e-9   # contact force below this fraction of the force scale: open


class RestingSolution(NamedTuple):
    """The acceleration-level contact LCP at one state."""

    force: np.ndarray        # λ_N ≥ 0 per candidate
    gap_acc: np.ndarray      # g̈ ≥ 0 per candidate
    closed: np.ndarray       # bool per candidate: λ_N above the force floor
    status: int              # ≥ 0: solved (pivots); < 0: core.lcp failure code

    @property
    def ok(self) -> bool:
        return self.status >= 0


def resting_lcp(M: np.ndarray, B: np.ndarray, G: np.ndarray, a_free: np.ndarray, gamma: np.ndarray,
                released: np.ndarray | None = None) -> RestingSolution:
    """Solve 0 ≤ g̈ = W λ + b ⟂ λ ≥ 0 for the contacts with gap-Jacobian rows ``G`` and
    gap-acceleration offsets ``gamma`` (g̈ = G a − γ), with bilateral Jacobian ``B`` kept,
    at the acceleration ``a_free`` of the bilateral problem without these contacts.
    ``released`` (bool per contact): contacts whose release was located at this state —
    they close again only with a force above the floor (module docstring); the others
    close with any positive force."""
    G = np.atleast_2d(np.asarray(G, float))
    k = G.shape[0]
    if k == 0:
        return RestingSolution(np.zeros(0), np.zeros(0), np.zeros(0, bool), 0)
    B = np.zeros((0, G.shape[1])) if B is None else np.atleast_2d(B)
    X = constrained_inverse(M if isinstance(M, DiagonalMass) else np.asarray(M, float), B, G)
    W = np.ascontiguousarray(G @ X)
    b = np.ascontiguousarray(G @ a_free - np.asarray(gamma, float))
    z, status = lcp(W, b)
    if status < 0:
        return RestingSolution(np.full(k, np.nan), np.full(k, np.nan), np.zeros(k, bool), status)
    # the force that would cancel the gap accelerations' own terms, |G a_B| + |γ| (not b, which
    # cancels at a release)
    terms = np.abs(G) @ np.abs(a_free) + np.abs(np.asarray(gamma, float))
    scale = float(np.max(terms / np.maximum(np.abs(np.diag(W)), 1e-300)))
    floor = np.where(np.zeros(k, bool) if released is None else np.asarray(released, bool),
                     CLOSED_FORCE_REL * scale, 0.0)
    return RestingSolution(z, W @ z + b, z > floor, status)


def failure_message(status: int) -> str:
    """What a failure of :func:`resting_lcp` means."""
    return "acceleration-level contact LCP: " + LCP_FAILURES.get(status, f"failed (status {status})")
