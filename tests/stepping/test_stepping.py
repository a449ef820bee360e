"""The one compiled stepping loop (daebench.stepping): batches of steps equal single steps,
step control lands on t_stop, failures end with their reason, and the interpreted path
(DAEBENCH_COMPILED=0: numba's DISABLE_JIT, the same source) equals the compiled one.

Truth here is the loop's own contract checked two ways (many steps per call against one
step per call through the driver, where the driver sees and books every step itself),
numpy's LU, and exact step arithmetic.
"""

import os
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from daebench.integrators.base import StepFailure
from daebench.integrators.baumgarte import BaumgarteABM4
from daebench.integrators.hht import HHT
from daebench.core.linalg import lu_factor, lu_solve
from daebench.models import build_system
from daebench.core.problem import Problem
from daebench.harness.running.runner import run_scene
from daebench.models.scenes import load_scene
from daebench.driver.simulate import Driver
from daebench.stepping import watch as W
from daebench.core.system import State


def test_lu_matches_numpy():
    rng = np.random.default_rng(1)
    for n in (1, 3, 8, 17):
        A = rng.standard_normal((n, n))
        b = rng.standard_normal(n)
        LU, piv, x = A.copy(), np.zeros(n, dtype=np.int64), b.copy()
        assert lu_factor(LU, piv) == 0
        lu_solve(LU, piv, x)
        assert np.allclose(x, np.linalg.solve(A, b), rtol=1e-12, atol=1e-12)
    assert lu_factor(np.zeros((2, 2)), np.zeros(2, dtype=np.int64)) == 1


def _both_ways(monkeypatch, scene, integrator, opts):
    """(record, result) with many steps per driver call, then with one step per call."""
    fast = run_scene(scene, integrator, opts, write=False)
    monkeypatch.setattr(Driver, "_batch_ok", lambda self, problem: False)
    slow = run_scene(scene, integrator, opts, write=False)
    monkeypatch.undo()
    return fast, slow


@pytest.mark.parametrize("integrator, opts", [
    ("hht", {"adaptive": True, "rtol": 1e-6, "atol": 1e-8, "alpha": -0.15}),
    ("hht", {"h": 1e-4, "h_contact": 1e-5, "alpha": -0.3}),
    ("baumgarte", {"h": 1e-4, "delta": 10.0, "epsilon": 50.0}),
])
def test_batches_take_exactly_the_single_steps(monkeypatch, integrator, opts):
    """Beam-impact (N = 3) through its first impact into the closed phase: the runner's
    quiet-step bookkeeping and stops reproduce the driver's step-by-step handling — same
    steps, rejections, impacts, constraint maxima and history, to the bit."""
    sc = load_scene("beam-impact", ["discretization.n=3", "t_end=0.3712", "output.dt=1e-3"])
    (r1, s1), (r2, s2) = _both_ways(monkeypatch, sc, integrator, opts)
    assert r1.status == r2.status == "completed", (r1.message, r2.message)
    assert len(s1.impacts) == len(s2.impacts) >= 1
    if opts.get("adaptive"):
        assert r1.counters["rejected"] > 0  # the controller did reject steps
    assert r1.counters == r2.counters
    assert [i.t for i in s1.impacts] == [i.t for i in s2.impacts]
    assert s1.constraint_max == s2.constraint_max
    np.testing.assert_array_equal(s1.history.to_numpy(float), s2.history.to_numpy(float))


def test_adaptive_step_underflow_ends_with_its_reason():
    """A state that makes every Newton attempt fail: the step is cut ×0.25 until it falls
    below H_MIN_REL, then the run stops saying why."""
    system = build_system(load_scene("pendulum"))
    problem = Problem(system)
    q0, v0 = system.initial_state()
    a0, lam0 = problem.acceleration(0.0, q0, v0)
    v0 = v0.copy()
    v0[0] = np.nan
    integ = HHT(adaptive=True)
    integ.start(problem, State(0.0, q0, v0, a0, lam0), 1e-3)
    watch = W.make(problem.n, problem.m, np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(1, bool), True,
                   np.zeros(3), 1.0, 1.0)
    with pytest.raises(StepFailure, match=r"^step size underflow after a failed step: non-finite .* \(t = 0\)$"):
        integ.advance(1.0, watch)
    assert integ.counters.rejected == 15 and integ.counters.steps == 0  # 1e-3 · 0.25^15 < 1e-12


