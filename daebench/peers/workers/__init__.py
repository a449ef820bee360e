"""The peer workers: scripts each run by its peer's own interpreter (:mod:`.common` is the
request and file format they share). They import numpy and their peer code only, never
daebench (the system Python that has Siconos need not have daebench's dependencies)."""
