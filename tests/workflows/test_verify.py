"""`daebench verify` (daebench.workflows.verify, through daebench.api.verify and daebench.cli.verify):
what an integrator declares, measured on cases with exact solutions.
Every built-in passes; a plugin that claims the wrong order, does not advance or returns a
wrong shape fails the named property, with the numbers."""

from __future__ import annotations

import re

import numpy as np
import pytest
from typer.testing import CliRunner

import daebench
from daebench.cli.app import app
from daebench.integrators import registry as integrator_registry
from daebench.integrators.base import Capabilities
from tests.integrators.test_contract import Stuck, WrongShape
from tests.integrators.test_register import NotebookVerlet

FAST = ["hht", "newmark", "genalpha", "baumgarte", "ida", "moreau", "imm"]
SLOW = ["nsgenalpha", "central", "lcp", "lcp-avg"]


def test_every_builtin_is_listed_here():
    assert set(FAST + SLOW) == {n for n, r in integrator_registry.registry().items() if r.distribution == "daebench"}


@pytest.mark.parametrize("name", FAST + [pytest.param(n, marks=pytest.mark.slow) for n in SLOW])
def test_builtins_pass(name):
    res = daebench.verify(name)
    assert res.ok, "\n".join(res.lines())
    assert [c.property for c in res.checks] == ["order", "drift", "energy", "contract", "contact"]
    if name != "imm":   # planar FE models only: nothing with an exact solution to measure it on
        assert {c.property for c in res.checks if c.status == "pass"} >= {"order", "energy", "contract"}
    # the numbers behind the verdict, read here against the declaration: the slope of the
    # step sweep's errors (or, adaptive only, of the tolerance sweep's) — not the pass flag
    order = next(c for c in res.checks if c.property == "order")
    if "measured" in order.numbers:
        errs = order.numbers["errors"]
        assert all(b < a for a, b in zip(errs, errs[1:])), errs   # falling with h
        assert order.numbers["measured"] >= order.numbers["declared"] - 0.3
    elif "tolerance_slope" in order.numbers:
        assert order.numbers["tolerance_slope"] >= 0.5


def test_verify_hht_prints_its_measured_order():
    out = CliRunner().invoke(app, ["verify", "hht", "--only", "order,drift"], env={"COLUMNS": "300"})
    assert out.exit_code == 0, out.output
    line = next(ln for ln in out.stdout.splitlines() if "order" in ln and "PASS" in ln)
    assert 1.95 < float(re.search(r"measured (\d+\.\d+)", line).group(1)) < 2.05 and "declared 2" in line
    assert any(ln.startswith("PASS  drift") for ln in out.stdout.splitlines())


class Verlet(NotebookVerlet):
    name = "t-verlet"


class ClaimsFourth(Verlet):
    name = "t-claims4"
    capabilities = Capabilities(order=4, constraints=True, index=1)


class ClaimsIndex3(Verlet):
    name = "t-claims-index3"
    capabilities = Capabilities(order=2, constraints=True, index=3)


@pytest.fixture
def plugins():
    classes = (Verlet, ClaimsFourth, ClaimsIndex3, Stuck, WrongShape)   # the last two: tests/integrators/test_contract.py
    for c in classes:
        daebench.register(c)
    yield
    for c in classes:
        integrator_registry.unregister(c.name)


def test_a_correct_python_plugin_passes(plugins):
    """Störmer–Verlet is second order: the slope of its errors over the step sweep, read here."""
    res = daebench.verify("t-verlet", properties=["order", "drift", "contract"])
    assert [c.status for c in res.checks] == ["pass"] * 3, "\n".join(res.lines())
    errs = next(c for c in res.checks if c.property == "order").numbers["errors"]
    assert all(b < a for a, b in zip(errs, errs[1:])), errs
    assert 1.8 < float(np.log2(errs[-2] / errs[-1])) < 2.2, errs   # successive steps halve


def test_a_wrong_order_claim_fails_with_the_measured_order(plugins):
    res = daebench.verify("t-claims4", properties=["order"])
    (c,) = res.checks
    assert c.status == "fail" and c.line.startswith("FAIL  order") and "declared 4" in c.text
    assert 1.9 < c.numbers["measured"] < 2.1 and len(c.numbers["errors"]) == 4


def test_a_drifting_method_that_declares_index_3_fails(plugins):
    (c,) = daebench.verify("t-claims-index3", properties=["drift"]).checks
    assert c.status == "fail" and "declared index 3" in c.text and c.numbers["C"] > 1e-8


def test_a_step_that_does_not_advance_fails_the_contract(plugins):
    (c,) = daebench.verify("t-stuck", properties=["contract"]).checks
    assert c.status == "fail" and "the step returned t = 0 s, which does not advance t" in c.text


def test_a_wrong_shape_fails_the_contract_naming_the_array(plugins):
    (c,) = daebench.verify("t-wrongshape", properties=["contract"]).checks
    assert c.status == "fail" and "lam has shape (3,), expected (1,) (1 active constraints in this phase)" in c.text
    out = CliRunner().invoke(app, ["verify", "t-wrongshape", "--only", "contract"], env={"COLUMNS": "300"})
    assert out.exit_code == 1 and "FAIL  contract" in out.stdout and "1 property fails" in out.stdout


def test_unknown_property_and_integrator_are_refused():
    with pytest.raises(daebench.ParamError, match="unknown property 'ordre'.*did you mean 'order'"):
        daebench.verify("hht", properties=["ordre"])
    out = CliRunner().invoke(app, ["verify", "hhtt"])
    assert out.exit_code == 2 and "did you mean 'hht'" in out.stderr
