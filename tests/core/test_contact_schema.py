"""One contact schema (daebench.core.contact.contact_schema): every model with contacts
declares its contact.* keys and their checks through it, and the system carries the
scene's restitution (MechanicalSystem.contact_restitution)."""

from __future__ import annotations

import math

import pytest

from daebench.core.contact import CONTACT_DEFAULTS, contact_schema
from daebench.core.params import ParamError
from daebench.core.scene import SceneError
from daebench.models import build_system
from daebench.models.scenes import load_scene

# a scene of each model with contacts, and the laws it offers
SCENES = {"ball": ("constraint", "penalty", "complementarity"),
          "chain-impact": ("hertz", "penalty", "constraint", "complementarity"),
          "double-pendulum": ("constraint", "hertz", "penalty", "complementarity"),
          "beam-impact": ("constraint", "hertz", "penalty"),
          "rod-wall": ("constraint", "penalty", "complementarity")}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_models_declare_the_shared_contact_keys(name):
    sc = load_scene(name)
    shared = {p.name: p for p in contact_schema(SCENES[name], exponent=True, friction=True).params}
    declared = [k for k in sc.schema if k.startswith("contact.") and k[len("contact."):] in CONTACT_DEFAULTS]
    assert sc.schema["contact.law"].choices == SCENES[name]
    for key in declared:
        mine, ours = sc.schema[key], shared[key]
        assert (mine.type, mine.low, mine.high, mine.choices, mine.unit) == \
            (ours.type, ours.low, ours.high, ours.choices, ours.unit), key
    assert ("contact.hertz_stiffness" in declared) == ("hertz" in SCENES[name])
    assert ("contact.penalty_stiffness" in declared) == ("penalty" in SCENES[name])


@pytest.mark.parametrize("name", [n for n, laws in SCENES.items() if "penalty" in laws])
def test_penalty_without_stiffness_is_refused_by_every_model(name):
    with pytest.raises(SceneError, match=r"contact\.penalty_stiffness"):
        load_scene(name, {"contact.law": "penalty", "contact.penalty_stiffness": 0.0})


@pytest.mark.parametrize("name", [n for n, laws in SCENES.items() if "hertz" in laws])
def test_flores_without_restitution_is_refused_by_every_model(name):
    with pytest.raises(SceneError, match=r"contact\.restitution"):
        load_scene(name, {"contact.law": "hertz", "contact.hertz_stiffness": 1e9, "contact.hertz_damping": "flores",
                          "contact.restitution": 0.0})


def test_hertz_stiffness_zero_means_the_model_rule_only_where_there_is_one():
    with pytest.raises(SceneError, match=r"contact\.hertz_stiffness"):
        load_scene("chain-impact", {"contact.hertz_stiffness": 0.0})
    sc = load_scene("double-pendulum", {"contact.law": "hertz", "contact.hertz_stiffness": 0.0})
    assert "(4/3) E/(1−ν²) √r" in sc.schema["contact.hertz_stiffness"].doc


def test_no_checks_when_contact_is_off():
    """The same values refused with contact on (above) load with it off, and the system
    built from them has no contact law."""
    bad = {"contact.law": "penalty", "contact.penalty_stiffness": 0.0}
    with pytest.raises(SceneError, match=r"contact\.penalty_stiffness"):
        load_scene("chain-impact", bad)
    sc = load_scene("chain-impact", {"effects.contact": False, **bad})
    assert sc["contact.penalty_stiffness"] == 0.0 and build_system(sc).contact_law is None


@pytest.mark.parametrize("law, e", [("complementarity", 0.8), ("constraint", 0.3), ("hertz", 0.5)])
def test_the_system_carries_the_scene_restitution(law, e):
    system = build_system(load_scene("chain-impact", {"contact.law": law, "contact.restitution": e}))
    assert system.contact_restitution == e
    if law == "complementarity":
        assert system.contact_law is None and system.contacts_by_integrator
    else:
        assert system.contact_law.restitution == e and system.contact_law.name == law


def test_a_model_without_contact_keys_has_no_restitution():
    system = build_system(load_scene("pendulum"))
    assert math.isnan(system.contact_restitution)


def test_friction_key_on_request():
    params = {p.name: p for p in contact_schema(("constraint",), friction=True).params}
    mu = params["contact.friction"]
    assert mu.default == 0.0 and mu.low == 0.0 and mu.high is None
    assert mu.validate("0.4", "scene key") == 0.4
    with pytest.raises(ParamError, match=r"contact\.friction"):
        mu.validate(-0.1, "scene key")
    assert "contact.friction" not in {p.name for p in contact_schema(("constraint",)).params}


def test_unknown_law_or_key_is_refused():
    with pytest.raises(ValueError, match="unknown law or key"):
        contact_schema(("hertzz",))
    with pytest.raises(ValueError, match="unknown law or key"):
        contact_schema(("hertz",), stiffness=1.0)
