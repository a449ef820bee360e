"""Settings and helpers shared by the `daebench perf` measurements."""

from __future__ import annotations

from dataclasses import dataclass

PUBLISHED_TABLE1_TOTAL_S = 47500.0
THETA_TARGET_RAD = 1e-6


@dataclass
class PerfSettings:
    """Sizes of the measurements (``quick`` shrinks all of them for smoke tests)."""

    jobs: int = 2
    table: bool = True
    table_t_end: float = 1.0
    scaling_Ns: tuple[int, ...] = (3, 5, 7, 9, 12)
    scaling_t_end: float = 0.3
    pendulum_T: float = 10.0
    pendulum_h: float = 1e-3
    peer_rounds: int = 15          # interleaved rounds of ours vs Exudyn on the pendulum (median ratio)
    beam_T: float = 0.3
    beam_hs: tuple[float, ...] = (4e-4, 2e-4, 1e-4, 5e-5)
    beam_ref_h: float = 6.25e-6
    ancf_elements: int = 8
    exudyn: bool = True
    adaptive_tols: tuple[float, ...] = (1e-6, 1e-7, 1e-8, 1e-9)
    adaptive_t_end: float = 1.0
    adaptive_cap_s: float = 60.0
    bound_h: float = 1e-5          # the spectrum run behind the resolution bound (target 4)
    bound_dt: float = 2.5e-5       # its output interval: Nyquist 1.26e5 rad/s
    bound_min_window: float = 0.05 # free-flight windows shorter than this are left out
    rates_t_end: float = 1.0
    capture: bool = True           # event-capturing steppers' steps/s beside hht
    capture_repeats: int = 3
    coldstart: bool = False        # first-run times with an empty kernel cache (minutes; opt-in)
    fe_elements: tuple[int, ...] = (50, 100, 200, 400)  # rod-wall sizes of the banded-FE scaling
    fe_t_end: float = 2e-4

    @classmethod
    def quick(cls) -> "PerfSettings":
        return cls(jobs=1, table=False, scaling_Ns=(3, 5), scaling_t_end=0.01, pendulum_T=0.1, peer_rounds=2, beam_T=0.01,
                   beam_hs=(2e-4, 1e-4), beam_ref_h=2.5e-5, ancf_elements=2, adaptive_tols=(1e-6,),
                   adaptive_t_end=0.02, rates_t_end=0.005, bound_min_window=0.01,
                   capture=False, fe_elements=(10, 20), fe_t_end=2e-5)  # capture rates: tests/integrators/test_capture_beam.py (slow)
