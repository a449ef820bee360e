"""What the columns of a scored row mean, in words: one registry of display names, units
and one-line definitions, for the terminal, the report pages, figure axes and the
recommendation. Column names stay in the files (``err_theta_max_trusted``); people read
"θ max error over the trusted span [deg]".

A column is described by :func:`describe` (a :class:`Measure`): first by the fixed
entries of :data:`FIXED` (costs, counters, residuals, impact and event measures), then by
the error pattern ``err_[<where>_]<obs>_<norm>[_trusted]`` of every observable a model
declares (:mod:`daebench.core.observables`: its label and unit), else it is its own name.
:func:`markdown` writes the glossary page (``docs/reference/glossary.md``), regenerated
with ``python -m daebench.harness.scoring.glossary docs/reference/glossary.md``.
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass
from pathlib import Path

from daebench.core.observables import Observable, Position
from daebench.harness.scoring import pipeline


@dataclass(frozen=True)
class Measure:
    """One column, for people.

    Attributes
    ----------
    column : the column's name in the files
    words : what it is, without the unit ("θ max error over the trusted span")
    short : a few words for a table header ("θ max trusted")
    unit : its unit ('' for a count or a ratio)
    definition : one line: how it is computed
    source : where the measure comes from ('' for a plain count or norm)
    """

    column: str
    words: str
    short: str
    unit: str = ""
    definition: str = ""
    source: str = ""

    @property
    def name(self) -> str:
        """The display name: words and unit ("θ max error over the trusted span [deg]")."""
        return f"{self.words} [{self.unit}]" if self.unit else self.words

    @property
    def header(self) -> str:
        """The table header: the short words, the unit on its own line."""
        return f"{self.short}\n[{self.unit}]" if self.unit else self.short


#: columns with a fixed meaning: column → (words, short header, unit, definition)
FIXED: dict[str, tuple[str, str, str, str]] = {
    "wall_s": ("wall time", "wall", "s", "minimum wall-clock time of the run's timed repeats, after a warm-up"),
    "cpu_s": ("CPU time", "CPU", "s", "minimum CPU (process) time of the run's timed repeats, after a warm-up; "
                                      "what recommendations and profiles rank by"),
    "cpu_spread": ("CPU time spread of the repeats", "spread", "",
                   "(largest − smallest) / smallest CPU time of the run's timed repeats (NaN for one repeat)"),
    "repeats": ("timed repeats", "repeats", "", "timed calls of the run whose minimum is its time"),
    "steps": ("steps", "steps", "", "accepted steps of the integrator"),
    "rejected": ("rejected steps", "rejected", "", "steps the error controller rejected and retried"),
    "residual_evals": ("residual evaluations", "residuals", "", "evaluations of the problem's residual"),
    "jacobian_evals": ("Jacobian evaluations", "Jacobians", "", "evaluations of the problem's Jacobian"),
    "lu_factorizations": ("LU factorizations", "LUs", "", "LU factorizations of the iteration matrix"),
    "newton_iterations": ("Newton iterations", "Newton", "", "Newton iterations over the run"),
    "t_final": ("time reached", "t reached", "s", "the last time the run reached"),
    "energy_resid_max": ("max energy-balance residual", "E res", "J",
                         "largest |E(t) − E(0) − work of the applied forces + energy the impacts removed|"),
    "energy_resid_rms": ("RMS energy-balance residual", "E res RMS", "J",
                         "root-mean-square of the energy-balance residual over the output times"),
    "energy_resid_final": ("final energy-balance residual", "E res final", "J",
                           "the energy-balance residual at the last time"),
    "energy_resid_rel": ("max energy-balance residual / energy scale", "E res rel", "",
                         "energy_resid_max divided by the run's energy scale"),
    "C_max": ("max position-constraint residual", "|C| max", "m",
              "largest |C(q)| of the closed contacts and joints (a gap or a joint's position error)"),
    "Cdot_max": ("max velocity-constraint residual", "|Ċ| max", "m/s", "largest |Ċ| of the closed contacts and joints"),
    "Cddot_max": ("max acceleration-constraint residual", "|C̈| max", "m/s²",
                  "largest |C̈| of the closed contacts and joints"),
    "impacts": ("impacts of the run", "impacts", "",
                "impacts the run located (event capturing: its contact episodes)"),
    "impacts_ref": ("impacts of the truth", "impacts ref", "", "impacts of the reference or exact solution"),
    "impacts_matched": ("impacts matched", "matched", "",
                        "run impacts paired one to one, in order, with the truth's within the impact tolerance"),
    "impacts_missed": ("impacts missed", "missed", "", "the truth's impacts no run impact stands for"),
    "impacts_spurious": ("spurious impacts", "spurious", "", "run impacts the truth does not have"),
    "impacts_merged": ("merged impacts", "merged", "", "matched run impacts that stand for several of the truth's"),
    "impacts_absorbed": ("absorbed impacts", "absorbed", "", "the truth's impacts inside a merged run impact's span"),
    "chatter_clusters": ("chatter clusters", "chatter", "", "clusters of impacts of one contact within the chatter "
                                                            "window"),
    "chatter_clusters_ref": ("chatter clusters of the truth", "chatter ref", "", "the same, of the truth"),
    "max_penetration": ("max penetration", "penetration", "m", "largest −gap of the run (≥ 0)"),
    "impact_tol": ("impact matching tolerance", "impact tol", "s", "how far a run impact may lie from the truth's "
                                                                     "to be matched"),
    "chatter_window": ("chatter window", "chatter window", "s", "the window that makes a chatter cluster"),
    "err_impact_t_max": ("max error of the impact times", "impact t err", "s",
                         "largest |t_run − t_truth| over the impacts paired in order"),
    "err_impact_t_matched_max": ("max error of the matched impacts' times", "matched t err", "s",
                                 "largest |t_run − t_truth| over the matched impacts"),
    "impact1_loss": ("energy lost at the first impact", "loss 1", "J", "kinetic energy the run's first impact removed"),
    "err_impact1_loss": ("error of the energy lost at the first impact", "loss 1 err", "J",
                         "|the run's first-impact loss − the truth's|"),
    "impact_loss_dev_max": ("max deviation of an impact's energy loss from the exact impact map", "loss dev", "J",
                            "largest |loss − Newton's law at the run's own pre-impact state| over the impacts"),
    "impact_loss_dev_rel": ("max relative deviation of an impact's energy loss", "loss dev rel", "",
                            "impact_loss_dev_max divided by the largest exact loss"),
    "err_impact_dv_max": ("max relative error of an impact's velocity jump", "Δv err", "",
                          "largest ‖Δv_run − Δv_exact‖_M / ‖Δv‖_M over the impacts, Newton's law applied at the "
                          "run's own pre-impact state"),
    "err_impact1_dv": ("relative error of the first impact's velocity jump", "Δv₁ err", "",
                       "the same at the first impact"),
    "err_impulse_max": ("max error of an impact's impulse", "impulse err", "N s",
                        "largest |Λ_run − Λ_exact| over the impacts"),
    "err_impulse_rel_max": ("max relative error of an impact's impulse", "impulse err rel", "",
                            "largest |Λ_run − Λ_exact| / Λ_exact over the impacts"),
    "oracle_impacts": ("impacts checked by the oracle", "oracle", "", "impact records the exact impact law was "
                                                                       "applied to"),
    "oracle_skipped": ("impacts the oracle could not check", "oracle skipped", "",
                       "records without a state, or not under Newton's law"),
    "err_graph_q": ("graph distance of the positions", "graph q", "",
                    "Hausdorff distance of the run's and the truth's graphs in (t/T, q/Q), the worst position"),
    "err_graph_v": ("graph distance of the velocities", "graph v", "",
                    "Hausdorff distance of the graphs in (t/T, v/V), the worst velocity"),
    "graph_resolution": ("graph distance resolution", "graph res", "", "the sampling distance of the graph distance"),
    "err_apex_t": ("error of the rebound apex time", "apex t err", "s", "|t_apex,run − t_apex,truth| after the first "
                                                                        "impact"),
    "err_apex_height": ("error of the rebound apex height", "apex err", "m",
                        "|height of the run's first rebound apex − the truth's|"),
    "trust_t": ("end of the trusted span", "trust t", "s",
                "the reference is trusted on [0, trust_t] (its accuracy record)"),
    "trust_impacts": ("impacts in the trusted span", "trust impacts", "", "the reference's impacts on [0, trust_t]"),
    "windows_matched": ("windows scored", "windows", "", "re-synchronised windows after the matched impacts"),
    "windows_ref": ("windows of the truth", "windows ref", "", "the truth's windows (one per impact)"),
}

_MODAL = "Géradin & Rixen, Mechanical Vibrations (2015) §2.3; daebench.harness.scoring.modal"
_NONSMOOTH = "Moreau (1988); Acary & Brogliato, Numerical Methods for Nonsmooth Dynamical Systems (2008) ch. 10"
#: measures that mean physics: column → (words, short header, unit, definition, source)
PHYSICS: dict[str, tuple[str, str, str, str, str]] = {
    "modes_resolved": ("modes in the resolved band", "resolved modes", "",
                       "linearised modes within 5 % of a finer discretization's frequency (or below the case's "
                       "[compare] modes_below)", _MODAL),
    "err_band_energy_max": ("max error energy in the resolved band", "band E err", "J",
                            "largest ½ Σ_band (ė_i² + ω_i² e_i²) of the modal errors e = ΦᵀM(q_run − q_truth) "
                            "before the first impact", _MODAL),
    "err_rest_energy_max": ("max error energy outside the resolved band", "rest E err", "J",
                            "the same over the modes outside the resolved band", _MODAL),
    "err_postband_energy_max": ("max error energy in the resolved band after the first impacts", "band E err after",
                                "J", "err_band_energy_max over the first free window after the truth's first "
                                "impacts, on the modes of the linearisation where that window starts", _MODAL),
    "err_postrest_energy_max": ("max error energy outside the resolved band after the first impacts",
                                "rest E err after", "J", "the same over the modes outside the resolved band", _MODAL),
    "err_impulse_measure": ("distance between the cumulative contact impulses", "Λ(t) dist", "N s",
                            "(1/T)∫₀ᵀ |Λ_run(t) − Λ_truth(t)| dt, Λ(t) the impulses of the impacts up to t plus "
                            "∫λ dt of the contact forces, T the trusted span", _NONSMOOTH),
    "err_impulse_measure_rel": ("relative distance between the cumulative contact impulses", "Λ(t) dist rel", "",
                                "err_impulse_measure divided by the truth's total impulse Λ_truth(T)", _NONSMOOTH),
}
_MODE = re.compile(r"(?P<err>err_)?mode(?P<k>\d+)_(?P<what>omega|energy)(?P<max>_max)?")

#: error norms: norm → (words, short, how)
NORMS = {"max": ("max error", "max", "the largest |run − truth|"),
         "final": ("final error", "final", "|run − truth| at the last time"),
         "l2": ("L2 error", "L2", "the root-mean-square of run − truth"),
         "l1": ("L¹ error", "L¹", "the time average of |run − truth| (a velocity of a run with contacts: it falls "
                                  "with the impact times' error, where the max stays at the jump's size; Acary & "
                                  "Brogliato 2008, ch. 10)")}
#: where an error is measured: (column prefix, trusted) → (words, short, where)
SPANS = {("", False): ("over the whole run", "whole run",
                       "over the run's output times, the truth interpolated within its smooth segments"),
         ("", True): ("over the trusted span", "trusted",
                      "on [0, trust_t], the span over which the reference's accuracy record trusts it"),
         ("pre_", False): ("before the first impact", "pre-impact", "on [0, t₁): before the truth's first impact"),
         ("win_", False): ("per re-synchronised window", "windows",
                           "largest over the windows after each impact, the run's window shifted onto the truth's "
                           "(NaN unless every impact matched)"),
         ("winm_", False): ("per matched window", "matched windows",
                            "the same over the windows of the impacts that matched"),
         ("band_", False): ("in the resolved modal band", "band",
                            "before the first impact, the part Σ_band (c_oᵀφ_i) e_i of the linearised error carried "
                            "by the resolved modes (e = ΦᵀM(q_run − q_truth), mass-normalised modes of the "
                            "linearisation at the start; Géradin & Rixen 2015 §2.3)"),
         ("rest_", False): ("outside the resolved modal band", "rest",
                            "the same, carried by the modes outside the resolved band (a discretization's "
                            "unresolved modes)"),
         ("postband_", False): ("in the resolved modal band after the first impacts", "band after",
                                "the band's part over the first free window after the truth's first impacts "
                                "(≥ a tenth of the span without an impact), on the modes of the linearisation "
                                "at the truth's configuration where that window starts"),
         ("postrest_", False): ("outside the resolved modal band after the first impacts", "rest after",
                                "the same, carried by the modes outside the resolved band")}
_ERROR = re.compile(r"err_(?P<where>pre_|winm_|win_|postband_|postrest_|band_|rest_)?(?P<obs>.+)_(?P<norm>final|max|l2|l1)"
                    r"(?P<trusted>_trusted)?")
_IMPACT_T = re.compile(r"err_impact(?P<k>\d+)_t")
_ORDINAL = {1: "first", 2: "second", 3: "third"}


def declared_observable(score_name: str, model: str | None = None) -> Observable | Position | None:
    """The declaration whose error columns are ``err_<score_name>_*``: model ``model``'s,
    else the one every registered model that declares it agrees on (label and unit; when
    they differ in label but agree on the unit: the name and that unit; when they agree on
    the label's symbol but not the unit: the symbol, "in each case's unit"); None otherwise."""
    if model is not None:
        return pipeline.declared(model).by_score_name(score_name)
    found = {d for d in pipeline.every_declared() if d.score_name == score_name}
    if len({(d.label, d.unit) for d in found}) == 1:
        return found.pop()
    units = {d.unit for d in found}
    if len(units) == 1:
        return Observable(score_name, units.pop())
    symbols = {(d.label or d.score_name).split()[0] for d in found}
    if len(symbols) == 1:   # one symbol ('θ', 'θ crank'), units that differ by model: no unit to print
        return Observable(score_name, "each case's unit", label=symbols.pop())
    return None


def describe(column: str, model: str | None = None) -> Measure:
    """The :class:`Measure` of ``column`` (labels and units of the observables of model
    ``model``; without it, those every model agrees on)."""
    if column in FIXED:
        return Measure(column, *FIXED[column])
    if column in PHYSICS:
        return Measure(column, *PHYSICS[column])
    m = _MODE.fullmatch(column)
    if m and ((not m.group("err") and not m.group("max")) or (m.group("err") and m.group("max")
                                                             and m.group("what") == "energy")):
        k = m.group("k")
        if m.group("what") == "omega":
            return Measure(column, f"frequency of linearised mode {k}", f"ω{k}", "rad/s",
                           f"√ of the k-th generalized eigenvalue of K φ = ω² M φ at the start (−√|ω²| for ω² ≤ 0)",
                           _MODAL)
        if m.group("err"):
            return Measure(column, f"max error of mode {k}'s energy", f"E{k} err", "J",
                           f"largest |E_{k},run − E_{k},truth| before the first impact, E_i = ½(η̇_i² + ω_i² η_i²), "
                           f"η = ΦᵀM(q − q₀)", _MODAL)
        return Measure(column, f"energy of mode {k}", f"E{k}", "J",
                       f"the truth's largest ½(η̇_{k}² + ω_{k}² η_{k}²) before the first impact, η = ΦᵀM(q − q₀)",
                       _MODAL)
    m = _IMPACT_T.fullmatch(column)
    if m:
        k = int(m.group("k"))
        nth = _ORDINAL.get(k, f"{k}th")
        return Measure(column, f"error of the {nth} impact time", f"t{k} err", "s",
                       f"|t_run − t_truth| of the {nth} impact")
    m = _ERROR.fullmatch(column)
    if m:
        d = declared_observable(m.group("obs"), model)
        label = (d.label or d.score_name) if d is not None else m.group("obs")
        unit = d.unit if d is not None else ""
        nw, ns, how = NORMS[m.group("norm")]
        key = (m.group("where") or "", bool(m.group("trusted")))
        if key not in SPANS:    # a window error over the trusted span is not made
            return Measure(column, column, column)
        sw, ss, where = SPANS[key]
        src = _MODAL if key[0] in ("band_", "rest_", "postband_", "postrest_") else _NONSMOOTH if m.group("norm") == "l1" else ""
        return Measure(column, f"{label} {nw} {sw}", f"{label} {ns} {ss}", unit, f"{how} of {label}, {where}", src)
    d = declared_observable(column, model)
    if d is not None:
        return Measure(column, d.label or d.score_name, d.label or d.score_name, d.unit, "the observable itself")
    return Measure(column, column, column)


def display(column: str, model: str | None = None) -> str:
    """The display name of ``column`` (:attr:`Measure.name`)."""
    return describe(column, model).name


def target_text(column: str, target: float, model: str | None = None) -> str:
    """A target in words: "θ max error over the trusted span ≤ 0.1 deg"."""
    m = describe(column, model)
    unit = f" ({m.unit})" if " " in m.unit else f" {m.unit}" if m.unit else ""
    return f"{m.words} ≤ {target:g}{unit}"


# ---- the glossary page ----------------------------------------------------------------------------
def _row(*cells: str) -> str:
    return "| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |"


def markdown() -> str:
    """The glossary page: the error pattern of every observable, the other measures, the
    observables each model declares."""
    lines = ["# Glossary of measures", "",
             "What every column of a scored run means. Files keep the column names; the terminal, the report "
             "pages, the figures and the recommendations print the display names. Generated from "
             "`daebench.harness.scoring.glossary` (`python -m daebench.harness.scoring.glossary "
             "docs/reference/glossary.md`); a test checks that it is current.", "",
             "## Errors of an observable", "",
             "`<obs>` is an observable's score name (the table at the end), `<norm>` one of "
             + ", ".join(f"`{n}`" for n in NORMS) + ". Display name: `<label> <norm> error <where> [<unit>]`, e.g. "
             f"*{describe('err_theta_max_trusted', 'hub-beam').name}*.", "",
             _row("column", "where", "definition"), _row("---", "---", "---")]
    for (prefix, trusted), (words, _, where) in SPANS.items():
        lines.append(_row(f"`err_{prefix}<obs>_<norm>{'_trusted' if trusted else ''}`", words, where))
    lines += ["", _row("norm", "words", "definition"), _row("---", "---", "---")]
    lines += [_row(f"`{n}`", w, how) for n, (w, _, how) in NORMS.items()]
    lines += ["", "## Other measures", "", _row("column", "display name", "definition"), _row("---", "---", "---")]
    lines.append(_row("`err_impact<k>_t`", describe("err_impact1_t").name.replace("first", "k-th"),
                      "|t_run − t_truth| of the k-th impact"))
    for col in FIXED:
        m = describe(col)
        lines.append(_row(f"`{col}`", m.name, m.definition))
    lines += ["", "## Measures that mean physics", "",
              "Frame-invariant, modal and nonsmooth measures (the band columns follow the error pattern above with "
              "`<where>` = `band_`, `rest_`, `postband_`, `postrest_`; velocities take the `l1` norm).", "",
              _row("column", "display name", "definition", "source"), _row("---", "---", "---", "---")]
    for col in (*PHYSICS, "mode<k>_omega", "mode<k>_energy", "err_mode<k>_energy_max"):
        m = describe(col.replace("<k>", "1"))
        lines.append(_row(f"`{col}`", m.name.replace("1", "k"), m.definition.replace("_1", "_k"), m.source))
    lines += ["", "## Observables the models declare", "", _row("model", "score name `<obs>`", "label", "unit"),
              _row("---", "---", "---", "---")]
    from daebench.models import MODELS, PROVIDERS  # lazy: the model registry, only for the page (daebench's own models)
    for model in (m for m in MODELS if PROVIDERS.get(m) == "daebench"):
        try:
            d = pipeline.declared(model)
        except Exception:  # noqa: BLE001 - a model that cannot be imported declares nothing here
            continue
        for o in (*d.declared, *d.positions):
            lines.append(_row(model, f"`{o.score_name}`", o.label or o.score_name, o.unit or "–"))
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Write the glossary page to the path given (stdout without one)."""
    args = sys.argv[1:] if argv is None else argv
    text = markdown()
    if args:
        Path(args[0]).parent.mkdir(parents=True, exist_ok=True)
        Path(args[0]).write_text(text, encoding="utf-8")
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

