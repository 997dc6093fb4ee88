"""One walker class for every walker: a plan, its compiled model and its run values.

The walker front end is a pipeline of typed products, each built once:

1. :func:`~.reading.walker_spec` — the ``[walker]`` table read against the model's frozen
   description: a :class:`~.hybrid.WalkerSpec` with its expressions parsed;
2. :func:`~.plan.walker_plan` — the spec checked against the model's
   :func:`~porthamiltonian.compiler.layout` (the names its compiled form will have): a
   :class:`~.plan.WalkerPlan` of frozen records, and the model's description with one output per
   expression a walk evaluates;
3. :func:`compile_walker` — that description compiled (:func:`porthamiltonian.compile_model`,
   cached on disk by the description's hash: the one place a compile is remembered) and the
   plan's records bound to its layout: a :class:`CompiledWalker` (output indices, the mode
   machine, the relabelling and impact maps);
4. :class:`HybridWalker` ``(plan, compiled)`` — the :class:`~.protocol.Walker` the analyses use,
   its run values (parameters, the parameter vector, the initial state, the integrator
   settings) in an immutable :class:`RunValues` that :meth:`~HybridWalker.with_parameters` and
   :meth:`~HybridWalker.with_options` replace; the plan and the compiled walker are shared.

:func:`build_walker` runs the pipeline for a spec; :func:`~.files.load_walker` for a file.
Rigid-impact walkers (a swing phase pinned at the stance foot, a plastic impact at heel strike)
and compliant-contact walkers (one floating-base model, contacts switched by the scuffing rule)
are configurations of it, not subclasses; a rule with an ``impact`` also compiles the floating
version of the multibody (:func:`~.resets.floating_model`, python back end: only its matrices
are used).

A walk (:meth:`HybridWalker.walk`): the section state z is lifted to a model state
(:meth:`~HybridWalker.lift`: the section coordinates, then the completions in order, then the
momenta p = M(q) v); the modes take their start values (the drop parameter the ``ground_drop``),
the ``start`` rules apply; one :func:`porthamiltonian.simulate` run with one action per event
(:class:`~.machine.ModeMachine`) goes on until the requested number of heel strikes, a fall, or
``max_step_time`` per step; :mod:`.strides` cuts the trajectory into :class:`~.protocol.Stride`
records, each ending on the section (:meth:`~HybridWalker.project`, relabelled into the section's
labelling when its ``labelling`` condition does not hold).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import Any

import numpy as np

from porthamiltonian.compiler import compile_model, layout
from porthamiltonian.errors import ModelError, ParameterValueError, StateError
from porthamiltonian.integrators import COMPILED_METHODS
from porthamiltonian.interfaces.io import ModelFile
from porthamiltonian.simulation.compiled import CompiledModel
from porthamiltonian.simulation.trajectory import Trajectory

from .hybrid import Integration, WalkerSpec
from .machine import Change, Condition, ModeMachine, Transition, WalkLog
from .plan import BodiesMass, ChangePlan, WalkerPlan, walker_plan
from .protocol import ParameterSpec, Stride, StrideStatus, check_parameters
from .reading import walker_spec
from .resets import ConstraintImpact, ImpactMap, Relabel
from .strides import cut_strides
from .variational import StrideSensitivity, stride_sensitivity

__all__ = ["CompiledWalker", "HybridWalker", "RunValues", "bind_walker", "build_walker",
           "compile_walker", "plan_walker"]


def _frozen(a: Any) -> np.ndarray:
    out = np.array(a, dtype=float)
    out.flags.writeable = False
    return out


@dataclass(frozen=True, eq=False)
class CompiledWalker:
    """A :class:`~.plan.WalkerPlan` bound to its compiled model (see the module docstring).

    model : the compiled model (the walker's expressions among its outputs); floating : the
    compiled floating-base multibody of a rigid walker's impact (None without one). out : output
    index by name. coordinates, momenta : state indices of the multibody's coordinates q and
    momenta p; rates : index into the joint rates v by rate name (``walker.v.leg1``). relabel :
    the relabelling (None without one). angles : θ, φ coefficients over q. to_thesis,
    from_thesis : the section's thesis map and its inverse. labelling : the section's labelling
    condition. start : the modes' start values; guess : the initial guess per section
    coordinate (:class:`~.machine.Change`: a number or an output). mass, leg_length : output
    indices; drop : the drop parameter's index. machine : the mode machine. bodies : the
    bodies' masses ``[walker] mass`` is checked against.
    """

    model: CompiledModel
    floating: CompiledModel | None
    out: Mapping[str, int]
    coordinates: tuple[int, ...]
    momenta: tuple[int, ...]
    rates: Mapping[str, int]
    relabel: Relabel | None
    angles: Mapping[str, np.ndarray]
    to_thesis: np.ndarray
    from_thesis: np.ndarray
    labelling: Condition | None
    start: tuple[Change, ...]
    guess: tuple[Change, ...]
    mass: int
    leg_length: int
    drop: int
    machine: ModeMachine
    bodies: BodiesMass


def compile_walker(plan: WalkerPlan, backend: str | None = None, text: str = "") -> CompiledWalker:
    """Compile ``plan``'s model description (back end ``backend``, default the spec's) and bind
    the plan to it (module docstring). ``text``: the file's TOML, for lines in errors."""
    spec = plan.spec
    with ModelFile(spec.model, spec.source, text).located():
        m = compile_model(plan.description, backend=backend or spec.integration.backend)
    floating = (compile_model(plan.floating.model, backend="python")
                if plan.floating is not None else None)
    return bind_walker(plan, m, floating)


