"""CompiledModel: the numeric model (layouts and numeric functions). No sympy, no graph.

Values live apart from the description (as in Drake's System/Context): a compiled model is
simulated with any parameter values without recompiling; ``params()`` builds the parameter vector
from defaults and overrides by name; :meth:`~CompiledModel.outputs`, :meth:`~CompiledModel.output`,
:meth:`~CompiledModel.energy` and :meth:`~CompiledModel.guards` evaluate the model at one point,
as do :meth:`~CompiledModel.derivative`, the exact Jacobians, :meth:`~CompiledModel.linearize`,
:meth:`~CompiledModel.trim` (:mod:`.linearize`) and :meth:`~CompiledModel.ph_matrices`
(:mod:`.phmatrices`).

``CompiledModel.simulate`` *is* :func:`porthamiltonian.simulation.simulate.simulate` (the same function,
bound as a method: one signature, documented once). The simulator sits below this module in the
import graph: it needs only the layout and the numeric functions of the model it is handed (it
imports this module for type checking only), so that the compiled model can offer the call users
expect (``compile_model(m).simulate(10.0)``) without an import cycle. ``export_fmu`` calls
:func:`porthamiltonian.fmu.export_fmu` (the FMU exporter sits in the back-end stage; it is
imported when a model is exported, not with every compiled model).
"""
from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np

from ..backends import Functions, beyond_floats
from ..errors import (
    ModelError,
    OptionError,
    ParameterValueError,
    StateError,
    UnknownParameterError,
)
from ..modeling.constraints import Constraint, ConstraintChecker
from .sampling import DiscreteBlock
from .simulate import simulate as _simulate

if TYPE_CHECKING:
    from .linearize import LinearModel, TrimResult
    from .phmatrices import PHMatrices


@dataclass(frozen=True)
class EventInfo:
    """A model event as the simulator sees it: its name, the direction of the guard's zero
    crossing that triggers it (+1 rising, -1 falling, 0 both) and whether it ends the run."""

    name: str
    direction: int
    terminal: bool


