"""The integrators: one file per method, each a class with its name, settings,
declared capabilities (order, fixed/adaptive, constraints, contact laws it resolves
itself) and the compiled stepper it uses. :mod:`.base` holds the contract and the
registry (entry-point group ``daebench.integrators``, and classes registered in a
process), :mod:`.compiled` the adapter for compiled steppers, :mod:`.family` the public
Newmark family. What `compare` runs of them on a case is the case's own (its scene
file's ``[compare]`` table); a plugin may still declare its own runs per case.

May import: :mod:`daebench.core` and :mod:`daebench.stepping`; never a model — a
model's own stepper part reaches an integrator through the system it is handed.
"""
