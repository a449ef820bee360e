"""A case's [compare] table (daebench.core.comparison): read from the scene file, kept out
of the scene hash, refused with a clear message when wrong, and the one source of the
protocol, measures, targets and survey tags."""

from __future__ import annotations

import tomllib

import pytest

from daebench.core import comparison
from daebench.core.comparison import ComparisonError
from daebench.core.scene import cases_dir, tagged
from daebench.models.scenes import load_scene, scene_from_dict
from daebench.workflows import protocol as P


def _raw(name: str) -> dict:
    return tomllib.loads((cases_dir() / f"{name}.toml").read_text(encoding="utf-8"))


def test_the_compare_table_is_not_in_the_scene_hash():
    raw = _raw("beam-impact")
    without = {k: v for k, v in raw.items() if k != "compare"}
    other = dict(raw, compare={"steps": [1e-3], "tags": ["quick"]})
    a, b, c = (scene_from_dict(r, "beam-impact") for r in (raw, without, other))
    assert a.hash == b.hash == c.hash
    assert a.comparison.declared and not b.comparison.declared and c.comparison.steps == (1e-3,)
    assert a.with_overrides({"t_end": 0.3}).comparison == a.comparison      # overrides keep it
    assert a.with_overrides({"t_end": 0.3}).hash != a.hash                  # physics still keys the hash


@pytest.mark.parametrize("table, words", [
    ({"step": [1e-4]}, "did you mean 'steps'"),
    ({"steps": [1e-4, 2e-4]}, "strictly decreasing"),
    ({"steps": [1e-4, float("nan")]}, "positive finite"),
    ({"tolerances": "1e-4"}, "a list of tolerances"),
    ({"tags": ["quik"]}, "did you mean 'quick'"),
    ({"measures": ["err_x_max"], "targets": {"err_y_max": [1.0]}}, "not one of the table's measures"),
    ({"measures": ["err_x_max"], "targets": {"err_x_max": [-1.0]}}, "> 0"),
    ({"contact_step": True}, "a step size"),
    ([1, 2], "must be a table"),
])
def test_a_bad_table_is_refused_naming_the_key(table, words):
    with pytest.raises(ComparisonError, match=words.replace("(", r"\(")):
        comparison.parse(table, "x.toml")


def test_targets_sorted_and_tags_default():
    c = comparison.parse({"measures": ["err_x_max"], "targets": {"err_x_max": [1e-3, 1e-1, 1e-2]}})
    assert c.targets == {"err_x_max": (1e-1, 1e-2, 1e-3)} and c.tags == ("survey",)
    assert comparison.parse(None) == comparison.Comparison() and not comparison.Comparison().declared


def test_the_survey_sets_are_the_cases_tags():
    quick = tagged("quick")
    assert quick == sorted(quick) and set(quick) == {n for n in quick if "quick" in load_scene(n).comparison.tags}
    assert set(quick) <= set(tagged("survey"))
    with pytest.raises(Exception, match="unknown case tag"):
        tagged("fast")


def test_a_plugins_own_declaration_comes_before_the_cases(monkeypatch):
    from daebench.integrators.base import Runs
    from daebench.integrators.registry import get_integrator

    sc = load_scene("beam-impact")
    assert P.declared_entries(sc)["hht"].steps == sc.comparison.steps
    monkeypatch.setattr(get_integrator("hht"), "protocols", {"beam-impact": Runs((3e-5,))})
    assert P.declared_entries(sc)["hht"].steps == (3e-5,)


def test_an_adaptive_only_method_takes_the_tolerances_and_only_named_methods_run_the_protocol():
    from daebench.integrators.registry import get_integrator

    c = comparison.parse({"methods": ["hht", "ida"], "steps": [1e-3, 5e-4], "tolerances": [1e-4, 1e-5, 1e-6],
                          "contact_step": 1e-6})
    ida = P.case_entry("ida", get_integrator("ida"), c)
    hht = P.case_entry("hht", get_integrator("hht"), c)
    assert ida.tols == (1e-4, 1e-5, 1e-6) and not ida.steps
    assert hht.steps == (1e-3, 5e-4) and hht.options == {"h_contact": 1e-6}
    assert P.case_entry("newmark", get_integrator("newmark"), c) is None
    assert P.case_entry("moreau", get_integrator("moreau"), comparison.parse({"steps": [1e-3],
                                                                             "contact_step": 1e-6})).options == {}
