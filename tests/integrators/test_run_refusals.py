"""A run refused before its first step says what is wrong and offers only what the scene accepts."""

from __future__ import annotations

import pytest

import daebench


def test_an_ode_integrator_on_a_rigid_contact_is_offered_only_the_laws_the_scene_has():
    """spring-wall's model (the ball's) offers constraint, complementarity and penalty, not
    hertz: only penalty is suggested."""
    with pytest.raises(daebench.ParamError) as err:
        daebench.run("spring-wall", "central", h=1e-3)
    msg = str(err.value)
    assert "integrates ODEs only" in msg and "scene 'spring-wall'" in msg
    assert "hertz" not in msg and "`--set contact.law=penalty`" in msg


def test_a_scene_with_a_continuous_law_gets_it_suggested():
    with pytest.raises(daebench.ParamError) as err:
        daebench.run("chain-impact", "central", h=1e-5, overrides={"contact.law": "constraint"})
    assert "`--set contact.law=hertz` or `penalty`" in str(err.value)
