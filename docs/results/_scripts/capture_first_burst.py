"""beam-impact (N = 5) with e = 0.3, 1 s: the mechanical energy each capturing scheme and IDA's
exact impact map lose in the first contact burst (from the first impact to 2 ms after it) and
what they hold at the end — the numbers behind the penetration-and-energy figure's caption.

    python docs/results/_scripts/capture_first_burst.py
"""

import numpy as np

import daebench

RUNS = {"moreau": dict(h=1e-4), "moreau + projection": dict(h=1e-4, projection=True),
        "nsgenalpha": dict(h=1e-4), "ida": {}}

for label, opts in RUNS.items():
    out = daebench.run("beam-impact", label.split()[0], write=False, overrides=["contact.restitution=0.3"], **opts)
    t, E = out.observables["t"].to_numpy(), out.observables["E"].to_numpy()
    t1 = out.record.impacts[0]["t"]
    after = float(np.interp(t1 + 2e-3, t, E))
    print(f"{label}: {out.record.status}, {len(out.record.impacts)} impacts, first at {t1:.6f} s; "
          f"lost in the first burst {E[0] - after:.4f} J; E(1 s) {E[-1]:.4f} J", flush=True)
