"""The Python API: what the command line does, as functions that return arrays, tables and
result values — the only door into the package for the command line.

>>> import daebench
>>> r = daebench.run("pendulum", integrator="hht", h=1e-3)
>>> r.t.shape, r.q.shape, r.status                    # doctest: +SKIP
((1001,), (1001, 2), 'completed')
>>> r.error                                           # doctest: +SKIP
{'against': 'exact solution', 'err_theta_max': 2.3e-05, ...}
>>> df = daebench.bench("pendulum", ["hht", "newmark"], steps=[1e-2, 5e-3])   # doctest: +SKIP

Every function validates its arguments as the command line does and raises
:class:`ParamError` (or a subclass) with a message that says what to change. The
functions live by concept: :mod:`.catalogue` (scenes and integrators), :mod:`.runs` (one
run, one reference), :mod:`.sweeps` (bench, compare, survey, report, effects, stability),
:mod:`.studies` (the reproduced papers, event capturing, speed), :mod:`.external` (other
codes' trajectories scored, a case exported for another code), :mod:`.figures` (plots) and
:mod:`.verify` (an integrator's conformance run); the values they take (:class:`Plan`,
:class:`SweepOptions`, …) are built once and passed on unchanged.

May import: every layer below it (workflows, studies, harness and the rest); nothing
below imports it, and :mod:`daebench.cli` imports nothing else.
"""

from daebench.api.catalogue import (IntegratorInfo, SceneInfo, cases, integrator_info, integrator_infos,
                                    integrator_refusals, load_scene, model_refusals, register, show)
from daebench.api.external import ExportResult, ScoreResult, Source, export_case, score
from daebench.api.peers import PeerFailed, PeerResult, PeerUnavailable, peer, peer_names, peer_sources
from daebench.api.figures import plot_convergence, plot_histories, plot_work_precision
from daebench.api.runs import reference, run
from daebench.api.studies import (CapturePage, StudyTable, averaged_gap_chain, averaged_gap_pendulum, capture_page,
                                  capture_rates, compile_report, hht_beam_impact, interactive_mode, numbers, perf)
from daebench.api.sweeps import (bench, compare, describe_measure, effects, error_columns, parse_targets, report,
                                 stability, survey)
from daebench.api.verify import Check, VerifyResult, verify
from daebench.core.params import Param, ParamError, parse_pairs
from daebench.harness.files import OutputWriteError
from daebench.core.interrupt import RunTimeout
from daebench.harness.running.progress import RunProgress
from daebench.harness.sweeps.dask_cluster import ClusterLost
from daebench.harness.sweeps.executors import sigterm_as_interrupt
from daebench.harness.sweeps.options import Execution, Plan, Storage, SweepOptions, Timing
from daebench.harness.sweeps.sweep import HARNESS_FAILURES, SweepInterrupted
from daebench.studies.perf.settings import PerfSettings
from daebench.workflows.run import RunOutput, Writing
from daebench.workflows.stability import Bisection
from daebench.workflows.survey import SurveyOptions

__all__ = [
    # catalogue, one run, references
    "load_scene", "cases", "integrator_infos", "integrator_info", "IntegratorInfo", "SceneInfo", "show",
    "register", "integrator_refusals", "model_refusals",
    "run", "RunOutput", "Writing", "reference",
    # other codes
    "score", "ScoreResult", "Source", "export_case", "ExportResult",
    "peer", "PeerResult", "peer_names", "peer_sources", "PeerFailed", "PeerUnavailable",
    # many runs
    "bench", "compare", "survey", "report", "effects", "stability", "error_columns", "parse_targets",
    "describe_measure",
    "Plan", "SweepOptions", "Timing", "Execution", "Storage", "SurveyOptions", "Bisection", "HARNESS_FAILURES",
    # conformance
    "verify", "VerifyResult", "Check",
    # studies and figures
    "hht_beam_impact", "averaged_gap_chain", "averaged_gap_pendulum", "interactive_mode", "StudyTable",
    "capture_page", "CapturePage", "capture_rates", "perf", "PerfSettings", "compile_report",
    "plot_work_precision", "plot_convergence", "plot_histories",
    # arguments and errors
    "Param", "parse_pairs", "numbers", "ParamError", "OutputWriteError", "RunTimeout", "SweepInterrupted",
    "ClusterLost",
    "sigterm_as_interrupt",
    "RunProgress",
]
