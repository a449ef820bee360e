"""The event-capturing schemes daebench.integrators.moreau (Moreau–Jean, θ = ½) and
daebench.integrators.nsgenalpha (nonsmooth generalized-α) on the dropped ball against its closed
form (tests/_closed_forms.py: parabolas between impacts at t_k, rebound e·v): Newton's law at
velocity level in every episode, each episode's impulse the momentum balance over it (the
records of daebench.stepping.episodes through daebench.integrators.capturing), the motion
first order in h (the impacts fall on the steps), the impact times within a few steps."""

from __future__ import annotations

import numpy as np
import pytest

import daebench
from _closed_forms import E_BALL, G, ball_impacts, ball_motion  # noqa: E402

MASS = 1.0   # kg, cases/ball.toml


#: impact times within this many steps of the closed form (measured: moreau 1.7, 2.5; nsgenalpha 3.3, 2.5)
WITHIN = {"moreau": 2.6, "nsgenalpha": 3.5}


@pytest.fixture(scope="module", params=sorted(WITHIN))
def runs(request):
    return request.param, {h: daebench.run("ball", integrator=request.param, h=h) for h in (1e-3, 5e-4)}


def _x_error(r) -> float:
    h = r.observables
    x, _ = ball_motion(h["t"].to_numpy(), ball_impacts())
    return float(np.max(np.abs(h["x"].to_numpy() - x)))


def test_newton_law_in_every_episode(runs):
    for r in runs[1].values():
        assert r.status == "completed"
        for i in r.impacts:
            assert i["vn_minus"] < 0.0 and i["vn_plus"] == pytest.approx(-E_BALL * i["vn_minus"], rel=1e-12)
            # Λ = m (ġ⁺ − ġ⁻) + m g (t_end − t): the ground's impulse also holds the weight over the episode
            want = MASS * (i["vn_plus"] - i["vn_minus"]) + MASS * G * (i["t_end"] - i["t"])
            assert i["impulse"] == pytest.approx(want, rel=1e-9)


def test_impact_times_and_first_order_motion(runs):
    name, by_h = runs
    exact = np.array(ball_impacts())
    for h, r in by_h.items():
        t = np.array([i["t"] for i in r.impacts])
        assert len(t) == len(exact) and np.max(np.abs(t - exact)) < WITHIN[name] * h
    # measured: moreau 7.8e-3, 4.1e-3 m; nsgenalpha 6.1e-3, 2.7e-3 m
    e1, e2 = _x_error(by_h[1e-3]), _x_error(by_h[5e-4])
    assert e1 < 10 * 1e-3 and 1.6 < e1 / e2 < 2.6
