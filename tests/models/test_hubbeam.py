"""Hub–beam model (daebench.models.hubbeam) against independent truth: beam theory,
Lagrange's equations by finite differences, energy balance, scene validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.core.problem import Problem

from daebench.models import build_system
from daebench.models.hubbeam import HubBeam, hertz_default_stiffness
from daebench.core.scene import SceneError
from daebench.models.scenes import load_scene
from _fd import fd  # tests/_fd.py

RNG = np.random.default_rng(20240607)

# every effect that shapes M and Q on, modes, with a hub
FULL_MODES = ["effects.axial=true", "effects.foreshortening=true", "hub.radius=0.05", "hub.inertia=0.3",
              "discretization.n=4"]
FULL_FEM = ["discretization.kind=fem", "discretization.n=3", "effects.axial=true", "hub.radius=0.05",
            "hub.inertia=0.3"]


def system(name: str, overrides=()) -> HubBeam:
    return build_system(load_scene(name, list(overrides)))


def random_state(s: HubBeam, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    q = np.zeros(s.n)
    v = np.zeros(s.n)
    q[0] = RNG.uniform(-np.pi, np.pi)
    v[0] = RNG.uniform(-3, 3)
    q[s.iA] = scale * 1e-3 * RNG.standard_normal(s.nA)
    v[s.iA] = scale * 1e-1 * RNG.standard_normal(s.nA)
    q[s.iB] = scale * 3e-2 * RNG.standard_normal(s.nB) / np.arange(1, s.nB + 1)
    v[s.iB] = scale * 1.0 * RNG.standard_normal(s.nB) / np.arange(1, s.nB + 1)
    return q, v


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


# ---------------------------------------------------------------------------
# beam theory
def bending_frequencies(s: HubBeam) -> np.ndarray:
    """Natural frequencies (Hz) of the clamped beam: θ locked, linearized at rest."""
    from scipy.linalg import eigh

    M = s.mass(np.zeros(s.n))[s.iB, s.iB]
    lam = eigh(s.K2, M, eigvals_only=True)
    return np.sqrt(lam) / (2 * np.pi)


def analytic_frequencies(scene, k: int) -> np.ndarray:
    from daebench.models.shapes import cantilever_roots

    L, rho, S = scene["beam.length"], scene["beam.density"], scene["beam.area"]
    EI = scene["beam.modulus"] * scene["beam.inertia"]
    return cantilever_roots(k) ** 2 * np.sqrt(EI / (rho * S * L**4)) / (2 * np.pi)


@pytest.mark.parametrize("N", [1, 3, 7, 12])
def test_modal_frequencies_exact(N):
    sc = load_scene("hub-beam", ["discretization.kind=modes", f"discretization.n={N}"])
    f = bending_frequencies(build_system(sc))
    assert rel(f, analytic_frequencies(sc, N)) < 1e-8


def test_fem_frequencies_converge_at_fourth_order():
    ne = np.array([4, 8, 16, 32])
    errs = []
    for n in ne:
        sc = load_scene("hub-beam", [f"discretization.n={n}", "effects.foreshortening=false"])
        f = bending_frequencies(build_system(sc))[:3]
        errs.append(np.abs(f / analytic_frequencies(sc, 3) - 1.0))
    errs = np.array(errs)  # (meshes, modes)
    for m in range(3):
        slope = np.polyfit(np.log(1.0 / ne), np.log(errs[:, m]), 1)[0]
        assert abs(slope - 4.0) < 0.3, (m, slope, errs[:, m])


def static_tip(s: HubBeam) -> float:
    """Tip deflection of the horizontal cantilever under gravity (θ locked at 0)."""
    QB = s.applied_force(0.0, np.zeros(s.n), np.zeros(s.n))[s.iB]
    B = np.linalg.solve(s.K2, QB)
    q = np.zeros(s.n)
    q[s.iB] = B
    return s.observables(0.0, q, np.zeros(s.n))["tip_w2"]


def exact_static_tip(sc) -> float:
    L = sc["beam.length"]
    return -sc["beam.density"] * sc["beam.area"] * sc["gravity.g"] * L**4 / (
        8 * sc["beam.modulus"] * sc["beam.inertia"])


def test_static_deflection_fem_exact_at_nodes():
    for n in (1, 4, 9):
        sc = load_scene("hub-beam", [f"discretization.n={n}", "effects.gravity=true", "effects.torque=false"])
        assert rel(static_tip(build_system(sc)), exact_static_tip(sc)) < 1e-10


def test_static_deflection_modes_converge():
    errs = {}
    for N in (3, 6, 12):
        sc = load_scene("beam-impact", [f"discretization.n={N}"])
        errs[N] = abs(static_tip(build_system(sc)) / exact_static_tip(sc) - 1.0)
    print("static tip error (modes)", errs)
    # measured: 1.6e-4, 6.1e-6, 2.1e-7
    assert errs[3] < 5e-4 and errs[12] < errs[6] < errs[3] and errs[12] < 1e-6


# ---------------------------------------------------------------------------
# Lagrange's equations, Jacobians
@pytest.mark.parametrize("overrides", [FULL_MODES, FULL_FEM], ids=["modes", "fem"])
def test_quadratic_velocity_force_from_lagrange(overrides):
    scene_over = overrides + ["effects.gravity=false", "effects.contact=false"]
    s = system("beam-impact" if "discretization.kind=fem" not in overrides else "hub-beam", scene_over +
               ["effects.torque=false"])
    for _ in range(3):
        q, v = random_state(s)
        Qv = s.applied_force(0.0, q, v) - s.applied_force(0.0, q, np.zeros(s.n))
        dT = fd(lambda x: np.array([0.5 * v @ s.mass(x) @ v]), q)[0]
        Mdot_v = fd(lambda x: s.mass(x) @ v, q) @ v
        assert rel(Qv, dT - Mdot_v) < 1e-6


def all_effects(kind: str) -> HubBeam:
    base = FULL_MODES if kind == "modes" else FULL_FEM
    name = "beam-impact" if kind == "modes" else "hub-beam"
    return system(name, base + ["effects.gravity=true", "effects.torque=true", "torque.tau0=3",
                                "effects.damping=true", "damping.beta=1e-3", "effects.contact=true",
                                "contact.plane_height=0.3", "contact.point=0.8"])


@pytest.mark.parametrize("kind", ["modes", "fem"])
def test_jacobians_match_finite_differences(kind):
    s = all_effects(kind)
    t = 0.7
    for _ in range(3):
        q, v = random_state(s)
        a = RNG.standard_normal(s.n)
        Kq, Kv = s.force_jacobian(t, q, v)
        assert rel(Kq, fd(lambda x: s.applied_force(t, x, v), q)) < 1e-6
        assert rel(Kv, fd(lambda x: s.applied_force(t, q, x), v)) < 1e-6
        assert rel(s.mass_jacobian_product(q, a), fd(lambda x: s.mass(x) @ a, q)) < 1e-6
        assert rel(s.gap_jacobian(q), fd(lambda x: s.gap(x), q)) < 1e-6
        # γ_g = −(g_q v)_q v
        gam = -fd(lambda x: s.gap_jacobian(x) @ v, q) @ v
        assert rel(s.gap_gamma(q, v), gam) < 1e-6


def test_gap_second_derivative_along_motion():
    """g̈ = g_q q̈ − γ_g along q(t) = q + v t + ½ a t²."""
    s = all_effects("modes")
    q, v = random_state(s)
    a = RNG.standard_normal(s.n)
    h = 1e-4
    g = [s.gap(q + v * t + 0.5 * a * t * t)[0] for t in (-h, 0.0, h)]
    gdd = (g[0] - 2 * g[1] + g[2]) / h**2
    pred = s.gap_jacobian(q)[0] @ a - s.gap_gamma(q, v)[0]
    assert abs(gdd - pred) < 1e-6 * max(1.0, abs(pred))


def test_hertz_contact_jacobian_when_penetrating():
    """The phase's force with an engaged Hertz contact: model force + g_qᵀF, Jacobian
    against differences of the total force."""
    s = system("beam-impact", ["contact.law=hertz", "contact.restitution=0.5"])
    p = Problem(s, engaged=np.ones(1), chi=s.contact_law.chi(np.array([1.0])))
    q, v = random_state(s, scale=0.1)
    q[0] = -0.002  # tip below the plane through the hinge
    v[0] = -0.5
    assert s.gap(q)[0] < 0
    Kq, Kv = p.force_jacobian(0.0, q, v)
    assert rel(Kq, fd(lambda x: p.force(0.0, x, v), q, h=1e-8)) < 1e-5
    assert rel(Kv, fd(lambda x: p.force(0.0, q, x), v, h=1e-8)) < 1e-5


# ---------------------------------------------------------------------------
# energy
def energy_rate(s: HubBeam, t: float, q: np.ndarray, v: np.ndarray) -> tuple[float, float]:
    """(E′ = ∂E/∂q·v + ∂E/∂v·M⁻¹Q, scale of its terms), both partial derivatives by
    central differences (separately, so that stiff axial terms don't spoil the step)."""
    acc = np.linalg.solve(s.mass(q), s.applied_force(t, q, v))
    h = 1e-5
    dE_q = (s.total_energy(q + h * v, v) - s.total_energy(q - h * v, v)) / (2 * h)
    # E is quadratic in v, so a central difference in v is exact for any step: take a large one
    ha = 1e-2 * (1.0 + float(np.abs(v).max())) / float(np.abs(acc).max())
    dE_v = (s.total_energy(q, v + ha * acc) - s.total_energy(q, v - ha * acc)) / (2 * ha)
    return dE_q + dE_v, abs(dE_q) + abs(dE_v)


@pytest.mark.parametrize("overrides", [FULL_MODES, FULL_FEM], ids=["modes", "fem"])
def test_energy_conserved_with_gravity_only(overrides):
    name = "hub-beam" if "discretization.kind=fem" in overrides else "beam-impact"
    s = system(name, overrides + ["effects.gravity=true", "effects.torque=false", "effects.contact=false"])
    for _ in range(3):
        q, v = random_state(s)
        dE, scale = energy_rate(s, 0.0, q, v)
        assert abs(dE) < 1e-6 * scale


def test_energy_rate_equals_torque_and_damping_power():
    s = system("hub-beam", ["effects.damping=true", "damping.beta=2e-3", "effects.gravity=true"])
    for t in (0.3, 1.1):
        q, v = random_state(s)
        dE, scale = energy_rate(s, t, q, v)
        P = s.power(t, q, v)
        assert P["damping"] < 0 and P["torque"] != 0
        assert abs(dE - P["torque"] - P["damping"]) < 1e-6 * (scale + abs(P["torque"]) + abs(P["damping"]))


def test_energy_includes_hertz_potential():
    s = system("beam-impact", ["contact.law=hertz"])
    q, v = random_state(s, scale=0.1)
    q[0] = -0.003
    q[s.iB] = 0.0
    E = s.energy(q, v)
    assert set(E) == {"kinetic", "elastic", "gravity", "contact"}
    assert E["contact"] > 0 and E["contact"] == pytest.approx(s.contact_potential(q))


# ---------------------------------------------------------------------------
# scenes, observables
def test_scenes_load_with_published_parameters():
    s = system("beam-impact")
    assert s.n == 6 and s.nA == 0 and s.n_contacts == 1 and s.contact_law.name == "constraint"
    q0, v0 = s.initial_state()
    assert q0[0] == pytest.approx(math.pi / 4) and not v0.any()
    obs = s.observables(0.0, q0, v0)
    assert obs["gap"] == pytest.approx(math.sqrt(0.5)) and obs["tip_x"] == pytest.approx(math.sqrt(0.5))
    assert {"theta_deg", "omega", "tip_x", "tip_y", "tip_w2", "W1", "W5"} <= set(obs)
    h = system("hub-beam")
    assert h.n == 1 + 9 + 18 and h.n_contacts == 0 and h.contact_law is None
    assert h.power(1.0, *h.initial_state()) == {"torque": 0.0}
    M, Q = h.mass_force(0.5, *h.initial_state())
    assert Q[0] == pytest.approx(7.0) and M[0, 0] == pytest.approx(
        0.3 + 2.7667e3 * 2.5e-4 * ((0.05 + 1.8) ** 3 - 0.05**3) / 3)


def test_hertz_default_stiffness():
    s = system("beam-impact", ["contact.law=hertz"])
    assert s.contact_law.stiffness == pytest.approx(hertz_default_stiffness(6.8952e10, 0.33, 0.01))
    assert s.contact_law.stiffness == pytest.approx(4 / 3 * 6.8952e10 / (1 - 0.33**2) * 0.1)


@pytest.mark.parametrize("override, key", [
    ("discretization.n=13", "discretization.n"),
    ("contact.penalty_stiffness=0", "contact.penalty_stiffness"),
    ("contact.restitution=1.5", "contact.restitution"),
    ("beam.lenght=2", "beam.length"),
])
def test_bad_scene_values_name_the_key(override, key):
    extra = ["contact.law=penalty"] if "penalty" in override else []
    with pytest.raises(SceneError, match=key.replace(".", r"\.")):
        load_scene("beam-impact", extra + [override])


def test_fem_allows_many_elements():
    sc = load_scene("hub-beam", ["discretization.n=13"])
    assert build_system(sc).n == 1 + 13 + 26


def test_kernels_callable_from_compiled_code():
    """The contract for compiled integrator loops: the generic kernels of
    daebench.core.kernels called from @njit code on the model's data."""
    from numba import njit

    from daebench.core import kernels

    @njit
    def call(md, t, q, v, M, Q):
        kernels.mass_force(md, t, q, v, M, Q)

    s = all_effects("modes")
    q, v = random_state(s)
    M = np.empty((s.n, s.n))
    Q = np.empty(s.n)
    call(s.kernel_handle(), 0.4, q, v, M, Q)  # what the integrator loops are handed
    M_ref, Q_ref = s.mass_force(0.4, q, v)
    assert np.array_equal(M, M_ref) and np.array_equal(Q, Q_ref)
    assert np.allclose(M, M.T, rtol=0, atol=1e-15 * np.abs(M).max())
    # on the model's own data (kernels compiled for C-contiguous arrays): the same up to the
    # summation order fastmath's reassociation may choose for another array layout
    call(s.kernel_data(), 0.4, q, v, M, Q)
    assert np.allclose(M, M_ref, rtol=0, atol=1e-14 * np.abs(M_ref).max())
    assert np.allclose(Q, Q_ref, rtol=0, atol=1e-14 * np.abs(Q_ref).max())


def test_switched_off_effects_are_not_assembled():
    s = system("beam-impact", ["effects.foreshortening=false", "effects.gravity=false", "effects.contact=false"])
    assert s.tables.H is None and s.contact_law is None and s.n_contacts == 0
    q, v = random_state(s)
    assert "gap" not in s.observables(0.0, q, v) and s.power(0.0, q, v) == {}
    assert s.energy(q, v)["gravity"] == 0.0
    # zero-order model: M does not depend on B
    q2 = q.copy()
    q2[s.iB] *= 3.0
    assert np.allclose(s.mass(q)[s.iB, s.iB], s.mass(q2)[s.iB, s.iB], rtol=0, atol=1e-15)
