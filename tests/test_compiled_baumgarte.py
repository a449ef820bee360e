"""The compiled (numba) path of `baumgarte` gives the same answers as its pure-Python path.

DAEBENCH_COMPILED=0 forces the Python path (BaumgarteABM4._rhs / _step_impl and one driver
step per accepted step); the default runs daebench.integrators._compiled_abm: the same
right-hand side, ABM4-PECE/RK4 step and a fixed-step phase runner. Same algorithm, same
order of the element-wise operations: the paths differ only by the round-off of the LU
(summation order) and of C_q v, so trajectories, event times and counters must agree.
"""

import re

import numpy as np
import pytest

from daebench.integrators import _compiled_abm as ca
from daebench.integrators import baumgarte as bg
from daebench.integrators.base import BatchWatch
from daebench.integrators.baumgarte import BaumgarteABM4
from daebench.models import build_system
from daebench.scene import load_scene
from daebench.system import Problem, State
from _paths import assert_same_history, both  # tests/_paths.py


def test_constants_match_the_python_path():
    assert ca.SNAP == bg.SNAP and ca.N_START == bg.N_START
    assert (ca.AB0, ca.AB1, ca.AB2, ca.AB3) == tuple(bg.AB4)
    assert (ca.AM0, ca.AM1, ca.AM2, ca.AM3) == tuple(bg.AM4)


# the paper's protocol at N = 3: free flight, the first impact at t ≈ 0.370 s, closed
# phases at h_contact = 1e-6, releases and re-impacts at 0.376 and 0.3796 s
def test_beam_impact_baumgarte_compiled_equals_python(monkeypatch):
    sc = load_scene("beam-impact", ["discretization.n=3", "t_end=0.45"])
    opts = {"h": 1e-4, "h_contact": 1e-6, "delta": 10.0, "epsilon": 50.0}
    (r0, s0), (r1, s1) = both(monkeypatch, sc, "baumgarte", opts)
    assert r0.status == r1.status == "completed"
    assert r0.counters == r1.counters
    assert r0.counters["lu_factorizations"] == r0.counters["residual_evals"] > 2 * r0.counters["steps"]
    assert len(s0.impacts) == len(s1.impacts) >= 3
    for i0, i1 in zip(s0.impacts, s1.impacts):
        assert abs(i0.t - i1.t) < 1e-10 and i0.closed == i1.closed
    # the paths differ by ~1e-16 per right-hand side; after an impact the beam's
    # accelerations (~1e5) amplify that, as for HHT (tests/test_compiled.py)
    assert_same_history(s0.history, s1.history, 1e-8)
    assert np.allclose(s0.final.q, s1.final.q, rtol=0, atol=1e-9)
    for k in ("C", "Cdot"):
        assert abs(s0.constraint_max[k] - s1.constraint_max[k]) <= 1e-10
    assert abs(s1.constraint_max["Cddot"] - s0.constraint_max["Cddot"]) <= 1e-10 * 1e5


@pytest.mark.parametrize("delta,epsilon", [(0.0, 0.0), (10.0, 50.0)])
def test_pendulum_baumgarte_compiled_equals_python(monkeypatch, delta, epsilon):
    sc = load_scene("pendulum", ["t_end=2.0"])
    opts = {"h": 1e-3, "delta": delta, "epsilon": epsilon}
    (r0, s0), (r1, s1) = both(monkeypatch, sc, "baumgarte", opts)
    assert r0.status == r1.status == "completed"
    assert r0.counters == r1.counters
    assert_same_history(s0.history, s1.history, 1e-12)
    for a, b in ((s0.final.q, s1.final.q), (s0.final.v, s1.final.v)):
        assert np.allclose(a, b, rtol=0, atol=1e-12)


def test_short_final_step_and_restart_compiled_equals_python(monkeypatch):
    # t_end off the step grid: the last step is a short RK4 step (the SNAP rule); the output
    # times force a stop of the phase runner at every output
    sc = load_scene("pendulum", ["t_end=0.10037", "output.dt=0.10037"])
    (r0, s0), (r1, s1) = both(monkeypatch, sc, "baumgarte", {"h": 1e-3, "delta": 5.0, "epsilon": 5.0})
    assert r0.status == r1.status == "completed"
    assert r0.counters == r1.counters
    assert s0.final.t == s1.final.t == pytest.approx(0.10037, abs=1e-15)
    assert np.allclose(s0.final.q, s1.final.q, rtol=0, atol=1e-14)
    assert np.allclose(s0.final.a, s1.final.a, rtol=0, atol=1e-12)


def _interleaved(monkeypatch, flag):
    """Single steps, a phase-runner batch, a restart and a short final step, on one integrator."""
    monkeypatch.setenv("DAEBENCH_COMPILED", flag)
    system = build_system(load_scene("pendulum"))
    problem = Problem(system)
    q, v = system.initial_state()
    a, lam = problem.acceleration(0.0, q, v)
    integ = BaumgarteABM4(h=1e-3, delta=5.0, epsilon=5.0)
    integ.start(problem, State(0.0, q, v, a, lam), 1e-3)
    assert (integ._md is not None) == (flag == "1") and integ.can_advance(problem) == (flag == "1")
    states = []
    for _ in range(2):
        states.append(integ.step(1.0))
    watch = BatchWatch(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(1, bool), False, True,
                       np.zeros(3), 1.0, 1.0, max_steps=7)
    while integ.state.t < 0.009 - 1e-12:  # Python: one step per call; compiled: one batch of 7
        integ.advance(1.0, watch)
    states += [integ.prev, integ.state]
    for _ in range(3):
        states.append(integ.step(1.0))
    integ.start(problem, integ.state, 5e-4)  # a restart mid-run: RK4 start again
    for _ in range(6):
        states.append(integ.step(0.01537))
    while integ.state.t < 0.01537:
        states.append(integ.step(0.01537))  # ends with a short RK4 step onto t_stop
    return states, integ.counters_snapshot()


def test_single_steps_batches_and_restarts_interleave(monkeypatch):
    s0, c0 = _interleaved(monkeypatch, "0")
    s1, c1 = _interleaved(monkeypatch, "1")
    assert c0 == c1
    assert len(s0) == len(s1) and s0[-1].t == s1[-1].t == 0.01537
    for a, b in zip(s0, s1):
        assert a.t == b.t
        for x, y in ((a.q, b.q), (a.v, b.v), (a.a, b.a), (a.lam, b.lam)):
            assert np.allclose(x, y, rtol=0, atol=1e-13)


# N = 5 at h = 1e-4 s: h·ω_max ≈ 1.1 > 0.93 (tests/test_beam_impact.py). With the case's output
# step the driver's energy check at an output time catches the blow-up first; with sparse
# output it is the integrator's own check ("diverged: state exploded"), raised inside the
# phase runner on the compiled path
@pytest.mark.parametrize("sets,verdict", [([], "energy residual"), (["output.dt=0.05"], "diverged: state")])
def test_n5_beam_impact_diverges_on_both_paths(monkeypatch, sets, verdict):
    sc = load_scene("beam-impact", ["t_end=0.1", *sets])
    (r0, _), (r1, _) = both(monkeypatch, sc, "baumgarte", {"h": 1e-4, "delta": 10.0, "epsilon": 50.0})
    assert r0.status == r1.status == "diverged"
    assert verdict in r0.message and verdict in r1.message
    number = re.compile(r"\d[\d.e+-]*")
    assert number.sub("#", r0.message) == number.sub("#", r1.message)
    assert r0.t_final == r1.t_final < 0.1
    assert r0.counters == r1.counters
