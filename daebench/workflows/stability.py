"""Stability map: the largest stable fixed step of each integrator, measured and predicted.

Measured
--------
For one integrator setting and one scene, the largest step h for which a whole trial run
*completes* — reaches its end with its energy balance within the driver's divergence
threshold (:data:`daebench.driver.history.DIVERGENCE_ENERGY` × the energy scale; the run's
status) — found by bisection in log h between ``h_min`` and ``h_max`` until the bracket
[h_stable, h_unstable] is narrower than a factor 1 + ``tol``. Bisection assumes one
boundary (stable below, unstable above); the trial length (:func:`trial_length`, 80
periods of the fastest mode by default) is chosen so that linear theory predicts one.

Predicted (linear theory, computed)
-----------------------------------
*The system*: the undamped frequencies ω_k at the start, from K φ = ω² M φ with the
tangent stiffness K = ∂(M q̈0)/∂q − ∂Q/∂q + ∂(C_qᵀλ0)/∂q (symmetric part) and M = M(q0),
restricted to the tangent space of the bilateral constraints when the model has any
(:func:`linearize`). The suddenly applied
load Q(q0) starts mode k with the oscillation energy E_k = f_k²/(2ω_k²), f_k = φ_kᵀQ(q0)
(φ mass-normalized) — the seed an unstable mode grows from.

*The method*: its spectral radius ρ(Ω) at Ω = hω on the undamped oscillator —
ABM4-PECE (:class:`AbmPece`): the largest root of its characteristic polynomial on
y′ = iωy; the Newmark family (:class:`NewmarkMember`): the largest eigenvalue of the
amplification matrix of ẍ = −ω²x — and the amplitude factor g_n(Ω) after n steps from the
method's own start (:func:`log_growth`: ρⁿ for the Newmark family, whose start is
consistent; for ABM4-PECE the RK4-started history expanded on the polynomial's roots, since
that start seeds the parasitic roots only weakly). The driver declares divergence when a
mode's energy E_k g_n² passes DIVERGENCE_ENERGY × the energy scale. So the method's
stability interval *for a run of n steps* is

    Ω*(n, G) = sup{Ω : g_n(Ω') ≤ G for all Ω' ≤ Ω},   G = √(DIVERGENCE_ENERGY · E_scale / E_k),

and the predicted h_max = min_k h with h ω_k = Ω*(t_end/h, G_k) (a fixed point in h). The
strict interval {ρ ≤ 1} is reported too: ∞ for the unconditionally stable Newmark members;
for ABM4-PECE it is empty — its principal root exceeds 1 by ≈ 0.16 Ω⁶ for small Ω (order
4, no damping on the imaginary axis) and a parasitic root crosses |ζ| = 1 near Ω ≈ 0.93,
beyond which growth is ≥ 3.6 % a step. On a short run the weak growth below 0.93 cannot
reach the threshold and Ω* sits at that crossing; on long runs Ω* drops towards 0.5.
"""

from __future__ import annotations

import functools
import math
import multiprocessing as mp
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import numpy as np
import pandas as pd
import scipy.linalg as sl

from daebench.core.energyscale import energy_scale
from daebench.core.params import ParamError
from daebench.core.problem import Problem
from daebench.core.scene import Scene, check_name
from daebench.driver.history import DIVERGENCE_ENERGY
from daebench.core.interrupt import RunTimeout
from daebench.harness.files import ensure_writable_dir, results_dir
from daebench.harness.running.runner import make_integrator, run_scene
from daebench.integrators.baumgarte import BaumgarteABM4
from daebench.integrators.family import NewmarkFamily
from daebench.models import build_system
from daebench.stepping import abm
from daebench.workflows import stability_report

# the beam-impact paper's settings (docs/sources.md §G.3), plus generalized-α and two Newmark members:
# the trapezoidal rule (unconditionally stable) and Fox–Goodwin β = 1/12 (stable for hω ≤ √6)
DEFAULT_METHODS = ("baumgarte:delta=0,epsilon=0", "baumgarte:delta=10,epsilon=50",
                   "baumgarte:delta=1000,epsilon=5000", "hht:alpha=0", "hht:alpha=-0.15", "hht:alpha=-0.3333",
                   "genalpha:rho_inf=0.74", "newmark:beta=0.25", "newmark:beta=0.0833333333")
