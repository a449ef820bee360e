"""The phase's mass and force — the model's, the continuous contact forces' and the slip
friction's — with their Jacobians, and every contact's gap."""

from __future__ import annotations

from daebench.core import coulomb, kernels
from daebench.core.borrow import uncounted
from daebench.core.phase import compliant, slip


@uncounted
def mass_force(ph, t, q, v, M, Q):
    """M(q) and the phase's force Q (model force + engaged contact forces g_qᵀF_N + t_qᵀF_T
    + the slip friction of closed contacts, :func:`add_slip_force`)."""
    compliant.force_without_slip(ph, t, q, v, M, Q)
    slip.add_slip(coulomb.present(ph.friction), ph, t, q, v, M, Q)


@uncounted
def force_jacobian(ph, t, q, v, Kq, Kv):
    """∂Q/∂q, ∂Q/∂v of the phase's force: the model's kernel plus central differences of
    each engaged, penetrating contact force g_iᵀF_N,i + t_iᵀF_T,i."""
    kernels.force_jacobian(ph.model, t, q, v, Kq, Kv)
    slip.add_slip_jacobian(coulomb.present(ph.friction), ph, t, q, v, Kq, Kv)
    compliant.add_contact_jacobian(ph.law, ph, q, v, Kq, Kv)


@uncounted
def mass_jacobian_product(ph, q, a, K):
    kernels.mass_jacobian_product(ph.model, q, a, K)


@uncounted
def gaps(ph, q, v, g, G, gam):
    """Every contact's gap, Jacobian row and γ_g (for the Python protocol)."""
    model_gaps(ph.model, q, v, g, G, gam)


@uncounted
def model_gaps(md, q, v, g, G, gam):
    """:func:`gaps` of the model's kernel data ``md`` alone (no phase)."""
    for i in range(g.shape[0]):
        g[i], gam[i] = kernels.gap(md, i, q, v, G[i])


@uncounted
def gap_table(md, Q, V, g, gdot, G):
    """Every contact's gap g and rate ġ = g_q · v (columns) at each row of (Q, V) into
    ``g``, ``gdot`` (the model's kernel data ``md``; ``G``: scratch for one Jacobian row):
    the output rows' contact forces and springs' energy."""
    for r in range(Q.shape[0]):
        for i in range(g.shape[1]):
            g[r, i], _ = kernels.gap(md, i, Q[r], V[r], G)
            s = 0.0
            for j in range(G.shape[0]):
                s += G[j] * V[r, j]
            gdot[r, i] = s