def bind_walker(plan: WalkerPlan, m: CompiledModel, floating: CompiledModel | None) -> CompiledWalker:
    """Bind ``plan`` to its compiled model ``m`` (and ``floating``, the compiled floating
    multibody of its impacts, if it has any): what :func:`compile_walker` does once compiled,
    and a warm start (:mod:`.warm`) with the models reopened from the cache."""
    out = MappingProxyType({n: i for i, n in enumerate(m.output_names)})
    mb = plan.names.multibody
    iq = tuple(i for i, s in enumerate(m.state_names) if s.startswith(f"{mb}.q."))
    relabel = (Relabel.build(plan.relabel.space, plan.relabel.A, plan.relabel.b, m.state_names,
                             m.param_names, [m.state_names[i] for i in iq], out)
               if plan.relabel is not None else None)
    sec = plan.section
    labelling = (Condition(sec.labelling.text, out[sec.labelling.output], sec.labelling.op)
                 if sec.labelling is not None else None)
    return CompiledWalker(
        model=m, floating=floating, out=out, coordinates=iq,
        momenta=tuple(i for i, s in enumerate(m.state_names) if s.startswith(f"{mb}.p.")),
        rates=MappingProxyType({f"{mb}.v.{m.state_names[i][len(mb) + 3:]}": k
                                for k, i in enumerate(iq)}),
        relabel=relabel,
        angles=MappingProxyType({k: _frozen(v) for k, v in sec.angles.items()}),
        to_thesis=_frozen(sec.to_thesis), from_thesis=_frozen(sec.from_thesis),
        labelling=labelling,
        start=tuple(Change(c.name, m.param_names.index(c.name), c.constant,
                           None if c.output is None else out[c.output]) for c in plan.start),
        guess=tuple(Change(c.name, k, c.constant, None if c.output is None else out[c.output])
                    for k, c in enumerate(plan.guess)),
        mass=out[plan.mass], leg_length=out[plan.leg_length],
        drop=m.param_names.index(plan.drop),
        machine=ModeMachine(m, _transitions(plan, m, floating, relabel, out)),
        bodies=plan.bodies)


def _transitions(plan: WalkerPlan, m: CompiledModel, floating: CompiledModel | None,
                 relabel: Relabel | None, out: Mapping[str, int]) -> tuple[Transition, ...]:
    """The plan's transitions bound to the compiled model (with their impact maps)."""
    events = [e.name for e in m.events]
    result = []
    for t in plan.transitions:
        impact: ImpactMap | ConstraintImpact | None = None
        if (t.impact is not None and plan.floating is not None and floating is not None
                and relabel is not None):       # the reader asks for a relabel with an impact
            impact = ImpactMap(m, floating, plan.names.multibody, t.impact, plan.spec.hip,
                               relabel, plan.floating.root, plan.floating.rehung)
        elif t.engage is not None:
            impact = ConstraintImpact(m, plan.names.multibody, t.engage)
        k = events.index(t.event) if t.event != "start" else -1
        result.append(Transition(
            t.name, t.event, k, m.events[k].direction if k >= 0 else 0,
            tuple(Condition(c.text, out[c.output], c.op) for c in t.conditions),
            tuple(Change(c.name, m.param_names.index(c.name), c.constant,
                         None if c.output is None else out[c.output]) for c in t.changes),
            impact, t.heel_strike, t.fall, t.energy, t.foot))
    return tuple(result)


