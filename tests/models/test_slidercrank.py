"""The slider-crank with a clearance joint (daebench.models.slidercrank, case
slider-crank-clearance) against independent truth: its kernels against the bodies'
geometry and kinetic energy written in Cartesian centres; with no clearance, the classic
rigid slider-crank (scipy's DOP853 on the 2-coordinate index-1 DAE) that the contacts must
reproduce, first order; the first contact time against the free flight solved by scipy;
the energy balance with the friction work; the two event-capturing schemes agreeing on
the contact pattern; the event-driven driver at μ = 0.

Cold-cache cost: the compiled loops of moreau and nsgenalpha (and hht, slow test) on this
model (~60–120 s CPU each); each run after that takes well under a second.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from daebench.core import kernels
from daebench.core.scene import SceneError
from daebench.harness.running import checks as guards
from daebench.integrators.applicability import applies_friction
from daebench.integrators.base import IntegratorError
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.scenes import load_scene
from daebench.models.slidercrank import SliderCrank
from _driver_runs import cached_run, slope  # noqa: E402

CASE = "slider-crank-clearance"


# -- an independent formulation: the three bodies' centres in Cartesian coordinates ------------------
def _centres(s: SliderCrank, q: np.ndarray) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """(mass, centre, Jacobian ∂centre/∂q) of crank, rod and slider."""
    l1, l2 = s.l1, s.l2
    c1, s1, c2, s2 = math.cos(q[0]), math.sin(q[0]), math.cos(q[1]), math.sin(q[1])
    return [(s.m1, np.array([l1 / 2 * c1, l1 / 2 * s1]), np.array([[-l1 / 2 * s1, 0, 0], [l1 / 2 * c1, 0, 0]])),
            (s.m2, np.array([l1 * c1 + l2 / 2 * c2, l1 * s1 + l2 / 2 * s2]),
             np.array([[-l1 * s1, -l2 / 2 * s2, 0], [l1 * c1, l2 / 2 * c2, 0]])),
            (s.m3, np.array([l1 * c1 + l2 * c2, l1 * s1 + l2 * s2]),
             np.array([[-l1 * s1, -l2 * s2, 0], [l1 * c1, l2 * c2, 0]]))]


def _mass(s: SliderCrank, q: np.ndarray) -> np.ndarray:
    return sum(m * J.T @ J for m, _, J in _centres(s, q)) + np.diag([s.J1, s.J2, s.J3])


def _potential(s: SliderCrank, q: np.ndarray) -> float:
    return sum(m * s.g * c[1] for m, c, _ in _centres(s, q))


def _corner(s: SliderCrank, i: int, q: np.ndarray) -> np.ndarray:
    p, r, _ = s.points[i]
    x3, y3 = _centres(s, q)[2][1]
    return np.array([x3 + p * math.cos(q[2]) - r * math.sin(q[2]), y3 + p * math.sin(q[2]) + r * math.cos(q[2])])


def _rhs(s: SliderCrank, rigid: bool):
    """q̈ of the free 3-coordinate system (slider flying), or of the rigid slider-crank
    (slider centre held on the axis: a multiplier on y3 = l1 sin θ1 + l2 sin θ2 = 0, θ3 fixed),
    from the Lagrangian of the Cartesian centres: M q̈ = −(Σ m J_cᵀ J̇_c) q̇ + ... (Ṁ q̇ − ∂T/∂q)."""
    def f(_, z):
        q, v = z[:3], z[3:]
        M = _mass(s, q)
        d = 1e-6
        # Lagrange: M q̈ + Ṁ q̇ − ∂T/∂q + ∂V/∂q = 0; Ṁ and ∂/∂q by central differences
        dM = [(_mass(s, q + d * e) - _mass(s, q - d * e)) / (2 * d) for e in np.eye(3)]
        Mdot = sum(v[k] * dM[k] for k in range(3))
        dT = np.array([0.5 * v @ dM[k] @ v for k in range(3)])
        dV = np.array([(_potential(s, q + d * e) - _potential(s, q - d * e)) / (2 * d) for e in np.eye(3)])
        F = -Mdot @ v + dT - dV
        if not rigid:
            return np.concatenate([v, np.linalg.solve(M, F)])
        G = np.array([[s.l1 * math.cos(q[0]), s.l2 * math.cos(q[1]), 0.0], [0.0, 0.0, 1.0]])
        gam = np.array([s.l1 * math.sin(q[0]) * v[0] ** 2 + s.l2 * math.sin(q[1]) * v[1] ** 2, 0.0])
        A = np.block([[M, G.T], [G, np.zeros((2, 2))]])
        return np.concatenate([v, np.linalg.solve(A, np.concatenate([F, gam]))[:3]])
    return f


def test_kernels_are_the_bodies_geometry_and_energy():
    """M from the centres' kinetic energy; Q = −(Ṁ q̇ − ∂T/∂q) − ∂V/∂q; the gap of each corner its
    distance from its wall, g_q and the tangent row its Jacobians, γ from g̈ = g_q q̈ − γ (second
    difference with q̈ = 0); the analytic ∂Q and ∂(M a)/∂q against central differences."""
    s = SliderCrank(friction=0.3)
    md = s.kernel_data()
    rng = np.random.default_rng(7)
    for _ in range(4):
        q, v, a = rng.normal(size=3), rng.normal(size=3) * 5, rng.normal(size=3)
        M, Q = s.mass_force(0.0, q, v)
        assert np.allclose(M, _mass(s, q), rtol=1e-13, atol=1e-16)
        acc = _rhs(s, False)(0.0, np.concatenate([q, v]))[3:]
        assert np.allclose(np.linalg.solve(M, Q), acc, rtol=1e-6, atol=1e-6)
        assert sum(s.energy(q, v).values()) == pytest.approx(0.5 * v @ M @ v + _potential(s, q), rel=1e-13)
        Kq, Kv = s.force_jacobian(0.0, q, v)
        d = 1e-6
        for j, e in enumerate(np.eye(3)):
            f = s.applied_force
            assert np.allclose(Kq[:, j], (f(0, q + d * e, v) - f(0, q - d * e, v)) / (2 * d), atol=1e-7)
            assert np.allclose(Kv[:, j], (f(0, q, v + d * e) - f(0, q, v - d * e)) / (2 * d), atol=1e-7)
        K = s.mass_jacobian_product(q, a)
        dMa = np.array([(_mass(s, q + d * e) - _mass(s, q - d * e)) @ a / (2 * d) for e in np.eye(3)]).T
        assert np.allclose(K, dMa, atol=1e-8)
        for i in range(4):
            gq, tq = np.zeros(3), np.zeros(3)
            g, gam = kernels.gap(md, i, q, v, gq)
            assert kernels.tangent(md, i, q, v, tq) == 0.3
            side = s.points[i, 2]
            assert g == pytest.approx(s.b + s.c - side * _corner(s, i, q)[1], abs=1e-14)
            J = np.array([(_corner(s, i, q + d * e) - _corner(s, i, q - d * e)) / (2 * d) for e in np.eye(3)]).T
            assert np.allclose(gq, -side * J[1], atol=1e-8) and np.allclose(tq, J[0], atol=1e-8)
            dt = 1e-4
            y = [_corner(s, i, q + k * dt * v)[1] for k in (-1, 0, 1)]
            gdd = -side * (y[0] - 2 * y[1] + y[2]) / dt**2
            assert gdd == pytest.approx(-gam, rel=1e-5, abs=1e-5)


def test_scene_start_and_refusals():
    """Siconos' start: θ̇2 = −75 rad/s (the rigid kinematics), every corner 1 mm from its wall,
    E0 = ½ q̇ᵀ M q̇ = 7.4955 J; impossible geometry refused with the key to change."""
    sc = load_scene(CASE)
    s = build_system(sc)
    q, v = s.initial_state()
    assert np.allclose(v, [150.0, -75.0, 0.0]) and np.allclose(s.corner_gaps(q), 1e-3, atol=1e-15)
    assert s.total_energy(q, v) == pytest.approx(0.5 * v @ _mass(s, q) @ v, rel=1e-14)
    assert s.total_energy(q, v) == pytest.approx(7.4955, abs=5e-5)   # the source states 4 digits
    s30 = build_system(load_scene(CASE, {"start.theta": 30.0}))
    q, v = s30.initial_state()
    assert s30.l1 * math.sin(q[0]) + s30.l2 * math.sin(q[1]) == pytest.approx(0.0, abs=1e-15)
    assert s30.l1 * math.cos(q[0]) * v[0] + s30.l2 * math.cos(q[1]) * v[1] == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(SceneError, match="crank.length"):
        load_scene(CASE, {"crank.length": 0.4})
    with pytest.raises(SceneError, match="clearance.c"):
        load_scene(CASE, {"clearance.c": 0.02})


def _rigid(sc, t: np.ndarray) -> np.ndarray:
    s = build_system(sc)
    q0, v0 = s.initial_state()
    sol = solve_ivp(_rhs(s, True), (0.0, t[-1]), np.concatenate([q0, v0]), method="DOP853", rtol=1e-12,
                    atol=1e-12, t_eval=t)
    return sol.y


def test_zero_clearance_is_the_rigid_slider_crank_first_order():
    """clearance.c = 0, e = 0: the four corners hold the slider on the axis, and moreau's crank
    angle approaches the rigid slider-crank's (1 DOF, scipy DOP853 at 1e-12) like h; the
    slider stays within 2e-7 m of the axis and level."""
    sc = load_scene(CASE, {"clearance.c": 0.0, "contact.restitution": 0.0, "t_end": 0.02})
    steps = (4e-5, 2e-5, 1e-5)
    err = []
    for h in steps:
        res, _ = cached_run("moreau", CASE, {"clearance.c": 0.0, "contact.restitution": 0.0, "t_end": 0.02}, h=h)
        H = res.history
        ref = _rigid(sc, H.t.values)
        err.append(np.abs(H.theta.values - ref[0]).max())
        assert np.abs(H.omega.values - ref[3]).max() < 400 * h
        assert np.abs(H.y.values).max() < 2e-7 and np.abs(H.psi.values).max() < 1e-15
    assert err[-1] < 5e-5, err
    assert 0.75 < slope(steps, err) < 1.3, err


def _first_contact_time(sc) -> float:
    """When the first corner reaches its wall in free flight (scipy, event located to 1e-12)."""
    s = build_system(sc)
    q0, v0 = s.initial_state()

    def hit(_, z):
        return float(s.corner_gaps(z[:3]).min())
    hit.terminal, hit.direction = True, -1
    sol = solve_ivp(_rhs(s, False), (0.0, sc.t_end), np.concatenate([q0, v0]), method="DOP853", rtol=1e-12,
                    atol=1e-12, events=hit)
    return float(sol.t_events[0][0])


@pytest.mark.parametrize("integrator", ["moreau", "nsgenalpha"])
def test_energy_balance_books_the_friction_work(integrator):
    """e = 1: frictionless, the energy changes only by the smooth part's error (→ 0 with h, no
    contact work); with μ = 0.3 the energy lost equals the friction work W_contact the scheme
    books (0.41 J of 7.5 J), the balance residual falling like h, the loss converging."""
    base = {"contact.restitution": 1.0, "t_end": 0.02}
    steps = (2e-5, 1e-5, 5e-6)
    drift, resid, loss = [], [], []
    for h in steps:
        r0, _ = cached_run(integrator, CASE, {**base, "contact.friction": 0.0}, h=h)
        r1, _ = cached_run(integrator, CASE, {**base, "contact.friction": 0.3}, h=h)
        H0, H1 = r0.history, r1.history
        drift.append(abs(H0.E.iloc[-1] - H0.E.iloc[0]))
        resid.append(np.abs(H1.energy_residual).max())
        dE, W = H1.E.iloc[-1] - H1.E.iloc[0], H1.W_contact.iloc[-1]
        assert abs(dE - W) <= resid[-1] * (1 + 1e-9)
        loss.append(-W)
    assert max(drift) < 2.5e-3 and slope(steps, drift) > 0.7, drift
    assert max(resid) < 1e-3 and slope(steps, resid) > 0.6, resid
    assert 0.40 < min(loss) and max(loss) < 0.42 and np.ptp(loss) < 3e-3, loss


def test_capturing_schemes_agree_on_the_contact_pattern():
    """moreau and nsgenalpha, μ = 0, h = 5e-6 s: both find the first contact within one step of the
    free flight's (scipy), on the upper wall's two corners at once (the slider is level); their
    slider heights agree to 5 % of the clearance on 95 % of the output times (chattering:
    the individual bounces differ), and each keeps every corner within 10 µm (1 % of c) of its wall."""
    sc = load_scene(CASE, {"t_end": 0.02})
    t1 = _first_contact_time(sc)
    assert 0.0026 < t1 < 0.0028
    h = 5e-6
    ys = []
    for name in ("moreau", "nsgenalpha"):
        res, _ = cached_run(name, CASE, {"t_end": 0.02}, h=h)
        first = [i for i in res.impacts if i.t < t1 + 2 * h]
        assert sorted(i.contact for i in first) == [0, 1] and all(abs(i.t - t1) <= h for i in first), first
        ys.append(res.history.y.values)
        assert res.history.gap.min() > -1e-5
    close = np.abs(ys[0] - ys[1]) < 0.05 * sc["clearance.c"]
    assert close.mean() > 0.95, close.mean()


@pytest.mark.parametrize("integrator", ["moreau", "nsgenalpha"])
def test_siconos_friction_variant_runs_and_books_the_friction_work(integrator):
    """μ = 0.01, e = 0.1 (the example's WITH_FRICTION variant), h = 1e-5 s: the run completes (moreau's
    frictional LCP used to end on a Lemke ray where the two corners of a wall strike together:
    identical tangent rows), its energy change is the booked contact work within its balance
    residual (< 1 mJ of 7.5 J), and friction dissipates more than the frictionless impacts
    alone (0.049 against 0.033 J). The slider stays level (|ψ| < 1e-9 rad): while both corners
    of a wall touch, their normal forces balance the friction's moment."""
    over = {"t_end": 0.02, "contact.friction": 0.01}
    res, _ = cached_run(integrator, CASE, over, h=1e-5)
    free, _ = cached_run(integrator, CASE, {"t_end": 0.02}, h=1e-5)
    H, F = res.history, free.history
    assert abs(H.E.iloc[-1] - H.E.iloc[0] - H.W_contact.iloc[-1]) <= np.abs(H.energy_residual).max() < 1e-3
    assert H.W_contact.iloc[-1] < F.W_contact.iloc[-1] - 0.01 < 0.0
    assert np.abs(H.psi).max() < 1e-9 and np.abs(F.psi).max() < 1e-15


