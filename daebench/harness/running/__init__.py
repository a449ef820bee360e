"""Running one scene: make the integrator (:mod:`.runner`), refuse a run that cannot work
before its first step (:mod:`.checks`), cap its wall time (:mod:`.deadline`), write and read
its history (:mod:`.history_io`), show its progress (:mod:`.progress`), time it
(:mod:`.timing`), listen to numba's compile events (:mod:`.compile_events`), tie a child process's life
to its parent (:mod:`.child_process`), check the
Python API's argument shapes (:mod:`.inputs`) and stamp outputs with provenance
(:mod:`.provenance`).

May import: :mod:`daebench.harness.files` and the layers below the harness.
"""
