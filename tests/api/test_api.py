"""The Python API: the README's example runs as written; results are arrays and tables."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import daebench

README = Path(__file__).resolve().parents[2] / "README.md"


def readme_api_block() -> str:
    text = README.read_text()
    section = text[text.index("## Python API"):]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_readme_example_runs_as_written(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    exec(compile(readme_api_block(), "README.md (Python API)", "exec"), {})
    printed = capsys.readouterr().out
    assert "max |θ − θ_exact| =" in printed and "completed" in printed


def test_run_returns_arrays_and_its_error_against_the_exact_solution():
    from daebench.models.pendulum import exact_theta

    errs = []
    for h in (2e-3, 1e-3):
        r = daebench.run("pendulum", integrator="hht", h=h, overrides={"t_end": 0.5})
        assert r.verdict == "completed" and r.ok and r.integrator == "hht" and r.settings["h"] == h
        n = len(r.observables)
        assert r.t.shape == (n,) and r.q.shape == (n, 2) and r.v.shape == (n, 2) and r.lam.shape == (n, 1)
        assert np.allclose(r.q[:, 0], r.observables["x"]) and np.allclose(r.q[:, 1], r.observables["y"])
        # λ = rod tension / l; at rest at 30° it is m g cos 30° (mass 1, g 9.81, l 1)
        assert r.lam[0, 0] == pytest.approx(9.81 * np.cos(np.radians(30.0)), rel=1e-9)
        theta = np.arctan2(r.q[:, 0], -r.q[:, 1])
        errs.append(np.max(np.abs(theta - exact_theta(r.t, np.radians(30.0)))))
        assert np.degrees(errs[-1]) == pytest.approx(r.error["err_theta_max"], rel=1e-6)
    assert 3.0 < errs[0] / errs[1] < 5.0  # second order


def test_bench_returns_one_scored_row_per_run(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    df = daebench.bench("pendulum", "hht,newmark", steps=[1e-2, 5e-3], overrides={"t_end": 0.2},
                        reference="compute", name="api")
    assert len(df) == 4 and (df["status"] == "completed").all() and df["err_theta_max"].notna().all()
    assert df.attrs["path"] == tmp_path / "bench" / "api.parquet"
    pd.testing.assert_frame_equal(pd.read_parquet(df.attrs["path"]), df.reset_index(drop=True))
    ref = daebench.reference("pendulum", overrides={"t_end": 0.2})
    assert ref.meta["rows"] == len(ref.history) and ref.rtol <= 1e-11


def test_catalogues_and_scene_loading():
    infos = daebench.integrator_infos()
    assert {"hht", "ida", "newmark", "baumgarte", "lcp"} <= set(infos)
    hht = daebench.integrator_info("HHT")
    assert hht.name == "hht" and hht.capabilities.adaptive and "alpha" in set(hht.settings_table()["setting"])
    cases = daebench.cases()
    assert "beam-impact" in set(cases["case"]) and set(cases.columns) == {"case", "model", "description"}
    sc = daebench.load_scene("beam-impact", {"discretization.n": 3})
    assert sc["discretization.n"] == 3
    assert {"run", "bench", "reference", "load_scene", "cases", "integrators"} <= set(dir(daebench))
    from daebench.harness.sweeps import sweep  # the module stays importable beside daebench.bench(...)
    assert callable(daebench.bench) and hasattr(sweep, "run_sweep")


def test_api_errors_are_param_errors():
    from daebench.core.params import ParamError

    with pytest.raises(ParamError, match="did you mean 'hht'"):
        daebench.run("pendulum", integrator="hhtt")
    with pytest.raises(ParamError, match="finite"):
        daebench.run("pendulum", integrator="hht", rtol=float("nan"))
    with pytest.raises(ParamError, match="jobs must be"):
        daebench.bench("pendulum", ["hht"], steps=[1e-2], jobs=0, write=False)
    with pytest.raises(ParamError, match="list of numbers"):
        daebench.bench("pendulum", ["hht"], steps="1e-2", write=False)


def test_bench_takes_its_options_as_values_or_as_keywords():
    """One options value per concern (what to run, how to time, where to store, how to
    execute); the keywords are the same sweep, mapped in one place."""
    from daebench.core.params import ParamError
    from daebench.harness.sweeps.options import Execution, Plan, Storage, SweepOptions, Timing

    kw = dict(overrides={"t_end": 0.1}, write=False, executor="inline", repeats=1)
    by_keywords = daebench.bench("pendulum", "hht,newmark", steps=[1e-2], reference="none", **kw)
    by_values = daebench.bench("pendulum", plan=Plan(["hht", "newmark"], steps=[1e-2]),
                               options=SweepOptions(reference="none", timing=Timing.for_repeats(1),
                                                    storage=Storage(write=False),
                                                    execution=Execution(executor="inline", progress=False)),
                               overrides={"t_end": 0.1})
    cols = ["label", "h", "status", "steps", "err_theta_max", "err_pos_max", "energy_resid_max"]
    pd.testing.assert_frame_equal(by_keywords[cols], by_values[cols])
    # the pendulum has an exact solution: scored against it even with reference='none'
    assert (by_values["against"] == "exact solution").all() and by_values["err_theta_max"].gt(0).all()
    with pytest.raises(ParamError, match="did you mean 'steps'"):
        daebench.bench("pendulum", ["hht"], stpes=[1e-2], write=False)
    with pytest.raises(ParamError, match="set by the storage= option"):
        daebench.bench("pendulum", ["hht"], steps=[1e-2], storage=Storage(write=False), name="x")
    with pytest.raises(ParamError, match="unknown reference mode"):
        SweepOptions(reference="sometimes")
