"""The compiled model interface: what a model provides so that every integrator runs on it
in numba, written once.

A model provides its physics as a handful of **kernels** — numba functions on plain
arrays — and a **data** object: an instance of a ``typing.NamedTuple`` class of its own
(tables, parameters, scratch arrays). Integrators call the five generic functions
below; numba selects the model's kernel at compile time from the type of the data
(static dispatch through :func:`numba.extending.overload`), so integrator code imports
no model and a new model needs no branch anywhere. A phase does not hand the model's own
data to the integrator loops but its :class:`~daebench.core.handles.ModelHandle`: the
kernels as compiled function values over one data layout, so each integrator loop is
compiled once for every model and each model once for every integrator
(:mod:`daebench.core.handles`).

The interface (all arrays float64; outputs are overwritten, never allocated):

``mass_force(md, t, q, v, M, Q)``               required
    The mass matrix M(q) (n × n) and the applied force Q(t, q, v) (n): inertia
    (quadratic velocity) terms, elastic, gravity, drive, damping — no contact-law
    force (the phase adds it, :mod:`daebench.core.phase`).
``force_jacobian(md, t, q, v, Kq, Kv)``         optional
    ∂Q/∂q and ∂Q/∂v. Default: central differences of ``mass_force``'s Q.
``mass_jacobian_product(md, q, a, K)``          optional
    ∂(M(q) a)/∂q at fixed a. Default: central differences; :func:`constant_mass` for a
    mass matrix that does not depend on q.
``constraints(md, t, q, v, C, Cq, Ct, gam)``    required when the model has bilateral constraints
    Rows 0 … n_bilateral − 1: C(t, q), C_q, C_t = ∂C/∂t and γ with C_q q̈ = γ (i.e.
    γ = −(C_q q̇)_q q̇ − 2 C_qt q̇ − C_tt). Default: no rows.
``gap(md, i, q, v, gq) -> (g, gamma)``          required when the model has contact points
    Normal gap g_i(q) of contact point i (≥ 0 open), its Jacobian into ``gq`` (n) and
    γ_g with g̈ = g_q q̈ − γ_g.
``tangent(md, i, q, v, tq) -> mu``              optional (planar Coulomb friction)
    The tangent Jacobian row of contact point i into ``tq`` (its slip velocity is
    tq · v) and its Coulomb friction coefficient μ_i ≥ 0. Default: μ = 0, no friction.

Register them once, at import of the model module::

    class PendulumData(NamedTuple):
        m: float
        l: float
        g: float

    @njit(cache=True)
    def _mass_force(md, t, q, v, M, Q): ...

    kernels.register(PendulumData, mass_force=_mass_force, constraints=_constraints)

The model's :class:`~daebench.core.system.MechanicalSystem` then returns its data from
``kernel_data()`` and derives its Python protocol from the kernels
(:class:`KernelSystem`), so its physics exists once.

A model written in plain Python (the protocol methods of MechanicalSystem, no kernels)
still runs under every compiled integrator: its ``kernel_data()`` is a :class:`PyModel`
handle whose kernels call the Python methods back through ``numba.objmode`` (~10 µs a
call). Same integrator code, no second path.

Setting ``DAEBENCH_COMPILED=0`` before daebench is imported runs everything — kernels,
integrator loops — as plain Python (numba's ``DISABLE_JIT``): the same source,
interpreted, for debugging.

A caveat of numba's on-disk cache: a cached function contains the functions it calls,
and numba invalidates it only when its own file changes. daebench keys its cache on its
own sources (:mod:`daebench.core.numba_cache`); a plugin model's compiled handle is keyed
on its package version too, so a plugin that changes its kernels should bump that
version or clear the cache.
"""

from __future__ import annotations

import itertools
import weakref
from typing import Any, Callable, NamedTuple

import numba
import numpy as np
from numba import njit

from daebench.core.dispatch import generic

FD_REL_STEP = 1e-7  # relative step of every central difference (Python and compiled)

KERNELS = ("mass_force", "force_jacobian", "mass_jacobian_product", "constraints", "gap", "tangent")


class KernelError(TypeError):
    """A model registered an incomplete or malformed kernel set."""


@njit(cache=True)
def fd_step(x: float) -> float:
    """The difference step for a coordinate of value x: FD_REL_STEP · max(1, |x|)."""
    return FD_REL_STEP * max(1.0, abs(x))


