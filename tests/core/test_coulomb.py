"""The compiled stick/slip phase (daebench.core.coulomb, daebench.core.phase.slip): its rows and
force against the planar rigid body's exact kinematics and the block on an incline's closed
forms, and the compiled loop's booking of the slip friction's work against the driver's own
(the same run with one step per call).

Cold-cache cost: hht's compiled loop on the rigid body with friction data (shared with
tests/driver/test_friction_driven.py), then well under a second per test.
"""

from __future__ import annotations

import math

import numpy as np

from daebench.core.problem import Problem
from daebench.driver import simulate as driver
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.rigid2d_exact import incline_stop
from daebench.models.scenes import load_scene
from daebench.stepping import runner

G = 9.81


def corner_x(points: np.ndarray, i: int, q: np.ndarray) -> float:
    """The tangential (along-ground) coordinate of corner i of the rigid body at q."""
    p, r = points[i]
    return q[0] + p * math.cos(q[2]) - r * math.sin(q[2])


def test_stick_row_is_the_corner_displacement_exactly():
    """C_T = X(q) − X(q*) (the corner's tangential coordinate), C_q = ∂X/∂q and
    γ_T = (p cos θ − r sin θ) θ̇² (so that C̈_T = C_q q̈ − γ_T): the line integral and the
    4-point difference of the compiled stick row against the exact kinematics."""
    system = build_system(load_scene("rocking-block"))
    pts = system.points
    q = np.array([0.013, 0.52, 0.21])
    v = np.array([0.3, -0.1, 1.7])
    anchor = np.array([-0.02, 0.5, 0.05])
    for c in (0, 1):
        prob = Problem(system, (c,), friction={"groups": {c: [c]}, "anchors": {c: anchor}, "slip": {},
                                               "mu": np.ones(system.n_contacts)})
        assert prob.n_bilateral == 1 and prob.m == 2
        C, Cq, Ct, gam = prob.constraint_rows(0.0, q, v)
        p, r = pts[c]
        assert abs(C[0] - (corner_x(pts, c, q) - corner_x(pts, c, anchor))) < 1e-15
        assert np.abs(Cq[0] - [1.0, 0.0, -(p * math.sin(q[2]) + r * math.cos(q[2]))]).max() < 1e-15
        assert Ct[0] == 0.0
        assert abs(gam[0] - (p * math.cos(q[2]) - r * math.sin(q[2])) * v[2] ** 2) < 1e-9
        assert abs(C[1] + system.gap(q)[c]) < 1e-15   # the normal row follows the stick row


def test_slip_phase_decelerates_by_the_closed_form():
    """The block sliding up the incline on both bottom corners (μ = 0.3): acceleration
    −g (sin φ + μ cos φ) along the slope, normal forces summing to m g cos φ, slip power
    −μ m g cos φ |ẋ| — the compiled slip force through its augmented solve."""
    sc = load_scene("block-incline")
    system = build_system(sc)
    q, v = (np.asarray(x, float) for x in system.initial_state())
    mu, phi, m = float(sc["contact.friction"]), math.radians(sc["ground.incline"]), float(sc["body.mass"])
    prob = Problem(system, (0, 1), friction={"groups": {}, "anchors": {}, "slip": {0: 1.0, 1: 1.0},
                                             "mu": np.full(system.n_contacts, mu)})
    assert prob.slips and prob.n_bilateral == 0
    a, lam = prob.acceleration(0.0, q, v)
    assert abs(a[0] + G * (math.sin(phi) + mu * math.cos(phi))) < 1e-12
    assert abs(a[1]) < 1e-12 and abs(a[2]) < 1e-12
    assert abs(lam.sum() - m * G * math.cos(phi)) < 1e-12
    assert abs(prob.slip_power(0.0, q, v) + mu * m * G * math.cos(phi) * abs(v[0])) < 1e-12


def test_compiled_loop_books_the_slip_work_as_the_driver_does(monkeypatch):
    """Block-incline (μ = 0.3, sliding up, stopping, sliding back) with hht: the compiled
    loop takes many steps per call in the slipping phases and books their friction work
    and the output rows' (core.coulomb.book_step, book_rows); one step per call, the driver
    books every step itself. The histories agree to round-off, the friction work is
    −μ m g cos φ times the distance slid, and the batched run made far fewer calls."""
    sc = load_scene("block-incline", {"t_end": 0.6})

    def run(batched: bool):
        calls: list[int] = []
        run_phase = runner.run_phase

        def counted(*args):
            out = run_phase(*args)
            calls.append(out[1])   # the steps this compiled call took
            return out

        monkeypatch.setattr(runner, "run_phase", counted)
        if not batched:
            monkeypatch.setattr(driver.Driver, "_batch_ok", lambda self, problem: False)
        res = driver.simulate(build_system(sc), get_integrator("hht")(h=1e-4), sc.t_end, sc["output.dt"])
        monkeypatch.undo()
        assert res.status == "completed", res.message
        return res.history, calls

    fast, calls_fast = run(True)
    slow, calls_slow = run(False)
    assert max(calls_fast) > 100 and max(calls_slow) == 1 and len(calls_fast) < len(calls_slow) / 50
    assert len(fast) == len(slow)
    for col in ("x", "vx", "W_friction", "energy_residual"):
        assert np.abs(fast[col].to_numpy() - slow[col].to_numpy()).max() < 1e-13, col
    mu, phi, m = float(sc["contact.friction"]), math.radians(sc["ground.incline"]), float(sc["body.mass"])
    x, t = fast["x"].to_numpy() - fast["x"].iloc[0], fast["t"].to_numpy()
    ts, xs = incline_stop(float(sc["start.vx"]), phi, mu, G)
    slid = np.where(t <= ts, x, 2.0 * xs - x)   # up to the stop, then back down
    assert np.abs(fast["W_friction"].to_numpy() + mu * m * G * math.cos(phi) * slid).max() < 1e-9
