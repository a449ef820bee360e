"""The integrator plugin contract and its counters (the registry: :mod:`daebench.integrators.registry`).

Implementer's contract (rule by rule, in the spirit of ``scipy.integrate.OdeSolver``):

1. Subclass :class:`Integrator`; set the class attributes ``name`` (unique, lower
   case), ``description`` (one line), ``capabilities`` (a :class:`Capabilities`)
   and ``settings_spec`` (a tuple of :class:`Setting`). Settings are validated by
   the base class and stored in ``self.settings`` (a dict).
2. Implement ``_start(self)``: called by :meth:`Integrator.start` after
   ``self.problem``, ``self.state`` (a consistent :class:`~daebench.core.system.State`)
   and ``self.h`` (the step size of this phase) are set. Reset any history here:
   the driver restarts the integrator after every event.
3. Implement ``_step_impl(self, t_stop) -> State``: advance one *accepted* step,
   never past ``t_stop``, and return the new state (with ``a`` and ``lam``).
   Adaptive methods reject and retry internally, counting ``self.counters.rejected``.
   Raise :class:`StepFailure` (with a reason) when no step can be taken; the
   driver turns it into a verdict, never a crash.
4. Count your own linear algebra: ``self.counters.lu_factorizations`` and
   ``self.counters.newton_iterations``. Residual and Jacobian evaluations made
   through the problem are counted automatically; steps are counted by the base.
5. Optionally override :meth:`dense` (the default is a cubic Hermite interpolant
   of q and v between the last two states, linear in λ) and :meth:`dense_many`.
6. Step control: a fixed-step method takes ``self.h``; every method lands exactly on
   ``t_stop`` with :func:`daebench.stepping.control.land` (a step within SNAP·h of it
   ends on it). An adaptive method uses a :class:`daebench.stepping.control.StepControl`
   (``self.step_control()``: fixed h, or error control to rtol/atol for the declared
   order) and :func:`daebench.stepping.control.judge` to accept or reject.
7. An integrator that resolves contacts itself (``capabilities.contacts``) reports
   each contact episode with :meth:`report_contact`; the driver books it like an impact.

The driver calls :meth:`start`, :meth:`advance` (an :class:`Advance`), :meth:`dense` and :meth:`dense_many`, and
reads ``capabilities``, ``records_outputs`` and ``counters_snapshot()``; the steps come from
the run's :class:`daebench.driver.step_policy.StepPolicy`, built from :meth:`step_size`. An integrator
reads the phase from its :class:`~daebench.core.problem.Problem` and nothing else.

For speed, subclass :class:`daebench.integrators.compiled.CompiledIntegrator` instead:
write the step as a compiled stepper (:mod:`daebench.stepping.methods`) and the base
runs it many steps per call, fixed or adaptive, on every model.

Built-ins register under the entry-point group ``daebench.integrators``; a third-
party package does the same in its own ``pyproject.toml`` (:mod:`daebench.integrators.registry`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

from daebench.core.contact import Impact
from daebench.core.params import Param, ParamError, did_you_mean
from daebench.core.problem import Problem
from daebench.stepping import control, dense as _dense
from daebench.stepping.watch import Watch
from daebench.core.system import State
from daebench.integrators import declarations



class StepFailure(RuntimeError):
    """An integrator could not take a step (Newton failure, step size underflow …).
    ``t`` is the time reached before the failing step, when known; ``outputs`` the
    (output time, state) of the output times the call's quiet steps passed before it (an
    integrator with ``records_outputs``: the driver writes their rows, then the run fails)."""

    def __init__(self, message: str, t: float | None = None,
                 outputs: Sequence[tuple[float, Any]] = ()):
        super().__init__(message)
        self.t = t
        self.outputs = list(outputs)


class IntegratorError(ParamError):
    """Bad integrator name, settings, or a capability mismatch — raised before any step."""


class ContractViolation(StepFailure):
    """A step broke the integrator contract (a wrong shape, no advance in t, a step past
    ``t_stop``): raised at the step where it happens, naming what and what was expected.
    The driver ends the run with it as the reason (status ``failed``)."""


Setting = Param  # an integrator setting is a declared parameter


@dataclass(frozen=True)
class Capabilities:
    """What an integrator declares about itself; the harness reads only this.

    Attributes
    ----------
    order : int
        Classical order of accuracy on smooth problems.
    fixed_step, adaptive : bool
        Step-size modes it supports (the ``adaptive`` setting selects).
    constraints : bool
        Whether it integrates problems with active constraints (m > 0).
    index : int or None
        The constraint formulation it accepts: 3 (position level, C = 0 enforced),
        1 (acceleration level, possibly stabilized); None for ODE-only methods.
    dense_output : bool
        Whether :meth:`Integrator.dense` is better than the default Hermite cubic.
    contacts : bool
        Whether it resolves the system's contacts itself (event-capturing time stepping:
        complementarity, Moreau–Jean, …) instead of leaving them to the driver's events
        and contact laws. It takes over contacts with no law ('complementarity') and
        those with the ``constraint`` law, whose restitution it applies; it reports each
        contact episode with :meth:`Integrator.report_contact`.
    friction : bool
        Whether it applies Coulomb friction at the contacts it resolves (a model's
        ``tangent`` kernel with μ > 0, scene key ``contact.friction``) — or, for an
        integrator the driver runs with the ``constraint`` law, whether it runs the driver's
        stick/slip phases (:mod:`daebench.driver.stickslip`: extra constraint rows and a
        state-dependent force, so it must take constraints). An integrator
        without it is refused on a case with μ > 0 before the first step (:func:`daebench.integrators.applicability.applies_friction`).
    """

    order: int
    fixed_step: bool = True
    adaptive: bool = False
    constraints: bool = False
    index: int | None = None
    dense_output: bool = False
    contacts: bool = False
    friction: bool = False


@dataclass(frozen=True)
class Runs:
    """What `daebench compare` (and the survey) runs of one integrator on one case: fixed
    steps ``steps`` [s] or tolerances ``tols`` (adaptive: rtol = tol, atol = tol/100) —
    neither: one run at its defaults — with the fixed settings ``options``."""

    steps: tuple[float, ...] = ()
    tols: tuple[float, ...] = ()
    options: Mapping[str, Any] = field(default_factory=dict)


DEFAULT_STEP = 1e-4  # s: the default fixed step (the paper's protocol outside contact)
AUTO_STEP = "auto"   # h = auto: the largest stable step of a conditionally stable method (Integrator.with_step)

# Settings every stepping integrator shares: the paper's protocol and adaptivity.
STEP_SETTINGS = (
    Setting("h", float, DEFAULT_STEP, "fixed step size outside contact [s]", low=1e-12, high=1.0),
    Setting("h_contact", float, 0.0, "fixed step size while a contact is closed, penetrating or near its surface [s]; 0 = same as h",
            low=0.0, high=1.0),
)
ADAPTIVE_SETTINGS = (
    Setting("adaptive", bool, False, "choose the step size from a local error estimate"),
    Setting("rtol", float, 1e-6, "relative tolerance of the local error (adaptive mode)", low=1e-14, high=1.0),
    Setting("atol", float, 1e-8, "absolute tolerance of the local error (adaptive mode)", low=1e-16, high=1.0),
)


@dataclass
class Counters:
    """Work counters kept identically for every integrator."""

    steps: int = 0
    rejected: int = 0
    residual_evals: int = 0
    jacobian_evals: int = 0
    lu_factorizations: int = 0
    newton_iterations: int = 0

    def as_dict(self) -> dict[str, int]:
        return asdict(self)

    def add(self, other: "Counters") -> None:
        for f in fields(self):
            setattr(self, f.name, getattr(self, f.name) + getattr(other, f.name))


class Integrator:
    """Base class of every time integrator (see the module docstring for the contract)."""

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""
    capabilities: ClassVar[Capabilities] = Capabilities(order=1)
    settings_spec: ClassVar[tuple[Setting, ...]] = ()
    #: contact laws whose contacts it takes over (``capabilities.contacts`` only):
    #: "complementarity" = left to it (no law), "constraint" = the impact law's restitution applies
    contact_laws: ClassVar[tuple[str, ...]] = ("complementarity", "constraint")
    #: its own protocol per case (scene name → :class:`Runs`), read by :meth:`protocol`; it
    #: comes before the case's ``[compare]`` table (daebench's own declare none: the cases do)
    protocols: ClassVar[Mapping[str, Runs]] = {}

    def __init__(self, **settings: Any) -> None:
        spec = {s.name: s for s in self.settings_spec}
        # h = auto: the largest stable step of a conditionally stable method, chosen before the
        # first step by the harness (daebench.harness.running.checks.check_step), then with_step()
        self.auto_step = isinstance(settings.get("h"), str) and settings["h"].strip().lower() == AUTO_STEP \
            and "h" in spec
        if self.auto_step:
            settings = {k: v for k, v in settings.items() if k != "h"}
        self.default_step = "h" in spec and "h" not in settings and not self.auto_step   # h not chosen
        unknown = [k for k in settings if k not in spec]
        if unknown:
            k = unknown[0]
            raise IntegratorError(
                f"integrator '{self.name}' has no setting '{k}'{did_you_mean(k, spec)} "
                f"(settings: {', '.join(spec) or 'none'})"
            )
        try:
            self.settings: dict[str, Any] = {
                name: s.validate(settings.get(name, s.default), f"integrator '{self.name}' setting")
                for name, s in spec.items()
            }
        except IntegratorError:
            raise
        except ParamError as exc:
            raise IntegratorError(str(exc)) from None
        self._check_settings()
        self.counters = Counters()
        self.problem: Problem | None = None
        self.state: State | None = None
        self.prev: State | None = None
        self.h = 0.0
        self._eval_base = (0, 0)
        self._events: list[Impact] = []
        self.failure: Exception | None = None   # the exception that ended a step, with its traceback

    # -- configuration ------------------------------------------------------
    def _check_settings(self) -> None:
        """Cross-setting validation hook (raise IntegratorError)."""

    def stability_model(self) -> Any:
        """The linear stability model of this method at its fixed step
        (:mod:`daebench.stepping.stability`: a ``NewmarkMember`` or ``AbmPece``), or None when
        it has none. A method whose interval is finite (explicit, conditionally stable) has its
        step checked against the scene's ω_max before the first step, and may take h = auto."""
        return None

    def with_step(self, h: float) -> "Integrator":
        """A new integrator of this class and settings at the fixed step ``h`` (h = auto, or a
        default beyond the stable step, resolved by the harness before the first step), its
        h_contact lowered to ``h`` where it was larger; this one is left as it is."""
        settings = {**self.settings, "h": float(h)}
        if float(settings.get("h_contact", 0.0) or 0.0) > h:
            settings["h_contact"] = float(h)
        return type(self)(**settings)

    def to_config(self) -> dict[str, Any]:
        return {"integrator": self.name, **self.settings}

    @classmethod
    def from_config(cls, config: dict[str, Any]) -> "Integrator":
        cfg = dict(config)
        name = cfg.pop("integrator", cls.name)
        if name != cls.name:
            raise IntegratorError(f"config is for '{name}', not '{cls.name}'")
        return cls(**cfg)

    @classmethod
    def protocol(cls, case: str) -> Runs | None:
        """What `daebench compare` runs of this integrator on the scene ``case`` (steps or
        tolerances, fixed settings) before the case's ``[compare]`` table; None: the case's
        table decides (else one run at its defaults). Override it, or declare ``protocols``."""
        return cls.protocols.get(case)

    @property
    def adaptive(self) -> bool:
        return bool(self.settings.get("adaptive", False))

    def step_size(self, in_contact: bool) -> float:
        """The fixed step of the settings for a phase in contact or not (h_contact > 0 in contact)."""
        hc = float(self.settings.get("h_contact", 0.0) or 0.0)
        return hc if (in_contact and hc > 0.0) else float(self.settings.get("h", DEFAULT_STEP))

    # -- stepping -------------------------------------------------------------
    def start(self, problem: Problem, state: State, h: float) -> None:
        """(Re)start on ``problem`` from the consistent ``state`` with step ``h``."""
        self._sync_eval_counters()
        self.problem = problem
        self._eval_base = (problem.counters.residual_evals, problem.counters.jacobian_evals)
        self.state = state.copy()
        self.prev = None
        self.h = float(h)
        self._start()

    def step(self, t_stop: float) -> State:
        """Advance one accepted step, not past ``t_stop``; return the new state."""
        if self.problem is None or self.state is None:
            raise RuntimeError("call start() before step()")
        if t_stop <= self.state.t:
            raise ValueError(f"t_stop = {t_stop} is not after t = {self.state.t}")
        prev = self.state
        try:
            new = self._step_impl(t_stop)
            check_step(self, prev, new, t_stop)
        except Exception as exc:  # kept with its traceback: the plugin's frames, for `run --traceback`
            self.failure = exc
            raise
        self.prev = prev
        self.state = new
        self.counters.steps += 1
        return new

    def advance(self, t_stop: float, watch: Watch | None = None) -> Advance:
        """Advance one or more accepted steps, never past ``t_stop``. The default takes one
        :meth:`step`. An integrator may take several when given a ``watch``, stopping after
        the first step the driver must see (:func:`daebench.stepping.watch.quiet`) and
        doing the quiet steps' bookkeeping on its own copies of the watch's arrays."""
        prev, new = self.state, self.step(t_stop)
        return Advance(prev, new, 1, *((None, None) if watch is None else (watch.armed, watch.cmax)),
                       self._take_events())

    def report_contact(self, event: Impact) -> None:
        """Book a contact episode resolved inside the steps (contact-resolving methods)."""
        self._events.append(event)

    def _take_events(self) -> list[Impact]:
        out, self._events = self._events, []
        return out

    def step_control(self) -> control.StepControl:
        """Fixed ``h`` or, with ``adaptive``, error control to (rtol, atol) for the
        declared order (the first step is ``h``)."""
        if self.adaptive:
            return control.adaptive(self.h, self.settings["rtol"], self.settings["atol"], self.capabilities.order)
        return control.fixed(self.h)

    def dense(self, t: float) -> State:
        """State at t within the last step: cubic Hermite in q (with v) and v (with a), linear in λ."""
        s0, s1 = self.prev, self.state
        return s1.copy() if s0 is None else hermite_state(s0, s1, t)

    def dense_many(self, ts: Sequence[float]) -> list[State]:
        """:meth:`dense` at each of the times ``ts`` (an override may compute them at once)."""
        return [self.dense(t) for t in ts]

    def counters_snapshot(self) -> dict[str, int]:
        self._sync_eval_counters()
        return self.counters.as_dict()

    def _sync_eval_counters(self) -> None:
        if self.problem is not None:
            c = self.problem.counters
            self.counters.residual_evals += c.residual_evals - self._eval_base[0]
            self.counters.jacobian_evals += c.jacobian_evals - self._eval_base[1]
            self._eval_base = (c.residual_evals, c.jacobian_evals)

    # -- for subclasses ---------------------------------------------------------
    def _start(self) -> None:
        raise NotImplementedError

    def _step_impl(self, t_stop: float) -> State:
        raise NotImplementedError


