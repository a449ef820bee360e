"""The compiled runner writes the rows of the output times its quiet steps pass: the same
history, to the bit, as handing every such step back to the driver (one Hermite rule,
daebench.stepping.dense, on both paths)."""

import numpy as np
import pandas as pd
import pytest

from daebench.harness.running.runner import run_scene
from daebench.integrators.base import State, hermite_state
from daebench.integrators.compiled import CompiledIntegrator
from daebench.models.scenes import load_scene


def _both(case, sets, integrator, options, monkeypatch):
    sc = load_scene(case, sets)
    _, fast = run_scene(sc, integrator, options, write=False)
    with monkeypatch.context() as mp:
        mp.setattr(CompiledIntegrator, "records_outputs", property(lambda self: False))
        _, slow = run_scene(sc, integrator, options, write=False)
    return fast, slow


@pytest.mark.parametrize("case, sets, integrator, options", [
    # output times between steps (h = 7e-4 does not divide 0.01): interpolated rows
    ("pendulum", ["t_end=0.5", "output.dt=0.01"], "hht", {"h": 7e-4}),
    # impacts: phases end and restart between output times
    ("beam-impact", ["discretization.n=3", "t_end=0.12", "output.dt=0.002"], "hht", {"h": 1e-4, "h_contact": 1e-6}),
])
def test_rows_written_in_the_loop_equal_the_driver_path(case, sets, integrator, options, monkeypatch):
    fast, slow = _both(case, sets, integrator, options, monkeypatch)
    assert fast.status == slow.status == "completed"
    assert len(fast.history) == len(slow.history) > 20
    pd.testing.assert_frame_equal(fast.history, slow.history, check_exact=True)
    assert fast.counters["steps"] == slow.counters["steps"]


def test_hermite_rule_reproduces_a_cubic_and_its_derivative():
    """q(t) = t³ − 2t, v = 3t² − 2, a = 6t: the cubic Hermite of q (with v) is exact, that of
    v (with a) is exact for the quadratic v; a and λ are linear."""
    q = lambda t: np.array([t**3 - 2 * t])
    v = lambda t: np.array([3 * t**2 - 2])
    a = lambda t: np.array([6 * t])
    s0 = State(0.3, q(0.3), v(0.3), a(0.3), np.array([1.0]))
    s1 = State(0.8, q(0.8), v(0.8), a(0.8), np.array([3.0]))
    s = hermite_state(s0, s1, 0.55)
    assert s.t == 0.55
    np.testing.assert_allclose(s.q, q(0.55), rtol=1e-14)
    np.testing.assert_allclose(s.v, v(0.55), rtol=1e-14)
    np.testing.assert_allclose(s.a, a(0.55), rtol=1e-14)
    np.testing.assert_allclose(s.lam, [2.0], rtol=1e-14)


def test_a_failing_call_keeps_the_rows_its_quiet_steps_wrote(monkeypatch):
    """A step that fails after quiet steps passed output times: those rows stay in the history
    (the runner's buffer travels with the StepFailure), equal to the completed run's rows."""
    from daebench.stepping import runner

    sc = load_scene("pendulum", ["t_end=3.0", "output.dt=0.01"])  # > 2000 steps: two compiled calls
    _, ok = run_scene(sc, "hht", {"h": 1e-3}, write=False)
    real = runner.run_phase
    calls = []

    def failing_second_call(*args):
        res = real(*args)
        calls.append(res)
        return (3, *res[1:]) if len(calls) == 2 else res  # "Newton did not converge" after its steps

    monkeypatch.setattr(runner, "run_phase", failing_second_call)
    _, bad = run_scene(sc, "hht", {"h": 1e-3}, write=False)
    assert bad.status == "failed" and "did not converge" in bad.message
    written = calls[1][8]
    assert written > 10  # the failing call had written rows before the failure was reported
    n = len(bad.history)
    # the failing call ran from t = 2 s (2 000 steps) to the end and wrote the rows up to 3.0 s;
    # without them the history would stop at 2.0 s
    assert bad.history["t"].iloc[-1] == pytest.approx(3.0, abs=1e-12)
    pd.testing.assert_frame_equal(bad.history, ok.history.iloc[:n], check_exact=True)
