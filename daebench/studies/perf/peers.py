"""Peers measured in the same run: Exudyn (generalized-α on the pendulum, ANCF cables on
the hinged beam) and the example plugin written against daebench's compiled interfaces."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from daebench.models.pendulum import exact_theta
from daebench.harness.running.runner import run_scene
from daebench.models.scenes import load_scene
from daebench.studies.perf import probes
from daebench.studies.perf.settings import PerfSettings


def _exu_settings(exu, T: float, h: float, rho: float):
    sim = exu.SimulationSettings()
    sim.timeIntegration.numberOfSteps = int(round(T / h))
    sim.timeIntegration.endTime = T
    sim.timeIntegration.generalizedAlpha.spectralRadius = rho
    sim.timeIntegration.newton.useModifiedNewton = True
    sim.timeIntegration.verboseMode = 0
    sim.solution.file.write = False
    sim.show.computationTime = False
    sim.show.statistics = False
    return sim


def exudyn_pendulum(T: float, h: float, rho: float, theta0_deg: float = 30.0) -> tuple[float, float]:
    """(wall time of SolveDynamic, final θ [rad]) of Exudyn's generalized-α on the Cartesian pendulum."""
    import exudyn as exu  # lazy: exudyn, an optional extra
    from exudyn.itemInterface import (  # lazy: as above
        DistanceConstraint, LoadCoordinate, MarkerNodeCoordinate, MarkerNodePosition, MassPoint2D, NodePoint2D,
        NodePointGround)

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    th, l, m, g = math.radians(theta0_deg), 1.0, 1.0, 9.81
    nG = mbs.AddNode(NodePointGround(referenceCoordinates=[0, 0, 0]))
    n = mbs.AddNode(NodePoint2D(referenceCoordinates=[l * math.sin(th), -l * math.cos(th)]))
    mbs.AddObject(MassPoint2D(mass=m, nodeNumber=n))
    mG = mbs.AddMarker(MarkerNodePosition(nodeNumber=nG))
    mB = mbs.AddMarker(MarkerNodePosition(nodeNumber=n))
    mbs.AddObject(DistanceConstraint(markerNumbers=[mG, mB], distance=l))
    mc = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=n, coordinate=1))
    mbs.AddLoad(LoadCoordinate(markerNumber=mc, load=-m * g))
    mbs.Assemble()
    sim = _exu_settings(exu, T, h, rho)
    _, w = probes.wall(lambda: exu.SolveDynamic(mbs, sim))
    p = mbs.GetNodeOutput(n, exu.OutputVariableType.Position)
    return w, math.atan2(p[0], -p[1])


def exudyn_ancf_beam(T: float, h: float, rho: float, ne: int, scene) -> tuple[float, float]:
    """(wall, tip angle [rad] at T) of a hinged ANCF cable (same L, EI, ρA, EA, start angle, g)."""
    import exudyn as exu  # lazy: exudyn, an optional extra
    from exudyn.itemInterface import (  # lazy: as above
        CoordinateConstraint, LoadMassProportional, MarkerBodyMass, MarkerNodeCoordinate, NodePoint2DSlope1,
        NodePointGround, ObjectANCFCable2D, ObjectGround)

    L, A, I = scene["beam.length"], scene["beam.area"], scene["beam.inertia"]
    rho_m, E, g = scene["beam.density"], scene["beam.modulus"], scene["gravity.g"]
    th = math.radians(scene["start.theta_deg"])
    c, s_ = math.cos(th), math.sin(th)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    nodes = [mbs.AddNode(NodePoint2DSlope1(referenceCoordinates=[k * L / ne * c, k * L / ne * s_, c, s_]))
             for k in range(ne + 1)]
    for k in range(ne):
        o = mbs.AddObject(ObjectANCFCable2D(length=L / ne, massPerLength=rho_m * A,
                                            bendingStiffness=E * I, axialStiffness=E * A,
                                            nodeNumbers=[nodes[k], nodes[k + 1]]))
        mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=o)),
                                         loadVector=[0, -g, 0]))
    mbs.AddObject(ObjectGround())
    nG = mbs.AddNode(NodePointGround(referenceCoordinates=[0, 0, 0]))
    mG = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nG, coordinate=0))
    for k in (0, 1):  # the hinge: root position fixed, slope free
        mbs.AddObject(CoordinateConstraint(markerNumbers=[mG, mbs.AddMarker(MarkerNodeCoordinate(
            nodeNumber=nodes[0], coordinate=k))]))
    mbs.Assemble()
    sim = _exu_settings(exu, T, h, rho)
    _, w = probes.wall(lambda: exu.SolveDynamic(mbs, sim))
    p = mbs.GetNodeOutput(nodes[-1], exu.OutputVariableType.Position)
    return w, math.atan2(p[1], p[0])


