"""The planar model's local statics module for the interactive-mode method (``imm``,
:mod:`daebench.integrators.imm` explains the method, its sources and the choices made
where the paper is silent) and the stepper coupling it to a global dynamics stepper. It
lives with the model because the local region is the model's FE structure; the model
offers it as ``PlanarBodies.local_statics_module()``. The held contact force f_c is in
the model data (``md.fc``, ``md.lam``) and the model's force kernel adds it, so any
global stepper integrates M q̈ = f + f_c unchanged.

Local statics at a global state q (:func:`local_solve`):

1. gaps of every candidate contact point at q; the active set starts as the
   penetrating ones (g < 0); none: f_c = 0;
2. region: every element with a node within ``radius`` of a contact point of an active
   pair (reference coordinates of its body), and every element of the slave node and of
   the master segment's nodes; its *free* nodes are those all of whose elements are in
   the region, the others (interface nodes) keep their global positions;
3. Newton on the free nodes' positions p and the multipliers λ of the active pairs:
   r₁ = f_el(p) + G_pᵀλ = 0, r₂ = g(p) = 0, with f_el the elastic force (the model's
   own kernel, exact in the floating frames), the iteration matrix [[−K_L, G_pᵀ],
   [G_p, 0]], K_L = Σ_e A K_e Aᵀ over the region (frames frozen at q; the curvature of
   g is left out — converged residuals are exact, the iteration is quasi-Newton);
4. active set: drop the pair with the most negative λ, or add a candidate whose slave
   node is free and whose gap at the solution is negative; repeat from 2;
5. f_c = Σ λ_i g_q,iᵀ at the solution (slave node and master nodes), held for the
   next step.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core.dispatch import generic
from daebench.stepping.central import CentralMethod
from daebench.core.linalg import lu_factor, lu_solve
from daebench.models import _planar_kernels as pk
from daebench.models._planar_mesh import smallest_element  # noqa: F401  (part of this module's interface, for imm)
from daebench.stepping import methods
from daebench.stepping.methods import C_LU, C_NEWTON
from daebench.stepping.newmark import NewmarkMethod

ST_LOCAL_NEWTON, ST_LOCAL_SINGULAR, ST_LOCAL_SIZE, ST_ACTIVE_SET = 61, 62, 63, 64
FAIL_MESSAGES = {
    ST_LOCAL_NEWTON: "interactive mode: the local statics Newton iteration did not converge",
    ST_LOCAL_SINGULAR: "interactive mode: singular local statics matrix (a region without interface nodes?)",
    ST_LOCAL_SIZE: "interactive mode: local region larger than max_local_nodes",
    ST_ACTIVE_SET: "interactive mode: the active set did not settle",
}
LOG_COLUMNS = 7     # contact, t start, t end, ġ at start, ġ at end, impulse, smallest gap
S_CONTACT_STEPS, S_REBUILDS, S_SET_CHANGES, S_LOG_LOST, S_MAX_FREE = range(5)


class ImmMethod(NamedTuple):
    inner: tuple          # the global stepper's method data (CentralMethod or NewmarkMethod)
    radius: float         # local region radius [m]
    tol: float            # local Newton: |δp|, |g| below tol × the smallest element size
    maxiter: int
    max_set_changes: int
    lsize: float          # length scale of the tolerance [m]
    model: tuple          # the planar model's own kernel data (the phase carries only its handle)


class ImmWork(NamedTuple):
    inner: tuple          # the global stepper's workspace
    fc: np.ndarray        # the model's held force (same array as md.fc)
    lam_model: np.ndarray  # the model's md.lam
    fc_next: np.ndarray   # (n)
    lam_next: np.ndarray  # (k)
    lam_try: np.ndarray   # (k)
    g: np.ndarray         # (k) gaps at the global state
    seg: np.ndarray       # (k) int64: each contact's master segment at the global state
    gdot: np.ndarray      # (k)
    active: np.ndarray    # (k) int64 flags
    elem_in: np.ndarray   # (nel) int64 flags
    node_map: np.ndarray  # (N) int64: free index or −1
    free: np.ndarray      # (max_free) int64: free nodes
    q_loc: np.ndarray     # (n) the global state with the free nodes moved
    Qel: np.ndarray       # (n)
    gq: np.ndarray        # (k, n) gap Jacobian rows of the active pairs
    A: np.ndarray         # (dim, dim)
    piv: np.ndarray
    rhs: np.ndarray       # (dim)
    t_new: np.ndarray     # [1]: time of the proposed step
    h_new: np.ndarray     # [1]
    ep_open: np.ndarray   # (k) int64
    ep: np.ndarray        # (k, 5): t start, ġ start, impulse, smallest gap, last λ
    log: np.ndarray       # (max_log, LOG_COLUMNS) finished episodes
    n_log: np.ndarray     # [1]
    stats: np.ndarray     # int64 counters (S_*)
    region_key: np.ndarray  # [2] signature of the last region


def workspace(inner_ws: tuple, md: pk.PlanarData, max_free: int, max_log: int = 20000) -> ImmWork:
    n = md.mass.shape[0]
    k = md.slave.shape[0]
    N = n // 2
    max_free = min(max_free, N)
    dim = 2 * max_free + k
    z = np.zeros
    return ImmWork(inner_ws, md.fc, md.lam, z(n), z(k), z(k), z(k), z(k, np.int64), z(k), z(k, np.int64),
                   z(md.elem_nodes.shape[0], np.int64), np.full(N, -1, np.int64), z(max_free, np.int64), z(n), z(n),
                   z((max(k, 1), n)), z((dim, dim)), z(dim, np.int64), z(dim), z(1), z(1), z(k, np.int64), z((k, 5)),
                   z((max_log, LOG_COLUMNS)), z(1, np.int64), z(5, np.int64), z(2))


# -- what changes in the global stepper when the held force changes -------------------------------
@generic
def held_force_changed(inner, a, minv_df):
    """The held force changed by M·minv_df: make the stepper's acceleration agree."""


