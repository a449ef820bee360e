"""Siconos (Debian's python3-siconos, the system Python) runs a daebench case: run as
``/usr/bin/python3 siconos_worker.py`` with the request on stdin (:mod:`common`).

Methods: ``mj`` — Moreau–Jean time stepping (θ = 0.5, one LCP per step, Newton's impact law
at velocity level; impulses, no events located); ``ed`` — event-driven with LSODAR (rtol
1e-14, atol 1e-16: impact times to ~1e-14 s on the ball), the impact LCP at each event and the
smooth-acceleration LCP for the contact status. Cases: the ``ball`` model (the bouncing ball
and the spring–wall oscillator: one coordinate, a linear time-invariant Lagrangian system, the
wall a linear relation y = x − x_w), both methods; the ``slider-crank`` model
(``slider-crank-clearance``, frictionless) with ``mj`` in Siconos' plugin formulation
(:mod:`siconos_slidercrank`): one Newton–LCP loop per step, an impact per corner where its
impulse turns positive; the ``rigid2d`` model (``block-incline``, ``rocking-block``: Coulomb
friction) with ``mj``, compiled relations with a normal and a tangential row per contact
point (:mod:`siconos_rigid2d`) and one 2-D friction-contact problem (Lemke) per Newton
iteration.

What the Python layer does not give: the Liu–Zhao–Brogliato multiple-impact law
(``MultipleImpactNSL`` is wrapped, its one-step solver ``OSNSMultipleImpact`` is not), so the
chains and the cradle are not run here.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402  (the worker's own folder: it runs outside daebench)

LSODAR_RTOL, LSODAR_ATOL = 1e-14, 1e-16
THETA = 0.5
NEWTON_TOL, NEWTON_MAX = 1e-10, 20
#: the friction-contact solver's tolerance (Lemke's method checks its solution against it)
FRICTION_TOL = 1e-12
#: Moreau–Jean's activation threshold [m] on the rigid2d model: a contact whose predicted gap
#: is at most this is in the step's problem. A resting corner's gap is zero up to rounding
#: (~1e-17 m); at Siconos' default 0 a corner whose rounding lands positive leaves the problem
#: for a step, falls through and drifts (measured on block-incline at h = 5e-4 s: y off by
#: 5e-5 m, x at 1 s off by 0.10 m). 1e-10 m is below any length the cases resolve.
ACTIVATION = 1e-10


def _version() -> str:
    """The module's own version, with the Debian package's where dpkg knows it."""
    import subprocess
    from importlib.metadata import PackageNotFoundError, version
    try:
        mod = version("siconos")
    except PackageNotFoundError:
        mod = "unknown"
    try:
        deb = subprocess.run(["dpkg-query", "-W", "-f=${Version}", "python3-siconos"], capture_output=True,
                             text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        deb = ""
    return f"{mod} (Debian python3-siconos {deb})" if deb else mod


def _ball(sk, p: dict, t_end: float):
    """The ball model as a Siconos system: (nsds, ds, interaction, wall)."""
    if not p.get("effects.contact", True):
        raise common.Refused("the Siconos adapter runs the ball with its wall (effects.contact = true)")
    if p["contact.law"] not in ("constraint", "complementarity"):
        raise common.Refused(f"Siconos resolves contact by Newton's impact law; contact.law = "
                             f"'{p['contact.law']}' is a compliant law: run it with contact.law = constraint")
    m, g, k, xr, wall = (float(p[key]) for key in ("ball.mass", "gravity.g", "spring.stiffness", "spring.rest",
                                                    "contact.wall"))
    ds = sk.LagrangianLinearTIDS([float(p["start.x"])], [float(p["start.v"])], np.array([[m]]))
    if k:
        ds.setKPtr(np.array([[k]]))
    ds.setFExtPtr(np.array([-m * g + k * xr]))
    rel = sk.LagrangianLinearTIR(np.array([[1.0]]), np.array([-wall]))
    inter = sk.Interaction(sk.NewtonImpactNSL(float(p["contact.restitution"])), rel)
    nsds = sk.NonSmoothDynamicalSystem(0.0, t_end)
    nsds.insertDynamicalSystem(ds)
    nsds.link(inter, ds)
    return nsds, ds, inter, wall


def moreau_jean(sk, nsds, ds, inter, wall, h: float, n: int):
    osi = sk.MoreauJeanOSI(THETA)
    sim = sk.TimeStepping(nsds, sk.TimeDiscretisation(0.0, h), osi, sk.LCP())
    rows = [(0.0, ds.q()[0], ds.velocity()[0], ds.q()[0] - wall)]
    impacts = []

    def loop():
        was = False
        while sim.hasNextEvent():
            sim.computeOneStep()
            t = sim.nextTime()
            x, v = ds.q()[0], ds.velocity()[0]
            rows.append((t, x, v, x - wall))
            on = inter.lambda_(1)[0] > 0.0    # an impulse in this step: a contact episode
            if on and not was:
                impacts.append((t, 0))
            was = on
            sim.nextStep()
    _, cpu = common.timed(loop)
    return rows, impacts, cpu, len(rows) - 1, f"Moreau–Jean (θ = {THETA}, LCP per step, h = {h!r} s)"


def event_driven(sk, nsds, ds, inter, wall, h: float, n: int):
    osi = sk.LsodarOSI()
    osi.setTol(1, LSODAR_RTOL, LSODAR_ATOL)
    sim = sk.EventDriven(nsds, sk.TimeDiscretisation(0.0, h))
    sim.insertIntegrator(osi)
    sim.insertNonSmoothProblem(sk.LCP(), sk.SICONOS_OSNSP_ED_IMPACT)
    sim.insertNonSmoothProblem(sk.LCP(), sk.SICONOS_OSNSP_ED_SMOOTH_ACC)
    events = sim.eventsManager()
    rows = [(0.0, ds.q()[0], ds.velocity()[0], ds.q()[0] - wall)]
    impacts = []
    count = [0]

    def loop():
        while sim.hasNextEvent():
            sim.advanceToEvent()
            nonsmooth = events.nextEvent().getType() == 2     # NS_EVENT: an impact
            sim.processEvents()
            count[0] += 1
            t = sim.startingTime()
            x = ds.q()[0]
            if nonsmooth:   # the two sides of the jump at the same t, as an exact reference holds them
                rows.append((t, x, ds.velocityMemory().getSiconosVector(1)[0], x - wall))
                impacts.append((t, 0))
            rows.append((t, x, ds.velocity()[0], x - wall))
    _, cpu = common.timed(loop)
    return rows, impacts, cpu, count[0], (f"event-driven, LSODAR (rtol {LSODAR_RTOL:g}, atol {LSODAR_ATOL:g}), "
                                          f"impact and smooth-acceleration LCPs, output every {h!r} s")


def _stepping(sim, ds, inters, observe, closed: list[bool]):
    """Moreau–Jean's loop over a Newton–one-step-problem simulation: the observables at every
    step, an impact per contact where its normal impulse turns positive (a contact closed at
    the start is none until it has opened), the loop's CPU time."""
    rows = [(0.0, *observe(ds.q(), ds.velocity()))]
    impacts = []

    def loop():
        was = list(closed)
        while sim.hasNextEvent():
            sim.computeOneStep()
            t = sim.nextTime()
            rows.append((t, *observe(ds.q(), ds.velocity())))
            for k, inter in enumerate(inters):
                on = inter.lambda_(1)[0] > 0.0
                if on and not was[k]:
                    impacts.append((t, k))
                was[k] = on
            sim.nextStep()
    _, cpu = common.timed(loop)
    return rows, impacts, cpu


