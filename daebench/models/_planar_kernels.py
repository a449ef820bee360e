"""Compiled kernels of planar elastic bodies on floating frames with node-to-segment
contact (:mod:`daebench.core.kernels` interface; the model is :mod:`daebench.models.planar`).

Coordinates: q = absolute positions (x, y) of every node of every flexible body,
node i ↔ q[2i], q[2i + 1]. Each body b carries a floating frame with fixed-node
reference conditions (Shabana 2013, §5.4): origin at its node a_b, x axis through its
node b_b. Its rotation θ_b = atan2(d) − θ_ref,b (d = x_b − x_a) and its deformation

    u_P = A(θ_b)ᵀ (x_P − x_a) − X̄_P          (X̄: reference position relative to a)

give the strain energy V = Σ_b ½ u_bᵀ K_b u_b (K_b the plane-stress stiffness of the
body in its frame). This is the floating-frame-of-reference model (R, θ, u) of the
interactive-mode paper [docs/sources.md §D.1] in other generalized coordinates: with lumped
nodal masses its kinetic energy ½ Σ m_P |ṙ_P|² is the same function of the nodal
velocities, so the Lagrangian is the same; written in the absolute nodal positions the
mass matrix is constant and diagonal and the coupling of rigid motion and deformation
moves from the inertia (quadratic-velocity terms) into V through θ(x). V is invariant
under rigid motions (momentum and angular momentum are conserved); the model is
linear elastic in the frame, as the paper's.

Kernels: mass_force (M = diag(m); Q = −∂V/∂q + f_c, with f_c the held nodal contact
force of the interactive-mode integrator, zero otherwise; an M with no rows is left
alone — the explicit steppers of :mod:`daebench.integrators.central` ask for the force
only), force_jacobian (−A K Aᵀ node block by node block, plus the exact columns (and,
by symmetry, rows) of the four frame DOFs by central differences: the Hessian of V
differs from A K Aᵀ only there), mass_jacobian_product (zero), gap.

Contact (node to segment, Wriggers 2006 §9.1): contact point i is slave node s_i
against master polyline m_i, whose points are nodes of a flexible body or fixed
points. Traversing a polyline, the body is on the left: a segment P0 → P1 has the unit
outward normal n = (t_y, −t_x)/|t|, t = P1 − P0. The slave is paired with the segment
closest to it (Euclidean distance to the segment); then

    g = nᵀ (r_S − r_M),  r_M = P0 + ξ t,  ξ = (r_S − P0)·t / |t|²,

and, because n ⊥ t, g = nᵀ(r_S − P0) exactly, with the exact Jacobian
∂g/∂r_S = n, ∂g/∂P0 = −(1 − ξ) n, ∂g/∂P1 = −ξ n. γ_g (g̈ = g_q q̈ − γ_g) is zero for a
fixed master and −d(g_q)/dt · v by a central difference along v otherwise.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core import kernels
from daebench.core.kernels import fd_step


class PlanarData(NamedTuple):
    """Kernel data of a set of planar bodies (see the module docstring)."""

    mass: np.ndarray        # (n,) lumped mass of each DOF [kg]
    Xref: np.ndarray        # (n,) reference position of each node relative to its body's node a [m]
    body_nodes: np.ndarray  # (nb + 1,) int64: body b owns nodes body_nodes[b] … body_nodes[b + 1] − 1
    frame: np.ndarray       # (nb, 2) int64: nodes a, b of each body's floating frame
    theta_ref: np.ndarray   # (nb,) angle of X̄_b in the body frame
    K_ptr: np.ndarray       # CSR of the block-diagonal stiffness (n × n) in the body frames
    K_idx: np.ndarray
    K_val: np.ndarray
    fc: np.ndarray          # (n,) held nodal contact force (interactive-mode integrator) [N]
    lam: np.ndarray         # (k,) the normal force of each contact point behind fc [N]
    slave: np.ndarray       # (k,) int64: slave node of each contact point
    surface: np.ndarray     # (k,) int64: master polyline of each contact point
    surf_ptr: np.ndarray    # (ns + 1,) int64: points of polyline j are surf_ptr[j] … surf_ptr[j + 1] − 1
    pt_node: np.ndarray     # (npt,) int64: node of a polyline point, −1 for a fixed point
    pt_xy: np.ndarray       # (npt, 2): position of a fixed point
    elem_nodes: np.ndarray  # (nel, 4) int64, −1 padded (triangles)
    elem_K: np.ndarray      # (nel, 8, 8) element stiffness in the body frame
    elem_body: np.ndarray   # (nel,) int64
    node_body: np.ndarray   # (N,) int64
    node_elem_ptr: np.ndarray  # CSR node → elements
    node_elems: np.ndarray
    u: np.ndarray           # (n,) scratch: deformation
    F: np.ndarray           # (n,) scratch: K u
    Qp: np.ndarray          # (n,) scratch: force at a perturbed state
    Qm: np.ndarray          # (n,) scratch


# -- floating frames and elastic force -----------------------------------------------------
@njit(cache=True, inline="always")
def frame_angle(md, b, q):
    """(θ_b, cos θ_b, sin θ_b, d_x, d_y) of body b at q."""
    a, c = md.frame[b, 0], md.frame[b, 1]
    dx = q[2 * c] - q[2 * a]
    dy = q[2 * c + 1] - q[2 * a + 1]
    th = math.atan2(dy, dx) - md.theta_ref[b]
    return th, math.cos(th), math.sin(th), dx, dy


@njit(cache=True)
def elastic_force(md, q, Q):
    """Q = −∂V/∂q (overwritten); returns the strain energy V."""
    V = 0.0
    u, F = md.u, md.F
    for b in range(md.frame.shape[0]):
        a, c = md.frame[b, 0], md.frame[b, 1]
        _, co, si, dx, dy = frame_angle(md, b, q)
        n0, n1 = md.body_nodes[b], md.body_nodes[b + 1]
        xa, ya = q[2 * a], q[2 * a + 1]
        for P in range(n0, n1):
            rx, ry = q[2 * P] - xa, q[2 * P + 1] - ya
            u[2 * P] = co * rx + si * ry - md.Xref[2 * P]
            u[2 * P + 1] = -si * rx + co * ry - md.Xref[2 * P + 1]
        for i in range(2 * n0, 2 * n1):
            s = 0.0
            for k in range(md.K_ptr[i], md.K_ptr[i + 1]):
                s += md.K_val[k] * u[md.K_idx[k]]
            F[i] = s
        gth = 0.0
        sfx = 0.0
        sfy = 0.0
        for P in range(n0, n1):
            fx, fy = F[2 * P], F[2 * P + 1]
            V += 0.5 * (u[2 * P] * fx + u[2 * P + 1] * fy)
            wx = u[2 * P] + md.Xref[2 * P]
            wy = u[2 * P + 1] + md.Xref[2 * P + 1]
            gth += wy * fx - wx * fy                   # ∂u_P/∂θ = (w_y, −w_x)
            sfx += fx
            sfy += fy
            Q[2 * P] = -(co * fx - si * fy)            # −A F_P
            Q[2 * P + 1] = -(si * fx + co * fy)
        Q[2 * a] += co * sfx - si * sfy                # ∂u_P/∂x_a = −Aᵀ: +A ΣF (≈ 0)
        Q[2 * a + 1] += si * sfx + co * sfy
        d2 = dx * dx + dy * dy
        tx, ty = -dy / d2, dx / d2                     # ∂θ/∂x_b = −∂θ/∂x_a
        Q[2 * c] -= gth * tx
        Q[2 * c + 1] -= gth * ty
        Q[2 * a] += gth * tx
        Q[2 * a + 1] += gth * ty
    return V


@njit(cache=True)
def _mass_force(md, t, q, v, M, Q):
    n = q.shape[0]
    if M.shape[0] == n:
        for i in range(n):
            for j in range(n):
                M[i, j] = 0.0
            M[i, i] = md.mass[i]
    elastic_force(md, q, Q)
    for i in range(n):
        Q[i] += md.fc[i]


@njit(cache=True)
def _force_jacobian(md, t, q, v, Kq, Kv):
    n = q.shape[0]
    Kq[:, :] = 0.0
    Kv[:, :] = 0.0
    for b in range(md.frame.shape[0]):
        _, co, si, _, _ = frame_angle(md, b, q)
        for i in range(2 * md.body_nodes[b], 2 * md.body_nodes[b + 1]):
            P, al = i // 2, i % 2
            a0, a1 = (co, si) if al == 0 else (-si, co)          # column al of A
            for k in range(md.K_ptr[i], md.K_ptr[i + 1]):
                j = md.K_idx[k]
                R = j // 2
                b0, b1 = (co, si) if j % 2 == 0 else (-si, co)
                kij = md.K_val[k]
                Kq[2 * P, 2 * R] -= a0 * kij * b0                # −(A K Aᵀ), node block (P, R)
                Kq[2 * P, 2 * R + 1] -= a0 * kij * b1
                Kq[2 * P + 1, 2 * R] -= a1 * kij * b0
                Kq[2 * P + 1, 2 * R + 1] -= a1 * kij * b1
    # the frame DOFs: exact columns of −∂²V/∂q² by central differences, rows by symmetry
    qq = q.copy()   # elastic_force uses md.u, md.F as scratch: differences go to Qp, Qm
    for b in range(md.frame.shape[0]):
        for node in (md.frame[b, 0], md.frame[b, 1]):
            for comp in range(2):
                j = 2 * node + comp
                dx = fd_step(q[j])
                qq[j] = q[j] + dx
                elastic_force(md, qq, md.Qp)
                qq[j] = q[j] - dx
                elastic_force(md, qq, md.Qm)
                qq[j] = q[j]
                for r in range(n):
                    Kq[r, j] = (md.Qp[r] - md.Qm[r]) / (2.0 * dx)
    for b in range(md.frame.shape[0]):
        for node in (md.frame[b, 0], md.frame[b, 1]):
            for comp in range(2):
                j = 2 * node + comp
                for r in range(n):
                    Kq[j, r] = Kq[r, j]



# -- node-to-segment contact -----------------------------------------------------------------
@njit(cache=True, inline="always")
def point_xy(md, p, q):
    node = md.pt_node[p]
    if node >= 0:
        return q[2 * node], q[2 * node + 1]
    return md.pt_xy[p, 0], md.pt_xy[p, 1]


@njit(cache=True, inline="always")
def closest_segment(md, i, q):
    """(g, n_x, n_y, ξ, p0) of contact point i: the master segment p0 → p0 + 1 closest to
    its slave node, the signed gap, the segment's outward unit normal and the
    (unclamped) projection parameter."""
    s = md.slave[i]
    xs, ys = q[2 * s], q[2 * s + 1]
    j = md.surface[i]
    best = math.inf
    out = (math.inf, 0.0, 0.0, 0.0, -1)
    for p in range(md.surf_ptr[j], md.surf_ptr[j + 1] - 1):
        x0, y0 = point_xy(md, p, q)
        x1, y1 = point_xy(md, p + 1, q)
        tx, ty = x1 - x0, y1 - y0
        L2 = tx * tx + ty * ty
        xi = ((xs - x0) * tx + (ys - y0) * ty) / L2
        xc = min(max(xi, 0.0), 1.0)
        ex, ey = xs - x0 - xc * tx, ys - y0 - xc * ty
        dist = ex * ex + ey * ey
        if dist < best:
            best = dist
            L = math.sqrt(L2)
            nx, ny = ty / L, -tx / L
            out = (nx * (xs - x0) + ny * (ys - y0), nx, ny, xi, p)
    return out


@njit(cache=True, inline="always")
def _gap_rate(md, i, q, v):
    """ġ = g_q v of contact point i at (q, v), with the geometry of (q)."""
    g, nx, ny, xi, p = closest_segment(md, i, q)
    s = md.slave[i]
    r = nx * v[2 * s] + ny * v[2 * s + 1]
    for k, w in ((p, 1.0 - xi), (p + 1, xi)):
        node = md.pt_node[k]
        if node >= 0:
            r -= w * (nx * v[2 * node] + ny * v[2 * node + 1])
    return r


@njit(cache=True)
def gap_on_segment(md, i, p, q, gq):
    """Gap of contact point i against master segment p → p + 1 (whichever is closest), its
    Jacobian row into gq; returns (g, whether a master point is a node)."""
    s = md.slave[i]
    xs, ys = q[2 * s], q[2 * s + 1]
    x0, y0 = point_xy(md, p, q)
    x1, y1 = point_xy(md, p + 1, q)
    tx, ty = x1 - x0, y1 - y0
    L2 = tx * tx + ty * ty
    xi = ((xs - x0) * tx + (ys - y0) * ty) / L2
    L = math.sqrt(L2)
    nx, ny = ty / L, -tx / L
    for j in range(gq.shape[0]):
        gq[j] = 0.0
    gq[2 * s] = nx
    gq[2 * s + 1] = ny
    flexible = False
    for k, w in ((p, 1.0 - xi), (p + 1, xi)):
        node = md.pt_node[k]
        if node >= 0:
            flexible = True
            gq[2 * node] -= w * nx
            gq[2 * node + 1] -= w * ny
    return nx * (xs - x0) + ny * (ys - y0), flexible


@njit(cache=True)
def _gap(md, i, q, v, gq):
    p = closest_segment(md, i, q)[4]
    g, flexible = gap_on_segment(md, i, p, q, gq)
    gamma = 0.0
    if flexible:
        vmax = 0.0
        for j in range(v.shape[0]):
            vmax = max(vmax, abs(v[j]))
        if vmax > 0.0:
            qmax = 0.0
            for j in range(q.shape[0]):
                qmax = max(qmax, abs(q[j]))
            eps = fd_step(qmax) / vmax
            qq = q + eps * v
            rp = _gap_rate(md, i, qq, v)
            qq = q - eps * v
            rm = _gap_rate(md, i, qq, v)
            gamma = -(rp - rm) / (2.0 * eps)
    return g, gamma


kernels.register(PlanarData, mass_force=_mass_force, force_jacobian=_force_jacobian,
                 mass_jacobian_product=kernels.constant_mass, gap=_gap)
