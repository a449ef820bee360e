"""daebench.integrators.declarations: the rules an integrator's declaration must keep
before it is registered, each broken rule a sentence ([] when none)."""

from __future__ import annotations

import math

import pytest

from daebench.core.params import Param
from daebench.integrators import declarations as d
from daebench.integrators.base import Capabilities


@pytest.mark.parametrize("name, ok", [("hht", True), ("my-method_2.1", True), ("a" * 40, True),
                                      ("a" * 41, False), ("HHT", False), ("-x", False), ("", False),
                                      ("external", False), (3, False), ("has space", False)])
def test_names(name, ok):
    assert (d.name_problems(name) == []) is ok


def test_reserved_and_long_names_say_why():
    assert "reserved" in d.name_problems("external")[0]
    assert "41 characters long: at most 40" in d.name_problems("a" * 41)[0]


def test_capabilities():
    assert d.capability_problems(Capabilities(order=2, constraints=True, index=3)) == []
    assert d.capability_problems(Capabilities(order=4)) == []                       # ODE-only, index None
    assert "order = 0" in d.capability_problems(Capabilities(order=0))[0]
    assert "order = True" in d.capability_problems(Capabilities(order=True))[0]      # a bool is not an order
    assert "order = 13" in d.capability_problems(Capabilities(order=d.MAX_ORDER + 1))[0]
    assert "fixed_step or adaptive" in d.capability_problems(Capabilities(order=2, fixed_step=False))[0]
    assert "index = 2.0" in d.capability_problems(Capabilities(order=2, constraints=True, index=2.0))[0]
    assert "index = True" in d.capability_problems(Capabilities(order=2, constraints=True, index=True))[0]
    assert "ODE-only" in d.capability_problems(Capabilities(order=2, index=3))[0]
    assert "capabilities.contacts = 1" in d.capability_problems(Capabilities(order=2, contacts=1))[0]


def test_settings():
    good = [Param("h", float, 1e-3, "step", low=1e-12, high=1.0), Param("mode", str, "a", "", choices=("a", "b"))]
    assert d.settings_problems(good) == []
    twice = good + [Param("h", float, 1e-2, "again")]
    assert d.settings_problems(twice) == ["setting 'h' is declared twice"]
    assert "Python identifier" in d.settings_problems([Param("not-an-id", float, 1.0, "")])[0]
    assert "low = 2 > high = 1" in d.settings_problems([Param("x", float, 1.5, "", low=2.0, high=1.0)])[0]
    assert "high = inf is not a finite number" in d.settings_problems([Param("x", float, 1.0, "", high=math.inf)])[0]
    assert "its default is refused" in d.settings_problems([Param("x", float, 5.0, "", low=0.0, high=1.0)])[0]
    assert "type 'complex'" in d.settings_problems([Param("x", complex, 1j, "")])[0]
