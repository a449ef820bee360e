"""The error of a flexible model's run decomposed onto its linearised modes: what a
structural dynamicist reads, the band a converged discretization resolves apart from the
rest.

**Modes.** A model that has them declares ``linearisation() -> (M, K)`` (the mass matrix
and tangent stiffness about its initial state at rest) and ``coordinate_names``, and writes
its state into the history as ``q_<name>``, ``v_<name>``. The generalized eigenproblem
K φ = ω² M φ gives mass-normalised modes (ΦᵀMΦ = I); ω² ≤ 0 (a rigid or a falling
motion, e.g. a hinged beam under gravity) is reported as −√|ω²| and counted as resolved.

**Resolved band.** Mode i is resolved when ω_i is below the frequency the case declares
(``[compare] modes_below``, rad/s), else when it lies within :data:`CONVERGED_RTOL` of the
i-th frequency of the same model on a finer discretization (the model's ``finer()``;
the continuum's frequencies when the finer model converges). The rest is the modes a
discretization adds without resolving them: a modal beam's top mode (beam-impact, N = 5:
11 145 rad/s against the continuum's 6 792).

**Errors.** With the run's and the truth's states Δq = q_run − q_truth, Δv at the run's
output times before the truth's first impact (the linearisation holds for the free
motion; the truth interpolated by cubic Hermite from q and v), the modal errors are
e = ΦᵀM Δq, ė = ΦᵀM Δv, so Δq = Φ e exactly. An observable o with the linearised map
c_o = ∂o/∂q (central differences at the start) has the error c_oᵀΦe, split as
Σ_{i ∈ band} (c_oᵀφ_i) e_i + Σ_{i ∉ band} (c_oᵀφ_i) e_i: ``err_band_<o>_max`` and
``err_rest_<o>_max``. The error's energy in a set of modes is ½ Σ (ė_i² + max(ω_i², 0) e_i²)
(``err_band_energy_max``, ``err_rest_energy_max`` [J]). Energy per mode:
E_i = ½ (η̇_i² + max(ω_i², 0) η_i²) of the modal coordinate η = ΦᵀM (q − q₀);
``mode<k>_energy`` is the truth's largest, ``err_mode<k>_energy_max`` the largest
|E_i,run − E_i,truth|; ``mode<k>_omega`` the frequency.

**After the first impacts.** The same split over the first free window after the truth's
first contact burst (:func:`post_window`: the first interval between successive truth
impacts lasting ≥ :data:`POST_WINDOW_FRACTION` of the span; beam-impact: 0.381–0.788 s),
on the modes of the linearisation at the truth's configuration where that window starts
(the model's ``linearisation(q)``): ``err_postband_<o>_max``, ``err_postrest_<o>_max``,
``err_postband_energy_max``, ``err_postrest_energy_max``. The run's own impacts in that
window (a chatter the truth does not have) are in its error.

References: Géradin & Rixen, *Mechanical Vibrations* (2015), §2.3 (modal decomposition,
mass-normalised modes) and §4 (discretized continua); Hilber, Hughes & Taylor (1977) on
integrators that damp the unresolved modes by design.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Sequence

import numpy as np
import scipy.linalg as sla

#: a mode is resolved when its frequency is within this fraction of the converged one
CONVERGED_RTOL = 0.05
#: the relative step of the central differences of an observable's linear map
FD_STEP = 1e-7


def modes(M: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(ω, Φ): the generalized eigenpairs of K φ = ω² M φ, ascending, Φ mass-normalised
    (ΦᵀMΦ = I); ω² ≤ 0 reported as −√|ω²|.

    Raises
    ------
    ValueError
        M not symmetric positive definite, or a non-finite entry.
    """
    M, K = np.asarray(M, float), np.asarray(K, float)
    if not (np.all(np.isfinite(M)) and np.all(np.isfinite(K))):
        raise ValueError("modes: M and K must be finite")
    w2, phi = sla.eigh(0.5 * (K + K.T), 0.5 * (M + M.T))
    return np.sign(w2) * np.sqrt(np.abs(w2)), phi


def resolved(omega: np.ndarray, converged: np.ndarray | None = None, below: float = math.nan) -> np.ndarray:
    """The resolved band (a mask over ``omega``): below ``below`` when it is given, else
    within :data:`CONVERGED_RTOL` of the same-index ``converged`` frequency; ω ≤ 0 always."""
    omega = np.asarray(omega, float)
    if math.isfinite(below):
        return omega < below
    if converged is None:
        raise ValueError("resolved: give the converged frequencies or a frequency to keep the modes below")
    conv = np.asarray(converged, float)[: omega.size]
    if conv.size < omega.size:
        raise ValueError(f"resolved: {conv.size} converged frequencies for {omega.size} modes")
    return (omega <= 0) | (np.abs(omega - conv) <= CONVERGED_RTOL * np.abs(conv))


