"""daebench: benchmark time integrators for constrained mechanical systems with impact."""
__version__ = "0.1.0"
