"""A run is a boundary a plugin's code cannot cross: whatever an integrator raises (an
exit, an interrupt of its own, any exception) ends the run as a failed run with the reason,
a capped run ends even when the plugin blocks, and registration refuses bad declarations."""

from __future__ import annotations

import json
import signal
import time
from dataclasses import replace
from typing import ClassVar

import pytest
from typer.testing import CliRunner

import daebench
from daebench.cli.app import app
from daebench.core.interrupt import RunTimeout
from daebench.core.system import State
from daebench.integrators import base
from daebench.integrators import registry as integrator_registry
from daebench.integrators.base import STEP_SETTINGS, Capabilities, Integrator, Setting
from daebench.stepping.control import land

runner = CliRunner()


class _Verlet(Integrator):
    """Velocity Verlet (acceleration level) that does something else on its third step."""

    description: ClassVar[str] = "test only"
    capabilities: ClassVar[Capabilities] = Capabilities(order=2, constraints=True, index=1)
    settings_spec = STEP_SETTINGS

    def _start(self) -> None:
        pass

    def third_step(self) -> None:
        raise NotImplementedError

    def _step_impl(self, t_stop: float) -> State:
        if self.counters.steps == 2:
            self.third_step()
        s, p = self.state, self.problem
        h, t1 = land(s.t, t_stop, self.h)
        q = s.q + h * s.v + 0.5 * h * h * s.a
        a1, lam1 = p.acceleration(t1, q, s.v + h * s.a)
        return State(t1, q, s.v + 0.5 * h * (s.a + a1), a1, lam1)


class Exits(_Verlet):
    name: ClassVar[str] = "exits"

    def third_step(self) -> None:
        raise SystemExit(0)


class Interrupts(_Verlet):
    name: ClassVar[str] = "interrupts"

    def third_step(self) -> None:
        raise KeyboardInterrupt


class Divides(_Verlet):
    name: ClassVar[str] = "divides"

    def third_step(self) -> None:
        1 / 0  # noqa: B018 - the plugin's bug


class Signals(_Verlet):
    """A real SIGINT (as Ctrl-C sends) arrives during its third step."""

    name: ClassVar[str] = "signals"

    def third_step(self) -> None:
        signal.raise_signal(signal.SIGINT)


class Sleeps(_Verlet):
    """Blocks 30 s in time.sleep on its third step, then leaves a mark file (named by its
    ``mark`` setting) — a mark proves the run was not stopped at its cap."""

    name: ClassVar[str] = "sleeps"
    settings_spec = STEP_SETTINGS + (Setting("mark", str, "", "file written after the sleep"),)

    def third_step(self) -> None:
        time.sleep(30.0)
        with open(self.settings["mark"], "w") as f:
            f.write("slept through the cap")


PLUGINS = (Exits, Interrupts, Divides, Signals, Sleeps)


@pytest.fixture(autouse=True)
def plugins():
    for cls in PLUGINS:
        daebench.register(cls)
    yield
    for cls in PLUGINS:
        integrator_registry.unregister(cls.name)


def short(**extra):
    return {"overrides": {"t_end": 0.05}, "h": 1e-3, **extra}


@pytest.mark.parametrize("name, raised", [("exits", "SystemExit(0)"), ("interrupts", "KeyboardInterrupt"),
                                          ("divides", "ZeroDivisionError")])
def test_what_a_plugin_raises_is_a_failed_run_output(name, raised):
    r = daebench.run("pendulum", name, **short())
    assert r.status == "failed" and raised in r.message and r.message.startswith("t = 0.002 s")
    assert "third_step" in r.traceback      # the plugin's own frame
    assert len(r.t) == 3                    # the output rows before the failing step are kept


@pytest.mark.parametrize("args", [[], ["--json"]])
def test_a_plugin_exit_is_a_failed_run_with_exit_code_one(args, tmp_path):
    res = runner.invoke(app, ["run", "pendulum", "-i", "exits", "--opt", "h=1e-3", "--set", "t_end=0.05",
                              "--out", str(tmp_path), *args])
    assert res.exit_code == 1, res.output
    text = json.loads(res.stdout)["message"] if args else " ".join(res.output.split())
    assert "SystemExit(0)" in text and "cannot end the program" in text


def test_a_plugin_keyboard_interrupt_is_not_ctrl_c(tmp_path):
    res = runner.invoke(app, ["run", "pendulum", "-i", "interrupts", "--opt", "h=1e-3", "--set", "t_end=0.05",
                              "--out", str(tmp_path)])
    assert res.exit_code == 1 and "no Ctrl-C or signal" in " ".join(res.output.split())


