"""daebench's own integrators' protocols, one table per step family: what `daebench
compare` runs of each on the cases that declare more than one run at defaults.

A built-in declares its table as any plugin does (``protocols`` or
:meth:`daebench.integrators.base.Integrator.protocol`); the methods of one family share one
table here, so that the case's steps are written once. A case that no integrator declares
runs every integrator once at its defaults (compare) or at its default step and halvings
(the survey).
"""

from __future__ import annotations

from types import MappingProxyType

from daebench.integrators.base import Runs

# beam-impact (docs/sources.md §G.2): the paper's h = 1e-4 s outside contact, 1e-6 s in contact,
# and two halvings of h
PAPER_STEPS = (1e-4, 5e-5, 2.5e-5)
_BEAMS = ("beam-impact", "beam-impact-hub")
# the nonsmooth cases with friction: both families at the same three steps; the Siconos
# slider-crank example's h = 1e-5 s and two doublings
ROCKING_STEPS = (2e-3, 1e-3, 5e-4)
CRANK_STEPS = (4e-5, 2e-5, 1e-5)

#: event-driven fixed-step methods (hht, newmark, genalpha, baumgarte)
EVENT_DRIVEN = MappingProxyType({
    **{c: Runs(PAPER_STEPS, options={"h_contact": 1e-6}) for c in _BEAMS},
    "rocking-block": Runs(ROCKING_STEPS),
    "slider-crank-clearance": Runs(CRANK_STEPS),
})

#: event-capturing time stepping (moreau, nsgenalpha): no contact step of their own
CAPTURING = MappingProxyType({
    **{c: Runs(PAPER_STEPS) for c in _BEAMS},
    "rocking-block": Runs(ROCKING_STEPS),
    "slider-crank-clearance": Runs(CRANK_STEPS),
})

#: the reference solver (ida): rtol 1e-4 on the beams, its defaults on the nonsmooth cases
REFERENCE = MappingProxyType({
    **{c: Runs(tols=(1e-4,)) for c in _BEAMS},
    "rocking-block": Runs(),
    "slider-crank-clearance": Runs(),
})
