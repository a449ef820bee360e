"""Summaries that agree with themselves, the API's values checked like overrides, signals said."""

from __future__ import annotations

import pytest

from _cli import cli


def test_a_diverged_run_summary_says_where_it_stopped(tmp_path, monkeypatch):
    """A diverged Baumgarte run printed 'max |E − E0 − W_nc + D_impacts| = 0 … 0 is exact' and
    'final t 0' while the JSON said t_final 0.001."""
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    r = cli(["run", "spring-wall", "-i", "baumgarte", "--opt", "h=1e-2", "--set", "spring.stiffness=1e8",
             "--set", "t_end=0.5"])
    assert r.exit_code == 1 and "diverged" in r.output, r.output
    assert "final t" not in r.output and "0 is exact" not in r.output
    assert "last kept t [s]: 0" in r.output and "stopped at: t = 0.001 s" in r.output


@pytest.mark.parametrize("key, value, why", [("t_end", -1, "'t_end' = -1"), ("output.dt", 0, "'output.dt' = 0"),
                                             ("pendulum.length", -1.0, "'pendulum.length' = -1"),
                                             ("t_end", "1", "not a value of its type")])
def test_values_changed_in_place_are_refused_as_param_errors(key, value, why):
    """scene.values["t_end"] = -1 raised ValueError, ["output.dt"] = 0 ZeroDivisionError, and a
    negative pendulum length completed."""
    import daebench

    sc = daebench.load_scene("pendulum")
    sc.values[key] = value
    with pytest.raises(daebench.ParamError, match=why):
        daebench.run(sc, "hht")


def test_numpy_booleans_and_huge_integers():
    import numpy as np

    import daebench
    from daebench.core.params import coerce

    sc = daebench.load_scene("ball", {"effects.contact": np.bool_(False)})
    assert sc["effects.contact"] is False
    for v in ("9" * 800, 9 ** 900):
        with pytest.raises(daebench.ParamError, match="-digit number \\(beyond any range; write e.g. 1e6\\)"):
            coerce(v, float, "scene key 'x'")


def test_compile_report_refuses_an_unknown_command():
    r = cli(["compile-report", "--", "nosuchcmd"])
    assert r.exit_code == 2 and "'nosuchcmd' is not a daebench command" in r.output, r.output


def test_sigterm_during_reference_and_ctrl_c_after_compares_runs_are_said(tmp_path, monkeypatch):
    """SIGTERM during `reference` and SIGINT during compare's last phase exited silently."""
    import os
    import signal

    import daebench.api as api

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))

    def terminated(*a, **kw):
        os.kill(os.getpid(), signal.SIGTERM)
        raise AssertionError("SIGTERM was not turned into an interruption")

    monkeypatch.setattr(api, "reference", terminated)
    r = cli(["reference", "pendulum"])
    assert r.exit_code == 130 and "interrupted (Ctrl-C or SIGTERM)" in r.output and "nothing was cached" in r.output

    def ctrl_c(*a, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(api, "compare", ctrl_c)
    r = cli(["compare", "pendulum"])
    assert r.exit_code == 130 and "interrupted (Ctrl-C or SIGTERM)" in r.output, r.output


def test_every_generated_module_runs_the_generated_text_not_the_file(tmp_path):
    """The stepper entries of a plugin (daebench.stepping.method_handles) ran whatever file was
    on disk, while the kernel modules were regenerated: both now load through one function, a
    planted file is rewritten and its line does not run."""
    from daebench.core import handles

    path = tmp_path / "_daebench_method_probe_step_0123.py"
    text = "VALUE = _GIVEN * 2\n"
    marker = tmp_path / "planted"
    path.write_text(f"open({str(marker)!r}, 'w').write('ran')\nVALUE = -1\n")
    module = handles.load_generated("_daebench_method_probe_step_0123", path, text, {"_GIVEN": 21})
    assert module.VALUE == 42 and not marker.exists() and path.read_text() == text
    path.write_text(text[:5])                                 # truncated: written anew
    assert handles.load_generated("_daebench_method_probe_step_0123", path, text, {"_GIVEN": 1}).VALUE == 2
    assert path.read_text() == text
