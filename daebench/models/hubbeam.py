"""Flexible hub–beam: an Euler–Bernoulli beam clamped to a turning hub, with optional
gravity, foreshortening, drive torque, structural damping and contact with a plane.

Model (derived here; the source paper: docs/sources.md §G)
----------------------------------------------------------
A beam of length L, density ρ, area S, second moment I, modulus E is clamped at
radius a on a hub (inertia J_h) that turns by θ about the fixed hinge O. In the frame
turning with the hub, material point x ∈ [0, L] sits at

    p(x, q) = [a + x + w1 + wc, w2],   w1 = Φx·A,  w2 = Φy·B,  wc = −½ BᵀH(x)B,

with H(x) = ∫₀ˣ Φy′ᵀΦy′ dξ: wc is the foreshortening, the axial pull-in of a bent
beam (second order in B; dropping it, H ≡ 0, gives the zero-order model that misses
geometric stiffening). q = (θ, A, B); A is absent when axial stretch is off
(inextensible beam, foreshortening kept). The inertial position is r = R(θ)p.

Differentiating, ṙ = R G q̇ with the field Jacobian G = [E p, ∂p/∂(A,B)] (2 × n),
E = [[0, −1], [1, 0]], ∂p/∂(A,B) = [[Φx, −(HB)ᵀ], [0, Φy]]; and r̈ = R(G q̈ + c) with

    c = −θ̇² p + 2θ̇ E ṗ + [−ḂᵀHḂ, 0]ᵀ     (centripetal, Coriolis, foreshortening rate).

Virtual work of the inertia forces, ∫ρS δrᵀr̈ dx, gives M q̈ − Q_v with

    M(q) = J_h e₁e₁ᵀ + ∫ρS GᵀG dx      (independent of θ),
    Q_v  = −∫ρS Gᵀ c dx.

Potential energies: U = ½AᵀK1A + ½BᵀK2B with K1 = ∫ES Φx′ᵀΦx′, K2 = ∫EI Φy″ᵀΦy″;
V_g = g ∫ρS e_Yᵀ r dx = g (sinθ ∫ρS p₁ + cosθ ∫ρS p₂), so Q_g = −∇V_g is computed
from the integrated tables ∫ρS Φx, ∫ρS Φy, ∫ρS H (no per-point work). Drive torque
Q_τ = τ(t) e₁, τ = τ0 sin(2πt/T) for t ≤ T and 0 after. Stiffness-proportional
structural damping Q_d = −β [0, K1 Ȧ, K2 Ḃ].

Contact with the plane Y = −h0 at material point x_P: g = e_Yᵀ R p(x_P) + h0,
g_q = e_Yᵀ R G(x_P), and since g̈ = g_q q̈ + e_Yᵀ R c(x_P), γ_g = −e_Yᵀ R c(x_P).

Energy: T = ½ q̇ᵀMq̇, U, V_g, and the continuous contact potential; with gravity alone
dE/dt = 0 along the motion (tests/models/test_hubbeam.py checks this numerically).

Discretizations (tables from :mod:`daebench.models.shapes`): clamped–free cantilever
modes (N per direction, normalized ∫Φy_iΦy_j dx = L δ_ij, evaluated cancellation-free)
with axial modes sin((2i−1)πx/2L); or Hermite-cubic/linear finite elements.
The per-evaluation work is in :mod:`daebench.models._hubbeam_kernels` (numba): one
pass over a fixed set of quadrature points, O(nq·nB²) with foreshortening.

Note on conditioning: with J_h = 0 (beam-impact) the rigid rotation field x·δθ is
almost in the span of the clamped modes, so cond(M) grows with N (≈ 4e3, 2e4, 1e5,
2e5 at N = 3, 5, 9, 12). That is the model, not a defect of the tables.

Modal participation (observables ``W1..WN``, modes only):
W_i = Φy_i(L) B_i / Σ_j |Φy_j(L) B_j|.
"""

from __future__ import annotations

import copy
import math
from collections import OrderedDict

import numpy as np

from typing import NamedTuple

from numba import njit

from daebench.core import kernels
from daebench.core.contact import contact_schema
from daebench.models import _hubbeam_jacobians as hj
from daebench.models import _hubbeam_kernels as kern
from daebench.models.meshfree import (MAX_INFLUENCE, MAX_NODES, MESHFREE_CELL_GAUSS, MESHFREE_INFLUENCE,
                                       MIN_INFLUENCE, meshfree_basis)