# -- the generic functions integrators call ------------------------------------------
@generic
def mass_force(md, t, q, v, M, Q):
    """M(q) and the applied force Q(t, q, v) of the model whose data is ``md``."""


@generic
def force_jacobian(md, t, q, v, Kq, Kv):
    """∂Q/∂q into Kq and ∂Q/∂v into Kv."""


@generic
def mass_jacobian_product(md, q, a, K):
    """∂(M(q) a)/∂q at fixed a into K."""


@generic
def constraints(md, t, q, v, C, Cq, Ct, gam):
    """The bilateral constraint rows C, C_q, C_t, γ (rows 0 … n_bilateral − 1)."""


@generic
def gap(md, i, q, v, gq):
    """(g_i, γ_g,i) of contact point i; its Jacobian row into gq."""


@generic
def tangent(md, i, q, v, tq):
    """μ_i of contact point i; its tangent Jacobian row into tq."""


_GENERICS = {"mass_force": mass_force, "force_jacobian": force_jacobian,
             "mass_jacobian_product": mass_jacobian_product, "constraints": constraints, "gap": gap,
             "tangent": tangent}


# -- defaults ---------------------------------------------------------------------------
@njit(cache=True)
def _fd_force_jacobian(md, t, q, v, Kq, Kv):
    n = q.shape[0]
    M = np.empty((n, n))
    Qp = np.empty(n)
    Qm = np.empty(n)
    x = np.empty(n)
    for wrt_v in (False, True):
        base = v if wrt_v else q
        K = Kv if wrt_v else Kq
        for j in range(n):
            dx = fd_step(base[j])
            for i in range(n):  # not x[:] = base: its shape check compiles an error message (3 s)
                x[i] = base[i]
            x[j] = base[j] + dx
            if wrt_v:
                mass_force(md, t, q, x, M, Qp)
            else:
                mass_force(md, t, x, v, M, Qp)
            x[j] = base[j] - dx
            if wrt_v:
                mass_force(md, t, q, x, M, Qm)
            else:
                mass_force(md, t, x, v, M, Qm)
            for i in range(n):
                K[i, j] = (Qp[i] - Qm[i]) / (2.0 * dx)


@njit(cache=True)
def _fd_mass_jacobian_product(md, q, a, K):
    n = q.shape[0]
    Mp = np.empty((n, n))
    Mm = np.empty((n, n))
    Q = np.empty(n)
    zeros = np.zeros(n)
    x = q.copy()
    for j in range(n):
        dx = fd_step(q[j])
        x[j] = q[j] + dx
        mass_force(md, 0.0, x, zeros, Mp, Q)
        x[j] = q[j] - dx
        mass_force(md, 0.0, x, zeros, Mm, Q)
        x[j] = q[j]
        for i in range(n):
            s = 0.0
            for k in range(n):
                s += (Mp[i, k] - Mm[i, k]) * a[k]
            K[i, j] = s / (2.0 * dx)


@njit(cache=True)
def constant_mass(md, q, a, K):
    """``mass_jacobian_product`` of a model whose mass matrix does not depend on q
    (lumped or Cartesian masses): ∂(M a)/∂q = 0. Register it instead of writing a zero
    kernel: ``kernels.register(Data, ..., mass_jacobian_product=kernels.constant_mass)``."""
    for i in range(K.shape[0]):
        for j in range(K.shape[1]):
            K[i, j] = 0.0


@njit(cache=True)
def _no_constraints(md, t, q, v, C, Cq, Ct, gam):
    pass


@njit(cache=True)
def _no_gap(md, i, q, v, gq):
    if i >= 0:
        raise IndexError("this model has no contact points")
    return 0.0, 0.0


@njit(cache=True)
def _no_friction(md, i, q, v, tq):
    for j in range(tq.shape[0]):
        tq[j] = 0.0
    return 0.0


_DEFAULTS = {"force_jacobian": _fd_force_jacobian, "mass_jacobian_product": _fd_mass_jacobian_product,
             "constraints": _no_constraints, "gap": _no_gap, "tangent": _no_friction}


