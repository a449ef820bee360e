"""How accurate a reference is, and for how long: its digits per observable over time and
its trusted span.

A reference (:mod:`daebench.harness.references.reference`) is computed three times: at its
tolerance (the *reference run*), :data:`LOOSE_FACTOR` looser (the *loose run*) and at its
tolerance again from a start perturbed at the round-off level of that tolerance (the
*perturbed run*: relative :data:`PERTURB_FACTOR` × rtol on every q and q̇, then projected
back onto the bilateral constraints, :func:`perturbed_start`). The loose run measures the
discretization error; the perturbed run measures how much an error the reference run
itself makes is amplified by the dynamics — after impacts, by a different event sequence.

Definitions (per scored observable c, reference history y(t), range R_c = max y − min y
over the run):

* estimated error of the reference a_c(t) = |y_loose(t) − y(t)| / LOOSE_FACTOR at its
  output times (the loose run interpolated linearly there; NaN where it stopped early):
  the loose run's difference scaled by the tolerance ratio (a tolerance-proportional
  error). Measured against runs 100× tighter it is right to ±0.6 digit (andrews, caraxis:
  tests/harness/test_reference_accuracy.py);
* sensitivity p_c(t) = |y_perturbed(t) − y(t)|: where a start moved by 10 × rtol ends up.
  It is not an error estimate — on a smooth, neutrally stable run it stays at the size of
  the perturbation (caraxis: 10.1 digits where the reference has 11.1–13.7) — but after an
  impact whose sequence the perturbation changes it jumps to the size of the solution;
* estimated correct digits in a time window W: d_c(W) = −log10(max_{t∈W} a_c(t) / R_c),
  capped at :data:`DIGITS_CAP` (a table of :data:`WINDOWS` equal windows × observables;
  the same table of p_c is ``digits_perturbed``);
* ``trust_t``: the last output time before the first one at which max(a_c, p_c) > :data:`TRUST_REL`
  × R_c for some scored observable c (``t_end`` if there is none); a column the reference
  keeps constant (R_c ≤ :data:`CONSTANT_RANGE` × max(1, max |y|): round-off only) limits
  nothing. On [0, trust_t] every
  scored observable of the reference is right to TRUST_REL of its range, far below the
  errors the harness scores (fixed-step runs: 1e-3 … 1e-1 of the range); after it the
  reference runs disagree by more than that, and an error measured there would measure
  the reference as much as the run;
* ``trust_impacts``: the number of the reference's impacts at t ≤ trust_t.

Conditioning (sidecar ``conditioning``, :func:`conditioning`): how the *problem* amplifies
a start error, apart from any integrator. The reference is run again from starts moved by
relative δ ∈ :data:`CONDITIONING_PERTURBATIONS` (1e-8, 1e-6, 1e-4; :func:`perturbed_start`)
at a tolerance :data:`CONDITIONING_TOL_RATIO` × δ (the perturbation, not the solver, sets
their difference), and per scored observable c the amplification is

    A_c(δ) = max_t |y_δ(t) − y(t)| / (δ · R_c),

the largest difference in units of the range per unit of relative start error. A_c near 1
is a well-conditioned run; a large A_c, or one that grows with δ (a different event
sequence), says how much of a run's error after an impact the problem itself makes of a
small error before it. The impacts each perturbed run had are kept beside.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
import pandas as pd


LOOSE_FACTOR = 10.0     # the loose run's tolerance / the reference's
PERTURB_FACTOR = 10.0   # relative perturbation of the start / the reference's rtol
TRUST_REL = 1e-4        # spread / range beyond which the reference is not trusted
WINDOWS = 10            # time windows of the digits table
DIGITS_CAP = 16.0       # digits reported when the runs agree to round-off
CONDITIONING_PERTURBATIONS = (1e-8, 1e-6, 1e-4)  # relative start perturbations of the conditioning runs
CONDITIONING_TOL_RATIO = 1e-2  # their tolerance / the perturbation (never tighter than the reference's)
CONSTANT_RANGE = 1e-12  # a column whose range is below this (× its size when > 1) is constant: no trust limit


def _unique(hist: pd.DataFrame) -> pd.DataFrame:
    """Rows at distinct times (an event written twice keeps the state after it)."""
    return hist[~hist["t"].duplicated(keep="last")]


def observable_ranges(hist: pd.DataFrame, columns: Sequence[str]) -> dict[str, float]:
    """Peak-to-peak range of each column over the run (0 for a constant one)."""
    return {c: float(hist[c].max() - hist[c].min()) for c in columns}


def spreads(ref: pd.DataFrame, others: Sequence[pd.DataFrame], columns: Sequence[str],
            weights: Sequence[float] | None = None) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(t, {c: e_c(t)}): the largest weighted difference w_k |y_k − y| of ``others`` from
    ``ref`` at ref's output times (others linearly interpolated there; NaN where another
    run stopped early). Weights default to 1."""
    weights = [1.0] * len(others) if weights is None else list(weights)
    r = _unique(ref)
    t = r["t"].to_numpy(float)
    out = {}
    for c in columns:
        y = r[c].to_numpy(float)
        s = np.zeros_like(y)
        for o, w in zip(others, weights):
            u = _unique(o)
            to = u["t"].to_numpy(float)
            yo = np.interp(t, to, u[c].to_numpy(float))
            yo[t > to[-1] + 1e-12 * max(1.0, abs(to[-1]))] = np.nan
            s = np.fmax(s, w * np.abs(yo - y))
            s[np.isnan(yo)] = np.nan
        out[c] = s
    return t, out