@njit(cache=True)
def _central_changed(inner, a, minv_df):
    for i in range(a.shape[0]):
        a[i] += minv_df[i]


@njit(cache=True)
def _newmark_changed(inner, a, minv_df):
    pass  # the family's averaging takes the new force as any applied load from the next step on


held_force_changed.register(CentralMethod, _central_changed)
held_force_changed.register(NewmarkMethod, _newmark_changed)


# -- the local statics module -----------------------------------------------------------------------
@njit(cache=True, inline="always")
def _near(md, e, body, cx, cy, r2):
    for j in range(4):
        nd = md.elem_nodes[e, j]
        if nd >= 0 and md.node_body[nd] == body:
            dx = md.Xref[2 * nd] - cx
            dy = md.Xref[2 * nd + 1] - cy
            if dx * dx + dy * dy <= r2:
                return True
    return False


@njit(cache=True, inline="always")
def _mark_node_elements(md, ws, nd):
    for k in range(md.node_elem_ptr[nd], md.node_elem_ptr[nd + 1]):
        ws.elem_in[md.node_elems[k]] = 1


@njit(cache=True)
def build_region(meth, ws, md, q):
    """Mark the region's elements and number its free nodes; returns the free count
    (−1: more than the workspace holds)."""
    nel = md.elem_nodes.shape[0]
    ws.elem_in[:] = 0
    r2 = meth.radius * meth.radius
    for i in range(md.slave.shape[0]):
        if not ws.active[i]:
            continue
        s = md.slave[i]
        _mark_node_elements(md, ws, s)
        bs = md.node_body[s]
        _, _, _, xi, p = pk.closest_segment(md, i, q)
        n0, n1 = md.pt_node[p], md.pt_node[p + 1]
        xc = min(max(xi, 0.0), 1.0)
        for e in range(nel):
            if ws.elem_in[e] == 0 and md.elem_body[e] == bs and _near(md, e, bs, md.Xref[2 * s], md.Xref[2 * s + 1], r2):
                ws.elem_in[e] = 1
        if n0 >= 0 and n1 >= 0:
            _mark_node_elements(md, ws, n0)
            _mark_node_elements(md, ws, n1)
            bm = md.node_body[n0]
            cx = (1.0 - xc) * md.Xref[2 * n0] + xc * md.Xref[2 * n1]
            cy = (1.0 - xc) * md.Xref[2 * n0 + 1] + xc * md.Xref[2 * n1 + 1]
            for e in range(nel):
                if ws.elem_in[e] == 0 and md.elem_body[e] == bm and _near(md, e, bm, cx, cy, r2):
                    ws.elem_in[e] = 1
    nf = 0
    key0 = 0.0
    key1 = 0.0
    for e in range(nel):
        if ws.elem_in[e] == 0:
            continue
        key0 += 1.0
        key1 += e * (e + 1.0)
        for j in range(4):
            nd = md.elem_nodes[e, j]
            if nd < 0 or ws.node_map[nd] >= 0:
                continue
            free = True
            for k in range(md.node_elem_ptr[nd], md.node_elem_ptr[nd + 1]):
                if ws.elem_in[md.node_elems[k]] == 0:
                    free = False
                    break
            if free:
                if nf >= ws.free.shape[0]:
                    return -1
                ws.node_map[nd] = nf
                ws.free[nf] = nd
                nf += 1
    if key0 != ws.region_key[0] or key1 != ws.region_key[1]:
        ws.stats[S_REBUILDS] += 1
        ws.region_key[0] = key0
        ws.region_key[1] = key1
    ws.stats[S_MAX_FREE] = max(ws.stats[S_MAX_FREE], nf)
    return nf


