"""Components: declared ports, states, parameters and symbolic constitutive laws.

A component is a small class: its docstring gives the physics, ``arguments`` its parameters (with
units), ``ports()`` its power ports, and ``build()`` its laws, written with a :class:`Builder`.
Example, a cubic spring in a few lines::

    @register
    class CubicSpring(Component):
        '''Hardening spring F = k q + c q^3 on a translational port (power in).'''
        kind = "CubicSpring"
        arguments = {"k": Arg("linear stiffness", "N/m"), "c": Arg("cubic stiffness", "N/m^3")}

        def ports(self):
            return [Port("p", "translation")]

        def build(self, b, k, c):
            q, p = b.state("q", unit="m"), b.port("p")
            b.storage(q, energy=k * q**2 / 2 + c * q**4 / 4, port=p, causality="C")

The energy roles are explicit: :meth:`Builder.storage` adds to the Hamiltonian, :meth:`Builder.dissipate`
to the dissipated power, :meth:`Builder.supply` to the supplied power. The compiler books the power
that a *modulated* storage receives (its energy depending on time or on other components' states)
as supplied power by itself.
"""
from __future__ import annotations

import copy
import math
from collections.abc import Callable, Collection, Iterator, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, ClassVar

import sympy as sp

from ..errors import (
    DuplicateNameError,
    ModelError,
    ParameterValueError,
    UnknownComponentError,
    UnknownPortError,
)
from .calls import KERNELS, WORK, KernelCall
from .calls import outputs as call_outputs
from .constraints import RULES, Constraint, violation
from .differentiation import derivative
from .expressions import TIME, as_expr, check_name, parse, to_text
from .ports import Port, domain

REQUIRED = object()


@dataclass(frozen=True)
class Arg:
    """A component argument.

    ``symbolic`` arguments are expressions (numbers, parameter names, ``t``, other states) parsed
    with :func:`porthamiltonian.modeling.expressions.parse`; the others are plain values (names, options).
    ``local`` lists the names a law may use beside the model's (e.g. ``("q",)`` for an energy in q).
    ``rule`` is a physical constraint ``value rule 0`` (``">"``, ``">="``, ``"!="``; see
    :mod:`porthamiltonian.modeling.constraints`), checked for numbers when the model compiles and for
    parameter values whenever they are bound. ``check`` validates a given (non-None) plain value
    when the component is made, raising a ModelError (e.g. a domain name).
    """

    doc: str
    unit: str = ""
    default: Any = REQUIRED
    symbolic: bool = True
    local: tuple[str, ...] = ()
    rule: str | None = None
    check: Callable[[Any], None] | None = None

    def __post_init__(self) -> None:
        if self.rule is not None and self.rule not in RULES:
            raise ModelError(f"Arg rule must be one of {', '.join(RULES)}, got {self.rule!r}")


@dataclass
class PortVars:
    """The effort and flow symbols of a port: scalars for dimension 1, else sympy column matrices."""

    port: Port
    e: Any
    f: Any

    @property
    def power(self) -> sp.Expr:
        """``e · f``, positive in the port's orientation."""
        if self.port.dim == 1:
            return self.e * self.f
        return (self.e.T * self.f)[0, 0]


#: the roles of a state (:meth:`Builder.state`)
STATE_ROLES = ("storage", "signal", "quadrature", "discrete")


@dataclass
class StateDecl:
    """A declared state: its symbol, the symbol of its time derivative, unit, initial value and
    role (one of :data:`STATE_ROLES`)."""

    symbol: sp.Symbol
    derivative: sp.Symbol
    unit: str
    initial: sp.Expr
    role: str = "storage"


