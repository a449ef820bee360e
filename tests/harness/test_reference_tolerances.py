"""A reference's tolerance has one bound, the reference solver's declared range: a value
outside it is refused with that range (never raised silently), and a reference computed
at a given tolerance is reused by the next call that asks for it."""

from __future__ import annotations

import pytest

import daebench
from daebench.harness.references import reference as references
from daebench.integrators.registry import get_integrator


def _declared_low(name: str) -> float:
    return next(s for s in get_integrator("ida").settings_spec if s.name == name).low


def test_rtol_below_the_solvers_range_is_refused_with_the_range(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    low = _declared_low("rtol")
    with pytest.raises(daebench.ParamError, match=r"out of range \[1e-14"):
        daebench.reference("pendulum", overrides=["t_end=0.05"], rtol=low / 10)
    assert not list(tmp_path.rglob("*.parquet"))   # refused before anything was computed


def test_a_reference_at_the_lowest_rtol_is_reused(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    low = _declared_low("rtol")
    first = daebench.reference("pendulum", overrides=["t_end=0.05"], rtol=low)
    assert first.rtol == pytest.approx(low, rel=1e-12)    # run at the tolerance asked for
    stamp = first.path.stat().st_mtime_ns
    calls = []
    monkeypatch.setattr(references, "compute_reference", lambda *a, **k: calls.append(a) or first)
    again = daebench.reference("pendulum", overrides=["t_end=0.05"], rtol=low)
    assert calls == [] and again.path == first.path and again.path.stat().st_mtime_ns == stamp


def test_derived_tolerance_stops_at_the_solvers_lowest():
    # a scored rtol of 1e-13 would ask REF_MARGIN tighter; the reference runs at the solver's lowest
    assert references.reference_tolerances(1e-13)[0] == _declared_low("rtol")
