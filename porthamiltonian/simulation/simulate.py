"""Hybrid simulation: stiff integration with the analytic Jacobian, events, modes and resets.

The integration state is the model state followed by the ledger states E_diss and E_in
(see :mod:`porthamiltonian.compiler.assemble`). Discrete modes are parameters (contact flags,
stance leg...) that an event action changes; a reset map changes the state. Every jump of the
Hamiltonian at a reset is booked in the ledger (as dissipated energy by default, e.g. a plastic
impact; as supplied energy when the action says so, e.g. a controller switching a stiffness), so
the residual r = H(t) − H(0) + E_diss − E_in stays closed across events.

The step loop is our own, over scipy's public step-wise solvers (``scipy.integrate.Radau``, ``BDF``,
``LSODA``, ``RK45``, ``DOP853``), rather than ``solve_ivp``: all guards are evaluated by one compiled
call per step, the step's interpolant is built only when a guard changes sign (or when dense output
is asked for), divergence is a cheap per-step check, a guard that has just fired is kept on its new
side at the restart (no re-firing at the same crossing), non-terminal events are recorded, and a
failing step keeps everything integrated before it. A failing or diverging integration ends with a
status in the :class:`Trajectory`, never with an exception from inside scipy.

:func:`simulate` checks its arguments and hands them to a :class:`Simulator`, which owns the
integration state (as Drake's Simulator owns a Context beside the System): the current time,
state and parameters, the next step size of the compiled loop, the side a guard that has just
fired is kept on, the counters; the :class:`Trajectory` it returns is an immutable result. The
compiled loop (Rodas5P, Rodas4 or QBDF, ``Functions.loops``) is called in one place,
:meth:`Simulator._compiled_segment`.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from ..errors import InputError, ModelError, OptionError, StateError
from ..integrators import COMPILED_METHODS
from .assembly import consistent
from .dense import step_interpolant
from .differences import Derivative, gradient, jacobian
from .inputs import InputPlan, plan_inputs
from .options import check_method, check_simulation
from .psensitivity import ParameterColumns, parameter_jump
from .saltation import Crossing, Seeds, Sensitivity, saltation_matrix
from .sampling import Breakpoints, sample
from .stiffness import BOUNDS, EVERY, StiffnessWatch
from .trajectory import Segment, Status, Trajectory

if TYPE_CHECKING:   # the compiled model offers simulate as its method: no run-time import of it
    from .compiled import CompiledModel, EventInfo

#: the methods whose whole step loop is compiled with the model (Functions.loops)
_COMPILED = COMPILED_METHODS
_STIFF = ("Radau", "BDF", "LSODA")
_EPS = np.finfo(float).eps


@dataclass
class Reset:
    """What an event action returns.

    x : new model state (length n), or None to keep it.
    params : parameters (modes) to change, by name.
    stop : end the simulation after this event.
    energy : where a jump of H is booked: ``"dissipated"`` (E_diss += H⁻ − H⁺) or
        ``"supplied"`` (E_in += H⁺ − H⁻).
    jacobian : ∂x⁺/∂x⁻ (n x n) of the state map, for runs with sensitivities (its saltation
        matrix, :mod:`porthamiltonian.simulation.saltation`); needed when ``x`` moves the state, else the
        identity.
    jacobian_p : ∂x⁺/∂p by parameter name (a vector of n each), for runs with parameter
        sensitivities: needed when ``x`` moves the state, for every differentiated parameter (a
        name left out: the map does not read it).
    params_jacobian : for a parameter that ``params`` sets from the state or from other
        parameters, the gradient of its new value by [x⁻, p] (a vector of n + len(param_names):
        the model states, then every parameter in the model's order), for runs with parameter
        sensitivities; a parameter not in it is set to a constant.
    """

    x: np.ndarray | None = None
    params: Mapping[str, float] | None = None
    stop: bool = False
    energy: Literal["dissipated", "supplied"] = "dissipated"
    jacobian: np.ndarray | None = None
    jacobian_p: Mapping[str, np.ndarray] | None = None
    params_jacobian: Mapping[str, np.ndarray] | None = None


#: An event action: (t, model state x, parameter vector p) -> Reset.
Action = Callable[[float, np.ndarray, np.ndarray], Reset]


@dataclass
class Event:
    """A Python-level event: guard g(t, x, p) on the model state; fires when g crosses zero."""

    name: str
    guard: Callable[[float, np.ndarray, np.ndarray], float]
    direction: int = 0
    terminal: bool = True


def simulate(model: CompiledModel, t_end: float, x0: np.ndarray | Mapping[str, float] | None = None,
             params: Mapping[str, float] | None = None, *, t_start: float = 0.0,
             method: str = "auto", rtol: float = 1e-8, atol: float | np.ndarray = 1e-10,
             max_step: float = math.inf, first_step: float | None = None, jacobian: bool = True,
             actions: Mapping[str, Action] | None = None, events: list[Event] | None = None,
             t_eval: np.ndarray | None = None, dense_output: bool = False,
             max_events: int = 100_000, max_steps: int = 10_000_000,
             divergence_bound: float = 1e12,
             sensitivity: bool | np.ndarray | Sequence[str] | Seeds = False,
             inputs: Any = None,
             progress: Callable[[float, int], None] | None = None) -> Trajectory:
    """Simulate ``model`` from ``t_start`` to ``t_end`` (also ``model.simulate(t_end, ...)``).

    Parameters
    ----------
    x0 : initial model state: an array (length n), a mapping ``{state name: value}`` overriding
        the components' initial values, or None for those values.
    params : parameter values by name (defaults for the others).
    inputs : the binding of every input of the model (``model.input_names``), by name: a
        number, :class:`~porthamiltonian.simulation.inputs.Samples` (held or interpolated), or a
        callable ``u(t, x)`` (scipy methods only: ``"auto"`` picks Radau); or one callable for
        all. See :mod:`porthamiltonian.simulation.inputs`; a model without inputs takes None.
    rtol, atol : tolerances; ``atol`` a scalar or one value per model state (e.g. tiny masses with
        tiny momenta); the ledger states E_diss, E_in get the largest of them.
    method : ``"auto"`` (default: Radau when Python events or callable inputs are asked for,
        else :func:`auto_method`: QBDF for a multibody of two or more coordinates, Rodas5P
        otherwise; where QBDF stalls (step size too small: a jump of the force inside a step,
        e.g. a Kelvin-Voigt contact at touchdown with a tight atol) the run is made again with
        Rodas5P from the start, and the message says so; ``progress`` then sees the time start
        again), a compiled method — ``"Rodas5P"`` or ``"Rodas4"`` (stiff, L-stable
        Rosenbrock methods of order 5 and 4: a Jacobian and an LU at every step; Rodas5P takes
        fewer steps at the same accuracy), ``"QBDF"`` (variable-order BDF, orders 1-5, reusing
        its Jacobian and LU over many steps; its global error is near rtol, Rodas5P's often far
        below: compare them at equal accuracy, benchmarks/RESULTS.md) — whose whole step loop
        is compiled with the model (the fast path with the C or numba back end; model events
        only; ``t_eval`` and dense output: see those), or a scipy method: Radau, BDF, LSODA
        (stiff, given the analytic Jacobian unless ``jacobian=False``), RK45, DOP853.
    max_step, first_step : bounds on the step size (s); ``first_step`` for the scipy methods.
    jacobian : give the stiff scipy methods the analytic Jacobian.
    actions : event name -> action (model events or ``events``). An event without action is
        recorded; if it is terminal, the simulation stops there.
    events : extra Python-level events.
    t_eval : times at which to store the solution (default: every accepted step); a compiled
        method gives its steps' interpolant there (as ``dense_output``: 1 to 2.3 times the
        steps' own error), except with ``sensitivity``, where its loop stops exactly on each time
        (a breakpoint), so that Φ there is the integration's own.
    dense_output : keep the interpolants, for :meth:`Trajectory.sol` (costs time): a scipy
        method's own; a compiled method's made after the run from its steps, by quintic
        Hermite interpolation with the model's exact rates and their time derivatives
        (:mod:`porthamiltonian.simulation.dense`: 1 to 2.3 times the error of the steps
        themselves on a closed form).
    max_events, max_steps : bounds (a chattering guard ends the run with status "failed").
    divergence_bound : the run ends with status "diverged" when max|x| exceeds it.
    sensitivity : also integrate the derivatives of the run by its initial model state,
        Φ(t) = ∂x(t)/∂x₀ · V, with saltation matrices at the events (``traj.sensitivity``, a
        :class:`~porthamiltonian.simulation.saltation.Sensitivity`: Φ at every point and where the run
        ended, the events' saltation matrices): True for V = I (all model states), or the
        directions V (n x m). Compiled methods only (``"auto"``: as without); the trajectory is
        the same, bit for bit, as without; an action that moves the state gives its Jacobian
        (``Reset(jacobian=...)``). Parameter names (``["k", "c"]``) add the columns ∂x(t)/∂p
        (``traj.sensitivity.parameters[name]``, from ∂x₀/∂p of the model's initial values),
        integrated with the generated ∂ẋ/∂p (the model compiles itself again with it, once),
        through events whose guard, reset or mode change reads p; a
        :class:`~porthamiltonian.simulation.saltation.Seeds` gives both the directions and the
        parameters (and ∂x₀/∂p). See :mod:`porthamiltonian.simulation.saltation`.
    progress : called with the simulated time and the steps taken so far, now and then during
        the run (after each batch of up to 4096 steps of a compiled loop, every 1000 steps of a
        scipy method): for a progress display of a long run (the command line's).

    Returns the :class:`Trajectory`; its ``status`` (a :class:`Status`) says how the run ended.

    Every argument is checked first (:mod:`porthamiltonian.simulation.options`): a wrong type or a value
    outside its rule (a NaN, zero or negative tolerance, ``rtol >= 1``, ``t_eval`` outside the
    span) raises :class:`~porthamiltonian.errors.OptionError` naming it, before any work.
    """
    checked = check_simulation(
        model.n_states, t_end, x0, params, t_start=t_start, method=method, rtol=rtol, atol=atol,
        max_step=max_step, first_step=first_step, jacobian=jacobian, actions=actions,
        events=events, t_eval=t_eval, dense_output=dense_output, max_events=max_events,
        max_steps=max_steps, divergence_bound=divergence_bound, sensitivity=sensitivity)
    t_start, t_end, t_eval = checked["t_start"], checked["t_end"], checked["t_eval"]
    plan = plan_inputs(model.input_names, len(model.param_names), inputs, t_start, t_end)
    calls = plan is not None and plan.has_callable
    if progress is not None and not callable(progress):
        raise OptionError(f"progress must be a function of the time and steps, or None, got "
                          f"{type(progress).__name__}")
    requested = check_method(method)
    if method == "auto":
        method = "Radau" if (events or calls) else auto_method(model)
    p = model.params(params)
    if plan is not None:
        p = plan.slots(p, t_start)
    if x0 is None or isinstance(x0, Mapping):
        x = model.initial_state(p, x0)
    else:
        x = np.array(x0, dtype=float)
    y = model.augment(x)
    if np.all(np.isfinite(y)):                  # a constrained multibody starts on its manifold
        with np.errstate(all="ignore"):         # (as in the run: Simulator.run)
            y[:model.n_states] = consistent(model, y[:model.n_states], p, t_start)
    if not np.all(np.isfinite(y)):
        raise StateError(f"model {model.name!r}: initial state is not finite: {x}")
    seeds = checked["sensitivity"]
    if seeds is not None and seeds.parameters:
        seeds = _parameter_seeds(model, seeds, p, x0)
    py_events = tuple(events or ())
    names = [e.name for e in model.events] + [e.name for e in py_events]
    actions = dict(actions or {})
    unknown = set(actions) - set(names)
    if unknown:
        raise ModelError(f"actions for unknown event(s) {', '.join(sorted(unknown))}; events: "
                         f"{', '.join(names) or 'none'}")
    if method in _COMPILED and py_events:
        raise ModelError(f"method {method!r} (a compiled loop) takes model events only; use a "
                         "scipy method (e.g. Radau) for Python events")
    if method in _COMPILED and calls:
        raise InputError(f"method {method!r} (a compiled loop) cannot call Python inputs "
                         "u(t, x); bind them to numbers or Samples, compile the controller "
                         "into the model, or use a scipy method (e.g. Radau)")
    if seeds is not None and method not in _COMPILED:
        raise ModelError(f"sensitivity needs a compiled method ({', '.join(_COMPILED)}), whose "
                         f"loop integrates the variational equation; got method {method!r}"
                         + (" (chosen by 'auto' for Python events or callable inputs)"
                            if requested == "auto" else ""))
    settings = Settings(
        method=method, rtol=checked["rtol"], atol=_ledger_atol(checked["atol"], model.n_states),
        max_step=checked["max_step"], first_step=checked["first_step"],
        jacobian=checked["jacobian"] and method in _STIFF and not calls, actions=actions,
        events=py_events,
        t_eval=t_eval, dense_output=checked["dense_output"], max_events=checked["max_events"],
        max_steps=checked["max_steps"], divergence_bound=checked["divergence_bound"],
        sensitivity=seeds, inputs=plan, progress=progress)
    simulator = Simulator(model, settings)
    result = simulator.run(t_start, y, p, t_end)
    if requested == "auto" and method == "QBDF" and simulator.stalled:
        # QBDF's controller can stall on a jump of the right-hand side inside a step (a
        # Kelvin-Voigt floor's damping force switching on at touchdown, with a tight atol);
        # Rodas5P's error estimate passes such a jump: the run is made again with it
        again = Simulator(model, replace(settings, method="Rodas5P"),
                          note=f" (method 'auto': {result.message}; run again with Rodas5P)")
        result = again.run(t_start, y, p, t_end)
    return result


def _parameter_seeds(model: CompiledModel, seeds: Seeds, p: np.ndarray, x0: Any) -> Seeds:
    """``seeds`` with its parameters checked and ∂x₀/∂p filled in: given, else that of the
    model's initial values (x0 None or a mapping: the states it names are fixed) by central
    differences (:mod:`.differences`; the initial values are the parameters' expressions,
    smooth), else zero (x0 given as an array)."""
    names = list(seeds.parameters)
    for name in names:
        model._param_index_of(name)         # UnknownParameterError naming the parameters
    if seeds.initial is not None:
        return seeds
    n = model.n_states
    if x0 is not None and not isinstance(x0, Mapping):
        return Seeds(seeds.states, seeds.parameters, np.zeros((n, len(names))))
    index = [model.param_names.index(name) for name in names]

    def initial(values: np.ndarray) -> np.ndarray:
        q = p.copy()
        q[index] = values
        return model.initial_state(q, x0)

    d = jacobian(initial, p[index], 1.0)
    return Seeds(seeds.states, seeds.parameters, d.value)


def auto_method(model: CompiledModel) -> str:
    """The compiled method ``method="auto"`` runs ``model`` with (no Python events or callable
    inputs): QBDF for a model with a multibody of two or more coordinates (a named
    mass matrix ``<component>.M`` and states ``<component>.q.*``: its Jacobian, the chain rule
    through the mass-matrix solve, costs several right-hand sides, which QBDF evaluates once in
    tens of steps), else Rodas5P. Measured at equal accuracy (benchmarks/RESULTS.md, "Jacobian
    reuse"): QBDF takes 0.1-0.3x Rodas5P's time on a sphere rolling in 3-D contact, 0.3-0.5x on
    the compass and compliant-leg walkers, 0.7x on the double pendulum, 0.8-1.0x on the bouncing
    ball (two coordinates, a constant mass matrix); 1.1-3x on the models without such a
    multibody (a stiff spring chain, the dc motor, the mass-spring-damper, a one-coordinate
    pendulum, the free rigid body), whose Jacobian is cheap and where Rodas5P's error is far
    below its tolerance."""
    for name in model.matrix_names:
        if name.endswith(".M"):
            prefix = name[:-1] + "q."
            if sum(1 for s in model.state_names if s.startswith(prefix)) >= 2:
                return "QBDF"
    return "Rodas5P"


def _ledger_atol(atol: float | np.ndarray, n: int) -> float | np.ndarray:
    """The absolute tolerance of the integration state: per model state, the ledger states E_diss
    and E_in scaled like the largest of them."""
    atol = np.asarray(atol, dtype=float)
    if atol.ndim == 1:
        if atol.shape != (n,):
            raise ModelError(f"atol must be a scalar or have one value per state ({n}), got "
                             f"shape {atol.shape}")
        return np.concatenate([atol, [atol.max(), atol.max()]])
    return float(atol)


@dataclass(frozen=True)
class Settings:
    """The checked settings of one simulation (the arguments of :func:`simulate`, which
    documents them; ``atol`` extended to the ledger states, ``jacobian`` only for stiff scipy
    methods, ``sensitivity`` the :class:`~.saltation.Seeds` (directions V, n x m, parameters
    and ∂x₀/∂p filled in) or None)."""

    method: str
    rtol: float
    atol: float | np.ndarray
    max_step: float
    first_step: float | None
    jacobian: bool
    actions: Mapping[str, Action]
    events: tuple[Event, ...]
    t_eval: np.ndarray | None
    dense_output: bool
    max_events: int
    max_steps: int
    divergence_bound: float
    sensitivity: Seeds | None = None
    inputs: InputPlan | None = None
    progress: Callable[[float, int], None] | None = None

    @property
    def loop_stops(self) -> np.ndarray | None:
        """The times of ``t_eval`` a compiled loop stops on: all of them with sensitivities (Φ
        there is the loop's own), else none (the run samples its steps' interpolant there)."""
        return (self.t_eval if self.method in _COMPILED and self.sensitivity is not None
                else None)


#: The compiled loops' return codes (porthamiltonian/integrators/rosenbrock_loop.py), but 5: its
#: store buffer is full, call again
_LOOP_STATUS = {0: Status.FINISHED, 1: Status.EVENT, 2: Status.FAILED, 3: Status.DIVERGED,
                4: Status.FAILED}
_LOOP_BUFFER_FULL = 5


class Simulator:
    """Integrates one compiled model with fixed :class:`Settings`; made by :func:`simulate`.

    It owns the integration state of a run (Drake's Context): the time ``t``, the integration
    state ``y`` (model states, then E_diss and E_in), the parameters ``p`` (modes change at
    events), the step size the compiled loop proposes next, the sign a terminal guard had before
    it fired (to keep it on its new side at the restart), the step and event counters, and what
    has been recorded so far. :meth:`run` returns the immutable :class:`Trajectory`.
    """

    def __init__(self, model: CompiledModel, settings: Settings, note: str = ""):
        self.model, self.settings, self.note = model, settings, note
        events: list[EventInfo | Event] = [*model.events, *settings.events]
        self.names = [e.name for e in events]
        self.direction = np.array([e.direction for e in events])
        self.terminal = np.array([e.terminal or e.name in settings.actions for e in events],
                                 dtype=np.bool_)
        self.n_model_events = len(model.events)
        # the integration state
        self.t, self.y, self.p = 0.0, np.empty(0), np.empty(0)
        self.h_next = 0.0               # the compiled loop's next step size (0: its own guess)
        self.pre_event_sign = 0.0       # sign of the last terminal guard before it fired
        self.steps = 0
        self._segments: list[Segment] = []
        self._events: list[tuple[float, str]] = []
        self._jumps: list[tuple[float, str, float]] = []
        self._counts = {"nfev": 0, "njev": 0, "nlu": 0}
        self.phi: np.ndarray | None = None     # the sensitivities (n + 2 x m), when asked for
        self.phi_error = 0.0                    # their largest error estimate (in rtol)
        self._crossings: list[Crossing] = []
        self.columns: ParameterColumns | None = None    # with parameters: Π and the build
        self.stalled = False            # a compiled loop's step size fell below its minimum
        self.h0 = math.nan              # H at the start (J)
        # an explicit method's steps held by its stability bound (a hint at the end of the run)
        self.watch = (StiffnessWatch(settings.method, model.n_states)
                      if settings.method in BOUNDS else None)

    def run(self, t_start: float, y: np.ndarray, p: np.ndarray, t_end: float) -> Trajectory:
        """Integrate from (t_start, y) with parameters p to t_end (or until a terminal event
        without action, a stopping action, a failure); the result. numpy's floating-point
        warnings are off during the run: a state beyond the float64 range shows in the run's
        status (diverged, failed) on every back end, not also as RuntimeWarnings of the python
        back end's generated code (whose small solves use numpy scalars) where C says
        nothing."""
        with np.errstate(all="ignore"):
            try:
                return self._run(t_start, y, p, t_end)
            except (ArithmeticError, ValueError) as err:
                if not self.model.raised_beyond_floats(err):
                    raise
                if not self._segments:          # the run keeps its start, as a failed step does
                    self._segments.append(Segment(
                        np.array([self.t]), self.y[:, None].copy(), self.p.copy(), None,
                        None if self.phi is None else self.phi[None].copy(),
                        inputs=self._binder()))
                return self._result(Status.FAILED, f"the model's functions raised "
                                    f"{type(err).__name__} ({err}) after t = {self.t:.6g} ("
                                    f"{self.model.backend} back end): a value beyond the float64 "
                                    "range or outside a function's domain, where the C back end "
                                    "computes inf or NaN and fails the run", self.h0)

    def _run(self, t_start: float, y: np.ndarray, p: np.ndarray, t_end: float) -> Trajectory:
        """:meth:`run`, under its floating-point state."""
        model, settings, n = self.model, self.settings, self.model.n_states
        self.t, self.y, self.p = t_start, y, p
        seeds = settings.sensitivity
        if seeds is not None:
            columns = seeds.states
            if seeds.parameters:
                columns = np.hstack([columns, seeds.initial])
                self.columns = ParameterColumns(model, seeds.parameters, columns.shape[1])
            self.phi = np.vstack([columns, np.zeros((2, columns.shape[1]))])
        h0 = self.h0 = float(model.energy(t_start, y, p)[0])
        breaks = Breakpoints(model, settings.inputs, t_start, t_end, y, p, settings.loop_stops)
        if breaks:
            self._break(breaks, t_start)            # the first samples (k = 0) at the start
        fired, n_events = None, 0
        while True:
            t_restart = self.t
            t_stop = breaks.next(self.t) if breaks else t_end
            status, message, k = self._segment(t_stop, fired)
            if status == Status.FINISHED and t_stop < t_end:
                self._break(breaks, t_stop)
                fired = None
                continue
            if status != Status.EVENT:
                return self._result(status, message, h0)
            t, name = self.t, self.names[k]
            self._events.append((t, name))
            n_events += 1
            if n_events > settings.max_events:
                return self._result(Status.FAILED, f"more than {settings.max_events} events (last "
                                    f"{name!r} at t = {t:.6g}): the guard chatters; add hysteresis "
                                    "to it", h0)
            action = settings.actions.get(name)
            if action is None:
                if self.phi is not None:
                    self._cross(self.phi, k, t, self.y, self.p, self.y, self.p, Reset(stop=True),
                                moved=False)
                return self._result(Status.EVENT, f"terminal event {name!r} at t = {t:.6g}", h0)
            y, p = self.y, self.p
            y_minus, p_minus = y, p
            reset = action(t, y[:n].copy(), p.copy())
            h_before = float(model.energy(t, y, p)[0])
            moved = reset.x is not None and not np.array_equal(np.asarray(reset.x, dtype=float),
                                                               y[:n])
            if reset.params:
                p = model.changed_params(p, reset.params)
            y = y.copy()
            if reset.x is not None:
                new_x = np.asarray(reset.x, dtype=float)
                if new_x.shape != (n,) or not np.all(np.isfinite(new_x)):
                    raise StateError(f"action for event {name!r} returned an invalid state {new_x}")
                y[:n] = new_x
            jump = float(model.energy(t, y, p)[0]) - h_before
            if reset.energy == "dissipated":
                y[n] -= jump
            else:
                y[n + 1] += jump
            self.y, self.p = y, p
            self._jumps.append((t, name, jump))
            phi = None
            if self.phi is not None:
                self._cross(self.phi, k, t, y_minus, p_minus, y, p, reset, moved=moved)
                phi = self.phi[None].copy()
            self._segments.append(Segment(np.array([t]), y[:, None].copy(), p.copy(), None, phi,
                                          inputs=self._binder()))
            if reset.stop:
                return self._result(Status.EVENT, f"stopped by the action of event {name!r} at "
                                    f"t = {t:.6g}", h0)
            if t >= t_end:
                return self._result(Status.FINISHED, "reached t_end", h0)
            # a guard that fired after some integration and whose state was not moved sits on its
            # root: keep it on its new side at the restart so that it does not fire again at the
            # same crossing. After a reset that moved the state, or an event at the very start of
            # a segment, guards are taken as they are (a state put back onto a guard and pushed
            # across it again fires again: a chattering contact, caught by max_events)
            fired = None if (moved or t == t_restart) else k

    def _break(self, breaks: Breakpoints, t: float) -> None:
        """At the breakpoint ``t`` (:mod:`.sampling`): the next input piece's slots, the
        sampling of the discrete blocks due; a sampling that changes the state is recorded as
        a point of its own (the state before it ends the previous segment)."""
        self.t = t
        starts, blocks = breaks.due(t)
        if starts and self.settings.inputs is not None:     # (starts come from the inputs)
            self.p = self.settings.inputs.slots(self.p, t)
        if blocks:
            if self.phi is not None:
                raise ModelError("sensitivities of runs with discrete-time blocks are not "
                                 "derived (their sampling is a reset of the state); simulate "
                                 "without sensitivity")
            y = sample(self.model, blocks, t, self.y, self.p)
            if not np.array_equal(y, self.y):
                self.y = y
                self._segments.append(Segment(np.array([t]), y[:, None].copy(), self.p.copy(),
                                              None, inputs=self._binder()))

    def _binder(self) -> Any:
        """The run's callable inputs as a segment records them (None without)."""
        plan = self.settings.inputs
        return plan.at if plan is not None and plan.has_callable else None

    def _result(self, status: Status, message: str, h0: float) -> Trajectory:
        sensitivity = None
        seeds = self.settings.sensitivity
        if self.phi is not None and seeds is not None:      # (phi is set from the seeds)
            n = self.model.n_states
            m0 = seeds.states.shape[1]
            phi = np.concatenate([s.phi for s in self._segments])
            extra: dict[str, Any] = {}
            if self.columns is not None:
                names = seeds.parameters
                extra = {"parameter_names": names,
                         "parameters": {name: phi[:, :n, m0 + j].copy()
                                        for j, name in enumerate(names)},
                         "final_parameters": self.phi[:n, m0:].copy(),
                         "ledger": phi[:, n:, :].copy(), "final_ledger": self.phi[n:].copy(),
                         "final_params": self.columns.pi.copy()}
            sensitivity = Sensitivity(seeds.states.copy(), phi[:, :n, :m0].copy(),
                                      tuple(self._crossings), self.phi[:n, :m0].copy(),
                                      self.phi_error, **extra)
        if self.watch is not None:
            self.watch.warn(self.model.name)
        return Trajectory(self.model, self._segments, self._events, self._jumps, status,
                          message + self.note, h0=h0, sensitivity=sensitivity, **self._counts)

    def _cross(self, phi: np.ndarray, k: int, t: float, y_minus: np.ndarray,
               p_minus: np.ndarray, y_plus: np.ndarray, p_plus: np.ndarray, reset: Reset, *,
               moved: bool) -> np.ndarray:
        """Apply the saltation matrix of event ``k`` at time t (from y_minus, p_minus to y_plus,
        p_plus by the action's ``reset``: its Jacobians; its ``stop``: the run ends on the
        event's surface) to the sensitivities and record the
        :class:`~porthamiltonian.simulation.saltation.Crossing`; returns Φ⁺ (model states).
        ``phi``: the run's Φ before the event (``self.phi``)."""
        model, n = self.model, self.model.n_states
        name = self.names[k]
        jacobian, stop = reset.jacobian, bool(reset.stop)
        if jacobian is None:
            if moved:
                raise ModelError(f"the action of event {name!r} moved the state at t = {t:.6g} "
                                 "but gave no Jacobian: with sensitivities it must return "
                                 "Reset(x=..., jacobian=dx_plus/dx_minus), an n x n array")
            R = np.eye(n)
        else:
            R = np.array(jacobian, dtype=float)
            if R.shape != (n, n) or not np.all(np.isfinite(R)):
                raise StateError(f"the action of event {name!r} returned a reset Jacobian of "
                                 f"shape {R.shape} (must be {n} x {n} and finite)")
        if self.columns is not None:
            return self._cross_parameters(phi, self.columns, k, t, y_minus, p_minus, y_plus,
                                          p_plus, reset, R, moved)
        f_minus = np.asarray(model.functions.rhs(t, y_minus, model.native_params(p_minus)))[:n]
        f_plus = (np.zeros(n) if stop else
                  np.asarray(model.functions.rhs(t, y_plus, model.native_params(p_plus)))[:n])
        phi_minus = phi[:n].copy()
        if not stop and jacobian is None and np.array_equal(f_plus, f_minus):
            S, g_x, g_t, error = np.eye(n), np.full(n, np.nan), float("nan"), float("nan")
            tau = np.full(phi_minus.shape[1], np.nan)
        else:
            grad = self._guard_gradient(k, t, y_minus, p_minus)
            g_t, g_x, error = float(grad.value[0]), grad.value[1:], grad.max_error
            S = saltation_matrix(f_minus, f_plus, g_x, R, g_t)
            tau = -(g_x @ phi_minus) / (g_t + g_x @ f_minus)
        phi_plus: np.ndarray = S @ phi_minus
        self.phi = np.vstack([phi_plus, np.zeros((2, phi_plus.shape[1]))])
        self._crossings.append(Crossing(t, name, y_minus[:n].copy(), y_plus[:n].copy(), f_minus,
                                        f_plus, g_x, g_t, error, R, S, stop, phi_minus,
                                        phi_plus, tau))
        return phi_plus

    def _cross_parameters(self, phi: np.ndarray, columns: ParameterColumns, k: int, t: float,
                          y_minus: np.ndarray, p_minus: np.ndarray, y_plus: np.ndarray,
                          p_plus: np.ndarray, reset: Reset, R: np.ndarray,
                          moved: bool) -> np.ndarray:
        """:meth:`_cross` of a run with parameter sensitivities: the augmented saltation
        matrix over (x, E_diss, E_in, p) (:func:`.psensitivity.parameter_jump`)."""
        model, settings, n = self.model, self.settings, self.model.n_states
        stop = bool(reset.stop)
        guard: Callable[[float, np.ndarray, np.ndarray], float]
        if k < self.n_model_events:
            def model_guard(t: float, x: np.ndarray, p: np.ndarray) -> float:
                yz = y_minus.copy()
                yz[:n] = x
                return float(model.functions.guards(t, yz, model.native_params(p))[k])
            guard = model_guard
        else:
            guard = settings.events[k - self.n_model_events].guard
        given = dict(reset.params_jacobian or {})
        unknown = set(given) - set(reset.params or {})
        if unknown:
            raise ModelError(f"the action of event {self.names[k]!r} gave params_jacobian for "
                             f"{', '.join(sorted(unknown))}, which it does not set")
        changed = {name: given.get(name) for name in (reset.params or {})}
        typical = np.broadcast_to(np.asarray(settings.atol, dtype=float), (n + 2,))[:n]
        scale = np.concatenate([[1.0], typical / settings.rtol])
        phi_minus, pi_minus = phi[:n].copy(), columns.pi.copy()
        out = parameter_jump(columns, phi, t, y_minus, p_minus, y_plus, p_plus, R,
                             reset.jacobian_p, changed, reset.energy, stop, moved, guard, scale,
                             self.names[k], k if k < self.n_model_events else None)
        self.phi, columns.pi = out.phi, out.pi
        if not stop:
            columns.follow()
        N = n + 2
        names = model.param_names
        S = out.augmented[:n, :n]
        f_minus = np.asarray(model.functions.rhs(t, y_minus, model.native_params(p_minus)))[:n]
        f_plus = (np.zeros(n) if stop else
                  np.asarray(model.functions.rhs(t, y_plus, model.native_params(p_plus)))[:n])
        self._crossings.append(Crossing(
            t, self.names[k], y_minus[:n].copy(), y_plus[:n].copy(), f_minus, f_plus, out.g_x,
            out.g_t, out.guard_error, R, S, stop, phi_minus, out.phi[:n].copy(),
            out.time_sensitivity, out.augmented[:N + len(names), :N + len(names)],
            {names[i]: v for i, v in out.g_p.items()}, pi_minus))
        return out.phi[:n]

    def _guard_gradient(self, k: int, t: float, y: np.ndarray, p: np.ndarray) -> Derivative:
        """(∂g/∂t, ∂g/∂x) of guard ``k`` at (t, y) by central differences, each state stepped
        relative to max(|x_i|, atol_i/rtol) (the size below which the integration does not
        resolve it), the time relative to max(|t|, 1)."""
        model, settings, n = self.model, self.settings, self.model.n_states
        pn = model.native_params(p)
        if k < self.n_model_events:
            def guard(z: np.ndarray) -> float:
                yz = y.copy()
                yz[:n] = z[1:]
                return float(model.functions.guards(float(z[0]), yz, pn)[k])
        else:
            event = settings.events[k - self.n_model_events]

            def guard(z: np.ndarray) -> float:
                return float(event.guard(float(z[0]), z[1:].copy(), p))
        typical = np.broadcast_to(np.asarray(settings.atol, dtype=float), (n + 2,))[:n]
        scale = np.concatenate([[1.0], typical / settings.rtol])
        return gradient(guard, np.concatenate([[t], y[:n]]), scale)

    def _guards(self, t: float, y: np.ndarray, pn: Any, p: np.ndarray) -> np.ndarray:
        n = self.model.n_states
        g = np.asarray(self.model.functions.guards(t, y, pn))[: self.n_model_events]
        if self.settings.events:
            g = np.concatenate([g, [e.guard(t, y[:n], p) for e in self.settings.events]])
        return g

    def _fired_side(self, fired: int) -> float:
        """The side (+1/-1) a guard that has just fired is kept on at the restart."""
        return float(self.direction[fired] or -np.sign(self.pre_event_sign or 1.0))

    def _segment(self, t_end: float, fired: int | None) -> tuple[Status, str, int]:
        """Integrate from the current (t, y) until t_end or a terminal event; record the segment,
        advance the state; returns (status, message, index of the terminal event or -1)."""
        if self.settings.method in _COMPILED:
            return self._compiled_segment(t_end, fired)
        return self._scipy_segment(t_end, fired)

    def _scipy_segment(self, t_end: float, fired: int | None) -> tuple[Status, str, int]:
        """One segment through a scipy step-wise solver."""
        # scipy.integrate is imported here, not at the top: runs on the compiled loops (the
        # default) never need it, and it costs a third of a second at every start
        import scipy.integrate as si
        from scipy.optimize import brentq
        model, settings, n = self.model, self.settings, self.model.n_states
        t0, y0, p = self.t, self.y, self.p
        pn = model.native_params(p)
        rhs, jacf = model.functions.rhs, model.functions.jac
        binder = self._binder()

        def params_at(t: float, y: np.ndarray) -> Any:
            """The parameters at (t, y): p with the callable inputs' values."""
            return pn if binder is None else model.native_params(binder(t, y[:n], p))

        def fun(t: float, y: np.ndarray) -> Any:
            return rhs(t, y, params_at(t, y))

        options: dict[str, Any] = {"rtol": settings.rtol, "atol": settings.atol,
                                   "max_step": settings.max_step}
        if settings.first_step is not None:
            options["first_step"] = settings.first_step
        if settings.jacobian:
            options["jac"] = lambda t, y: jacf(t, y, params_at(t, y))
        solver = getattr(si, settings.method)(fun, t0, y0, t_end, **options)
        t_eval = settings.t_eval
        ts, ys, interpolants = [t0], [y0], list[Any]()
        if t_eval is not None:
            ts, ys = [], []
            self._eval_at(ts, ys, None, t0, t0, y0, include_start=True)
        has_events = len(self.direction) > 0
        g_old = self._guards(t0, y0, params_at(t0, y0), p) if has_events else np.empty(0)
        if fired is not None:  # keep a guard that just fired on its new side at the restart
            g_old[fired] = self._fired_side(fired) * max(abs(g_old[fired]), 1e-300)

        def close(status: Status, message: str, t_last: float, y_last: np.ndarray | None,
                  k: int = -1) -> tuple[Status, str, int]:
            sol = (si.OdeSolution([s.t_old for s in interpolants] + [interpolants[-1].t],
                               interpolants) if (settings.dense_output and interpolants) else None)
            self._segments.append(Segment(np.array(ts), np.array(ys).T if ys else
                                          np.empty((n + 2, 0)), p.copy(), sol, inputs=binder))
            for key in self._counts:
                self._counts[key] += getattr(solver, key)
            self.t = t_last
            if y_last is not None:
                self.y = y_last
            return status, message, k

        # rates that are not finite at the segment's start: scipy's initial step size is then
        # NaN, and RK45's and DOP853's step loops never leave (NaN is neither accepted nor
        # below the smallest step: `--set m=1e-300` hung for ever, with no progress line)
        f0 = np.asarray(fun(t0, y0), dtype=float)
        if not np.all(np.isfinite(f0)):
            names = [*model.state_names, "E_diss", "E_in"]
            bad = ", ".join(f"{names[i]}: {f0[i]:g}" for i in np.flatnonzero(~np.isfinite(f0)))
            return close(Status.FAILED, f"the rates at t = {t0:.6g} are not finite ({bad})",
                         t0, None)
        while True:
            t_old = solver.t
            try:
                message = solver.step()
            except (ValueError, ArithmeticError, np.linalg.LinAlgError) as err:
                return close(Status.FAILED, f"integration failed at t = {t_old:.6g}: {err}",
                             t_old, None)
            self.steps += 1
            if solver.status == "failed":
                return close(Status.FAILED, f"{settings.method} failed at t = {t_old:.6g}: "
                             f"{message}", t_old, None)
            if solver.t == t_old and solver.status == "running":
                # LSODA's step size can fall below the resolution of t (pendulum at g = 1e300:
                # periods of 1e-150 s at t = 0); its steps then never advance, and the run
                # took max_steps of them without a word
                return close(Status.FAILED, f"{settings.method}'s step size fell below the "
                             f"resolution of t at t = {t_old:.6g}: its steps no longer advance",
                             t_old, None)
            t_new, y_new = solver.t, solver.y
            if self.steps % EVERY == 0:
                if settings.progress is not None:
                    settings.progress(float(t_new), self.steps)
                if self.watch is not None:
                    self.watch.sample(t_new, jacf(t_new, y_new, params_at(t_new, y_new)),
                                      t_new - t_old)
            bound = settings.divergence_bound
            if not np.all(np.isfinite(y_new)) or np.max(np.abs(y_new[:n])) > bound:
                return close(Status.DIVERGED, f"max|x| exceeded {bound:g} (or "
                             f"became non-finite) near t = {t_new:.6g}", t_old, None)
            step_sol = None
            if settings.dense_output or t_eval is not None:
                step_sol = solver.dense_output()
                if settings.dense_output:
                    interpolants.append(step_sol)
            if has_events:
                g_new = self._guards(t_new, y_new, params_at(t_new, y_new), p)
                step_sol = step_sol or solver.dense_output()

                def g_at(t: float, sol: Any = step_sol) -> np.ndarray:
                    y_t = sol(t)
                    return self._guards(t, y_t, params_at(t, y_t), p)
                for t_root, k, before in _crossings(g_at, t_old, g_old, t_new, g_new,
                                                    self.direction, self.terminal, brentq):
                    y_root = step_sol(t_root)
                    if self.terminal[k]:
                        self.pre_event_sign = before
                        self._eval_at(ts, ys, step_sol, t_old, t_root, y_root)
                        if t_eval is None:
                            ts.append(t_root)
                            ys.append(y_root)
                        if settings.dense_output and interpolants:
                            interpolants[-1] = _Clipped(interpolants[-1], t_root)
                        return close(Status.EVENT, "", t_root, y_root, k)
                    self._events.append((t_root, self.names[k]))
                g_old = g_new
            self._eval_at(ts, ys, step_sol, t_old, t_new, y_new)
            if t_eval is None:
                ts.append(t_new)
                ys.append(y_new.copy())
            if solver.status == "finished":
                return close(Status.FINISHED, "reached t_end", t_new, y_new)
            if self.steps >= settings.max_steps:
                return close(Status.FAILED, f"more than {settings.max_steps} steps (t = "
                             f"{t_new:.6g})", t_new, y_new)

    def _compiled_segment(self, t_end: float, fired: int | None) -> tuple[Status, str, int]:
        """One segment through the model's compiled loop of the method (the one place it is called)."""
        model, settings, n = self.model, self.settings, self.model.n_states
        t0, p = self.t, self.p
        pn = np.ascontiguousarray(p, dtype=float) if model.backend == "numba" else p.copy()
        mask_index, mask_sign = -1, 0.0
        if fired is not None:
            mask_index, mask_sign = fired, self._fired_side(fired)
        slopes = p[len(model.param_names) + len(model.input_names):]
        tgrad = 0.0 if model.autonomous and not np.any(slopes) else 1e-7 * max(1.0, abs(t0))
        t, y, h = t0, np.ascontiguousarray(self.y, dtype=float), self.h_next
        ts, ys = [np.array([t0])], [y[None, :].copy()]
        atol = np.ascontiguousarray(np.broadcast_to(settings.atol, (n + 2,)), dtype=float)
        hmax = settings.max_step if math.isfinite(settings.max_step) else 1e300
        sensitive = self.phi is not None
        if self.phi is not None:       # the variational loop: Φ too (18-tuple)
            build = model if self.columns is None else self.columns.build
            variational = build.functions.variational[settings.method]
            gain = (np.zeros((0, self.phi.shape[1])) if self.columns is None
                    else self.columns.gain())
            phis = [self.phi[None].copy()]

            def loop(*args: Any) -> Any:
                out = variational(*args, np.ascontiguousarray(self.phi), gain)
                self.phi = out[15]
                phis.append(out[16][:out[5]].copy())
                self.phi_error = max(self.phi_error, out[17] / settings.rtol)
                return out[:15]
        else:
            loop = model.functions.loops[settings.method]
        while True:
            (code, t, y, t_store, y_store, n_store, nfev, njev, nsteps, k, ev_t, ev_k, n_ev,
             h, nlu) = loop(t, y, t_end, pn, settings.rtol, atol, h, hmax, self.direction,
                       self.terminal, mask_index, mask_sign, n, settings.divergence_bound,
                       settings.max_steps - self.steps, 4096, tgrad)
            self.steps += nsteps
            if settings.progress is not None:
                settings.progress(float(t), self.steps)
            self._counts["nfev"] += nfev
            self._counts["njev"] += njev
            self._counts["nlu"] += nlu
            ts.append(t_store[:n_store].copy())
            ys.append(y_store[:n_store].copy())
            for j in range(n_ev):
                self._events.append((float(ev_t[j]), self.names[int(ev_k[j])]))
            mask_index = -1
            if code != _LOOP_BUFFER_FULL:
                break
        self.h_next = h
        t_all, y_all = np.concatenate(ts), np.concatenate(ys)
        phi_all = np.concatenate(phis) if sensitive else None
        sampled = settings.t_eval is not None and settings.loop_stops is None
        sol = (step_interpolant(model, t_all, y_all.T, p, tgrad > 0.0)
               if settings.dense_output or sampled else None)   # from every step
        if settings.t_eval is not None:     # the points asked for in [t0, t] (t0: the first's)
            te = settings.t_eval
            asked = te[np.searchsorted(te, t0, "right" if self._segments else "left"):
                       np.searchsorted(te, t, "right")]
            if sampled and sol is not None:     # the steps' interpolant at them
                t_all, y_all = asked.copy(), sol(asked).T
            else:                               # the loop stopped on them (sensitivities)
                keep = np.isin(t_all, asked)
                t_all, y_all = t_all[keep], y_all[keep]
                phi_all = phi_all[keep] if phi_all is not None else None
        self._segments.append(Segment(t_all, y_all.T, p.copy(),
                                      sol if settings.dense_output else None, phi_all))
        self.t, self.y = float(t), y.copy()
        status = _LOOP_STATUS.get(int(code), Status.FAILED)
        self.stalled = int(code) == 2
        if status == Status.EVENT:
            self.pre_event_sign = -float(np.sign(self.direction[k])) if self.direction[k] else 0.0
            return status, "", int(k)
        message = {0: "reached t_end",
                   2: f"{settings.method}: step size too small (or W singular) at t = {t:.6g}",
                   3: f"max|x| exceeded {settings.divergence_bound:g} (or became non-finite) near "
                      f"t = {t:.6g}"}.get(int(code), f"more than {settings.max_steps} steps "
                                                     f"(t = {t:.6g})")
        return status, message, -1

    def _eval_at(self, ts: list[Any], ys: list[Any], step_sol: Any, t_old: float, t_new: float,
                 y_new: np.ndarray, include_start: bool = False) -> None:
        """Append the points of ``t_eval`` in (t_old, t_new] (or [t_old, ...]) to ts, ys."""
        te = self.settings.t_eval
        if te is None:
            return
        mask = ((te >= t_old) if include_start else (te > t_old)) & (te <= t_new)
        for t in te[mask]:
            ts.append(float(t))
            ys.append(y_new.copy() if (step_sol is None or t == t_new) else step_sol(t))


class _Clipped:
    """A step interpolant whose step ended early at a terminal event."""

    def __init__(self, inner: Any, t_end: float) -> None:
        self.inner, self.t_old, self.t = inner, inner.t_old, t_end

    def __call__(self, t: float) -> Any:
        return self.inner(t)


#: the guards are sampled at this many interior points of every step besides its ends, as the
#: compiled loops do (``PH_SAMPLES`` of rosenbrock_loop.c, ``_SAMPLES`` of rosenbrock_loop.py):
#: a guard that crosses zero and back within one step (a swing foot grazing the surface) changes
#: sign between two samples, where it has none between the step's ends
GUARD_SAMPLES = 3


def _crossings(g_at: Callable[[float], np.ndarray], t_a: float, g_a: np.ndarray, t_b: float,
               g_b: np.ndarray, direction: np.ndarray, terminal: np.ndarray,
               brentq: Callable[..., float]) -> list[tuple[float, int, float]]:
    """The guards' crossings in their directions within the step (t_a, t_b] of a scipy method,
    sorted by time, each with the guard's sign before it: ``g_at(t)`` the guards on the step's
    dense output, ``g_a``, ``g_b`` at its ends. The step is cut at :data:`GUARD_SAMPLES`
    interior points; in each piece, in order, a sign change in a guard's direction is located by
    ``brentq`` to 4 ε; the pieces after the first one with a terminal crossing are not searched
    (the compiled loops' rule)."""
    roots: list[tuple[float, int, float]] = []
    t_lo, g_lo = t_a, g_a
    for i in range(1, GUARD_SAMPLES + 2):
        t_hi = t_a + (t_b - t_a) * i / (GUARD_SAMPLES + 1) if i <= GUARD_SAMPLES else t_b
        g_hi = g_at(t_hi) if i <= GUARD_SAMPLES else g_b
        found = False
        for k in _active(g_lo, g_hi, direction):
            def gk(t: float, k: int = k) -> float:
                return float(g_at(t)[k])
            roots.append((brentq(gk, t_lo, t_hi, xtol=4 * _EPS, rtol=4 * _EPS), int(k),
                          float(np.sign(g_lo[k]))))
            found = found or bool(terminal[k])
        if found:
            break
        t_lo, g_lo = t_hi, g_hi
    return sorted(roots)


def _active(g: np.ndarray, g_new: np.ndarray, direction: np.ndarray) -> np.ndarray:
    up = (g <= 0) & (g_new >= 0)
    down = (g >= 0) & (g_new <= 0)
    either = up | down
    mask = (up & (direction > 0)) | (down & (direction < 0)) | (either & (direction == 0))
    return np.nonzero(mask)[0]
