"""A run cap (guards.deadline: an asynchronous RunTimeout) that lands inside a Python
model's call from compiled code ends the run as a timeout.

numba's exception handling fails when the asynchronous exception is pending in a
``numba.objmode`` call: measured on chain-impact (a Python model) with hht and caps of
20–200 ms, before the fix 5–8 of 60 capped runs raised "SystemError: <weakref … to 'Chain'>
returned a result with an exception set" (chained down to the RunTimeout) or a garbled
"TypeError: _pm_gap expected 5 arguments, got 0" instead of RunTimeout (the survey
workers' intermittent SystemError)."""

import random
import time

import pytest

from daebench.harness.running.deadline import RunTimeout, deadline


def test_an_error_raised_after_the_cap_fired_is_a_timeout_with_it_as_cause():
    with pytest.raises(RunTimeout, match="wall-time cap of 0.05 s") as info:
        with deadline(0.05):
            t0 = time.monotonic()
            try:
                while time.monotonic() - t0 < 10.0:
                    pass
            except RunTimeout as exc:  # what numba's exception machinery makes of it
                raise SystemError("<weakref> returned a result with an exception set") from exc
    assert isinstance(info.value.__cause__, SystemError)


def test_an_error_before_the_cap_stays_itself():
    with pytest.raises(ValueError, match="the model's own"):
        with deadline(5.0):
            raise ValueError("the model's own error")


@pytest.mark.slow
def test_capped_python_model_runs_all_end_as_timeouts():
    from daebench.harness.running.runner import run_scene
    from daebench.models.scenes import load_scene

    run_scene(load_scene("chain-impact", ["t_end=0.001"]), "hht", {}, write=False)  # compiled before the caps
    scene = load_scene("chain-impact", ["t_end=50"])
    rng = random.Random(1)
    got = []
    for _ in range(60):
        try:
            run_scene(scene, "hht", {}, write=False, run_cap=rng.uniform(0.02, 0.2), force=True)
            got.append("no timeout")
        except RunTimeout:
            got.append("RunTimeout")
        except Exception as exc:  # noqa: BLE001 - what the test counts
            got.append(type(exc).__name__)
    assert got == ["RunTimeout"] * 60