@dataclass(frozen=True, eq=False)
class RunValues:
    """A walker's run values (SI): its parameters by name, the parameter vector ``p`` and the
    initial state ``x_init`` of the compiled model (read-only arrays), the total mass (kg) and
    leg length (m) at these parameters, and the integrator settings. Immutable: a walker with
    other values holds another record (``dataclasses.replace``)."""

    parameters: Mapping[str, float]
    p: np.ndarray
    x_init: np.ndarray
    total_mass: float
    leg_length: float
    options: Integration

    @classmethod
    def of(cls, compiled: CompiledWalker, parameters: Mapping[str, float],
           options: Integration) -> RunValues:
        """The run values of ``compiled`` at ``parameters`` (validated already) and
        ``options``."""
        m = compiled.model
        p = m.params({k: v for k, v in parameters.items() if k in m.param_names})
        x = m.initial_state(p)
        y = m.outputs(0.0, x, p)
        mass = float(y[compiled.mass])
        compiled.bodies.check(mass, {**parameters, **dict(zip(m.param_names, p.tolist()))})
        return cls(MappingProxyType(dict(parameters)), _frozen(p), _frozen(x), mass,
                   float(y[compiled.leg_length]), options)

    def with_parameters(self, compiled: CompiledWalker, parameters: Mapping[str, float]) -> RunValues:
        """These run values with other parameters (validated already)."""
        new = RunValues.of(compiled, parameters, self.options)
        return replace(self, parameters=new.parameters, p=new.p, x_init=new.x_init,
                       total_mass=new.total_mass, leg_length=new.leg_length)


def build_walker(spec: WalkerSpec, *, backend: str | None = None,
                 options: Integration | None = None, values: Mapping[str, float] | None = None,
                 text: str = "") -> HybridWalker:
    """The walker of ``spec`` (module docstring: read if it was built in Python, planned against
    its model's layout, compiled, bound). ``backend``: default the spec's
    ``integration.backend`` (``"auto"``: the framework's choice); ``options``: integrator
    settings replacing the spec's; ``values``: parameter values by name (validated against the
    ranges); ``text``: the file's TOML, for lines in errors. Raises ModelFileError for a bad
    description (before anything is compiled) and ParameterValueError for bad values."""
    plan = plan_walker(spec, text)
    options = options or plan.spec.integration
    compiled = compile_walker(plan, backend or options.backend, text)
    return HybridWalker(plan, compiled, values=values, options=options)


def plan_walker(spec: WalkerSpec, text: str = "") -> WalkerPlan:
    """The plan of ``spec`` (read first if it was built in Python) against its model's layout
    (the steps of :func:`build_walker` before the compile). ``text``: the file's TOML, for lines
    in errors."""
    if spec.parsed is None or spec.frozen is None:
        spec = walker_spec(spec.model, spec.to_table(), source=spec.source, text=text,
                           description=spec.description, units=spec.units)
    with ModelFile(spec.model, spec.source, text).located():
        names = layout(spec.frozen if spec.frozen is not None else spec.model)
    return walker_plan(spec, names, text)


class _OverBudget(Exception):
    """A stride of a walk took more integrator steps than its budget (raised by the run's
    progress callback; ``steps``: the run's steps at the stride's start)."""

    def __init__(self, steps: int):
        super().__init__(steps)
        self.steps = steps


