"""Model kernels as compiled values (daebench.core.handles): the handle's kernels give
bit for bit what the model's own kernels give, every integrator loop is compiled once for
all models, a kernel that raises fails the run, and bad data is refused."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pytest

from daebench.api import load_scene
from daebench.core import handles, kernels
from daebench.core.kernels import KernelError, PyModel
from daebench.harness.running.runner import run_scene
from daebench.models import build_system

FAST = ["pendulum", "ball", "block-incline"]
ALL = ["pendulum", "ball", "block-incline", "andrews", "newton-cradle", "rocking-block", "crank", "caraxis",
       "double-pendulum", "beam-impact", "slider-crank-clearance", "rod-wall", "slider-slot", "spring-wall"]


def _evaluate(md, s, q, v):
    """Every kernel of the interface at (t, q, v), as a dict of arrays and numbers."""
    n, rng = s.n, np.random.default_rng(3)
    out = {}
    M, Q, Kq, Kv, K = (np.empty((n, n)), np.empty(n), np.empty((n, n)), np.empty((n, n)), np.empty((n, n)))
    kernels.mass_force(md, 0.123, q, v, M, Q)
    kernels.force_jacobian(md, 0.123, q, v, Kq, Kv)
    kernels.mass_jacobian_product(md, q, rng.standard_normal(n), K)
    out.update(M=M, Q=Q, Kq=Kq, Kv=Kv, K=K)
    m = max(s.n_bilateral, 1)
    C, Cq, Ct, gam = np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m)
    kernels.constraints(md, 0.123, q, v, C, Cq, Ct, gam)
    out.update(C=C, Cq=Cq, Ct=Ct, gam=gam)
    for i in range(s.n_contacts):
        gq, tq = np.empty(n), np.empty(n)
        out[f"gap{i}"] = np.array(kernels.gap(md, i, q, v, gq))
        out[f"mu{i}"] = np.array(kernels.tangent(md, i, q, v, tq))
        out.update({f"gq{i}": gq, f"tq{i}": tq})
    return out


def _same_kernels(case: str) -> None:
    s = build_system(load_scene(case))
    md = s.kernel_data()
    if isinstance(md, PyModel):
        pytest.skip(f"{case} is a Python model: its data is passed as it is")  # not a dependency skip
    q, v = (np.asarray(x, float) for x in s.initial_state()[:2])
    v = v + 0.1 * np.random.default_rng(1).standard_normal(s.n)  # a state where every term acts
    h = handles.handle(md)
    assert isinstance(h, handles.ModelHandle)
    direct, through = _evaluate(md, s, q, v), _evaluate(h, s, q, v)
    for key, val in direct.items():
        np.testing.assert_array_equal(through[key], val, err_msg=f"{case}: {key}")


@pytest.mark.parametrize("case", FAST)
def test_handle_kernels_equal_the_models_own(case):
    _same_kernels(case)


@pytest.mark.slow
@pytest.mark.parametrize("case", [c for c in ALL if c not in FAST])
def test_handle_kernels_equal_the_models_own_everywhere(case):
    _same_kernels(case)


def test_one_compiled_loop_serves_every_model():
    """The integrator loop is typed for the handle and the phase's layout (consistent or
    lumped mass, with or without a continuous law), not for the model: once hht has run one
    consistent-mass model, three other models of that layout add no compiled signature."""
    from daebench.stepping.runner import run_phase

    run_scene(load_scene("pendulum", ["t_end=0.01"]), "hht", {"h": 1e-3}, write=False)
    before = len(run_phase.signatures)
    for case in ("beam-impact", "double-pendulum", "crank"):
        rec, _ = run_scene(load_scene(case, ["t_end=0.01"]), "hht", {"h": 1e-4}, write=False)
        assert rec.status == "completed", (case, rec.message)
    assert len(run_phase.signatures) == before
    assert all("ModelHandle" in str(sig[2]) or "PyModel" in str(sig[2]) for sig in run_phase.signatures)


class Stiff(NamedTuple):
    k: float
    scale: np.ndarray
    stop: float


def _stiff_mass_force(md, t, q, v, M, Q):
    M[0, 0] = md.scale[0]
    Q[0] = -md.k * q[0]
    if q[0] > md.stop:
        Q[0] = Q[0] / (md.stop - md.stop)  # ZeroDivisionError: a kernel that raises


kernels.register(Stiff, mass_force=_stiff_mass_force, mass_jacobian_product=kernels.constant_mass)


def test_a_kernel_that_raises_raises_through_the_handle_and_data_is_read_in_place():
    scale = np.array([2.0])
    h = handles.handle(Stiff(3.0, scale, 1.0))
    M, Q = np.empty((1, 1)), np.empty(1)
    kernels.mass_force(h, 0.0, np.array([0.5]), np.zeros(1), M, Q)
    assert (M[0, 0], Q[0]) == (2.0, -1.5)
    scale[0] = 5.0  # the handle reads the model's arrays, not a copy
    kernels.mass_force(h, 0.0, np.array([0.5]), np.zeros(1), M, Q)
    assert M[0, 0] == 5.0
    with pytest.raises(ZeroDivisionError):  # the model's own exception, through the compiled call
        kernels.mass_force(h, 0.0, np.array([2.0]), np.zeros(1), M, Q)


class Soft(NamedTuple):
    k: float


def _soft_mass_force(md, t, q, v, M, Q):
    M[:, :] = 0.0
    for i in range(q.shape[0]):
        M[i, i] = 1.0 + q[i] * q[i]
        Q[i] = -md.k * q[i] ** 3 - 0.3 * v[i] * abs(v[i])


kernels.register(Soft, mass_force=_soft_mass_force)


def test_default_kernels_are_compiled_once_for_every_model_and_give_the_models_own():
    """A kernel a model leaves to the defaults is one shared compiled entry (a new model
    compiles only its own kernels), and it gives bit for bit what the default of
    core.kernels gives on the model's own data (the same differences of the same function)."""
    soft, stiff = handles.handle(Soft(2.0)), handles.handle(Stiff(3.0, np.array([2.0]), 1.0))
    assert soft.fns[1] == stiff.fns[1] and soft.fns[3:].tolist() == stiff.fns[3:].tolist()
    assert soft.fns[0] != stiff.fns[0] and soft.fns[2] != stiff.fns[2]  # constant_mass vs differences
    module = handles._MODULES[next(k for k in handles._MODULES if k[0] is Soft)]
    assert hasattr(module, "mass_force") and not hasattr(module, "force_jacobian")
    q, v, a = np.array([0.3, -1.2, 2.5]), np.array([1.5, -0.2, 0.0]), np.array([0.7, 0.1, -2.0])
    md, n = Soft(2.0), q.shape[0]
    direct = [np.empty((n, n)) for _ in range(3)]
    through = [np.empty((n, n)) for _ in range(3)]
    # the defaults run as Python on the model's own data (a compiled default specialised
    # on a class of this test file would be cached with an older copy of its kernel)
    kernels._fd_force_jacobian.py_func(md, 0.5, q, v, direct[0], direct[1])
    kernels.force_jacobian(soft, 0.5, q, v, through[0], through[1])
    kernels._fd_mass_jacobian_product.py_func(md, q, a, direct[2])
    kernels.mass_jacobian_product(soft, q, a, through[2])
    for d, t in zip(direct, through):
        np.testing.assert_array_equal(t, d)
    assert through[0][0, 0] == pytest.approx(-3.0 * 2.0 * q[0] ** 2, rel=1e-7)  # ∂Q/∂q, closed form
    assert through[1][1, 1] == pytest.approx(-0.6 * abs(v[1]), rel=1e-7)
    assert through[2][2, 2] == pytest.approx(2.0 * q[2] * a[2], rel=1e-7)  # ∂(M a)/∂q


def test_a_handle_is_not_pickled():
    import pickle

    with pytest.raises(TypeError, match="memory addresses"):
        pickle.dumps(handles.handle(Stiff(1.0, np.ones(1), 1.0)))


@pytest.mark.parametrize("bad, what", [(np.ones((4, 4))[:, 1], "C-contiguous"),
                                       (np.array(["a"]), "float64, int64 or bool"),
                                       ("text", "not a kernel value")])
def test_data_a_handle_cannot_carry_is_refused(bad, what):
    with pytest.raises(KernelError, match=what):
        handles.handle(Stiff(1.0, bad, 1.0))