@njit(cache=True)
def _clear_map(ws, nf):
    for j in range(nf):
        ws.node_map[ws.free[j]] = -1


@njit(cache=True)
def _assemble_KL(md, ws, q, nf):
    """A[:2nf, :2nf] = −K_L (region elements, frames frozen at q)."""
    A = ws.A
    for e in range(md.elem_nodes.shape[0]):
        if ws.elem_in[e] == 0:
            continue
        _, co, si, _, _ = pk.frame_angle(md, md.elem_body[e], q)
        for r in range(4):
            nr = md.elem_nodes[e, r]
            if nr < 0 or ws.node_map[nr] < 0:
                continue
            ir = 2 * ws.node_map[nr]
            for s in range(4):
                ns = md.elem_nodes[e, s]
                if ns < 0 or ws.node_map[ns] < 0:
                    continue
                js = 2 * ws.node_map[ns]
                k00, k01 = md.elem_K[e, 2 * r, 2 * s], md.elem_K[e, 2 * r, 2 * s + 1]
                k10, k11 = md.elem_K[e, 2 * r + 1, 2 * s], md.elem_K[e, 2 * r + 1, 2 * s + 1]
                # A K Aᵀ with A = [[co, −si], [si, co]]
                t00, t01 = co * k00 - si * k10, co * k01 - si * k11
                t10, t11 = si * k00 + co * k10, si * k01 + co * k11
                A[ir, js] -= t00 * co - t01 * si
                A[ir, js + 1] -= t00 * si + t01 * co
                A[ir + 1, js] -= t10 * co - t11 * si
                A[ir + 1, js + 1] -= t10 * si + t11 * co


