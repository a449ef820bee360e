"""A body that comes to rest on its contacts stays at rest: the Zeno accumulation of a
rocking's alternating impacts, and a contact that an index-3 step's drift opens while the
body rests, are settled by the one Zeno rule (2ġ/|g̈| below the step in force)."""

from __future__ import annotations

import numpy as np
import pytest

import daebench

FLAT = {"contact.restitution": 0.0, "contact.friction": 0.0}
M, G, HEIGHT = 1.0, 9.81, 1.0      # rocking-block: 1 kg, g, a 1.0 m tall block


@pytest.mark.parametrize("integrator", ["hht", "newmark"])
def test_a_block_landing_flat_with_e_zero_comes_to_rest_and_stays(integrator):
    """Housner's block released at α/2 with μ = 0, e = 0: it rocks on its corners with ever
    smaller swings (a Zeno sequence) and must come to rest flat on both — before, hht took
    63 537 impacts over 2 s, |ω| growing to 3e-4 rad/s (24 impacts now, at rest by 1.17 s)."""
    r = daebench.run("rocking-block", integrator, h=1e-3, overrides=FLAT)
    assert r.status == "completed", r.message
    assert len(r.impacts) <= 40
    h = r.observables
    rest = h[h["t"] >= 1.5]
    assert np.abs(rest["omega"]).max() < 1e-9 and np.abs(rest["vy"]).max() < 1e-9
    assert np.abs(rest["theta"]).max() < 1e-9
    # at rest flat: the centre at half the height, the potential energy m g h/2
    assert rest["E_gravity"].to_numpy() == pytest.approx(M * G * HEIGHT / 2, rel=1e-9)
    # the balance stays bounded and stops changing at rest (before, it grew linearly)
    resid = np.abs(h["energy_residual"].to_numpy())
    assert resid.max() < 1e-6 * h["E"].iloc[0]
    assert np.ptp(rest["energy_residual"].to_numpy()) < 1e-12 * h["E"].iloc[0]
    assert h["E"].iloc[-1] <= h["E"].iloc[0]