def slider_crank(sk, sheet: dict, p: dict, t_end: float, h: float, method: str):
    """Moreau–Jean on the slider-crank in Siconos' plugin formulation (:mod:`siconos_slidercrank`)."""
    import siconos_slidercrank as sc

    if method != "mj":
        raise common.Refused("the slider-crank's corners chatter (accumulating impacts): Siconos' event-driven "
                             "scheme does not pass them; run it with siconos-mj")
    nsds, ds, inters = sc.build(sk, np, sheet, p, t_end)
    sim = sk.TimeStepping(nsds, sk.TimeDiscretisation(0.0, h), sk.MoreauJeanOSI(THETA), sk.LCP())
    sim.setNewtonTolerance(NEWTON_TOL)
    sim.setNewtonMaxIteration(NEWTON_MAX)
    rows, impacts, cpu = _stepping(sim, ds, inters, lambda q, v: sc.observables(q, v, p), [False] * len(inters))
    return sc.COLUMNS, rows, impacts, cpu, len(rows) - 1, (f"Moreau–Jean (θ = {THETA}, LCP per step, Newton "
                                                            f"tolerance {NEWTON_TOL:g}, h = {h!r} s), plugin formulation")


def rigid2d(sk, sheet: dict, p: dict, t_end: float, h: float, method: str):
    """Moreau–Jean with Coulomb friction on the planar rigid body (:mod:`siconos_rigid2d`):
    one 2-D friction-contact problem per Newton iteration, solved by Lemke's pivoting
    method (exact to rounding, no tolerance of its own)."""
    import siconos.numerics as sn
    import siconos_rigid2d as rb

    if method != "mj":
        raise common.Refused("the Siconos rigid2d adapter runs Moreau–Jean (siconos-mj): Siconos' event-driven "
                             "scheme has no Coulomb friction in its impact and acceleration problems")
    nsds, ds, inters = rb.build(sk, np, sheet, p, t_end)
    osnsp = sk.FrictionContact(2, sn.SICONOS_FRICTION_2D_LEMKE)
    osnsp.numericsSolverOptions().dparam[sn.SICONOS_DPARAM_TOL] = FRICTION_TOL
    osi = sk.MoreauJeanOSI(THETA)
    osi.setConstraintActivationThreshold(ACTIVATION)
    sim = sk.TimeStepping(nsds, sk.TimeDiscretisation(0.0, h), osi, osnsp)
    sim.setNewtonTolerance(NEWTON_TOL)
    sim.setNewtonMaxIteration(NEWTON_MAX)
    rows, impacts, cpu = _stepping(sim, ds, inters, lambda q, v: rb.observables(q, v, p), [False] * len(inters))
    return rb.COLUMNS, rows, impacts, cpu, len(rows) - 1, (
        f"Moreau–Jean (θ = {THETA}, 2-D friction-contact problem per Newton iteration, Lemke, Newton tolerance "
        f"{NEWTON_TOL:g}, h = {h!r} s), plugin relations")


