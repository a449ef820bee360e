"""Event-capturing integrators (moreau, nsgenalpha) against independent truth: the ball
dropped on the ground (closed-form impact times and apex heights e^(2k)·h0), the
spring–wall oscillator with e = 1 (energy conserved, exact piecewise-harmonic motion),
the complementarity conditions of the LCP solver.

Cold-cache cost: one compiled stepper loop per integrator on the ball model (two pairs);
the beam-impact and chain-impact checks are in tests/integrators/test_capture_beam.py (slow).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize

from daebench.core.lcp import lcp_work, solve_lcp
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.ball import ball_impacts, exact_motion
from daebench.models.scenes import load_scene
from _driver_runs import cached_run, slope  # noqa: E402
from daebench.driver.simulate import simulate

STEPS = (1e-3, 5e-4, 2.5e-4, 1.25e-4)
SWEEP = tuple(2e-3 * 1.5 ** -np.arange(8))   # 2e-3 … 1.2e-4: ratios that sample the impact phase
H0, E_BALL, G = 1.0, 0.8, 9.81


def run(integrator: str, scene: str, overrides: dict | None = None, **settings):
    """Run through the driver (cached: several tests read the same runs)."""
    return cached_run(integrator, scene, overrides, **settings)


# -- the LCP solver -------------------------------------------------------------------------------
def test_lcp_solution_is_complementary_and_minimizes_the_quadratic():
    """z ≥ 0, w = Az + b ≥ 0, zᵀw = 0 on random SPD problems, and z is the minimizer of
    ½zᵀAz + bᵀz on z ≥ 0 (found independently by L-BFGS-B); unused rows stay zero."""
    rng = np.random.default_rng(7)
    for k in (1, 2, 3, 5, 8):
        for _ in range(20):
            B = rng.normal(size=(k, k))
            A = B @ B.T + 0.1 * np.eye(k)
            b = rng.normal(size=k)
            use = np.ones(k, bool)
            z, w = np.zeros(k), np.zeros(k)
            assert solve_lcp(A, b, use, z, w, lcp_work(k)) >= 0
            assert z.min() >= 0.0 and w.min() >= -1e-12 and abs(z @ w) <= 1e-12
            qp = minimize(lambda x: 0.5 * x @ A @ x + b @ x, np.zeros(k), jac=lambda x: A @ x + b,
                          bounds=[(0, None)] * k, method="L-BFGS-B", options={"ftol": 1e-15, "gtol": 1e-12})
            assert np.allclose(z, qp.x, atol=1e-5)
    A = np.array([[2.0, 1.0], [1.0, 2.0]])
    z, w = np.zeros(2), np.zeros(2)
    solve_lcp(A, np.array([-1.0, -1.0]), np.array([True, False]), z, w, lcp_work(2))
    assert z[0] == 0.5 and z[1] == 0.0


# -- the bouncing ball: first order at impacts ----------------------------------------------------
@pytest.mark.parametrize("integrator", ["moreau", "nsgenalpha"])
def test_ball_impact_times_and_apex_heights_first_order(integrator):
    """Impact times (start of the first step with a positive impulse) and apex heights
    against the closed forms; the error over the first four bounces falls like h
    (fitted over eight steps whose ratio 1.5 samples where in a step the impacts fall)."""
    t_exact, apex_exact = ball_impacts(H0, E_BALL, G, 4)
    err_t, err_apex = [], []
    for h in SWEEP:
        res, _ = run(integrator, "ball", h=h)
        t = np.array([i.t for i in res.impacts[:4]])
        assert t.size == 4
        err_t.append(np.max(np.abs(t - t_exact)))
        hist = res.history
        x, tt = hist["x"].to_numpy(), hist["t"].to_numpy()
        bounds = [*t_exact, math.inf]
        apex = [x[(tt > bounds[k]) & (tt < bounds[k + 1])].max() for k in range(3)]
        err_apex.append(np.max(np.abs(np.array(apex) - apex_exact[:3])))
    p_t, p_apex = slope(SWEEP, err_t), slope(SWEEP, err_apex)
    print(f"\n{integrator}: h = {['%.2e' % h for h in SWEEP]}\n  impact-time error / h "
          f"{['%.2f' % (e / h) for e, h in zip(err_t, SWEEP)]} (slope {p_t:.2f})\n  apex error / h "
          f"{['%.2f' % (e / h) for e, h in zip(err_apex, SWEEP)]} m/s (slope {p_apex:.2f})")
    assert all(e <= 7.0 * h for e, h in zip(err_t + err_apex, SWEEP + SWEEP))
    assert 0.7 <= p_t <= 1.6 and 0.7 <= p_apex <= 1.6


@pytest.mark.parametrize("integrator", ["moreau", "nsgenalpha"])
def test_ball_episode_record(integrator):
    """Each bounce is one episode of one step: ġ⁻ = −√(2gh0)·e^(k−1) and the energy lost
    ½(1−e²) m ġ⁻² (the exact impact map) to O(h); ġ⁺ = −e ġ⁻ and the impulse
    (1+e) m |ġ⁻| + m g h (the contact also carries the step's weight) to round-off."""
    h = STEPS[2]
    res, _ = run(integrator, "ball", h=h)
    # the impulses' work Σ P (U⁻ + U⁺)/2 is booked as W_contact: Moreau θ = ½ balances
    # exactly on this linear system; nsgenalpha's position correction Q lifts the ball out of
    # the ground by up to h|ġ⁻| at each bounce: m g Q, O(h) in all (measured 4.2 h E0)
    E0 = G * H0
    print(f"\n{integrator}: energy residual {res.energy_residual:.2e} J of E0 = {E0} J, "
          f"W_contact {res.history['W_contact'].iloc[-1]:.4f} J")
    assert res.energy_residual <= (1e-9 if integrator == "moreau" else 10.0 * h) * E0
    v1 = math.sqrt(2.0 * G * H0)
    for k, imp in enumerate(res.impacts[:4]):
        vm = -v1 * E_BALL**k
        assert imp.vn_minus == pytest.approx(vm, abs=2 * G * h + 0.02 * abs(vm))
        assert imp.vn_plus == pytest.approx(-E_BALL * imp.vn_minus, rel=1e-9)
        assert imp.impulse == pytest.approx((1 + E_BALL) * abs(imp.vn_minus) + G * h, rel=1e-9)
        exact = 0.5 * (1 - E_BALL**2) * vm**2
        assert imp.energy_loss == pytest.approx(exact, rel=20 * h)
        assert imp.t_end == pytest.approx(imp.t + h) and not imp.closed


# -- smooth motion: second order --------------------------------------------------------------------
@pytest.mark.parametrize("integrator", ["moreau", "nsgenalpha"])
def test_smooth_motion_second_order(integrator):
    """The spring–mass without reaching the wall: θ = ½ and generalized-α are second order."""
    sc = {"contact.wall": -1.0, "t_end": 1.0}
    hs = (4e-3, 2e-3, 1e-3)
    err = []
    for h in hs:
        res, system = run(integrator, "spring-wall", sc, h=h)
        _, at = exact_motion(system, 1.0)
        x, _ = at(res.history["t"].to_numpy())
        err.append(np.max(np.abs(res.history["x"].to_numpy() - x)))
    p = slope(hs, err)
    print(f"\n{integrator} smooth: max |x − x_exact| {['%.2e' % e for e in err]} m, slope {p:.2f}")
    assert 1.8 <= p <= 2.2


# -- spring–wall, e = 1: energy -----------------------------------------------------------------------
def test_spring_wall_energy():
    """e = 1: Moreau θ = ½ conserves the energy exactly (the step balance ½(U + U⁻)P = 0);
    θ = 1 loses O(h); nsgenalpha's error is O(h) too (the position correction moves the
    mass against the spring force at each impact) and far below θ = 1's."""
    rel = {}
    for name, settings in (("moreau", {}), ("moreau", {"theta": 1.0}), ("nsgenalpha", {"rho_inf": 1.0})):
        out = []
        for h in STEPS[:3]:
            res, _ = run(name, "spring-wall", h=h, **settings)
            E = res.history["E"].to_numpy()
            out.append(np.max(np.abs(E - E[0])) / E[0])
            assert len(res.impacts) == 5
        rel[(name, settings.get("theta", settings.get("rho_inf")))] = out
    for k, v in rel.items():
        print(f"\n{k}: max |E − E0|/E0 = {['%.2e' % e for e in v]}")
    assert max(rel[("moreau", None)]) < 1e-10
    assert 0.8 <= slope(STEPS[:3], rel[("moreau", 1.0)]) <= 1.2
    assert all(e <= 20.0 * h for e, h in zip(rel[("nsgenalpha", 1.0)], STEPS))
    assert all(a < 0.2 * b for a, b in zip(rel[("nsgenalpha", 1.0)], rel[("moreau", 1.0)]))


# -- penetration ------------------------------------------------------------------------------------
def _min_gap(res) -> float:
    return min(res.history["gap"].min(), min(i.min_gap for i in res.impacts))


def test_penetration():
    """nsgenalpha and Moreau with projection: no gap below the Newton tolerance (history at
    every output time and every episode's step ends); Moreau θ = γ = 1: above −h²g (the bound
    of its docstring); Moreau θ = γ = ½ (Siconos' default): O(h |ġ⁻|), first order."""
    pen = {}
    for h in SWEEP:
        pen[("nsga", h)] = _min_gap(run("nsgenalpha", "ball", h=h)[0])
        pen[("mj", h)] = _min_gap(run("moreau", "ball", h=h)[0])
    for h in SWEEP[::3]:
        pen[("proj", h)] = _min_gap(run("moreau", "ball", h=h, projection=True)[0])
        pen[("mj11", h)] = _min_gap(run("moreau", "ball", h=h, theta=1.0, gamma=1.0)[0])
    print("\nmin gap [m]:", {k: [f"{h:.1e}: {g:.2e}" for (kk, h), g in pen.items() if kk == k]
                             for k in ("nsga", "proj", "mj11", "mj")})
    v1 = math.sqrt(2.0 * G * H0)
    for (k, h), g in pen.items():
        if k in ("nsga", "proj"):
            assert g >= -1e-12
        elif k == "mj11":
            assert g >= -h * h * G * (1 + 1e-9)
        else:
            assert -g <= h * v1
    depth = [-pen[("mj", h)] for h in SWEEP]
    assert 0.7 <= slope(SWEEP, depth) <= 1.3


def test_capture_cli_registers_its_commands():
    """`register(app)` adds `capture page|rates`; bad --steps are refused with exit 2."""
    import typer
    from typer.testing import CliRunner

    from daebench.cli.studies import register

    app = typer.Typer()

    @app.command()
    def other() -> None:  # a second command, so that `capture` stays a sub-command
        pass

    register(app)
    r = CliRunner().invoke(app, ["capture", "--help"])
    assert r.exit_code == 0 and "page" in r.output and "rates" in r.output
    r = CliRunner().invoke(app, ["capture", "page", "beam-impact", "--steps", "1e-4,abc"])
    assert r.exit_code == 2 and "'steps' must be a number, got 'abc'" in r.output
