"""The modal band errors (daebench.harness.scoring.modal) against systems whose modes are
known in closed form, and the hub-beam's linearised modes against the continuum beam."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from daebench.core.observables import Observable, Observables, Position
from daebench.harness.scoring import metrics, modal

N, MASS, K_SPRING = 8, 2.0, 50.0


def _chain() -> tuple[np.ndarray, np.ndarray]:
    """N equal masses between two walls, joined by N + 1 equal springs."""
    K = K_SPRING * (2 * np.eye(N) - np.eye(N, k=1) - np.eye(N, k=-1))
    return MASS * np.eye(N), K


def _closed_form() -> tuple[np.ndarray, np.ndarray]:
    """ω_j = 2√(k/m) sin(jπ/2(N+1)), φ_j(i) = √(2/(m(N+1))) sin(ijπ/(N+1)) (mass-normalised)."""
    j = np.arange(1, N + 1)
    omega = 2 * math.sqrt(K_SPRING / MASS) * np.sin(j * math.pi / (2 * (N + 1)))
    i = np.arange(1, N + 1)[:, None]
    return omega, math.sqrt(2 / (MASS * (N + 1))) * np.sin(i * j[None, :] * math.pi / (N + 1))


def test_modes_of_a_spring_chain_are_the_closed_form():
    omega, phi = modal.modes(*_chain())
    w, P = _closed_form()
    assert omega == pytest.approx(w, rel=1e-12)
    assert np.allclose(phi.T @ _chain()[0] @ phi, np.eye(N), atol=1e-12)
    assert np.allclose(np.abs(phi.T @ _chain()[0] @ P), np.eye(N), atol=1e-10)   # the same modes, up to sign


class _Chain:
    """A linear chain as a model with modes: observables x1 (first mass) and x5."""

    n = N
    coordinate_names = tuple(f"x{i + 1}" for i in range(N))

    def linearisation(self):
        return _chain()

    def initial_state(self):
        return np.zeros(N), np.zeros(N)

    def observables(self, t, q, v):
        return {"x1": float(q[0]), "x5": float(q[4])}


def _motion(amps: np.ndarray, omegas: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    _, P = _closed_form()
    q = (np.cos(np.outer(t, omegas)) * amps) @ P.T
    v = (-np.sin(np.outer(t, omegas)) * amps * omegas) @ P.T
    return q, v


@pytest.mark.parametrize("planted, in_band", [(2, True), (6, False)])
def test_a_planted_phase_error_in_one_mode_shows_in_its_band_only(planted, in_band):
    """Truth: every mode of the chain at its exact frequency; the run: mode ``planted`` (0-based)
    at a frequency 0.1 % off. Resolved band: the modes below a declared frequency between
    ω₄ and ω₅."""
    w, P = _closed_form()
    t = np.linspace(0.0, 2.0, 2001)
    amps = 1e-3 * np.arange(1, N + 1)[::-1]
    wrong = w.copy()
    wrong[planted] *= 1.001
    tq, tv = _motion(amps, w, t)
    rq, rv = _motion(amps, wrong, t)
    below = 0.5 * (w[3] + w[4])
    out = modal.scores(_Chain(), rq, rv, tq, tv, {"x1": "x1", "x5": "x5"}, below)
    assert out["modes_resolved"] == 4
    for o, i in (("x1", 0), ("x5", 4)):
        exact = np.abs(P[i, planted] * amps[planted] * (np.cos(wrong[planted] * t) - np.cos(w[planted] * t))).max()
        hit, other = ("band", "rest") if in_band else ("rest", "band")
        assert out[f"err_{hit}_{o}_max"] == pytest.approx(exact, rel=1e-9)
        assert out[f"err_{other}_{o}_max"] < 1e-12 * exact + 1e-18
    assert out["err_rest_energy_max" if in_band else "err_band_energy_max"] < 1e-20
    others = [out[f"err_mode{k + 1}_energy_max"] for k in range(N) if k != planted]
    assert max(others) < 1e-12 * out[f"mode{planted + 1}_energy"]
    assert out[f"mode{planted + 1}_omega"] == pytest.approx(w[planted], rel=1e-12)


def test_the_resolved_band_from_a_converged_discretization():
    omega = np.array([-3.2, 385.0, 1247.0, 2604.0, 4475.0, 11145.0])
    fine = np.array([-3.2, 384.9, 1247.1, 2602.1, 4449.9, 6790.9, 9626.8])
    assert modal.resolved(omega, fine).tolist() == [True, True, True, True, True, False]
    assert modal.resolved(omega, below=3000.0).tolist() == [True, True, True, True, False, False]
    with pytest.raises(ValueError, match="converged frequencies"):
        modal.resolved(omega)


def test_the_chord_angle_error_is_the_planted_rotation():
    """A tip rotated by 0.1° about the hinge: the chord angle error is 0.1° whatever the
    radius; the floating frame's angle does not enter."""
    t = np.linspace(0.0, 1.0, 101)
    ang = np.radians(45.0 - 40.0 * t)
    r = 0.9 + 0.05 * np.sin(7 * t)
    ref = pd.DataFrame({"t": t, "tip_x": r * np.cos(ang), "tip_y": r * np.sin(ang)})
    run = pd.DataFrame({"t": t, "tip_x": r * np.cos(ang + math.radians(0.1)),
                        "tip_y": r * np.sin(ang + math.radians(0.1))})
    d = Observables([Observable("tip_x", "m"), Observable("tip_y", "m"),
                     Position("tip", "tip_x", "tip_y", angle="chord", angle_label="chord angle")])
    out = metrics.accuracy(run, ref, ["tip_x", "tip_y"], declared=d)
    assert out["err_chord_max"] == pytest.approx(0.1, rel=1e-9) and out["err_chord_l2"] == pytest.approx(0.1, rel=1e-9)


