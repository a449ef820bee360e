"""The IVP test set's own accuracy measures for its mechanical cases (``andrews``, ``crank``,
``caraxis``), and the digits of daebench's references against its published solutions.

F. Mazzia, C. Magherini, *Test Set for IVP Solvers*, release 2.4 (Univ. Bari, 2008)
scores a run by the number of correct digits at the end time against its published
reference solution y_ref, over the components it names for each problem:

    scd   = −log10 max_i |y_i − y_ref,i| / |y_ref,i|                (significant correct digits)
    mescd = −log10 max_i |y_i − y_ref,i| / (atol/rtol + |y_ref,i|)  (mixed error, release 2.4)

(the mixed form counts absolute digits for components smaller than atol/rtol). For a
fixed-step run, which has no tolerances, we take atol/rtol = 1.

The references below are the test set's, copied digit for digit with their source. Our
variables map to the test set's as documented in :mod:`daebench.models.crank` and
:mod:`daebench.models.caraxis` (caraxis: y9, y10 = −λ1, −λ2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from daebench.models import build_system
from daebench.harness.running.runner import make_integrator, run_scene
from daebench.core.scene import Scene
from daebench.models.scenes import load_scene


@dataclass(frozen=True)
class Reference:
    """A published reference: the scored components of the test set's y at t_end."""

    case: str
    t_end: float
    names: tuple[str, ...]
    values: np.ndarray
    source: str


REFERENCES: dict[str, Reference] = {
    # andrews.f, subroutine solut (andsoln): PSIDE at rtol = atol = 1e-14 on a Cray C90,
    # t = 0.03; the seven angles (the positions; the velocities agree with every solver to
    # 7.3–10 digits only, tests/models/test_andrews.py).
    "andrews": Reference(
        "andrews", 0.03, ("beta", "theta", "gamma", "phi", "delta", "omega", "epsilon"),
        np.array([0.1581077119629904e+2, -0.1575637105984298e+2, 0.4082224013073101e-1,
                  -0.5347301163226948e+0, 0.5244099658805304e+0, 0.5347301163226948e+0,
                  0.1048080741042263e+1]),
        "Mazzia & Magherini, Test Set for IVP Solvers 2.4, andrews.f solut (PSIDE, rtol = atol = 1e-14)"),
    # crank.f, subroutine solut (= deTestSet's cranksoln): MEBDFI at rtol = atol = 1e-14,
    # initial step 1e-12, t = 0.1 (176 556 accepted steps). The test set scores the first
    # seven components, the positions (deTestSet ex_crank.R: "first seven components").
    "crank": Reference(
        "crank", 0.1, ("phi1", "phi2", "x3", "q1", "q2", "q3", "q4"),
        np.array([0.1500000000000104e+002, -0.3311734988256260e+000, 0.1697373328427860e+000,
                  0.1893192899613509e-003, 0.2375751249879174e-004, -0.5323896770569702e-005,
                  -0.8363313279112129e-005]),
        "Mazzia & Magherini, Test Set for IVP Solvers 2.4, crank.f solut (MEBDFI, rtol = atol = 1e-14)"),
    # caraxis.f, subroutine solut (= deTestSet's reference("caraxis")), t = 3: all ten
    # components y = (xl, yl, xr, yr, ẋl, ẏl, ẋr, ẏr, λ1, λ2) in the test set's signs.
    "caraxis": Reference(
        "caraxis", 3.0, ("xl", "yl", "xr", "yr", "vxl", "vyl", "vxr", "vyr", "lambda1", "lambda2"),
        np.array([0.493455784275402809122e-1, 0.496989460230171153861, 0.104174252488542151681e1,
                  0.373911027265361256927, -0.770583684040972357970e-1, 0.744686658723778553466e-2,
                  0.175568157537232222276e-1, 0.770341043779251976443, -0.473688659084893324729e-2,
                  -0.110468033125734368808e-2]),
        "Mazzia & Magherini, Test Set for IVP Solvers 2.4, caraxis.f solut"),
}


def scd(y: np.ndarray, ref: np.ndarray) -> float:
    """Significant correct digits −log10 max |y − ref|/|ref| (∞ for an exact match)."""
    err = np.max(np.abs(np.asarray(y, float) - ref) / np.abs(ref))
    return math.inf if err == 0.0 else -math.log10(err)


def mescd(y: np.ndarray, ref: np.ndarray, ratio: float = 1.0) -> float:
    """Mixed-error significant digits −log10 max |y − ref|/(ratio + |ref|), ratio = atol/rtol."""
    err = np.max(np.abs(np.asarray(y, float) - ref) / (ratio + np.abs(ref)))
    return math.inf if err == 0.0 else -math.log10(err)


