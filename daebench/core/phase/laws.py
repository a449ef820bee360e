"""The continuous contact laws' formulas, the one implementation: Hertz F = K δⁿ (1 + χ δ̇),
penalty F = K δ + c δ̇, both clipped at 0 (no adhesion), and the regularised Coulomb
friction F_T = −μ F_N tanh(v_T / v_ε) (see :mod:`daebench.core.phase`).

Parameters ``law`` = [kind, K, exponent, c, v_ε]; δ = −g."""

from __future__ import annotations

import math

from daebench.core.borrow import uncounted

LAW_NONE, LAW_HERTZ, LAW_PENALTY = 0, 1, 2


@uncounted
def law_force(law, engaged, chi, g, gdot):
    """Normal force F ≥ 0 of a continuous law at gap g and gap rate ġ."""
    kind = law[0]
    delta = max(-g, 0.0)
    if kind == LAW_HERTZ:
        elastic = law[1] * delta ** law[2] if engaged else 0.0
        return max(elastic * (1.0 + chi * (-gdot)), 0.0)
    if kind == LAW_PENALTY:
        F = law[1] * delta + law[3] * (-gdot)
        return max(F, 0.0) if (engaged and delta > 0.0) else 0.0
    return 0.0


@uncounted
def law_elastic(law, engaged, g):
    """The conservative part of the force (its potential is :func:`law_potential`)."""
    if not engaged:
        return 0.0
    delta = max(-g, 0.0)
    if law[0] == LAW_HERTZ:
        return law[1] * delta ** law[2]
    if law[0] == LAW_PENALTY:
        return law[1] * delta
    return 0.0


@uncounted
def law_potential(law, g):
    """Energy stored in the contact spring at gap g."""
    delta = max(-g, 0.0)
    if law[0] == LAW_HERTZ:
        return law[1] * delta ** (law[2] + 1.0) / (law[2] + 1.0)
    if law[0] == LAW_PENALTY:
        return 0.5 * law[1] * delta * delta
    return 0.0


@uncounted
def law_forces(law, engaged, chi, g, gdot, F):
    """:func:`law_force` of every contact (columns; ``engaged``, ``chi`` per contact) at every
    row of the gaps ``g`` and gap rates ``gdot`` into ``F``."""
    for r in range(g.shape[0]):
        for i in range(g.shape[1]):
            F[r, i] = law_force(law, engaged[i], chi[i], g[r, i], gdot[r, i])


@uncounted
def law_potentials(law, g, U):
    """Σ_i :func:`law_potential` over the contacts (columns) of each row of ``g`` into ``U``."""
    for r in range(g.shape[0]):
        s = 0.0
        for i in range(g.shape[1]):
            s += law_potential(law, g[r, i])
        U[r] = s


@uncounted
def friction_force(law, mu, fn, vt):
    """Tangential force F_T = −μ F_N tanh(v_T / v_ε) of the regularised Coulomb law at
    normal force F_N ≥ 0 and slip velocity v_T (module docstring); 0 for μ = 0."""
    if mu == 0.0 or fn == 0.0:
        return 0.0
    return -mu * fn * math.tanh(vt / law[4])
