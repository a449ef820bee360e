"""The event-driven driver: runs an integrator phase by phase over a scene's horizon,
locates gap and contact-force events, applies the impact law, changes the active set and
restarts the integrator (:mod:`.simulate`); the contacts' state is one value,
:class:`.contact_state.ContactState`, that :mod:`.events` (where an event falls) and
:mod:`.transitions` (what it does to the state) take and update.

May import: :mod:`daebench.core`, :mod:`daebench.stepping`, :mod:`daebench.models`,
:mod:`daebench.integrators`.
"""