def check_step(integ: Integrator, prev: State, new: Any, t_stop: float) -> None:
    """Hold one step to the contract (rule 3): a :class:`State` after ``prev.t``, not past
    ``t_stop``, with q, v, a of shape (n,) and λ of shape (m,) for the phase's problem.

    Raises
    ------
    ContractViolation
        Naming the integrator, the time, the array, its shape and the expected one."""
    p = integ.problem
    where = f"integrator '{integ.name}' broke the step contract in the step from t = {prev.t:.9g} s"
    if not isinstance(new, State):
        raise ContractViolation(f"{where}: _step_impl returned {type(new).__name__}, not a "
                                f"daebench.core.system.State", prev.t)
    expected = {"q": (p.n,), "v": (p.n,), "a": (p.n,), "lam": (p.m,)}
    for key, shape in expected.items():
        got = np.shape(getattr(new, key))
        own = key == "lam" and integ.capabilities.contacts and got == (p.m + p.n_contacts,)
        if got != shape and not own:
            what = f"{p.n} coordinates" if key != "lam" else f"{p.m} active constraints" + (
                f"; or {(p.m + p.n_contacts,)} with one contact force per contact point, for an integrator that "
                f"resolves contacts" if integ.capabilities.contacts else "")
            raise ContractViolation(f"{where}: {key} has shape {got}, expected {shape} ({what} in this phase)", prev.t)
    t = float(new.t)
    if not t > prev.t:
        raise ContractViolation(f"{where}: the step returned t = {t:.9g} s, which does not advance t (a step must "
                                f"advance one accepted step; the run ends here instead of calling it again)", prev.t)
    if t > t_stop:
        raise ContractViolation(f"{where}: the step returned t = {t:.9g} s, past t_stop = {t_stop:.9g} s (land on "
                                f"t_stop: daebench.stepping.control.land)", prev.t)


