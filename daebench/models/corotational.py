"""Planar co-rotational Euler–Bernoulli beam elements: a frame of beams as a compiled model.

Formulation (Crisfield 1991, vol. 1, §7.3; Battini 2002, ch. 2)
----------------------------------------------------------------
Each node carries absolute coordinates (x, y) and each element end a rotation θ measured
from the (stress-free, straight-element) reference configuration. An element between
end points p₁, p₂ has the current chord length l and chord angle β; with its reference
length l₀ and angle β₀ its *local* deformations, in the frame that follows the chord,

    u = l − l₀,     θ̄₁ = θ₁ − (β − β₀),     θ̄₂ = θ₂ − (β − β₀)

are small even when the element turns by any angle (large rotation, small strain). The
local forces are those of the linear Euler–Bernoulli element,

    f_l = (N, M₁, M₂) = K_l (u_l + β_d u̇_l),   K_l = [[EA/l₀, 0, 0], [0, 4EI/l₀, 2EI/l₀],
                                                       [0, 2EI/l₀, 4EI/l₀]],

where β_d u̇_l is the optional stiffness-proportional damping that reproduces the
"time-averaged stress" of the double-pendulum source (docs/sources.md §E.2): the stress averaged
over [t, t + h_s] is σ + (h_s/2) σ̇, i.e. β_d = h_s/2 (modal damping ratio ζ ≈ h_s ω/4).
With r = ∂l/∂p = [−c, −s, 0, c, s, 0], z = [s, −c, 0, −s, c, 0] (∂β/∂p = z/l) and
B = [r; e₃ − z/l; e₆ − z/l] the global internal force and its tangent are

    f_g = Bᵀ f_l,
    ∂f_g/∂p = Bᵀ K_l (B + β_d D) + N z zᵀ/l + (M₁ + M₂)(r zᵀ + z rᵀ)/l²,
    ∂f_g/∂ṗ = β_d Bᵀ K_l B,

with D = ∂(B ṗ)/∂p = [(z·ṗ)/l zᵀ; ((r·ṗ) zᵀ + (z·ṗ) rᵀ)/l²; same] (the rotation of the
damping's rate with the chord). The local angles are wrapped to (−π, π], so an element
may turn any number of times.

Mass: lumped. Each element gives ρA l₀/2 to the translations of both its nodes and
ρI l₀/2 (the section's own rotary inertia) to both its end rotations. Why lumped: in
absolute coordinates it is constant and diagonal — no quadratic-velocity terms, an exact
kinetic energy ½ vᵀMv, M⁻¹ free for explicit methods — and a node touching a rigid
foundation has its own mass, which is how node-to-surface contact is posed (a consistent
cubic co-rotational mass is configuration dependent, Le, Battini & Hjiaj 2011). The cost
is the convergence order of the frequencies: 2 instead of 4 for the consistent mass
(measured in tests/models/test_corotational.py). Gravity and dead loads are constant nodal forces
(gravity: −m_i g on each node's y, consistent with the lumped mass).

Coordinates: a node's translations may be held (a pinned or clamped support) and an end
rotation may be held (a clamp). Two element ends at one node share its rotation unless
they are given separate rotation ids — a revolute joint (hinge) built into the
coordinates, so a pinned pendulum of beams is an ODE without constraints.

Contact: a list of nodes against the smooth foundation y = −h0; gap g = y + h0,
g_q = e_y, γ_g = 0.

References
----------
M. A. Crisfield, Non-linear Finite Element Analysis of Solids and Structures, vol. 1,
Wiley 1991, §7.3 (the co-rotational beam element and its tangent).
J.-M. Battini, Co-rotational beam elements in instability problems, PhD thesis, KTH 2002.
T.-N. Le, J.-M. Battini, M. Hjiaj, Efficient formulation for dynamics of corotational 2D
beams, Comput. Mech. 48 (2011) 153–161 (consistent vs lumped co-rotational mass).
"""

from __future__ import annotations

import math
from typing import NamedTuple, Sequence

import numpy as np
from numba import njit

from daebench.core import kernels
from daebench.core.linalg import STRUCTURED_MIN_N, Sparsity, band_order
from daebench.core.system import KernelSystem


