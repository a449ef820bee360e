"""daebench.harness.running.inputs: the Python API's arguments of the wrong shape become a
ParamError naming the argument and an example, before anything runs."""

from __future__ import annotations

import pytest

from daebench.core.params import ParamError
from daebench.harness.running import inputs


def test_mapping_takes_a_dict_or_none_and_refuses_the_command_lines_string():
    assert inputs.mapping(None, "settings", '{"h": 1e-3}') == {}
    given = {"h": 1e-3}
    out = inputs.mapping(given, "settings", '{"h": 1e-3}')
    assert out == given and out is not given                       # a copy: the caller's dict is not kept
    with pytest.raises(ParamError, match=r"settings must be a dict .*in Python pass a dict"):
        inputs.mapping("h=1e-3", "settings", '{"h": 1e-3}')
    with pytest.raises(ParamError, match="names must be strings.*got 1"):
        inputs.mapping({1: 2.0}, "settings", '{"h": 1e-3}')


def test_names_split_a_comma_list_and_refuse_what_names_nothing():
    assert inputs.names(" hht, newmark ,") == ["hht", "newmark"]
    assert inputs.names(("hht", "ida")) == ["hht", "ida"]
    assert inputs.names(",") == []          # names nothing: the planner refuses it ("no integrators given")
    for bad in (None, 3, {"hht": 1}, ["hht", ""], [1], b"hht"):
        with pytest.raises(ParamError, match="must name at least one integrator.*daebench list"):
            inputs.names(bad)


def test_a_grid_needs_lists_and_a_single_value_is_pointed_to_options():
    assert inputs.grid({"alpha": (0.0, -0.1)}) == {"alpha": [0.0, -0.1]}
    with pytest.raises(ParamError, match=r"grid key 'alpha' must have a list.*options=\{\"alpha\": 0.0\}"):
        inputs.grid({"alpha": 0.0})
    with pytest.raises(ParamError, match="grid key 'law' must have a list"):
        inputs.grid({"law": "hertz"})                                  # a string is not a list of values


def test_a_grid_key_that_steps_or_tols_also_set_is_refused():
    inputs.check_grid_against_modes(["alpha"], steps=[1e-2], tols=None)     # nothing shared
    inputs.check_grid_against_modes(["h"], steps=None, tols=None)           # --grid h alone is fine
    with pytest.raises(ParamError, match="grid key 'h' is also set by --steps"):
        inputs.check_grid_against_modes(["h", "alpha"], steps=[1e-2], tols=None)
    with pytest.raises(ParamError, match="grid key 'rtol' is also set by --tols"):
        inputs.check_grid_against_modes(["rtol"], steps=None, tols=[1e-6])