def test_event_driven_takes_the_frictionless_case_and_refuses_friction_it_cannot_apply():
    """hht (event-driven) is accepted at μ = 0; with μ > 0 it is refused before the first step,
    naming the integrators that apply friction, unless it declares friction itself."""
    hht = get_integrator("hht")
    guards.check_applicable(load_scene(CASE), hht)
    sc = load_scene(CASE, {"contact.friction": 0.01})
    if applies_friction(hht, sc["contact.law"]):
        guards.check_applicable(sc, hht)
    else:
        with pytest.raises(IntegratorError, match="friction"):
            guards.check_applicable(sc, hht)
    guards.check_applicable(sc, get_integrator("moreau"))


@pytest.mark.slow
def test_event_driven_hht_finds_the_first_contact():
    """hht at μ = 0 locates the first contact at the free flight's time (scipy) to within 1e-6 s,
    the error falling like h (5.5e-7, 2.7e-7 s at h = 1e-5, 5e-6 s), and runs the chattering
    through (the driver's impacts, the contacts closing) without penetrating."""
    sc = load_scene(CASE, {"t_end": 0.02})
    t1 = _first_contact_time(sc)
    err = []
    for h in (1e-5, 5e-6):
        res, _ = cached_run("hht", CASE, {"t_end": 0.02}, h=h)
        err.append(abs(res.impacts[0].t - t1))
        assert res.history.gap.min() > -1e-9
    assert err[0] < 1e-6 and 0.4 * err[0] < err[1] < 0.6 * err[0], err