class FrameData(NamedTuple):
    """Kernel data of a frame of co-rotational beams (see the module docstring)."""

    dof: np.ndarray     # int64[ne, 6]: q index of each element's (x₁, y₁, θ₁, x₂, y₂, θ₂); −1 = held
    held: np.ndarray    # float64[ne, 6]: the value of a held coordinate
    l0: np.ndarray      # float64[ne]: reference length
    c0: np.ndarray      # float64[ne]: cos β₀
    s0: np.ndarray      # float64[ne]: sin β₀
    ea: np.ndarray      # float64[ne]: EA
    ei: np.ndarray      # float64[ne]: EI
    beta: float         # stiffness-proportional damping β_d = h_s/2 [s]
    mass: np.ndarray    # float64[n]: lumped mass (diagonal of M)
    fext: np.ndarray    # float64[n]: constant generalized force (gravity, dead loads)
    cdof: np.ndarray    # int64[nc]: q index of each contact node's y
    h0: float           # the foundation is y = −h0


@njit(cache=True)
def _wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


@njit(cache=True)
def gather(md, e, q, v, pe, ve):
    """The element's six end coordinates and velocities (held ones from md.held, rate 0)."""
    for j in range(6):
        k = md.dof[e, j]
        if k >= 0:
            pe[j] = q[k]
            ve[j] = v[k]
        else:
            pe[j] = md.held[e, j]
            ve[j] = 0.0


@njit(cache=True)
def local_state(md, e, pe):
    """(l, c, s, u, θ̄₁, θ̄₂): current chord and local deformations of element e."""
    dx = pe[3] - pe[0]
    dy = pe[4] - pe[1]
    l = math.sqrt(dx * dx + dy * dy)
    c = dx / l
    s = dy / l
    alpha = math.atan2(md.c0[e] * s - md.s0[e] * c, md.c0[e] * c + md.s0[e] * s)  # β − β₀
    return l, c, s, l - md.l0[e], _wrap(pe[2] - alpha), _wrap(pe[5] - alpha)


@njit(cache=True)
def element_force(md, e, pe, ve, fg, Kf, Cf, want_jac):
    """Global internal force f_g of element e into fg (6); with ``want_jac`` its
    tangent ∂f_g/∂p into Kf and ∂f_g/∂ṗ into Cf (6 × 6). Returns the strain energy."""
    l, c, s, u, t1, t2 = local_state(md, e, pe)
    r = (-c, -s, 0.0, c, s, 0.0)
    z = (s, -c, 0.0, -s, c, 0.0)
    rv = 0.0
    zv = 0.0
    for j in range(6):
        rv += r[j] * ve[j]
        zv += z[j] * ve[j]
    ka = md.ea[e] / md.l0[e]
    kb = md.ei[e] / md.l0[e]
    bd = md.beta
    ud, t1d, t2d = rv, ve[2] - zv / l, ve[5] - zv / l   # u̇_l = B ṗ
    N = ka * (u + bd * ud)
    M1 = kb * (4.0 * (t1 + bd * t1d) + 2.0 * (t2 + bd * t2d))
    M2 = kb * (2.0 * (t1 + bd * t1d) + 4.0 * (t2 + bd * t2d))
    for j in range(6):
        fg[j] = N * r[j] - (M1 + M2) * z[j] / l
    fg[2] += M1
    fg[5] += M2
    if want_jac:
        B = np.empty((3, 6))
        for j in range(6):
            B[0, j] = r[j]
            B[1, j] = -z[j] / l
            B[2, j] = -z[j] / l
        B[1, 2] += 1.0
        B[2, 5] += 1.0
        KB = np.empty((3, 6))  # K_l B
        for j in range(6):
            KB[0, j] = ka * B[0, j]
            KB[1, j] = kb * (4.0 * B[1, j] + 2.0 * B[2, j])
            KB[2, j] = kb * (2.0 * B[1, j] + 4.0 * B[2, j])
        l2 = l * l
        for i in range(6):
            for j in range(6):
                kbb = B[0, i] * KB[0, j] + B[1, i] * KB[1, j] + B[2, i] * KB[2, j]
                Cf[i, j] = bd * kbb
                # D = ∂(Bṗ)/∂p: rows (zv/l) z and ((rv) z + (zv) r)/l² (twice)
                d0 = zv / l * z[j]
                d12 = (rv * z[j] + zv * r[j]) / l2
                kd = B[0, i] * ka * d0 + (B[1, i] + B[2, i]) * 6.0 * kb * d12
                Kf[i, j] = kbb + bd * kd + N * z[i] * z[j] / l + (M1 + M2) * (r[i] * z[j] + z[i] * r[j]) / l2
    return 0.5 * (ka * u * u) + kb * (2.0 * t1 * t1 + 2.0 * t1 * t2 + 2.0 * t2 * t2)


