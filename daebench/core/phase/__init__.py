"""One smooth phase, compiled: the model's kernels plus the phase's active contact
constraints and continuous contact forces (numba).

Integrators see a *phase*: the model with a fixed set of closed contacts (constraint
law) and a fixed set of engaged contacts (continuous laws), never a switch. Its data,
:class:`PhaseData`, is built by :class:`daebench.core.problem.Problem` and fixed for the
phase; the functions here are the only place where the phase is assembled from the
model's kernels (:mod:`daebench.core.kernels`), for every integrator and for the Python
protocol alike:

* forces: Q = Q_model + Σ g_iᵀ F_i over engaged, penetrating contacts, F_i from the
  contact law (:func:`law_force` — the one implementation of the laws' formulas);
* constraints: the model's bilateral rows, then C = −g_i of each closed contact i, so
  that with M q̈ + C_qᵀ λ = Q the multiplier λ_i ≥ 0 is the compressive contact force;
* their Jacobians (contact force and ∂(C_qᵀλ)/∂q, ∂(C_q v)/∂q by central differences
  with the one step rule :func:`daebench.core.kernels.fd_step`).

Contact-law parameters ``law`` = [kind, K, exponent, c, v_ε]: Hertz F = K δⁿ (1 + χ δ̇),
penalty F = K δ + c δ̇, both clipped at 0 (no adhesion); δ = −g, χ per contact from the
approach speed of the episode (:func:`daebench.core.contact.hysteresis_factor`).

Regularised Coulomb friction (continuous laws only): at a penetrating contact with
friction coefficient μ_i > 0 (the model's ``tangent`` kernel, which also gives the
tangent row t_q with slip velocity v_T = t_q · v) the tangential force

    F_T = −μ_i F_N tanh(v_T / v_ε)

acts along t_q (:func:`friction_force`, the one implementation): the hyperbolic-tangent
characteristic of the smooth dry-friction models reviewed by Pennestrì, Rossi, Salvini
& Valentini (2016), "Review and comparison of dry friction force models", Nonlinear Dyn.
83, 1785–1801 (also Flores et al. 2011's regularised Coulomb law). |F_T| → μ F_N once
|v_T| ≫ v_ε (the deficit μ F_N (1 − tanh(|v_T|/v_ε)) ≤ 2 μ F_N e^{−2|v_T|/v_ε}); a
load below the cone is held by a creep speed v_T = v_ε artanh(|F|/(μ F_N)) ∝ v_ε,
never by an exact stick. Its power Σ F_T v_T ≤ 0 is the friction work the driver books
(:func:`friction_power`); its ∂/∂q, ∂/∂v enter :func:`force_jacobian` with the normal
force's (the slope μ F_N / v_ε at v_T = 0 is a stiff viscous term: implicit Newton loops
need it to converge at steps larger than the time constant v_ε / (μ g)).

Modules: :mod:`.data` (the phase's data), :mod:`.laws` (the laws' formulas),
:mod:`.compliant` (continuous contact forces), :mod:`.slip` (Coulomb slip at closed contacts),
:mod:`.rows` (the active constraints), :mod:`.forces` (the phase's mass and force) and
:mod:`.augmented` (the augmented system). The names below are the compiled interface an
integrator uses (:doc:`/howto/write-an-integrator`)."""

from __future__ import annotations

from daebench.core.phase.data import PhaseData
from daebench.core.phase.laws import (LAW_HERTZ, LAW_NONE, LAW_PENALTY, friction_force, law_elastic,
                                      law_force, law_forces, law_potential, law_potentials)
from daebench.core.phase.compliant import friction_power, has_law
from daebench.core.phase.slip import (add_slip_force, book_friction, book_rows, friction_switches,
                                      slip_normal_forces, slip_power)
from daebench.core.phase.rows import (constraint_force_jacobian, constraint_jacobian, constraint_residuals,
                                      constraints, velocity_constraint_jacobian)
from daebench.core.phase.forces import (force_jacobian, gap_table, gaps, mass_force, mass_jacobian_product,
                                        model_gaps)
from daebench.core.phase.augmented import AugmentedWork, augmented_work, solve_augmented

__all__ = ["PhaseData", "LAW_NONE", "LAW_HERTZ", "LAW_PENALTY", "law_force", "law_forces", "law_elastic",
           "law_potential", "law_potentials", "friction_force", "friction_power", "has_law", "add_slip_force",
           "book_friction", "book_rows", "friction_switches", "slip_normal_forces", "slip_power", "constraints",
           "constraint_jacobian", "constraint_force_jacobian", "velocity_constraint_jacobian",
           "constraint_residuals", "mass_force", "force_jacobian", "mass_jacobian_product", "gaps", "model_gaps",
           "gap_table", "AugmentedWork", "augmented_work", "solve_augmented"]
