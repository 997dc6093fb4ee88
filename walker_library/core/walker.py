"""One walker class for every walker: a model plus its hybrid description, run as a Walker.

:class:`HybridWalker` takes a :class:`~.hybrid.WalkerSpec` (from a model file's ``[walker]``
table or built in Python) and implements the :class:`~.protocol.Walker` protocol the analyses
use. Rigid-impact walkers (a swing phase pinned at the stance foot, a plastic impact at heel
strike) and compliant-contact walkers (one floating-base model, contacts switched by the
scuffing rule) are configurations of it, not subclasses.

Compilation. The walker compiles a copy of its model (components, bonds, parameters, events and
outputs; not the file's descriptions, so editing text does not recompile) with one extra output
per expression of the description that is evaluated during a walk: the rules' conditions and
parameter values, the modes' start values, the section's completions, the initial guess, the
total mass and the leg length. They go through the same compiler and back end as the model's
equations, so a walk evaluates no Python expression from a file. Before that, every name of the
description is checked against the model's names (:func:`~.names.check_names`, on
:func:`porthamiltonian.symbolic`); a rule with an ``impact`` also compiles the floating version
of the multibody (:func:`~.resets.floating_model`, python back end: only its matrices are used).

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

import copy
import json
import math
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from porthamiltonian import Model, compile_model, symbolic
from porthamiltonian.compiler import cache
from porthamiltonian.errors import ModelError, ParameterValueError
from porthamiltonian.integrators import COMPILED_METHODS
from porthamiltonian.interfaces.io import ModelFile
from porthamiltonian.simulation.compiled import CompiledModel

from .hybrid import Integration, WalkerSpec, expand, parse_condition, parse_equation, parse_interval
from .machine import Change, Condition, ModeMachine, Transition, WalkLog
from .names import ModelNames, check_names
from .protocol import ParameterSpec, Stride, check_parameters
from .resets import ImpactMap, Relabel, floating_model
from .strides import cut_strides
from .variational import StrideSensitivity, stride_sensitivity

__all__ = ["HybridWalker", "compiled"]

_COMPILED: dict[tuple[str, str], CompiledModel] = {}
_CHECKED: dict[str, tuple[ModelNames, dict]] = {}
#: prefix of the outputs the walker adds to its model (one per evaluated expression)
PREFIX = "hybrid"


def compiled(model: Model, backend: str) -> CompiledModel:
    """``compile_model(model, backend)``, memoized in this process by the model's cache key."""
    key = (cache.model_key(model), backend)
    if key not in _COMPILED:
        _COMPILED[key] = compile_model(model, backend=backend)
    return _COMPILED[key]


def _checked(spec: WalkerSpec, text: str) -> tuple[ModelNames, dict]:
    """The model's names (:func:`_model_names`) and the description's linear maps, after
    :func:`~.names.check_names` (memoized by model and spec)."""
    key = cache.model_key(spec.model) + repr(spec)
    if key not in _CHECKED:
        names = _model_names(spec, text)
        _CHECKED[key] = (names, check_names(spec, names, text))
    return _CHECKED[key]


def _model_names(spec: WalkerSpec, text: str) -> ModelNames:
    """The names of the walker's model: parameters, states and outputs of its symbolic form
    without its events and model outputs (whose expressions :func:`~.names.check_names` checks
    with their lines). The symbolic compiler is run once per model: the three name lists are
    kept in the model's cache entry (``names.json``, verified by its sha256 like every cached
    file), so a walker that is already built loads without symbolic work."""
    bare = copy.deepcopy(spec.model)
    bare.events, bare.outputs = [], {}
    key = cache.model_key(bare)
    stored = cache.load_verified(key, _NAMES_FILE)
    try:
        lists = json.loads(stored) if stored is not None else None
        lists = lists if isinstance(lists, dict) and all(
            isinstance(lists.get(k), list) and all(isinstance(n, str) for n in lists[k])
            for k in ("params", "states", "outputs")) else None
    except ValueError:
        lists = None
    if lists is None:
        with ModelFile(bare, spec.source, text).located():
            sym = symbolic(bare)
        lists = {"params": list(sym.param_names), "states": list(sym.state_names),
                 "outputs": list(sym.outputs)}
        cache.store(key, _NAMES_FILE, json.dumps(lists))
    return ModelNames.of(spec.model, lists["params"], lists["states"], lists["outputs"])


