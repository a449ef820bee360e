"""A class in a notebook (here: this module) registers with one call and then runs like an
installed plugin; a name that a built-in or another provider holds is refused, naming both."""

from __future__ import annotations

import numpy as np
import pytest

import daebench
from daebench.core.system import State
from daebench.integrators import base
from daebench.integrators import registry as integrator_registry
from daebench.integrators.base import STEP_SETTINGS, Capabilities, Integrator
from daebench.stepping.control import land


class NotebookVerlet(Integrator):
    """Velocity Verlet at acceleration level, as one would write it in a notebook."""

    name = "nb-verlet"
    description = "velocity Verlet written in a notebook (test)"
    capabilities = Capabilities(order=2, constraints=True, index=1)
    settings_spec = STEP_SETTINGS

    def _start(self) -> None:
        pass

    def _step_impl(self, t_stop: float) -> State:
        s, p = self.state, self.problem
        h, t1 = land(s.t, t_stop, self.h)
        q = s.q + h * s.v + 0.5 * h * h * s.a
        a1, lam1 = p.acceleration(t1, q, s.v + h * s.a)
        return State(t1, q, s.v + 0.5 * h * (s.a + a1), a1, lam1)


@pytest.fixture
def registered():
    daebench.register(NotebookVerlet)
    yield NotebookVerlet
    integrator_registry.unregister(NotebookVerlet.name)


def test_one_call_registers_and_it_runs_and_sweeps_like_an_installed_plugin(registered):
    info = daebench.integrator_infos()["nb-verlet"]
    assert info.distribution.startswith("registered") and info.capabilities.order == 2
    r = daebench.run("pendulum", "nb-verlet", h=1e-3, overrides={"t_end": 0.2})
    assert r.status == "completed" and r.error["against"] == "exact solution" and r.error["err_theta_max"] < 1e-4
    # bench on worker processes (forked: they know the class), scored like the built-ins
    df = daebench.bench("pendulum", ["nb-verlet", "hht"], steps=[2e-3, 1e-3], overrides={"t_end": 0.2},
                        reference="none", write=False, jobs=2)
    assert list(df["status"]) == ["completed"] * 4
    e = df.set_index(["integrator", "h"])["err_theta_max"]
    assert 3.0 < e["nb-verlet", 2e-3] / e["nb-verlet", 1e-3] < 5.0        # second order, as declared


def test_a_registered_class_takes_part_in_compare(registered, tmp_path, monkeypatch):
    from daebench import api
    from daebench.workflows import compare as C

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    sc = daebench.load_scene("pendulum", {"t_end": 0.2})
    assert "nb-verlet" in {e.integrator for e in C.protocol_for(sc).entries}   # every integrator, once
    proto = C.Protocol((C.Entry("nb-verlet", (2e-3,)), C.Entry("hht", (2e-3,))), ("err_theta_max",))
    res = daebench.compare(sc, api.SweepOptions(reference="none", execution=api.Execution(jobs=1, progress=False)),
                           out=tmp_path / "cmp", protocol=proto)
    assert list(res.table["integrator"]) == ["nb-verlet", "hht"] and res.ok
    assert (res.table["against"] == "exact solution").all() and res.table["err_theta_max"].notna().all()
    assert res.heading("pendulum").endswith("nb-verlet, hht: h = 0.002 s")


def test_a_name_already_provided_is_refused_naming_both_providers(registered):
    class Shadow(NotebookVerlet):
        name = "hht"

    with pytest.raises(daebench.ParamError) as exc:
        daebench.register(Shadow)
    msg = str(exc.value)
    assert "'hht' is taken" in msg and "daebench's built-in (daebench.integrators.hht:HHT)" in msg
    assert "Shadow" in msg and "registered in this process" in msg

    class Other(NotebookVerlet):
        name = "NB-Verlet"          # a case-insensitive clash with the registered one

    with pytest.raises(daebench.ParamError, match="lower-case name"):
        daebench.register(Other)
    Other.name = "nb-verlet"
    with pytest.raises(daebench.ParamError, match=r"test_register\.NotebookVerlet registered in this process"):
        daebench.register(Other)
    assert daebench.register(NotebookVerlet) is NotebookVerlet       # the same class again: replaces it


def test_declarations_are_checked_where_the_class_is_registered():
    class Bad(Integrator):
        name = "bad"
        capabilities = {"order": 2}
        settings_spec = STEP_SETTINGS

    with pytest.raises(daebench.ParamError) as exc:
        daebench.register(Bad)
    msg = str(exc.value)
    assert "capabilities = {'order': 2}: a daebench.integrators.base.Capabilities is needed" in msg
    assert "_start() is not implemented" in msg and "_step_impl() is not implemented" in msg
    assert "bad" not in integrator_registry.registry()