def _cost_at(errs: list[float], walls: list[float], target: float) -> float:
    """Wall time at error ``target`` on the log–log work–precision line (interpolated)."""
    e, w = np.log(np.array(errs)), np.log(np.array(walls))
    ok = np.isfinite(e) & np.isfinite(w)
    e, w = e[ok], w[ok]
    if len(e) < 2:
        return math.nan
    order = np.argsort(e)
    return float(np.exp(np.interp(math.log(target), e[order], w[order])))


def _pendulum_pair(s: PerfSettings, integrator: str, opts: dict[str, Any], rho: float) -> dict[str, Any]:
    """``integrator`` against Exudyn's generalized-α on the Cartesian pendulum (same h, ρ∞),
    both timed by CPU time in this process, in ``s.peer_rounds`` rounds that run each side
    back to back (pairing keeps the ratio meaningful while the machine's speed drifts).

    Per step is the slope between two run lengths, T/4 and T: (cost(T) − cost(T/4)) / (steps
    between), which leaves out what each side pays once per run (ours: scene → model → phase
    → history table; Exudyn: SolveDynamic's initialisation). The ratio quoted is the median
    of the rounds' slope ratios; the whole-run ratio (each side's whole call at T — ours
    ``run_scene``, Exudyn building the system and ``SolveDynamic`` — per step) is given beside it."""
    T, h = s.pendulum_T, s.pendulum_h
    long_, short = (load_scene("pendulum", [f"t_end={tt}", f"output.dt={tt / 10}"]) for tt in (T, T / 4))
    run_long, run_short = ((lambda sc=sc: run_scene(sc, integrator, opts, write=False)) for sc in (long_, short))
    run_long()  # compiled, cached
    exudyn_pendulum(min(T, 0.01), h, rho)
    slope, whole, us, exu_us = [], [], [], []
    for _ in range(s.peer_rounds):
        (rec, res), c_long = probes.cpu(run_long)
        (rec_s, _), c_short = probes.cpu(run_short)
        (_, th_e), e_long = probes.cpu(lambda: exudyn_pendulum(T, h, rho))
        _, e_short = probes.cpu(lambda: exudyn_pendulum(T / 4, h, rho))
        steps, steps_s = rec.counters["steps"], rec_s.counters["steps"]
        n_exu, n_exu_s = round(T / h), round(T / 4 / h)
        o, e = (c_long - c_short) / (steps - steps_s), (e_long - e_short) / (n_exu - n_exu_s)
        slope.append(o / e)
        whole.append((c_long / steps) / (e_long / n_exu))
        us.append(1e6 * o)
        exu_us.append(1e6 * e)
    th_exact = float(exact_theta(T, math.radians(30.0)))
    ours_err = abs(math.radians(float(res.history["theta_deg"].iloc[-1])) - th_exact)
    exu_err = abs(th_e - th_exact)
    return {"T": T, "h": h, "rho_inf": rho, "steps": steps, "rounds": s.peer_rounds,
            "ratio_ours_over_exudyn": float(np.median(slope)),
            "ratio_range": [float(min(slope)), float(max(slope))],
            "whole_run_ratio": float(np.median(whole)),
            "ours_us_per_step": float(np.median(us)), "exudyn_us_per_step": float(np.median(exu_us)),
            "ours_theta_err": ours_err, "exudyn_theta_err": exu_err,
            "error_ratio_ours_over_exudyn": ours_err / exu_err if exu_err > 0 else math.nan,
            "newton_per_step": rec.counters["newton_iterations"] / steps}


