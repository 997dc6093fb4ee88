"""Signal blocks, controllers, sensors and actuators: block diagrams beside the bond graph.

A signal block is a component without power ports: it reads signals — any expression of the
model (states ``mass.p``, port efforts and flows ``mass.p.f``, outputs ``walker.foot1.z``, inputs,
parameters, ``t``) — through its ``input`` argument(s), and gives its output ``<block>.y``, which
any other expression reads by that name (a source's effort, another block's input). Its states
(an integrator's, a filter's) join the model's states with the role ``"signal"``: out of the
Hamiltonian and of the energy ledger, inside the linearization. So a controller is a component
like any other: ``Model.replace("pid", TransferFunction(...))`` swaps it, a model file writes it
as a ``[components.NAME]`` table.

Continuous blocks: :class:`Gain`, :class:`Sum`, :class:`Integrator`, :class:`Derivative`
(filtered), :class:`PID` (with a derivative filter and back-calculation anti-windup),
:class:`TransferFunction`, :class:`StateSpace`, :class:`Saturation`, :class:`LookupTable`,
:class:`Sensor`.

Discrete-time blocks (sample period ``period``; sampled at t_k = t₀ + k·period in the simulator's
loop, their output held between samples; :mod:`porthamiltonian.simulation.sampling`):
:class:`ZeroOrderHold`, :class:`DiscretePID`, :class:`DiscreteStateSpace`.

The bond between the two worlds: an :class:`Actuator` is a modulated source (effort or flow) on a
power port, driven by a signal; it books the energy it supplies in its own quadrature state
``<actuator>.work`` (J; ``Trajectory.ledger()["actuators"]``), beside the model's E_in. A
sensor is any expression; :class:`Sensor` names one (with a gain and a unit).

Sign conventions: a block's output is y = (its law)(input); a PID acts on the error it is given
(``input = "r - plant.y"``). Units: SI; a block's output carries its input's unit times its gain.
"""
from __future__ import annotations

from typing import Any

import sympy as sp

from ..errors import ModelError
from ..modeling.component import Arg, Builder, Component, register
from ..modeling.elements import _check_domain, _exactly_one
from ..modeling.ports import Port


def _saturate(value: sp.Expr, lower: sp.Expr | None, upper: sp.Expr | None) -> sp.Expr:
    """``value`` clipped to [lower, upper] (None: no bound)."""
    if lower is not None:
        value = sp.Max(value, lower)
    if upper is not None:
        value = sp.Min(value, upper)
    return value


class _Block(Component):
    """A signal block: no ports; the subclass's ``build`` declares states and outputs."""

    def ports(self) -> list[Port]:
        return []


def _vector(b: Builder, value: Any, what: str, length: int | None = None) -> list[sp.Expr]:
    """A list argument of expressions, parsed (``what`` names it in errors)."""
    if not isinstance(value, list) or not value:
        raise ModelError(f"{what} must be a non-empty list of numbers or expressions, got "
                         f"{value!r}")
    if length is not None and len(value) != length:
        raise ModelError(f"{what} must have {length} entries, got {len(value)}")
    return [b.parse(v, what) for v in value]


def _matrix(b: Builder, value: Any, what: str, rows: int | None = None,
            cols: int | None = None) -> sp.Matrix:
    """A matrix argument (a list of rows), parsed; an empty list is a matrix with no rows."""
    if not isinstance(value, list) or any(not isinstance(r, list) for r in value):
        raise ModelError(f"{what} must be a list of rows (lists), got {value!r}")
    parsed = [[b.parse(v, what) for v in row] for row in value]
    width = len(parsed[0]) if parsed else (cols or 0)
    if any(len(row) != width for row in parsed):
        raise ModelError(f"{what}: every row must have {width} entries")
    matrix = sp.Matrix(len(parsed), width, [v for row in parsed for v in row]) if parsed \
        else sp.zeros(rows or 0, cols or 0)
    if (rows is not None and matrix.rows != rows) or (cols is not None and matrix.cols != cols):
        raise ModelError(f"{what} must be {rows} x {cols}, got {matrix.rows} x {matrix.cols}")
    return matrix


