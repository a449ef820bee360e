"""The data of one phase (daebench.core.phase.data.PhaseData) as the compiled phase
functions read it: one numba type per model layout, whatever the phase — so closing or
opening contacts, engaging a continuous law or changing the hysteresis factor never
compiles a new specialization (numba's own typing is the judge)."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from daebench.core import phase
from daebench.core.phase.data import PhaseData
from daebench.core.problem import Problem
from daebench.models import build_system
from daebench.models.scenes import load_scene


@pytest.mark.parametrize("case, overrides", [("rocking-block", {}),
                                             ("ball", {"contact.law": "penalty"})])
def test_every_phase_of_a_model_has_one_numba_type(case, overrides):
    system = build_system(load_scene(case, overrides))
    nc, n = system.n_contacts, system.n
    phases = [Problem(system), Problem(system, active=(0,)), Problem(system, active=tuple(range(nc))),
              Problem(system, engaged=np.zeros(nc), chi=np.full(nc, 0.5))]
    for p in phases:
        k = p.kernel
        assert isinstance(k, PhaseData)
        assert k.active.dtype == np.int64 and list(k.active) == list(p.active)
        assert k.nb == system.n_bilateral
        assert k.engaged.shape == k.chi.shape == (nc,) and k.engaged.dtype == k.chi.dtype == np.float64
        assert k.gq.shape == (n,) and k.work.shape == (5 * n,)
        # a continuous law (penalty) travels as its parameters; the constraint law is the driver's
        assert (k.law is None) == ("contact.law" not in overrides)
        if k.law is not None:
            assert k.law.shape == (5,) and k.law.dtype == np.float64
    types = {numba.typeof(p.kernel) for p in phases}
    assert len(types) == 1, types
    q, v = system.initial_state()
    before = len(phase.mass_force.signatures)
    for p in phases:
        p.mass_force(0.0, q, v)
    assert len(phase.mass_force.signatures) <= before + 1   # at most this layout's own, once