def pendulum_vs_exudyn(s: PerfSettings, alpha: float = -0.15) -> dict[str, Any]:
    """hht (α, GGL) against Exudyn's generalized-α at ρ∞ = (1 + α)/(1 − α) (:func:`_pendulum_pair`)."""
    rho = (1 + alpha) / (1 - alpha)
    return {**_pendulum_pair(s, "hht", {"h": s.pendulum_h, "alpha": alpha}, rho), "alpha": alpha}


def exudyn_compare(s: PerfSettings) -> dict[str, Any]:
    try:
        import exudyn  # lazy: exudyn, an optional extra
    except ImportError:
        return {"available": False, "note": "exudyn not installed (pip install 'daebench[exudyn]')"}
    out: dict[str, Any] = {"available": True, "version": exudyn.__version__}
    alpha = -0.15
    rho = (1 + alpha) / (1 - alpha)
    out["pendulum"] = pendulum_vs_exudyn(s, alpha)
    out["genalpha"] = genalpha_vs_exudyn(s, out["pendulum"]["rho_inf"])
    # -- flexible beam, equal accuracy -------------------------------------------------------
    # Two of our discretizations against ANCF × ne: the modal one of beam-impact, and the
    # like-for-like one (ne Hermite elements with axial stretch, as the ANCF cable has).
    T, ne = s.beam_T, s.ancf_elements
    base = ["effects.contact=false", f"t_end={T}", f"output.dt={T / 10}"]
    models = {"modes": ("hub-beam modes N=5 (n=6), inextensible", []),
              "fem": (f"hub-beam FEM × {ne} Hermite elements, axial on",
                      ["discretization.kind=fem", f"discretization.n={ne}", "effects.axial=true"])}
    scenes = {k: load_scene("beam-impact", base + sets) for k, (_, sets) in models.items()}

    def ours(key, hh):
        (rec, res), w = probes.wall(lambda: run_scene(scenes[key], "hht", {"h": hh, "alpha": alpha}, write=False))
        last = res.history.iloc[-1]
        return w, math.atan2(float(last["tip_y"]), float(last["tip_x"]))

    refs = {}
    for k in models:
        ours(k, s.beam_hs[0])  # warm
        refs[k] = ours(k, s.beam_ref_h)[1]
    _, ref_e = exudyn_ancf_beam(T, s.beam_ref_h, rho, ne, scenes["modes"])
    rows = []
    for hh in s.beam_hs:
        row: dict[str, Any] = {"h": hh}
        for k in models:
            wo, tho = ours(k, hh)
            row[f"{k}_wall_s"], row[f"{k}_err"] = wo, abs(tho - refs[k])
        we, the = exudyn_ancf_beam(T, hh, rho, ne, scenes["modes"])
        row["exudyn_wall_s"], row["exudyn_err"] = we, abs(the - ref_e)
        row["fem_over_exudyn_per_step"] = row["fem_wall_s"] / we
        rows.append(row)
    beam: dict[str, Any] = {"T": T, "alpha": alpha, "rho_inf": rho, "rows": rows,
                            "models": {k: v[0] for k, v in models.items()},
                            "exudyn_model": f"ANCFCable2D × {ne} elements", "ref_tip_angle_exudyn": ref_e}
    ce_errs, ce_walls = [r["exudyn_err"] for r in rows], [r["exudyn_wall_s"] for r in rows]
    for k in models:
        errs = [r[f"{k}_err"] for r in rows] + ce_errs
        pos = [e for e in errs if e > 0]
        target = float(np.exp(np.mean(np.log(pos)))) if pos else math.nan  # inside both lines' ranges
        co = _cost_at([r[f"{k}_err"] for r in rows], [r[f"{k}_wall_s"] for r in rows], target)
        ce = _cost_at(ce_errs, ce_walls, target)
        beam[k] = {"target_err": target, "ours_wall_at_target": co, "exudyn_wall_at_target": ce,
                   "ratio_ours_over_exudyn": co / ce if ce == ce and ce > 0 else math.nan,
                   "ref_tip_angle": refs[k]}
    out["beam"] = beam
    return out


