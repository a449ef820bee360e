"""daebench.cli.catalogue: `daebench list` names every case file and every registered
integrator (truth: the cases folder and the registry, not the command's own code), and
`daebench show` a scene's size as its model builds it and an integrator's order."""

from __future__ import annotations

from pathlib import Path

import typer
from typer.testing import CliRunner

from daebench.cli import catalogue
from daebench.integrators.registry import get_integrator, registry
from daebench.models import build_system
from daebench.models.scenes import load_scene

CASES = Path(__file__).resolve().parents[2] / "cases"


def _app() -> typer.Typer:
    app = typer.Typer()
    catalogue.register(app)
    return app


def test_list_names_every_case_file_and_integrator():
    r = CliRunner().invoke(_app(), ["list"], terminal_width=200)
    assert r.exit_code == 0, r.output
    for toml in CASES.glob("*.toml"):
        assert toml.stem in r.output, toml.stem
    for name in registry():
        assert name in r.output, name
    assert "settings of an integrator: daebench show NAME" in r.output


def test_show_a_scene_gives_the_size_its_model_builds():
    system = build_system(load_scene("pendulum"))
    r = CliRunner().invoke(_app(), ["show", "pendulum"], terminal_width=200)
    assert r.exit_code == 0, r.output
    assert f"size: n = {system.n} coordinates, {system.n_bilateral} bilateral constraints" in r.output


def test_show_an_integrator_and_refuse_an_unknown_name():
    r = CliRunner().invoke(_app(), ["show", "hht"], terminal_width=200)
    assert r.exit_code == 0 and "hht" in r.output and str(get_integrator("hht").capabilities.order) in r.output
    bad = CliRunner().invoke(_app(), ["show", "no-such-thing"], terminal_width=200)
    assert bad.exit_code != 0
