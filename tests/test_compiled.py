"""The compiled (numba) paths give the same answers as the pure-Python paths, to round-off.

DAEBENCH_COMPILED=0 forces the Python path (the Newton iteration of
daebench.integrators._newmark_family and a driver step per accepted step); the default
runs the compiled Newton step and the fixed-step phase runner of
daebench.integrators._compiled_newmark. Same model, same algorithm: the trajectories,
event times and work counters must agree except for round-off (LU and dot-product
summation order).
"""

import numpy as np
import pytest

from daebench.integrators import _compiled_newmark as cn
from daebench.integrators import _newmark_family as nf
from daebench.models import build_system
from daebench.scene import load_scene
from daebench.simulate import simulate
from _paths import assert_same_history, both  # tests/_paths.py


def test_constants_match_the_python_path():
    for k in ("NEWTON_RATE_REFRESH", "NEWTON_RATE_DIVERGE", "JAC_H_RATIO", "VEL_TOL_FACTOR", "ROUNDOFF", "SNAP",
              "SAFETY", "FAC_MIN", "FAC_MAX", "FAC_NEWTON_FAIL", "ZX_MIN_COEFF"):
        assert getattr(cn, k) == getattr(nf, k), k
    from daebench import simulate as S
    from daebench import system
    assert cn.GAP_BAND == S.GAP_BAND and cn.FD_REL_STEP == system.FD_REL_STEP


def test_lu_matches_numpy():
    rng = np.random.default_rng(1)
    for n in (1, 3, 8, 17):
        A = rng.standard_normal((n, n))
        b = rng.standard_normal(n)
        LU, piv, x = A.copy(), np.zeros(n, dtype=np.int64), b.copy()
        assert cn.lu_factor(LU, piv) == 0
        cn.lu_solve(LU, piv, x)
        assert np.allclose(x, np.linalg.solve(A, b), rtol=1e-12, atol=1e-12)
    assert cn.lu_factor(np.zeros((2, 2)), np.zeros(2, dtype=np.int64)) == 1


# first impact, closed phases, releases and re-impacts: free and constrained phases, events.
# With α = −0.3 a release near t = 0.3794 s chatters (re-closures at ġ ~ 1e-10 m/s): which
# sub-step re-closure happens first there is decided by round-off, in either path, so that
# run stops before it.
@pytest.mark.parametrize("alpha,t_end", [(0.0, 0.381), (-0.3, 0.3790)])
def test_beam_impact_hht_compiled_equals_python(monkeypatch, alpha, t_end):
    sc = load_scene("beam-impact", ["discretization.n=3", f"t_end={t_end}", "output.dt=2e-4"])
    opts = {"alpha": alpha, "h": 1e-4, "h_contact": 1e-5}
    (r0, s0), (r1, s1) = both(monkeypatch, sc, "hht", opts)
    assert r0.status == r1.status == "completed"
    # the same work; an event time that differs by round-off may move one step boundary
    for k, v in r0.counters.items():
        assert abs(r1.counters[k] - v) <= max(3, 1e-3 * v), (k, v, r1.counters[k])
    assert len(s0.impacts) == len(s1.impacts) >= 2
    for i0, i1 in zip(s0.impacts, s1.impacts):
        # located to EVENT_TOL; a grazing re-closure (ġ ~ 1e-9 m/s) moves by round-off/ġ
        assert abs(i0.t - i1.t) < 1e-12 + 1e-15 / abs(i0.vn_minus) and i0.closed == i1.closed
    # Newton stops at newton_tol = 1e-12, so the paths differ by ~1e-13 per step (free flight:
    # 1.5e-11 in θ̇ at t = 0.12 s); event times then differ by ~1e-12 s, and after an impact
    # the beam's accelerations (~1e5) turn that into ~1e-7 in velocities: round-off, amplified
    assert_same_history(s0.history, s1.history, 1e-8)
    assert np.allclose(s0.final.q, s1.final.q, rtol=0, atol=1e-9)
    for k in ("C", "Cdot"):
        assert abs(s0.constraint_max[k] - s1.constraint_max[k]) <= 1e-10
    assert abs(s1.constraint_max["Cddot"] - s0.constraint_max["Cddot"]) <= 1e-10 * 1e5  # see LOOSE