from daebench.models.shapes import (FEM_POINTS_PER_ELEMENT, MAX_ELEMENTS, MAX_MODES, MODE_PANELS,
                                     MODE_POINTS_PER_PANEL, fem_basis, modal_basis, tabulate)
from daebench.core.observables import Observable, Position
from daebench.core.params import Param
from daebench.core.scene import Scene, SceneError
from daebench.core.system import KernelSystem

#: discretization.kind → shape builder (length, n, axial, **options) -> ShapeBasis
BUILDERS = {"modes": modal_basis, "fem": fem_basis, "meshfree": meshfree_basis}
#: extra scene keys ``discretization.<key>`` a builder takes as keyword arguments
BUILDER_OPTIONS: dict[str, tuple[str, ...]] = {"meshfree": ("influence", "cell_gauss")}

_TABLES: OrderedDict = OrderedDict()  # the last few discretizations' (basis, quadrature tables)
_TABLES_KEPT = 4


def basis_tables(kind: str, L: float, n: int, axial: bool, opts: dict, points: tuple[float, ...],
                 fore: bool) -> tuple:
    """(basis, :func:`~daebench.models.shapes.tabulate` tables) of a discretization: computed
    once per process for the last few (5 ms each for the modal N = 5 beam, a fifth of a short
    run's set-up; a sweep builds the same scene again and again); each caller gets its own copy."""
    key = (kind, L, n, axial, tuple(sorted(opts.items())), points, fore)
    if key not in _TABLES:
        basis = BUILDERS[kind](L, n, axial, **opts)
        _TABLES[key] = (basis, tabulate(basis, np.array(points), foreshortening=fore))
        while len(_TABLES) > _TABLES_KEPT:
            _TABLES.popitem(last=False)
    _TABLES.move_to_end(key)
    return copy.deepcopy(_TABLES[key])


DESCRIPTION = "flexible beam on a turning hub (modes or FEM), gravity, torque, damping, contact with a plane"

#: the history's columns as the scorer reads them (daebench.core.observables); the
#: fingerprint tolerances are 50× (θ) the agreement between the reference (IDA rtol 1e-11)
#: and its 10× looser check run on beam-impact (1.8e-6°)
OBSERVABLES = (
    Observable("theta_deg", "deg", "θ", short="theta", derivative="omega", derivative_factor=180.0 / math.pi,
               fingerprint_tol=1e-4, impact_windows=True, summary=True),
    Observable("omega", "rad/s", "ω"),
    Observable("tip_w2", "m", "tip deflection", summary=True),
    Observable("gap", "m", "gap", height=True),
    Observable("tip_x", "m", "tip x"),
    Observable("tip_y", "m", "tip y", fingerprint_tol=1e-6, height=True, summary=True),
    Position("tip", "tip_x", "tip_y", label="tip position", impact_windows=True, angle="chord",
             angle_label="chord angle hinge→tip"),
)

# Dense H tables cost nq·nB² doubles; refuse scenes that would need more than this.
MAX_TABLE_BYTES = 512 * 2**20
CONTACT = contact_schema(("constraint", "hertz", "penalty"),
                         hertz_rule="(4/3) E/(1−ν²) √r, r = contact.hertz_radius, ν = beam.poisson")

