"""daebench.stepping.central on its own: velocity Verlet on the lumped 10-element steel rod
(rod-wall, flying free, all its modes excited by a seeded velocity field), against the
scheme written here with the model's force (v_{n+½} = v_n + h a_n/2, q_{n+1} = q_n + h v_{n+½},
a_{n+1} = M⁻¹Q, v_{n+1} = v_{n+½} + h a_{n+1}/2), its order measured from a step sweep, and
the bounded energy error of a symplectic scheme."""

from __future__ import annotations

import numpy as np
import pytest

from daebench.core.problem import Problem
from daebench.core.system import State
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.scenes import load_scene

T = 2e-5   # s: a fifth of the rod's first axial period (2 × 0.387 ms), many periods of its highest modes


@pytest.fixture(scope="module")
def rod():
    s = build_system(load_scene("rod-wall", {"rod.elements": 10, "start.gap": 1.0}))
    q0, v0 = s.initial_state()
    v0 = v0 + 1e-2 * np.random.default_rng(7).standard_normal(v0.size)
    return s, Problem(s), q0, v0


def _central(rod, h: float) -> list[State]:
    s, p, q0, v0 = rod
    a0, lam0 = p.acceleration(0.0, q0, v0)
    integ = get_integrator("central")(h=h)
    integ.start(p, State(0.0, q0, v0, a0, lam0), h)
    out = [integ.state]
    while out[-1].t < T * (1 - 1e-12):
        out.append(integ.step(T))
    return out


def test_each_step_is_velocity_verlet(rod):
    s, p, q, v = rod
    h = 1e-7
    states = _central(rod, h)
    a = p.mass_force(0.0, q, v)[1] / s.lumped_mass
    for k, st in enumerate(states[1:], start=1):
        vh = v + 0.5 * h * a
        q = q + h * vh
        a = p.mass_force(k * h, q, vh)[1] / s.lumped_mass
        v = vh + 0.5 * h * a
        assert st.t == pytest.approx(k * h, rel=1e-12)
        np.testing.assert_allclose(st.q, q, rtol=0.0, atol=1e-13 * np.abs(q).max())
        np.testing.assert_allclose(st.v, v, rtol=0.0, atol=1e-12 * np.abs(v).max())
    assert len(states) == round(T / h) + 1


def test_second_order_and_bounded_energy(rod):
    s = rod[0]
    end = {h: _central(rod, h)[-1] for h in (4e-7, 2e-7, 1e-7, 5e-8)}
    hs = sorted(end, reverse=True)
    # successive differences of an order-p scheme fall by 2^p as h halves
    d = [np.abs(end[a].q - end[b].q).max() for a, b in zip(hs, hs[1:])]
    slopes = np.log2(np.array(d[:-1]) / np.array(d[1:]))
    assert np.all(np.abs(slopes - 2.0) < 0.15), slopes   # measured 1.93, 1.99
    E = [sum(s.energy(st.q, st.v).values()) for st in _central(rod, 1e-7)]
    E0 = E[0]
    assert max(abs(e - E0) for e in E) < 1e-3 * E0   # no drift: O((ω h)²) oscillation only
