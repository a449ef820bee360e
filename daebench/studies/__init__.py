"""Studies built on the workflows and the harness: the reproductions of the source papers,
each named after its paper — :mod:`.hht_beam_impact` (HHT-α against Baumgarte on a
flexible beam with impact, Acta Physica Sinica 2017), :mod:`.interactive_mode_contact`
(flexible bodies in contact by the interactive mode, Acta Physica Sinica 2017) and
:mod:`.averaged_gap_lcp` (the time-averaged-gap LCP on a chain and a flexible double
pendulum) —, the event-capturing comparison (:mod:`.event_capturing`), the IVP test set's
own accuracy measures (:mod:`.ivptest`) and the speed figures of `daebench perf`
(:mod:`.perf`).

May import: :mod:`daebench.workflows`, :mod:`daebench.harness` and the layers below;
never :mod:`daebench.api` or :mod:`daebench.cli` (the API reaches the studies, not the
other way round).
"""
