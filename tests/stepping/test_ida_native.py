"""The native IDA backend (SUNDIALS called directly, compiled callbacks and step loop)
against scikit-sundae's interface and against exact solutions.

Both backends make the same SUNDIALS calls with the same residual and Jacobian entries,
so they must agree to the last digit: step by step (the one-step path), and over whole
runs through the driver (the compiled quiet-step loop, :meth:`IDA.advance`). The
pendulum is also scored against its exact solution (elliptic functions).
"""

from __future__ import annotations

import numpy as np
import pytest

from daebench import api
from daebench.core.params import ParamError
from daebench.core.problem import Problem
from daebench.core.system import State
from daebench.integrators.ida import IDA
from daebench.models import build_system
from daebench.models.pendulum import exact_theta


def _steps(scene_name: str, backend: str, n_steps: int, **settings) -> tuple[np.ndarray, dict]:
    system = build_system(api.load_scene(scene_name))
    q, v = system.initial_state()
    integ = IDA(backend=backend, **settings)
    integ.start(Problem(system), State(0.0, np.asarray(q, float), np.asarray(v, float)), 1e-4)
    rows = []
    for _ in range(n_steps):
        s = integ.step(10.0)
        rows.append(np.concatenate([[s.t], s.q, s.v, s.a, s.lam]))
    return np.array(rows), integ.counters_snapshot()


def plant_chain_force(monkeypatch):
    """The chain model's applied force raises beyond 5 ms (a Python model's error inside
    IDA's callback); returns the real one."""
    from daebench.models.chain import Chain

    real = Chain.applied_force

    def planted(self, t, q, v):
        if t > 0.005:
            raise ValueError("planted: the chain's force is undefined beyond 5 ms")
        return real(self, t, q, v)

    monkeypatch.setattr(Chain, "applied_force", planted)
    return real


@pytest.mark.parametrize("jacobian", ["analytic", "fd"])
def test_one_step_path_equals_sksundae_bitwise(jacobian):
    """Cartesian pendulum (index 3, GGL form): 60 single IDA steps, every number equal,
    and the same residual/Jacobian/LU counts."""
    nat, c_nat = _steps("pendulum", "native", 60, jacobian=jacobian)
    ref, c_ref = _steps("pendulum", "sksundae", 60, jacobian=jacobian)
    assert np.array_equal(nat, ref)
    assert c_nat == c_ref
    assert c_nat["residual_evals"] > 60 and c_nat["lu_factorizations"] > 0


def test_driver_runs_equal_and_match_exact_pendulum():
    """Whole runs through the driver (compiled quiet-step loop for native): identical
    histories and counters; θ within 1e-6 rad of the exact solution at rtol 1e-10."""
    kw = dict(overrides={"t_end": 0.3}, rtol=1e-10, atol=1e-12)
    nat = api.run("pendulum", "ida", backend="native", **kw)
    ref = api.run("pendulum", "ida", backend="sksundae", **kw)
    assert nat.status == ref.status == "completed"
    assert nat.settings["backend"] == "native" and ref.settings["backend"] == "sksundae"
    assert np.array_equal(nat.t, ref.t)
    assert np.array_equal(nat.q, ref.q) and np.array_equal(nat.v, ref.v)
    assert np.array_equal(nat.lam, ref.lam)
    assert {k: nat.counters[k] for k in ("steps", "residual_evals", "lu_factorizations")} == \
        {k: ref.counters[k] for k in ("steps", "residual_evals", "lu_factorizations")}
    x, y = nat.q[:, 0], nat.q[:, 1]
    theta = np.arctan2(x, -y)
    exact = exact_theta(nat.t, np.radians(30.0), 0.0, 9.81, 1.0)
    assert np.max(np.abs(theta - exact)) < 1e-6


def test_backend_choice_is_checked():
    with pytest.raises(ParamError):
        IDA(backend="cvode")


@pytest.mark.slow
def test_beam_impact_native_equals_sksundae():
    """Beam impact (flexible beam, contact events, phase changes through IDAReInit):
    identical histories, impacts and counters over the first impact."""
    kw = dict(overrides={"t_end": 0.45})
    nat = api.run("beam-impact", "ida", backend="native", **kw)
    ref = api.run("beam-impact", "ida", backend="sksundae", **kw)
    assert nat.status == ref.status == "completed"
    assert np.array_equal(nat.t, ref.t)
    assert np.array_equal(nat.q, ref.q) and np.array_equal(nat.v, ref.v) and np.array_equal(nat.lam, ref.lam)
    assert len(nat.impacts) == len(ref.impacts)
    assert nat.counters["residual_evals"] == ref.counters["residual_evals"]


def test_a_python_models_exception_ends_the_run_with_its_message(monkeypatch, capfd):
    """chain-impact's model is written in Python (its kernels call it through numba.objmode):
    an exception it raises inside IDA's residual ends the run 'failed' with the model's own
    message at the time it was raised — not 'Exception ignored' and IDA going on — under
    the default backend (a Python model runs through scikit-sundae's callbacks)."""
    from daebench.harness.running.runner import run_scene
    from daebench.models.chain import Chain

    real = plant_chain_force(monkeypatch)
    scene = api.load_scene("chain-impact", ["t_end=0.01"])
    rec, res = run_scene(scene, "ida", {}, write=False)
    assert res.status == "failed"
    assert "planted: the chain's force is undefined beyond 5 ms" in res.message
    assert 0.004 < res.t_final <= 0.005 + 1e-9
    assert "Exception ignored" not in capfd.readouterr().err
    monkeypatch.setattr(Chain, "applied_force", real)
    _, native = run_scene(scene, "ida", {"backend": "native"}, write=False)
    _, sundae = run_scene(scene, "ida", {"backend": "sksundae"}, write=False)
    assert native.status == "completed" and native.counters == sundae.counters
    np.testing.assert_array_equal(native.history.to_numpy(), sundae.history.to_numpy())


def test_a_python_models_exception_inside_idas_callback_is_the_sweep_rows_error(monkeypatch):
    """The same planted exception through a sweep row (what compare and the survey store):
    the row is 'failed' with the model's own message — not an 'error' row carrying a
    'SystemError: <weakref …> returned a result with an exception set' or any other
    exception of the bridge — and its errors are NaN."""
    from daebench.harness.sweeps.options import Timing
    from daebench.harness.sweeps.plan import plan_sweep
    from daebench.harness.sweeps.row import execute

    plant_chain_force(monkeypatch)
    scene = api.load_scene("chain-impact", ["t_end=0.01"])
    (spec,) = plan_sweep(scene, ["ida"], tols=[1e-6])
    row = execute(spec, scene, "none", Timing(repeats=1, warmup=False))
    assert row["status"] == "failed", row["message"]
    assert "planted: the chain's force is undefined beyond 5 ms" in row["message"]
    assert "SystemError" not in row["message"] and "weakref" not in row["message"]
    assert 0.004 < row["t_final"] <= 0.005 + 1e-9
