"""Co-rotational planar Euler–Bernoulli beams (daebench.models.corotational).

Independent truth:
* rigid-body motion (any rotation, also beyond ±π, any translation and rigid velocity)
  strains nothing: zero force, zero strain energy, zero damping power;
* the analytic tangent equals central differences of the force (daebench.core.kernels);
* linear Euler–Bernoulli cantilever: tip deflection P L³/(3EI) (the cubic element is
  nodally exact), uniform load q L⁴/(8EI) and the clamped–free frequencies
  (β_i L)² √(EI/(ρA L⁴)), β₁L = 1.875104, β₂L = 4.694091, β₃L = 7.854757 — with the
  convergence order measured from a mesh sweep (lumped mass and loads: 2);
* the elastica of a cantilever under a dead tip load, Mattiasson (1981), Table 1 (also
  reproduced by shooting on θ″ = −(PL²/EI) cos θ below).
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from daebench.core import kernels
from daebench.models.corotational import Frame

L, EI, EA, RHOA, RHOI = 1.0, 1.0, 1e8, 1.0, 1e-8
BETA_L = np.array([1.875104068711961, 4.694091132974175, 7.854757438237613])
# K. Mattiasson, "Numerical results from large deflection beam and frame problems analysed
# by means of elliptic integrals", IJNME 17 (1981) 145–153, Table 1: PL²/EI →
# (vertical tip deflection v/L, horizontal tip displacement u/L, tip rotation φ [rad])
MATTIASSON = {1.0: (0.30172, 0.05643, 0.46135), 2.0: (0.49346, 0.16064, 0.78175),
              3.0: (0.60325, 0.25442, 0.98602), 4.0: (0.66996, 0.32894, 1.12124),
              5.0: (0.71379, 0.38763, 1.21537)}


def cantilever(n: int, g: float = 0.0, P: float = 0.0, beta: float = 0.0) -> Frame:
    nodes = np.c_[np.linspace(0.0, L, n + 1), np.zeros(n + 1)]
    el = np.c_[np.arange(n), np.arange(1, n + 1)]
    return Frame(nodes, el, EA, EI, RHOA, RHOI, pinned=[0], clamped_rotations=[0], g=g,
                 loads={n: (0.0, -P)} if P else None, damping_beta=beta)


def tip(fr: Frame, q: np.ndarray, n: int) -> tuple[float, float, float]:
    x, y = fr.node_position(q, n)
    return x, y, float(q[fr.coordinate_names.index(f"th{n}")])


def order(errors) -> np.ndarray:
    e = np.abs(np.asarray(errors))
    return np.log2(e[:-1] / e[1:])


@pytest.mark.parametrize("angle", [0.3, 2.5, -4.0, 7.0, 40.0])
def test_rigid_body_motion_strains_nothing(angle):
    """A free, curved frame moved rigidly: rotation by ``angle`` (beyond ±π and many turns),
    a translation, a rigid angular velocity and a drift — no force, energy or power."""
    nodes = np.array([[0.0, 0.0], [0.7, 0.2], [1.3, 0.1], [1.8, -0.4], [2.0, -1.0]])
    el = np.c_[np.arange(4), np.arange(1, 5)]
    fr = Frame(nodes, el, 1e5, 10.0, 2.0, 1e-3, damping_beta=0.01)
    R = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    shift, om, drift = np.array([0.3, -1.2]), 1.7, np.array([0.2, 0.1])
    q, v = np.zeros(fr.n), np.zeros(fr.n)
    for a in range(5):
        k = fr._trans[a]
        x = R @ nodes[a]
        q[k:k + 2] = x + shift
        q[k + 2] = angle
        v[k:k + 2] = om * np.array([-x[1], x[0]]) + drift
        v[k + 2] = om
    Q = fr.applied_force(0.0, q, v)
    assert np.max(np.abs(Q)) < 1e-9 * 1e5  # round-off of EA-sized terms
    assert fr.energy(q, v)["elastic"] < 1e-20
    assert abs(fr.power(0.0, q, v)["damping"]) < 1e-20


def test_tangent_equals_central_differences():
    nodes = np.c_[np.linspace(0.0, 2.0, 5), np.zeros(5)]
    el = np.c_[np.arange(4), np.arange(1, 5)]
    fr = Frame(nodes, el, 1e5, 10.0, 2.0, 1e-3, pinned=[0], damping_beta=0.01)
    rng = np.random.default_rng(1)
    q = fr.reference_state() + 0.05 * rng.normal(size=fr.n)
    v = rng.normal(size=fr.n)
    Kq, Kv = fr.force_jacobian(0.0, q, v)
    Kq_fd, Kv_fd = np.empty_like(Kq), np.empty_like(Kv)
    kernels._fd_force_jacobian(fr.data, 0.0, q, v, Kq_fd, Kv_fd)
    assert np.max(np.abs(Kq - Kq_fd)) < 1e-7 * np.max(np.abs(Kq))
    assert np.max(np.abs(Kv - Kv_fd)) < 1e-7 * np.max(np.abs(Kv))


def test_small_tip_load_gives_the_euler_bernoulli_deflection_on_any_mesh():
    P = 1e-6  # small: the geometric nonlinearity is O(P²)
    for n in (1, 2, 5):
        fr = cantilever(n, P=P)
        q = fr.static_equilibrium(steps=1)
        _, y, th = tip(fr, q, n)
        assert y == pytest.approx(-P * L**3 / (3 * EI), rel=1e-9)
        assert th == pytest.approx(-P * L**2 / (2 * EI), rel=1e-9)


def test_uniform_load_deflection_converges_at_order_two():
    g = 1e-6
    exact = g * RHOA * L**4 / (8 * EI)
    errs = []
    for n in (4, 8, 16, 32):
        fr = cantilever(n, g=g)
        q = fr.static_equilibrium(steps=1)
        errs.append(-tip(fr, q, n)[1] / exact - 1.0)
    p = order(errs)
    print("uniform load: relative errors", errs, "orders", p)
    assert np.all(np.abs(p - 2.0) < 0.05)
    assert abs(errs[-1]) < 5e-4


def test_first_bending_frequencies_converge_at_order_two():
    exact = BETA_L**2 * math.sqrt(EI / (RHOA * L**4))
    errs = []
    for n in (8, 16, 32):
        w = cantilever(n).linear_frequencies()[:3]  # the axial modes lie far above (EA ≫ EI/L²)
        errs.append(w / exact - 1.0)
    errs = np.array(errs)
    p = order(errs)
    print("frequencies: relative errors", errs.tolist(), "orders", p.tolist())
    assert np.all(np.abs(p[-1] - 2.0) < 0.05)
    assert np.all(np.abs(errs[-1]) < 3e-3)


def elastica(k: float) -> tuple[float, float, float]:
    """(v/L, u/L, φ) of the inextensible elastica under a dead tip load, PL²/EI = k, by
    shooting on θ″ = −k cos θ, θ(0) = 0, θ′(1) = 0 (s = arc length / L)."""
    def tip_angle_residual(a):
        s = solve_ivp(lambda s, y: [y[1], -k * math.cos(y[0])], [1.0, 0.0], [a, 0.0], rtol=1e-12, atol=1e-13)
        return s.y[0, -1]
    a = brentq(tip_angle_residual, 1e-9, math.pi / 2 - 1e-12, xtol=1e-14)
    s = solve_ivp(lambda s, y: [y[1], -k * math.cos(y[0]), math.cos(y[0]), math.sin(y[0])], [1.0, 0.0],
                  [a, 0.0, 0.0, 0.0], rtol=1e-12, atol=1e-13)
    return -s.y[3, -1], 1.0 + s.y[2, -1], a


def test_mattiasson_table_is_the_elastica():
    """The published table against an independent shooting solution (5 digits)."""
    for k, ref in MATTIASSON.items():
        assert np.allclose(elastica(k), ref, atol=1e-5)


def test_large_deflection_cantilever_matches_the_elastica_to_1e_3():
    n = 20
    worst = 0.0
    for k, (v_ref, u_ref, phi_ref) in MATTIASSON.items():
        fr = cantilever(n, P=k * EI / L**2)
        q = fr.static_equilibrium(steps=int(4 * k))
        x, y, th = tip(fr, q, n)
        err = max(abs(-y / L - v_ref), abs(1.0 - x / L - u_ref), abs(-th - phi_ref))
        worst = max(worst, err)
    print(f"elastica, {n} elements: worst error {worst:.2e}")
    assert worst < 1e-3
