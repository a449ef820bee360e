"""One run and one reference (`daebench run`, `daebench reference`)."""

from __future__ import annotations

from typing import Any, Iterable

from daebench.api.catalogue import SceneLike, load_scene
from daebench.harness.references import reference as references
from daebench.harness.references import shipped
from daebench.harness.references.reference import Reference
from daebench.harness.running.progress import run_progress_factory
from daebench.studies import ivptest
from daebench.workflows.run import RunOutput, Writing
from daebench.workflows.run import run as _run


def run(scene: SceneLike, integrator: str = "ida", *, overrides: Iterable[str] | dict[str, Any] | None = None,
        settings: dict[str, Any] | None = None, writing: Writing | None = None, progress: bool | Any = False,
        **keywords: Any) -> RunOutput:
    """Run one scene with one integrator.

    Parameters
    ----------
    scene : case name, path to a TOML file, or a Scene
    integrator : registered name, case-insensitive (default ``"ida"``)
    overrides : scene keys, ``{"t_end": 0.5}`` or ``["t_end=0.5"]``
    settings : integrator settings, e.g. ``{"h": 1e-3, "alpha": -0.1}``
    writing : whether and where the history is written, the run's wall-time cap and
        ``force`` (:class:`daebench.workflows.run.Writing`); or, as keywords, ``write``,
        ``out_dir`` (default results/runs), ``run_cap`` [s]
        (:class:`daebench.core.interrupt.RunTimeout` beyond it), ``force`` (run
        beyond the step-count and history-size limits)
    progress : True for a progress bar on stderr, or a callable ``progress(t)``
    keywords : those of ``writing``, and integrator settings (``h=1e-3, alpha=-0.1``)

    Returns
    -------
    RunOutput
        The run's record (``.record``: what ``daebench run --json`` prints) with its arrays
        and errors.
    """
    given = {k: keywords.pop(k) for k in ("write", "out_dir", "run_cap", "force") if k in keywords}
    writing = writing if writing is not None else Writing(**given)
    sc = load_scene(scene, overrides)
    return _run(sc, integrator, {**(settings or {}), **keywords} if keywords else settings, writing, progress)


def reference(scene: SceneLike, *, overrides: Iterable[str] | dict[str, Any] | None = None,
              rtol: float | None = None, atol: float | None = None, force: bool = False,
              progress: bool = False, ship: bool = False) -> Reference:
    """The cached reference of a scene (history, impact times, sidecar), computed when
    missing, damaged or ``force`` (IDA at rtol 1e-11 by default, checked against a 10×
    looser run). A case of the IVP test set gets a note of its digits against the test
    set's published solution (``notes``). ``ship`` (maintainers): copy it into the package
    (:mod:`daebench.harness.references.shipped`; ``shipped`` then names the file)."""
    sc = load_scene(scene, overrides)
    references.reference_tolerances(rtol=rtol, atol=atol)   # refused here, before a cached one is read
    kw = dict(rtol=rtol, atol=atol, progress=run_progress_factory(progress))
    ref = references.compute_reference(sc, **kw) if force else references.load_reference(sc, mode="compute", **kw)
    if sc.model in ivptest.REFERENCES and abs(sc.t_end - ivptest.REFERENCES[sc.model].t_end) < 1e-12:
        dig = ivptest.reference_digits(sc.model, ref.history)
        ref.notes.append("digits at t_end against the IVP test set's published solution: "
                         + ", ".join(f"{k} {v:.2f}" for k, v in dig.items()))
    if ship:
        ref.shipped = shipped.ship(sc, ref)
    return ref
