"""CompiledModel: the numeric model (layouts and numeric functions). No sympy, no graph.

Values live apart from the description (as in Drake's System/Context): a compiled model is
simulated with any parameter values without recompiling; ``params()`` builds the parameter vector
from defaults and overrides by name; :meth:`~CompiledModel.outputs`, :meth:`~CompiledModel.output`,
:meth:`~CompiledModel.energy` and :meth:`~CompiledModel.guards` evaluate the model at one point.

``CompiledModel.simulate`` *is* :func:`porthamiltonian.simulation.simulate.simulate` (the same function,
bound as a method: one signature, documented once). The simulator sits below this module in the
import graph: it needs only the layout and the numeric functions of the model it is handed (it
imports this module for type checking only), so that the compiled model can offer the call users
expect (``compile_model(m).simulate(10.0)``) without an import cycle.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..backends import Functions
from ..errors import OptionError, ParameterValueError, StateError, UnknownParameterError
from ..modeling.constraints import ConstraintChecker
from .simulate import simulate as _simulate


@dataclass(frozen=True)
class EventInfo:
    name: str
    direction: int
    terminal: bool


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
    events : the model's event guards.
    functions : the back end's numeric functions (see :mod:`porthamiltonian.backends`).
    """

    def __init__(self, meta: Mapping[str, Any], functions: Functions, source: str, key: str):
        self.name: str = meta["name"]
        self.state_names: list[str] = meta["state_names"]
        self.param_names: list[str] = meta["param_names"]
        self.param_defaults = np.array(meta["param_defaults"], dtype=float)
        self.param_units: list[str] = meta["param_units"]
        self.output_names: list[str] = meta["output_names"]
        self.events = [EventInfo(**e) for e in meta["events"]]
        self.equations: list[str] = meta["equations"]
        self.hamiltonian: str = meta["hamiltonian"]
        self.matrix_names: list[str] = meta["matrices"]
        self.autonomous: bool = meta["autonomous"]
        self.energy_parts: list[tuple[str, str]] = [tuple(e) for e in meta.get("energy_parts", [])]
        self.constraints = ConstraintChecker(self.name, meta.get("constraints", []))
        self.units: dict[str, str] = dict(meta.get("units", {}))
        self.functions = functions
        self.source = source
        self.key = key
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
        p = self.param_defaults.copy()
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

    def _param_index_of(self, name: str) -> int:
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
            value = float(value)
        except (TypeError, ValueError):
            raise ParameterValueError(f"parameter {name!r} of model {self.name!r} must be a "
                                      f"number, got {value!r}") from None
        if not math.isfinite(value):
            raise ParameterValueError(f"parameter {name!r} of model {self.name!r} must be "
                                      f"finite, got {value!r}")
        return value

    def native_params(self, p: np.ndarray) -> list[float] | np.ndarray:
        """The parameter vector in the form the back end's functions take."""
        return p.tolist() if self.backend == "python" else np.ascontiguousarray(p, dtype=float)

    def initial_state(self, p: np.ndarray | None = None,
                      values: Mapping[str, float] | None = None) -> np.ndarray:
        """Initial model state from the components' initial values, overridden by name."""
        p = self.param_defaults if p is None else p
        x = np.array(self.functions.initial(self.native_params(p)), dtype=float)[: self.n_states]
        for name, value in (values or {}).items():
            index = self.state_index(name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
                raise StateError(f"model {self.name!r}: the initial value of state {name!r} must "
                                 f"be a number, got {type(value).__name__} {value!r}")
            x[index] = value
        if not np.all(np.isfinite(x)):
            bad = ", ".join(f"{n} = {v}" for n, v in zip(self.state_names, x) if not np.isfinite(v))
            raise StateError(f"model {self.name!r}: initial state is not finite: {bad} (from the "
                             "initial values the components compute from the parameters; check "
                             "the parameters they read)")
        return x

    def state_index(self, name: str) -> int:
        """The index of the state ``name``; StateError naming the states if there is none."""
        try:
            return self._state_index[name]
        except KeyError:
            raise StateError(f"model {self.name!r} has no state {name!r}; states: "
                             f"{', '.join(self.state_names)}") from None

    def output_index(self, name: str) -> int:
        """The index of the output ``name``; StateError naming the outputs if there is none."""
        try:
            return self._output_index[name]
        except KeyError:
            raise StateError(f"model {self.name!r} has no state or output {name!r}; outputs: "
                             f"{', '.join(self.output_names)}") from None

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
        return np.ascontiguousarray(y, dtype=float)

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

    def _repr_html_(self) -> str:
        from .display import model_html
        return model_html(self)

    simulate = _simulate

    def __repr__(self) -> str:
        return (f"CompiledModel({self.name!r}, {self.n_states} states, {len(self.param_names)} "
                f"parameters, backend={self.backend!r})")
