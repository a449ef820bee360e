"""daebench.integrators.central: what central differences need of a model (a positive lumped
mass) and its stability bound h ω ≤ 2, against the characteristic polynomial of the
recurrence x_{n+1} − (2 − Ω²) x_n + x_{n−1} = 0 (Ω = h ω): |λ| = 1 for Ω ≤ 2, and beyond it
the real root (Ω² − 2 + Ω √(Ω² − 4)) / 2 of modulus > 1."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from daebench.integrators.base import IntegratorError
from daebench.integrators.central import CentralDifference, method_for
from daebench.stepping.stability import strict_interval


def test_a_model_without_a_lumped_mass_is_refused_with_what_to_use():
    with pytest.raises(IntegratorError, match="constant lumped \\(diagonal\\) mass.*use hht or newmark"):
        method_for(SimpleNamespace())
    with pytest.raises(IntegratorError, match="positive nodal masses"):
        method_for(SimpleNamespace(lumped_mass=[1.0, 0.0]))
    assert list(method_for(SimpleNamespace(lumped_mass=[2.0, 4.0]))[0]) == [0.5, 0.25]   # 1/m


@pytest.mark.parametrize("omega", [0.5, 1.0, 1.9, 1.999, 2.001, 2.5, 4.0])
def test_the_stability_model_is_the_recurrences_polynomial(omega):
    rho = CentralDifference.stability_model(None).radius(omega)
    if omega <= 2.0:
        assert rho == pytest.approx(1.0, abs=1e-6)
    else:
        root = (omega ** 2 - 2.0 + omega * math.sqrt(omega ** 2 - 4.0)) / 2.0
        assert rho == pytest.approx(root, rel=1e-9)


def test_the_bound_is_two():
    assert strict_interval(CentralDifference.stability_model(None)) == pytest.approx(2.0, rel=1e-6)