@dataclass
class Built:
    """What a component's ``build`` declared; consumed by the compiler."""

    name: str
    ports: dict[str, PortVars] = field(default_factory=dict)
    states: list[StateDecl] = field(default_factory=list)
    equations: list[tuple[sp.Expr, str]] = field(default_factory=list)
    energy: sp.Expr = sp.S.Zero
    dissipation: sp.Expr = sp.S.Zero
    supply: sp.Expr = sp.S.Zero
    outputs: dict[str, sp.Expr] = field(default_factory=dict)
    output_units: dict[str, str] = field(default_factory=dict)
    storage_ports: list[str] = field(default_factory=list)
    #: the energy's dependence on other components' states is paid through this component's own
    #: power ports (e.g. a contact whose penetration is a body point's height): no modulation
    energy_via_ports: bool = False
    blocks: list[tuple[list[sp.Symbol], sp.Matrix, sp.Matrix]] = field(default_factory=list)
    matrices: dict[str, sp.Matrix] = field(default_factory=dict)
    intermediates: list[tuple[sp.Symbol, sp.Expr]] = field(default_factory=list)
    #: constraints on parameter values, checked when they are bound (see :meth:`Builder.require`)
    constraints: list[Constraint] = field(default_factory=list)
    #: kernel calls by qualified name (see :meth:`Builder.call`)
    calls: dict[str, KernelCall] = field(default_factory=dict)
    #: a discrete-time block's sampling (:meth:`Builder.sample`): (period, [(state, value)])
    samples: list[tuple[sp.Expr, list[tuple[sp.Symbol, sp.Expr]]]] = field(default_factory=list)


@dataclass
class Dissipator:
    """A dissipative law of a component, as the port-Hamiltonian form's cut build records it
    (:meth:`Builder.resistive`): the law's effort-like output ``z`` and flow-like input ``w``
    (expressions over the component's port variables, states, parameters; scalars as 1-vectors),
    the symbols ``zeta`` that stand for z in the cut build, and ``coefficient`` C when the law is
    linear, z = C(x) w (a linear dissipator: it goes into R = G C Gᵀ), else None."""

    component: str
    name: str
    z: list[sp.Expr]
    w: list[sp.Expr]
    zeta: list[sp.Symbol]
    coefficient: sp.Matrix | None


@dataclass
class Source:
    """A port imposed from outside (an effort or flow source, an actuator, an open port) as the
    cut build records it (:meth:`Builder.source`): its imposed ``value`` (the input u), the
    ``conjugate`` port variable (supplied power u·conjugate) and the symbol ``upsilon`` standing
    for u in the cut build."""

    component: str
    name: str
    value: sp.Expr
    conjugate: sp.Expr
    upsilon: sp.Symbol


@dataclass
class PHCut:
    """The records of the port-Hamiltonian form's cut build (:mod:`porthamiltonian.compiler.
    phform`): there every constitutive law is replaced by a symbol — a storage's co-energy
    ∂H/∂x by η(x), a dissipator's output by ζ, a source's value by υ — so that the solved
    junction structure (junctions, transformers, gyrators, a multibody's kinematics) is linear
    in them with the matrix M₀(x) of [ẋ; w; y] = M₀ [∇H; z; u]."""

    coenergies: dict[sp.Symbol, sp.Symbol] = field(default_factory=dict)
    dissipators: list[Dissipator] = field(default_factory=list)
    sources: list[Source] = field(default_factory=list)

    def eta(self, state: sp.Symbol) -> sp.Symbol:
        """η(x): the symbol of ∂H/∂x for the state ``x``."""
        if state not in self.coenergies:
            self.coenergies[state] = sp.Symbol(f"dH/d({state})", real=True)
        return self.coenergies[state]

    @property
    def symbols(self) -> set[sp.Symbol]:
        """Every symbol of the cut (η, ζ, υ)."""
        return ({*self.coenergies.values()} | {z for d in self.dissipators for z in d.zeta}
                | {s.upsilon for s in self.sources})