def genalpha_vs_exudyn(s: PerfSettings, rho: float = 0.74) -> dict[str, Any]:
    """``genalpha`` (index 3, as Exudyn's) against Exudyn's generalized-α at the same ρ∞
    (:func:`_pendulum_pair`)."""
    return _pendulum_pair(s, "genalpha", {"h": s.pendulum_h, "rho_inf": rho}, rho)


def _plugin_classes():
    """The example plugins from the repository's tests/plugin_pkg (None when daebench is
    not run from a checkout)."""
    root = Path(__file__).resolve().parents[3] / "tests" / "plugin_pkg"
    if not (root / "daebench_verlet").is_dir():
        return None
    if str(root) not in sys.path:
        sys.path.insert(0, str(root))
    from daebench_verlet import Verlet  # lazy: the example plugin, importable once its folder is on sys.path
    from daebench_verlet.compiled import CompiledVerlet  # lazy: as above

    return Verlet, CompiledVerlet


def compiled_plugin(s: PerfSettings) -> dict[str, Any]:
    """Per-step cost on the pendulum (same h, best of 3) of the example plugin written
    against the compiled interfaces, beside the built-ins and its plain-Python twin."""
    classes = _plugin_classes()
    if classes is None:
        return {"available": False, "note": "tests/plugin_pkg not found (run from a checkout)"}
    Verlet, CompiledVerlet = classes
    T, h = s.pendulum_T, s.pendulum_h
    sc = load_scene("pendulum", [f"t_end={T}", f"output.dt={T / 10}"])
    rows = {}
    for label, make in (("verlet-compiled (plugin)", lambda: CompiledVerlet(h=h)),
                        ("verlet (plugin, plain Python)", lambda: Verlet(h=h)),
                        ("hht", lambda: "hht"), ("genalpha", lambda: "genalpha")):
        opts = {"h": h} if label in ("hht", "genalpha") else {}
        run_scene(sc, make(), opts, write=False)  # warm
        best = math.inf
        for _ in range(3):
            (rec, _), w = probes.wall(lambda: run_scene(sc, make(), opts, write=False))
            best = min(best, w)
        rows[label] = {"steps": rec.counters["steps"], "us_per_step": 1e6 * best / rec.counters["steps"]}
    plugin = rows["verlet-compiled (plugin)"]["us_per_step"]
    return {"available": True, "T": T, "h": h, "rows": rows,
            "plugin_over_hht": plugin / rows["hht"]["us_per_step"],
            "plugin_over_genalpha": plugin / rows["genalpha"]["us_per_step"],
            "python_over_compiled_plugin": rows["verlet (plugin, plain Python)"]["us_per_step"] / plugin}


def pendulum_peer_markdown(s: PerfSettings) -> str:
    """hht and genalpha per step against Exudyn's generalized-α on the pendulum, in this
    process (:func:`_pendulum_pair`), as Markdown: `daebench perf --section pendulum-peer`."""
    try:
        import exudyn  # lazy: exudyn, an optional extra
    except ImportError:
        return "exudyn is not installed (pip install 'daebench[exudyn]'): nothing to compare\n"
    hht = pendulum_vs_exudyn(s)
    ga = genalpha_vs_exudyn(s, hht["rho_inf"])
    lines = [f"Pendulum (30°, T = {s.pendulum_T:g} s, h = {s.pendulum_h:g} s, ρ∞ = {hht['rho_inf']:.4f}) against "
             f"Exudyn {exudyn.__version__}'s generalized-α, CPU time in one process, {s.peer_rounds} rounds "
             f"(median; per step = slope between T/4 and T)", "",
             "| ours | µs/step | Exudyn µs/step | ratio per step (range) | whole-run ratio | Newton/step |",
             "|---|---|---|---|---|---|"]
    for name, r in (("hht", hht), ("genalpha", ga)):
        lo, hi = r["ratio_range"]
        lines.append(f"| {name} | {r['ours_us_per_step']:.2f} | {r['exudyn_us_per_step']:.2f} | "
                     f"{r['ratio_ours_over_exudyn']:.3f} ({lo:.3f}–{hi:.3f}) | {r['whole_run_ratio']:.3f} | "
                     f"{r['newton_per_step']:.2f} |")
    return "\n".join(lines) + "\n"