def _state_space(b: Builder, where: str, inputs: list, A: list, B: list, C: list,
                 D: list | None, initial: list | None) -> tuple:
    """(u, A, B, C, D, x0) of a state-space block's arguments, parsed and checked: A square
    (n x n), B n x m for the m inputs, C p x n, D p x m (zero when not given), x0 of length n."""
    u = sp.Matrix(_vector(b, inputs, f"{where} inputs"))
    Am = _matrix(b, A, f"{where} A")
    n, m = Am.rows, u.rows
    if Am.cols != n:
        raise ModelError(f"{where}: A must be square, got {Am.rows} x {Am.cols}")
    Bm = _matrix(b, B, f"{where} B", n, m)
    Cm = _matrix(b, C, f"{where} C", None, n)
    Dm = _matrix(b, D, f"{where} D", Cm.rows, m) if D is not None else sp.zeros(Cm.rows, m)
    x0 = _vector(b, initial, f"{where} initial", n) if initial is not None else [0] * n
    return u, Am, Bm, Cm, Dm, x0


_INPUT = Arg("the block's input: an expression of the model's signals")


@register
class Gain(_Block):
    """y = gain · input."""

    kind = "Gain"
    arguments = {"input": _INPUT, "gain": Arg("the gain k")}

    def build(self, b: Builder, input: sp.Expr, gain: sp.Expr) -> None:
        b.output("y", gain * input)


@register
class Sum(_Block):
    """y = Σ signs[i] · inputs[i] (signs default to +1)."""

    kind = "Sum"
    arguments = {"inputs": Arg("the summed signals (a list of expressions)", symbolic=False),
                 "signs": Arg("a sign (or weight) per input (default: all +1)", symbolic=False,
                              default=None)}
    vector_arguments = ("inputs", "signs")

    def build(self, b: Builder, inputs: list, signs: list | None) -> None:
        terms = _vector(b, inputs, f"Sum {b.name!r} inputs")
        weights = _vector(b, signs, f"Sum {b.name!r} signs", len(terms)) if signs is not None \
            else [sp.Integer(1)] * len(terms)
        b.output("y", sp.Add(*[w * t for w, t in zip(weights, terms)]))


@register
class Integrator(_Block):
    """ẋ = gain · input, y = x; state ``x`` (signal), initial value ``initial``."""

    kind = "Integrator"
    arguments = {"input": _INPUT, "gain": Arg("the gain k", default=1),
                 "initial": Arg("x(0)", default=0)}

    def build(self, b: Builder, input: sp.Expr, gain: sp.Expr, initial: sp.Expr) -> None:
        x = b.state("x", initial=initial, role="signal")
        b.equation(b.der(x), gain * input, "dx/dt = k u")
        b.output("y", x)


@register
class Derivative(_Block):
    """Filtered derivative y = k s/(τ s + 1) · input: ẋ = (input − x)/τ, y = k (input − x)/τ;
    state ``x`` (signal; ``initial``: x(0), set it to the input's initial value to avoid a kick)."""

    kind = "Derivative"
    arguments = {"input": _INPUT, "tau": Arg("filter time constant τ (s)", "s", rule=">"),
                 "gain": Arg("the gain k", default=1), "initial": Arg("x(0)", default=0)}

    def build(self, b: Builder, input: sp.Expr, tau: sp.Expr, gain: sp.Expr,
              initial: sp.Expr) -> None:
        x = b.state("x", initial=initial, role="signal")
        b.equation(b.der(x), (input - x) / tau, "dx/dt = (u - x)/tau")
        b.output("y", gain * (input - x) / tau)