@dataclass(frozen=True)
class ModelMeta:
    """What the compiler hands a :class:`CompiledModel` besides its numeric functions: the
    layouts and the equations for display (``meta.json`` of a cache entry, :meth:`to_json`).

    name : the model's name. state_names, param_names, param_defaults (SI), param_units,
    output_names : the layouts. events : the model events. equations, hamiltonian : text for
    display. matrices : the named matrices (``walker.M``); shapes : the shape of every generated
    function's result by function name. autonomous : the state equations do not read time.
    energy_parts : ``(output, kind)`` of the outputs that split H. constraints : the components'
    constraints on parameter values. units : SI unit by state or port-variable name.
    input_names, input_units : the declared inputs (two parameter-vector slots each).
    state_roles : per state "storage", "signal", "quadrature" or "discrete". declared_outputs :
    the model's outputs y. jac_p : the parameters of the generated ∂ẋ/∂p. discrete : the
    discrete-time blocks. ph : the port-Hamiltonian form's layout (with ``ph=True``: from the
    add-on of the model's cache entry, :meth:`CompiledModel.with_extra`; None in ``meta.json``).
    kernels : the compiled kernels the generated code calls (the C library links their
    objects; an FMU embeds their source). unavailable : why a derivative function was not
    generated, by its name (e.g. ``out_jac`` of outputs read from a kernel's value-only entry).
    """

    name: str
    state_names: tuple[str, ...]
    param_names: tuple[str, ...]
    param_defaults: tuple[float, ...]
    param_units: tuple[str, ...]
    output_names: tuple[str, ...]
    events: tuple[EventInfo, ...]
    equations: tuple[str, ...]
    hamiltonian: str
    matrices: tuple[str, ...]
    shapes: Mapping[str, tuple[int, ...]]
    autonomous: bool
    energy_parts: tuple[tuple[str, str], ...] = ()
    constraints: tuple[Constraint, ...] = ()
    units: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))
    input_names: tuple[str, ...] = ()
    input_units: tuple[str, ...] = ()
    state_roles: tuple[str, ...] = ()
    declared_outputs: tuple[str, ...] = ()
    jac_p: tuple[str, ...] = ()
    discrete: tuple[DiscreteBlock, ...] = ()
    ph: Mapping[str, Any] | None = None
    kernels: tuple[str, ...] = ()
    unavailable: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))

    def to_json(self) -> dict[str, Any]:
        """The record as the JSON table of ``meta.json`` (the cache's format: lists, tables)."""
        out: dict[str, Any] = {f.name: getattr(self, f.name) for f in fields(self)}
        out.update(events=[{"name": e.name, "direction": e.direction, "terminal": e.terminal}
                           for e in self.events],
                   shapes={k: list(v) for k, v in self.shapes.items()},
                   energy_parts=[list(e) for e in self.energy_parts],
                   constraints=[c.to_dict() for c in self.constraints], units=dict(self.units),
                   unavailable=dict(self.unavailable),
                   discrete=[{"component": d.component, "period": d.period,
                              "states": list(d.states), "update": d.update}
                             for d in self.discrete])
        return {k: list(v) if isinstance(v, tuple) else v for k, v in out.items()}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> ModelMeta:
        """The record of a :meth:`to_json` table; KeyError, TypeError or ValueError when it is
        not one (a cache entry written by another version, or damaged)."""
        return cls(
            name=str(data["name"]), state_names=_strings(data["state_names"]),
            param_names=_strings(data["param_names"]),
            param_defaults=tuple(float(v) for v in data["param_defaults"]),
            param_units=_strings(data["param_units"]),
            output_names=_strings(data["output_names"]),
            events=tuple(EventInfo(str(e["name"]), int(e["direction"]), bool(e["terminal"]))
                         for e in data["events"]),
            equations=_strings(data["equations"]), hamiltonian=str(data["hamiltonian"]),
            matrices=_strings(data["matrices"]),
            shapes=MappingProxyType({str(k): tuple(int(n) for n in v)
                                     for k, v in dict(data["shapes"]).items()}),
            autonomous=bool(data["autonomous"]),
            energy_parts=tuple((str(a), str(b)) for a, b in data.get("energy_parts", [])),
            constraints=tuple(Constraint.from_dict(c) for c in data.get("constraints", [])),
            units=MappingProxyType({str(k): str(v)
                                    for k, v in dict(data.get("units", {})).items()}),
            input_names=_strings(data.get("input_names", [])),
            input_units=_strings(data.get("input_units", [])),
            state_roles=_strings(data.get("state_roles", [])),
            declared_outputs=_strings(data.get("declared_outputs", [])),
            jac_p=_strings(data.get("jac_p", [])),
            discrete=tuple(DiscreteBlock(str(d["component"]), str(d["period"]),
                                         _strings(d["states"]), str(d["update"]))
                           for d in data.get("discrete", [])),
            ph=dict(data["ph"]) if data.get("ph") is not None else None,
            kernels=_strings(data.get("kernels", [])),
            unavailable=MappingProxyType({str(k): str(v)
                                          for k, v in dict(data.get("unavailable", {})).items()}))


def _native_array(a: Any) -> np.ndarray:
    """``a`` as a contiguous, writable float array (itself when it is one): numba compiles a
    function once per argument type, and a read-only array (a trajectory's, a walker's frozen
    state) is a type of its own — passing one would compile the function a second time."""
    out = np.ascontiguousarray(a, dtype=float)
    return out if out.flags.writeable else out.copy()


def _strings(values: Any) -> tuple[str, ...]:
    if isinstance(values, str) or not all(isinstance(v, str) for v in values):
        raise TypeError(f"expected a list of strings, got {values!r}")
    return tuple(values)


