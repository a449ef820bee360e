"""Compiled stepping, written once for every integrator and every model (numba).

* :mod:`.control` — step-size control apart from the stepper: fixed steps or an error
  controller, and the rule that lands a step exactly on ``t_stop``;
* :mod:`.watch` — which step the event-driven driver must see (the quiet-step rule);
* :mod:`.methods` — the generic stepper interface (``start``, ``step``, ``accept``)
  that a method's data class implements;
* :mod:`.runner` — one loop for every stepper: many steps per call, fixed or adaptive;
* :mod:`.newmark` and :mod:`.abm` — the built-in steppers (Newmark family: Newmark,
  HHT-α, generalized-α; Adams–Bashforth–Moulton 4 with Baumgarte stabilization).

May import: :mod:`daebench.core` only — steppers know the kernel interface, never a
model or an integrator class.
"""