@register
class PID(_Block):
    """PID controller on the error ``input`` (parallel form, filtered derivative, saturation and
    back-calculation anti-windup; Åström & Hägglund, *Advanced PID Control*, 2006, §3.5):

        v = kp e + I + kd (e − x_d)/tf,   y = sat(v) in [u_min, u_max],
        İ = ki e + (y − v)/tt,            ẋ_d = (e − x_d)/tf,

    so that, without saturation, y = (kp + ki/s + kd s/(tf s + 1)) e. States ``I`` (the integral
    term) and ``xd`` (the derivative filter), both signals. Outputs ``y`` (saturated), ``v``
    (unsaturated), ``P``, ``I``, ``D``. ``tt``, the tracking time constant (s), defaults to
    Ti = kp/ki (give it when kp = 0); without limits there is no tracking term.
    """

    kind = "PID"
    arguments = {
        "input": Arg("the error e (an expression, e.g. 'r - plant.q')"),
        "kp": Arg("proportional gain", default=0), "ki": Arg("integral gain (1/s)", default=0),
        "kd": Arg("derivative gain (s)", default=0),
        "tf": Arg("derivative filter time constant (s; needed when kd != 0)", "s", default=None,
                  rule=">"),
        "u_min": Arg("lower output limit (default: none)", default=None),
        "u_max": Arg("upper output limit (default: none)", default=None),
        "tt": Arg("anti-windup tracking time constant (s; default kp/ki)", "s", default=None,
                  rule=">"),
        "initial": Arg("I(0)", default=0),
    }

    def build(self, b: Builder, input: sp.Expr, kp: sp.Expr, ki: sp.Expr, kd: sp.Expr,
              tf: sp.Expr | None, u_min: sp.Expr | None, u_max: sp.Expr | None,
              tt: sp.Expr | None, initial: sp.Expr) -> None:
        e = input
        integral = b.state("I", initial=initial, role="signal")
        d_term = sp.Integer(0)
        if kd != 0:
            if tf is None:
                raise ModelError(f"PID {b.name!r}: a derivative gain kd needs the filter time "
                                 "constant tf (s), e.g. tf = kd/(10 kp)")
            xd = b.state("xd", role="signal")
            b.equation(b.der(xd), (e - xd) / tf, "derivative filter")
            d_term = kd * (e - xd) / tf
        v = kp * e + integral + d_term
        y = _saturate(v, u_min, u_max)
        rate = ki * e
        if u_min is not None or u_max is not None:
            if tt is None:
                if kp == 0 or ki == 0:
                    raise ModelError(f"PID {b.name!r}: with output limits give tt, the "
                                     "anti-windup tracking time constant (s)")
                tt = kp / ki
            rate = rate + (y - v) / tt
        b.equation(b.der(integral), rate, "dI/dt = ki e + (y - v)/tt")
        b.output("y", y)
        b.output("v", v)
        b.output("P", kp * e)
        b.output("D", d_term)


def _normalised(b: Builder, num: list, den: list, where: str
                ) -> tuple[list[sp.Expr], list[sp.Expr], sp.Expr]:
    """(c_1..c_n, a_1..a_n, d) of a proper transfer function num/den (descending powers), den
    made monic: (c_1 s^{n-1} + … + c_n)/(s^n + a_1 s^{n-1} + … + a_n) + d."""
    nums = _vector(b, num, f"{where} num")
    dens = _vector(b, den, f"{where} den")
    if len(nums) > len(dens):
        raise ModelError(f"{where}: the transfer function must be proper (num no longer than "
                         f"den), got num of degree {len(nums) - 1}, den {len(dens) - 1}")
    if dens[0] == 0:
        raise ModelError(f"{where}: the leading coefficient of den must not be zero")
    n = len(dens) - 1
    nums = [sp.Integer(0)] * (len(dens) - len(nums)) + nums
    a = [v / dens[0] for v in dens[1:]]
    bb = [v / dens[0] for v in nums]
    d = bb[0]
    c = [bb[i + 1] - d * a[i] for i in range(n)]
    return c, a, d


@register
class TransferFunction(_Block):
    """y = (num(s)/den(s)) · input, coefficients in descending powers of s (numbers or
    expressions of parameters), proper. Realised in controllable canonical form: states ``x1``
    … ``xn`` (signals), ẋ_k = x_{k+1}, ẋ_n = u − a_n x_1 − … − a_1 x_n, y = c_n x_1 + … + c_1 x_n
    + d u (zero initial state)."""

    kind = "TransferFunction"
    arguments = {"input": _INPUT,
                 "num": Arg("numerator coefficients, highest power first", symbolic=False),
                 "den": Arg("denominator coefficients, highest power first", symbolic=False)}
    vector_arguments = ("num", "den")

    def build(self, b: Builder, input: sp.Expr, num: list, den: list) -> None:
        c, a, d = _normalised(b, num, den, f"TransferFunction {b.name!r}")
        n = len(a)
        xs = [b.state(f"x{k + 1}", role="signal") for k in range(n)]
        for k in range(n - 1):
            b.equation(b.der(xs[k]), xs[k + 1], "controllable canonical form")
        if n:
            b.equation(b.der(xs[-1]), input - sp.Add(*[a[n - 1 - k] * xs[k] for k in range(n)]),
                       "controllable canonical form")
        b.output("y", sp.Add(*[c[n - 1 - k] * xs[k] for k in range(n)]) + d * input)