SCHEMA: dict[str, Param] = {
    p.name: p
    for p in (
        Param("discretization.kind", str, "modes", "shape functions of the beam",
              choices=("modes", "fem", "meshfree")),
        Param("discretization.n", int, 5,
              f"modes per direction (modes: 1..{MAX_MODES}), number of elements (fem: 1..{MAX_ELEMENTS}) or of "
              f"nodes, root included (meshfree: 3..{MAX_NODES})", low=1, high=MAX_ELEMENTS),
        Param("discretization.influence", float, MESHFREE_INFLUENCE,
              "meshfree: influence-domain radius in nodal spacings", low=MIN_INFLUENCE, high=MAX_INFLUENCE),
        Param("discretization.cell_gauss", int, MESHFREE_CELL_GAUSS, "meshfree: Gauss points per background cell",
              low=1, high=16),
        Param("effects.gravity", bool, True, "gravity along −Y"),
        Param("effects.axial", bool, True, "axial stretch (off: inextensible beam, foreshortening kept)"),
        Param("effects.foreshortening", bool, True, "first-order coupling (off: zero-order model, H ≡ 0)"),
        Param("effects.torque", bool, False, "drive torque τ(t) on the hub"),
        Param("effects.damping", bool, False, "stiffness-proportional structural damping"),
        Param("effects.contact", bool, False, "contact of one beam point with the plane Y = −h0"),
        Param("beam.length", float, 1.0, "beam length L", low=1e-3, high=1e3, unit="m"),
        Param("beam.area", float, 3.14e-4, "cross-section area S", low=1e-10, high=10.0, unit="m^2"),
        Param("beam.inertia", float, 7.85e-9, "second moment of area I", low=1e-20, high=10.0, unit="m^4"),
        Param("beam.density", float, 2.7667e3, "density ρ", low=1.0, high=1e5, unit="kg/m^3"),
        Param("beam.modulus", float, 6.8952e10, "Young's modulus E", low=1e3, high=1e13, unit="Pa"),
        Param("beam.poisson", float, 0.33, "Poisson ratio ν (Hertz stiffness)", low=0.0, high=0.5),
        Param("hub.radius", float, 0.0, "hub radius a (beam root at radius a)", low=0.0, high=1e3, unit="m"),
        Param("hub.inertia", float, 0.0, "hub moment of inertia J_h about the hinge", low=0.0, high=1e9,
              unit="kg m^2"),
        Param("gravity.g", float, 9.81, "gravitational acceleration", low=0.0, high=1e3, unit="m/s^2"),
        Param("torque.tau0", float, 0.0, "torque amplitude τ0 in τ = τ0 sin(2πt/T), t ≤ T", low=-1e9, high=1e9,
              unit="N m"),
        Param("torque.period", float, 2.0, "torque duration T (one sine period, 0 after)", low=1e-9, high=1e6,
              unit="s"),
        Param("damping.beta", float, 0.0, "structural damping β in Q_d = −β K v_elastic", low=0.0, high=10.0,
              unit="s"),
        *CONTACT.params,
        Param("contact.plane_height", float, 0.0, "the plane is Y = −h0 (0: through the hinge)", low=-1e3,
              high=1e3, unit="m"),
        Param("contact.point", float, 1.0, "contact point x_P as a fraction of L (1 = tip)", low=1e-6, high=1.0),
        Param("contact.hertz_radius", float, 0.01, "radius r of the tip sphere for the default Hertz K",
              low=1e-9, high=1e3, unit="m"),
        Param("start.theta_deg", float, 0.0, "initial hub angle θ from +X", low=-3600.0, high=3600.0, unit="deg"),
        Param("start.omega", float, 0.0, "initial angular velocity θ̇", low=-1e4, high=1e4, unit="rad/s"),
    )
}


# -- kernel data and its registration (daebench.core.kernels) ---------------------------------------
class HubBeamData(NamedTuple):
    """Tables and parameters of one hub–beam scene (point-contiguous, see the module
    docstring); ``work`` and ``G1`` are scratch."""

    prm: np.ndarray
    fore: int
    xs: np.ndarray
    wm: np.ndarray
    phx: np.ndarray
    phy: np.ndarray
    H: np.ndarray
    Mc: np.ndarray
    K1: np.ndarray
    K2: np.ndarray
    phx_bar: np.ndarray
    phy_bar: np.ndarray
    Hbar: np.ndarray
    work: np.ndarray
    xp: float          # the contact point's material coordinate and its tables
    phx_p: np.ndarray
    phy_p: np.ndarray
    H_p: np.ndarray
    G1: np.ndarray


@njit(cache=True, fastmath=kern.FASTMATH)
def _k_mass_force(md, t, q, v, M, Q):
    kern.mass_force(t, q, v, md.prm, md.fore, md.xs, md.wm, md.phx, md.phy, md.H, md.Mc, md.K1, md.K2, md.phx_bar,
               md.phy_bar, md.Hbar, True, M, Q, md.work)