@njit(cache=True)
def _newton(meth, ws, md, q, nf, idx, na, cnt):
    """Local statics for the free nodes and the active pairs idx[:na]; λ in ws.lam_try.
    Returns a status (0: converged)."""
    nd = 2 * nf
    dim = nd + na
    ws.q_loc[:] = q
    tol = meth.tol * meth.lsize
    for it in range(meth.maxiter):
        pk.elastic_force(md, ws.q_loc, ws.Qel)
        A, b = ws.A, ws.rhs
        for i in range(dim):
            for j in range(dim):
                A[i, j] = 0.0
        _assemble_KL(md, ws, q, nf)
        gmax = 0.0
        for j in range(nd):
            b[j] = -ws.Qel[2 * ws.free[j // 2] + j % 2]
        for a in range(na):
            i = idx[a]
            g, _ = pk.gap_on_segment(md, i, ws.seg[i], ws.q_loc, ws.gq[a])   # segment fixed in the solve
            gmax = max(gmax, abs(g))
            b[nd + a] = -g
            lam = ws.lam_try[i]
            for j in range(nd):
                gj = ws.gq[a, 2 * ws.free[j // 2] + j % 2]
                A[j, nd + a] = gj
                A[nd + a, j] = gj
                b[j] -= lam * gj
        if lu_factor(A[:dim, :dim], ws.piv[:dim]) != 0:
            return ST_LOCAL_SINGULAR
        cnt[C_LU] += 1
        cnt[C_NEWTON] += 1
        lu_solve(A[:dim, :dim], ws.piv[:dim], b[:dim])
        dmax = 0.0
        for j in range(nd):
            k = 2 * ws.free[j // 2] + j % 2
            ws.q_loc[k] += b[j]
            dmax = max(dmax, abs(b[j]))
        for a in range(na):
            ws.lam_try[idx[a]] += b[nd + a]
        if dmax <= tol and gmax <= tol:
            return 0
    return ST_LOCAL_NEWTON


@njit(cache=True)
def local_solve(meth, ws, md, q, v, cnt):
    """Steps 1–5 of the module docstring: ws.fc_next and ws.lam_next at the global state
    (q, v); also the gaps and gap rates of every candidate. Returns a status."""
    k = md.slave.shape[0]
    n = q.shape[0]
    any_pen = False
    for i in range(k):
        g, _, _, _, p = pk.closest_segment(md, i, q)
        ws.g[i] = g
        ws.seg[i] = p
        ws.gdot[i] = pk._gap_rate(md, i, q, v)
        ws.active[i] = 1 if ws.g[i] < 0.0 else 0
        any_pen = any_pen or ws.g[i] < 0.0
        ws.lam_try[i] = 0.0
    ws.fc_next[:] = 0.0
    ws.lam_next[:] = 0.0
    if not any_pen:
        return 0
    ws.stats[S_CONTACT_STEPS] += 1
    idx = np.empty(k, np.int64)
    for change in range(meth.max_set_changes):
        nf = build_region(meth, ws, md, q)
        if nf < 0:
            _clear_map(ws, ws.free.shape[0])
            return ST_LOCAL_SIZE
        na = 0
        for i in range(k):
            if ws.active[i]:
                idx[na] = i
                na += 1
        if 2 * nf + na > ws.A.shape[0]:
            _clear_map(ws, nf)
            return ST_LOCAL_SIZE
        st = _newton(meth, ws, md, q, nf, idx, na, cnt)
        if st:
            _clear_map(ws, nf)
            return st
        worst, drop = 0.0, -1
        for a in range(na):
            if ws.lam_try[idx[a]] < worst:
                worst, drop = ws.lam_try[idx[a]], idx[a]
        add = -1
        if drop < 0:
            for i in range(k):
                if not ws.active[i] and ws.node_map[md.slave[i]] >= 0:
                    if pk.gap_on_segment(md, i, ws.seg[i], ws.q_loc, ws.Qel)[0] < 0.0:
                        add = i
                        break
        _clear_map(ws, nf)
        if drop < 0 and add < 0:
            for a in range(na):
                i = idx[a]
                ws.lam_next[i] = ws.lam_try[i]
                for j in range(n):
                    ws.fc_next[j] += ws.lam_try[i] * ws.gq[a, j]
            return 0
        ws.stats[S_SET_CHANGES] += 1
        if drop >= 0:
            ws.active[drop] = 0
            ws.lam_try[drop] = 0.0
        else:
            ws.active[add] = 1
        if na == 1 and drop >= 0:
            return 0        # the last pair pulls: no contact force
    return ST_ACTIVE_SET


# -- the stepper ---------------------------------------------------------------------------------
@njit(cache=True)
def _commit(meth, ws, a, t, h):
    """Hold the new force (and make the stepper's acceleration agree), book episodes."""
    n = ws.fc.shape[0]
    minv_df = ws.Qel          # scratch here
    for i in range(n):
        minv_df[i] = (ws.fc_next[i] - ws.fc[i]) / _mass_of(meth.inner, i)
        ws.fc[i] = ws.fc_next[i]
    held_force_changed(meth.inner, a, minv_df)
    for i in range(ws.lam_next.shape[0]):
        lam = ws.lam_next[i]
        ws.lam_model[i] = lam
        if ws.ep_open[i]:
            ws.ep[i, 2] += ws.ep[i, 4] * h          # the force held over the step just taken
            ws.ep[i, 3] = min(ws.ep[i, 3], ws.g[i])
        if lam > 0.0 and not ws.ep_open[i]:
            ws.ep_open[i] = 1
            ws.ep[i, 0] = t
            ws.ep[i, 1] = ws.gdot[i]
            ws.ep[i, 2] = 0.0
            ws.ep[i, 3] = ws.g[i]
        elif lam <= 0.0 and ws.ep_open[i]:
            ws.ep_open[i] = 0
            r = ws.n_log[0]
            if r < ws.log.shape[0]:
                ws.log[r, 0] = i
                ws.log[r, 1] = ws.ep[i, 0]
                ws.log[r, 2] = t
                ws.log[r, 3] = ws.ep[i, 1]
                ws.log[r, 4] = ws.gdot[i]
                ws.log[r, 5] = ws.ep[i, 2]
                ws.log[r, 6] = ws.ep[i, 3]
                ws.n_log[0] = r + 1
            else:
                ws.stats[S_LOG_LOST] += 1
        ws.ep[i, 4] = lam


@generic
def _mass_of(inner, i):
    """The lumped mass of DOF i as the global stepper knows it (1 when it does not need it)."""


@njit(cache=True)
def _central_mass(inner, i):
    return 1.0 / inner.minv[i]


@njit(cache=True)
def _newmark_mass(inner, i):
    return 1.0


_mass_of.register(CentralMethod, _central_mass)
_mass_of.register(NewmarkMethod, _newmark_mass)


@njit(cache=True)
def _start(meth, ws, ph, t, cur, cnt):
    st = local_solve(meth, ws, meth.model, cur.q, cur.v, cnt)
    if st:
        return st
    ws.fc[:] = ws.fc_next
    ws.lam_model[:] = ws.lam_next
    for i in range(ws.lam_next.shape[0]):
        ws.ep[i, 4] = ws.lam_next[i]
    return methods.start(meth.inner, ws.inner, ph, t, cur, cnt)


@njit(cache=True)
def _step(meth, ws, ph, ctl, t, h, cur, new, cnt):
    st, err = methods.step(meth.inner, ws.inner, ph, ctl, t, h, cur, new, cnt)
    if st:
        return st, err
    st = local_solve(meth, ws, meth.model, new.q, new.v, cnt)
    ws.t_new[0] = t + h
    ws.h_new[0] = h
    return st, err


@njit(cache=True)
def _accept(meth, ws, h, prev, cur):
    methods.accept(meth.inner, ws.inner, h, prev, cur)
    _commit(meth, ws, cur.a, ws.t_new[0], h)


methods.start.register(ImmMethod, _start)
methods.step.register(ImmMethod, _step)
methods.accept.register(ImmMethod, _accept)

