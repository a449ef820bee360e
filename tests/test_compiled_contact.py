"""Continuous contact laws in the compiled model kernels: same answers as the Python path.

With a Hertz or penalty contact engaged, ``_compiled_models.descriptor`` now returns the
model descriptor (with the law's state copied in) instead of None, so HHT/Newmark, IDA
and Baumgarte keep their compiled iterations during contact episodes. The kernels add
g_qᵀF and its central-difference Jacobian exactly as the Python model does; these tests
compare both paths (DAEBENCH_COMPILED=0 forces the Python one) through the first contact
episodes of beam-impact.

Known round-off-sign sensitivities of the driver (simulate.py, not of the kernels), which
decide the horizons below: an event state sits on g = 0 to ~1e-17 m, and (1) whether a
re-closing after a separation is located at g = 0 or at g = −GAP_BAND, (2) whether the
penalty law's damping force c·δ̇ (discontinuous at touch) enters the booked power at that
state, follow the sign of that round-off. Either path may flip it at a later episode
(measured near t = 0.3809 s: a 3e-9 s shift of a re-closing, and 1e-4 J of booked
work with penalty damping; the same happened before with Python contact on both paths).
"""

import numpy as np
import pytest

from daebench.contact import HertzLaw
from daebench.integrators import _compiled_models as cm
from daebench.models import build_system
from daebench.scene import load_scene
from _paths import assert_same_history, both  # tests/_paths.py

LAWS = {
    "hertz-lankarani-nikravesh": ["contact.law=hertz", "contact.hertz_damping=lankarani-nikravesh"],
    "hertz-hunt-crossley": ["contact.law=hertz", "contact.hertz_damping=hunt-crossley"],
    "hertz-flores": ["contact.law=hertz", "contact.hertz_damping=flores", "contact.restitution=0.3"],
    "penalty": ["contact.law=penalty", "contact.penalty_stiffness=1e8", "contact.penalty_damping=100"],
}
# the first impact is at t = 0.370011 s; this horizon holds the first two contact episodes
# (closing, separation, re-closing) of every law above
T_END = 0.3715
PROTOCOL = {"h": 1e-4, "h_contact": 1e-6}
COLUMNS = ["theta_deg", "tip_x", "tip_y", "energy_residual"]


def _spy_descriptor(monkeypatch) -> list:
    """Record (contact engaged, compiled descriptor returned) at every descriptor call."""
    calls = []
    real = cm.descriptor

    def spy(system):
        md = real(system)
        law = getattr(system, "contact_law", None)
        calls.append((law is not None and bool(np.any(law.engaged)), md is not None))
        return md

    monkeypatch.setattr(cm, "descriptor", spy)
    return calls


def _compare_runs(r0, s0, r1, s1, *, t_tol: float, tol: float, min_impacts: int = 2) -> None:
    assert r0.status == r1.status == "completed", (r0.message, r1.message)
    assert len(s0.impacts) == len(s1.impacts) >= min_impacts
    for i0, i1 in zip(s0.impacts, s1.impacts):
        assert abs(i0.t - i1.t) < t_tol, (i0.t, i1.t)
        assert np.isfinite(i0.vn_plus) == np.isfinite(i1.vn_plus)
    # contact ends: the separation of each finished episode (vn_plus is recorded there)
    assert sum(np.isfinite(i.vn_plus) for i in s0.impacts) >= 1
    for i0, i1 in zip(s0.impacts, s1.impacts):
        if np.isfinite(i0.vn_plus):
            assert abs(i0.vn_plus - i1.vn_plus) <= tol * max(1.0, abs(i0.vn_plus))
    assert_same_history(s0.history[COLUMNS], s1.history[COLUMNS], tol)


@pytest.mark.parametrize("law", list(LAWS))
def test_newmark_contact_episode_compiled_equals_python(monkeypatch, law):
    sc = load_scene("beam-impact", LAWS[law] + [f"t_end={T_END}", "output.dt=5e-5"])
    calls = _spy_descriptor(monkeypatch)
    (r0, s0), (r1, s1) = both(monkeypatch, sc, "newmark", PROTOCOL)
    # the compiled run started phases with the contact engaged, on the compiled path
    assert any(engaged and compiled for engaged, compiled in calls)
    assert r0.counters == r1.counters
    _compare_runs(r0, s0, r1, s1, t_tol=1e-10, tol=1e-9)


def test_hht_hertz_episodes_compiled_equals_python(monkeypatch):
    sc = load_scene("beam-impact", LAWS["hertz-lankarani-nikravesh"] + [f"t_end={T_END}", "output.dt=5e-5"])
    calls = _spy_descriptor(monkeypatch)
    (r0, s0), (r1, s1) = both(monkeypatch, sc, "hht", {"alpha": -0.1, **PROTOCOL})
    assert any(engaged and compiled for engaged, compiled in calls)
    assert r0.counters == r1.counters
    _compare_runs(r0, s0, r1, s1, t_tol=1e-10, tol=1e-9)


