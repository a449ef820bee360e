"""Event sequences, classified (daebench.harness.scoring.eventseq): synthetic sequences with known
answers, and properties (a sequence against itself is all matched; dropping k impacts gives
k missed, adding k far from the others k spurious; the in-order pairing is a maximum
matching, checked against scipy's bipartite maximum matching)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import maximum_bipartite_matching

from daebench.core.contact import Impact
from daebench.core.params import ParamError
from daebench.harness.scoring import eventseq as es

TOL = 1e-3
times = st.lists(st.floats(0.0, 10.0, allow_nan=False), min_size=0, max_size=25, unique=True)


def counts(run, ref, tol=TOL, window=1e-2):
    s = es.sequence_scores(run, ref, tol, window)
    return {k: s[k] for k in ("impacts_matched", "impacts_missed", "impacts_spurious", "impacts_merged",
                              "impacts_absorbed")}


def test_known_sequence():
    """Reference 1.0, 2.0, 2.0005, 3.0 (contact 0) and 1.5 (contact 1); the run strikes 1.0002
    (0), 2.0001 (0) once for the close pair, 2.7 (0) and 1.5004 (1): 3 matched, one reference
    impact absorbed by the run's 2.0001 (merged), 3.0 missed, 2.7 spurious."""
    ref = [(1.0, 0), (2.0, 0), (2.0005, 0), (3.0, 0), (1.5, 1)]
    run = [(1.0002, 0), (2.0001, 0), (2.7, 0), (1.5004, 1)]
    c = es.classify(run, ref, TOL)
    assert c.matched == [(0, 0), (1, 1), (3, 4)]
    assert c.absorbed[1] == [2] and c.merged == [1]
    assert c.missed == [3] and c.spurious == [2]
    assert counts(run, ref) == {"impacts_matched": 3, "impacts_missed": 1, "impacts_spurious": 1,
                                "impacts_merged": 1, "impacts_absorbed": 1}


def test_contacts_are_kept_apart():
    """An impact of contact 1 never pairs with the reference's impact of contact 0 at the same time."""
    c = es.classify([(1.0, 1)], [(1.0, 0)], TOL)
    assert c.matched == [] and c.missed == [0] and c.spurious == [0]


def test_unknown_contacts_form_one_sequence():
    """Bare times (a reference that stores times only) pair with records of any contact."""
    c = es.classify([Impact(1.0, 3, -1.0, 0.5, 0.1)], [1.0004], TOL)
    assert c.matched == [(0, 0)]


def test_episode_span_absorbs_reference_chatter():
    """A run's closed contact episode [1.0, 1.2] stands for the reference's chatter at 1.0,
    1.05, 1.1 (event-capturing runs: one episode for a Zeno sequence); after it is released
    a reference impact at 1.3 is missed. A bounce (no duration) absorbs only within tol."""
    run = [Impact(1.0, 0, -1.0, 0.0, 0.1, closed=True, t_end=1.2)]
    ref = [1.0, 1.05, 1.1, 1.3]
    assert counts(run, ref) == {"impacts_matched": 1, "impacts_missed": 1, "impacts_spurious": 0,
                                "impacts_merged": 1, "impacts_absorbed": 2}
    still_closed = [Impact(1.0, 0, -1.0, math.nan, 0.1, closed=True)]   # never released: to the end
    assert counts(still_closed, ref)["impacts_absorbed"] == 3
    bounce = [Impact(1.0, 0, -1.0, 0.5, 0.1)]
    assert counts(bounce, ref)["impacts_missed"] == 3


def test_chatter_clusters():
    """Contact 0 strikes 5 times within 4 ms (one cluster: the scan resumes after it), then
    twice; contact 1 three times within 8 ms: a cluster at a 10 ms window, none at 5 ms."""
    ev = [(1.000, 0), (1.001, 0), (1.002, 0), (1.003, 0), (1.004, 0), (2.0, 0), (2.001, 0),
          (3.0, 1), (3.004, 1), (3.008, 1)]
    assert es.chatter_clusters(ev, 0.01) == 2
    assert es.chatter_clusters(ev, 0.005) == 1
    assert es.chatter_clusters(ev, 0.002) == 1       # 1.000-1.002: three within 2 ms, then 1.003-1.004: two
    assert es.chatter_clusters([(1.0, 0), (1.001, 1), (1.002, 0)], 0.01) == 0