def test_a_real_sigint_during_a_step_still_interrupts():
    # a user's process has Python's own SIGINT handler; a test worker may have inherited
    # another (ignored, or a library's) from an earlier test, and then no Ctrl-C arrives at all
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            daebench.run("pendulum", "signals", **short())
    finally:
        signal.signal(signal.SIGINT, old)


def test_the_run_cap_stops_a_plugin_blocked_in_sleep(tmp_path):
    mark = tmp_path / "mark"
    with pytest.raises(RunTimeout) as err:
        daebench.run("pendulum", "sleeps", **short(mark=str(mark)), run_cap=1.0)
    assert "killed" in str(err.value)
    assert not mark.exists()


def test_a_plugin_under_a_cap_that_completes_returns_its_whole_run():
    r = daebench.run("pendulum", "divides", **short(), run_cap=60.0)   # run in a child process
    assert r.status == "failed" and "ZeroDivisionError" in r.message and "third_step" in r.traceback


def test_verify_reports_a_plugin_exit_as_a_failure_with_exit_code_one():
    res = runner.invoke(app, ["verify", "exits", "--only", "order,contract"])
    assert res.exit_code == 1, res.output
    assert res.output.count("FAIL") == 2 and "SystemExit(0)" in " ".join(res.output.split())


def test_verify_caps_each_property_of_a_blocking_plugin(tmp_path):
    r = daebench.verify("sleeps", {"mark": str(tmp_path / "mark")}, properties="contract", run_cap=1.0)
    assert [c.property for c in r.checks] == ["contract"]      # the string is one name, not letters
    assert r.checks[0].status == "fail" and "wall-time cap of 1 s" in r.checks[0].text
    assert not (tmp_path / "mark").exists()


def test_verify_takes_a_comma_separated_string_of_properties():
    with pytest.raises(daebench.ParamError) as err:
        daebench.verify("divides", properties="order,nope")
    assert "unknown property 'nope'" in str(err.value)


# -- registration ----------------------------------------------------------------------------------
def _declared(**attrs):
    return type("Declared", (_Verlet,), {"name": "declared", **attrs})


@pytest.mark.parametrize("attrs, said", [
    ({"name": "external"}, "'external' is reserved"),
    ({"name": "x" * 5000}, "5000 characters long"),
    ({"name": "Bad Name"}, "a lower-case name is needed"),
    ({"capabilities": Capabilities(order=2, constraints=True, index=7)}, "capabilities.index = 7"),
    ({"capabilities": Capabilities(order=2, constraints=False, index=3)}, "an ODE-only method declares index None"),
    ({"capabilities": Capabilities(order=0)}, "capabilities.order = 0"),
    ({"capabilities": Capabilities(order=2, fixed_step=False, adaptive=False)}, "fixed_step or adaptive"),
    ({"capabilities": Capabilities(order=2, contacts="yes")}, "capabilities.contacts = 'yes'"),
    ({"settings_spec": STEP_SETTINGS + (Setting("beta", float, 2.0, "x", low=0.0, high=1.0),)},
     "setting 'beta': its default is refused"),
    ({"settings_spec": STEP_SETTINGS + (STEP_SETTINGS[0],)}, "setting 'h' is declared twice"),
    ({"settings_spec": STEP_SETTINGS + (Setting("beta", float, 0.5, "x", low=1.0, high=0.0),)},
     "low = 1 > high = 0"),
    ({"settings_spec": STEP_SETTINGS + (Setting("beta", float, 0.5, "x", low=float("nan")),)},
     "low = nan is not a finite number"),
    ({"settings_spec": STEP_SETTINGS + (Setting("not a name", float, 0.5, "x"),)}, "a Python identifier"),
])
def test_registration_refuses_bad_declarations(attrs, said):
    with pytest.raises(daebench.ParamError) as err:
        daebench.register(_declared(**attrs))
    assert said in str(err.value)
    assert "declared" not in integrator_registry.registry() and "external" not in integrator_registry.registry()


def test_every_built_in_passes_the_registration_rules():
    for name, reg in integrator_registry.registry().items():
        if reg.distribution == "daebench":
            assert reg.cls is not None and base.declaration_problems(reg.cls) == [], name
    good = _declared(capabilities=replace(_Verlet.capabilities, order=3))
    daebench.register(good)
    integrator_registry.unregister("declared")