DEFAULT_N = (3, 5, 7, 9)
# trials of 80 periods of the fastest mode (≈ 530 steps near ABM4-PECE's boundary: an instability
# beyond it shows as e^18, the weak growth below it stays under e^3.4; see trial_length).
# On beam-impact that is 0.01-0.12 s (J_h = 0) and 0.03-0.32 s (with a hub): before the first
# impact (0.37 s), in the free flight that the linearization at the start describes.
DEFAULT_PERIODS = 80.0
MIN_STEPS = 100         # the largest step tried gives a trial this many steps (hω_max ≤ 5 at 80 periods)
OMEGA_GRID = np.concatenate([np.linspace(1e-3, 4.0, 4000), np.geomspace(4.0, 1e7, 600)[1:]])
STRICT_SLACK = 1e-12    # ρ ≤ 1 + this counts as |ρ| ≤ 1 (round-off of the eigenvalue solver)


# -- the methods on the undamped oscillator ------------------------------------------------------
@dataclass(frozen=True)
class AbmPece:
    """Adams–Bashforth–Moulton 4, PECE mode (the stepper :mod:`daebench.stepping.abm`, its
    coefficients): y_{n+1} = y_n + z[AM0 (y_n + z Σ AB_j y_{n−j}) + AM1 y_n + AM2 y_{n−1}
    + AM3 y_{n−2}] on y′ = λy, z = hλ, i.e. the characteristic polynomial
    ζ⁴ − c1 ζ³ − c2 ζ² − c3 ζ − c4 with c1 = 1 + z(AM0 + AM1) + z²AM0·AB0,
    c2 = z AM2 + z²AM0·AB1, c3 = z AM3 + z²AM0·AB2, c4 = z²AM0·AB3. The history is started by
    three RK4 steps, y_k = R(z)^k y_0 with R(z) = 1 + z + z²/2 + z³/6 + z⁴/24: this start
    seeds the parasitic roots, which decide the boundary near hω ≈ 0.93 (:meth:`log_growth`)."""

    name: str = "ABM4-PECE"

    def coefficients(self, z: np.ndarray) -> tuple[np.ndarray, ...]:
        a0 = abm.AM0
        return (1.0 + z * (a0 + abm.AM1) + z * z * a0 * abm.AB0, z * abm.AM2 + z * z * a0 * abm.AB1,
                z * abm.AM3 + z * z * a0 * abm.AB2, z * z * a0 * abm.AB3)

    def radius_z(self, z: complex) -> float:
        c1, c2, c3, c4 = self.coefficients(np.complex128(z))
        return float(np.abs(np.roots([1.0, -c1, -c2, -c3, -c4])).max())

    def radius(self, omega: float) -> float:
        return self.radius_z(1j * omega)

    def start_modes(self, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Roots ζ_k (len(omega) × 4) and the weights α_k of the RK4-started history
        (y3, y2, y1, y0) = Σ_k α_k (ζ_k³, ζ_k², ζ_k, 1), so that y_{3+m} = Σ_k α_k ζ_k^{3+m}."""
        z = 1j * np.asarray(omega, float)
        c1, c2, c3, c4 = self.coefficients(z)
        R = 1.0 + z + z**2 / 2.0 + z**3 / 6.0 + z**4 / 24.0
        roots = np.empty((z.size, 4), complex)
        alpha = np.empty((z.size, 4), complex)
        for i in range(z.size):
            C = np.array([[c1[i], c2[i], c3[i], c4[i]], [1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]], complex)
            lam, V = np.linalg.eig(C)
            roots[i] = lam
            alpha[i] = np.linalg.solve(V, np.array([R[i] ** 3, R[i] ** 2, R[i], 1.0])) * V[0]
        return roots, alpha


@dataclass(frozen=True)
class NewmarkMember:
    """A Newmark-family member (α_m, α_f, β, γ; force or acceleration averaging, as in
    :mod:`daebench.stepping.newmark`) on ẍ + ω²x = 0 with Ω = hω."""

    alpha_m: float
    alpha_f: float
    beta: float
    gamma: float
    accel_avg: bool = False
    name: str = "Newmark family"

    def matrix(self, omega: float) -> np.ndarray:
        """The amplification matrix: state (x, h v, h² a) [and h² ẍ with acceleration averaging]."""
        am, af, b, g, w2 = self.alpha_m, self.alpha_f, self.beta, self.gamma, omega * omega
        # unknowns u = (x1, v1, a1[, ẍ1]); rows: equation of motion, x update, v update[, ẍ1 = −Ω² x1]
        if not self.accel_avg:
            L = np.array([[(1 - af) * w2, 0.0, 1 - am], [1.0, 0.0, -b], [0.0, 1.0, -g]])
            R = np.array([[-af * w2, 0.0, -am], [1.0, 1.0, 0.5 - b], [0.0, 1.0, 1 - g]])
        else:
            L = np.array([[0.0, 0.0, 1 - am, -(1 - af)], [1.0, 0.0, -b, 0.0], [0.0, 1.0, -g, 0.0],
                          [w2, 0.0, 0.0, 1.0]])
            R = np.array([[0.0, 0.0, -am, af], [1.0, 1.0, 0.5 - b, 0.0], [0.0, 1.0, 1 - g, 0.0],
                          [0.0, 0.0, 0.0, 0.0]])
        return np.linalg.solve(L, R)

    def radius(self, omega: float) -> float:
        return float(np.abs(np.linalg.eigvals(self.matrix(omega))).max())


def method_of(integrator: Any) -> AbmPece | NewmarkMember | None:
    """The stability model of a built-in fixed-step integrator instance (None: not covered)."""
    if isinstance(integrator, BaumgarteABM4):
        return AbmPece()
    if isinstance(integrator, NewmarkFamily):
        c = integrator.coefficients()
        return NewmarkMember(c.alpha_m, c.alpha_f, c.beta, c.gamma, bool(c.accel_avg), type(integrator).__name__)
    return None


@functools.lru_cache(maxsize=64)
def _log_radius(method: AbmPece | NewmarkMember) -> np.ndarray:
    """ln ρ on :data:`OMEGA_GRID` (computed once per method)."""
    return np.log(np.maximum([method.radius(float(w)) for w in OMEGA_GRID], 1e-300))


@functools.lru_cache(maxsize=8)
def _abm_start_modes() -> tuple[np.ndarray, np.ndarray]:
    return AbmPece().start_modes(OMEGA_GRID)


def log_growth(method: AbmPece | NewmarkMember, steps: float, omega: float | None = None) -> np.ndarray:
    """ln of the amplitude factor of a mode after ``steps`` steps from the method's start, on
    :data:`OMEGA_GRID` (or at one Ω): for ABM4-PECE |y_n/y_0| from the RK4-started history
    (parasitic roots included); for the Newmark family, whose start a_0 = q̈_0 is consistent,
    n ln ρ(Ω)."""
    if isinstance(method, AbmPece):
        roots, alpha = method.start_modes(np.array([omega])) if omega is not None else _abm_start_modes()
        m = max(float(steps) - 3.0, 0.0)
        with np.errstate(over="ignore", divide="ignore"):
            logs = np.log(np.abs(alpha)) + m * np.log(np.abs(roots))  # per root, then a stable log-sum
            top = logs.max(axis=1, keepdims=True)
            val = np.abs(np.sum(alpha * np.exp(m * np.log(roots + 0j) - top), axis=1))
            out = top[:, 0] + np.log(np.maximum(val, 1e-300))
        return out
    if omega is not None:
        return np.array([steps * math.log(max(method.radius(omega), 1e-300))])
    return steps * _log_radius(method)


def strict_interval(method: AbmPece | NewmarkMember) -> float:
    """sup{Ω : ρ(ω') ≤ 1 for all ω' ≤ Ω} on :data:`OMEGA_GRID` (∞ if ρ ≤ 1 up to 1e7)."""
    bad = np.flatnonzero(_log_radius(method) > math.log1p(STRICT_SLACK))
    return float(OMEGA_GRID[bad[0]]) if bad.size else math.inf


def run_interval(method: AbmPece | NewmarkMember, steps: float, log_budget: float) -> float:
    """Ω*(n, G) = sup{Ω : growth over n steps ≤ G for all Ω' ≤ Ω} (∞ if never exceeded up to 1e7)."""
    bad = np.flatnonzero(log_growth(method, steps) > log_budget)
    if not bad.size:
        return math.inf
    i = int(bad[0])
    lo, hi = (float(OMEGA_GRID[i - 1]) if i else 0.0), float(OMEGA_GRID[i])
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if log_growth(method, steps, mid)[0] > log_budget:
            hi = mid
        else:
            lo = mid
    return lo


# -- the system at the start ----------------------------------------------------------------------
@dataclass
class Linearization:
    """Undamped frequencies ω_k [rad/s] at the start (ascending), the oscillation energy
    E_k [J] the start load gives each mode, and the run's energy scale [J]."""

    omega: np.ndarray
    seed_energy: np.ndarray
    energy_scale: float


def linearize(scene: Scene) -> Linearization:
    """Frequencies of K φ = ω² M φ at (q0, v0) (see the module docstring), with the tangent
    stiffness of M(q) q̈ − Q + C_qᵀλ at the start's consistent (q̈0, λ0):
    K = ∂(M q̈0)/∂q − ∂Q/∂q + ∂(C_qᵀλ0)/∂q (symmetric part), restricted to the null space of C_q
    (a pendulum's stiffness is all in the last term)."""
    sysm = build_system(scene)
    q0, v0 = sysm.initial_state()
    q0, v0 = np.asarray(q0, float), np.asarray(v0, float)
    prob = Problem(sysm)
    a0, lam0 = prob.acceleration(0.0, q0, v0)
    M = sysm.mass(q0)
    Kq, _ = sysm.force_jacobian(0.0, q0, v0)
    Kt = sysm.mass_jacobian_product(q0, a0) - Kq + prob.constraint_force_jacobian(0.0, q0, lam0)
    K = 0.5 * (Kt + Kt.T)
    Q0 = np.asarray(sysm.applied_force(0.0, q0, v0), float)
    if sysm.n_bilateral:
        N = sl.null_space(np.asarray(sysm.constraint_jacobian(0.0, q0)).reshape(sysm.n_bilateral, -1))
        M, K, Q0 = N.T @ M @ N, N.T @ K @ N, N.T @ Q0
    w2, phi = sl.eigh(K, M)                       # φᵀ M φ = I
    keep = w2 > 0.0
    omega = np.sqrt(w2[keep])
    f = phi[:, keep].T @ Q0
    scale = energy_scale(sysm, q0, v0)  # the driver's rule (core.energyscale)
    seed = np.maximum(f * f / (2.0 * omega * omega), (1e-16) ** 2 * scale)   # round-off seeds every mode
    return Linearization(omega, seed, scale)


def predict(method: AbmPece | NewmarkMember, lin: Linearization, t_trial: float) -> dict[str, float]:
    """Predicted h_max and the interval behind it: for each mode the fixed point
    h ω_k = Ω*(t_trial/h, G_k); the smallest h over the modes."""
    best = {"h_pred": math.inf, "interval": math.inf, "omega_limiting": float(lin.omega.max(initial=0.0))}
    for w, e0 in zip(lin.omega[::-1], lin.seed_energy[::-1]):
        log_g = 0.5 * math.log(DIVERGENCE_ENERGY * lin.energy_scale / e0)
        h = run_interval(method, 500.0, log_g) / w
        for _ in range(8):                        # n = t_end/h depends on h: iterate to the fixed point
            if not math.isfinite(h):
                break
            h_new = run_interval(method, max(t_trial / h, 1.0), log_g) / w
            if abs(h_new - h) <= 1e-6 * h:
                h = h_new
                break
            h = h_new
        if h < best["h_pred"]:
            best = {"h_pred": h, "interval": h * w, "omega_limiting": float(w)}
    return best


def divergence_time(method: AbmPece | NewmarkMember, lin: Linearization, h: float) -> float:
    """Predicted time [s] at which a run at fixed step h crosses the divergence threshold in
    free flight: min_k h ln G_k / ln ρ(h ω_k) (∞ if no mode grows)."""
    best = math.inf
    for w, e0 in zip(lin.omega, lin.seed_energy):
        growth = math.log(max(method.radius(h * w), 1e-300))
        if growth > 0.0:
            best = min(best, h * 0.5 * math.log(DIVERGENCE_ENERGY * lin.energy_scale / e0) / growth)
    return best


# -- measured: bisection on whole runs --------------------------------------------------------------
@dataclass(frozen=True)
class Task:
    """One (integrator setting, scene) bisection."""

    scene: Scene
    integrator: str
    settings: tuple[tuple[str, Any], ...]
    label: str
    n: int | None
    h_min: float
    h_max: float
    tol: float
    t_trial: float
    run_cap: float | None = None


def run_is_stable(scene: Scene, integrator: str, settings: dict[str, Any], h: float, t_trial: float | None = None,
                  run_cap: float | None = None) -> tuple[bool, str]:
    """(completed?, status) of one fixed-step run at h (h_contact = h) to ``t_trial`` (the
    scene's t_end when None)."""
    integ = make_integrator(integrator, {**settings, "h": h, "h_contact": h})
    if t_trial is not None:
        scene = scene.with_overrides({"t_end": t_trial})
    try:
        _, res = run_scene(scene, integ, write=False, force=True, run_cap=run_cap)
    except RunTimeout:
        return False, "timeout"
    return res.status == "completed", res.status


def bisect(task: Task, report: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Largest stable h of one task: the bracket [h_stable, h_unstable] (NaN where the
    bounds were not crossed) and the status of the run at h_unstable."""
    s = dict(task.settings)
    runs = 1
    ok, status = run_is_stable(task.scene, task.integrator, s, task.h_max, task.t_trial, task.run_cap)
    lo, hi, bad = math.nan, math.nan, ""
    if ok:
        lo = task.h_max
    else:
        hi, bad = task.h_max, status
        runs += 1
        ok, status = run_is_stable(task.scene, task.integrator, s, task.h_min, task.t_trial, task.run_cap)
        if ok:
            lo = task.h_min
        else:
            hi, bad = task.h_min, status
    while math.isfinite(lo) and math.isfinite(hi) and hi / lo > 1.0 + task.tol:
        mid = math.sqrt(lo * hi)
        runs += 1
        ok, status = run_is_stable(task.scene, task.integrator, s, mid, task.t_trial, task.run_cap)
        if ok:
            lo = mid
        else:
            hi, bad = mid, status
    if report is not None:
        report(f"{task.label:<34s} N = {task.n!s:>4}: h_max in [{lo:.4g}, {hi:.4g}] s ({runs} runs)")
    return {"h_stable": lo, "h_unstable": hi, "unstable_status": bad, "runs": runs}


def _solve(task: Task) -> dict[str, Any]:
    return bisect(task, lambda line: print(line, file=sys.stderr, flush=True))


def trial_length(scene: Scene, lin: Linearization, periods: float) -> float:
    """The run length of one trial: ``periods`` periods of the fastest mode at the start,
    capped at the scene's t_end. With 80 periods (≈ 500 rad) a run near ABM4-PECE's boundary
    takes ≈ 530 steps: beyond it the parasitic root grows ≥ 3.6 % a step (e^18 over the run),
    below it the principal root's weak growth (≤ 0.7 % a step, e^3.4) cannot reach the
    threshold — so the stable steps form one interval and the boundary is the method's.
    Longer runs add a band of weak instability below that boundary (:func:`divergence_time`
    predicts when it ends a whole run)."""
    w = float(lin.omega.max(initial=0.0))
    return scene.t_end if w <= 0.0 else min(scene.t_end, periods * 2.0 * math.pi / w)


@dataclass(frozen=True)
class Bisection:
    """How the largest stable step is searched: the key N stands for (``n_key``), the trial
    length (``t_end`` [s], or None: ``periods`` periods of the fastest mode,
    :func:`trial_length`), the bisection bounds ``h_min``, ``h_max`` [s] and relative
    bracket width ``tol`` (the upper bound is lowered to t_trial/:data:`MIN_STEPS`: a trial
    of fewer steps shows no instability), worker processes (``jobs``: one bisection per
    task, the tasks in parallel), the wall-time cap of one run (``run_cap`` [s]), and a step
    drawn as a line on the figure (``mark_h`` [s])."""

    n_key: str = "discretization.n"
    t_end: float | None = None
    periods: float = DEFAULT_PERIODS
    h_min: float = 1e-6
    h_max: float = 1e-2
    tol: float = 0.02
    jobs: int = 1
    run_cap: float | None = None
    mark_h: float | None = None


def stability_map(scene: Scene, methods: Sequence[tuple[str, dict[str, Any]]], n_values: Iterable[int] | None,
                  search: Bisection = Bisection(), progress: Callable[[str], None] | None = None) -> pd.DataFrame:
    """The stability table: one row per (integrator setting, N).

    Parameters
    ----------
    scene : the case
    methods : (integrator name, settings) pairs, e.g. ``("baumgarte", {"delta": 10, "epsilon": 50})``
    n_values : values of ``search.n_key`` to sweep (None: the scene's own)
    search : trial length, bisection bounds and width, workers, run cap (:class:`Bisection`)

    Returns
    -------
    DataFrame with columns integrator, settings, label, N, omega_max [rad/s], method,
    interval_strict, interval [hω], h_pred, h_stable, h_unstable [s], unstable_status,
    runs, t_trial [s], agrees (h_pred within one bisection step of the measured bracket).
    """
    n_key, t_end, periods, h_min, h_max, tol, jobs, run_cap = (
        search.n_key, search.t_end, search.periods, search.h_min, search.h_max, search.tol, search.jobs, search.run_cap)
    scenes = []
    for n in (list(n_values) if n_values else [None]):
        sc = scene.with_overrides({n_key: n}) if n is not None else scene
        lin = linearize(sc)
        te = min(t_end, sc.t_end) if t_end is not None else trial_length(sc, lin, periods)
        scenes.append((n, sc, lin, te))
    tasks, meta = [], []
    for name, settings in methods:
        integ = make_integrator(name, settings)
        if not integ.capabilities.fixed_step or integ.adaptive:
            raise ValueError(f"integrator '{integ.name}' does not take fixed steps; the stability map bisects h")
        label = name + ("" if not settings else " " + ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                                                               for k, v in settings.items()))
        meth = method_of(integ)
        strict = strict_interval(meth) if meth is not None else math.nan
        for n, sc, lin, te in scenes:
            pred = predict(meth, lin, te) if meth is not None else {"h_pred": math.nan, "interval": math.nan}
            top = min(h_max, te / MIN_STEPS)       # never fewer than MIN_STEPS steps in a trial
            tasks.append(Task(sc, name, tuple(settings.items()), label, n, min(h_min, 0.5 * top), top, tol, te,
                              run_cap))
            meta.append({"integrator": name, "settings": dict(settings), "label": label, "N": n,
                         "omega_max": float(lin.omega.max(initial=0.0)), "method": getattr(meth, "name", "n/a"),
                         "interval_strict": strict, "interval": pred["interval"], "h_pred": pred["h_pred"]})
    if jobs > 1 and len(tasks) > 1:
        ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
        with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
            found = list(pool.map(_solve, tasks))
    else:
        found = [bisect(t, progress) for t in tasks]
    rows = []
    for m, f, t in zip(meta, found, tasks):
        rows.append({**m, **f, "t_trial": t.t_trial, "h_top": t.h_max, "tol": tol,
                     "agrees": agrees(m["h_pred"], f, tol, t.h_max)})
    return pd.DataFrame(rows)


def agrees(h_pred: float, found: dict[str, Any], tol: float, h_max: float) -> bool:
    """Whether the prediction lies within one bisection step (a factor 1 + tol) of the
    measured bracket; an unbounded prediction agrees when no instability was found below h_max."""
    lo, hi = found["h_stable"], found["h_unstable"]
    if not math.isfinite(h_pred):
        return bool(math.isfinite(lo) and lo >= h_max)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return False
    return lo / (1.0 + tol) <= h_pred <= hi * (1.0 + tol)


def parse_method(text: str) -> tuple[str, dict[str, Any]]:
    """``"baumgarte:delta=10,epsilon=50"`` → ("baumgarte", {"delta": 10.0, "epsilon": 50.0}),
    validated and typed by the integrator's own settings."""
    name, _, rest = text.partition(":")
    pairs = [kv for kv in rest.split(",") if kv.strip()]
    if any("=" not in kv or not kv.split("=", 1)[0].strip() for kv in pairs):
        bad = next(kv for kv in pairs if "=" not in kv or not kv.split("=", 1)[0].strip())
        raise ParamError(f"--method '{text}': '{bad}' is not name=value; write integrator:name=value,name=value, "
                         f"e.g. hht:alpha=-0.1")
    raw = dict(kv.split("=", 1) for kv in pairs)
    integ = make_integrator(name.strip(), {k.strip(): v.strip() for k, v in raw.items()})
    return integ.name, {k.strip(): integ.settings[k.strip()] for k in raw}


@dataclass
class StabilityResult:
    """The table, the files written, and what a reader is told first (``heading``: what was
    measured) and last (``summary``: how many rows agree, the runs and their wall time)."""

    table: pd.DataFrame
    files: list[Path]
    markdown: str
    heading: str
    summary: str


def _whole_numbers(text: str, key: str) -> list[int]:
    """``"3,5,7"`` → [3, 5, 7]; a ValueError that says what --n takes."""
    out = []
    for x in (x.strip() for x in text.split(",") if x.strip()):
        if not x.isdigit() or len(x) > 6:
            raise ValueError(f"--n takes whole numbers for {key}, comma-separated, e.g. --n 3,5,7 ('' = the "
                             f"scene's own, auto = {','.join(map(str, DEFAULT_N))}); got {x[:20]!r}")
        out.append(int(x))
    return out


def run_stability(scene: Scene, methods: Sequence[str] = DEFAULT_METHODS, n: str = "auto",
                  search: Bisection = Bisection(), out: Path | None = None,
                  name: str | None = None, progress: Callable[[str], None] | None = None) -> StabilityResult:
    """The stability map of ``scene`` (:func:`stability_map`) with its files under ``out``
    (default results/stability; ``<name or scene-stability>``.parquet, .csv, .md, .png:
    :mod:`.stability_report`), the folder proved writable and the name a plain file-name
    stem before any run.

    ``methods`` are ``integrator:setting=value,...`` texts (:func:`parse_method`); ``n``
    the values of ``search.n_key``, comma-separated ('': the scene's own; 'auto':
    :data:`DEFAULT_N` when the scene has that key).

    Raises
    ------
    ParamError
        For a bad method, N or bound, before anything runs.
    """
    try:
        parsed = [parse_method(m) for m in methods]
        if n.strip() == "auto":
            n = ",".join(map(str, DEFAULT_N)) if search.n_key in scene.schema else ""
        ns = _whole_numbers(n, search.n_key) if n.strip() else None
    except ValueError as exc:
        raise ParamError(str(exc)) from None
    if ns is not None and search.n_key not in scene.schema:
        raise ParamError(f"scene '{scene.name}' has no key '{search.n_key}' to vary; give --n '' or --n-key")
    if not (0.0 < search.h_min < search.h_max) or not (0.0 < search.tol < 1.0) or search.jobs < 1 \
            or (search.t_end is not None and search.t_end <= 0.0) or search.periods <= 0.0:
        raise ParamError("need 0 < --h-min < --h-max, 0 < --tol < 1, --jobs ≥ 1, --t-end ≥ 0 and --periods > 0")
    stem = check_name(name if name is not None else f"{scene.name}-stability", "--name")
    out = ensure_writable_dir(Path(out) if out is not None else results_dir() / "stability", "output folder (--out)",
                              stem + ".parquet")
    te = min(search.t_end, scene.t_end) if search.t_end is not None else None
    search = replace(search, t_end=te)
    length = f"{te:g} s" if te is not None else f"{search.periods:g} periods of the fastest mode"
    heading = (f"stability map of {scene.name}: {len(parsed)} settings × {len(ns or [None])} N, trials of {length}, "
               f"h in [{search.h_min:g}, {search.h_max:g}] s to {search.tol:.0%}, {search.jobs} job(s)")
    if progress is not None:
        progress(heading)
    wall0 = time.perf_counter()
    try:
        df = stability_map(scene, parsed, ns, search, progress)
    except ValueError as exc:
        raise ParamError(str(exc)) from None
    extra = ", ".join(f"{k}={v}" for k, v in scene.changes().items())
    title = (f"{scene.name}{' (' + extra + ')' if extra else ''}: largest stable step, trials of {length}, "
             f"bisection to {search.tol:.0%}")
    files = stability_report.write(df, out, stem, title, search.h_max, search.mark_h)
    summary = (f"{int(df['agrees'].sum())}/{len(df)} rows agree with the prediction within one bisection step; "
               f"{int(df['runs'].sum())} runs in {time.perf_counter() - wall0:.1f} s")
    return StabilityResult(df, files, stability_report.markdown(df, search.h_max), heading, summary)