@register
class StateSpace(_Block):
    """ẋ = A x + B u, y = C x + D u with u = ``inputs`` (a list of expressions); states ``x1`` …
    (signals, ``initial``), outputs ``y1`` … (and ``y`` for a single output)."""

    kind = "StateSpace"
    arguments = {"inputs": Arg("the input signals u (a list of expressions)", symbolic=False),
                 "A": Arg("n x n matrix (list of rows)", symbolic=False),
                 "B": Arg("n x m matrix", symbolic=False),
                 "C": Arg("p x n matrix", symbolic=False),
                 "D": Arg("p x m matrix (default zero)", symbolic=False, default=None),
                 "initial": Arg("x(0) (default zero)", symbolic=False, default=None)}
    vector_arguments = ("inputs", "A", "B", "C", "D", "initial")

    def build(self, b: Builder, inputs: list, A: list, B: list, C: list, D: list | None,
              initial: list | None) -> None:
        u, Am, Bm, Cm, Dm, x0 = _state_space(b, f"StateSpace {b.name!r}", inputs, A, B, C, D,
                                             initial)
        n = Am.rows
        x = sp.Matrix([b.state(f"x{k + 1}", initial=x0[k], role="signal") for k in range(n)])
        rates = Am * x + Bm * u
        for k in range(n):
            b.equation(b.der(x[k]), rates[k], "dx/dt = A x + B u")
        y = Cm * x + Dm * u
        for k in range(y.rows):
            b.output(f"y{k + 1}", y[k])
        if y.rows == 1:
            b.output("y", y[0])


@register
class Saturation(_Block):
    """y = min(max(input, lower), upper) (either bound may be left out)."""

    kind = "Saturation"
    arguments = {"input": _INPUT, "lower": Arg("lower limit", default=None),
                 "upper": Arg("upper limit", default=None)}

    def build(self, b: Builder, input: sp.Expr, lower: sp.Expr | None,
              upper: sp.Expr | None) -> None:
        b.output("y", _saturate(input, lower, upper))


@register
class LookupTable(_Block):
    """1-D lookup table: y interpolated linearly in the breakpoints ``x`` (strictly increasing)
    and values ``y``, held constant beyond the first and last breakpoints."""

    kind = "LookupTable"
    arguments = {"input": _INPUT, "x": Arg("breakpoints (increasing numbers)", symbolic=False),
                 "y": Arg("values at the breakpoints", symbolic=False)}
    vector_arguments = ("x", "y")

    def build(self, b: Builder, input: sp.Expr, x: list, y: list) -> None:
        where = f"LookupTable {b.name!r}"
        xs = _vector(b, x, f"{where} x")
        ys = _vector(b, y, f"{where} y", len(xs))
        if not all(v.is_number for v in xs) or any(
                float(xs[k + 1]) <= float(xs[k]) for k in range(len(xs) - 1)):
            raise ModelError(f"{where}: the breakpoints x must be strictly increasing numbers")
        pieces = [(ys[0], input <= xs[0])]
        for k in range(len(xs) - 1):
            slope = (ys[k + 1] - ys[k]) / (xs[k + 1] - xs[k])
            pieces.append((ys[k] + slope * (input - xs[k]), input <= xs[k + 1]))
        pieces.append((ys[-1], True))
        b.output("y", sp.Piecewise(*pieces))


@register
class Sensor(_Block):
    """y = gain · input: a named measurement of any signal — an effort (``mass.p.e``), a flow
    (``mass.p.f``), a state, an output — with its SI ``unit``."""

    kind = "Sensor"
    arguments = {"input": Arg("the measured signal (any expression of the model)"),
                 "gain": Arg("the sensor gain", default=1),
                 "unit": Arg("the SI unit of y", symbolic=False, default="")}

    def build(self, b: Builder, input: sp.Expr, gain: sp.Expr, unit: str) -> None:
        b.output("y", gain * input, unit if isinstance(unit, str) else "")


@register
class Actuator(Component):
    """A modulated source driven by a signal: imposes ``effort`` (a force, a torque, a voltage)
    or ``flow`` on its power port ``p`` (out), and books the energy it supplies, ∫ e·f dt, in its
    quadrature state ``work`` (J) as well as in the model's E_in.

    Ports: ``p`` (power out; ``dim`` components). Outputs: ``power`` (W). State: ``work`` (J,
    role ``"quadrature"``).
    """

    kind = "Actuator"
    arguments = {"domain": Arg("energy domain of the port", symbolic=False,
                               default="translation", check=_check_domain),
                 "effort": Arg("the imposed effort (a signal expression)", default=None),
                 "flow": Arg("the imposed flow (a signal expression)", default=None)}

    def ports(self) -> list[Port]:
        return [Port("p", self.value("domain"), orientation="out")]

    def build(self, b: Builder, domain: str, effort: sp.Expr | None,
              flow: sp.Expr | None) -> None:
        chosen, command = _exactly_one("Actuator", {"effort": effort, "flow": flow})
        port = b.port("p")
        if chosen == "effort":
            b.equation(port.e, b.source(command, port.f), "e = command")
        else:
            b.equation(port.f, b.source(command, port.e), "f = command")
        work = b.state("work", "J", role="quadrature")
        b.equation(b.der(work), port.power, "d(work)/dt = e f")
        b.supply(port.power)
        b.output("power", port.power, "W")