class Builder:
    """Collects the declarations of one component during compilation.

    Symbols are named ``component.state`` and ``component.port.e`` / ``.f`` (``.e0``, ``.e1``... for
    vector ports), so compiled equations read by name.
    """

    def __init__(self, name: str, ports: list[Port], names: Mapping[str, sp.Expr],
                 dotted: Callable[[str], sp.Expr | None] | None = None,
                 orientation: Mapping[str, str] | None = None,
                 inputs: Collection[sp.Expr] = ()):
        self.name = name
        self._names = names
        self._dotted = dotted
        self._orientation = dict(orientation or {})
        #: the symbols of the model's inputs among ``names`` (signals, not parameters)
        self._inputs = frozenset(inputs)
        #: None, or the records of the port-Hamiltonian form's cut build (:class:`PHCut`)
        self.ph: PHCut | None = None
        self.built = Built(name)
        self._claimed: dict[str, str] = {}
        for port in ports:
            variables = self._port_vars(port)
            self.built.ports[port.name] = variables
            for symbol in (*sp.Matrix([variables.e]), *sp.Matrix([variables.f])):
                self._claimed[symbol.name] = f"port {port.name!r} variable"

    def _port_vars(self, port: Port) -> PortVars:
        base = f"{self.name}.{port.name}"
        if port.dim == 1:
            return PortVars(port, sp.Symbol(f"{base}.e", real=True), sp.Symbol(f"{base}.f", real=True))
        e = sp.Matrix([sp.Symbol(f"{base}.e{i}", real=True) for i in range(port.dim)])
        f = sp.Matrix([sp.Symbol(f"{base}.f{i}", real=True) for i in range(port.dim)])
        return PortVars(port, e, f)

    # --- declarations -------------------------------------------------------------------------
    def port(self, name: str) -> PortVars:
        """The effort/flow symbols of the declared port ``name``."""
        try:
            return self.built.ports[name]
        except KeyError:
            raise UnknownPortError(
                f"component {self.name!r} has no port {name!r}; ports: {', '.join(self.built.ports)}"
            ) from None

    def sign(self, name: str) -> int:
        """+1 if power on port ``name`` is positive into this component, -1 if out of it.

        For ports with a fixed orientation this is the declared one; for free ports it is set by
        the bond (head: in, tail: out); an unconnected optional port counts as in.
        """
        port = self.port(name).port
        orientation = port.orientation or self._orientation.get(name, "in")
        return 1 if orientation == "in" else -1

    def parametric(self, expr: Any) -> bool:
        """True when ``expr`` depends on the model's parameters only (no time, state, model
        input or signal of another component)."""
        return bool(as_expr(expr).free_symbols <= set(self._names.values()) - self._inputs)

    def connected(self, name: str) -> bool:
        """True when a bond ends on port ``name`` (an unconnected optional port has zero
        effort)."""
        self.port(name)
        return name in self._orientation

    def intermediate(self, name: str, expr: sp.Expr) -> sp.Expr:
        """A named intermediate ``component.name = expr`` (expr in states, parameters, time,
        earlier intermediates, the unknowns of implicit blocks and port variables). The generated
        code computes it once and differentiates through it by the chain rule, so expressions
        stay local (e.g. mass-matrix entries and their derivatives, a friction law of its port's
        slip). An intermediate that reads port variables gets them replaced by their solutions
        once the model's structure is solved; a port variable solved from such an intermediate
        of itself is an algebraic loop, and a stored energy may not read one. Constants are
        returned as they are."""
        expr = as_expr(expr)
        if expr.is_number:
            return expr
        symbol = sp.Symbol(self._claim(name, "intermediate"), real=True)
        self.built.intermediates.append((symbol, expr))
        return symbol

    def implicit(self, name: str, A: sp.Matrix, rhs: sp.Matrix) -> list[sp.Symbol]:
        """Declare intermediates ``v`` defined by the linear system ``A v = rhs``.

        ``A`` and ``rhs`` may depend on states, parameters and time only. The system is solved
        numerically in the generated code (never inverted symbolically) and its derivative enters
        the Jacobian by implicit differentiation. Returns the symbols ``component.name0..``.
        """
        A, rhs = sp.Matrix(A), sp.Matrix(rhs)
        if A.shape != (rhs.shape[0], rhs.shape[0]) or rhs.shape[1] != 1:
            raise ModelError(f"component {self.name!r}: implicit block {name!r} needs a square A "
                             f"and a column rhs, got {A.shape} and {rhs.shape}")
        symbols = [sp.Symbol(self._claim(f"{name}{i}", "implicit unknown"), real=True)
                   for i in range(rhs.shape[0])]
        self.built.blocks.append((symbols, A, rhs))
        return symbols

    def call(self, name: str, kernel: str, entry: str, table: list[int], constants: list[Any],
             inputs: list[Any], n_outputs: int, after: str = "") -> list[sp.Symbol]:
        """Outputs computed by a compiled kernel (:mod:`porthamiltonian.modeling.calls`): the
        routine ``entry`` of ``kernel`` with the integer ``table``, the ``constants``
        (expressions in the parameters only) and the ``inputs`` (expressions in states, port
        variables, intermediates). Returns the intermediates ``component.name.<k>`` of its
        ``n_outputs`` outputs; the compiler differentiates through the call by the kernel's own
        tangents (entries that have none may not reach the state equations). ``after``: the
        name of an earlier call of this component whose work this one may reuse
        (:class:`~porthamiltonian.modeling.calls.KernelCall`)."""
        if kernel not in KERNELS or entry not in KERNELS[kernel][0] | KERNELS[kernel][1]:
            raise ModelError(f"component {self.name!r}: unknown kernel entry {kernel}.{entry}")
        qualified = self._qualified(name)
        if qualified in self.built.calls:
            raise ModelError(f"component {self.name!r} declares call {name!r} twice")
        if after:
            after = self._qualified(after)
            first = self.built.calls.get(after)
            keeps, reuses = WORK.get(kernel, (set(), set()))
            if (first is None or first.kernel != kernel or first.entry not in keeps
                    or entry not in reuses):
                raise ModelError(f"component {self.name!r}: call {name!r} cannot reuse the work "
                                 f"of {after!r}")
        constants = [as_expr(c) for c in constants]
        for value in constants:
            stray = value.free_symbols - (set(self._names.values()) - self._inputs)
            if stray:
                raise ModelError(f"component {self.name!r}: call {name!r} constants may depend on "
                                 f"parameters only, not on {', '.join(sorted(map(str, stray)))}")
        self.built.calls[qualified] = KernelCall(
            qualified, kernel, entry, tuple(int(v) for v in table), tuple(constants), len(inputs),
            n_outputs, entry in KERNELS[kernel][0], after)
        return [self.intermediate(f"{name}.{k}", expr)
                for k, expr in enumerate(call_outputs(qualified, list(inputs), n_outputs))]

    def matrix(self, name: str, value: sp.Matrix) -> None:
        """A named matrix ``component.name`` available numerically (e.g. a mass matrix)."""
        self.built.matrices[self._claim(name, "matrix")] = sp.Matrix(value)

    def state(self, name: str, unit: str = "", initial: Any = 0, role: str = "storage"
              ) -> sp.Symbol:
        """Declare a state ``component.name`` with an initial value (expression in parameters).

        ``role``: ``"storage"`` (an energy storage's state, the default), ``"signal"`` (a signal
        block's continuous state: a controller's integrator, a filter; it joins the model's
        states but not its Hamiltonian), ``"quadrature"`` (an integral read by no rate, e.g. an
        actuator's work; left out of linearizations) or ``"discrete"`` (a value held between the
        sampling instants of a discrete-time block: zero rate, updated by
        :meth:`sample`)."""
        if role not in STATE_ROLES:
            raise ModelError(f"component {self.name!r}: state role must be one of "
                             f"{', '.join(STATE_ROLES)}, got {role!r}")
        symbol = sp.Symbol(self._qualified(name), real=True)
        if any(s.symbol == symbol for s in self.built.states):
            raise ModelError(f"component {self.name!r} declares state {name!r} twice")
        self._claim(name, "state")
        init = initial if isinstance(initial, sp.Basic) else self.parse(
            initial, f"initial value of state {name!r}")
        self.built.states.append(StateDecl(symbol, sp.Symbol(f"d({self.name}.{name})/dt", real=True),
                                           unit, init, role))
        return symbol

    def sample(self, period: Any, updates: list[tuple[sp.Symbol, Any]]) -> None:
        """Make this component a discrete-time block sampled every ``period`` seconds (an
        expression in parameters, output as ``<component>.T``): at each sampling instant
        t_k = t₀ + k·period the states of ``updates`` (declared with ``role="discrete"``) take
        their new values (expressions in the model's variables just before t_k: states, port
        variables, outputs, inputs) and hold them until the next one (their rate is zero). See
        :mod:`porthamiltonian.simulation.sampling`."""
        if self.built.samples:
            raise ModelError(f"component {self.name!r} declares its sampling twice")
        period = as_expr(period)
        if period.free_symbols - (set(self._names.values()) - self._inputs):
            raise ModelError(f"component {self.name!r}: the sample period must depend on "
                             f"parameters only, got {period}")
        roles = {s.symbol: s.role for s in self.built.states}
        for state, _ in updates:
            if roles.get(state) != "discrete":
                raise ModelError(f"component {self.name!r}: {state} is not one of its discrete "
                                 "states (declare it with role='discrete')")
        self.built.samples.append((period, [(state, as_expr(v)) for state, v in updates]))
        self.output("T", period, "s")
        self.require(period, ">", "sample period")
        for state, _ in updates:
            self.equation(self.der(state), 0, "held between samples")

    def der(self, state: sp.Symbol) -> sp.Symbol:
        """The time-derivative symbol of one of this component's states."""
        for s in self.built.states:
            if s.symbol == state:
                return s.derivative
        raise ModelError(f"component {self.name!r}: {state} is not one of its states")

    def equation(self, lhs: Any, rhs: Any = 0, doc: str = "") -> None:
        """Add the law ``lhs = rhs`` (element-wise for matrices)."""
        lhs, rhs = as_expr(lhs), as_expr(rhs)
        if isinstance(lhs, sp.MatrixBase):
            for a, b in zip(lhs, rhs if isinstance(rhs, sp.MatrixBase) else [rhs] * len(lhs)):
                self.built.equations.append((as_expr(a - b), doc))
        else:
            self.built.equations.append((lhs - rhs, doc))

    def storage(self, state: sp.Symbol, energy: sp.Expr, port: PortVars, causality: str) -> None:
        """Make ``state`` an energy storage on ``port``, adding ``energy`` to the Hamiltonian.

        ``causality="C"`` (q-type): dq/dt = f, e = ∂H/∂q. ``causality="I"`` (p-type):
        dp/dt = e, f = ∂H/∂p. ``energy`` is this component's whole stored energy; call
        :meth:`storage` once per state with the same total, or use :meth:`energy` and
        :meth:`storage_law` for multiport storages.
        """
        self.energy(energy)
        self.storage_law(state, energy, port, causality)

    def energy(self, energy: sp.Expr, via_ports: bool = False) -> None:
        """Add ``energy`` (J) to this component's stored energy (its part of the Hamiltonian).

        By default a dependence of the energy on time or on other components' states is a
        *modulation* and the compiler books its power as supplied (a stiffness K(t), K(φ)).
        ``via_ports=True`` says that the dependence on other states is physical and paid through
        this component's power ports (e.g. a contact spring whose penetration is read from a
        body point's position while its force acts back on that point): then only an explicit
        time dependence is booked as modulation.
        """
        self.built.energy = self.built.energy + energy
        self.built.energy_via_ports = self.built.energy_via_ports or via_ports

    def storage_law(self, state: sp.Symbol, energy: sp.Expr, port: PortVars, causality: str) -> None:
        """The integral-causality law of one storage state (see :meth:`storage`)."""
        if causality not in ("C", "I"):
            raise ModelError(f"component {self.name!r}: storage causality must be 'C' or 'I'")
        gradient = derivative(energy, state)
        for decl in self.built.states:          # a state without a unit gets its port's
            if decl.symbol == state and not decl.unit:
                dom = domain(port.port.domain)
                decl.unit = dom.displacement_unit if causality == "C" else dom.momentum_unit
        if causality == "C":
            self.equation(self.der(state), port.f, "dq/dt = f")
            self.equation(port.e, self.coenergy(state, gradient), "e = dH/dq")
        else:
            self.equation(self.der(state), port.e, "dp/dt = e")
            self.equation(port.f, self.coenergy(state, gradient), "f = dH/dp")
        self.built.storage_ports.append(port.port.name)

    # --- the explicit port-Hamiltonian form (porthamiltonian/compiler/phform.py) ---------------
    # In an ordinary build these return their expression. In the cut build of the pH form
    # (``self.ph`` set) they return symbols standing for the laws, so that the solved junction
    # structure is linear in them; a component whose laws pass through these declares its
    # port-Hamiltonian structure with no further code.
    def coenergy(self, state: sp.Symbol, gradient: Any) -> Any:
        """A storage law's output, the co-energy ∂H/∂``state`` (``gradient``): as given, or η in
        the cut build."""
        return gradient if self.ph is None else self.ph.eta(state)

    def stored_via_ports(self, effort: Any) -> Any:
        """An elastic effort whose energy is stored as a function of other components' states
        and paid through this component's ports (``energy(..., via_ports=True)``, e.g. a contact
        spring on a body point): as given; zero in the cut build, where the owner of those
        states carries it as part of their ∇H."""
        return effort if self.ph is None else 0 * effort

    def resistive(self, effort: Any, flow: Any, name: str = "R") -> Any:
        """A dissipative law's output ``effort`` (scalar or vector: z) of its input ``flow``
        (w), with z·w >= 0 its dissipated power: as given, or the symbols ζ in the cut build
        (which records the law and, when it is linear, z = C w with C free of port variables,
        its coefficient C)."""
        if self.ph is None:
            return effort
        z = _entries(effort)
        w = _entries(flow)
        ports = {v for pv in self.built.ports.values() for v in _entries(pv.e) + _entries(pv.f)}
        linear = (all(isinstance(wj, sp.Symbol) for wj in w)   # (a law of a port's flow)
                  and all(zi.is_polynomial(*w) for zi in z))
        if linear:
            C = sp.Matrix(len(z), len(w), lambda i, j: derivative(z[i], w[j]))
            linear = (not (C.free_symbols & (ports | set(w)))
                      and all(sp.expand(zi - sum(C[i, j] * w[j] for j in range(len(w)))) == 0
                              for i, zi in enumerate(z)))
        index = len(self.ph.dissipators)
        zeta = [sp.Symbol(f"z{index}[{self.name}.{name}{'' if len(z) == 1 else i}]", real=True)
                for i in range(len(z))]
        self.ph.dissipators.append(Dissipator(self.name, name, z, w, zeta,
                                              C if linear else None))
        return zeta[0] if isinstance(effort, sp.Basic) and not isinstance(
            effort, sp.MatrixBase) else sp.Matrix(zeta)

    def source(self, value: Any, conjugate: Any, name: str = "p") -> Any:
        """An imposed port variable ``value`` (a source's effort or flow: the input u) whose
        ``conjugate`` port variable makes the supplied power u·conjugate: as given, or the
        symbol υ in the cut build."""
        if self.ph is None:
            return value
        upsilon = sp.Symbol(f"u{len(self.ph.sources)}[{self.name}.{name}]", real=True)
        self.ph.sources.append(Source(self.name, name, as_expr(value), as_expr(conjugate),
                                      upsilon))
        return upsilon

    def dissipate(self, power: sp.Expr) -> None:
        """Add ``power`` (W, >= 0) to the dissipated power."""
        self.built.dissipation = self.built.dissipation + power

    def supply(self, power: sp.Expr) -> None:
        """Add ``power`` (W) to the power supplied to the model from outside."""
        self.built.supply = self.built.supply + power

    def output(self, name: str, expr: sp.Expr, unit: str = "") -> None:
        """A named output ``component.name`` (any expression in the model's variables), in SI
        ``unit`` if given. Other components may read it as a signal by its dotted name (e.g.
        ``walker.foot1.z``)."""
        expr = as_expr(expr)
        same = sp.Symbol(self._qualified(name), real=True)
        if expr == same and self._claimed.get(same.name) == "intermediate":
            self.built.outputs[same.name] = expr      # an intermediate shown as an output
        else:
            self.built.outputs[self._claim(name, "output")] = expr
        if unit:
            self.built.output_units[self._qualified(name)] = unit

    def parse(self, text: Any, what: str, local: Mapping[str, sp.Expr] | None = None) -> sp.Expr:
        """Parse an expression of this component (model names plus ``local`` names). An
        expression in parameters that is undefined for some values (``sqrt(k)``, ``1/k``,
        ``log(x)``) is required to be a finite real number whenever parameters are bound."""
        names = {**self._names, **(local or {})}
        expr = parse(text, names, f"component {self.name!r} {what}", self._dotted)
        if _may_be_undefined(expr):
            self.require(expr, "real", what)
        return expr

    def require(self, value: sp.Expr, rule: str, what: str, bound: Any = 0,
                bound_name: str = "") -> None:
        """Declare the physical constraint ``value rule bound`` on a parsed argument ``what``
        (e.g. ``b.require(mass, ">", "body 'leg' mass")``; ``rule`` one of
        :data:`porthamiltonian.modeling.constraints.RULES`). Checked now when both sides are numbers
        (ParameterValueError), recorded for the run-time parameter check when they depend on
        parameters only, skipped when they depend on states or time."""
        value, bound = as_expr(value), as_expr(bound)
        params = set(self._names.values()) - self._inputs
        if not (value.free_symbols | bound.free_symbols) <= params:
            return
        constraint = Constraint(self.name, what, to_text(value), rule, to_text(bound), bound_name)
        if value.is_number and bound.is_number:
            message = violation(constraint, float(value), float(bound), symbolic=False)
            if message:
                raise ParameterValueError(message)
        else:
            self.built.constraints.append(constraint)

    def _claim(self, name: str, kind: str) -> str:
        """``component.name`` (:meth:`_qualified`) for a new ``kind`` of name (state, output,
        intermediate, matrix, implicit unknown): one namespace per component, so a name
        declared twice (a body point named like a joint's state group, ``q`` beside a joint
        ``x``: the output ``q.x`` and the state ``q.x``) is refused instead of one shadowing the
        other."""
        qualified = self._qualified(name)
        other = self._claimed.get(qualified)
        if other is not None:
            raise DuplicateNameError(
                f"component {self.name!r}: its {kind} {name!r} has the name of its {other} "
                f"{name!r}; two names of the component collide (e.g. a body point or frame named "
                "like a joint's state group 'q' or 'p'): rename one of them")
        self._claimed[qualified] = kind
        return qualified

    def _qualified(self, name: str) -> str:
        """``component.name`` for a state, output, intermediate or matrix, each part of ``name``
        checked to be a name (these reach generated code and its layout)."""
        check_name(name, f"component {self.name!r}: state, output or matrix name", dotted=True)
        return f"{self.name}.{name}"