@njit(cache=True, fastmath=kern.FASTMATH)
def _k_force_jacobian(md, t, q, v, Kq, Kv):
    hj.force_jacobian(t, q, v, md.prm, md.fore, md.xs, md.wm, md.phx, md.phy, md.H, md.K1, md.K2, md.phx_bar,
                      md.phy_bar, md.Hbar, Kq, Kv)


@njit(cache=True, fastmath=kern.FASTMATH)
def _k_mass_jacobian_product(md, q, a, K):
    hj.mass_jacobian_product(q, a, md.prm, md.fore, md.xs, md.wm, md.phx, md.phy, md.H, K)


@njit(cache=True, fastmath=kern.FASTMATH)
def _k_gap(md, i, q, v, gq):
    return kern.gap_kernel(q, v, md.prm, md.fore, md.xp, md.phx_p, md.phy_p, md.H_p, gq, md.G1)


kernels.register(HubBeamData, mass_force=_k_mass_force, force_jacobian=_k_force_jacobian,
                 mass_jacobian_product=_k_mass_jacobian_product, gap=_k_gap)


def hertz_default_stiffness(modulus: float, poisson: float, radius: float) -> float:
    """K = (4/3) E/(1 − ν²) √r: a sphere of radius r on a rigid plane."""
    return 4.0 / 3.0 * modulus / (1.0 - poisson**2) * math.sqrt(radius)


def check_scene(scene: Scene) -> None:
    """Cross-key checks; raise :class:`SceneError` naming the key and the fix."""
    kind = scene["discretization.kind"]
    n = scene["discretization.n"]
    if kind == "meshfree" and not 3 <= n <= MAX_NODES:
        raise SceneError(f"scene key 'discretization.n' = {n} is out of range [3, {MAX_NODES}] for "
                         f"discretization.kind = 'meshfree' (number of nodes, root included)")
    if kind == "modes" and not 1 <= n <= MAX_MODES:
        raise SceneError(f"scene key 'discretization.n' = {n} is out of range [1, {MAX_MODES}] for "
                         f"discretization.kind = 'modes' (number of cantilever modes)")
    if kind == "fem" and not 1 <= n <= MAX_ELEMENTS:
        raise SceneError(f"scene key 'discretization.n' = {n} is out of range [1, {MAX_ELEMENTS}] for "
                         f"discretization.kind = 'fem' (number of elements)")
    if scene["effects.foreshortening"]:
        nB = n if kind == "modes" else 2 * n
        nq = MODE_PANELS * MODE_POINTS_PER_PANEL if kind == "modes" else FEM_POINTS_PER_ELEMENT * n
        if 8 * nq * nB * nB > MAX_TABLE_BYTES:
            raise SceneError(f"scene key 'discretization.n' = {n}: foreshortening tables would need "
                             f"{8 * nq * nB * nB / 2**20:.0f} MiB; use fewer elements or "
                             f"effects.foreshortening = false")
    CONTACT.check(scene)
    if scene["effects.torque"] and scene["torque.period"] <= 0.0:
        raise SceneError("scene key 'torque.period' must be > 0")


def build(scene: Scene) -> "HubBeam":
    """The hub–beam system a scene describes (only switched-on effects are assembled)."""
    check_scene(scene)
    return HubBeam(scene)