def test_hub_beam_modes_are_the_continuum_pinned_free_beams_but_the_top_one():
    """beam-impact (N = 5 clamped-free modes, J_h = 0) linearised at the start: ω₁..₄ of the
    continuum pinned-free beam (βL the roots of tan βL = tanh βL, ω = (βL)² √(EI/ρSL⁴)) to
    1 %; the fifth far above the continuum's, and the converged-discretization test keeps
    the first four."""
    from scipy.optimize import brentq

    from daebench.models.hubbeam import build
    from daebench.models.scenes import load_scene

    sc = load_scene("beam-impact")
    sys_ = build(sc)
    omega, phi = modal.modes(*sys_.linearisation())
    roots = [brentq(lambda x: math.tan(x) - math.tanh(x), k * math.pi + 0.1, (k + 0.5) * math.pi - 1e-6)
             for k in range(1, 6)]
    c = math.sqrt(sc["beam.modulus"] * sc["beam.inertia"] / (sc["beam.density"] * sc["beam.area"])) \
        / sc["beam.length"] ** 2
    cont = np.array([b * b * c for b in roots])
    assert omega[1:5] == pytest.approx(cont[:4], rel=0.01)
    assert omega[5] > 1.5 * cont[4]
    assert modal.resolved(omega, modal.modes(*sys_.finer().linearisation())[0]).tolist() == [True] * 5 + [False]
    assert abs(phi[0, 5]) > 10 * abs(phi[0, 1])   # θ carries the top mode strongly (θ·L ≈ −100)


def test_the_window_after_the_first_impacts_is_the_first_long_free_interval():
    """beam-impact's reference impacts: a burst of five at 0.370–0.381 s, the next at 0.788 s."""
    imps = [0.3700, 0.3731, 0.3769, 0.3805, 0.3808, 0.7879, 0.7881, 0.7914]
    assert modal.post_window(imps, 1.0) == (0.3808, 0.7879)
    assert modal.post_window([0.95], 1.0) is None          # 0.05 s left: shorter than a tenth of the span
    assert modal.post_window([], 1.0) is None


class _StiffenedChain(_Chain):
    """The chain whose springs stiffen with the first coordinate: K(q) = (1 + q₁) K₀, so its
    modes keep their shapes and their frequencies scale by √(1 + q₁)."""

    def linearisation(self, q=None):
        M, K = _chain()
        s = 1.0 if q is None else 1.0 + float(q[0])
        return M, s * K


def test_the_window_modes_are_those_of_the_configuration_it_starts_from():
    """After the impacts the chain sits at q₁ = 0.44, where its frequencies are 1.2 times the
    start's: linearised there, the scores report those frequencies, the resolved band below a
    frequency between the window's ω₄ and ω₅, and a planted 0.1 % phase error of mode 3 in
    that band alone."""
    w, P = _closed_form()
    t = np.linspace(0.0, 1.0, 1001)
    amps = 1e-3 * np.arange(1, N + 1)[::-1]
    fast = 1.2 * w
    wrong = fast.copy()
    wrong[2] *= 1.001
    tq, tv = _motion(amps, fast, t)
    rq, rv = _motion(amps, wrong, t)
    about = np.zeros(N)
    about[0] = 0.44
    below = 0.5 * (fast[3] + fast[4])
    out = modal.scores(_StiffenedChain(), rq, rv, tq, tv, {"x1": "x1"}, below, about=about)
    exact = np.abs(P[0, 2] * amps[2] * (np.cos(wrong[2] * t) - np.cos(fast[2] * t))).max()
    assert out["err_band_x1_max"] == pytest.approx(exact, rel=1e-9)
    assert out["err_rest_x1_max"] < 1e-12 * exact
    assert out["mode3_omega"] == pytest.approx(fast[2], rel=1e-12)
    assert out["modes_resolved"] == 4
