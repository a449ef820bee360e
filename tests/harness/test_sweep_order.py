"""The order in which a sweep's workers take runs (daebench.harness.sweeps.sweep.compile_order):
one run of each compiled loop first, so that two workers never compile one loop at once; and
which integrators share a loop, checked against the types numba specialises the loop on."""

from __future__ import annotations

import numba
import pytest

from daebench.driver.simulate import simulate
from daebench.harness.sweeps.plan import RunSpec
from daebench.harness.sweeps.sweep import compile_order
from daebench.integrators.compiled import code_owner
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.scenes import load_scene


def _spec(i: int, name: str) -> RunSpec:
    return RunSpec(index=i, integrator=name, options={}, scene_overrides={}, varied={})


def test_first_run_of_each_loop_goes_first_then_plan_order():
    plan = ["ida", "ida", "baumgarte", "baumgarte", "genalpha", "genalpha", "hht", "moreau", "moreau", "newmark"]
    order = compile_order([_spec(i, n) for i, n in enumerate(plan)])
    # hht and newmark run the Newmark-family loop that genalpha's first run compiles
    assert [s.index for s in order] == [0, 2, 4, 7, 1, 3, 5, 6, 8, 9]
    assert sorted(s.index for s in order) == list(range(len(plan)))   # nothing lost or doubled


@pytest.mark.parametrize("a, b, shared", [("hht", "genalpha", True), ("hht", "newmark", True),
                                          ("hht", "moreau", False), ("hht", "baumgarte", False),
                                          ("moreau", "nsgenalpha", False)])
def test_integrators_with_one_owner_hand_the_loop_the_same_numba_types(a, b, shared):
    """Two integrators share compiled code exactly when the stepping loop is specialised on
    the same types: their method data and workspace, as numba types them on a run of the bouncing ball."""
    sc = load_scene("ball", {"t_end": 0.01})
    types = {}
    for name in (a, b):
        integ = get_integrator(name)(h=1e-3)
        res = simulate(build_system(sc), integ, sc.t_end, sc["output.dt"])
        assert res.status == "completed", res.message
        types[name] = (numba.typeof(integ._meth), numba.typeof(integ._ws))
    assert (types[a] == types[b]) is shared
    assert (code_owner(get_integrator(a)) is code_owner(get_integrator(b))) is shared
