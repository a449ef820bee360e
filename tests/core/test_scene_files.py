"""Deep, broken or conflicting scene files are refused by name, and one broken scene file or
plugin blocks only itself."""

from __future__ import annotations

import pytest

from _cli import cli


@pytest.fixture()
def odd_cases(tmp_path, monkeypatch):
    import shutil

    from daebench.core.scene import cases_dir

    d = tmp_path / "cases"
    d.mkdir()
    shutil.copy(cases_dir() / "pendulum.toml", d)
    (d / "deep.toml").write_text('model = "pendulum"\nx = ' + "[" * 3000 + "]" * 3000 + "\n")
    (d / "broken.toml").write_text('model = "pendulum\n')
    (d / "tables.toml").write_text('model = "pendulum"\n[' + ".".join(["a"] * 2500) + "]\nb = 1\n")
    (d / "inline.toml").write_text('model = "pendulum"\nx = ' + "{a = " * 900 + "1" + "}" * 900 + "\n")
    (d / "twice.toml").write_text('model = "ball"\n"contact.restitution" = 0.3\n[contact]\nrestitution = 0.9\n')
    monkeypatch.setenv("DAEBENCH_CASES", str(d))
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "results"))
    return d


@pytest.mark.parametrize("case, why", [("deep", "nested too deeply"), ("broken", "not valid TOML"),
                                       ("tables", "nested more than 16 deep"), ("inline", "nested too deeply"),
                                       ("twice", "'contact.restitution' is given twice")])
def test_a_deep_broken_or_conflicting_scene_file_is_refused_by_name(odd_cases, case, why):
    r = cli(["run", case, "-i", "hht"])
    assert r.exit_code == 2 and why in r.output, r.output
    r = cli(["run", str(odd_cases / f"{case}.toml"), "-i", "hht"])
    assert r.exit_code == 2 and why in r.output, r.output


def test_one_broken_scene_file_does_not_block_the_others(odd_cases):
    """An invalid TOML in DAEBENCH_CASES made `run pendulum` and `list` refuse."""
    r = cli(["list"])
    assert r.exit_code == 0 and "pendulum" in r.output and "cannot be read" in r.output, r.output
    r = cli(["run", "pendulum", "-i", "hht", "--set", "t_end=0.01"])
    assert r.exit_code == 0, r.output


def test_one_broken_plugin_does_not_block_a_survey_of_others(monkeypatch):
    """A plugin that fails to import made `survey` refuse even with -i naming others."""
    from daebench.integrators import registry as integrator_registry
    from daebench.models.scenes import load_scene
    from daebench.workflows import survey

    reg = {**integrator_registry.registry(), "broken": integrator_registry.Registered("broken", None, "bad-plugin", "ImportError: no module x")}
    monkeypatch.setattr(integrator_registry, "registry", lambda refresh=False: dict(reg))
    proto = survey.survey_protocol(load_scene("pendulum"), quick=True)
    assert any(e.integrator == "broken" for e in proto.entries)
    assert any(e.integrator == "hht" and e.steps for e in proto.entries)
