"""The cradle takes only masses its arithmetic survives, and the LZB law's step limit says
what to change."""

from __future__ import annotations

import numpy as np
import pytest

import daebench


@pytest.mark.parametrize("ratio, most", [(20.0, 3), (0.05, 3)])
def test_a_chain_whose_masses_leave_float64_is_refused_with_the_range_that_fits(ratio, most):
    """ratio 20 with 100 balls overflowed (masses 20^297), 0.05 underflowed to a singular mass matrix."""
    with pytest.raises(daebench.ParamError) as err:
        daebench.load_scene("newton-cradle", {"cradle.balls": 100, "cradle.ratio": ratio})
    msg = str(err.value)
    assert f"cradle.ratio = {ratio:g} with cradle.balls = 100" in msg
    assert "keep cradle.ratio in [0.9326, 1.072]" in msg and f"use at most {most} balls" in msg


def test_masses_at_the_limit_run_and_keep_momentum_and_energy():
    """Four balls, radii falling by 0.11 (the last 2.4e-9 of the striker's mass, within the
    limit), e = 1 under the sequential law (two-ball impacts, each elastic): momentum and
    kinetic energy are kept to round-off."""
    sc = daebench.load_scene("newton-cradle", {"cradle.balls": 4, "cradle.ratio": 0.11,
                                               "contact.impact_law": "sequential"})
    r = daebench.run(sc, "hht", h=1e-4)
    assert r.status == "completed", r.message
    m = 0.1 * 0.11 ** (3 * np.arange(4))
    assert m[-1] / m[0] == pytest.approx(2.36e-9, rel=1e-2)
    v0, v1 = r.v[0], r.v[-1]
    assert len(r.impacts) >= 3 and v1[-1] > 1.9                        # the light end leaves at ~2 v₀
    assert m @ v1 == pytest.approx(m @ v0, rel=1e-12)
    assert 0.5 * m @ v1 ** 2 == pytest.approx(0.5 * m @ v0 ** 2, rel=1e-10)


def test_the_lzb_step_limit_says_what_to_change():
    """e = 0 at accuracy 1e-13: the process runs into its 2 000 000 steps."""
    sc = daebench.load_scene("newton-cradle", {"contact.impact_law": "lzb", "contact.restitution": 0.0,
                                               "contact.lzb_accuracy": 1e-13})
    r = daebench.run(sc, "hht", h=1e-4)
    assert r.status == "failed"
    msg = " ".join(r.message.split())
    assert "did not end within 2000000 steps at N = " in msg and "with energetic restitution e = 0" in msg
    assert "raise contact.lzb_accuracy" in msg and "contact.impact_law = simultaneous" in msg
