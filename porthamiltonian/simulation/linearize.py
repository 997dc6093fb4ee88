"""A compiled model at one point: its derivative, exact Jacobians, linearization and trim.

Everything here evaluates generated code (no sympy, no finite differences): ``rhs`` for the
derivative, ``jac`` for ∂ẋ/∂x, ``jac_u`` for ∂ẋ/∂u and ``out_jac`` for ∂y/∂[x, u] of the declared
outputs (built on the first linearization, an add-on of the model's cache entry), all from the
chain rule of :func:`porthamiltonian.compiler.codegen.jacobian_function`.
The functions are also methods of :class:`~porthamiltonian.simulation.compiled.CompiledModel`
(``model.derivative(t, x, u, params)``, ``model.linearize(x, u, params)``, ...).

A point is given as

* ``t``: the time (s), 0 by default;
* ``x``: the model state (an array of length n, ``model.state_names``), or a mapping
  ``{state: value}`` overriding the components' initial values, or None for those;
* ``u``: the inputs (an array of length m, ``model.input_names``, or a mapping ``{input:
  value}``; every input must be given; None for a model without inputs);
* ``params``: parameter values by name (defaults for the others), or a parameter vector.

The linearization ẋ ≈ A δx + B δu, y ≈ C δx + D δu is taken over the *dynamic* states: those of
the storages and of continuous signal blocks (``model.state_roles``); the quadratures (an
actuator's work) and the held values of discrete-time blocks are left out (they are read by no
rate, or change only at samples). Its outputs are the model's declared outputs
(``model.declared_outputs``: the ``[outputs]`` of a model file); a model that declares none gets
y = x (C = I, D = 0).

``trim`` solves ẋ(x, u) = 0 (the dynamic states' rates) by Newton's method with the exact
Jacobian [A B], for the free states (default: every dynamic state) and free inputs (default:
none), the others held at their given values; least squares when the counts differ.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InputError, ModelError, OptionError, StateError
from .assembly import consistent, constraint_rows
from .options import check_integer, check_number

if TYPE_CHECKING:
    from .compiled import CompiledModel

#: the state roles a linearization keeps (see the module docstring)
DYNAMIC = ("storage", "signal")


@dataclass(frozen=True)
class Point:
    """A model at one point: the time, the integration state y (model states, ledger zeros) and
    the parameter vector p with the inputs' slots set (constant inputs)."""

    t: float
    y: np.ndarray
    p: np.ndarray

    @property
    def x(self) -> np.ndarray:
        """The model state (y without the ledger states)."""
        return self.y[:-2]