@dataclass
class Advance:
    """What :meth:`Integrator.advance` hands the driver: the last step (prev → new), how
    many accepted steps were taken, the watch's re-armed contacts and constraint maxima
    after the quiet steps, the contact episodes the integrator resolved itself, and — for
    such integrators — the cumulative work of their contact forces at prev.t and at new.t
    and, optionally, their power at prev.t (the driver books it as ``W_contact`` in the
    energy balance, interpolated within the step: quadratic with the power, else linear)."""

    prev: State
    new: State
    steps: int
    armed: np.ndarray | None = None
    cmax: np.ndarray | None = None
    events: list[Impact] = field(default_factory=list)
    contact_work: tuple[float, ...] | None = None


@dataclass
class RecordedAdvance(Advance):
    """An :class:`Advance` with the (output time, state there) of the output times its quiet
    steps passed (``advance`` given the output times, by integrators with
    ``records_outputs``; the driver writes their rows)."""

    outputs: list[tuple[float, State]] = field(default_factory=list)


def hermite_state(s0: State, s1: State, t: float) -> State:
    """Cubic Hermite interpolation between two states (q with v, v with a; the one rule,
    :func:`daebench.stepping.dense.hermite`, which the compiled runner's output rows use too)."""
    if s1.t - s0.t <= 0.0:
        return s1.copy()
    q, v, a, lam = (np.empty(x.size) for x in (s1.q, s1.v, s1.a, s1.lam))
    c = np.ascontiguousarray
    _dense.hermite(float(s0.t), c(s0.q, float), c(s0.v, float), c(s0.a, float), c(s0.lam, float), float(s1.t),
                   c(s1.q, float), c(s1.v, float), c(s1.a, float), c(s1.lam, float), float(t), q, v, a, lam)
    return State(float(t), q, v, a, lam)


