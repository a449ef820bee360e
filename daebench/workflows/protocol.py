"""What `daebench compare` (and the survey) runs on a case and how it judges it: the
protocol, read from one owner per part.

**Where a protocol is declared.** By the case, in its scene file's ``[compare]`` table
(:mod:`daebench.core.comparison`: the methods given the protocol, their steps, contact
step and tolerances, the headline measures with their targets, the survey's tags), kept
out of the scene hash so that a changed step list re-keys no cached reference. An
integrator may declare its own runs for a case
(:meth:`daebench.integrators.base.Integrator.protocol`, its ``protocols`` table): a
plugin's own declaration comes before the case's. Every other integrator runs once at its
default settings. No code here knows a case by name.

**Which series.** A method the case's table names takes the table's ``steps`` when it has
fixed steps (and ``contact_step`` as ``h_contact`` when the driver resolves its contacts:
an event-capturing method resolves them inside its steps), else the table's
``tolerances`` when it is adaptive.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Mapping

from daebench.core.comparison import Comparison
from daebench.core.scene import Scene
from daebench.integrators import base
from daebench.integrators import registry as integrator_registry

#: the measure a case without declared measures is judged by (``{obs}``: its headline observable)
DEFAULT_MEASURES = ("err_{obs}_max_trusted",)


@dataclass(frozen=True)
class Entry:
    """One integrator of a protocol: fixed steps or tolerances (neither: one run at its
    defaults) and fixed settings."""

    integrator: str
    steps: tuple[float, ...] = ()
    tols: tuple[float, ...] = ()
    options: Mapping[str, Any] = field(default_factory=dict)
    declared: bool = False      # declared for the case (by the case or the integrator; else: its defaults)


@dataclass(frozen=True)
class Protocol:
    """What `daebench compare` runs on a case, which error measures it plots and judges and
    their target errors (none: round decades of the runs' errors); in a measure ``{obs}``
    stands for the case's headline observable
    (:func:`daebench.harness.scoring.pipeline.headline`: what the model declares first)."""

    entries: tuple[Entry, ...]
    measures: tuple[str, ...] = DEFAULT_MEASURES
    why: str = ""
    targets: Mapping[str, tuple[float, ...]] = field(default_factory=dict)

    def resolved(self, obs: str) -> "Protocol":
        """This protocol with ``{obs}`` replaced by the score name ``obs``."""
        return replace(self, measures=tuple(m.format(obs=obs) for m in self.measures),
                       targets={m.format(obs=obs): t for m, t in self.targets.items()})


def _from_runs(name: str, runs: base.Runs) -> Entry:
    return Entry(name, tuple(runs.steps), tuple(runs.tols), dict(runs.options), True)


def case_entry(name: str, cls: type, cmp: Comparison) -> Entry | None:
    """The runs the case's ``[compare]`` table gives integrator ``name`` (module
    docstring), or None when it gives it none (not named, or no series for its kind)."""
    if not cmp.names(name):
        return None
    caps = cls.capabilities
    if caps.fixed_step and cmp.steps:
        settings = {s.name for s in cls.settings_spec}
        driven = not caps.contacts and "h_contact" in settings and cmp.contact_step > 0
        return Entry(name, cmp.steps, (), {"h_contact": cmp.contact_step} if driven else {}, True)
    if caps.adaptive and not caps.fixed_step and cmp.tolerances:
        return Entry(name, (), cmp.tolerances, {}, True)
    return None


def declared_entries(scene: Scene) -> dict[str, Entry]:
    """The runs declared for ``scene`` per registered integrator — its own declaration for
    the case, else the case's table's —, in run order: tolerance runs first (the longest:
    a two-worker sweep then ends together), then by name; integrators with neither are not
    in it."""
    out = {}
    for name, reg in integrator_registry.registry().items():
        if reg.cls is None:
            continue
        own = reg.cls.protocol(scene.name)
        entry = _from_runs(name, own) if own is not None else case_entry(name, reg.cls, scene.comparison)
        if entry is not None:
            out[name] = entry
    return dict(sorted(out.items(), key=lambda kv: (not kv[1].tols, kv[0])))


def case_measures(scene: Scene) -> tuple[tuple[str, ...], Mapping[str, tuple[float, ...]], str]:
    """The case's headline measures, their targets and why (its ``[compare]`` table; the
    default measure otherwise)."""
    cmp = scene.comparison
    return (cmp.measures or DEFAULT_MEASURES), cmp.targets, cmp.why


def default_protocol(scene: Scene) -> Protocol:
    """Every registered integrator, one run at its default settings, judged by the case's
    measures."""
    measures, targets, _ = case_measures(scene)
    return Protocol(tuple(Entry(n) for n in sorted(integrator_registry.registry())), measures,
                    "no protocol declared for this case: every integrator once, at its default settings", targets)


def protocol_for(scene: Scene) -> Protocol:
    """What compare runs on ``scene``: the runs declared for it (:func:`declared_entries`),
    then every registered integrator with none, once at its defaults, so that the
    comparison covers every integrator; the case's measures and targets."""
    declared = declared_entries(scene)
    if not declared:
        return default_protocol(scene)
    measures, targets, why = case_measures(scene)
    extra = tuple(Entry(n) for n in sorted(integrator_registry.registry()) if n not in declared)
    return Protocol(tuple(declared.values()) + extra, measures,
                    "the runs declared for this case, the others once at their defaults"
                    + (f"; {why}" if why else ""), targets)