def point(model: CompiledModel, t: float = 0.0, x: Any = None, u: Any = None,
          params: Any = None) -> Point:
    """The :class:`Point` (t, x, u, params) of ``model`` (see the module docstring), checked:
    StateError for a state of the wrong length, InputError for inputs missing, unknown or of the
    wrong length."""
    if isinstance(params, Mapping) or params is None:
        p = model.params(params)
    else:
        p = np.asarray(params, dtype=float)
        if p.shape not in ((len(model.param_names),), (model.n_slots,)):
            raise OptionError(f"params must be a mapping {{name: value}} or a vector of "
                              f"{len(model.param_names)} values, got shape {p.shape}")
        p = model._padded(p)
    t = check_number("t", t)           # NaN went through: a linearization of NaN
    if x is None or isinstance(x, Mapping):
        state = model.initial_state(p, x)
    else:
        try:
            state = np.asarray(x, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise StateError(f"model {model.name!r}: the state must be numbers (an array or a "
                             f"mapping {{state: value}}), got {x!r}") from None
    y = model.augment(state)
    if not np.all(np.isfinite(y)):
        raise StateError(f"model {model.name!r}: the state is not finite: {state}")
    P, m = len(model.param_names), len(model.input_names)
    values = input_vector(model, u)
    p = p.copy()
    p[P:P + m], p[P + m:P + 2 * m] = values, 0.0
    return Point(float(t), y, p)


def input_vector(model: CompiledModel, u: Any) -> np.ndarray:
    """The inputs ``u`` (array or mapping; None without inputs) as a vector in the order of
    ``model.input_names``; InputError naming what is missing, unknown or of the wrong shape."""
    names, m = model.input_names, len(model.input_names)
    if u is None:
        if m:
            raise InputError(f"model {model.name!r} has inputs {', '.join(names)}: give u (an "
                             f"array of {m} values or a mapping {{input: value}})")
        return np.zeros(0)
    if isinstance(u, Mapping):
        unknown = [k for k in u if k not in names]
        missing = [k for k in names if k not in u]
        if unknown or missing:
            raise InputError(f"model {model.name!r}: u has unknown input(s) {unknown} or lacks "
                             f"{missing}; its inputs: {', '.join(names) or 'none'}")
    try:
        values = (np.array([u[k] for k in names], dtype=float) if isinstance(u, Mapping)
                  else np.atleast_1d(np.asarray(u, dtype=float)))
    except OverflowError:               # an integer beyond the float range: not finite
        raise InputError(f"model {model.name!r}: the inputs must be finite, got {u!r}") from None
    if values.shape != (m,):
        raise InputError(f"model {model.name!r}: u must have {m} value(s) "
                         f"({', '.join(names) or 'no inputs'}), got shape {values.shape}")
    if not np.all(np.isfinite(values)):
        raise InputError(f"model {model.name!r}: the inputs must be finite, got {values}")
    return values


def derivative(model: CompiledModel, t: float = 0.0, x: Any = None, u: Any = None,
               params: Any = None) -> np.ndarray:
    """ẋ = f(t, x, u, p) of the model states (length n; the ledger's rates are
    ``model.energy``'s P_diss and P_in)."""
    pt = point(model, t, x, u, params)
    return _rhs(model, pt)[:model.n_states]


def _rhs(model: CompiledModel, pt: Point) -> np.ndarray:
    return np.asarray(model.functions.rhs(pt.t, pt.y, model.native_params(pt.p)), dtype=float)


def jacobian(model: CompiledModel, t: float = 0.0, x: Any = None, u: Any = None,
             params: Any = None) -> np.ndarray:
    """∂ẋ/∂x (n x n) of the model states, exact (the generated chain rule)."""
    pt = point(model, t, x, u, params)
    n = model.n_states
    return _jac(model, pt)[:n, :n]


def _jac(model: CompiledModel, pt: Point) -> np.ndarray:
    return np.asarray(model.functions.jac(pt.t, pt.y, model.native_params(pt.p)), dtype=float)


def input_jacobian(model: CompiledModel, t: float = 0.0, x: Any = None, u: Any = None,
                   params: Any = None) -> np.ndarray:
    """∂ẋ/∂u (n x m), exact (the generated ``jac_u``)."""
    pt = point(model, t, x, u, params)
    return _jac_u(model, pt)


def _jac_u(model: CompiledModel, pt: Point) -> np.ndarray:
    n, m = model.n_states, len(model.input_names)
    if not m:
        return np.zeros((n, 0))
    out = model.functions.extra["jac_u"](pt.t, pt.y, model.native_params(pt.p))
    return np.asarray(out, dtype=float)[:n]


def _out_jac(model: CompiledModel, pt: Point) -> np.ndarray:
    """∂y/∂[x, u] of the declared outputs (n_y x (n + m)), the generated ``out_jac``: not part
    of a model's own build, it is the add-on of its cache entry that the model gets on its
    first use (``model.extended(out_jac=True)``: generated and compiled alone, once); ModelError
    (saying why) when the model cannot have it."""
    if "out_jac" in model.meta.unavailable:
        raise ModelError(model.meta.unavailable["out_jac"])
    if "out_jac" not in model.functions.extra:
        model = model.extended(out_jac=True)
    out = model.functions.extra["out_jac"](pt.t, pt.y, model.native_params(pt.p))
    return np.asarray(out, dtype=float)


def outputs_y(model: CompiledModel, t: float = 0.0, x: Any = None, u: Any = None,
              params: Any = None) -> np.ndarray:
    """The declared outputs y at a point (``model.declared_outputs``)."""
    pt = point(model, t, x, u, params)
    values = model.outputs(pt.t, pt.y, pt.p)
    return np.array([values[model.output_index(name)] for name in model.declared_outputs])


def acceleration_rows(model: CompiledModel) -> dict[str, int]:
    """The multibodies' accelerations the model gives exactly, ``"<mb>.a.<velocity>"`` -> the
    index of the coordinate whose rate is that velocity (a revolute, prismatic, translational or
    universal joint: q̇ = v, so v̇ = (∂q̇/∂x) ẋ, a row of the generated Jacobian times the
    right-hand side)."""
    states = set(model.state_names)
    out = {}
    for name in model.output_names:
        mb, sep, label = name.partition(".v.")
        if sep and f"{mb}.q.{label}" in states and f"{mb}.p.{label}" in states:
            out[f"{mb}.a.{label}"] = model.state_index(f"{mb}.q.{label}")
    return out


def acceleration_values(model: CompiledModel, t: float, y: np.ndarray, pn: Any) -> np.ndarray:
    """The accelerations of :func:`acceleration_rows` (in its order) at (t, y) with the
    back end's parameters ``pn``."""
    rows = list(acceleration_rows(model).values())
    f = np.asarray(model.functions.rhs(t, y, pn), dtype=float)
    J = np.asarray(model.functions.jac(t, y, pn), dtype=float)
    values: np.ndarray = J[rows] @ f
    return values


def accelerations(model: CompiledModel, t: float = 0.0, x: Any = None, u: Any = None,
                  params: Any = None) -> dict[str, float]:
    """``{"<mb>.a.<velocity>": v̇}`` at a point, exact (:func:`acceleration_rows`)."""
    pt = point(model, t, x, u, params)
    values = acceleration_values(model, pt.t, pt.y, model.native_params(pt.p))
    return dict(zip(acceleration_rows(model), values.tolist()))


@dataclass(frozen=True)
class LinearModel:
    """ẋ ≈ A δx + B δu, y ≈ C δx + D δu about an operating point; names of the states, inputs
    and outputs (rows and columns), the point itself (``x``, ``u``, ``t``, the full model state
    ``x_full``) and the rates there (``xdot``: zero at an equilibrium)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    x: np.ndarray
    u: np.ndarray
    t: float = 0.0
    xdot: np.ndarray = field(default_factory=lambda: np.zeros(0))
    x_full: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def eigenvalues(self) -> np.ndarray:
        """The eigenvalues of A (complex), sorted by real part then imaginary part."""
        values = np.linalg.eigvals(self.A) if self.A.size else np.zeros(0, dtype=complex)
        return values[np.lexsort((values.imag, values.real))]

    def to_control(self) -> Any:
        """A python-control ``StateSpace`` (A, B, C, D) with the state, input and output names
        (``pip install 'porthamiltonian[control]'``)."""
        try:
            import control
        except ImportError:
            raise ModelError("to_control needs python-control: pip install "
                             "'porthamiltonian[control]'") from None
        return control.ss(self.A, self.B, self.C, self.D, states=list(self.states),
                          inputs=list(self.inputs), outputs=list(self.outputs))

    def to_dict(self) -> dict[str, Any]:
        """The JSON form of ``porthamiltonian linearize --json``: A, B, C, D (nested lists),
        states, inputs, outputs (names), eigenvalues ([re, im] pairs) and the point."""
        return {"A": self.A.tolist(), "B": self.B.tolist(), "C": self.C.tolist(),
                "D": self.D.tolist(), "states": list(self.states), "inputs": list(self.inputs),
                "outputs": list(self.outputs),
                "eigenvalues": [[float(v.real), float(v.imag)] for v in self.eigenvalues],
                "t": self.t, "x": dict(zip(self.states, self.x.tolist())),
                "u": dict(zip(self.inputs, self.u.tolist())),
                "xdot_norm": self.xdot_norm}

    @property
    def xdot_norm(self) -> float:
        """|ẋ| at the point (Euclidean; 0 at an equilibrium), without overflow in the squares
        (:func:`math.hypot`: numpy's norm gave inf, with a warning, for rates beyond 1e154)."""
        return math.hypot(*self.xdot.tolist())


def dynamic_states(model: CompiledModel) -> list[int]:
    """The indices of the states a linearization keeps (roles in :data:`DYNAMIC`)."""
    return [i for i, role in enumerate(model.state_roles) if role in DYNAMIC]


def linearize(model: CompiledModel, x: Any = None, u: Any = None, params: Any = None,
              t: float = 0.0) -> LinearModel:
    """The :class:`LinearModel` (A, B, C, D) of ``model`` at (t, x, u, params), from the exact
    Jacobians (see the module docstring for the states and outputs it keeps)."""
    pt = point(model, t, x, u, params)
    keep = dynamic_states(model)
    n, m = model.n_states, len(model.input_names)
    J = _jac(model, pt)[:n, :n]
    A = J[np.ix_(keep, keep)]
    B = _jac_u(model, pt)[keep, :]
    if model.declared_outputs:
        Y = _out_jac(model, pt)
        C, D = Y[:, keep], Y[:, n:n + m]
        outputs = tuple(model.declared_outputs)
    else:
        C, D = np.eye(len(keep)), np.zeros((len(keep), m))
        outputs = tuple(model.state_names[i] for i in keep)
    xdot = _rhs(model, pt)[:n][keep]
    P = len(model.param_names)
    return LinearModel(A, B, C, D, tuple(model.state_names[i] for i in keep),
                       tuple(model.input_names), outputs, pt.x[keep].copy(),
                       pt.p[P:P + m].copy(), pt.t, xdot, pt.x.copy())


@dataclass(frozen=True)
class TrimResult:
    """An operating point found by :func:`trim`: the model state ``x`` (all states), the inputs
    ``u``, max |ẋ| of the dynamic states there (``residual``), the Newton iterations, whether it
    converged (``success``) and a ``message``."""

    x: np.ndarray
    u: np.ndarray
    residual: float
    iterations: int
    success: bool
    message: str

    def as_dict(self, model: CompiledModel) -> dict[str, dict[str, float]]:
        """``{"x": {state: value}, "u": {input: value}}``."""
        return {"x": dict(zip(model.state_names, self.x.tolist())),
                "u": dict(zip(model.input_names, self.u.tolist()))}


def trim(model: CompiledModel, x: Any = None, u: Any = None, params: Any = None,
         t: float = 0.0, free_states: Sequence[str] | None = None,
         free_inputs: Sequence[str] = (), tol: float = 1e-12, max_iter: int = 50
         ) -> TrimResult:
    """An equilibrium: states and inputs with ẋ = 0 (see the module docstring). ``x``, ``u`` are
    the starting point (and the values of what is not free); ``free_states`` default to every
    dynamic state, ``free_inputs`` to none (give some to find the inputs that hold a given
    state). Converged when max |ẋ| <= tol · (1 + max |∂ẋ/∂z · z|) (z the free variables). Never
    raises on non-convergence: ``success`` says. A multibody with loops or constraints is kept
    on them: every iterate is assembled (:func:`~.assembly.consistent`)."""
    pt = point(model, t, x, u, params)
    # checked, not taken as given: tol = inf "converged" at the start, NaN never did, a name
    # given as a string was read letter by letter
    tol = check_number("tol", tol, positive=True)
    max_iter = check_integer("max_iter", max_iter, 0)
    if isinstance(free_states, str) or isinstance(free_inputs, str):
        raise OptionError("free_states and free_inputs are lists of names, not a string")
    n, m, P = model.n_states, len(model.input_names), len(model.param_names)
    keep = dynamic_states(model)
    free_x = keep if free_states is None else [model.state_index(s) for s in free_states]
    unknown = [k for k in free_inputs if k not in model.input_names]
    if unknown:
        raise InputError(f"model {model.name!r} has no input(s) {unknown} to trim; its inputs: "
                         f"{', '.join(model.input_names) or 'none'}")
    free_u = [model.input_names.index(k) for k in free_inputs]
    if not free_x and not free_u:
        raise OptionError("nothing to trim: free_states and free_inputs are both empty")
    y, p = pt.y.copy(), pt.p.copy()
    rows = keep
    residual, iterations, message = np.inf, 0, ""
    constrained = bool(constraint_rows(model))
    for iterations in range(max_iter + 1):
        if constrained:         # every iterate on the constraints: an equilibrium off them,
            # where the drift stabilization balances the forces, is no equilibrium of the mechanism
            y[:n] = consistent(model, y[:n], p, pt.t, warn=False)
        cur = Point(pt.t, y, p)
        f = _rhs(model, cur)[:n][rows]
        J = _jac(model, cur)[:n, :n]
        G = np.hstack([J[np.ix_(rows, free_x)], _jac_u(model, cur)[np.ix_(rows, free_u)]])
        z = np.concatenate([y[free_x], p[[P + k for k in free_u]]])
        residual = float(np.max(np.abs(f))) if f.size else 0.0
        with np.errstate(over="ignore", invalid="ignore"):
            scale = 1.0 + float(np.max(np.abs(G * z[None, :]))) if G.size else 1.0
        if not (math.isfinite(scale) and math.isfinite(residual)):
            # e.g. an angle of 1e308: ∂ẋ/∂z · z overflows, and every residual would pass
            message = (f"the point is beyond the float64 range (max |dx/dt| = {residual:.3g}, "
                       f"max |∂(dx/dt)/∂z · z| = {scale - 1.0:.3g})")
            break
        if residual <= tol * scale:
            return TrimResult(y[:n].copy(), p[P:P + m].copy(), residual, iterations, True,
                              "converged")
        if iterations == max_iter:
            message = f"no convergence in {max_iter} iterations (max |dx/dt| = {residual:.3g})"
            break
        step, *_ = np.linalg.lstsq(G, -f, rcond=None)
        if not np.all(np.isfinite(step)):
            message = "the Jacobian is singular along the free variables"
            break
        for j, i in enumerate(free_x):
            y[i] += step[j]
        for j, k in enumerate(free_u):
            p[P + k] += step[len(free_x) + j]
    return TrimResult(y[:n].copy(), p[P:P + m].copy(), residual, iterations, False, message)


__all__ = ["DYNAMIC", "LinearModel", "Point", "TrimResult", "acceleration_rows",
           "acceleration_values", "accelerations", "derivative", "dynamic_states",
           "input_jacobian", "input_vector", "jacobian", "linearize", "outputs_y", "point",
           "trim"]
