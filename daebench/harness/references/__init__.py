"""Trusted references: IDA far tighter than anything scored (or a fine event-capturing run,
:mod:`.capturing`), its check runs beside it (:mod:`.side_runs`), its own accuracy
(:mod:`.accuracy`), cached by scene hash and checked on every read (:mod:`.reference`),
against the model's physics (:mod:`.modelprobe`) and shipped fingerprints
(:mod:`.fingerprints`); the references shipped inside the package (:mod:`.shipped`).

May import: :mod:`daebench.harness.running`, :mod:`daebench.harness.scoring` and the
layers below the harness.
"""