#: the file of a model's cache entry holding the names a walker checks its description against
_NAMES_FILE = "names.json"


class _Outputs:
    """The expressions a walker evaluates, as extra outputs of its model (see the module
    docstring): ``add(text)`` gives the output's name (one per distinct expression)."""

    def __init__(self):
        self.exprs: dict[str, str] = {}

    def add(self, text: Any) -> str:
        """The name of the output that evaluates ``text`` (added if new)."""
        text = str(text)
        for name, expr in self.exprs.items():
            if expr == text:
                return name
        name = f"{PREFIX}_e{len(self.exprs)}"
        self.exprs[name] = text
        return name


def _number(value: Any) -> float | None:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    return None


def _specs(spec: WalkerSpec) -> dict[str, ParameterSpec]:
    """The user-settable parameters (the model's, less the modes), with their ranges."""
    ranges = dict(spec.ranges)
    out = {}
    modes = set(spec.mode_names)
    for name, par in spec.model.parameters.items():
        if name in modes:
            continue
        low, high, low_closed, high_closed, integer = (
            parse_interval(ranges[name]) if name in ranges else
            (-math.inf, math.inf, False, False, False))
        out[name] = ParameterSpec(name, par.value, par.unit, par.doc, "", low, high, low_closed,
                                  high_closed, integer)
    return out