def digits(spread: np.ndarray, scale: float) -> float:
    """−log10(max spread / scale), capped at DIGITS_CAP (NaN spread: 0 digits)."""
    if not scale > 0:
        return math.nan
    if spread.size and np.any(np.isnan(spread)):
        return 0.0
    worst = float(np.max(spread)) if spread.size else 0.0
    return DIGITS_CAP if worst <= scale * 10.0 ** -DIGITS_CAP else min(DIGITS_CAP, -math.log10(worst / scale))


def assess(ref: pd.DataFrame, ref_impacts: Sequence[float], loose: pd.DataFrame, perturbed: pd.DataFrame,
           columns: Sequence[str], t_end: float, windows: int = WINDOWS,
           loose_factor: float = LOOSE_FACTOR) -> dict[str, Any]:
    """The accuracy record of a reference (stored in its sidecar under ``accuracy``).

    Parameters
    ----------
    ref : the reference run's history
    ref_impacts : its impact times
    loose, perturbed : the loose (``loose_factor`` × the tolerances) and the perturbed runs' histories
    columns : the scored observables
    t_end : the scene's end time

    Returns
    -------
    dict
        ``trust_t`` [s], ``trust_impacts``, ``trust_limited_by`` (the observable whose
        spread first exceeds the threshold, or None), ``trust_rel`` (the threshold),
        ``ranges`` {c: R_c}, ``digits`` {"windows": [[t0, t1], …], c: [d_c per window]},
        ``digits_perturbed`` (the same for p_c), ``digits_final`` {c: −log10(a_c(t_end) /
        |y(t_end)|), the IVP test set's significant digits}.
    """
    cols = [c for c in columns if c in ref.columns]
    ranges = observable_ranges(ref, cols)
    t, s = spreads(ref, [loose, perturbed], cols, [1.0 / loose_factor, 1.0])
    _, acc = spreads(ref, [loose], cols, [1.0 / loose_factor])
    _, sens = spreads(ref, [perturbed], cols)
    first = len(t)
    limited_by = None
    for c in cols:
        if not ranges[c] > 0 or ranges[c] <= CONSTANT_RANGE * max(1.0, float(np.nanmax(np.abs(ref[c])))):
            continue   # a constant column (θ ≡ 0 of a block that never tips): its round-off limits nothing
        bad = np.flatnonzero(~(s[c] <= TRUST_REL * ranges[c]))
        if bad.size and bad[0] < first:
            first, limited_by = int(bad[0]), c
    trust_t = float(t_end) if first >= len(t) else float(t[max(first - 1, 0)])
    edges = np.linspace(0.0, float(t_end), windows + 1)

    def table(e: dict[str, np.ndarray]) -> dict[str, Any]:
        out: dict[str, Any] = {"windows": [[float(a), float(b)] for a, b in zip(edges[:-1], edges[1:])]}
        for c in cols:
            out[c] = [round(digits(e[c][(t >= a) & (t <= b)], ranges[c]), 2) for a, b in zip(edges[:-1], edges[1:])]
        return out

    final = _unique(ref).iloc[-1]
    dfinal = {c: round(digits(acc[c][-1:], abs(float(final[c]))), 2) for c in cols}
    return {"trust_t": trust_t, "trust_impacts": int(sum(1 for x in ref_impacts if x <= trust_t)),
            "trust_limited_by": limited_by, "trust_rel": TRUST_REL, "ranges": ranges, "digits": table(acc),
            "digits_perturbed": table(sens), "digits_final": dfinal, "loose_factor": loose_factor,
            "perturb_factor": PERTURB_FACTOR}