def _entries(value: Any) -> list[sp.Expr]:
    """A scalar or a vector (matrix, list) as a list of expressions."""
    if isinstance(value, sp.MatrixBase):
        return list(value)
    if isinstance(value, (list, tuple)):
        return [as_expr(v) for v in value]
    return [as_expr(value)]


def _may_be_undefined(expr: Any) -> bool:
    """True when the expression ``expr`` (of finite parameters) may be undefined or infinite:
    it calls a function or takes a power other than a whole number >= 0 (a root, a division)."""
    if not isinstance(expr, sp.Expr) or expr.is_number:
        return False
    return any(isinstance(node, sp.Function) or (
        isinstance(node, sp.Pow) and not (node.exp.is_Integer and node.exp >= 0))
        for node in sp.preorder_traversal(expr))


#: an expression among a component's arguments, as :meth:`Component.expression_fields` yields
#: it: ``(key path, value, what, local names)``
ExpressionField = tuple[tuple[str | int, ...], Any, str, tuple[str, ...]]


class _Frozen(type):
    """Metaclass of :class:`Component`: an instance is frozen once its whole ``__init__`` chain
    has run (subclasses may set private attributes while they are constructed)."""

    def __call__(cls, *args: Any, **kwargs: Any) -> Any:
        instance = super().__call__(*args, **kwargs)
        object.__setattr__(instance, "_frozen", True)
        return instance