class HybridWalker:
    """A walker from its :class:`~.hybrid.WalkerSpec` (see the module docstring).

    Parameters
    ----------
    spec : the model and its hybrid description.
    backend : the back end (default: the description's ``integration.backend``; ``"auto"`` is
        the framework's choice).
    options : integrator settings (default: the description's :class:`~.hybrid.Integration`).
    values : parameter values by name (validated against the ranges; the file's by default).
    text : the model file's TOML text, for line numbers in errors.

    Attributes
    ----------
    name, doc, spec; model : the compiled model; backend : its back end (resolved);
    multibody : its multibody's name;
    parameters : the current values (SI);
    specs : :class:`~.protocol.ParameterSpec` per parameter; section, thesis_section : names of
    the section's coordinates (model's, thesis's); legged : θ and φ are defined; options.
    """

    def __init__(self, spec: WalkerSpec, *, backend: str | None = None,
                 options: Integration | None = None, values: Mapping[str, float] | None = None,
                 text: str = ""):
        names, maps = _checked(spec, text)
        self.spec = spec
        self.name = spec.name
        self.doc = spec.description
        self.options = options or spec.integration
        self.backend = backend or self.options.backend
        self.specs = _specs(spec)
        self.parameters = check_parameters(self.specs, dict(values or {}))
        self._names = names
        mb = names.multibody
        self.section = spec.section.coordinates
        self.thesis_section = tuple(k for k, _ in spec.section.thesis) or self.section
        self._T = (np.array(maps["thesis"], dtype=float) if spec.section.thesis
                   else np.eye(len(self.section)))
        self._T_inv = (np.array(maps["thesis_inverse"], dtype=float) if spec.section.thesis
                       else np.eye(len(self.section)))
        self.legged = all(k in dict(spec.angles) for k in ("theta", "phi"))

        # the compiled model: the file's model with the walker's expressions as outputs
        ex = _Outputs()
        plan = self._plan(spec, ex)
        offsets = {}
        if spec.relabel:
            offsets = {b: ex.add(b) for b in maps["relabel"][2] if isinstance(b, str)}
        model = copy.deepcopy(spec.model)
        for name, text_ in ex.exprs.items():
            model.output(name, text_)
        with ModelFile(model, spec.source, text).located():
            self.model = compiled(model, self.backend)
        self.backend = self.model.backend          # "auto" resolved: the back end in use
        m = self.model
        out = {n: i for i, n in enumerate(m.output_names)}
        self._out = out
        self.multibody = mb
        self._iq = [i for i, s in enumerate(m.state_names) if s.startswith(f"{mb}.q.")]
        self._ip = [i for i, s in enumerate(m.state_names) if s.startswith(f"{mb}.p.")]
        self._rate = {f"{mb}.v.{s[len(mb) + 3:]}": k
                      for k, s in enumerate(m.state_names[i] for i in self._iq)}
        self._relabel = (Relabel.build(*maps["relabel"], m.state_names, m.param_names,
                                       [m.state_names[i] for i in self._iq],
                                       {b: out[o] for b, o in offsets.items()})
                         if spec.relabel else None)
        self._angles = {k: np.array(v[0]) for k, v in maps["angles"].items() if v is not None}
        self._plan_lift = [(kind, target, out.get(o) if o else None, extra)
                           for kind, target, o, extra in plan["lift"]]
        self._plan_project = [(kind, target, out.get(o) if o else None)
                              for kind, target, o in plan["project"]]
        self._labelling = (Condition(spec.section.labelling, out[plan["labelling"][0]],
                                     plan["labelling"][1]) if spec.section.labelling else None)
        self._guess = [out[o] if o else c for o, c in plan["guess"]]
        self._start = [(m.param_names.index(k), c if o is None else out[o])
                       for k, o, c in plan["start"]]
        self._mass, self._leg = out[plan["mass"]], out[plan["leg_length"]]
        self._drop = m.param_names.index(spec.terrain.drop)
        self.machine = ModeMachine(m, tuple(self._transitions(spec, plan, names)))
        self.basin_state = self._basin_from_guess if spec.section.basin == "guess" else None
        self._setup()

    # --- construction -------------------------------------------------------------------------
    @staticmethod
    def _plan(spec: WalkerSpec, ex: _Outputs) -> dict[str, Any]:
        """Which output evaluates which expression (names, resolved after compilation)."""
        plan: dict[str, Any] = {"rules": [], "lift": [], "project": []}
        for r in spec.rules:
            conds = []
            for c in r.when:
                lhs, op, rhs = parse_condition(c)
                conds.append((c, ex.add(f"({lhs}) - ({rhs})"), op))
            sets = [(k, None if _number(v) is not None else ex.add(v), _number(v))
                    for k, v in r.set]
            plan["rules"].append((conds, sets))
        plan["start"] = [(k, None if _number(v) is not None else ex.add(v), _number(v))
                         for k, v in spec.modes]
        coords = spec.section.coordinates
        defined = {}
        for c in spec.section.complete:
            if c.such_that is None:
                const = _number(c.value)
                plan["lift"].append(("value", c.coordinate,
                                     None if const is not None else ex.add(c.value), const))
                continue
            lhs, rhs = parse_equation(c.such_that)
            if rhs in coords or lhs in coords:
                given, expr = (rhs, lhs) if rhs in coords else (lhs, rhs)
                o = ex.add(expr)
                defined[given] = o
                plan["lift"].append(("solve", c.coordinate, o, given))
            else:
                plan["lift"].append(("solve", c.coordinate, ex.add(f"({lhs}) - ({rhs})"), None))
        for name in coords:
            plan["project"].append(("defined", name, defined[name]) if name in defined else
                                   ("coordinate", name, None))
        if spec.section.labelling:
            lhs, op, rhs = parse_condition(spec.section.labelling)
            plan["labelling"] = (ex.add(f"({lhs}) - ({rhs})"), op)
        guess = dict(spec.guess)
        plan["guess"] = [(None, _number(guess[n])) if _number(guess.get(n)) is not None
                         else (ex.add(expand(guess.get(n, 0), spec.guess_where,
                                             spec.model.parameters)), None) for n in coords]
        plan["mass"], plan["leg_length"] = ex.add(spec.mass), ex.add(spec.leg_length)
        return plan

    def _transitions(self, spec: WalkerSpec, plan: dict, names: ModelNames) -> list[Transition]:
        m, out = self.model, self._out
        events = [e.name for e in m.events]
        floating = None
        result = []
        for i, (r, (conds, sets)) in enumerate(zip(spec.rules, plan["rules"])):
            impact = None
            if r.impact is not None:
                if floating is None:
                    floating = floating_model(spec.model, names.multibody, names.root_joint,
                                              spec.hip.split(".", 1)[1])
                impact = ImpactMap(m, compiled(floating.model, "python"), names.multibody,
                                   r.impact, spec.hip, self._relabel, floating.root,
                                   floating.rehung)
            k = events.index(r.on) if r.on != "start" else -1
            result.append(Transition(
                f"{r.on}#{i + 1}", r.on, k, m.events[k].direction if k >= 0 else 0,
                tuple(Condition(c, out[o], op) for c, o, op in conds),
                tuple(Change(name, m.param_names.index(name), const,
                             None if o is None else out[o]) for name, o, const in sets),
                impact, r.heel_strike, r.fall, r.energy, r.foot))
        return result

    def _setup(self) -> None:
        m = self.model
        self._p = m.params({k: v for k, v in self.parameters.items() if k in m.param_names})
        self._x_init = m.initial_state(self._p)
        y = m.outputs(0.0, self._x_init, self._p)
        self.total_mass = float(y[self._mass])
        self.leg_length = float(y[self._leg])

    def with_parameters(self, **values: float) -> HybridWalker:
        """A copy with some parameters changed (validated; the compiled models are shared)."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.parameters = check_parameters(self.specs, {**self.parameters, **values})
        new._setup()
        if new.basin_state is not None:
            new.basin_state = new._basin_from_guess
        return new

    # --- properties -----------------------------------------------------------------------------
    @property
    def weight(self) -> float:
        """Total weight m_total g (N); g is the model's parameter ``g``."""
        return self.total_mass * self.parameters["g"]

    @property
    def gait_tolerance(self) -> float:
        """Newton tolerance of the gait search (section units)."""
        return self.options.gait_tolerance

    @property
    def feet(self) -> tuple[str, ...]:
        """The feet's multibody points (for stick figures)."""
        return tuple(f.point for f in self.spec.feet)

    @property
    def hip(self) -> str:
        """The multibody point reported as the hip (``[walker] hip``)."""
        return self.spec.hip

    # --- numeric helpers ----------------------------------------------------------------------------
    def outputs(self, t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """All outputs of the compiled model at state ``x`` and parameters ``p``."""
        return self.model.outputs(t, x, p)

    def output(self, name: str, x: np.ndarray, p: np.ndarray | None = None,
               t: float = 0.0) -> float:
        """One named output at state ``x`` (parameters ``p``, default the walker's)."""
        return float(self.outputs(t, x, self._p if p is None else p)[self._out[name]])

    def velocities(self, x: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
        """Joint rates v of the multibody: M(q) v = p (solved, not inverted)."""
        M = self.model.matrix(f"{self.multibody}.M", 0.0, x, self._p if p is None else p)
        return np.linalg.solve(M, np.asarray(x)[self._ip])

    def start_params(self, ground_drop: float = 0.0) -> np.ndarray:
        """The parameter vector at the start of a walk: the drop set to ``ground_drop``, the modes
        at their start values (before the ``start`` rules, which need the state)."""
        p = self._p.copy()
        p[self._drop] = float(ground_drop)
        y = self.model.outputs(0.0, self._x_init, p)
        for index, value in self._start:
            p[index] = value if isinstance(value, float) else y[value]
        return p

    # --- the section ----------------------------------------------------------------------------
    def lift(self, z: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
        """Section coordinates -> model state (see the module docstring)."""
        p = self.start_params() if p is None else p
        z = np.asarray(z, dtype=float)
        if z.shape != (len(self.section),):
            raise ValueError(f"{self.name}: a section state has {len(self.section)} coordinates "
                             f"({', '.join(self.section)}), got {z.shape}")
        m = self.model
        x = np.zeros(m.n_states)
        v = np.zeros(len(self._iq))
        given = dict(zip(self.section, z))
        for name, value in given.items():
            if name in self._rate:
                v[self._rate[name]] = value
            elif name in m.state_names:
                x[m.state_index(name)] = value
        for kind, target, o, extra in self._plan_lift:
            if kind == "value":
                value = extra if o is None else self.outputs(0.0, x, p)[o]
            else:
                value = self._solve(x, p, target, o, 0.0 if extra is None else given[extra])
            if target in self._rate:
                v[self._rate[target]] = value
            else:
                x[m.state_index(target)] = value
        x[self._ip] = self.model.matrix(f"{self.multibody}.M", 0.0, x, p) @ v
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
                raise ValueError(f"{self.name}: cannot complete {target!r}: the equation does "
                                 "not depend on it")
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
        return self._labelling is not None and not self._labelling.holds(self.outputs(0.0, x, p))

    def canonical(self, x: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(state, joint rates, parameters) of state ``x`` in the section's labelling: relabelled
        when the section's ``labelling`` condition does not hold (a compliant walker with foot 2
        leading), else as they are."""
        v = self.velocities(x, p)
        if self.relabelled(x, p):
            y = self.outputs(0.0, x, p)
            x = self._relabel.state(x, y)
            v = self._relabel.rates(v)
            p = self._relabel.params(p, y)
            x[self._ip] = self.model.matrix(f"{self.multibody}.M", 0.0, x, p) @ v
        return x, v, p

    def project(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Model state (on the section) -> section coordinates, in the section's labelling."""
        x, v, p = self.canonical(np.asarray(x, dtype=float), p)
        y = None
        z = []
        for kind, name, o in self._plan_project:
            if kind == "defined":
                y = self.outputs(0.0, x, p) if y is None else y
                z.append(float(y[o]))
            elif name in self._rate:
                z.append(float(v[self._rate[name]]))
            else:
                z.append(float(x[self.model.state_index(name)]))
        return np.array(z)

    def to_thesis(self, z: np.ndarray) -> np.ndarray:
        """Section coordinates in the thesis's terms (:attr:`thesis_section`)."""
        return self._T @ np.asarray(z, dtype=float)

    def from_thesis(self, w: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`to_thesis`."""
        return self._T_inv @ np.asarray(w, dtype=float)

    def angles(self, x: np.ndarray, v: np.ndarray | None = None) -> dict[str, float]:
        """The thesis's θ, φ (rad) of a state in the section's labelling, and their rates when
        the joint rates ``v`` are given."""
        q = np.asarray(x)[self._iq]
        out = {k: float(a @ q) for k, a in self._angles.items()}
        if v is not None:
            out.update({f"{k}_dot": float(a @ v) for k, a in self._angles.items()})
        return out

    def section_state(self, z: np.ndarray) -> dict[str, float]:
        """The section state by name: its coordinates, the completed state coordinates, the
        thesis's coordinates and angles (theta, theta_dot, phi, phi_dot where defined), and the
        hip's speed (m/s)."""
        z = np.asarray(z, dtype=float)
        x = self.lift(z)
        p = self.start_params()
        v = self.velocities(x, p)
        d = dict(zip(self.section, (float(a) for a in z)))
        for c in self.spec.section.complete:
            d[c.coordinate] = float(v[self._rate[c.coordinate]] if c.coordinate in self._rate
                                    else x[self.model.state_index(c.coordinate)])
        d.update(zip(self.thesis_section, (float(a) for a in self.to_thesis(z))))
        d.update(self.angles(x, v))
        if self.hip:
            J = self.model.matrix(f"{self.multibody}.J.{self.hip.split('.', 1)[1]}", 0.0, x, p)
            d["hip_speed"] = float(np.linalg.norm(J @ v))
        return d

    def initial_guess(self) -> np.ndarray:
        """The description's rough section state (its ``guess``, from the parameters)."""
        y = self.model.outputs(0.0, self._x_init, self._p)
        return np.array([g if isinstance(g, float) else float(y[g]) for g in self._guess])

    def _basin_from_guess(self, z_star, theta: float, theta_dot: float) -> np.ndarray:
        """A basin grid point made like the initial guess: theta0 = θ, theta_dot0 = θ̇, phi_dot0
        the fixed point ``z_star``'s φ̇ (``basin = "guess"`` in the section)."""
        phi_dot = float(self.to_thesis(np.asarray(z_star, dtype=float))[
            list(self.thesis_section).index("phi_dot")])
        return self.with_parameters(theta0=theta, theta_dot0=theta_dot,
                                    phi_dot0=phi_dot).initial_guess()

    # --- walking ----------------------------------------------------------------------------------
    def stride(self, z: np.ndarray, *, details: bool = False, record: bool = False) -> Stride:
        """One step from section coordinates ``z`` (see :meth:`walk`)."""
        return self.walk(z, 1, details=details, record=record)[0]

    def walk(self, z: np.ndarray, n_steps: int, *, details: bool = False, record: bool = False,
             ground_drop: float = 0.0) -> list[Stride]:
        """``n_steps`` consecutive strides from section state ``z`` in one simulation (one
        energy ledger); stops at the first fall, which is the last Stride (status "fell").

        ``details``: also max |θ|, max |φ| per step; ``record``: the trajectory in the last
        stride's ``info["trajectory"]``; ``ground_drop`` h (m, >= 0): the description's drop
        parameter is h, and its rules lower the surface (e.g. ahead of the stance foot, once)."""
        if not (math.isfinite(ground_drop) and ground_drop >= 0.0):
            raise ParameterValueError(f"ground_drop = {ground_drop!r} must be a finite height >= 0 (m)")
        p0 = self.start_params(ground_drop)
        try:
            x0 = self.lift(z, p0)
        except (np.linalg.LinAlgError, ModelError, ValueError) as err:
            return [Stride("fell", None, 0.0, reason=f"invalid_state: {err}")]
        if not np.all(np.isfinite(x0)):
            return [Stride("fell", None, 0.0, reason="invalid_state")]
        p0 = self.machine.start(x0, p0)
        log = WalkLog(int(n_steps))
        o = self.options
        traj = self.model.simulate(
            o.max_step_time * n_steps, x0=x0, params=dict(zip(self.model.param_names, p0)),
            method=o.method, rtol=o.rtol, atol=o.atol, max_step=o.max_step,
            actions=self.machine.actions(log), max_events=100 * n_steps + 100,
            dense_output=(details or record) and o.method not in COMPILED_METHODS)
        return cut_strides(self, traj, log, details=details, record=record, x0=x0, p0=p0)

    def stride_sensitivity(self, z: np.ndarray, period: int = 1, *,
                           factor: float = 1.0) -> StrideSensitivity:
        """The exact Jacobian of the stride map S^period at section state ``z``, from strides
        integrated with their variational equations at the walker's tolerances times
        ``factor`` (:func:`.variational.stride_sensitivity`)."""
        return stride_sensitivity(self, z, period, factor=factor)

    def with_options(self, **changes: Any) -> HybridWalker:
        """A copy with some integrator settings changed (e.g. ``max_step``)."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.options = replace(self.options, **changes)
        return new

    def __repr__(self) -> str:
        return f"HybridWalker({self.name!r}, section={self.section}, backend={self.backend!r})"
