"""driver.history: blocks of rows join the table exactly as rows one by one would."""

import numpy as np
import pandas as pd

from daebench.driver.history import Block, block, divergence, frame


def _rows_of(b: Block) -> list[dict]:
    n = len(b["t"])
    return [{k: (v[i].item() if isinstance(v, np.ndarray) else v) for k, v in b.items()} for i in range(n)]


def test_frame_of_rows_and_blocks_equals_the_frame_of_rows():
    b1 = Block(t=np.array([0.1, 0.2]), x=np.array([1.5, -2.0]), n_active=np.array([0, 0]), W=3.0)
    b2 = Block(t=np.array([0.5, 0.6, 0.7]), x=np.array([4.0, 5.0, 6.0]), y=np.array([1e-300, -0.0, 7.0]), W=3.5)
    single = [{"t": 0.0, "x": 1.0, "n_active": 0, "W": 0.0}, {"t": 0.3, "x": 2.0, "z": 9.0, "W": 3.0}]
    mixed = [single[0], b1, single[1], b2]
    expected = pd.DataFrame([single[0], *_rows_of(b1), single[1], *_rows_of(b2)])
    got = frame(mixed)
    pd.testing.assert_frame_equal(got, expected, check_exact=True)
    assert list(got.columns) == ["t", "x", "n_active", "W", "z", "y"]   # first seen first
    assert frame([]).empty and frame([b1]).shape == (2, 4)


def test_block_head_and_divergence_rule():
    b = block(np.array([0.0, 1.0, 2.0]), {"theta": np.array([1.0, 2.0, 3.0])},
              {"kinetic": np.array([1.0, 2.0, 50.0]), "potential": np.array([0.5, 0.5, 0.5])},
              {"damping": -0.25}, E0=1.5, d_impacts=0.125, observables=None, n_active=None)
    np.testing.assert_array_equal(b["E"], [1.5, 2.5, 50.5])
    # E − E0 − ΣW + D, in the row's order of operations
    np.testing.assert_array_equal(b["energy_residual"], [(1.5 - 1.5 + 0.25) + 0.125, (2.5 - 1.5 + 0.25) + 0.125,
                                                        (50.5 - 1.5 + 0.25) + 0.125])
    # bookkeeping scale 0.75 + |−0.25| + 0.125 = 1.125: a residual over 11.25 diverged
    bad, why = divergence(b["E"], b["energy_residual"], {"damping": -0.25}, 1.5, 0.75, 0.125)
    assert bad.tolist() == [False, False, True] and why.startswith("energy residual 49.4 J")
    assert divergence(1.5, float("nan"), {}, 1.5, 1.0, 0.0)[0] and not divergence(1.5, 9.9, {}, 1.5, 1.0, 0.0)[0]
    h = b.head(2)
    assert len(h["t"]) == 2 and h["W_damping"] == -0.25 and "n_active" not in h


def test_energy_made_from_nowhere_diverges_whatever_the_dissipative_work_booked():
    """An unstable contact step books its own energy as contact work: the residual closes
    (E − E0 − W_contact = 0) while E grows from 1 J to 500 J with no input. The rule reads
    the gain beyond the input works (here none), not the residual; an input (a torque's
    work) that supplied the gain excuses it."""
    E = np.array([1.0, 5.0, 500.0])
    W = {"contact": 499.0}
    bad, why = divergence(E, E - 1.0 - 499.0, W, 1.0, 1.0, 0.0)
    assert bad.tolist() == [False, False, True] and "energy from nowhere" in why
    bad, _ = divergence(E, E - 1.0 - 499.0, {"torque": 499.0}, 1.0, 1.0, 0.0)
    assert not bad.any()


def test_divergence_with_work_per_row_is_the_rule_row_by_row():
    """Rows whose work grows along a step (one value per row): the mask is the single-row
    rule's at each row, and the message gives the failing row's own scale (0.5 + |W| there)."""
    E = np.array([1.0, 1.0, 60.0])
    W = {"torque": np.array([0.0, 1.0, 2.0]), "damping": np.array([0.0, -0.5, -1.0])}
    resid = E - 1.0 - W["torque"] - W["damping"]
    bad, why = divergence(E, resid, W, 1.0, 0.5, 0.0)
    rows = [divergence(E[i], resid[i], {k: float(w[i]) for k, w in W.items()}, 1.0, 0.5, 0.0)[0]
            for i in range(3)]
    assert bad.tolist() == [bool(r) for r in rows] == [False, False, True]
    assert why == ("energy residual 58 J exceeds 10 × the energy scale 3.5 J")
