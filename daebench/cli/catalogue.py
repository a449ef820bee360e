"""`daebench list` and `daebench show NAME`: what there is, and one scene or integrator
described (:mod:`daebench.api.catalogue`)."""

from __future__ import annotations

import typer

from daebench.cli.common import fail, out, print_table


def register(app: typer.Typer) -> None:
    """Add `daebench list` and `daebench show` to ``app``."""
    app.command("list")(list_cmd)
    app.command("show")(show)


def list_cmd() -> None:
    """Cases (scene files) and integrators (built-in and plugins)."""
    from daebench import api

    try:
        cases = api.cases()
    except api.ParamError as exc:  # DAEBENCH_CASES pointing nowhere
        fail(str(exc))
    print_table(["case", "description"], [[r.case, r.description] for r in cases.itertuples()], "cases")
    out()
    rows = []
    for name, info in api.integrator_infos().items():
        if info.capabilities is None:
            rows.append([name, "", "", "", info.distribution, f"cannot be loaded: {info.error}"])
            continue
        cap = info.capabilities
        steps = "/".join(x for x, ok in (("fixed", cap.fixed_step), ("adaptive", cap.adaptive)) if ok)
        cons = f"index {cap.index}" if cap.constraints else "ODE only"
        if cap.contacts:
            cons += ", resolves contacts"
        rows.append([name, cap.order, steps, cons, info.distribution, info.description])
    print_table(["name", "order", "steps", "constraints", "from", "description"], rows, "integrators")
    for why in api.integrator_refusals() + api.model_refusals():
        out(f"refused: {why}")
    out("settings of an integrator: daebench show NAME")


def show(name: str = typer.Argument(..., help="an integrator, a case name or a path to a .toml file"),
         set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
         keys: bool = typer.Option(False, "--keys", help="list every valid key with its type and range")) -> None:
    """An integrator's settings and capabilities, or a scene's resolved parameters, effects and size."""
    from daebench import api

    try:
        info = api.show(name, set_, keys)
    except api.ParamError as exc:
        fail(str(exc))
    if isinstance(info, api.IntegratorInfo):
        return _integrator(info)
    sc = info.scene
    out(f"{sc.name} — {sc.description}  (model {sc.model}, hash {sc.hash})")
    eff = sc.effects()
    if eff:
        out("effects: " + ", ".join(f"{k} {'on' if v else 'off'}" for k, v in eff.items()))
    rows = []
    for k, v in sc.values.items():
        if k.startswith("effects."):
            continue
        p = sc.schema[k]
        rows.append([k, repr(v)] + ([p.describe(), f"{p.doc}{f' [{p.unit}]' if p.unit else ''}"] if keys else []))
    print_table(["key", "value"] + (["type / range", "meaning"] if keys else []), rows)
    if info.error:
        fail(info.error)
    out(f"size: n = {info.n} coordinates, {info.n_bilateral} bilateral constraints, "
        f"{info.n_contacts} contact point(s)" + (f", contact law {info.contact_law}" if info.contact_law else ""))
    scored = set(sc.get("output.observables") or [])
    print_table(["observable", "unit", "meaning", "scored"],
                [[n, u or "-", m, "yes" if n in scored else ""] for n, u, m in info.observables],
                "observables (the columns of a history, and of a file for `daebench score`)")


def _integrator(info) -> None:
    out(f"{info.name} — {info.description} (from {info.distribution})")
    cap = info.capabilities
    if cap is None:
        fail(f"integrator '{info.name}' cannot be loaded: {info.error}")
    steps = ", ".join(x for x, ok in (("fixed", cap.fixed_step), ("adaptive", cap.adaptive)) if ok)
    out(f"capabilities: order {cap.order}; steps: {steps}; "
        + (f"constraints at index {cap.index}" if cap.constraints else "ODE only (no constraints)")
        + ("; resolves contacts itself" if cap.contacts else "")
        + ("; own dense output" if cap.dense_output else ""))
    print_table(["setting", "type / range", "default", "meaning"],
                [[p.name, p.describe(), repr(p.default), p.doc] for p in info.settings], "settings (--opt name=value)")