def component_digits(y: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Per-component −log10 of the relative error (capped at 17 digits)."""
    rel = np.abs(np.asarray(y, float) - ref) / np.abs(ref)
    return -np.log10(np.maximum(rel, 1e-17))


def reference_components(case: str, system: Any, t: float, q: np.ndarray, v: np.ndarray,
                    lam: np.ndarray | None) -> np.ndarray:
    """Our state at t in the test set's scored components (see :data:`REFERENCES`)."""
    if case in ("crank", "andrews"):
        return np.asarray(q, float).copy()
    if case == "caraxis":
        return system.test_set_vector(t, q, v, lam)
    raise KeyError(f"no IVP test-set reference for case '{case}'; have {', '.join(REFERENCES)}")


#: the position components of each case (what a reference must match to 9 digits)
POSITIONS = {"andrews": 7, "crank": 7, "caraxis": 4}


def reference_digits(case: str, history: Any) -> dict[str, float]:
    """Significant digits of a reference history's final row against the published solution,
    per position component (the observables of these scenes are their positions).

    Raises
    ------
    KeyError
        For a case without a published solution.
    """
    ref = REFERENCES[case]
    names = ref.names[:POSITIONS[case]]
    last = history.iloc[-1]
    if abs(float(last["t"]) - ref.t_end) > 1e-9 * ref.t_end:
        raise ValueError(f"the history ends at t = {float(last['t']):g} s, the published solution is at {ref.t_end:g} s")
    y = np.array([float(last[c]) for c in names])
    return {c: float(d) for c, d in zip(names, component_digits(y, ref.values[:len(names)]))}


@dataclass
class Score:
    """One run scored by the test set's measures."""

    case: str
    integrator: str
    settings: dict[str, Any]
    status: str
    message: str
    scd: float
    mescd: float
    digits: dict[str, float] = field(default_factory=dict)
    y: np.ndarray = field(default_factory=lambda: np.zeros(0))
    wall_s: float = math.nan
    steps: int = 0
    energy_residual: float = math.nan

    def row(self) -> dict[str, Any]:
        """A flat record (for a table)."""
        return {"case": self.case, "integrator": self.integrator,
                **{k: v for k, v in self.settings.items() if k in ("h", "rtol", "atol", "alpha", "rho_inf")},
                "status": self.status, "scd": self.scd, "mescd": self.mescd, "steps": self.steps,
                "wall_s": self.wall_s, "energy_residual": self.energy_residual}


def score(case: str | Scene, integrator: str = "ida", *, multipliers: str = "integrator",
          **settings: Any) -> Score:
    """Run ``case`` (``andrews``, ``crank`` or ``caraxis``, or a Scene of one) with ``integrator`` and
    score the state at t_end by the test set's scd and mescd.

    Parameters
    ----------
    case : the case, run to its scene's t_end (which must be the reference's)
    integrator, settings : e.g. ``"ida", rtol=1e-10, atol=1e-10`` or ``"hht", h=1e-4``
    multipliers : where scored multipliers (caraxis λ) come from: ``"integrator"`` — the
        integrator's own λ at t_end, as the test set scores its solvers' algebraic
        variables — or ``"consistent"`` — λ from the index-1 solve at (t_end, q, q̇).

    Returns
    -------
    Score
        scd and mescd over the reference's components (−inf when the run did not reach
        t_end), per-component digits, steps, wall time and the run's energy residual.
    """
    sc = case if isinstance(case, Scene) else load_scene(case)
    ref = REFERENCES.get(sc.model)
    if ref is None:
        raise KeyError(f"no IVP test-set reference for model '{sc.model}'; have {', '.join(REFERENCES)}")
    if abs(sc.t_end - ref.t_end) > 1e-12 * ref.t_end:
        raise ValueError(f"the {ref.case} reference is at t = {ref.t_end:g} s; the scene ends at {sc.t_end:g} s")
    if multipliers not in ("integrator", "consistent"):
        raise ValueError(f"multipliers must be 'integrator' or 'consistent', got {multipliers!r}")
    integ = make_integrator(integrator, settings)
    rec, res = run_scene(sc, integ, write=False)
    sysm = build_system(sc)
    fin = res.final
    if res.status != "completed" or fin is None or abs(fin.t - ref.t_end) > 1e-9 * ref.t_end:
        return Score(ref.case, integ.name, dict(integ.settings), res.status, res.message, -math.inf, -math.inf,
                     wall_s=rec.wall_s, steps=rec.counters.get("steps", 0), energy_residual=rec.energy_residual)
    lam = fin.lam[:sysm.n_bilateral] if multipliers == "integrator" and fin.lam.size >= sysm.n_bilateral else None
    y = reference_components(ref.case, sysm, fin.t, fin.q, fin.v, lam)
    s = integ.settings
    ratio = float(s["atol"]) / float(s["rtol"]) if s.get("adaptive") else 1.0  # fixed step: no tolerances
    return Score(ref.case, integ.name, dict(s), res.status, res.message, scd(y, ref.values),
                 mescd(y, ref.values, ratio), dict(zip(ref.names, component_digits(y, ref.values))), y,
                 rec.wall_s, rec.counters.get("steps", 0), rec.energy_residual)
