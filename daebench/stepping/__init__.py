"""Compiled stepping, written once for every integrator and every model (numba).

* :mod:`.control` — step-size control apart from the stepper: fixed steps or an error
  controller, and the rule that lands a step exactly on ``t_stop``;
* :mod:`.watch` — which step the event-driven driver must see (the quiet-step rule);
* :mod:`.methods` — the generic stepper interface (``start``, ``step``, ``accept``)
  that a method's data class implements;
* :mod:`.runner` — one loop for every stepper: many steps per call, fixed or adaptive;
* :mod:`.method_handles` — a plugin's stepper as compiled values, so that the loop is
  compiled once for every plugin and an edit compiles the plugin's own code;
* the compiled steppers, every one of daebench's, one module each: :mod:`.newmark`
  (Newmark family: Newmark, HHT-α, generalized-α; its iteration matrix in
  :mod:`.newmark_matrix`), :mod:`.abm` (Adams–Bashforth–Moulton 4 with Baumgarte
  stabilization), :mod:`.central` (explicit central differences), :mod:`.lcp_avg`
  (Dormand–Prince with the time-averaged-gap contact LCP), and the event-capturing
  :mod:`.moreau` (Moreau–Jean) and :mod:`.nsgenalpha` (nonsmooth generalized-α), which
  share :mod:`.episodes` (contact episodes) and :mod:`.friction` (Coulomb friction LCP).
  The LCP solvers they use are :mod:`daebench.core.lcp`'s.

May import: :mod:`daebench.core` only — steppers know the kernel interface, never a
model or an integrator class.
"""
