"""rod-wall with mass redistribution (``rod.contact_mass = "redistributed"``) against the
semi-discrete bar solved exactly in time, written here from its definition: N lumped
2-node bar elements, the struck node massless and its mass on the next node, the first
element a unilateral spring against the wall; modal superposition, release at the
reaction's first zero (docs/sources.md §A.3's method; with the struck node stopped
instead it reproduces that table's lumped rows, which the first test checks)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import eigh
from scipy.optimize import brentq

from daebench.core.scene import SceneError
from daebench.models import build_system, rodwall
from daebench.models.scenes import load_scene
from daebench.studies.interactive_mode_contact import measures as fc


def semi_discrete_bar(N: int, redistributed: bool, wall_spring: float = 1.0) -> dict[str, float]:
    """The bar of N lumped elements after its end touches the wall at v0, in units
    L = E = ρ = A = v0 = 1 (T_exact = 2, Z v0 = 1, KE0 = ½). ``redistributed``: the end's
    mass moved to the next node, the end massless; else the end node stopped (its
    kinetic energy lost) and held. ``wall_spring``: the first element's stiffness factor
    (a penalty spring k_p in series: k_p / (k_e + k_p))."""
    l = 1.0 / N
    m = np.full(N + 1, l)
    m[0] = m[-1] = 0.5 * l
    if redistributed:
        m[1] += m[0]
        m[0] = 0.0
    mass = m.sum()
    k = 1.0 / l
    K = np.zeros((N, N))
    for i in range(N - 1):
        K[i:i + 2, i:i + 2] += k * np.array([[1.0, -1.0], [-1.0, 1.0]])
    ks = wall_spring * k
    K[0, 0] += ks
    w2, phi = eigh(K, np.diag(m[1:]))
    w = np.sqrt(w2)
    a = phi.T @ (m[1:] * -1.0)                         # u(t) = Σ φ_j a_j sin(ω_j t)/ω_j, u(0) = 0, u̇(0) = −v0

    def reaction(t: float) -> float:
        return -ks * float(phi[0] @ (a * np.sin(w * t) / w))

    ts = np.linspace(1e-9, 4.0, 400_001)
    R = -ks * (np.sin(np.outer(ts, w)) / w) @ (a * phi[0])
    j = np.flatnonzero((R[:-1] > 0.0) & (R[1:] <= 0.0))[0]
    T = brentq(reaction, ts[j], ts[j + 1], xtol=1e-14)
    impulse = -ks * float(phi[0] @ (a * (1.0 - np.cos(w * T)) / w2))
    u, v = phi @ (a * np.sin(w * T) / w), phi @ (a * np.cos(w * T))
    K[0, 0] -= ks                                      # released: the bar alone
    energy = 0.5 * float(m[1:] @ v ** 2) + 0.5 * float(u @ K @ u)
    return {"T_ratio": T / 2.0, "F_mean_ratio": impulse / T, "v_after_ratio": float(m[1:] @ v) / mass,
            "E_after_ratio": energy / 0.5}


def test_the_closed_form_reproduces_the_lumped_rows_of_the_sources_table():
    """docs/sources.md §A.3, lumped, struck node stopped: N = 10 / 50 / 200."""
    for N, row in ((10, (1.0246, 0.917, 0.928, 0.950)), (50, (1.0091, 0.975, 0.978, 0.990)),
                   (200, (1.0037, 0.991, 0.992, 0.998))):
        s = semi_discrete_bar(N, redistributed=False)
        got = (s["T_ratio"], s["F_mean_ratio"], s["v_after_ratio"], s["E_after_ratio"])
        assert got == pytest.approx(row, abs=6e-4), N


def _run(N: int, h: float, **over):
    ov = {"rod.elements": N, "rod.contact_mass": "redistributed", "output.dt": 5e-7, **over}
    rec, res, integ, timer, sc = fc.run("rod-wall", "ACM", ov, h=h, alpha=0.0)
    assert res.status == "completed", res.message
    return res, fc.rod_wall_scores(res, sc)


def test_redistributed_rod_is_the_semi_discrete_bar_and_keeps_its_energy():
    """N = 50, trapezoidal Newmark (HHT α = 0) at h = 1e-7 s (h·ω_max = 0.05): contact time,
    mean force and rebound speed those of the semi-discrete bar (1.01156, 0.98059, 0.98385)
    to 1e-4; after separation the rod holds its initial energy (no impact, no jump: the
    lumped treatment keeps 0.990). The mean force stays 1.9 % below Z v0: the lumped mesh's
    dispersion, which only refinement removes (0.992 at N = 200, the closed form)."""
    res, s = _run(50, 1e-7)
    exact = semi_discrete_bar(50, redistributed=True)
    for key in ("T_ratio", "F_mean_ratio", "v_after_ratio"):
        assert s[key] == pytest.approx(exact[key], abs=1e-4), key
    assert exact["E_after_ratio"] == pytest.approx(1.0, abs=1e-12)
    assert abs(s["E_after_ratio"] - 1.0) < 1e-3
    assert not any(i.closed for i in res.impacts)             # the driver sees a spring, not an impact
    assert res.history["x_end"].min() == 0.0 and res.history["x_end"].iloc[-1] > 0.0


def test_redistribution_keeps_the_rods_mass_and_moves_it_off_the_struck_end():
    L, A, rho, N = 1.0, 1e-4, 7850.0, 50
    sys_ = build_system(load_scene("rod-wall", {"rod.contact_mass": "redistributed"}))
    mx = sys_.data.mass[0::2]
    assert mx.sum() == pytest.approx(rho * A * L, rel=1e-12)
    assert mx[sys_.slaves] == pytest.approx([0.75 * rho * A * L / N] * 2, rel=1e-12)   # ρAl/4 own + ρAl/2 moved
    assert sys_.contact_law.stiffness == pytest.approx(0.5 * 2.1e11 * A * N / L, rel=1e-12)


@pytest.mark.parametrize("over, key", [({"rod.nu": 0.3}, "rod.nu"), ({"rod.elements_across": 2}, "rod.elements_across"),
                                       ({"contact.law": "complementarity"}, "contact.law"),
                                       ({"contact.law": "penalty", "contact.penalty_damping": 1.0},
                                        "contact.penalty_damping")])
def test_redistribution_refuses_what_it_cannot_condense_exactly(over, key):
    with pytest.raises(SceneError, match=key):
        build_system(load_scene("rod-wall", {"rod.contact_mass": "redistributed", **over}))


@pytest.mark.slow
@pytest.mark.parametrize("N, h", [(50, 5e-8), (10, 1e-7), (200, 2.5e-8)])
def test_redistributed_rod_at_other_steps_and_meshes(N, h):
    """The same agreement at a second step and on two more meshes (N = 10: 1.04261,
    0.94268, 0.96570; N = 200: 1.00410, 0.99225, 0.99262)."""
    res, s = _run(N, h)
    exact = semi_discrete_bar(N, redistributed=True)
    for key in ("T_ratio", "F_mean_ratio", "v_after_ratio"):
        assert s[key] == pytest.approx(exact[key], abs=2e-4), key
    assert abs(s["E_after_ratio"] - 1.0) < 1e-3


@pytest.mark.slow
def test_penalty_spring_in_series_with_the_massless_end():
    """contact.law = penalty with k_p = k_e: the end is two equal springs in series, k_e/2.
    At h = 2.5e-8 s (at 1e-7 s the second of the two end nodes' separations is booked one
    step after the first, 2.6e-4 of T late)."""
    k_e = 0.5 * 2.1e11 * 1e-4 * 50 / 1.0
    res, s = _run(50, 2.5e-8, **{"contact.law": "penalty", "contact.penalty_stiffness": k_e})
    exact = semi_discrete_bar(50, redistributed=True, wall_spring=0.5)
    for key in ("T_ratio", "F_mean_ratio", "v_after_ratio"):
        assert s[key] == pytest.approx(exact[key], abs=2e-4), key


def test_saint_venants_numbers_and_the_condensed_end_spring():
    """Steel, 1 m × 1 cm², 1 m/s (cases/rod-wall.toml): c = √(E/ρ), Z = ρ c A, T = 2L/c,
    F = Z v0; the redistributed end's spring per node E A N / (2 L), and in series with a
    penalty spring of the same stiffness half of it."""
    sc = load_scene("rod-wall", {"rod.elements": 20})
    c = (2.1e11 / 7850.0) ** 0.5
    ex = rodwall.exact(sc)
    assert ex["c"] == pytest.approx(c, rel=1e-15) and ex["T"] == pytest.approx(2.0 / c, rel=1e-15)
    assert ex["Z"] == pytest.approx(7850.0 * c * 1e-4, rel=1e-15) and ex["F"] == pytest.approx(ex["Z"] * 1.0)
    assert ex["mass"] == pytest.approx(0.785, rel=1e-15)
    k_e = 2.1e11 * 1e-4 * 20 / 2.0
    assert rodwall.condensed_stiffness(sc) == pytest.approx(k_e, rel=1e-15)
    pen = sc.with_overrides({"contact.law": "penalty", "contact.penalty_stiffness": k_e})
    assert rodwall.condensed_stiffness(pen) == pytest.approx(k_e / 2.0, rel=1e-15)
