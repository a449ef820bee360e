"""The rod-wall run both the ACM test and the diagonal-mass test make: 10 lumped elements,
the struck end stopped by the constraint law, and what docs/sources.md §A.3 gives for it
(modal superposition of the semi-discrete rod, exact in time)."""

from __future__ import annotations

import pytest

from daebench.studies.interactive_mode_contact import measures as fc

#: docs/sources.md §A.3, N = 10 lumped: post-impact v/v0 and energy after / before
SEMI_DISCRETE_N10 = {"v_after_ratio": 0.928, "E_after_ratio": 0.950}


def acm_ten_elements():
    """(result, scores) of rod-wall, 10 elements, HHT α = 0, h = 1e-6 s, 1e-7 s near contact."""
    rec, res, integ, timer, sc = fc.run("rod-wall", "ACM", {"rod.elements": 10, "output.dt": 5e-7},
                                        h=1e-6, h_contact=1e-7, alpha=0.0)
    assert res.status == "completed", res.message
    return res, fc.rod_wall_scores(res, sc)


def assert_semidiscrete_rod(res, scores) -> None:
    """§A.3's values to 1.5e-3, both end nodes closed at one instant."""
    for key, value in SEMI_DISCRETE_N10.items():
        assert scores[key] == pytest.approx(value, abs=1.5e-3), key
    assert len(res.impacts) == 2 and all(i.closed for i in res.impacts)