@njit(cache=True)
def _mass_force(md, t, q, v, M, Q):
    """M = diag(mass) and Q; an M with no rows is left alone (force only: what a stepper
    asks of a model that declares its mass constant, :meth:`Frame.sparsity`)."""
    n = q.shape[0]
    full = M.shape[0] == n
    for i in range(n):
        if full:
            for j in range(n):
                M[i, j] = 0.0
            M[i, i] = md.mass[i]
        Q[i] = md.fext[i]
    pe = np.empty(6)
    ve = np.empty(6)
    fg = np.empty(6)
    dummy = np.empty((1, 1))
    for e in range(md.l0.shape[0]):
        gather(md, e, q, v, pe, ve)
        element_force(md, e, pe, ve, fg, dummy, dummy, False)
        for j in range(6):
            k = md.dof[e, j]
            if k >= 0:
                Q[k] -= fg[j]


@njit(cache=True)
def _force_jacobian(md, t, q, v, Kq, Kv):
    Kq[:, :] = 0.0
    Kv[:, :] = 0.0
    pe = np.empty(6)
    ve = np.empty(6)
    fg = np.empty(6)
    Kf = np.empty((6, 6))
    Cf = np.empty((6, 6))
    for e in range(md.l0.shape[0]):
        gather(md, e, q, v, pe, ve)
        element_force(md, e, pe, ve, fg, Kf, Cf, True)
        for a in range(6):
            ka = md.dof[e, a]
            if ka < 0:
                continue
            for b in range(6):
                kb = md.dof[e, b]
                if kb >= 0:
                    Kq[ka, kb] -= Kf[a, b]
                    Kv[ka, kb] -= Cf[a, b]



@njit(cache=True)
def _gap(md, i, q, v, gq):
    for j in range(q.shape[0]):
        gq[j] = 0.0
    k = md.cdof[i]
    gq[k] = 1.0
    return q[k] + md.h0, 0.0


kernels.register(FrameData, mass_force=_mass_force, force_jacobian=_force_jacobian,
                 mass_jacobian_product=kernels.constant_mass, gap=_gap)


@njit(cache=True)
def strain_energy_and_damping_power(md, q, v):
    """(Σ elastic energy ½ u_lᵀK_l u_l, damping power −β_d Σ u̇_lᵀK_l u̇_l)."""
    pe = np.empty(6)
    ve = np.empty(6)
    U = 0.0
    P = 0.0
    for e in range(md.l0.shape[0]):
        gather(md, e, q, v, pe, ve)
        l, c, s, u, t1, t2 = local_state(md, e, pe)
        U += 0.5 * md.ea[e] / md.l0[e] * u * u + md.ei[e] / md.l0[e] * (2.0 * t1 * t1 + 2.0 * t1 * t2 + 2.0 * t2 * t2)
        ud = -c * (ve[0] - ve[3]) - s * (ve[1] - ve[4])
        zv = s * (ve[0] - ve[3]) - c * (ve[1] - ve[4])
        t1d, t2d = ve[2] - zv / l, ve[5] - zv / l
        P -= md.beta * (md.ea[e] / md.l0[e] * ud * ud
                        + md.ei[e] / md.l0[e] * (4.0 * t1d * t1d + 4.0 * t1d * t2d + 4.0 * t2d * t2d))
    return U, P


