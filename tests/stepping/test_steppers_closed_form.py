"""Every stepper on its own, against its published recurrence.

On the undamped oscillator ẍ = −ω² x (no constraint, no contact) each scheme is a linear
map of (x, v, a) per step, written here from the papers — not from daebench's code —
as A y_{n+1} = B y_n:

- Newmark (β, γ) and its family in Chung & Hulbert's form (1993, eqs. 5–8):
  (1−α_m) a_{n+1} + α_m a_n + ω² [(1−α_f) x_{n+1} + α_f x_n] = 0, with
  x_{n+1} = x_n + h v_n + h² [(½−β) a_n + β a_{n+1}], v_{n+1} = v_n + h [(1−γ) a_n + γ a_{n+1}].
  HHT-α (Hilber, Hughes & Taylor 1977): α_m = 0, α_f = −α, β = (1−α)²/4, γ = ½ − α.
  Generalized-α from ρ∞ (Chung & Hulbert 1993, eq. 25): α_m = (2ρ∞−1)/(ρ∞+1),
  α_f = ρ∞/(ρ∞+1), γ = ½ − α_m + α_f, β = ¼ (1 − α_m + α_f)². Arnold & Brüls' variant
  (acceleration-like a beside q̈ = −ω² x) and the nonsmooth generalized-α's smooth part
  give the same (x, v) on a linear problem. Central differences (velocity Verlet) is
  Newmark (0, ½).
- Moreau–Jean's θ-method (Jean 1999): v_{n+1} − v_n = h [(1−θ) a_n + θ a_{n+1}],
  x_{n+1} = x_n + h [(1−θ) v_n + θ v_{n+1}], a = −ω² x; at θ = ½ the trapezoidal rule,
  which is also the complementarity integrator's smooth part (Newmark's average
  acceleration with Carpenter, Taylor & Katona's Lagrange contact, 1991).

- An explicit Runge–Kutta method (the time-averaged-gap LCP's Dormand–Prince 5(4) at a
  fixed step) is its stability polynomial R(hJ) on y = (x, v).

Each stepper's (x, v) must follow its map to round-off (measured ≤ 1e-12 of the amplitude) over 400 steps at h ω = 0.3,
while the exact solution and the neighbouring coefficient sets differ by far more (the test
can tell the schemes apart).
"""

from __future__ import annotations

import numpy as np
import pytest

from daebench.core.problem import Problem
from daebench.core.system import MechanicalSystem, State
from daebench.integrators.registry import get_integrator

OMEGA = 10.0
H = 0.03            # h ω = 0.3
STEPS = 400
X0, V0 = 0.1, 0.0


class Oscillator(MechanicalSystem):
    """ẍ = −ω² x with a unit mass, declared lumped (central differences needs it)."""

    n = 1
    lumped_mass = np.ones(1)

    def mass(self, q):
        return np.eye(1)

    def applied_force(self, t, q, v):
        return -OMEGA**2 * q

    def energy(self, q, v):
        return {"kinetic": 0.5 * float(v @ v), "elastic": 0.5 * OMEGA**2 * float(q @ q)}


class WalledOscillator(Oscillator):
    """The same with a wall at x = −10 X0 that it never reaches: the event-capturing
    schemes need a contact to exist, and one that never closes leaves the smooth part alone."""

    n_contacts = 1

    def gap(self, q):
        return np.array([q[0] + 10.0 * X0])

    def gap_jacobian(self, q):
        return np.ones((1, 1))

    def gap_gamma(self, q, v):
        return np.zeros(1)


def steps_of(integ) -> list[State]:
    """The states after each of STEPS steps, the integrator driven as the driver drives it."""
    prob = Problem(WalledOscillator() if integ.capabilities.contacts else Oscillator())
    q0, v0 = np.array([X0]), np.array([V0])
    state = State(0.0, q0, v0, *prob.acceleration(0.0, q0, v0))
    integ.start(prob, state, H)
    states = [state]
    for _ in range(STEPS):
        states.append(integ.step(STEPS * H))
    return states


def family(alpha_m: float, alpha_f: float, beta: float, gamma: float, h: float = H):
    w2 = OMEGA**2
    A = np.array([[1.0, 0.0, -beta * h * h],
                  [0.0, 1.0, -gamma * h],
                  [(1.0 - alpha_f) * w2, 0.0, 1.0 - alpha_m]])
    B = np.array([[1.0, h, (0.5 - beta) * h * h],
                  [0.0, 1.0, (1.0 - gamma) * h],
                  [-alpha_f * w2, 0.0, -alpha_m]])
    return A, B


def hht(alpha: float, h: float = H):
    return family(0.0, -alpha, 0.25 * (1.0 - alpha) ** 2, 0.5 - alpha, h)


def chung_hulbert(rho: float, h: float = H):
    am, af = (2.0 * rho - 1.0) / (rho + 1.0), rho / (rho + 1.0)
    return family(am, af, 0.25 * (1.0 - am + af) ** 2, 0.5 - am + af, h)


def theta_method(theta: float, h: float = H):
    A = np.array([[1.0, -theta * h, 0.0],
                  [0.0, 1.0, -theta * h],
                  [OMEGA**2, 0.0, 1.0]])
    B = np.array([[1.0, (1.0 - theta) * h, 0.0],
                  [0.0, 1.0, (1.0 - theta) * h],
                  [0.0, 0.0, 0.0]])
    return A, B