# --- discrete-time blocks ---------------------------------------------------------------------
_PERIOD = Arg("sample period T (s)", "s", rule=">")


@register
class ZeroOrderHold(_Block):
    """Sample and hold: at each sampling instant y takes the input's value and holds it.
    State ``y`` (discrete, ``initial`` before the first sample)."""

    kind = "ZeroOrderHold"
    arguments = {"input": _INPUT, "period": _PERIOD, "initial": Arg("y before the first sample",
                                                                    default=0)}

    def build(self, b: Builder, input: sp.Expr, period: sp.Expr, initial: sp.Expr) -> None:
        y = b.state("y", initial=initial, role="discrete")
        b.sample(period, [(y, input)])


@register
class DiscretePID(_Block):
    """Discrete PID on the error ``input``, sampled every ``period`` T: at t_k, with e_k the
    error there,

        I_k = I_{k−1} + ki T e_k,   D_k = kd (e_k − e_{k−1}) / T,
        v_k = kp e_k + I_k + D_k,   y_k = sat(v_k),   and with limits I_k += y_k − v_k

    (the integrator clamped so that it tracks the saturated output: anti-windup), y held until
    t_{k+1}. States (discrete): ``I``, ``e_prev`` (``initial_error``), ``y`` (the held output,
    ``initial`` before the first sample)."""

    kind = "DiscretePID"
    arguments = {"input": Arg("the error e (an expression)"), "period": _PERIOD,
                 "kp": Arg("proportional gain", default=0),
                 "ki": Arg("integral gain (1/s)", default=0),
                 "kd": Arg("derivative gain (s)", default=0),
                 "u_min": Arg("lower output limit", default=None),
                 "u_max": Arg("upper output limit", default=None),
                 "initial": Arg("y before the first sample", default=0),
                 "initial_error": Arg("e before the first sample", default=0)}

    def build(self, b: Builder, input: sp.Expr, period: sp.Expr, kp: sp.Expr, ki: sp.Expr,
              kd: sp.Expr, u_min: sp.Expr | None, u_max: sp.Expr | None, initial: sp.Expr,
              initial_error: sp.Expr) -> None:
        integral = b.state("I", role="discrete")
        e_prev = b.state("e_prev", initial=initial_error, role="discrete")
        y = b.state("y", initial=initial, role="discrete")
        e = input
        i_new = integral + ki * period * e
        v = kp * e + i_new + kd * (e - e_prev) / period
        y_new = _saturate(v, u_min, u_max)
        if u_min is not None or u_max is not None:
            i_new = i_new + (y_new - v)
        b.sample(period, [(integral, i_new), (e_prev, e), (y, y_new)])


@register
class DiscreteStateSpace(_Block):
    """x_{k+1} = A x_k + B u_k, y_k = C x_k + D u_k, sampled every ``period``: at t_k the output
    y_k (from the state before the instant and the inputs there) is computed and held, and the
    state advances. States (discrete): ``x1`` …, the held outputs ``y1`` … (and output ``y`` for
    one output)."""

    kind = "DiscreteStateSpace"
    arguments = {**StateSpace.arguments, "period": _PERIOD}
    vector_arguments = StateSpace.vector_arguments

    def build(self, b: Builder, inputs: list, A: list, B: list, C: list, D: list | None,
              initial: list | None, period: sp.Expr) -> None:
        u, Am, Bm, Cm, Dm, x0 = _state_space(b, f"DiscreteStateSpace {b.name!r}", inputs, A, B,
                                             C, D, initial)
        n = Am.rows
        x = sp.Matrix([b.state(f"x{k + 1}", initial=x0[k], role="discrete") for k in range(n)])
        y = [b.state(f"y{k + 1}", role="discrete") for k in range(Cm.rows)]
        x_next, y_now = Am * x + Bm * u, Cm * x + Dm * u
        b.sample(period, [*zip(x, x_next), *zip(y, y_now)])
        if len(y) == 1:
            b.output("y", y[0])


__all__ = ["PID", "Actuator", "Derivative", "DiscretePID", "DiscreteStateSpace", "Gain",
           "Integrator", "LookupTable", "Saturation", "Sensor", "StateSpace", "Sum",
           "TransferFunction", "ZeroOrderHold"]