def test_ida_hertz_episode_compiled_equals_python(monkeypatch):
    # IDA's error control (rtol 1e-9) may take other steps after round-off differences, so
    # the paths agree to its tolerance, not to round-off. N = 3 and one episode keep it short
    # (N = 5 takes 56e3 steps to the first impact at this tolerance)
    sc = load_scene("beam-impact", LAWS["hertz-lankarani-nikravesh"]
                    + ["discretization.n=3", f"t_end={T_END}", "output.dt=5e-5"])
    calls = _spy_descriptor(monkeypatch)
    (r0, s0), (r1, s1) = both(monkeypatch, sc, "ida", {"rtol": 1e-9, "atol": 1e-10})
    assert any(engaged and compiled for engaged, compiled in calls)
    _compare_runs(r0, s0, r1, s1, t_tol=1e-10, tol=1e-7, min_impacts=1)


def _penetrating_states(system, rng, k: int):
    """k random (q, v) with the contact point below the plane and approaching or leaving."""
    n = system.n
    out = []
    while len(out) < k:
        q = 1e-5 * rng.standard_normal(n)
        q[0] = -1e-3 * (1.0 + rng.random())
        v = 0.1 * rng.standard_normal(n)
        v[0] = rng.uniform(-2.0, 0.5)  # mostly approaching; a fast separation clips F at 0
        if system.gap(q)[0] < 0.0:
            out.append((q, v))
    return out


@pytest.mark.parametrize("law", list(LAWS))
def test_kernels_equal_model_force_and_jacobian(law):
    system = build_system(load_scene("beam-impact", LAWS[law]))
    system.contact_law.approach_speed[:] = 1.7
    rng = np.random.default_rng(7)
    n = system.n
    M, Q, Kq, Kv = np.empty((n, n)), np.empty(n), np.empty((n, n)), np.empty((n, n))
    for engaged in (True, False):
        system.contact_law.engaged[:] = engaged
        md = cm.descriptor(system)
        assert md is not None
        pushing = 0
        for q, v in _penetrating_states(system, rng, 6):
            t = 0.1
            cm.mass_force(md, t, q, v, M, Q)
            cm.force_jacobian(md, t, q, v, Kq, Kv)
            Q0 = system.force(t, q, v)
            Kq0, Kv0 = system.force_jacobian(t, q, v)
            pushing += np.abs(Q0 - system.applied_force(t, q, v)).max() > 1.0
            assert np.allclose(M, system.mass(q), rtol=0.0, atol=1e-10 * np.abs(M).max())
            assert np.allclose(Q, Q0, rtol=0.0, atol=1e-10 * np.abs(Q0).max())
            assert np.allclose(Kq, Kq0, rtol=0.0, atol=1e-10 * np.abs(Kq0).max())
            assert np.allclose(Kv, Kv0, rtol=0.0, atol=1e-10 * np.abs(Kv0).max())
        # engaged, the contact force acts (large) at most states; released, at none
        assert pushing >= 3 if engaged else pushing == 0


def test_descriptor_refreshes_the_law_state_in_place():
    system = build_system(load_scene("beam-impact", LAWS["hertz-flores"]))
    law = system.contact_law
    law.engaged[:] = False
    md = cm.descriptor(system)
    state = md[3][cm.A1_LAW]
    assert state[cm.CL_KIND] == cm.LAW_HERTZ and state[cm.CL_HEAD] == 0.0
    law.engaged[:] = True
    law.approach_speed[:] = 2.5
    assert cm.descriptor(system) is md  # the cached descriptor, updated
    assert state[cm.CL_HEAD] == 1.0 and state[cm.CL_HEAD + 1] == law._chi()[0] > 0.0
    assert state[cm.CL_K] == law.stiffness and state[cm.CL_EXP] == law.exponent


def test_unknown_continuous_law_keeps_the_python_path():
    # a subclass may change the force: the kernels cannot know it, so while it is engaged
    # the integrators get no descriptor
    class Softer(HertzLaw):
        def force(self, g, gdot):
            return 0.5 * super().force(g, gdot)

    system = build_system(load_scene("beam-impact", LAWS["hertz-lankarani-nikravesh"]))
    old = system.contact_law
    system.contact_law = Softer(old.restitution, old.stiffness, old.damping)
    system.contact_law.engaged[:] = False
    assert cm.descriptor(system) is not None
    system.contact_law.engaged[:] = True
    assert cm.descriptor(system) is None
