"""beam-impact (N = 5, e = 0): θ's largest error through the first contact burst and the
free flight after it (t ≤ 0.5 s; the reference's impacts are at 0.370–0.381 s and from
0.788 s on) against its largest over the whole run, and the modal band errors before the
first impact and over the free window after the first burst.

    python docs/results/_scripts/beam_burst.py hht,newmark,genalpha 1e-4,5e-5,2.5e-5,1.25e-5
"""

import sys

import numpy as np

import daebench
from daebench.harness.references.reference import load_reference
from daebench.harness.scoring import modal, pipeline
from daebench.models import build_system

for name in sys.argv[1].split(","):
    for h in (float(x) for x in sys.argv[2].split(",")):
        out = daebench.run("beam-impact", name, h=h, h_contact=1e-6)
        scene, hist = out.scene, out.observables
        run = pipeline.Run(scene, build_system(scene), hist, [], pipeline.declared(scene.model))
        tr = pipeline.truth(run, lambda: load_reference(scene, mode="require"))
        th = np.interp(hist["t"].to_numpy(), tr.history["t"].to_numpy(), tr.history["theta_deg"].to_numpy())
        err = np.abs(hist["theta_deg"].to_numpy() - th)
        burst, whole = err[hist["t"].to_numpy() <= 0.5].max(), err.max()
        m = modal.measure(run, tr)
        print(f"{name} h={h:g}: θ error to 0.5 s {burst:.3g}°, whole run {whole:.3g}°, ratio {whole / burst:.3g}; "
              f"band {m['err_band_theta_max']:.3g}° rest {m['err_rest_theta_max']:.3g}° before t1; after the burst "
              f"band {m['err_postband_theta_max']:.3g}° rest {m['err_postrest_theta_max']:.3g}°", flush=True)