def test_max_penetration():
    recs = [Impact(1.0, 0, -1.0, 0.5, 0.1, min_gap=-2e-4), Impact(2.0, 0, -1.0, 0.5, 0.1, min_gap=1e-5)]
    assert es.max_penetration(recs) == pytest.approx(2e-4)
    assert es.max_penetration(recs, gap=[0.3, -5e-4, 0.1]) == pytest.approx(5e-4)
    assert math.isnan(es.max_penetration([Impact(1.0, 0, -1.0, 0.5, 0.1)]))   # no smallest gap recorded
    assert math.isnan(es.max_penetration([1.0]))
    assert es.max_penetration([], gap=[0.1, 0.2]) == 0.0


def test_bad_input_is_refused():
    with pytest.raises(ParamError, match="tolerance"):
        es.classify([1.0], [1.0], 0.0)
    with pytest.raises(ParamError, match="chatter window"):
        es.chatter_clusters([1.0], math.nan)
    with pytest.raises(ParamError, match="finite"):
        es.classify([math.inf], [1.0], TOL)


def test_default_windows():
    assert es.default_windows(1.0, 1e-4) == (1e-3, 1e-2)
    assert es.default_windows(1.0, 1e-3) == (2e-3, 1e-2)
    assert es.default_windows(2.5) == (2.5e-3, 2.5e-2)


# -- properties ---------------------------------------------------------------------------------
@settings(max_examples=60, deadline=None)
@given(times)
def test_sequence_against_itself_is_all_matched(ts):
    c = counts(ts, ts)
    assert c == {"impacts_matched": len(ts), "impacts_missed": 0, "impacts_spurious": 0,
                 "impacts_merged": 0, "impacts_absorbed": 0}


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 400), min_size=1, max_size=25, unique=True), st.data())
def test_dropping_k_gives_k_missed_adding_k_gives_k_spurious(slots, data):
    """Impacts ≥ 10 tol apart (25 ms grid): removing k from the run leaves k missed, adding k
    far from every reference impact gives k spurious."""
    ref = [0.025 * s for s in slots]
    k = data.draw(st.integers(0, len(ref)))
    drop = set(data.draw(st.permutations(range(len(ref))))[:k])
    run = [t for i, t in enumerate(ref) if i not in drop]
    assert counts(run, ref) == {"impacts_matched": len(ref) - k, "impacts_missed": k, "impacts_spurious": 0,
                                "impacts_merged": 0, "impacts_absorbed": 0}
    extra = [t + 0.0125 for t in ref[:k]]                    # halfway between grid slots
    c = counts(ref + extra, ref)
    assert c["impacts_matched"] == len(ref) and c["impacts_spurious"] == k and c["impacts_missed"] == 0


@settings(max_examples=80, deadline=None)
@given(st.lists(st.floats(0.0, 0.02, allow_nan=False), max_size=12),
       st.lists(st.floats(0.0, 0.02, allow_nan=False), max_size=12))
def test_pairing_is_a_maximum_matching(run, ref):
    """The greedy in-order pairing pairs as many impacts as a general maximum bipartite
    matching under |r − s| ≤ tol (scipy), and each pair is within tol; counts add up."""
    c = es.classify(run, ref, TOL)
    if run and ref:
        adj = np.abs(np.subtract.outer(np.asarray(run), np.asarray(ref))) <= TOL
        best = int(np.sum(maximum_bipartite_matching(csr_matrix(adj.astype(int)), perm_type="column") >= 0))
    else:
        best = 0
    assert len(c.matched) == best
    assert all(abs(run[i] - ref[j]) <= TOL for i, j in c.matched)
    absorbed = sum(len(v) for v in c.absorbed.values())
    assert len(c.matched) + absorbed + len(c.missed) == len(ref)
    assert len(c.matched) + len(c.spurious) == len(run)


def test_pipeline_measure():
    """The measure of the scoring pipeline: the horizon's windows (1 ms, 10 ms at t_end = 1 s),
    the run's records against the truth's impact times, penetration from the gap column."""
    from types import SimpleNamespace

    import pandas as pd
    run = SimpleNamespace(scene=SimpleNamespace(t_end=1.0), impacts=[Impact(0.3702, 0, -1.0, 0.0, 0.1)],
                          history=pd.DataFrame({"t": [0.0, 0.5, 1.0], "gap": [0.1, -3e-6, 0.0]}))
    s = es.measure(run, SimpleNamespace(impacts=(0.3700, 0.6)))
    assert (s["impact_tol"], s["chatter_window"]) == (1e-3, 1e-2)
    assert (s["impacts_matched"], s["impacts_missed"], s["impacts_spurious"]) == (1, 1, 0)
    assert s["max_penetration"] == pytest.approx(3e-6)
