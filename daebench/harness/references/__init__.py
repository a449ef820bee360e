"""Trusted references: IDA far tighter than anything scored (or a fine event-capturing run,
:mod:`.capturing`), its check runs beside it (:mod:`.side_runs`), its own accuracy
(:mod:`.accuracy`), computed, cached by scene hash and loaded (:mod:`.reference`), its files sealed and
checked on every read (:mod:`.stored`),
against the model's physics (:mod:`.modelprobe`) and shipped fingerprints
(:mod:`.fingerprints`); the references shipped inside the package (:mod:`.shipped`,
stored thin: :mod:`.packed`).

May import: :mod:`daebench.harness.running`, :mod:`daebench.harness.scoring` and the
layers below the harness.
"""