def _project(system: Any, t: float, q: np.ndarray, v: np.ndarray, sq: np.ndarray,
             sv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """q onto C(t, q) = 0, then v onto C_q v + C_t = 0, each by the least change in the norm
    weighted by 1/s (Gauss–Newton with S² C_qᵀ (C_q S² C_qᵀ)⁻¹): a component moves in
    proportion to its own size, so a small coordinate (an elastic one, 1e-5 m beside a
    0.45 m slider) is not handed the correction of a large one."""
    if system.n_bilateral == 0:
        return q, v
    Sq, Sv = sq * sq, sv * sv
    for _ in range(20):
        C = system.constraint(t, q)
        G = system.constraint_jacobian(t, q)
        q = q - Sq * (G.T @ np.linalg.solve((G * Sq) @ G.T, C))
        if np.max(np.abs(C)) <= 1e-15 * max(1.0, float(np.max(np.abs(q)))):
            break
    G = system.constraint_jacobian(t, q)
    v = v - Sv * (G.T @ np.linalg.solve((G * Sv) @ G.T, G @ v + system.constraint_t(t, q)))
    return q, v


def _sizes(x: np.ndarray, scale: np.ndarray | None) -> np.ndarray:
    """|x_i|, and for a zero entry 1e-3 of its declared scale (or of the largest |x_j|)."""
    a = np.abs(x)
    floor = 1e-3 * (np.asarray(scale, float) if scale is not None else float(np.max(a, initial=0.0)))
    return np.where(a > 0, a, floor)


def perturbed_start(system: Any, rtol: float, factor: float = PERTURB_FACTOR) -> tuple[np.ndarray, np.ndarray]:
    """The system's start, every q_i and q̇_i moved by ±factor·rtol·|x_i| (alternating
    signs; a zero entry by factor·rtol·1e-3·its scale: the model's ``state_scale()`` if it
    declares one, else the largest |x_j|), projected back onto the bilateral constraints
    with the same sizes as weights (:func:`_project`).
    Contact points that are open at the start stay open: if a gap would close, only the
    velocities are perturbed."""
    q0, v0 = (np.asarray(x, float) for x in system.initial_state())
    d = float(factor) * float(rtol)
    sign_q = np.where(np.arange(q0.size) % 2 == 0, 1.0, -1.0)
    sign_v = np.where(np.arange(v0.size) % 2 == 0, -1.0, 1.0)
    scale = getattr(system, "state_scale", None)
    qs, vs = scale() if scale is not None else (None, None)
    sq, sv = _sizes(q0, qs), _sizes(v0, vs)
    q = q0 + d * sign_q * sq
    v = v0 + d * sign_v * sv
    sq = np.where(sq > 0, sq, 1.0)
    sv = np.where(sv > 0, sv, 1.0)
    qp, vp = _project(system, 0.0, q, v, sq, sv)
    if system.n_contacts:
        g0, g1 = system.gap(q0), system.gap(qp)
        if np.any((g0 > 0) & (g1 <= 0)):
            qp, vp = _project(system, 0.0, q0.copy(), v, sq, sv)
    return qp, vp


def conditioning(ref: pd.DataFrame, runs: dict[float, tuple[pd.DataFrame, int]],
                 columns: Sequence[str]) -> dict[str, Any]:
    """The conditioning record (module docstring): ``runs`` {δ: (history from the start moved
    by δ, its number of impacts)} against the reference history ``ref``."""
    columns = [c for c in columns if c in ref]  # an observable of a switched-off effect is not there
    ranges = observable_ranges(_unique(ref), columns)
    deltas = sorted(runs)
    amp: dict[str, list[float]] = {}
    for c in columns:
        amp[c] = []
        for d in deltas:
            _, sp = spreads(ref, [runs[d][0]], [c])
            worst = float(np.nanmax(sp[c])) if np.isfinite(sp[c]).any() else math.nan
            amp[c].append(worst / (d * ranges[c]) if ranges[c] > 0 and math.isfinite(worst) else math.nan)
    return {"perturbations": deltas, "amplification": amp, "impacts": [int(runs[d][1]) for d in deltas]}


def conditioning_tolerance(delta: float, rtol: float) -> float:
    """The tolerance of the run from a start moved by ``delta``: CONDITIONING_TOL_RATIO × δ,
    never tighter than the reference's own ``rtol``."""
    return max(float(rtol), CONDITIONING_TOL_RATIO * float(delta))


def with_start(system: Any, q: np.ndarray, v: np.ndarray) -> Any:
    """``system`` starting from (q, v) instead of its own start (this instance only)."""
    system.initial_state = lambda: (q.copy(), v.copy())
    return system


def summary_lines(meta: dict[str, Any], impacts: Sequence[float], t_end: float) -> list[str]:
    """What `daebench reference` prints about a reference's accuracy record."""
    acc = meta.get("accuracy") or {}
    if "trust_t" not in acc:
        return ["accuracy: not assessed (computed without the check runs); `--force` recomputes it"]
    tt, ti = float(acc["trust_t"]), int(acc["trust_impacts"])
    lim = acc.get("trust_limited_by")
    why = (f"after it the runs disagree by more than {acc['trust_rel']:g} of the range of {lim}" if lim
           else f"the runs agree to {acc['trust_rel']:g} of every observable's range over the whole run")
    lines = [f"trust_t = {tt:.6g} s of {t_end:g} s, trust_impacts = {ti} of {len(impacts)} ({why})"]
    if not impacts:
        lines.append("the scene's horizon ends before its first impact: the reference has no impact")
    elif tt < impacts[0]:
        lines.append(f"the trusted span ends before the first impact (t = {impacts[0]:.6g} s)")
    coarse = f"coarse h = {acc['coarse_h']:g} s" if "coarse_h" in acc else f"loose ×{acc['loose_factor']:g}"
    pert = f"relative {acc['perturb_rel']:g}" if "perturb_rel" in acc else f"relative {acc['perturb_factor']:g}×rtol"
    lines.append(f"runs: {coarse} {acc.get('loose')}, perturbed start ({pert}) {acc.get('perturbed')}, "
                 f"impacts {acc.get('loose_impacts')} / {acc.get('perturbed_impacts')} (reference {len(impacts)})")
    table = acc.get("digits", {})
    cols = [c for c in table if c != "windows"]
    if cols:
        est = acc.get("estimate") or f"loose run's difference / {acc.get('loose_factor', LOOSE_FACTOR):g}"
        lines.append(f"estimated correct digits ({est}, of the range) per time window:")
        lines.append("  window [s]          " + " ".join(f"{c[:10]:>10s}" for c in cols))
        for k, (a, b) in enumerate(table["windows"]):
            lines.append(f"  {a:8.4g} – {b:<8.4g} " + " ".join(f"{table[c][k]:10.1f}" for c in cols))
        fin = acc.get("digits_final", {})
        lines.append("  at t_end (relative) " + " ".join(f"{fin.get(c, math.nan):10.1f}" for c in cols))
    sens = acc.get("digits_perturbed", {})
    if cols and sens:
        lines.append("sensitivity: the perturbed start's difference in digits of the range, per window:")
        for k, (a, b) in enumerate(sens["windows"]):
            lines.append(f"  {a:8.4g} – {b:<8.4g} " + " ".join(f"{sens[c][k]:10.1f}" for c in cols))
    cond = meta.get("conditioning") or acc.get("conditioning")
    if cond and cond.get("amplification"):
        amp = cond["amplification"]
        ccols = list(amp)
        lines.append("conditioning: max |Δy| / (δ × range) from a start moved by relative δ (the problem's own "
                     "amplification of a start error):")
        lines.append("  δ          impacts " + " ".join(f"{c[:10]:>10s}" for c in ccols))
        for k, d in enumerate(cond["perturbations"]):
            lines.append(f"  {d:<10.0e} {cond['impacts'][k]:7d} " + " ".join(f"{amp[c][k]:10.3g}" for c in ccols))
    return lines
