"""Scenes: validation with messages that say what is wrong and how to fix it."""

import json

import pytest
from typer.testing import CliRunner

from daebench.cli.app import app
from daebench.core.scene import SceneError, list_scenes
from daebench.models.scenes import load_scene, scene_from_dict

runner = CliRunner()


def test_named_scenes_load_with_their_published_parameters():
    sc = load_scene("beam-impact")
    assert sc["beam.length"] == 1.0 and sc["beam.area"] == 3.14e-4 and sc["beam.inertia"] == 7.85e-9
    assert sc["beam.density"] == 2.7667e3 and sc["beam.modulus"] == 6.8952e10
    assert sc["start.theta_deg"] == 45.0 and sc["contact.plane_height"] == 0.0
    assert sc["discretization.kind"] == "modes" and sc["discretization.n"] == 5
    hb = load_scene("hub-beam")
    assert (hb["hub.radius"], hb["hub.inertia"], hb["torque.period"]) == (0.05, 0.3, 2.0)
    names = [n for n, _ in list_scenes()]
    assert {"beam-impact", "hub-beam", "pendulum", "andrews", "chain-impact"} <= set(names)


@pytest.mark.parametrize("override, fragment", [
    ("contact.restitutoin=0.3", "did you mean 'contact.restitution'"),
    ("discretisation.n=3", "did you mean 'discretization.n'"),
    ("contact.restitution=1.5", "out of range [0, 1]"),
    ("contact.restitution=abc", "must be a number"),
    ("discretization.n=2.5", "must be an integer"),
    ("discretization.kind=model", "did you mean 'modes'"),
    ("contact.law=hertzian", "must be one of constraint, hertz, penalty"),
    ("effects.gravity=maybe", "must be true or false"),
    ("t_end=-1", "out of range"),
    ("t_end", "must look like key=value"),
])
def test_bad_overrides_name_the_key_and_the_fix(override, fragment):
    with pytest.raises(SceneError) as exc:
        load_scene("beam-impact", [override])
    assert fragment in str(exc.value)


def test_overrides_are_applied_and_change_the_hash():
    a = load_scene("beam-impact")
    b = load_scene("beam-impact", ["contact.restitution=0.3", "discretization.n=9"])
    assert b["contact.restitution"] == 0.3 and b["discretization.n"] == 9
    assert a.hash != b.hash
    assert load_scene("beam-impact", ["description=x"]).hash == a.hash  # physics only


def test_bad_scene_files():
    with pytest.raises(SceneError, match="unknown scene 'beam-impakt'; did you mean 'beam-impact'"):
        load_scene("beam-impakt")
    with pytest.raises(SceneError, match="unknown model 'hub-bem'; did you mean 'hub-beam'"):
        scene_from_dict({"model": "hub-bem"})
    with pytest.raises(SceneError, match="must name its model"):
        scene_from_dict({"t_end": 1.0})
    with pytest.raises(SceneError, match=r"unknown scene key 'beam.lenght'.*did you mean 'beam.length'"):
        scene_from_dict({"model": "hub-beam", "beam": {"lenght": 2.0}})


def test_toml_syntax_error_is_reported(tmp_path):
    p = tmp_path / "broken.toml"
    p.write_text('model = "hub-beam"\nt_end = \n')
    with pytest.raises(SceneError, match="not valid TOML"):
        load_scene(p)


def test_cli_reports_bad_input_with_exit_code_2():
    r = runner.invoke(app, ["run", "beam-impact", "--set", "contact.restitutoin=0.3"])
    assert r.exit_code == 2 and "did you mean 'contact.restitution'" in r.output
    r = runner.invoke(app, ["run", "beam-impact", "--integrator", "hhtt"])
    assert r.exit_code == 2 and "did you mean 'hht'" in r.output
    r = runner.invoke(app, ["run", "beam-impact", "--integrator", "hht", "--opt", "h=-1e-4"])
    assert r.exit_code == 2 and "'h' = -0.0001 is out of range" in r.output
    r = runner.invoke(app, ["run", "beam-impact", "--integrator", "hht", "--opt", "alpah=-0.1"])
    assert r.exit_code == 2 and "did you mean 'alpha'" in r.output
    r = runner.invoke(app, ["run", "pendulum", "--integrator", "lcp"])
    assert r.exit_code == 2 and "resolves contacts itself" in r.output


def test_cli_show_and_json_record(tmp_path):
    r = runner.invoke(app, ["show", "beam-impact", "--keys"])
    assert r.exit_code == 0 and "contact.restitution" in r.output and "n = 6 coordinates" in r.output
    r = runner.invoke(app, ["run", "pendulum", "--integrator", "hht", "--opt", "h=1e-3",
                            "--out", str(tmp_path), "--json"])
    assert r.exit_code == 0, r.output
    rec = json.loads(r.stdout)
    for key in ("scene", "integrator", "settings", "status", "message", "wall_s", "counters",
                "energy_residual", "observables", "history", "impacts", "constraint_max"):
        assert key in rec
    assert rec["status"] == "completed" and rec["settings"]["h"] == 1e-3
    assert (tmp_path / rec["history"].split("/")[-1]).exists()
