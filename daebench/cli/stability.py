"""`daebench stability CASE`: the stability map (largest stable fixed step, measured by
bisection on whole runs, beside the linear prediction; :mod:`daebench.workflows.stability`)."""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any, Optional

import typer

from daebench.core.params import ParamError

# the beam-impact paper's settings (docs/sources.md §G.3), plus generalized-α and two Newmark members:
# the trapezoidal rule (unconditionally stable) and Fox–Goodwin β = 1/12 (stable for hω ≤ √6)
DEFAULT_METHODS = ("baumgarte:delta=0,epsilon=0", "baumgarte:delta=10,epsilon=50",
                   "baumgarte:delta=1000,epsilon=5000", "hht:alpha=0", "hht:alpha=-0.15", "hht:alpha=-0.3333",
                   "genalpha:rho_inf=0.74", "newmark:beta=0.25", "newmark:beta=0.0833333333")
DEFAULT_N = (3, 5, 7, 9)
# trials of 80 periods of the fastest mode (≈ 530 steps near ABM4-PECE's boundary: an instability
# beyond it shows as e^18, the weak growth below it stays under e^3.4; see stability.trial_length).
# On beam-impact that is 0.01-0.12 s (J_h = 0) and 0.03-0.32 s (with a hub): before the first
# impact (0.37 s), in the free flight that the linearization at the start describes.
DEFAULT_PERIODS = 80.0


def parse_method(text: str) -> tuple[str, dict[str, Any]]:
    """``"baumgarte:delta=10,epsilon=50"`` → ("baumgarte", {"delta": 10.0, "epsilon": 50.0}),
    validated and typed by the integrator's own settings."""
    from daebench.harness.running.runner import make_integrator

    name, _, rest = text.partition(":")
    raw = dict(kv.split("=", 1) for kv in rest.split(",") if kv.strip()) if rest.strip() else {}
    if any(not k.strip() for k in raw):
        raise ParamError(f"--method '{text}': write integrator:name=value,name=value")
    integ = make_integrator(name.strip(), {k.strip(): v.strip() for k, v in raw.items()})
    return integ.name, {k.strip(): integ.settings[k.strip()] for k in raw}


def register(app: typer.Typer) -> None:
    """Add `daebench stability` to ``app``."""

    @app.command("stability")
    def stability(case: str = typer.Argument(..., help="scene name or path to a .toml file"),
                  method: list[str] = typer.Option(list(DEFAULT_METHODS), "--method", "-m",
                                                   help="integrator:setting=value,... (repeat for each)"),
                  n: str = typer.Option("auto", "--n",
                                        help="values of --n-key, comma-separated; '' = the scene's own; auto = "
                                             f"{','.join(map(str, DEFAULT_N))} if the scene has --n-key"),
                  n_key: str = typer.Option("discretization.n", "--n-key", help="the scene key N stands for"),
                  set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
                  t_end: float = typer.Option(0.0, "--t-end",
                                              help="run length of each trial, s (0: --periods of the fastest mode, "
                                                   "capped at the scene's t_end)"),
                  periods: float = typer.Option(DEFAULT_PERIODS, "--periods",
                                                help="trial length in periods of the fastest mode (with --t-end 0)"),
                  h_min: float = typer.Option(1e-6, "--h-min", help="lower bisection bound, s"),
                  h_max: float = typer.Option(1e-2, "--h-max", help="upper bisection bound, s"),
                  tol: float = typer.Option(0.02, "--tol", help="relative width of the final bracket"),
                  jobs: int = typer.Option(1, "--jobs", "-j", help="worker processes"),
                  run_cap: Optional[float] = typer.Option(None, "--run-cap", help="wall-time cap of one run, s"),
                  mark_h: float = typer.Option(0.0, "--mark-h", help="draw this step as a line, s (0: none)"),
                  out: str = typer.Option("results/stability", "--out", help="output folder"),
                  name: Optional[str] = typer.Option(None, "--name", help="file stem (default <case>-stability)")
                  ) -> None:
        """Largest stable fixed step per integrator setting and N, measured by bisection on
        whole runs (completed, energy balance within the divergence threshold), beside the
        linear prediction (start frequencies × the method's computed stability interval)."""
        from daebench.cli.common import fail
        from daebench.models.scenes import load_scene
        from daebench.workflows import stability as st
        from daebench.workflows import stability_report as rep

        try:
            sc = load_scene(case, set_)
            methods = [parse_method(m) for m in method]
            if n.strip() == "auto":
                n = ",".join(map(str, DEFAULT_N)) if n_key in sc.schema else ""
            ns = [int(x) for x in n.split(",") if x.strip()] if n.strip() else None
            if ns is not None and n_key not in sc.schema:
                raise ParamError(f"scene '{sc.name}' has no key '{n_key}' to vary; give --n '' or --n-key")
            if not (0.0 < h_min < h_max) or not (0.0 < tol < 1.0) or jobs < 1 or t_end < 0.0 or periods <= 0.0:
                raise ParamError("need 0 < --h-min < --h-max, 0 < --tol < 1, --jobs ≥ 1, --t-end ≥ 0 "
                                 "and --periods > 0")
        except (ParamError, ValueError) as exc:
            fail(str(exc))
        te = min(t_end, sc.t_end) if t_end > 0.0 else None
        length = f"{te:g} s" if te is not None else f"{periods:g} periods of the fastest mode"
        sys.stderr.write(f"stability map of {sc.name}: {len(methods)} settings × {len(ns or [None])} N, "
                         f"trials of {length}, h in [{h_min:g}, {h_max:g}] s to {tol:.0%}, {jobs} job(s)\n")
        wall0 = time.perf_counter()
        try:
            df = st.stability_map(sc, methods, ns, n_key=n_key, t_end=te, periods=periods, h_min=h_min,
                                  h_max=h_max, tol=tol,
                                  jobs=jobs, run_cap=run_cap, progress=lambda line: sys.stderr.write(line + "\n"))
        except (ParamError, ValueError) as exc:
            fail(str(exc))
        extra = ", ".join(s for s in set_)
        title = (f"{sc.name}{' (' + extra + ')' if extra else ''}: largest stable step, trials of {length}, "
                 f"bisection to {tol:.0%}")
        files = rep.write(df, Path(out), name or f"{sc.name}-stability", title, h_max, mark_h or None)
        typer.echo(rep.markdown(df, h_max))
        typer.echo(f"\n{int(df['agrees'].sum())}/{len(df)} rows agree with the prediction within one bisection "
                   f"step; {int(df['runs'].sum())} runs in {time.perf_counter() - wall0:.1f} s")
        typer.echo("wrote " + ", ".join(map(str, files)))
