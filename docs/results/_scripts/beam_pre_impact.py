"""beam-impact before the first impact (t_end 0.3 s): the full θ error, the resolved-band and
rest θ errors of hht, newmark and genalpha over h = 1e-4 … 6.25e-6 s, from rest (argument
``rest``) or from the quasi-static deflection (``static``: the elastic accelerations zero at
t = 0). Prints one JSON line per run. Used for docs/results/flexible-beams.md:

    PYTHONPATH=. python docs/results/_scripts/beam_pre_impact.py rest
    PYTHONPATH=. python docs/results/_scripts/beam_pre_impact.py static
"""
import json, math, sys, time
import numpy as np
from daebench.models.scenes import load_scene
from daebench.models import build_system
from daebench.models.hubbeam import HubBeam
from daebench.harness.running.runner import make_integrator, run_scene
from daebench.harness.scoring import metrics, modal, pipeline

START = sys.argv[1] if len(sys.argv) > 1 else "rest"
sc = load_scene("beam-impact", {"t_end": 0.3, "output.dt": 1e-4})
orig = HubBeam.initial_state

def quasi_static(self):
    """B with zero elastic acceleration at t = 0 (linearised): [M_θθ K_θB; M_Bθ K_BB][θ̈; B] = Q0."""
    q0, v0 = orig(self)
    M = self.mass(q0)
    Kq, _ = self.force_jacobian(0.0, q0, v0)
    K = -0.5 * (Kq + Kq.T)
    Q0 = self.applied_force(0.0, q0, v0)
    A = np.zeros_like(M)
    A[:, 0] = M[:, 0]
    A[:, 1:] = K[:, 1:]
    x = np.linalg.solve(A, Q0)
    q = q0.copy(); q[1:] = x[1:]
    return q, v0

if START == "static":
    HubBeam.initial_state = quasi_static

def history(name, **s):
    t0 = time.process_time()
    _, res = run_scene(sc, make_integrator(name, s), write=False, force=True)
    assert res.status == "completed", (name, s, res.status, res.message)
    return res, time.process_time() - t0

ref, c = history("ida", rtol=1e-11, atol=1e-13, adaptive=True)
chk, _ = history("ida", rtol=1e-10, atol=1e-12, adaptive=True)
system = build_system(sc)
d = pipeline.declared(sc.model)
tr = pipeline.Truth(ref.history, (), "reference", 1e-11, trust_t=0.3, trust_impacts=0)
def score(res):
    run = pipeline.Run(sc, system, res.history, res.impacts, d)
    acc = metrics.accuracy(res.history, ref.history, sc["output.observables"], declared=d)
    m = modal.measure(run, tr)
    from dataclasses import replace
    bands = {}
    for below in (3000.0, 1500.0):
        sc2 = replace(sc, comparison=replace(sc.comparison, modes_below=below))
        mb = modal.measure(pipeline.Run(sc2, system, res.history, res.impacts, d), tr)
        bands[f"band_{below:g}"] = mb["err_band_theta_max"]
        bands[f"rest_{below:g}"] = mb["err_rest_theta_max"]
    return {"theta": acc["err_theta_max"], "chord": acc.get("err_chord_max"), "tip": acc["err_tip_max"],
            "band_theta": m["err_band_theta_max"], "rest_theta": m["err_rest_theta_max"],
            "band_tip_y": m["err_band_tip_y_max"], "rest_tip_y": m["err_rest_tip_y_max"],
            "band_E": m["err_band_energy_max"], "rest_E": m["err_rest_energy_max"],
            "resolved": m["modes_resolved"], **bands, "E_modes": [m[f"mode{k}_energy"] for k in range(1, 7)]}
out = {"start": START, "ref_cpu": c, "ref_vs_check": score(chk), "runs": []}
print(json.dumps(out), flush=True)
for name in ("hht", "newmark", "genalpha"):
    for h in (1e-4, 5e-5, 2.5e-5, 1.25e-5, 6.25e-6):
        res, cpu = history(name, h=h)
        r = {"integrator": name, "h": h, "cpu": cpu, **score(res)}
        out["runs"].append(r)
        print(json.dumps(r), flush=True)