class CompiledModel:
    """A compiled model: state, parameter and output layouts and the numeric functions.

    Attributes
    ----------
    state_names : model states in order (``component.state``); the simulator appends the ledger
        states ``ledger.E_diss`` and ``ledger.E_in``.
    param_names, param_defaults, param_units : the run-time parameters.
    output_names : named outputs (every ``component.port.e`` / ``.f``, component and model outputs).
    energy_parts : ``(output, kind)`` of the outputs that split H into per-storage parts
        (``<component>.H``, or ``.T`` and ``.V`` of a multibody; kind ``"stored"`` or
        ``"potential"``), for the ledger's scale (Trajectory.energy_scale).
    constraints : the components' constraints on parameter values, checked by :meth:`params`.
    units : SI unit by name of the states and port variables whose unit is known
        (``"spring.q": "m"``, ``"mass.p.e": "N"``).
    events : the model's event guards (:class:`EventInfo`).
    meta : the compiler's :class:`ModelMeta` these layouts come from.
    input_names, input_units : the inputs (bound at run time, :mod:`.inputs`); the parameter
        vector the functions take has two slots per input after the parameters (:attr:`n_slots`).
    state_roles : per state "storage", "signal", "quadrature" or "discrete" (a linearization
        keeps the first two).
    declared_outputs : the model's outputs y (rows of the linearization's C and D).
    discrete : the discrete-time blocks (:class:`~.sampling.DiscreteBlock`).
    ph_layout : the port-Hamiltonian form's layout when compiled with ``ph=True``, else None.
    functions : the back end's numeric functions (see :mod:`porthamiltonian.backends`).
    source : the generated source the back end runs (C or Python); c_source : the generated C
        body (what the C back end compiles, also under the other back ends: an FMU embeds it).
    param_docs : the parameters' descriptions, in the order of :attr:`param_names`.
    input_docs : the inputs' descriptions, in the order of :attr:`input_names`.
    output_expressions : the declared outputs' expressions as the model states them
        (``{"x": "cart_pole.q.slider"}``), for documentation (an FMU's variables).
    """

    def __init__(self, meta: ModelMeta, functions: Functions, source: str, key: str, *,
                 c_source: str = "", param_docs: Sequence[str] = (),
                 input_docs: Sequence[str] = (), output_expressions: Mapping[str, str] | None = None,
                 rebuild: Callable[..., CompiledModel] | None = None):
        self.meta = meta
        self.name: str = meta.name
        self.state_names: list[str] = list(meta.state_names)
        self.param_names: list[str] = list(meta.param_names)
        self.param_defaults = np.array(meta.param_defaults, dtype=float)
        self.param_units: list[str] = list(meta.param_units)
        self.output_names: list[str] = list(meta.output_names)
        self.events = list(meta.events)
        self.equations: list[str] = list(meta.equations)
        self.hamiltonian: str = meta.hamiltonian
        self.matrix_names: list[str] = list(meta.matrices)
        self.autonomous: bool = meta.autonomous
        self.energy_parts: list[tuple[str, str]] = list(meta.energy_parts)
        self.constraints = ConstraintChecker(self.name, [c.to_dict() for c in meta.constraints])
        self.units: dict[str, str] = dict(meta.units)
        self.input_names: list[str] = list(meta.input_names)
        self.input_units: list[str] = list(meta.input_units)
        self.state_roles: list[str] = list(meta.state_roles or ["storage"] * len(self.state_names))
        self.declared_outputs: list[str] = list(meta.declared_outputs)
        self.jac_p_names: list[str] = list(meta.jac_p)
        self.discrete: list[DiscreteBlock] = list(meta.discrete)
        self.ph_layout: Mapping[str, Any] | None = meta.ph
        self.functions = functions
        self.source = source
        self.c_source = c_source
        self.param_docs: list[str] = list(param_docs) or [""] * len(self.param_names)
        self.input_docs: list[str] = list(input_docs) or [""] * len(self.input_names)
        self.output_expressions: dict[str, str] = dict(output_expressions or {})
        self.key = key
        #: ``rebuild(model, **options)``: this model with more generated functions
        #: (``ph=True``, ``jac_p=``), set by the compiler; None for a model made otherwise
        self._rebuild = rebuild
        self._extended: dict[str, CompiledModel] = {}
        self._state_index = {n: i for i, n in enumerate(self.state_names)}
        self._param_index = {n: i for i, n in enumerate(self.param_names)}
        self._output_index = {n: i for i, n in enumerate(self.output_names)}

    @property
    def n_states(self) -> int:
        """The number of model states (without the two ledger states)."""
        return len(self.state_names)

    @property
    def backend(self) -> str:
        """The back end of the numeric functions (``"python"``, ``"numba"``)."""
        return self.functions.backend

    def params(self, values: Mapping[str, float] | None = None, **more: float) -> np.ndarray:
        """Parameter vector: defaults overridden by name. Unknown names, values that are not
        finite numbers, and values that violate a component's constraint (a mass <= 0, a
        damping < 0: :attr:`constraints`) raise, naming the parameter and the component."""
        if values is not None and not isinstance(values, Mapping):
            raise OptionError(f"params must be a mapping {{name: value}} (e.g. {{'k': 9.0}}), got "
                              f"{type(values).__name__}")
        p = self._padded(self.param_defaults)
        for name, value in {**(values or {}), **more}.items():
            p[self._param_index_of(name)] = self._param_value(name, value)
        self.constraints.check(dict(zip(self.param_names, p.tolist())))
        return p

    def changed_params(self, p: np.ndarray, changes: Mapping[str, float]) -> np.ndarray:
        """A copy of the parameter vector ``p`` (valid already) with ``changes`` applied, checked
        like :meth:`params`; only the constraints that read a changed parameter are evaluated
        again (an event action switching a mode flag is then cheap)."""
        p = np.array(p, dtype=float)
        changed = set()
        for name, value in changes.items():
            i = self._param_index_of(name)
            value = self._param_value(name, value)
            if value != p[i]:
                p[i] = value
                changed.add(name)
        if changed:
            self.constraints.check(dict(zip(self.param_names, p.tolist())), changed)
        return p

    def _padded(self, p: np.ndarray) -> np.ndarray:
        """Parameter values followed by the input slots (zero where ``p`` has none)."""
        out = np.zeros(len(self.param_names) + 2 * len(self.input_names))
        out[:len(p)] = p
        return out

    def _param_index_of(self, name: str) -> int:
        if name in self.input_names:
            raise UnknownParameterError(
                f"{name!r} is an input of model {self.name!r}, not a parameter: bind it with "
                f"inputs={{{name!r}: ...}} (simulate) or u= (derivative, linearize)")
        if name not in self._param_index:
            raise UnknownParameterError(
                f"model {self.name!r} has no parameter {name!r}; parameters: "
                f"{', '.join(self.param_names) or 'none'}"
            )
        return self._param_index[name]

    def _param_value(self, name: str, value: Any) -> float:
        """``value`` as a finite float, or a ParameterValueError naming the parameter."""
        if isinstance(value, (bool, str, bytes)) or np.ndim(value) != 0:
            raise ParameterValueError(f"parameter {name!r} of model {self.name!r} must be a "
                                      f"number, got {value!r}")
        try:
            number = float(value)
        except OverflowError:           # an integer beyond the float range: not finite
            number = math.inf
        except (TypeError, ValueError):
            raise ParameterValueError(f"parameter {name!r} of model {self.name!r} must be a "
                                      f"number, got {value!r}") from None
        if not math.isfinite(number):
            raise ParameterValueError(f"parameter {name!r} of model {self.name!r} must be "
                                      f"finite, got {number!r}")
        return number

    def raised_beyond_floats(self, err: BaseException) -> bool:
        """Whether ``err``, raised while this model's functions ran, is Python's (or numba's)
        arithmetic at a value beyond the float64 range or outside a function's domain —
        ``x**2`` overflowing, a division by zero, ``math.cos(inf)``, numba's
        ``np.linalg.solve`` of a matrix holding inf or NaN — where C's arithmetic gives inf or
        NaN (the python and numba back ends; the C back end's functions never raise): a state
        the caller treats as C's inf or NaN (a failed run, a fallen stride), not as a bug."""
        if self.backend == "c":
            return False
        return isinstance(err, np.linalg.LinAlgError) or beyond_floats(err)

    def native_params(self, p: np.ndarray) -> list[float] | np.ndarray:
        """The parameter vector in the form the back end's functions take (a vector of the
        parameters alone gets its input slots appended, zero)."""
        if len(p) < self.n_slots:
            p = self._padded(p)
        return p.tolist() if self.backend == "python" else _native_array(p)

    def initial_state(self, p: np.ndarray | None = None,
                      values: Mapping[str, float] | None = None) -> np.ndarray:
        """Initial model state from the components' initial values, overridden by name."""
        p = self._padded(self.param_defaults if p is None else p)
        x = np.array(self.functions.initial(self.native_params(p)), dtype=float)[: self.n_states]
        for name, value in (values or {}).items():
            index = self.state_index(name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
                raise StateError(f"model {self.name!r}: the initial value of state {name!r} must "
                                 f"be a number, got {type(value).__name__} {value!r}")
            try:
                x[index] = value
            except OverflowError:       # an integer beyond the float range: not finite
                x[index] = math.inf
        if not np.all(np.isfinite(x)):
            bad = ", ".join(f"{n} = {v}" for n, v in zip(self.state_names, x) if not np.isfinite(v))
            raise StateError(f"model {self.name!r}: initial state is not finite: {bad} (from the "
                             "initial values the components compute from the parameters; check "
                             "the parameters they read)")
        return x

    def state_index(self, name: str) -> int:
        """The index of the state ``name``; StateError naming the states if there is none."""
        return self._index(self._state_index, name, "state", "states", self.state_names)

    def output_index(self, name: str) -> int:
        """The index of the output ``name``; StateError naming the outputs if there is none."""
        return self._index(self._output_index, name, "state or output", "outputs",
                           self.output_names)

    def _index(self, table: Mapping[str, int], name: str, what: str, kind: str,
               names: Sequence[str]) -> int:
        """``table[name]``, or StateError: the model has no ``what`` ``name``, its ``kind``
        are ``names``."""
        try:
            return table[name]
        except KeyError:
            raise StateError(f"model {self.name!r} has no {what} {name!r}; {kind}: "
                             f"{', '.join(names)}") from None

    def augment(self, x: np.ndarray) -> np.ndarray:
        """Model state -> integration state (ledger states E_diss = E_in = 0 appended)."""
        x = np.asarray(x, dtype=float)
        if x.shape != (self.n_states,):
            raise StateError(f"model {self.name!r}: state must have length {self.n_states} "
                             f"({', '.join(self.state_names)}), got shape {x.shape}")
        return np.concatenate([x, [0.0, 0.0]])

    def _point(self, x: np.ndarray) -> np.ndarray:
        """The integration state of a model or integration state ``x``, contiguous floats."""
        y = x if len(x) == self.n_states + 2 else self.augment(x)
        return _native_array(y)

    def energy(self, t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """[H, P_diss, P_in] (J, W, W) at one point (x: the model or the integration state)."""
        return np.asarray(self.functions.energy(t, self._point(x), self.native_params(p)))

    def outputs(self, t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Every named output at one point, in the order of :attr:`output_names` (x may be the
        model or the integration state, p the parameter vector)."""
        return np.asarray(self.functions.outputs(t, self._point(x), self.native_params(p)))

    def output(self, name: str, t: float, x: np.ndarray, p: np.ndarray) -> float:
        """The named output ``name`` (e.g. ``"spring.p.e"``) at one point; StateError naming the
        outputs for an unknown name."""
        return float(self.outputs(t, x, p)[self.output_index(name)])

    def guards(self, t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The model's event guards at one point, in the order of :attr:`events`."""
        g = np.asarray(self.functions.guards(t, self._point(x), self.native_params(p)))
        return g[: len(self.events)]

    def matrix(self, name: str, t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The named matrix (e.g. ``walker.M``, a mass matrix) at one point."""
        try:
            k = self.matrix_names.index(name)
        except ValueError:
            raise StateError(f"model {self.name!r} has no matrix {name!r}; matrices: "
                             f"{', '.join(self.matrix_names) or 'none'}") from None
        return np.asarray(self.functions.matrices[k](t, self._point(x), self.native_params(p)))

    def power_balance(self, t: float, x: np.ndarray, p: np.ndarray, h: float = 1e-3) -> float:
        """dH/dt − P_in + P_diss at one point, dH/dt by a fourth-order central difference of H
        along the flow (step h / max(1, max|ẋ|)).

        An independent numeric check of the assembled ledger (zero up to O(h⁴) and round-off
        for a consistent model); works for every model, including those with implicit blocks.
        """
        y = self.augment(x) if len(x) == self.n_states else np.asarray(x, dtype=float)
        pn = self.native_params(p)
        ydot = np.asarray(self.functions.rhs(t, y, pn))
        step = h / max(1.0, float(np.max(np.abs(ydot[: self.n_states]))))

        def H(k: int) -> float:
            return float(self.functions.energy(t + k * step, y + k * step * ydot, pn)[0])

        dH = (8 * (H(1) - H(-1)) - (H(2) - H(-2))) / (12 * step)
        _, p_diss, p_in = self.functions.energy(t, y, pn)
        return float(dH - p_in + p_diss)

    @property
    def n_slots(self) -> int:
        """The length of the parameter vector the functions take: the parameters, then two
        slots per input (:mod:`porthamiltonian.simulation.inputs`)."""
        return len(self.param_names) + 2 * len(self.input_names)

    # --- the model at a point: derivative, Jacobians, linearization, trim -----------------------
    def derivative(self, t: float = 0.0, x: Any = None, u: Any = None,
                   params: Any = None) -> np.ndarray:
        """ẋ = f(t, x, u, p) of the model states at one point: ``x`` the model state (array or
        ``{state: value}`` over the initial values), ``u`` the inputs (array or ``{input:
        value}``), ``params`` parameter values by name (see
        :mod:`porthamiltonian.simulation.linearize`)."""
        from .linearize import derivative

        return derivative(self, t, x, u, params)

    def jacobian(self, t: float = 0.0, x: Any = None, u: Any = None,
                 params: Any = None) -> np.ndarray:
        """∂ẋ/∂x (n x n) at one point, exact (the generated chain rule); arguments as
        :meth:`derivative`."""
        from .linearize import jacobian

        return jacobian(self, t, x, u, params)

    def input_jacobian(self, t: float = 0.0, x: Any = None, u: Any = None,
                       params: Any = None) -> np.ndarray:
        """∂ẋ/∂u (n x m) at one point, exact; arguments as :meth:`derivative`."""
        from .linearize import input_jacobian

        return input_jacobian(self, t, x, u, params)

    def accelerations(self, t: float = 0.0, x: Any = None, u: Any = None,
                      params: Any = None) -> dict[str, float]:
        """A multibody's accelerations v̇ at one point, ``{"<mb>.a.<velocity>": value}``
        (rad/s², m/s²), exact: the rate of the velocity output ``<mb>.v.<velocity>`` of each
        revolute, prismatic, translational and universal joint; arguments as
        :meth:`derivative`. A trajectory gives them by name too (``traj["arm.a.pivot"]``).
        With loops or constraints they include the position correction of the constraints'
        stabilisation (``constraint_gain``), so off the constraints (φ ≠ 0 or φ̇ ≠ 0) they
        differ from M⁻¹(ṗ − Ṁv) of the momentum rates; on them the correction vanishes."""
        from .linearize import accelerations

        return accelerations(self, t, x, u, params)

    def linearize(self, x: Any = None, u: Any = None, params: Any = None,
                  t: float = 0.0) -> LinearModel:
        """(A, B, C, D) at (t, x, u, params) from the exact Jacobians, as a
        :class:`~porthamiltonian.simulation.linearize.LinearModel` (``.to_control()``: a
        python-control StateSpace). States: the dynamic ones (storages, continuous signal
        blocks); outputs: the declared outputs (else the states)."""
        from .linearize import linearize

        return linearize(self, x, u, params, t)

    def trim(self, x: Any = None, u: Any = None, params: Any = None, t: float = 0.0,
             free_states: Any = None, free_inputs: Any = (), tol: float = 1e-12,
             max_iter: int = 50) -> TrimResult:
        """An equilibrium ẋ = 0 by Newton's method with the exact Jacobians, from the point
        (x, u): the free states (default: all dynamic ones) and free inputs (default: none) are
        solved for (see :func:`porthamiltonian.simulation.linearize.trim`)."""
        from .linearize import trim

        return trim(self, x, u, params, t, free_states, free_inputs, tol, max_iter)

    def to_control(self, x: Any = None, u: Any = None, params: Any = None,
                   t: float = 0.0) -> Any:
        """The linearization at (t, x, u, params) as a python-control ``StateSpace``
        (:meth:`linearize` then ``to_control``)."""
        return self.linearize(x, u, params, t).to_control()

    def parameter_jacobian(self, names: Any, t: float = 0.0, x: Any = None, u: Any = None,
                           params: Any = None) -> np.ndarray:
        """∂ẋ/∂p (n x len(names)) by the parameters ``names`` at one point, exact: the generated
        ``jac_p`` (this model compiles itself again with it, once, when it lacks it)."""
        names = [names] if isinstance(names, str) else list(names)
        model = self if self.jac_p_names == names else self.extended(jac_p=names)
        from .linearize import point

        pt = point(model, t, x, u, params)
        out = model.functions.extra["jac_p"](pt.t, pt.y, model.native_params(pt.p))
        return np.asarray(out, dtype=float)[:self.n_states]

    def ph_matrices(self, x: Any = None, params: Any = None, t: float = 0.0,
                    u: Any = None) -> PHMatrices:
        """The explicit port-Hamiltonian form [ẋ; w; y] = (J − R)[∇H; z; u] at one point
        (arguments as :meth:`derivative`): J, R, ∇H, z, u and the checks
        (:mod:`porthamiltonian.simulation.phmatrices`; this model compiles itself again with
        the form's functions, once, when it lacks them)."""
        model = self if self.ph_layout is not None else self.extended(ph=True)
        from .linearize import point
        from .phmatrices import ph_matrices

        pt = point(model, t, x, u, params)
        return ph_matrices(model, pt.t, pt.y, pt.p)

    def extended(self, **options: Any) -> CompiledModel:
        """This model with more generated functions, kept for later calls: ``ph=True``, the
        port-Hamiltonian form's, ``out_jac=True``, the declared outputs' Jacobian (add-ons of
        the model's cache entry: this model's own functions kept, the add-on's compiled beside
        them, :func:`porthamiltonian.compiler.compile_model`); ``jac_p=[...]``, ∂ẋ/∂p (the
        model compiled again)."""
        key = repr(sorted(options.items()))
        if key not in self._extended:
            if self._rebuild is None:
                raise ModelError(f"model {self.name!r} was not made by compile_model: compile it "
                                 f"with {', '.join(f'{k}={v!r}' for k, v in options.items())}")
            self._extended[key] = self._rebuild(self, **options)
        return self._extended[key]

    def with_extra(self, functions: Mapping[str, Callable[..., Any]],
                   shapes: Mapping[str, tuple[int, ...]],
                   ph: Mapping[str, Any] | None = None) -> CompiledModel:
        """This model with further generated ``functions`` (by name, ``(t, x, p)`` like
        ``jac``; their result ``shapes``) in ``functions.extra`` and ``meta.shapes``, and the
        port-Hamiltonian form's layout ``ph`` in ``meta.ph`` when given: the compiler's add-on
        of a model's cache entry (:func:`porthamiltonian.compiler.compile_model`). The same
        numeric functions, sources and texts otherwise; it extends itself as this model
        does."""
        meta = replace(self.meta, shapes=MappingProxyType({**self.meta.shapes, **shapes}),
                       ph=self.meta.ph if ph is None else ph)
        numeric = replace(self.functions, extra={**self.functions.extra, **functions})
        return CompiledModel(meta, numeric, self.source, self.key, c_source=self.c_source,
                             param_docs=self.param_docs, input_docs=self.input_docs,
                             output_expressions=self.output_expressions, rebuild=self._rebuild)

    def _repr_html_(self) -> str:
        from .display import model_html
        return model_html(self)

    simulate = _simulate

    def export_fmu(self, path: str | os.PathLike[str], **options: Any) -> Path:
        """Write this model as an FMU at ``path``: :func:`porthamiltonian.fmu.export_fmu` with
        its keyword ``options`` (``fmi``, ``kind``, ``params``, ``rtol``, ...)."""
        from ..fmu import export_fmu

        return export_fmu(self, path, **options)

    def __repr__(self) -> str:
        return (f"CompiledModel({self.name!r}, {self.n_states} states, {len(self.param_names)} "
                f"parameters, backend={self.backend!r})")
