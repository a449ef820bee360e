"""daebench.driver.books: the history rows a step writes at once — here the free flight and
the solitary wave of a Hertz chain, whose IDA steps in free flight span thousands of output
rows — against the chain's physics written here: x₁ = v₀ t until the striker arrives, the
Hertz force K δ^{3/2} and spring energy K δ^{5/2}/(5/2) of each contact from the recorded
positions, the kinetic energy ½ Σ m v², and E and Σ m v conserved (e = 1, no external force)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.driver.simulate import simulate
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.scenes import load_scene

# cases/hertz-chain.toml: ten steel balls R = 1 cm, E = 203 GPa, ν = 0.3, ρ = 7780 kg/m³, v₀ = 1 m/s
R, E, NU, RHO, V0, BALLS = 0.01, 203e9, 0.3, 7780.0, 1.0, 10
K = 4.0 / 3.0 * E / (2.0 * (1.0 - NU ** 2)) * math.sqrt(R / 2.0)   # Hertz: (4/3) E* √R*
M = RHO * 4.0 / 3.0 * math.pi * R ** 3
GAP = 2e-3                                                         # striker's start gap [m] (here)
DT = 1e-7


@pytest.fixture(scope="module")
def wave():
    sc = load_scene("hertz-chain", {"start.gap": GAP, "t_end": 2.6e-3, "output.dt": DT})
    integ = get_integrator("ida")(rtol=1e-10, atol=1e-13, adaptive=True)
    res = simulate(build_system(sc), integ, sc.t_end, DT)
    assert res.status == "completed", res.message
    return res.history, integ


def test_every_output_row_is_written_once_in_order(wave):
    h, integ = wave
    n = round(2.6e-3 / DT) + 1
    assert len(h) == n
    np.testing.assert_allclose(h["t"].to_numpy(), np.arange(n) * DT, rtol=0.0, atol=1e-15)
    # IDA's free-flight steps are long: most rows came from inside its steps
    assert integ.counters.steps < 0.15 * n


def test_free_flight_is_uniform_motion(wave):
    h, _ = wave
    before = h[h["t"] < 0.99 * GAP / V0]
    np.testing.assert_allclose(before["x1"], V0 * before["t"], rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(before["v1"], V0, rtol=0.0, atol=1e-12)
    assert (before[[f"contact_force_{i}" for i in range(BALLS - 1)]].to_numpy() == 0.0).all()


def test_contact_forces_and_energies_follow_hertz(wave):
    h, _ = wave
    x = h[[f"x{i}" for i in range(1, BALLS + 1)]].to_numpy()
    v = h[[f"v{i}" for i in range(1, BALLS + 1)]].to_numpy()
    gaps = np.diff(x, axis=1)
    gaps[:, 0] += GAP
    delta = np.maximum(-gaps, 0.0)
    F = h[[f"contact_force_{i}" for i in range(BALLS - 1)]].to_numpy()
    assert F.max() > 100.0                                   # the wave ran through the rows
    np.testing.assert_allclose(F, K * delta ** 1.5, rtol=0.0, atol=1e-9 * F.max())
    np.testing.assert_allclose(h["E_kinetic"], 0.5 * M * (v * v).sum(axis=1), rtol=1e-13, atol=0.0)
    np.testing.assert_allclose(h["E_contact"], (K * delta ** 2.5 / 2.5).sum(axis=1), rtol=0.0,
                               atol=1e-9 * h["E_contact"].max())
    E0 = 0.5 * M * V0 ** 2
    np.testing.assert_allclose(h["E"], E0, rtol=1e-6)
    np.testing.assert_allclose(M * v.sum(axis=1), M * V0, rtol=1e-9)


def test_rows_whose_names_differ_are_not_joined_as_columns():
    """A model whose observables change names between rows: no block (the rows one at a time)."""
    from types import SimpleNamespace

    from daebench.core.system import State
    from daebench.driver.books import _model_rows

    model = SimpleNamespace(observables=lambda t, q, v: {"a": q[0]} if t < 1 else {"b": q[0]},
                            energy=lambda q, v: {"kinetic": 0.5 * float(v @ v)})
    rows = [(t, State(t, np.array([t]), np.array([2.0]))) for t in (0.0, 0.5)]
    obs, terms = _model_rows(model, rows)
    np.testing.assert_array_equal(obs["a"], [0.0, 0.5])
    np.testing.assert_array_equal(terms["kinetic"], [2.0, 2.0])
    assert _model_rows(model, rows + [(1.5, State(1.5, np.array([1.5]), np.array([2.0])))]) is None