def run(req: dict) -> None:
    import siconos.kernel as sk

    sheet = req["sheet"]
    p = common.values(sheet)
    t_end, h = float(sheet["time"]["t_end"]), float(req["h"])
    n = common.steps_of(t_end, h)
    if sheet["model"] in PLUGIN_MODELS:
        columns, rows, impacts, cpu, steps, words = PLUGIN_MODELS[sheet["model"]](sk, sheet, p, t_end, h,
                                                                                  req["method"])
        common.write(req, columns, rows, impacts,
                     {"cost_s": repr(cpu), "steps": steps, "code": f"Siconos {_version()}", "method": words,
                      "cost": "CPU time of the simulation loop in the peer's process (time.process_time)",
                      "h": repr(h)})
        return
    if sheet["model"] != "ball":
        raise common.Refused(f"the Siconos adapter runs the ball model's cases (ball, spring-wall), "
                             f"slider-crank-clearance and the rigid2d model's (block-incline, rocking-block); "
                             f"case '{sheet['case']}' is model '{sheet['model']}'")
    scheme = {"mj": moreau_jean, "ed": event_driven}[req["method"]]
    rows, impacts, cpu, steps, words = scheme(sk, *_ball(sk, p, t_end), h, n)
    common.write(req, ["t", "x", "v", "gap"], rows, impacts,
                 {"cost_s": repr(cpu), "steps": steps, "code": f"Siconos {_version()}", "method": words,
                  "cost": "CPU time of the simulation loop in the peer's process (time.process_time)",
                  "h": repr(h)})


PLUGIN_MODELS = {"slider-crank": slider_crank, "rigid2d": rigid2d}

if __name__ == "__main__":
    common.main(run)
