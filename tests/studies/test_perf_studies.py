"""The `daebench perf` studies that time whole runs, at sizes a test can afford: what each
row reports checked against what is known without the study — the step count of a fixed-step
run (t_end / h), a scene's friction coefficient, a command's exit code, the order of time
stamps — and, for the new-model study, the claim it exists to measure: with the integrator
loops cached, a new model compiles its own kernels and no loop."""

from __future__ import annotations

import math

import pytest

from daebench.models.scenes import load_scene
from daebench.studies.perf import cold_start, friction_cost, new_model


def test_friction_cost_rows_count_the_steps_and_pair_each_mu_with_mu_zero():
    h = 1e-3
    df = friction_cost.friction_step_rates(h=h, repeats=1, cases=("block-incline",), integrators=("moreau",),
                                           compliant=(), driven=())
    sc = load_scene("block-incline")
    assert sorted(df.mu) == [0.0, float(sc["contact.friction"])] == [0.0, 0.3]
    assert set(df.status) == {"completed"}
    assert list(df.steps) == [round(sc.t_end / h)] * 2             # fixed step: t_end / h steps
    fr, free = df[df.mu > 0].iloc[0], df[df.mu == 0].iloc[0]
    assert fr.friction_over_frictionless == pytest.approx(fr.us_per_step / free.us_per_step)
    assert math.isnan(free.friction_over_frictionless)
    assert fr.us_per_step == pytest.approx(1e6 * fr.wall_s / fr.steps)
    assert friction_cost.markdown(df).count("\n| block-incline | moreau |") == 2


def test_cold_start_stamps_a_commands_output_and_keeps_its_exit_code():
    res = cold_start.measure({"help": ["--help"], "unknown case": ["run", "no-such-case", "-i", "hht"]},
                             timeout=300)
    ok, bad = res
    assert ok.returncode == 0 and bad.returncode != 0
    for r in res:
        assert 0.0 < r.first_output_s <= r.cold_s and r.longest_silence_s <= r.cold_s and r.warm_s > 0.0
    assert cold_start.markdown(res).count("\n| `daebench ") == 2


@pytest.mark.slow
def test_a_new_model_on_cached_loops_compiles_only_its_kernels():
    """pendulum warms the hht loop up in a new cache for the dense-mass layout; falling-rod
    (rigid2d, dense mass too) then compiles its own kernels and the contact paths pendulum
    never took — not the loops (measured: 1.0 s CPU of compiling, against 33 s for the
    warm-up; 60 s for this test)."""
    r = new_model.measure(first="pendulum", new="falling-rod", integrators=("hht",), t_end=0.01, timeout=1800)
    assert r.runs == {"hht": "completed"}
    names = {f["name"] for f in r.compiled}
    assert any(n.startswith("_daebench_handle_rigid2ddata_") for n in names), names
    loops = ("daebench.stepping.runner.", "daebench.stepping.newmark.", "daebench.stepping.newmark_matrix.")
    assert not [n for n in names if n.startswith(loops)], names
    assert r.new_model_compile_cpu_s == pytest.approx(r.new_cpu_s - r.again_cpu_s)
    assert r.new_model_compile_cpu_s < 10.0      # the study's target