# -- declarations -----------------------------------------------------------------------------
def declaration_problems(cls: Any, name: str | None = None) -> list[str]:
    """What is wrong with the declarations of integrator class ``cls`` (rule 1 of the
    contract: a subclass of :class:`Integrator`, a valid ``name`` — the entry point's
    ``name`` when given —, valid :class:`Capabilities`, a tuple of valid :class:`Setting`:
    :mod:`.declarations` —, and rules
    2–3: ``_start`` and ``_step_impl`` implemented, unless it is compiled); [] when none."""
    if not (isinstance(cls, type) and issubclass(cls, Integrator)):
        return [f"{cls!r} is not a subclass of daebench.integrators.base.Integrator"]
    own = getattr(cls, "name", "")
    out = declarations.name_problems(own)
    if not out and name is not None and own != name:
        out.append(f"the entry point is named '{name}' but the class declares name = '{own}' (make them agree: "
                   f"rename the entry point in the plugin's pyproject.toml or the class attribute `name`)")
    if not isinstance(cls.capabilities, Capabilities):
        out.append(f"capabilities = {cls.capabilities!r}: a daebench.integrators.base.Capabilities is needed")
    else:
        out += declarations.capability_problems(cls.capabilities)
    spec = cls.settings_spec
    if not isinstance(spec, (tuple, list)) or not all(isinstance(x, Param) for x in spec):
        out.append("settings_spec must be a tuple of daebench.integrators.base.Setting")
    else:
        out += declarations.settings_problems(spec)
    compiled = any(k.__name__ == "CompiledIntegrator" and k.__module__.startswith("daebench.") for k in cls.__mro__)
    if not compiled:
        for method in ("_start", "_step_impl"):
            if getattr(cls, method) is getattr(Integrator, method) and cls.advance is Integrator.advance:
                out.append(f"{method}() is not implemented (rule {2 if method == '_start' else 3} of the contract)")
    return out