class Frame(KernelSystem):
    """A planar frame of co-rotational Euler–Bernoulli beams (no contact law of its own;
    a model sets ``contact_law``).

    Parameters
    ----------
    nodes : (N, 2) reference positions [m]
    elements : (ne, 2) node pairs
    EA, EI, rhoA, rhoI : per element (scalars broadcast) [N, N m², kg/m, kg m]
    rot_ids : (ne, 2) rotation id of each element end; default: one per node (rigid joints).
        Different ids at one node make a hinge.
    pinned : nodes whose translations are held
    clamped_rotations : rotation ids held at 0
    g : gravity along −y [m/s²]
    loads : {node: (Fx, Fy)} dead loads [N]
    contact_nodes : nodes that can touch the foundation y = −h0
    damping_beta : β_d = h_s/2 of the time-averaged stress [s]
    gravity_datum : height of zero gravitational energy [m] (the foundation, so that the
        energy terms give the run a scale)
    """

    def __init__(self, nodes: np.ndarray, elements: np.ndarray, EA, EI, rhoA, rhoI,
                 rot_ids: np.ndarray | None = None, pinned: Sequence[int] = (),
                 clamped_rotations: Sequence[int] = (), g: float = 0.0,
                 loads: dict[int, tuple[float, float]] | None = None, contact_nodes: Sequence[int] = (),
                 h0: float = 0.0, damping_beta: float = 0.0, gravity_datum: float = 0.0) -> None:
        X = np.asarray(nodes, dtype=float)
        el = np.asarray(elements, dtype=np.int64)
        ne = el.shape[0]
        rot = np.array(el if rot_ids is None else rot_ids, dtype=np.int64)
        names: list[str] = []
        trans: dict[int, int] = {}
        rotk: dict[int, int] = {}
        for a in range(X.shape[0]):  # numbering: per node x, y, then its rotation ids
            if a not in pinned:
                trans[a] = len(names)
                names += [f"x{a}", f"y{a}"]
            for e in range(ne):
                for end in range(2):
                    rid = int(rot[e, end])
                    if el[e, end] == a and rid not in rotk and rid not in clamped_rotations:
                        rotk[rid] = len(names)
                        names.append(f"th{rid}")
        self.n = len(names)
        self.coordinate_names = tuple(names)
        self.nodes = X
        self._trans = trans
        dof = np.full((ne, 6), -1, dtype=np.int64)
        held = np.zeros((ne, 6))
        mass = np.zeros(self.n)
        bc = lambda x: np.broadcast_to(np.asarray(x, dtype=float), (ne,)).copy()  # noqa: E731
        EA, EI, rhoA, rhoI = bc(EA), bc(EI), bc(rhoA), bc(rhoI)
        d = X[el[:, 1]] - X[el[:, 0]]
        l0 = np.hypot(d[:, 0], d[:, 1])
        for e in range(ne):
            for end in range(2):
                a, rid = int(el[e, end]), int(rot[e, end])
                if a in trans:
                    dof[e, 3 * end:3 * end + 2] = (trans[a], trans[a] + 1)
                    mass[[trans[a], trans[a] + 1]] += 0.5 * rhoA[e] * l0[e]
                else:
                    held[e, 3 * end:3 * end + 2] = X[a]
                if rid in rotk:
                    dof[e, 3 * end + 2] = rotk[rid]
                    mass[rotk[rid]] += 0.5 * rhoI[e] * l0[e]
        self.fgrav = np.zeros(self.n)
        for a, k in trans.items():
            self.fgrav[k + 1] = -g * mass[k]
        self.gravity_datum = float(gravity_datum)
        self.fload = np.zeros(self.n)
        for a, (fx, fy) in (loads or {}).items():
            self.fload[trans[a]] += fx
            self.fload[trans[a] + 1] += fy
        self.contact_nodes = tuple(int(a) for a in contact_nodes)
        self.n_contacts = len(self.contact_nodes)
        self.contact_law = None
        self.data = FrameData(dof, held, l0, d[:, 0] / l0, d[:, 1] / l0, EA, EI, float(damping_beta), mass,
                              self.fgrav + self.fload,
                              np.array([trans[a] + 1 for a in self.contact_nodes], dtype=np.int64), float(h0))

    @property
    def power_free(self) -> bool:
        return self.data.beta == 0.0

    def sparsity(self) -> Sparsity | None:
        """The structure of the iteration matrices (:class:`daebench.core.linalg.Sparsity`):
        an element couples its own six end coordinates only, so in the node-by-node
        numbering (or its reverse Cuthill–McKee order) the DOFs form a band, with no
        border; M is diagonal and constant. None (dense LU) below
        ``STRUCTURED_MIN_N`` DOFs, where the dense factorization is as cheap — and the
        default cases (double-pendulum: 50 DOFs) keep their histories bit for bit."""
        if self.n < STRUCTURED_MIN_N:
            return None
        if getattr(self, "_sparsity", None) is None:
            rows, cols = [], []
            for d in self.data.dof:
                d = d[d >= 0]
                rows.append(np.repeat(d, d.size))
                cols.append(np.tile(d, d.size))
            order, bw = band_order(self.n, np.zeros(0, np.int64), np.concatenate(rows), np.concatenate(cols))
            self._sparsity = Sparsity(order, self.n, bw, bw, 0, True)
        return self._sparsity

    # -- geometry ------------------------------------------------------------------------
    def node_position(self, q: np.ndarray, node: int) -> tuple[float, float]:
        k = self._trans.get(node)
        if k is None:
            return float(self.nodes[node, 0]), float(self.nodes[node, 1])
        return float(q[k]), float(q[k + 1])

    def reference_state(self) -> np.ndarray:
        """q of the undeformed reference configuration (positions, zero rotations)."""
        q = np.zeros(self.n)
        for a, k in self._trans.items():
            q[k:k + 2] = self.nodes[a]
        return q

    # -- bookkeeping -------------------------------------------------------------------------
    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        q = np.ascontiguousarray(q, dtype=float)
        U, _ = strain_energy_and_damping_power(self.data, q, np.zeros(self.n))
        out = {"kinetic": 0.5 * float(v @ (self.data.mass * v)), "elastic": float(U),
               "gravity": -float(self.fgrav @ q) + float(np.sum(self.fgrav)) * self.gravity_datum}
        if self.fload.any():
            out["load"] = -float(self.fload @ q)
        if self.n_contacts:
            out["contact"] = self.contact_potential(q)
        return out

    def power(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        if self.data.beta == 0.0:
            return {}
        _, P = strain_energy_and_damping_power(self.data, np.ascontiguousarray(q, dtype=float),
                                               np.ascontiguousarray(v, dtype=float))
        return {"damping": float(P)}

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.reference_state(), np.zeros(self.n)

    # -- statics and linear dynamics (tests, studies) --------------------------------------------
    def static_equilibrium(self, steps: int = 10, tol: float = 1e-12, maxiter: int = 50,
                           q0: np.ndarray | None = None) -> np.ndarray:
        """Q(q) = 0 under the full constant load, reached in ``steps`` equal load increments,
        each by Newton's method with the analytic tangent (converged when the increment is
        below tol · max(1, |q|)). Raises RuntimeError if an increment does not converge."""
        q = self.reference_state() if q0 is None else np.array(q0, dtype=float)
        full = self.data.fext.copy()
        zero = np.zeros(self.n)
        try:
            for k in range(1, steps + 1):
                self.data = self.data._replace(fext=full * (k / steps))
                for _ in range(maxiter):
                    Q = self.applied_force(0.0, q, zero)
                    Kq, _ = self.force_jacobian(0.0, q, zero)
                    dq = np.linalg.solve(Kq, -Q)
                    q += dq
                    if np.max(np.abs(dq)) <= tol * max(1.0, float(np.max(np.abs(q)))):
                        break
                else:
                    raise RuntimeError(f"static Newton did not converge at load step {k}/{steps}")
        finally:
            self.data = self.data._replace(fext=full)
        return q

    def linear_frequencies(self, q: np.ndarray | None = None) -> np.ndarray:
        """Angular frequencies [rad/s] of small vibrations about q (default: the reference
        state), ascending: the eigenvalues of K = −∂Q/∂q with the lumped M (without
        damping)."""
        from scipy.linalg import eigh

        q = self.reference_state() if q is None else q
        Kq, _ = self.force_jacobian(0.0, q, np.zeros(self.n))
        K = -0.5 * (Kq + Kq.T)
        lam = eigh(K, np.diag(self.data.mass), eigvals_only=True)
        return np.sqrt(np.clip(lam, 0.0, None))