def linear_map(fun: Callable[[np.ndarray], float], q0: np.ndarray) -> np.ndarray:
    """∂fun/∂q at ``q0`` by central differences (step FD_STEP·max(1, |q_j|))."""
    q0 = np.asarray(q0, float)
    out = np.empty(q0.size)
    for j in range(q0.size):
        h = FD_STEP * max(1.0, abs(q0[j]))
        a, b = q0.copy(), q0.copy()
        a[j] += h
        b[j] -= h
        out[j] = (fun(a) - fun(b)) / (2 * h)
    return out


def decompose(dq: np.ndarray, dv: np.ndarray, M: np.ndarray, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Modal errors (e, ė) = (Δq M Φ, Δv M Φ) of state errors ``dq``, ``dv`` (rows: times)."""
    P = np.asarray(M, float) @ np.asarray(phi, float)
    return np.asarray(dq, float) @ P, np.asarray(dv, float) @ P


def energies(x: np.ndarray, xd: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """½ (ẋ_i² + max(ω_i², 0) x_i²) per mode and time (rows: times)."""
    w2 = np.maximum(np.sign(omega) * omega * omega, 0.0)
    return 0.5 * (xd * xd + w2 * x * x)


def band_errors(e: np.ndarray, ed: np.ndarray, omega: np.ndarray, band: np.ndarray, phi: np.ndarray,
                maps: dict[str, np.ndarray]) -> dict[str, float]:
    """The largest error of each observable carried by the band and by the rest
    (``err_band_<o>_max``, ``err_rest_<o>_max``; ``maps``: score name → c_o) and the
    error's largest energy in each (``err_band_energy_max``, ``err_rest_energy_max``)."""
    out: dict[str, float] = {}
    en = energies(e, ed, omega)
    for part, mask in (("band", band), ("rest", ~band)):
        out[f"err_{part}_energy_max"] = float(en[:, mask].sum(axis=1).max()) if mask.any() else 0.0
    for name, c in maps.items():
        w = c @ phi     # the observable's weight on each mode
        for part, mask in (("band", band), ("rest", ~band)):
            out[f"err_{part}_{name}_max"] = float(np.abs(e[:, mask] @ w[mask]).max()) if mask.any() else 0.0
    return out


def mode_energies(eta_run: np.ndarray, etad_run: np.ndarray, eta_tr: np.ndarray, etad_tr: np.ndarray,
                  omega: np.ndarray) -> dict[str, float]:
    """``mode<k>_omega``, ``mode<k>_energy`` (the truth's largest) and
    ``err_mode<k>_energy_max`` per mode (module docstring)."""
    er, et = energies(eta_run, etad_run, omega), energies(eta_tr, etad_tr, omega)
    out: dict[str, float] = {}
    for k in range(omega.size):
        out[f"mode{k + 1}_omega"] = float(omega[k])
        out[f"mode{k + 1}_energy"] = float(et[:, k].max())
        out[f"err_mode{k + 1}_energy_max"] = float(np.abs(er[:, k] - et[:, k]).max())
    return out


def columns(n_modes: int, observables: Sequence[str]) -> list[str]:
    """The columns :func:`measure` returns for ``n_modes`` modes and these observables."""
    out = ["modes_resolved"]
    for pre in ("", "post"):
        out += [f"err_{pre}band_energy_max", f"err_{pre}rest_energy_max"]
        out += [f"err_{pre}{p}_{o}_max" for o in observables for p in ("band", "rest")]
    out += [c for k in range(n_modes) for c in (f"mode{k + 1}_omega", f"mode{k + 1}_energy",
                                               f"err_mode{k + 1}_energy_max")]
    return out


def scores(system: Any, run_q: np.ndarray, run_v: np.ndarray, tr_q: np.ndarray, tr_v: np.ndarray,
           observables: dict[str, str], below: float = math.nan, about: np.ndarray | None = None
           ) -> dict[str, float]:
    """Every modal score of a run (rows of ``run_q``, ``run_v``: its states at its output
    times) against the truth's states at the same times (module docstring);
    ``observables``: column → score name of the observables split by band; ``about``: the
    configuration to linearise about (default: the start, where the mode energies are
    measured from)."""
    M, K = system.linearisation() if about is None else system.linearisation(about)
    omega, phi = modes(M, K)
    conv = None
    if not math.isfinite(below):
        fine = system.finer()
        conv = modes(*fine.linearisation())[0]
    band = resolved(omega, conv, below)
    q0, v0 = (np.asarray(x, float) for x in system.initial_state())
    qa = q0 if about is None else np.asarray(about, float)
    maps = {}
    for col, name in observables.items():
        c = linear_map(lambda q: system.observables(0.0, q, np.zeros_like(q))[col], qa)
        if np.any(c != 0.0):
            maps[name] = c
    e, ed = decompose(run_q - tr_q, run_v - tr_v, M, phi)
    out: dict[str, float] = {"modes_resolved": float(band.sum())}
    out.update(band_errors(e, ed, omega, band, phi, maps))
    er, erd = decompose(run_q - q0, run_v - v0, M, phi)
    et, etd = decompose(tr_q - q0, tr_v - v0, M, phi)
    out.update(mode_energies(er, erd, et, etd, omega))
    return out


def measure(run: Any, tr: Any) -> dict[str, Any]:
    """The scoring pipeline's measure (:data:`daebench.harness.scoring.pipeline.MEASURES`):
    the modal scores of a run of a model with a linearisation, before the truth's first
    impact and within its trusted span; NaN where the run or the truth has no state columns
    (a reference computed before they were recorded); nothing for a model without modes."""
    sys_ = run.system
    if not (callable(getattr(sys_, "linearisation", None)) and hasattr(sys_, "coordinate_names")):
        return {}
    names = {o: run.declared.get(o).score_name for o in run.scored_columns()}
    nan = {c: math.nan for c in columns(sys_.n, list(names.values()))}
    qc = [f"q_{c}" for c in sys_.coordinate_names]
    vc = [f"v_{c}" for c in sys_.coordinate_names]
    if not all(c in run.history.columns and c in tr.history.columns for c in qc + vc):
        return nan
    span_end = min(tr.trust_t if math.isfinite(tr.trust_t) else math.inf, float(tr.history["t"].iloc[-1]))
    h = run.history[~run.history["t"].duplicated(keep="last")]
    below = float(getattr(getattr(run.scene, "comparison", None), "modes_below", math.nan))
    out = dict(nan)
    start = _window_states(h, tr.history, qc, vc, -math.inf, min([*tr.impacts[:1], span_end]))
    if start is not None:
        out.update(scores(sys_, *start, names, below))
    post = post_window(list(tr.impacts), span_end)
    if post is not None:
        states = _window_states(h, tr.history, qc, vc, *post)
        if states is not None:
            about = states[2][0]    # the truth's configuration where the window starts
            got = scores(sys_, *states, names, below, about=about)
            out.update({c.replace("err_band", "err_postband").replace("err_rest", "err_postrest"): v
                        for c, v in got.items() if c.startswith(("err_band", "err_rest"))})
    return out


#: the window after the first impacts: the first interval without a truth impact that lasts
#: at least this fraction of the scored span
POST_WINDOW_FRACTION = 0.1


def post_window(impacts: Sequence[float], span_end: float) -> tuple[float, float] | None:
    """(t_a, t_b): the first interval between the truth's successive impacts (the last
    one and ``span_end``) that lasts ≥ :data:`POST_WINDOW_FRACTION` of the span — the free
    motion after the first contact burst; None without impacts or such an interval."""
    ts = sorted(float(t) for t in impacts if float(t) < span_end)
    for a, b in zip(ts, [*ts[1:], span_end]):
        if b - a >= POST_WINDOW_FRACTION * span_end:
            return a, b
    return None


def _window_states(h: Any, truth: Any, qc: list[str], vc: list[str], t_a: float, t_b: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """The run's states at its output times in (t_a, t_b) — open at both ends: the rows at
    an impact time hold the state after it — and the truth's there, interpolated within
    its smooth segment (cubic Hermite in q from q and v); None where fewer than two rows
    are usable."""
    from daebench.harness.scoring import metrics   # lazy: metrics imports this module

    seg = metrics.smooth_rows(truth, t_a, t_b)
    if len(seg) < 2:
        return None
    t = h["t"].to_numpy(float)
    keep = (t < t_b) & (t >= float(seg["t"].iloc[0])) & (t > t_a)
    if keep.sum() < 2:
        return None
    t = t[keep]
    tq = np.column_stack([metrics.dense(seg, q, t, (v, 1.0)) for q, v in zip(qc, vc)])
    tv = np.column_stack([metrics.dense(seg, v, t) for v in vc])
    ok = np.all(np.isfinite(tq), axis=1) & np.all(np.isfinite(tv), axis=1)
    rq, rv = h[qc].to_numpy(float)[keep][ok], h[vc].to_numpy(float)[keep][ok]
    if ok.sum() < 2 or not (np.all(np.isfinite(rq)) and np.all(np.isfinite(rv))):
        return None
    return rq, rv, tq[ok], tv[ok]