def test_an_installed_plugin_that_shadows_a_builtin_is_refused_and_said(monkeypatch):
    class EP:
        def __init__(self, name, value, dist):
            self.name, self.value, self.dist = name, value, type("D", (), {"name": dist})()

        def load(self):
            return NotebookVerlet

    fake = [EP("hht", "daebench.integrators.hht:HHT", "daebench"), EP("hht", "evil.mod:HHT", "evil-pkg")]
    monkeypatch.setattr(integrator_registry, "entry_points", lambda group: fake)
    reg = integrator_registry.registry(refresh=True)
    try:
        assert reg["hht"].distribution == "daebench"
        assert integrator_registry.refusals() == [
            "integrator 'hht' of the installed distribution evil-pkg (evil.mod:HHT) is refused: daebench's built-in "
            "(daebench.integrators.hht:HHT) provides that name (a plugin may not shadow a built-in or another "
            "plugin; rename its entry point and its class's name)"]
    finally:
        monkeypatch.undo()
        integrator_registry.registry(refresh=True)


def test_an_installed_model_that_shadows_a_builtin_is_refused_and_said_as_an_integrator_is(monkeypatch):
    """The model registry skipped a plugin that claimed a built-in's name without a word, while the
    integrator registry refused it and said so: one rule (daebench.core.entry_names) for both."""
    from daebench import api, models

    class EP:
        def __init__(self, name, value, dist):
            self.name, self.value, self.dist = name, value, type("D", (), {"name": dist})()

    fake = [EP("evil", "evil.first:MODEL", "evil-one"), EP("ball", "evil.mod", "evil-pkg"),
            EP("ball", "daebench.models.ball", "daebench"), EP("evil", "evil.second:MODEL", "evil-two")]
    monkeypatch.setattr(models, "entry_points", lambda group: fake)
    try:
        found = models._scan()
        assert found == {"ball": "daebench.models.ball", "evil": "evil.first:MODEL"}
        assert api.model_refusals() == [
            "model 'ball' of the installed distribution evil-pkg (evil.mod) is refused: daebench's built-in model "
            "(daebench.models.ball) provides that name (a plugin may not shadow a built-in or another plugin; "
            "rename its entry point)",
            "model 'evil' of the installed distribution evil-two (evil.second:MODEL) is refused: the installed "
            "distribution evil-one (evil.first:MODEL) provides that name (a plugin may not shadow a built-in or "
            "another plugin; rename its entry point)"]
    finally:
        monkeypatch.undo()
        models._scan()
    assert api.model_refusals() == []


def test_a_model_registers_too(tmp_path):
    from daebench.models import ball, register_model, unregister_model

    with pytest.raises(daebench.ParamError, match="model name 'ball' is taken: daebench's built-in model"):
        register_model("ball", ball)
    daebench.register(ball, name="nb-ball")
    try:
        scene = tmp_path / "drop.toml"
        scene.write_text('name = "drop"\ndescription = "a registered model"\nmodel = "nb-ball"\nt_end = 0.5\n'
                         '[output]\ndt = 1e-3\nobservables = ["x", "v"]\n')
        r = daebench.run(str(scene), "hht", h=1e-3)
        assert r.status == "completed" and r.error["against"] == "exact solution"
        assert np.isclose(r.impacts[0]["t"], np.sqrt(2.0 / 9.81), atol=1e-9)
    finally:
        unregister_model("nb-ball")


@pytest.mark.slow
def test_a_registered_class_takes_part_in_the_survey_and_its_page(registered, tmp_path, monkeypatch):
    from daebench.workflows import report, survey

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    res = survey.run_survey(survey.SurveyOptions(cases=("pendulum",), integrators=("nb-verlet", "hht"), quick=True,
                                                 jobs=1, name="nb", reference="none", repeat_check=False,
                                                 progress=False, budget_s=1e6))
    assert set(res.table["integrator"]) == {"nb-verlet", "hht"} and (res.table["status"] == "completed").all()
    page = report.write_survey_report(res, tmp_path / "page.html").read_text()
    assert "nb-verlet" in page


def test_compare_beam_impact_runs_the_steps_a_plugin_declares(registered, monkeypatch):
    """A plugin declares its runs per case (here the class attribute ``protocols``) and compare
    plans exactly those; the built-ins keep their family's."""
    from daebench.integrators.base import Runs
    from daebench.workflows import compare as C

    monkeypatch.setattr(NotebookVerlet, "capabilities", Capabilities(order=2, constraints=True, index=3))
    monkeypatch.setattr(NotebookVerlet, "protocols", {"beam-impact": Runs((2e-4, 1e-4), options={"h_contact": 1e-6})},
                        raising=False)
    sc = daebench.load_scene("beam-impact")
    specs, refused = C.plan(sc, C.protocol_for(sc))
    mine = [(s.options["h"], s.options["h_contact"]) for s in specs if s.integrator == "nb-verlet"]
    assert mine == [(2e-4, 1e-6), (1e-4, 1e-6)]
    assert sorted(s.options["h"] for s in specs if s.integrator == "hht") == [2.5e-5, 5e-5, 1e-4]