class HubBeam(KernelSystem):
    """Hub–beam :class:`~daebench.core.system.KernelSystem`; see the module docstring. Its
    physics is the kernels of :class:`HubBeamData`; the protocol methods derive from them."""

    def __init__(self, scene: Scene):
        s = scene
        self.scene = s
        self.kind = s["discretization.kind"]
        self.effects = {k: bool(s[f"effects.{k}"]) for k in
                        ("gravity", "axial", "foreshortening", "torque", "damping", "contact")}
        L = self.length = s["beam.length"]
        rho, S, EI = s["beam.density"], s["beam.area"], s["beam.modulus"] * s["beam.inertia"]
        ES = s["beam.modulus"] * S
        rhoS = rho * S
        a = s["hub.radius"]
        fore = self.effects["foreshortening"]
        opts = {k: s[f"discretization.{k}"] for k in BUILDER_OPTIONS.get(self.kind, ())}
        self.x_contact = s["contact.point"] * L
        # extra material points: 0 = tip, 1 = contact point
        basis, tab = basis_tables(self.kind, L, s["discretization.n"], self.effects["axial"], opts,
                                  (L, self.x_contact), fore)
        self.tables = tab
        self.basis = basis
        nA, nB = basis.n_axial, basis.n_transverse
        self.nA, self.nB = nA, nB
        self.n = 1 + nA + nB
        self.n_contacts = 1 if self.effects["contact"] else 0
        self.coordinate_names = ("theta",) + tuple(basis.axial_names) + tuple(basis.transverse_names)
        self.iA = slice(1, 1 + nA)
        self.iB = slice(1 + nA, 1 + nA + nB)

        at, w = tab.at, tab.w
        wm = rhoS * w
        self.K1 = np.ascontiguousarray((at.dphx * (ES * w)[:, None]).T @ at.dphx)
        self.K2 = np.ascontiguousarray((at.ddphy * (EI * w)[:, None]).T @ at.ddphy)
        self.K1 = 0.5 * (self.K1 + self.K1.T)
        self.K2 = 0.5 * (self.K2 + self.K2.T)
        Mc = np.zeros((self.n, self.n))
        Mc[0, 0] = s["hub.inertia"]
        Mc[self.iA, self.iA] = (at.phx * wm[:, None]).T @ at.phx
        Mc[self.iB, self.iB] = (at.phy * wm[:, None]).T @ at.phy
        self.Mc = 0.5 * (Mc + Mc.T)
        H = tab.H if fore else np.zeros((1, 1, 1))
        Hbar = np.einsum("k,kij->ij", wm, tab.H) if fore else np.zeros((nB, nB))
        Hp = tab.H_points if fore else np.zeros((2, nB, nB))

        prm = np.zeros(kern.N_PRM)
        prm[kern.P_A] = a
        prm[kern.P_JH] = s["hub.inertia"]
        prm[kern.P_G] = s["gravity.g"] if self.effects["gravity"] else 0.0
        prm[kern.P_TAU0] = s["torque.tau0"]
        prm[kern.P_T] = s["torque.period"]
        prm[kern.P_TORQUE] = 1.0 if self.effects["torque"] else 0.0
        prm[kern.P_BETA] = s["damping.beta"] if self.effects["damping"] else 0.0
        prm[kern.P_H0] = s["contact.plane_height"]
        prm[kern.P_M1] = float(np.sum(wm * (a + tab.x)))
        self.prm = prm
        self.fore = 1 if fore else 0
        c = np.ascontiguousarray
        nq = tab.x.size
        # point-contiguous tables (kernels loop over quadrature points innermost); the
        # material points are 0 = tip, 1 = contact point
        self._pt = [(float(tab.points[i]), c(tab.at_points.phx[i]), c(tab.at_points.phy[i]), c(Hp[i]))
                    for i in range(2)]
        xp, phx_p, phy_p, H_p = self._pt[1]
        self.data = HubBeamData(prm, self.fore, c(tab.x), c(wm), c(at.phx.T), c(at.phy.T), c(H.transpose(1, 2, 0)),
                                self.Mc, c(self.K1), c(self.K2), c(wm @ at.phx), c(wm @ at.phy), c(Hbar),
                                np.zeros((nB + 8, nq)), xp, phx_p, phy_p, H_p, np.zeros(self.n))

        self.contact_restitution = float(s["contact.restitution"])
        if self.effects["contact"]:
            self.hertz_stiffness = s["contact.hertz_stiffness"] or hertz_default_stiffness(
                s["beam.modulus"], s["beam.poisson"], s["contact.hertz_radius"])
            self.contact_law = CONTACT.law(s, 1, self.hertz_stiffness)
        else:
            self.contact_law = None

    # -- bookkeeping ----------------------------------------------------------------
    def tip_position(self, q: np.ndarray) -> tuple[float, float]:
        """Inertial tip position r(L) = R(θ) p(L) (the observables tip_x, tip_y)."""
        o = self.observables(0.0, q, np.zeros(self.n))
        return o["tip_x"], o["tip_y"]

    def output_rows(self, t: np.ndarray, q: np.ndarray, v: np.ndarray) -> tuple[dict[str, np.ndarray],
                                                                              dict[str, np.ndarray]]:
        """(observables, energy terms) of the states ``q[r]``, ``v[r]`` at times ``t[r]``, as
        columns: one compiled pass over the rows (:func:`daebench.models._hubbeam_kernels.output_rows`,
        the model's one place for these formulas), the continuous contact law's potential
        added (:meth:`contact_potential`). :meth:`energy` and :meth:`observables` are one row of it."""
        q = np.ascontiguousarray(q, dtype=float).reshape(-1, self.n)
        v = np.ascontiguousarray(v, dtype=float).reshape(-1, self.n)
        if v.shape != q.shape or np.size(t) != q.shape[0]:
            raise ValueError(f"output_rows: {np.size(t)} times, q {q.shape}, v {v.shape}: one row each")
        names = self._obs_names
        obs = np.empty((q.shape[0], len(names)))
        en = np.empty((q.shape[0], len(kern.ENERGY_TERMS)))
        d = self.data
        xt, phx_t, phy_t, H_t = self._pt[0]
        kern.output_rows(np.asarray(t, dtype=float), q, v, self.kernel_handle(), d.prm, d.fore, d.K1, d.K2, d.phx_bar,
                         d.phy_bar, d.Hbar, xt, phx_t, phy_t, H_t, self.n_contacts > 0, self.kind == "modes", obs, en)
        terms = {k: en[:, j] for j, k in enumerate(kern.ENERGY_TERMS)}
        law = self.contact_law
        if law is not None and law.continuous and self.n_contacts:
            terms["contact"] = np.array([float(law.potential(obs[r, 5:6])) for r in range(q.shape[0])])
        else:
            terms["contact"] = np.zeros(q.shape[0])
        cols = {k: obs[:, j] for j, k in enumerate(names)}
        for j, c in enumerate(self.coordinate_names):   # the state, for the modal measures (never scored)
            cols[f"q_{c}"], cols[f"v_{c}"] = q[:, j].copy(), v[:, j].copy()
        return cols, terms

    @property
    def _obs_names(self) -> tuple[str, ...]:
        """The columns of :meth:`output_rows`' observables (kern.output_rows writes them in this order)."""
        return (kern.OBS_FIXED + (("gap",) if self.n_contacts else ())
                + (tuple(f"W{i + 1}" for i in range(self.nB)) if self.kind == "modes" else ()))

    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {k: float(x[0]) for k, x in self.output_rows(np.zeros(1), q, v)[1].items()}

    @property
    def power_free(self) -> bool:
        return not (self.effects["torque"] or self.effects["damping"])

    def power(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        out: dict[str, float] = {}
        if self.effects["torque"]:
            out["torque"] = kern.torque(float(t), self.prm) * float(v[0])
        if self.effects["damping"]:
            vA, vB = v[self.iA], v[self.iB]
            out["damping"] = -self.prm[kern.P_BETA] * float(vA @ self.K1 @ vA + vB @ self.K2 @ vB)
        return out

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {k: float(x[0]) for k, x in self.output_rows(np.full(1, float(t)), q, v)[0].items()}

    def linearisation(self, q: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(M, K) of the motion linearised about the configuration ``q`` at rest (default:
        the initial one): the mass matrix there and the tangent stiffness K = −∂Q/∂q
        (elastic, and gravity's), symmetrised; their generalized eigenvectors are the
        model's linearised modes (:mod:`daebench.harness.scoring.modal`)."""
        q0 = self.initial_state()[0] if q is None else np.asarray(q, float)
        v0 = np.zeros(self.n)
        Kq, _ = self.force_jacobian(0.0, q0, v0)
        return np.asarray(self.mass(q0), float), -0.5 * (Kq + Kq.T)

    def finer(self) -> "HubBeam":
        """The same scene on a finer discretization (twice the modes, at most MAX_MODES;
        twice the elements or nodes): the converged frequencies a mode is tested against."""
        n = self.scene["discretization.n"]
        fine = min(2 * n, MAX_MODES) if self.kind == "modes" else min(2 * n, MAX_NODES if self.kind == "meshfree"
                                                                          else MAX_ELEMENTS)
        return HubBeam(self.scene.with_overrides({"discretization.n": fine}))

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        q0 = np.zeros(self.n)
        v0 = np.zeros(self.n)
        q0[0] = math.radians(self.scene["start.theta_deg"])
        v0[0] = self.scene["start.omega"]
        return q0, v0