def runge_kutta(coefficients: tuple[float, ...], h: float = H):
    """An explicit Runge–Kutta step on y' = J y, y = (x, v), is R(hJ) y with R the method's
    stability polynomial Σ c_k z^k; a follows from x."""
    J = np.array([[0.0, 1.0], [-OMEGA**2, 0.0]])
    R = sum(c * np.linalg.matrix_power(h * J, k) for k, c in enumerate(coefficients))
    B = np.zeros((3, 3))
    B[:2, :2] = R
    B[2, :2] = -OMEGA**2 * R[0]
    return np.eye(3), B


#: Dormand & Prince 5(4)'s 5th-order solution: e^z's Taylor polynomial to z⁵ plus z⁶/600
#: (Hairer, Nørsett & Wanner, Solving ODEs I, §II.5 / Fig. IV.2.1)
DOPRI5 = (1.0, 1.0, 1 / 2, 1 / 6, 1 / 24, 1 / 120, 1 / 600)
#: the classical 4th-order Runge–Kutta's: e^z's Taylor polynomial to z⁴
RK4 = (1.0, 1.0, 1 / 2, 1 / 6, 1 / 24)


def recurrence(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """(x, v) after each of STEPS steps of A y_{n+1} = B y_n from rest at X0."""
    y = np.array([X0, V0, -OMEGA**2 * X0])
    out = [y[:2]]
    step = np.linalg.solve(A, B)
    for _ in range(STEPS):
        y = step @ y
        out.append(y[:2])
    return np.array(out)


CASES = [
    ("newmark", {}, family(0.0, 0.0, 0.25, 0.5), family(0.0, 0.0, 0.3, 0.5)),
    ("newmark", {"beta": 0.3025, "gamma": 0.6}, family(0.0, 0.0, 0.3025, 0.6), family(0.0, 0.0, 0.25, 0.5)),
    ("hht", {"alpha": -0.15}, hht(-0.15), hht(-0.1)),
    ("hht", {"alpha": -0.3, "ggl": False}, hht(-0.3), hht(-0.25)),
    ("genalpha", {"rho_inf": 0.74}, chung_hulbert(0.74), chung_hulbert(0.8)),
    ("genalpha", {"rho_inf": 0.2}, chung_hulbert(0.2), chung_hulbert(0.3)),
    ("nsgenalpha", {"rho_inf": 0.9}, chung_hulbert(0.9), chung_hulbert(0.8)),
    ("central", {}, family(0.0, 0.0, 0.0, 0.5), family(0.0, 0.0, 0.25, 0.5)),
    ("moreau", {"theta": 0.5}, theta_method(0.5), theta_method(0.55)),
    ("moreau", {"theta": 0.7}, theta_method(0.7), theta_method(0.65)),
    # the complementarity integrator's smooth part is the trapezoidal rule, whatever its gap weight
    ("lcp", {"gap_weight": 0.5}, theta_method(0.5), theta_method(0.55)),
    ("lcp", {"gap_weight": 1.0}, theta_method(0.5), theta_method(0.45)),
    # the time-averaged-gap LCP's smooth part at a fixed step: Dormand–Prince's 5th-order solution
    ("lcp-avg", {"adaptive": False}, runge_kutta(DOPRI5), runge_kutta(RK4)),
]


@pytest.mark.parametrize("name, settings, scheme, neighbour", CASES,
                         ids=[f"{c[0]}-{'-'.join(f'{k}={v}' for k, v in c[1].items())}" for c in CASES])
def test_a_stepper_follows_its_published_recurrence(name, settings, scheme, neighbour):
    integ = get_integrator(name)(h=H, **settings)
    states = steps_of(integ)
    got = np.array([[s.q[0], s.v[0]] for s in states])
    times = np.array([s.t for s in states])
    assert len(got) == STEPS + 1 and np.allclose(times, H * np.arange(STEPS + 1), rtol=0, atol=1e-12)
    want = recurrence(*scheme)
    scale = np.array([X0, OMEGA * X0])
    dev = np.max(np.abs(got - want) / scale)
    exact = np.column_stack([X0 * np.cos(OMEGA * times), -OMEGA * X0 * np.sin(OMEGA * times)])
    assert dev < 1e-11, dev
    # what the comparison can resolve, 1e5 × the deviation allowed: the discretization error
    # (8.3e-5 for Dormand–Prince's 5th order, the smallest) and a neighbouring scheme
    assert np.max(np.abs(want - exact) / scale) > 1e-6
    assert np.max(np.abs(recurrence(*neighbour) - want) / scale) > 1e-6


def test_the_recurrences_are_the_papers_stability_facts():
    """The maps written above, checked on their own defining properties: the trapezoidal
    rule (Newmark ¼, ½, θ = ½) is unitary; Chung–Hulbert's spectral radius tends to ρ∞;
    HHT's spectral radius at h ω → ∞ is (1 + α)/(1 − α) (Hilber et al. 1977)."""
    def radius(A, B):
        return max(abs(np.linalg.eigvals(np.linalg.solve(A, B))))
    assert radius(*family(0.0, 0.0, 0.25, 0.5)) == pytest.approx(1.0, abs=1e-12)
    assert radius(*theta_method(0.5)) == pytest.approx(1.0, abs=1e-12)
    h_inf = 1e5 / OMEGA
    assert radius(*chung_hulbert(0.74, h_inf)) == pytest.approx(0.74, rel=1e-3)
    assert radius(*hht(-0.2, h_inf)) == pytest.approx(0.8 / 1.2, rel=1e-3)
    assert radius(*theta_method(0.7)) < 1.0 - 1e-3      # θ > ½ damps