# -- registration -------------------------------------------------------------------------
def register(data_class: type, **kernels: Callable) -> None:
    """Declare the kernels of the model whose data is an instance of ``data_class``
    (a ``typing.NamedTuple`` class defined at module level, so the on-disk cache can
    name it). ``mass_force`` is required; omitted optional kernels get the defaults of
    the module docstring. Plain Python functions are compiled with ``njit(cache=True)``.
    """
    unknown = sorted(set(kernels) - set(KERNELS))
    if unknown:
        raise KernelError(f"unknown kernel(s) {', '.join(unknown)} for {getattr(data_class, '__name__', data_class)}; "
                          f"the interface is {', '.join(KERNELS)}")
    if "mass_force" not in kernels:
        raise KernelError(f"{getattr(data_class, '__name__', data_class)}: the 'mass_force' kernel is required")
    for name in KERNELS:
        _GENERICS[name].register(data_class, kernels.get(name) or _DEFAULTS[name])


def registered(data_class: type) -> bool:
    return mass_force.registered(data_class)


def friction_coefficients(md: Any, n_contacts: int, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """μ_i of each contact point of the model whose data is ``md`` (the ``tangent``
    kernel at (q, v)); all zero for a model without friction."""
    tq = np.zeros(q.shape[0])
    return np.array([float(tangent(md, i, q, v, tq)) for i in range(int(n_contacts))])


# -- Python models behind the same interface ------------------------------------------------
class PyModel(NamedTuple):
    """Handle of a model written in plain Python (see the module docstring)."""

    key: int


_PY_SYSTEMS: "weakref.WeakValueDictionary[int, Any]" = weakref.WeakValueDictionary()
_PY_KEYS = itertools.count(1)


def python_handle(system: Any) -> PyModel:
    """The :class:`PyModel` handle of a Python model (kept while the system lives)."""
    key = getattr(system, "_py_kernel_key", None)
    if key is None or _PY_SYSTEMS.get(key) is not system:
        key = next(_PY_KEYS)
        _PY_SYSTEMS[key] = system
        system._py_kernel_key = key
    return PyModel(key)


def _py_mass_force(key, t, q, v, M, Q):
    s = _PY_SYSTEMS[key]
    M[:, :] = s.mass(q)
    Q[:] = s.applied_force(t, q, v)


def _py_force_jacobian(key, t, q, v, Kq, Kv):
    a, b = _PY_SYSTEMS[key].force_jacobian(t, q, v)
    Kq[:, :] = a
    Kv[:, :] = b


def _py_mass_jacobian_product(key, q, a, K):
    K[:, :] = _PY_SYSTEMS[key].mass_jacobian_product(q, a)


def _py_constraints(key, t, q, v, C, Cq, Ct, gam):
    s = _PY_SYSTEMS[key]
    nb = s.n_bilateral
    if nb:
        C[:nb] = s.constraint(t, q)
        Cq[:nb, :] = np.asarray(s.constraint_jacobian(t, q)).reshape(nb, -1)
        Ct[:nb] = s.constraint_t(t, q)
        gam[:nb] = s.constraint_gamma(t, q, v)


def _py_gap(key, i, q, v, gq):
    s = _PY_SYSTEMS[key]
    gq[:] = s.gap_jacobian(q)[i]
    return float(s.gap(q)[i]), float(s.gap_gamma(q, v)[i])


def _pm_mass_force(md, t, q, v, M, Q):
    key = md.key
    with numba.objmode():
        _py_mass_force(key, t, q, v, M, Q)


def _pm_force_jacobian(md, t, q, v, Kq, Kv):
    key = md.key
    with numba.objmode():
        _py_force_jacobian(key, t, q, v, Kq, Kv)


def _pm_mass_jacobian_product(md, q, a, K):
    key = md.key
    with numba.objmode():
        _py_mass_jacobian_product(key, q, a, K)


def _pm_constraints(md, t, q, v, C, Cq, Ct, gam):
    key = md.key
    with numba.objmode():
        _py_constraints(key, t, q, v, C, Cq, Ct, gam)


def _pm_gap(md, i, q, v, gq):
    key = md.key
    with numba.objmode(g="float64", gam="float64"):
        g, gam = _py_gap(key, i, q, v, gq)
    return g, gam


register(PyModel, mass_force=_pm_mass_force, force_jacobian=_pm_force_jacobian,
         mass_jacobian_product=_pm_mass_jacobian_product, constraints=_pm_constraints, gap=_pm_gap)
