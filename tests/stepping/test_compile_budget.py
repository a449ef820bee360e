"""What the main job compiles, bounded: the number of specializations of each compiled
function and their machine code, counted in a fresh process that ran the main job in small
(:func:`daebench.studies.perf.loaded_code.main_job`: each integrator of `daebench compare
beam-impact` through an impact), so that a change that makes a function compile more often
or grow fails here, naming the function.

Counts, not times: the specializations are exact; the machine-code bytes (the text sections
of the object code numba emitted, read from the kernel cache) depend on the numba/LLVM
version and the CPU's instruction set by a few per cent, which the budget's headroom
(:data:`HEADROOM`) covers. The child loads what the suite's other tests compiled into the
kernel cache — then it holds the functions the job calls from Python, each with the machine
code of every callee linked into it (27 specializations, 1.39 MB: 9 s of CPU); on an empty
cache it compiles the main job once (minutes, which the rest of the suite then loads) and
holds every function compiled. The budget bounds every function either way.

The budget is the census of the main job when it was set (docs/performance.md, "Compile
budget"); lower it when a change shrinks what is compiled, raise it only with a reason.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numba
import pytest

from daebench.studies.perf.loaded_code import Loaded, by_function

#: module.qualname → (specializations, machine code [kB]) of the main job, as measured
#: (numba 0.68.1, LLVM 22, x86-64; 108 functions, 123 specializations, 2.63 MB of machine code)
BUDGET: dict[str, tuple[int, int]] = {
    "daebench.stepping.runner.run_phase": (4, 873),
    "daebench.stepping.ida_advance.advance_loop": (1, 108),
    "daebench.stepping.moreau._project": (1, 66),
    "daebench.stepping.abm._rk4": (1, 63),
    "daebench.stepping.abm._start": (1, 61),
    "daebench.stepping.ida_native.ggl_jacobian": (1, 58),
    "daebench.stepping.newmark_matrix.factor": (1, 56),
    "daebench.stepping.nsgenalpha._residual": (1, 55),
    "daebench.stepping.nsgenalpha._jacobian": (1, 52),
    "daebench.stepping.abm.rhs": (1, 44),
    "daebench.stepping.watch.events": (1, 44),
    "daebench.core.phase.augmented.solve_augmented": (1, 38),
    "daebench.models.hubbeam._k_mass_force": (1, 37),
    "daebench.stepping.friction.impulses": (1, 37),
    "daebench.models.hubbeam._k_force_jacobian": (1, 34),
    "daebench.stepping.moreau._factor": (1, 34),
    "daebench.stepping.nsgenalpha._start": (1, 34),
    "_daebench_handle_hubbeamdata.mass_force": (1, 33),
    "daebench.models._hubbeam_kernels.mass_force": (1, 32),
    "_daebench_handle_hubbeamdata.force_jacobian": (1, 31),
    "daebench.stepping.watch.track": (1, 30),
    "daebench.stepping.newmark._start": (1, 30),
    "daebench.models._hubbeam_jacobians.force_jacobian": (1, 28),
    "daebench.core.phase.augmented._solve_augmented": (1, 28),
    "daebench.models._hubbeam_kernels.output_rows": (1, 27),
    "daebench.stepping.ida_advance.record_outputs": (1, 26),
    "daebench.stepping.ida_advance.solve": (1, 26),
    "daebench.stepping.ida_native.ggl_residual": (1, 23),
    "daebench.stepping.moreau._mass_solve": (1, 22),
    "daebench.stepping.moreau._lcp_matrix": (1, 22),
    "daebench.stepping.moreau._start": (1, 21),
    "daebench.models.hubbeam._k_mass_jacobian_product": (1, 21),
    "daebench.models._hubbeam_kernels.point_kinematics": (2, 18),
    "daebench.core.lcp.solve_lcp_lemke": (2, 12),
    "daebench.core.lcp._lemke_pivot": (6, 12),
    "daebench.core.linalg.lu_factor": (2, 7),
    "daebench.core.linalg.lu_solve": (2, 6),
    "daebench.models._hubbeam_kernels._quadratic": (3, 5),
    "daebench.core.lcp._complementary": (2, 4),
}
#: any function the budget does not name: at most this many specializations and kB
OTHER = (1, 20)
#: all of it together [kB]
TOTAL_KB = 2631
#: allowance on the machine-code bytes (numba/LLVM version, CPU instruction set)
HEADROOM = 1.25


def over_budget(rows: list[Loaded]) -> list[str]:
    """Every function beyond its budget, as 'name: what grew (budget)' lines (empty: within)."""
    sigs: dict[str, list[str]] = {}
    for r in rows:
        sigs.setdefault(r.name, []).append(r.signature)
    lines = []
    for name, (count, size) in sorted(by_function(rows).items()):
        n_max, kb_max = BUDGET.get(name, OTHER)
        if count > n_max:
            lines.append(f"{name}: {count} specializations (budget {n_max}): "
                         + " | ".join(s[:120] for s in sigs[name]))
        if size > HEADROOM * kb_max * 1e3:
            lines.append(f"{name}: {size / 1e3:.0f} kB of machine code (budget {kb_max} kB + "
                         f"{100 * (HEADROOM - 1):.0f} %)")
    total = sum(r.code_bytes for r in rows)
    if total > HEADROOM * TOTAL_KB * 1e3:
        lines.append(f"all functions: {total / 1e3:.0f} kB of machine code (budget {TOTAL_KB} kB + "
                     f"{100 * (HEADROOM - 1):.0f} %)")
    return lines


def _main_job_census() -> list[Loaded]:
    p = subprocess.run([sys.executable, "-m", "daebench.studies.perf.loaded_code"], capture_output=True,
                       text=True, timeout=1800, env=dict(os.environ))
    assert p.returncode == 0, f"the main job's census failed (exit {p.returncode}):\n{p.stderr[-3000:]}"
    return [Loaded(**r) for r in json.loads(p.stdout.strip().splitlines()[-1])]


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="nothing compiles with NUMBA_DISABLE_JIT")
def test_main_job_compiles_within_its_budget():
    rows = _main_job_census()
    assert rows, "the census found no compiled function"
    assert all(r.code_bytes > 0 for r in rows), [r.name for r in rows if r.code_bytes <= 0]
    assert not over_budget(rows), "compiled beyond the budget:\n" + "\n".join(over_budget(rows))


def test_over_budget_names_the_function_that_grew():
    budget = dict(BUDGET)
    try:
        BUDGET.clear()
        BUDGET["a.f"] = (1, 10)
        rows = [Loaded("a.f", "float64", 9_000), Loaded("a.f", "int64", 9_000), Loaded("a.g", "float64", 1_000)]
        lines = over_budget(rows)
        assert lines[0].startswith("a.f: 2 specializations (budget 1): float64 | int64")
        assert lines[1].startswith("a.f: 18 kB of machine code (budget 10 kB")
        assert all("a.g" not in x for x in lines)
    finally:
        BUDGET.clear()
        BUDGET.update(budget)