def _abm_sequence(interleave: bool):
    """Baumgarte on the pendulum: single steps, one batch, a restart with another h and a
    short final RK4 step onto t_stop (``interleave``), or the same times by single steps."""
    system = build_system(load_scene("pendulum"))
    problem = Problem(system)
    q, v = system.initial_state()
    a, lam = problem.acceleration(0.0, q, v)
    integ = BaumgarteABM4(h=1e-3, delta=5.0, epsilon=5.0)
    integ.start(problem, State(0.0, q, v, a, lam), 1e-3)
    states = [integ.step(1.0), integ.step(1.0)]
    out = W.make(problem.n, problem.m, np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(1, bool), False,
                 np.zeros(3), 0.009, 1.0)
    if interleave:
        adv = integ.advance(1.0, out)  # stops at the output time 0.009 (7 steps)
        assert adv.steps == 7
        states.append(adv.new)
    else:
        for _ in range(7):
            states.append(integ.step(1.0))
    integ.start(problem, integ.state, 5e-4)  # a restart mid-run: RK4 start again
    while integ.state.t < 0.01537:
        states.append(integ.step(0.01537))  # ends with a short RK4 step onto t_stop
    return states, integ.counters_snapshot()


def test_single_steps_batches_and_restarts_interleave():
    s0, c0 = _abm_sequence(False)
    s1, c1 = _abm_sequence(True)
    assert c0 == c1
    assert s0[-1].t == s1[-1].t == 0.01537  # landed exactly (control.land)
    for a, b in zip(s0[:2] + s0[-9:], s1[:2] + s1[-9:]):
        assert a.t == b.t
        for x, y in ((a.q, b.q), (a.v, b.v), (a.a, b.a), (a.lam, b.lam)):
            np.testing.assert_array_equal(x, y)


# N = 5 at h = 1e-4 s: h·ω_max ≈ 1.1 > 0.93 (tests/models/test_beam_impact.py). With the case's output
# step the driver's energy check at an output time catches the blow-up first; with sparse
# output it is the integrator's own check ("diverged: state exploded"), raised inside a batch
@pytest.mark.parametrize("sets,verdict", [([], "energy residual"), (["output.dt=0.05"], "diverged: state")])
def test_n5_beam_impact_diverges_with_its_reason(sets, verdict):
    sc = load_scene("beam-impact", ["t_end=0.1", *sets])
    rec, res = run_scene(sc, "baumgarte", {"h": 1e-4, "delta": 10.0, "epsilon": 50.0}, write=False)
    assert rec.status == "diverged" and verdict in rec.message
    assert rec.t_final < 0.1 and re.search(r"t = [\d.e-]+", rec.message)


def test_interpreted_path_equals_compiled():
    """DAEBENCH_COMPILED=0 runs the same source without numba: HHT (adaptive) and IDA on
    the pendulum give the compiled answers to round-off (a fresh process: the switch is
    read at import)."""
    code = textwrap.dedent("""
        import json, numba
        from daebench.harness.running.runner import run_scene
        from daebench.models.scenes import load_scene
        sc = load_scene("pendulum", ["t_end=0.2", "output.dt=0.05"])
        out = {}
        for name, opts in (("hht", {"adaptive": True, "rtol": 1e-6}), ("baumgarte", {"h": 2e-3})):
            rec, res = run_scene(sc, name, opts, write=False)
            out[name] = [res.status, res.counters["steps"], list(res.final.q)]
        out["jit"] = not numba.config.DISABLE_JIT
        print(json.dumps(out))
    """)
    runs = {}
    for flag in ("0", "1"):
        env = {**os.environ, "DAEBENCH_COMPILED": flag}
        p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
        assert p.returncode == 0, p.stderr[-2000:]
        runs[flag] = __import__("json").loads(p.stdout.strip().splitlines()[-1])
    assert runs["0"]["jit"] is False and runs["1"]["jit"] is True
    for name in ("hht", "baumgarte"):
        a, b = runs["0"][name], runs["1"][name]
        assert a[0] == b[0] == "completed" and a[1] == b[1]
        np.testing.assert_allclose(a[2], b[2], rtol=0, atol=1e-13)