def test_pendulum_fixed_and_adaptive_compiled_equals_python(monkeypatch):
    sc = load_scene("pendulum", ["t_end=2.0"])
    for integ, opts in (("hht", {"h": 1e-3}), ("newmark", {"h": 1e-3, "gamma": 0.6, "beta": 0.3025}),
                        ("hht", {"adaptive": True, "rtol": 1e-6, "atol": 1e-8}),
                        ("hht", {"h": 1e-3, "ggl": False, "reuse_jacobian": False})):
        (r0, s0), (r1, s1) = both(monkeypatch, sc, integ, opts)
        assert r0.status == r1.status == "completed", (integ, opts)
        assert r0.counters == r1.counters, (integ, opts)
        assert_same_history(s0.history, s1.history, 1e-12)


def test_adaptive_phase_runner_equals_python_and_single_steps(monkeypatch):
    """Adaptive HHT on beam-impact through the first impact: the compiled phase runner
    (step-size control in numba) agrees with the Python path to round-off, and takes
    exactly the steps of compiled single steps through the driver."""
    from daebench.integrators.hht import HHT

    sc = load_scene("beam-impact", ["discretization.n=3", "t_end=0.3705", "output.dt=1e-3"])
    opts = {"adaptive": True, "rtol": 1e-6, "atol": 1e-8, "alpha": -0.15}
    (r0, s0), (r1, s1) = both(monkeypatch, sc, "hht", opts)
    assert r0.status == r1.status == "completed" and len(s0.impacts) == len(s1.impacts) == 1
    assert r1.counters["rejected"] > 0  # the controller did reject steps
    for k, v in r0.counters.items():
        assert abs(r1.counters[k] - v) <= max(3, 1e-3 * v), (k, v, r1.counters[k])
    assert abs(s0.impacts[0].t - s1.impacts[0].t) < 1e-11
    # round-off (5e-11 in θ̇ before the impact) is amplified ~1e4 by the impact (see above)
    before = s0.history["t"] < s0.impacts[0].t
    assert_same_history(s0.history[before], s1.history[before], 1e-9)
    assert_same_history(s0.history, s1.history, 1e-6)
    monkeypatch.setattr(HHT, "can_advance", lambda self, problem: False)
    r2, s2 = both(monkeypatch, sc, "hht", opts)[1]
    assert r2.counters == r1.counters and s2.impacts[0].t == s1.impacts[0].t
    assert_same_history(s1.history, s2.history, 1e-13)


def test_adaptive_newton_failures_take_the_same_path_both_ways(monkeypatch):
    """Thousands of Newton failures, each cutting the step, and error rejections: the
    compiled adaptive runner repeats the Python controller decision for decision."""
    sc = load_scene("pendulum", ["t_end=0.1"])
    (r0, s0), (r1, s1) = both(monkeypatch, sc, "hht", {"adaptive": True, "newton_maxiter": 1, "newton_tol": 1e-14})
    assert r0.status == r1.status == "completed" and r0.counters["rejected"] > 1000
    assert r0.counters == r1.counters
    assert_same_history(s0.history, s1.history, 1e-12)


@pytest.mark.parametrize("compiled", ["0", "1"])
def test_adaptive_step_underflow_message_is_the_same_on_both_paths(monkeypatch, compiled):
    """A state that makes every Newton attempt fail: the step is cut ×0.25 until it falls
    below H_MIN_REL; both paths stop with the same message."""
    from daebench.integrators.base import BatchWatch, StepFailure
    from daebench.integrators.hht import HHT
    from daebench.system import Problem, State

    monkeypatch.setenv("DAEBENCH_COMPILED", compiled)
    system = build_system(load_scene("pendulum"))
    problem = Problem(system)
    q0, v0 = system.initial_state()
    a0, lam0 = problem.acceleration(0.0, q0, v0)
    integ = HHT(adaptive=True)
    integ.start(problem, State(0.0, q0, v0, a0, lam0), 1e-3)
    integ.state.v[0] = np.nan
    watch = BatchWatch(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(1, bool), False, True,
                       np.zeros(3), 1.0, 1.0)
    with pytest.raises(StepFailure, match=r"^step size underflow after Newton failure: non-finite .* \(t = 0\)$"):
        integ.advance(1.0, watch)
    assert integ.counters.rejected == 15 and integ.counters.steps == 0  # 1e-3 · 0.25^15 < 1e-12


def test_python_models_keep_the_python_path(monkeypatch):
    # a model without kernels (Andrews) and a plain-Python plugin never see the compiled path
    from daebench.integrators.hht import HHT
    sc = load_scene("andrews", ["t_end=0.001"])
    system = build_system(sc)
    assert not hasattr(system, "kernels")
    integ = HHT(h=1e-5)
    res = simulate(system, integ, 0.001, 1e-4)
    assert res.status == "completed" and integ._md is None