class Component(metaclass=_Frozen):
    """Base class of all components. Subclasses set ``kind``, ``arguments`` and implement
    :meth:`ports` and :meth:`build`.

    A component is an immutable value: it holds its arguments as given (text or numbers, copied
    at construction, so that a model saves back to the same file) in the read-only mapping
    :attr:`args`, and nothing changes it afterwards: connecting it records the bond (and a
    junction's new port) on the model's graph, so one instance may be added to several models.
    """

    kind: ClassVar[str] = ""
    arguments: ClassVar[dict[str, Arg]] = {}
    #: constraints between two arguments, ``(argument, rule, other argument)``, e.g.
    #: ``("mu_c", "<=", "mu_st")``; checked like :attr:`Arg.rule`
    relations: ClassVar[tuple[tuple[str, str, str], ...]] = ()
    #: plain (non-symbolic) arguments that are vectors or matrices of expressions
    vector_arguments: ClassVar[tuple[str, ...]] = ()
    #: Junction-like components: each bond to them makes a new port (kept on the model's graph).
    free_ports: ClassVar[bool] = False
    _frozen: bool = False

    def __init__(self, **args: Any):
        unknown = sorted(set(args) - set(self.arguments))
        if unknown:
            raise ModelError(
                f"{self.kind} has no argument(s) {', '.join(unknown)}; its arguments are: "
                f"{', '.join(self.arguments) or 'none'}", path=(unknown[0],))
        missing = [n for n, a in self.arguments.items() if a.default is REQUIRED and n not in args]
        if missing:
            raise ModelError(f"{self.kind} needs argument(s) {', '.join(missing)}")
        for name, value in args.items():
            if isinstance(value, float) and not math.isfinite(value):
                raise ModelError(f"{self.kind}: argument value {value!r} is not finite",
                                 path=(name,))
            check = self.arguments[name].check
            if check is not None and value is not None:
                try:
                    check(value)
                except ModelError as err:
                    raise err.within(name) from None
        self.args: Mapping[str, Any] = MappingProxyType(copy.deepcopy(args))

    def __setattr__(self, name: str, value: Any) -> None:
        if self._frozen:
            raise AttributeError(f"{self.kind or type(self).__name__} components are immutable "
                                 f"(cannot set {name!r}); make a new one with other arguments")
        object.__setattr__(self, name, value)

    def __copy__(self) -> Component:
        return self

    def __deepcopy__(self, memo: dict[int, Any]) -> Component:
        return self

    def __reduce__(self) -> tuple[Any, ...]:
        return _rebuild, (type(self), dict(self.args))

    def value(self, name: str) -> Any:
        """An argument as given, or its default."""
        return self.args.get(name, self.arguments[name].default)

    def ports(self) -> list[Port]:
        """The power ports this component declares."""
        return []

    def build(self, b: Builder, *args: Any, **kwargs: Any) -> None:  # pragma: no cover - abstract
        """Declare the component's states, laws, energy, dissipation and outputs with the
        builder ``b``; the arguments come by name, symbolic ones parsed (:meth:`parsed_args`).

        Each subclass lists its own :attr:`arguments` as keyword parameters (``def build(self,
        b, domain, stiffness, ...)``); this signature is the one every such override matches
        (a type checker holds ``b`` to :class:`Builder` and leaves the rest to the subclass)."""
        raise NotImplementedError

    def expression_fields(self) -> Iterator[ExpressionField]:
        """Every expression among the arguments as ``(key path, value, what, local names)``, for
        the model-file loader to parse and locate: the symbolic arguments, and the entries of the
        :attr:`vector_arguments`. ``what`` is how the compiler names the field in messages
        (``"argument 'mass'"``)."""
        for name, arg in self.arguments.items():
            value = self.args.get(name)
            if value is None:
                continue
            if arg.symbolic:
                yield (name,), value, f"argument {name!r}", arg.local
            elif name in self.vector_arguments and isinstance(value, list):
                stack: list[tuple[tuple[str | int, ...], Any]] = [
                    ((name, i), item) for i, item in enumerate(value)]
                while stack:
                    path, item = stack.pop(0)
                    if isinstance(item, list):
                        stack[:0] = [((*path, i), x) for i, x in enumerate(item)]
                    else:
                        yield path, item, f"argument {name!r}", ()

    def parsed_args(self, b: Builder) -> dict[str, Any]:
        """Arguments for :meth:`build`: symbolic ones parsed (with their local names), others raw;
        the arguments' rules and the :attr:`relations` declared with :meth:`Builder.require`. An
        error carries the argument's name as its path."""
        out: dict[str, Any] = {}
        for name, arg in self.arguments.items():
            value = self.value(name)
            if arg.symbolic and value is not None:
                local = {n: sp.Symbol(n, real=True) for n in arg.local}
                try:
                    out[name] = b.parse(value, f"argument {name!r}", local)
                    if arg.rule is not None:
                        b.require(out[name], arg.rule, f"argument {name!r}")
                except ModelError as err:
                    raise err.within(name) from None
            else:
                out[name] = value
        for name, rule, other in self.relations:
            if out.get(name) is not None and out.get(other) is not None:
                b.require(out[name], rule, f"argument {name!r}", out[other], f"argument {other!r}")
        return out

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.args.items())
        return f"{type(self).__name__}({args})"


def _rebuild(cls: type[Component], args: dict[str, Any]) -> Component:
    """Unpickling: the component made again from its arguments."""
    return cls(**args)


REGISTRY: dict[str, type[Component]] = {}


def register(cls: type[Component]) -> type[Component]:
    """Class decorator: make a component type loadable by its ``kind`` from model files."""
    if not cls.kind:
        raise ModelError(f"{cls.__name__} needs a 'kind' to be registered")
    if cls.kind in REGISTRY and REGISTRY[cls.kind] is not cls:
        raise ModelError(f"component kind {cls.kind!r} is registered twice")
    REGISTRY[cls.kind] = cls
    return cls


def component_class(kind: str) -> type[Component]:
    """The registered component class of ``kind``, or an error listing the known kinds."""
    try:
        return REGISTRY[kind]
    except KeyError:
        raise UnknownComponentError(
            f"unknown component type {kind!r}; known types: {', '.join(sorted(REGISTRY))}"
        ) from None


__all__ = ["REGISTRY", "STATE_ROLES", "TIME", "Arg", "Builder", "Component", "Dissipator",
           "ExpressionField", "PHCut", "PortVars", "Source", "component_class", "register"]
