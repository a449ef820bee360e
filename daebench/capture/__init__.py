"""Event-capturing (time-stepping) steppers: contact impulses resolved inside every step,
no event location — the counterpart of the event-driven driver (:mod:`daebench.simulate`).

* :mod:`.lcp` — a compiled linear complementarity solver (Murty's least-index principal
  pivoting, exact for P-matrices) for the contact impulses of several contacts;
* :mod:`.episodes` — the contact-episode book both steppers keep in compiled code and
  hand to the driver as :class:`daebench.contact.Impact` records;
* :mod:`.moreau` — Moreau–Jean (θ-method, Newton impact law, optional position
  projection as Siconos' CombinedProjection);
* :mod:`.nsgenalpha` — the nonsmooth generalized-α of Capobianco, Harsch, Eugster &
  Leine (2021), frictionless normal contact with restitution.

Both are steppers on the kernel interface (:mod:`daebench.stepping.methods`); their
integrators are :mod:`daebench.integrators.moreau` and
:mod:`daebench.integrators.nsgenalpha`.
"""