class HybridWalker:
    """A walker: its :class:`~.plan.WalkerPlan`, its :class:`CompiledWalker` and its
    :class:`RunValues` (see the module docstring; :func:`build_walker` and
    :func:`~.files.load_walker` make one).

    Parameters
    ----------
    plan, compiled : the plan and the compiled walker (shared by every copy).
    run : the run values; default: ``values`` (parameter values by name, validated against the
        ranges; the spec's defaults for the others) and ``options`` (integrator settings; default
        the spec's).

    Attributes
    ----------
    name, doc, spec; model : the compiled model; backend : its back end; multibody : its
    multibody's name; parameters : the current values (SI); specs : the
    :class:`~.protocol.ParameterSpec` per parameter; section, thesis_section : names of the
    section's coordinates (model's, thesis's); legged : θ and φ are defined; options : the
    integrator settings; machine : the mode machine.
    """

    def __init__(self, plan: WalkerPlan, compiled: CompiledWalker, run: RunValues | None = None,
                 *, values: Mapping[str, float] | None = None,
                 options: Integration | None = None):
        self.plan = plan
        self.compiled = compiled
        self.run = run if run is not None else RunValues.of(
            compiled, check_parameters(plan.parameters, dict(values or {})),
            options or plan.spec.integration)
        #: the last plain walk: (z, n_steps, ground_drop) and (trajectory, log, x0, p0, the run
        #: values it used: a walk after ``walker.run`` was replaced is integrated again) (:meth:`walk`)
        self._last_walk: tuple[tuple, tuple] | None = None

    # --- what the walker is --------------------------------------------------------------------
    @property
    def spec(self) -> WalkerSpec:
        """The walker's description (its table, read)."""
        return self.plan.spec

    @property
    def name(self) -> str:
        """The walker's name: its model's."""
        return self.plan.spec.name

    @property
    def doc(self) -> str:
        """The model file's ``[model] description``."""
        return self.plan.spec.description

    @property
    def model(self) -> CompiledModel:
        """The compiled model (the walker's expressions among its outputs)."""
        return self.compiled.model

    @property
    def backend(self) -> str:
        """The back end in use (``"auto"`` resolved)."""
        return self.compiled.model.backend

    @property
    def multibody(self) -> str:
        """The name of the model's multibody."""
        return self.plan.names.multibody

    @property
    def joint_types(self) -> Mapping[str, str]:
        """The multibody's joints' types by joint name (the reports' units read them)."""
        return dict(self.plan.names.joint_types)

    @property
    def machine(self) -> ModeMachine:
        """The mode machine (the rules as transitions)."""
        return self.compiled.machine

    @property
    def section(self) -> tuple[str, ...]:
        """Names of the section's coordinates (the model's)."""
        return self.plan.section.coordinates

    @property
    def thesis_section(self) -> tuple[str, ...]:
        """Names of the thesis's section coordinates (the section's own without a thesis)."""
        return self.plan.section.thesis_names

    @property
    def legged(self) -> bool:
        """True when the thesis's θ and φ are defined."""
        return self.plan.legged

    @property
    def specs(self) -> Mapping[str, ParameterSpec]:
        """The user-settable parameters with their ranges (the modes are the walker's own)."""
        return self.plan.parameters

    @property
    def mode_names(self) -> tuple[str, ...]:
        """Parameters the walker sets itself (its modes and the drop): not the user's."""
        return self.plan.spec.mode_names

    @property
    def run_time_parameters(self) -> tuple[str, ...]:
        """The parameters the compiled model takes at run time."""
        return tuple(self.compiled.model.param_names)

    @property
    def parameters(self) -> Mapping[str, float]:
        """The current parameter values by name (SI)."""
        return self.run.parameters

    @property
    def options(self) -> Integration:
        """The integrator settings."""
        return self.run.options

    @property
    def total_mass(self) -> float:
        """Total mass m_total (kg) at the current parameters (``[walker] mass``)."""
        return self.run.total_mass

    @property
    def leg_length(self) -> float:
        """The leg length (m) at the current parameters (``[walker] leg_length``)."""
        return self.run.leg_length

    @property
    def weight(self) -> float:
        """Total weight m_total g (N); g is the model's parameter ``g``."""
        return self.run.total_mass * self.run.parameters["g"]

    @property
    def gait_tolerance(self) -> float:
        """Newton tolerance of the gait search (section units)."""
        return self.run.options.gait_tolerance

    @property
    def feet(self) -> tuple[str, ...]:
        """The feet's multibody points (for stick figures)."""
        return tuple(f.point for f in self.spec.feet)

    @property
    def hip(self) -> str:
        """The multibody point reported as the hip (``[walker] hip``)."""
        return self.spec.hip

    # --- other values --------------------------------------------------------------------------
    def with_parameters(self, **values: float) -> HybridWalker:
        """A walker with some parameters changed (validated; plan and compiled model shared)."""
        parameters = check_parameters(self.plan.parameters, {**self.parameters, **values})
        return HybridWalker(self.plan, self.compiled,
                            self.run.with_parameters(self.compiled, parameters))

    def with_options(self, **changes: Any) -> HybridWalker:
        """A walker with some integrator settings changed (e.g. ``max_step``)."""
        return HybridWalker(self.plan, self.compiled,
                            replace(self.run, options=replace(self.run.options, **changes)))

    # --- numeric helpers ----------------------------------------------------------------------------
    def outputs(self, t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """All outputs of the compiled model at state ``x`` and parameters ``p``."""
        return self.model.outputs(t, x, p)

    def output(self, name: str, x: np.ndarray, p: np.ndarray | None = None,
               t: float = 0.0) -> float:
        """One named output at state ``x`` (parameters ``p``, default the walker's)."""
        p = self.run.p if p is None else p
        return float(self.outputs(t, x, p)[self.compiled.model.output_index(name)])

    def velocities(self, x: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
        """Joint rates v of the multibody: M(q) v = p (solved, not inverted)."""
        M = self.model.matrix(f"{self.multibody}.M", 0.0, x, self.run.p if p is None else p)
        try:
            return np.linalg.solve(M, np.asarray(x)[list(self.compiled.momenta)])
        except np.linalg.LinAlgError:
            raise StateError(f"walker {self.name!r}: the mass matrix {self.multibody}.M is "
                             "singular at this state: a body without mass or inertia (a "
                             "length or mass so small that its inertia rounds to zero?); "
                             "check the parameters") from None

    def start_params(self, ground_drop: float = 0.0, p: np.ndarray | None = None) -> np.ndarray:
        """The parameter vector at the start of a walk: the drop set to ``ground_drop``, the modes
        at their start values (before the ``start`` rules, which need the state); ``p``: from
        this parameter vector of the model instead of the walker's (its initial state
        evaluated again; for derivatives by parameters, without a walker per point)."""
        c = self.compiled
        x_init = self.run.x_init if p is None else self.model.initial_state(p)
        p = (self.run.p if p is None else np.asarray(p, dtype=float)).copy()
        p[c.drop] = float(ground_drop)
        y = self.model.outputs(0.0, x_init, p)
        for change in c.start:
            p[change.index] = change.value(y)
        return p

    # --- the section ----------------------------------------------------------------------------
    def lift(self, z: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
        """Section coordinates -> model state (see the module docstring)."""
        p = self.start_params() if p is None else p
        z = np.asarray(z, dtype=float)
        if z.shape != (len(self.section),):
            raise StateError(f"{self.name}: a section state has {len(self.section)} coordinates "
                             f"({', '.join(self.section)}), got {z.shape}")
        m, c = self.model, self.compiled
        x = np.zeros(m.n_states)
        v = np.zeros(len(c.coordinates))
        given = dict(zip(self.section, z))
        for name, value in given.items():
            if name in c.rates:
                v[c.rates[name]] = value
            elif name in m.state_names:
                x[m.state_index(name)] = value
        for step in self.plan.section.lift:
            if isinstance(step, ChangePlan):
                value = (step.constant if step.output is None
                         else self.outputs(0.0, x, p)[c.out[step.output]])
            else:
                value = self._solve(x, p, step.name, c.out[step.output],
                                    0.0 if step.given is None else given[step.given])
            if step.name in c.rates:
                v[c.rates[step.name]] = value
            else:
                x[m.state_index(step.name)] = value
        # momenta beyond the float64 range (a guess of 1e308 rad/s): a state that the run
        # refuses, and the stride falls; numpy's warning about it would only repeat that
        with np.errstate(over="ignore", invalid="ignore"):
            x[list(c.momenta)] = self.model.matrix(f"{self.multibody}.M", 0.0, x, p) @ v
        return x

    def _solve(self, x: np.ndarray, p: np.ndarray, target: str, o: int, value: float) -> float:
        """The value of state coordinate ``target`` that makes output ``o`` equal ``value``
        (secant iterations; one for an affine dependence, as the shipped walkers have)."""
        i = self.model.state_index(target)

        def g(c: float) -> float:
            x[i] = c
            return float(self.outputs(0.0, x, p)[o]) - value

        c0 = x[i]
        h = 1e-3 * max(1.0, abs(c0))
        g0 = g(c0)
        for _ in range(30):
            g1 = g(c0 + h)
            if g1 == g0:
                raise StateError(f"{self.name}: cannot complete {target!r}: the equation does "
                                 "not depend on it (see [walker.section.complete])")
            step = -g0 * h / (g1 - g0)
            c0 += step
            g0 = g(c0)
            if abs(step) <= 1e-15 * max(1.0, abs(c0)) or g0 == 0.0:
                break
            h = step
        x[i] = c0
        return c0

    def relabelled(self, x: np.ndarray, p: np.ndarray) -> bool:
        """True when the state ``x`` with parameters ``p`` is not in the section's labelling
        (its ``labelling`` condition does not hold), so :meth:`project` relabels it."""
        labelling = self.compiled.labelling
        return labelling is not None and not labelling.holds(self.outputs(0.0, x, p))

    def canonical(self, x: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(state, joint rates, parameters) of state ``x`` in the section's labelling: relabelled
        when the section's ``labelling`` condition does not hold (a compliant walker with foot 2
        leading), else as they are."""
        v = self.velocities(x, p)
        relabel = self.compiled.relabel
        if relabel is not None and self.relabelled(x, p):
            y = self.outputs(0.0, x, p)
            x = relabel.state(x, y)
            v = relabel.rates(v)
            p = relabel.params(p, y)
            x[list(self.compiled.momenta)] = self.model.matrix(f"{self.multibody}.M", 0.0, x, p) @ v
        return x, v, p

    def project(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Model state (on the section) -> section coordinates, in the section's labelling."""
        x, v, p = self.canonical(np.asarray(x, dtype=float), p)
        c = self.compiled
        y = None
        z = []
        for entry in self.plan.section.project:
            if entry.output is not None:
                y = self.outputs(0.0, x, p) if y is None else y
                z.append(float(y[c.out[entry.output]]))
            elif entry.name in c.rates:
                z.append(float(v[c.rates[entry.name]]))
            else:
                z.append(float(x[self.model.state_index(entry.name)]))
        return np.array(z)

    def to_thesis(self, z: np.ndarray) -> np.ndarray:
        """Section coordinates in the thesis's terms (:attr:`thesis_section`)."""
        return self.compiled.to_thesis @ np.asarray(z, dtype=float)

    def from_thesis(self, w: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`to_thesis`."""
        return self.compiled.from_thesis @ np.asarray(w, dtype=float)

    def angles(self, x: np.ndarray, v: np.ndarray | None = None) -> dict[str, float]:
        """The thesis's θ, φ (rad) of a state in the section's labelling, and their rates when
        the joint rates ``v`` are given."""
        angles = self.compiled.angles
        q = np.asarray(x)[list(self.compiled.coordinates)]
        out = {k: float(a @ q) for k, a in angles.items()}
        if v is not None:
            out.update({f"{k}_dot": float(a @ v) for k, a in angles.items()})
        return out

    def section_state(self, z: np.ndarray) -> dict[str, float]:
        """The section state by name: its coordinates, the completed state coordinates, the
        thesis's coordinates and angles (theta, theta_dot, phi, phi_dot where defined), and the
        hip's speed (m/s). A state beyond the float64 range (the last iterate of a search that
        diverged) gives inf or nan there, without numpy's warnings."""
        z = np.asarray(z, dtype=float)
        with np.errstate(all="ignore"):
            x = self.lift(z)
            p = self.start_params()
            v = self.velocities(x, p)
            d = dict(zip(self.section, (float(a) for a in z)))
            rates = self.compiled.rates
            for c in self.spec.section.complete:
                d[c.coordinate] = float(v[rates[c.coordinate]] if c.coordinate in rates
                                        else x[self.model.state_index(c.coordinate)])
            d.update(zip(self.thesis_section, (float(a) for a in self.to_thesis(z))))
            d.update(self.angles(x, v))
            if self.hip:
                J = self.model.matrix(f"{self.multibody}.J.{self.hip.split('.', 1)[1]}", 0.0, x,
                                      p)
                d["hip_speed"] = float(np.linalg.norm(J @ v))
        return d

    def initial_guess(self) -> np.ndarray:
        """The description's rough section state (its ``guess``, from the parameters)."""
        y = self.model.outputs(0.0, self.run.x_init, self.run.p)
        return np.array([g.value(y) for g in self.compiled.guess])

    def basin_state(self, z_star: np.ndarray, theta: float,
                    theta_dot: float) -> np.ndarray | None:
        """A basin grid point of the section's own making, or None (``basin = "fixed_point"``:
        the analyses keep the fixed point's other coordinates). With ``basin = "guess"``: made
        like the initial guess, theta0 = θ, theta_dot0 = θ̇, phi_dot0 the fixed point
        ``z_star``'s φ̇."""
        if self.spec.section.basin != "guess":
            return None
        phi_dot = float(self.to_thesis(np.asarray(z_star, dtype=float))[
            list(self.thesis_section).index("phi_dot")])
        return self.with_parameters(theta0=theta, theta_dot0=theta_dot,
                                    phi_dot0=phi_dot).initial_guess()

    # --- walking ----------------------------------------------------------------------------------
    def stride(self, z: np.ndarray, *, details: bool = False, record: bool = False) -> Stride:
        """One step from section coordinates ``z`` (see :meth:`walk`)."""
        return self.walk(z, 1, details=details, record=record)[0]

    def walk(self, z: np.ndarray, n_steps: int, *, details: bool = False, record: bool = False,
             ground_drop: float = 0.0,
             until: Callable[[np.ndarray], bool] | None = None,
             reuse: bool = True) -> list[Stride]:
        """``n_steps`` consecutive strides from section state ``z`` in one simulation (one
        energy ledger); stops at the first fall, which is the last Stride (status "fell").

        ``details``: also max |θ|, max |φ| per step; ``record``: the trajectory in the last
        stride's ``info["trajectory"]``; ``ground_drop`` h (m, >= 0): the description's drop
        parameter is h, and its rules lower the surface (e.g. ahead of the stance foot, once);
        ``until``: called with the section state after each heel strike, ends the walk there
        (fewer than ``n_steps`` strides, the last a step) when it returns True.

        The same walk as the last one, asked again (e.g. with ``details``: a gait's strides after
        Newton's last residual at the fixed point; or after a ``record`` walk, as callers of
        :func:`~walker_library.analyses.gait.walk` do), is cut from the last one's trajectory,
        not integrated again (a walk without ``until`` or ``record`` whose integrator keeps no
        dense output: its trajectory does not depend on ``details``, nor on the last walk's
        ``record``, which only handed it over); ``reuse=False`` integrates it anyway (e.g. to
        time the integration), and so is a ``record`` walk always (the benchmarks time those).

        Each stride may take ``max_steps_per_stride`` integrator steps (the options): one that
        passes them falls (``"failed: more than N steps in one stride ..."``), the strides
        before it kept (the run is stopped there and made again up to that stride's budget)."""
        if not (math.isfinite(ground_drop) and ground_drop >= 0.0):
            raise ParameterValueError(f"ground_drop = {ground_drop!r} must be a finite height >= 0 (m)")
        o = self.options
        t_end = o.walk_time(n_steps)                # 0 and 2.5 steps reached the integrator
        dense = (details or record) and o.method not in COMPILED_METHODS
        kept = until is None and not dense and reuse       # its trajectory: the plain walk's
        plain = kept and not record
        key = (np.asarray(z, dtype=float).tobytes(), n_steps, float(ground_drop))
        last = self._last_walk
        if plain and last is not None and last[0] == key and last[1][4] is self.run:
            traj, log, x0, p0, _ = last[1]
            return self._cut(traj, log, details=details, record=False, x0=x0, p0=p0)
        p0 = self.start_params(ground_drop)
        with np.errstate(all="ignore"):         # as in start_state and the run itself
            x0 = self.start_state(z, p0)
            if isinstance(x0, str):
                return [Stride(StrideStatus.FELL, None, 0.0, reason=x0)]
            p0 = self.machine.start(x0, p0)
        budget = o.max_steps_per_stride

        def run(max_steps: int, watch: bool) -> tuple[Trajectory, WalkLog]:
            """The walk's simulation; ``watch``: stopped (_OverBudget) once a stride has taken
            more than ``budget`` steps since the last heel strike (the loops report at every
            event and every 4096 steps)."""
            log = WalkLog(n_steps, None if until is None
                          else lambda x, p: until(self.project(x, p)))
            mark = [0, 0, 0]        # heel strikes seen, the steps at the last one, at the last report

            def check(t: float, steps: int) -> None:
                if len(log.heel_strikes) != mark[0]:    # its action ran after the last report,
                    mark[:2] = [len(log.heel_strikes), mark[2]]        # the strike's own event
                mark[2] = steps
                if steps - mark[1] > budget:
                    raise _OverBudget(mark[1])

            traj = self.model.simulate(
                t_end, x0=x0, params=dict(zip(self.model.param_names, p0)),
                method=o.method, rtol=o.rtol, atol=o.atol, max_step=o.max_step,
                actions=self.machine.actions(log), max_events=100 * n_steps + 100,
                max_steps=max_steps, dense_output=dense, progress=check if watch else None)
            return traj, log

        try:
            traj, log = run(budget * n_steps, n_steps > 1)
            over = False
        except _OverBudget as err:
            # a stride over its budget: the same run again (the same strides before it), ended
            # where that stride passes the budget, so that no stride costs more than its own
            traj, log = run(err.steps + budget, False)
            over = True
        if kept:
            self._last_walk = (key, (traj, log, x0, p0, self.run))
        strides = self._cut(traj, log, details=details, record=record, x0=x0, p0=p0)
        if over and strides[-1].fell and traj.status == "failed":
            strides[-1].reason = (f"failed: more than {budget} steps in one stride "
                                  f"(max_steps_per_stride; t = {traj.t_final:.6g})")
        return strides

    def start_state(self, z: np.ndarray, p0: np.ndarray) -> np.ndarray | str:
        """The model state x₀ = L(z) a stride from section state ``z`` starts from (parameters
        ``p0``), or, for a state no stride can start from, its fall reason
        (``"invalid_state..."``): the lift fails (a wrong shape, no solution) or gives values
        beyond the float64 range. numpy's floating-point warnings are off, as in the run
        itself, and Python's arithmetic errors beyond float64 are such a fall, so that the
        python back end answers as C does."""
        with np.errstate(all="ignore"):
            try:
                x0 = self.lift(z, p0)
            except (np.linalg.LinAlgError, ModelError, ValueError, ArithmeticError) as err:
                if isinstance(err, ArithmeticError) and not self.model.raised_beyond_floats(err):
                    raise
                return f"invalid_state: {err}"
        return x0 if np.all(np.isfinite(x0)) else "invalid_state"

    def _cut(self, traj: Trajectory, log: WalkLog, **options: Any) -> list[Stride]:
        """:func:`.strides.cut_strides` of a walk's run, numpy's floating-point warnings off as in
        the run itself (porthamiltonian.simulation.simulate): a state beyond the float64 range is
        a fall (its reason says so), not also a RuntimeWarning of the python back end's energy."""
        with np.errstate(all="ignore"):
            return cut_strides(self, traj, log, **options)

    def stride_sensitivity(self, z: np.ndarray, period: int = 1, *, factor: float = 1.0,
                           deadline: float = math.inf) -> StrideSensitivity:
        """The exact Jacobian of the stride map S^period at section state ``z``, from strides
        integrated with their variational equations at the walker's tolerances times
        ``factor``, stopped (``stopped``) once ``time.perf_counter()`` passes ``deadline``
        (:func:`.variational.stride_sensitivity`)."""
        return stride_sensitivity(self, z, period, factor=factor, deadline=deadline)

    def __repr__(self) -> str:
        return f"HybridWalker({self.name!r}, section={self.section}, backend={self.backend!r})"
