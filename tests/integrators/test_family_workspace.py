"""A Newmark-family integrator keeps its dense scratch across phases
(daebench.integrators.family._dense_scratch_kept): at every phase start (an impact, a
contact that closes) the iteration matrix and the n × n Jacobians are taken over when their
shapes agree, so a large model's 180 MB matrices are not mapped and faulted in again; the
run is the same to the bit as with new matrices at every start."""

from __future__ import annotations

import numpy as np

from daebench.driver.simulate import simulate
from daebench.integrators import family
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.scenes import load_scene


def _run(monkeypatch, keep: bool):
    seen = []
    original = family._dense_scratch_kept

    def recording(ws, previous):
        out = original(ws, previous) if keep else ws
        seen.append({k: getattr(out, k) for k in family._DENSE_SCRATCH} | {"shape": out.LU.shape})  # kept alive
        return out

    monkeypatch.setattr(family, "_dense_scratch_kept", recording)
    sc = load_scene("beam-impact", {"t_end": 0.45})
    integ = get_integrator("hht")(h=5e-5)
    res = simulate(build_system(sc), integ, sc.t_end, sc["output.dt"])
    assert res.status == "completed", res.message
    return res, seen, integ


def test_phases_of_one_shape_share_the_dense_scratch_and_the_run_is_unchanged(monkeypatch):
    kept, starts, integ = _run(monkeypatch, keep=True)
    assert len(kept.impacts) >= 3 and len(starts) >= 4          # several phase starts through the impacts
    n_by_n = ("M", "Kq", "Kv", "KM", "KC")      # n × n whatever the contact set: one set for the run
    assert all(s[k] is starts[0][k] for s in starts for k in n_by_n)
    pairs = [(a, b) for a, b in zip(starts, starts[1:]) if a["shape"] == b["shape"]]
    assert pairs and all(a["LU"] is b["LU"] for a, b in pairs)   # the iteration matrix while its shape holds
    fresh, _, _ = _run(monkeypatch, keep=False)
    a, b = kept.history, fresh.history
    assert list(a.columns) == list(b.columns)
    assert np.array_equal(a.to_numpy(), b.to_numpy(), equal_nan=True)
    assert [i.t for i in kept.impacts] == [i.t for i in fresh.impacts]


def test_only_scratch_of_the_same_shape_is_kept_and_the_history_is_new():
    """Taken over: the dense scratch whose shape agrees. New: the predictor's history
    (a_{n-1}, h_M, the step's state) and every matrix of another shape."""
    from daebench.stepping import newmark as nm

    old = nm.workspace(6, 1, True)
    same = family._dense_scratch_kept(nm.workspace(6, 1, True), old)
    assert all(getattr(same, k) is getattr(old, k) for k in family._DENSE_SCRATCH)
    assert same.hM is not old.hM and same.a_old is not old.a_old and same.st is not old.st
    other = family._dense_scratch_kept(nm.workspace(6, 2, True), old)   # another contact set: LU is 10 × 10
    assert other.LU is not old.LU and other.LU.shape == (10, 10)
    assert all(getattr(other, k) is getattr(old, k) for k in ("M", "Kq", "Kv", "KM", "KC"))   # still 6 × 6
    assert family._dense_scratch_kept(same, None) is same
