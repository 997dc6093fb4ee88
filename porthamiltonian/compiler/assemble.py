"""Assembly of the port-Hamiltonian state equations and the energy ledger.

From the explicit solution of the structure analysis this builds, all as sympy expressions in the
states x, the parameters p and the time t:

* ẋ = F(t, x, p), with the ledger states E_diss and E_in appended (Ė_diss = P_diss, Ė_in = P_in);
* the Hamiltonian H = Σ component energies;
* P_diss = Σ dissipator powers (each e·f >= 0 for a passive law);
* P_in = Σ source powers + Σ modulation powers, where a storage c whose energy H_c depends
  explicitly on t or on states it does not own receives ∂H_c/∂t + Σ_{x ∉ c} ∂H_c/∂x · ẋ from the
  modulation (e.g. ½ K̇ q² for a stiffness K(t));
* every port effort/flow as a named output, component outputs, model outputs, event guards,
  initial states;
* the energy *parts* (:func:`energy_parts`): each storage component's stored energy as an output
  ``<component>.H``, or its outputs ``T`` and ``V`` when it splits its energy into kinetic and
  potential (a multibody), for the ledger's offset-free scale
  (:attr:`porthamiltonian.simulation.trajectory.Trajectory.energy_scale`);
* the constraints on parameter values the components declared (:mod:`porthamiltonian.modeling.constraints`);
* the SI units of the states (declared, or a storage port's time integral: m for a C storage on
  a translation port, N·s for an I storage) and of the port variables (their domain's).

The residual r(t) = H(t) − H(0) + E_diss(t) − E_in(t) is then zero up to integration error;
:func:`power_balance` gives dH/dt − P_in + P_diss, which is identically zero for a consistent model.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import sympy as sp

from ..errors import ModelError, StateError
from ..modeling.calls import KernelCall
from ..modeling.constraints import Constraint
from ..modeling.differentiation import derivative, free_symbols, remembering
from ..modeling.expressions import TIME, parse
from ..modeling.model import EventSpec
from ..modeling.ports import domain
from .structure import Solution, System, _flat, substituted


@dataclass
class SymbolicModel:
    """Everything the code generator needs; no graph, no components."""

    name: str
    states: list[sp.Symbol]
    state_names: list[str]
    params: list[sp.Symbol]
    param_names: list[str]
    param_defaults: list[float]
    param_units: list[str]
    rhs: list[sp.Expr]                 # length n + 2 (ledger rates last)
    hamiltonian: sp.Expr
    p_diss: sp.Expr
    p_in: sp.Expr
    outputs: dict[str, sp.Expr]
    events: list[tuple[EventSpec, sp.Expr]]
    initial: list[sp.Expr]
    equations: list[str] = field(default_factory=list)
    blocks: list[tuple[list[sp.Symbol], sp.Matrix, sp.Matrix]] = field(default_factory=list)
    matrices: dict[str, sp.Matrix] = field(default_factory=dict)
    intermediates: list[tuple[sp.Symbol, sp.Expr]] = field(default_factory=list)
    #: (output name, "stored" or "potential") of the energy parts (see :func:`energy_parts`)
    energy_parts: list[tuple[str, str]] = field(default_factory=list)
    constraints: list[Constraint] = field(default_factory=list)
    #: SI unit by name of the states and port variables whose unit is known
    units: dict[str, str] = field(default_factory=dict)
    #: the components' kernel calls by name (:mod:`porthamiltonian.modeling.calls`)
    calls: dict[str, KernelCall] = field(default_factory=dict)
    #: the model's inputs (signals bound at run time), their names and units
    inputs: list[sp.Symbol] = field(default_factory=list)
    input_names: list[str] = field(default_factory=list)
    input_units: list[str] = field(default_factory=list)
    #: the role of each state (:data:`porthamiltonian.modeling.component.STATE_ROLES`)
    state_roles: list[str] = field(default_factory=list)
    #: the model's declared outputs y (model-level ``outputs``), in order: the rows of the
    #: linearization's C and D
    declared_outputs: list[str] = field(default_factory=list)
    #: the discrete-time blocks: (component, its period output, its discrete states, their
    #: values at a sampling instant as expressions of the model)
    discrete: list[tuple[str, str, list[sp.Symbol], list[sp.Expr]]] = field(default_factory=list)
    #: makes the explicit port-Hamiltonian form (set by :func:`porthamiltonian.compiler.symbolic`)
    ph_maker: Any = field(default=None, repr=False, compare=False)
    #: seconds of this model's structure solve made by an earlier call (a layout) and reported
    #: by no build line yet (compiler._solved): a build adds them to its symbolic time
    solved_earlier: float = field(default=0.0, repr=False, compare=False)

    def ph_form(self) -> Any:
        """The explicit port-Hamiltonian form [ẋ; w; y] = (J − R)[∇H; z; u] of this model, a
        :class:`porthamiltonian.compiler.phform.PHForm` (symbolic J, R, the dissipators' z(w),
        the ports' u)."""
        if self.ph_maker is None:
            raise ModelError(f"model {self.name!r}: the port-Hamiltonian form is made by "
                             "porthamiltonian.symbolic(model).ph_form()")
        return self.ph_maker()

    @property
    def ledger_states(self) -> list[sp.Symbol]:
        """The symbols of the ledger states E_diss and E_in (appended to the model states)."""
        return [sp.Symbol("ledger.E_diss", real=True), sp.Symbol("ledger.E_in", real=True)]


@remembering
def assemble(solution: Solution) -> SymbolicModel:
    """The state equations, energy ledger, outputs, guards and initial values of a solved
    system (see the module docstring)."""
    system = solution.system
    flat = system.flat
    values = {u: expr for u, expr, _ in solution.order}
    xdot = {system.derivatives[d]: values[d] for d in system.derivatives}
    states = system.states
    owned: dict[str, set[sp.Symbol]] = {c: {s.symbol for s in b.states} for c, b in system.built.items()}
    unknowns = set(system.unknowns)

    H = sp.Integer(0)
    p_diss = sp.Integer(0)
    p_in = sp.Integer(0)
    energies: dict[str, sp.Expr] = {}
    hidden = _hidden_dependencies(system.intermediates, {*states, TIME})
    # port variables, and the intermediates that read them (directly or through others)
    ported = unknowns | system.port_level
    for cname, b in system.built.items():
        energy = substituted(b.energy, system.aliases)
        energies[cname] = energy
        if energy.free_symbols & ported:
            raise ModelError(f"component {cname!r}: its stored energy depends on port variables; "
                             "energy must be a function of states, parameters and time")
        H += energy
        reached = set().union(*(hidden[w] for w in energy.free_symbols if w in hidden))
        if TIME in reached or (reached - owned[cname] - {TIME} and not b.energy_via_ports):
            # intermediates hide a dependence on time or on other components' states: the
            # modulation power is formed from the energy written out in states
            energy = _inline(energy, system.intermediates)
        modulation = derivative(energy, TIME)
        if not b.energy_via_ports:
            modulation += sum((derivative(energy, x) * xdot[x] for x in energy.free_symbols & set(states)
                               if x not in owned[cname]), sp.Integer(0))
        p_in += modulation
        p_diss += substituted(substituted(b.dissipation, system.aliases), values)
        p_in += substituted(substituted(b.supply, system.aliases), values)

    outputs: dict[str, sp.Expr] = {}
    units = {str(s.symbol): s.unit for b in system.built.values() for s in b.states if s.unit}
    for cname, b in system.built.items():
        for pname, pv in b.ports.items():
            names = _port_names(cname, pname, pv.port.dim)
            dom = domain(pv.port.domain)
            kinds = [dom.effort_unit] * pv.port.dim + [dom.flow_unit] * pv.port.dim
            for name, sym, unit in zip(names, _flat(pv.e) + _flat(pv.f), kinds):
                outputs[name] = values[system.aliases.get(sym, sym)]
                if unit and "|" not in unit:
                    units[name] = unit
        for oname, expr in b.outputs.items():
            outputs[oname] = substituted(substituted(expr, system.aliases), values)
        units.update(b.output_units)
    parts = energy_parts(energies, outputs)
    units.update({name: "J" for name, _ in parts})
    units.update({name: i.unit for name, i in flat.inputs.items() if i.unit and i.bind is None})
    symbol_table = _symbol_table(system, outputs)
    for oname, text in flat.outputs.items():
        outputs[oname] = _model_expr(text, f"output:{oname}", symbol_table, system,
                                     f"output {oname!r}").xreplace(values)
    events = [(ev, _model_expr(ev.guard, f"event:{ev.name}", symbol_table, system,
                               f"event {ev.name!r} guard").xreplace(values)) for ev in flat.events]

    initial = []
    param_set = set(system.params.values())
    # intermediates of the parameters alone (e.g. a kernel's initial momenta) may give initial
    # values (the intermediates are ordered: one pass)
    constant: set[sp.Symbol] = set()
    for w, expr in system.intermediates:
        if expr.free_symbols <= param_set | constant:
            constant.add(w)
    for b in system.built.values():
        for s in b.states:
            if not s.initial.free_symbols <= param_set | {TIME} | constant:
                raise StateError(f"initial value of {s.symbol} must depend on parameters only")
            initial.append(s.initial.subs(TIME, 0))

    matrices = {name: m.xreplace(system.aliases).xreplace(values)
                for b in system.built.values() for name, m in b.matrices.items()}
    discrete = [(cname, f"{cname}.T", [state for state, _ in updates],
                 [v.xreplace(system.aliases).xreplace(values) for _, v in updates])
                for cname, b in system.built.items() for _, updates in b.samples]
    rhs = [xdot[x] for x in states] + [p_diss, p_in]
    used = [*rhs, H, *outputs.values(), *(g for _, g in events), *matrices.values(),
            *(e for _, A, b in system.blocks for e in (*A, *b)), *initial,
            *(v for *_, new in discrete for v in new)]
    return SymbolicModel(
        name=flat.name, states=states, state_names=[str(s) for s in states],
        params=list(system.params.values()), param_names=list(system.params),
        param_defaults=[p.value for p in flat.parameters.values()],
        param_units=[p.unit for p in flat.parameters.values()],
        rhs=rhs, hamiltonian=H, p_diss=p_diss, p_in=p_in, outputs=outputs, events=events,
        initial=initial,
        equations=[f"{u} = {expr}" for u, expr, _ in solution.order if u in system.derivatives],
        blocks=system.blocks, matrices=matrices,
        intermediates=_needed(system.intermediates, used),
        energy_parts=parts,
        constraints=[c for b in system.built.values() for c in b.constraints],
        units=units,
        calls={name: call for b in system.built.values() for name, call in b.calls.items()},
        inputs=list(system.inputs.values()), input_names=list(system.inputs),
        input_units=[i.unit for i in flat.inputs.values() if i.bind is None],
        state_roles=[s.role for b in system.built.values() for s in b.states],
        declared_outputs=list(flat.outputs),
        discrete=discrete,
    )


def energy_parts(energies: dict[str, sp.Expr],
                 outputs: dict[str, sp.Expr]) -> list[tuple[str, str]]:
    """The outputs that split H into parts, as ``(name, kind)``, for Trajectory.energy_scale: per
    component with stored energy, its outputs ``<c>.T`` (kind ``"stored"``: a kinetic energy,
    zero at rest) and ``<c>.V`` (kind ``"potential"``: measured from an arbitrary datum) when they
    add up to its energy, as a Multibody or FreeBody declares them; else its energy as a new
    output ``<c>.H`` (added to ``outputs``), kind ``"stored"`` (the library's storages have zero
    energy at their zero state)."""
    parts = []
    for cname, energy in energies.items():
        if energy == 0:
            continue
        kinetic, potential = outputs.get(f"{cname}.T"), outputs.get(f"{cname}.V")
        if kinetic is not None and potential is not None and kinetic + potential == energy:
            parts += [(f"{cname}.T", "stored"), (f"{cname}.V", "potential")]
            continue
        name = f"{cname}.H"
        while name in outputs:
            name += "_stored"
        outputs[name] = energy
        parts.append((name, "stored"))
    return parts


def _needed(intermediates: list[tuple[sp.Symbol, sp.Expr]],
            exprs: list[sp.Expr]) -> list[tuple[sp.Symbol, sp.Expr]]:
    """The intermediates that ``exprs`` use, directly or through other intermediates (in their
    order): a component may declare more than a model uses (e.g. a multibody's inertia entries
    that a planar motion never reads)."""
    wanted: set[sp.Symbol] = set()
    for e in exprs:
        wanted |= free_symbols(sp.sympify(e))
    for symbol, expr in reversed(intermediates):
        if symbol in wanted:
            wanted |= free_symbols(expr)
    return [(s, e) for s, e in intermediates if s in wanted]


def _hidden_dependencies(intermediates: list[tuple[sp.Symbol, sp.Expr]],
                         leaves: set[sp.Symbol]) -> dict[sp.Symbol, set[sp.Symbol]]:
    """For each intermediate, the states and time (``leaves``) it depends on, directly or
    through earlier intermediates."""
    reach: dict[sp.Symbol, set[sp.Symbol]] = {}
    for symbol, expr in intermediates:
        found = set(free_symbols(expr) & leaves)
        for w in free_symbols(expr):
            if w in reach:
                found |= reach[w]
        reach[symbol] = found
    return reach


def _inline(expr: sp.Expr, intermediates: list[tuple[sp.Symbol, sp.Expr]]) -> sp.Expr:
    """``expr`` with its intermediates substituted by their definitions, recursively."""
    defs = dict(intermediates)
    values: dict[sp.Symbol, sp.Expr] = {}

    def value(symbol: sp.Symbol) -> sp.Expr:
        if symbol not in values:
            inner = defs[symbol]
            values[symbol] = inner.xreplace({w: value(w) for w in inner.free_symbols if w in defs})
        return values[symbol]

    return expr.xreplace({w: value(w) for w in expr.free_symbols if w in defs})


def _port_names(comp: str, port: str, dim: int) -> list[str]:
    if dim == 1:
        return [f"{comp}.{port}.e", f"{comp}.{port}.f"]
    return [f"{comp}.{port}.e{i}" for i in range(dim)] + [f"{comp}.{port}.f{i}" for i in range(dim)]


def _symbol_table(system: System, outputs: Mapping[str, sp.Expr]) -> dict[str, sp.Expr]:
    """Names a model-level expression (event guard, output) may use: states, port variables and
    every component output (e.g. a body point's height ``walker.foot1.z``)."""
    table: dict[str, sp.Expr] = {str(s): s for s in system.states}
    for cname, b in system.built.items():
        for pname, pv in b.ports.items():
            for name, sym in zip(_port_names(cname, pname, pv.port.dim), _flat(pv.e) + _flat(pv.f)):
                table[name] = system.aliases.get(sym, sym)
    for name, expr in outputs.items():
        table.setdefault(name, expr)
    return table


def _model_expr(text: str, key: str, table: dict[str, sp.Symbol], system: System,
                where: str) -> sp.Expr:
    """A model output's or event guard's expression (``key``: ``"output:<name>"`` or
    ``"event:<name>"``) in its scope; an error carries its path."""
    flat = system.flat
    prefix = flat.scopes[key]
    try:
        return parse(text, flat.scope_names(prefix), f"model {flat.name!r} {where}",
                     lambda ref: table.get(prefix + ref)).xreplace(system.bound)
    except ModelError as err:
        suffix = ("guard",) if key.startswith("event:") else ()
        raise err.within(*flat.paths[key], *suffix) from None


def power_balance(model: SymbolicModel) -> sp.Expr:
    """dH/dt − P_in + P_diss along the state equations (zero for a consistent model).

    Symbolic, so only for models without implicit blocks; for those use
    :meth:`porthamiltonian.simulation.compiled.CompiledModel.power_balance` (numeric).
    """
    if model.blocks or model.calls:
        raise ModelError(f"model {model.name!r} has implicit blocks or kernel calls (e.g. a mass "
                         "matrix solved numerically): check its power balance with "
                         "CompiledModel.power_balance")
    n = len(model.states)
    if model.intermediates:
        return power_balance(_inlined(model))
    dH = derivative(model.hamiltonian, TIME) + sum(
        (derivative(model.hamiltonian, x) * f for x, f in zip(model.states, model.rhs[:n])), sp.Integer(0))
    return dH - model.p_in + model.p_diss


def _inlined(model: SymbolicModel) -> SymbolicModel:
    """The model with its intermediates substituted (for symbolic checks only)."""
    from dataclasses import replace

    values: dict[sp.Symbol, sp.Expr] = {}
    for symbol, expr in model.intermediates:
        values[symbol] = expr.xreplace(values)
    return replace(model, rhs=[e.xreplace(values) for e in model.rhs],
                   hamiltonian=model.hamiltonian.xreplace(values),
                   p_diss=model.p_diss.xreplace(values), p_in=model.p_in.xreplace(values),
                   intermediates=[])
