"""`daebench perf`: the speed figures, one module per thing measured — the paper's Table 1
grid, scaling in N, adaptive steps and the resolution bound (:mod:`.adaptive_steps`), the
floor under steps/s (:mod:`.model_floor`), peers measured in the same run (:mod:`.peers`),
cost that follows the structure (:mod:`.structure`), friction's per-step cost
(:mod:`.friction_cost`), a newcomer's cold start (:mod:`.cold_start`), what a cold run
compiles (:mod:`.compile_census`) and what a new model costs to compile
(:mod:`.new_model`). :mod:`.probes` is how they measure (timers, a fresh process with an
empty kernel cache), :mod:`.settings` their sizes, :mod:`.suite` runs them all and
:mod:`.report` writes perf.md.

May import: :mod:`daebench.workflows`, :mod:`daebench.harness`, the other studies and the
layers below.
"""
