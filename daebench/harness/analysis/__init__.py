"""What the numbers of a table mean: the cost to reach a target error (:mod:`.costs`),
performance profiles across cases (:mod:`.profiles`), a recommendation a user can act on
(:mod:`.recommend`), and the figures (:mod:`.plots`).

May import: :mod:`daebench.harness.running`, :mod:`daebench.harness.scoring` and the
layers below the harness.
"""
