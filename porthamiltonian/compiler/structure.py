"""Structure analysis: from a flattened model to an ordered sequence of explicit assignments.

Every component's laws, the bonds (which identify the port variables of their two ends) and the
junction laws give a set of equations ``r_i = 0``. The unknowns are the port efforts and flows and
the state derivatives; states, parameters and time are known. Causality assignment is done as a
bipartite matching between equations and unknowns, where equation *i* may compute unknown *u* only
if ``r_i`` is affine in *u* with a coefficient free of unknowns (this is the bond-graph causality
of the law: a linear R has both causalities, a nonlinear R only the one its law is written in, a
storage only integral causality because its state is known). This is equivalent to sequential
causality assignment, but also covers multiports and modulated elements without special cases.

Then

* no complete matching -> over-/under-determined parts (Dulmage-Mendelsohn by alternating paths):
  dependent storages are reported as :class:`DerivativeCausalityError` with the storages named;
* strongly connected blocks of size > 1 in the dependency graph -> :class:`AlgebraicLoopError`
  naming the components and port variables of the loop;
* otherwise a topological order of single-equation blocks, each solved explicitly.

Component intermediates (:meth:`~porthamiltonian.modeling.component.Builder.intermediate`) stay symbols in
the solved expressions. Those that read port variables (port level, e.g. a friction's slip from
its port's flow) are not known when the equations are matched: after the solution their port
variables are replaced by the solved expressions and all intermediates reordered
(:func:`_port_level`), so that the state equations never contain the expanded law.

Intermediates and implicit blocks are ordered by *stage* (:func:`stages`): stage 0 reads states,
parameters and time only (position level); a block's unknowns are one stage above everything its
matrix and right-hand side read; an intermediate is at the stage of the latest thing it reads. A
multibody's velocities (M(q) v = p) are stage 1; a block that reads velocity-level intermediates —
the accelerations and multipliers of closed kinematic loops, whose right-hand side holds the
velocity products — is stage 2. The code generator differentiates stage by stage.
"""
from __future__ import annotations

from collections.abc import Mapping
from collections.abc import Set as AbstractSet
from dataclasses import dataclass, field
from typing import Any, NoReturn

import networkx as nx
import sympy as sp

from ..errors import (
    AlgebraicLoopError,
    DerivativeCausalityError,
    ModelError,
    StructureError,
    UnknownParameterError,
)
from ..modeling.component import Builder, Built, PHCut, PortVars
from ..modeling.differentiation import derivative, free_symbols, remembering
from ..modeling.elements import _Junction
from ..modeling.expressions import TIME, parse
from ..modeling.model import ModelDescription


@dataclass
class Equation:
    residual: sp.Expr
    component: str
    doc: str


@dataclass
class System:
    """The equation system of a flattened model, before solving."""

    flat: ModelDescription
    built: dict[str, Built]
    params: dict[str, sp.Symbol]
    equations: list[Equation]
    unknowns: list[sp.Symbol]
    states: list[sp.Symbol]
    derivatives: dict[sp.Symbol, sp.Symbol]        # derivative symbol -> state symbol
    aliases: dict[sp.Symbol, sp.Symbol]             # head port symbol -> tail port symbol
    inputs: dict[str, sp.Symbol] = field(default_factory=dict)   # the model's input signals
    #: the inputs bound in the model: symbol -> expression (signals resolved)
    bound: dict[sp.Symbol, sp.Expr] = field(default_factory=dict)
    owner: dict[sp.Symbol, str] = field(default_factory=dict)   # unknown -> component
    blocks: list[tuple[list[sp.Symbol], sp.Matrix, sp.Matrix]] = field(default_factory=list)
    intermediates: list[tuple[sp.Symbol, sp.Expr]] = field(default_factory=list)
    #: the intermediates that read port variables (directly or through others); :func:`solve`
    #: replaces those variables by their solutions
    port_level: set[sp.Symbol] = field(default_factory=set)


@dataclass
class Solution:
    """Explicit assignments ``unknown = expression`` in an order where each uses only earlier ones."""

    system: System
    order: list[tuple[sp.Symbol, sp.Expr, Equation]]


@remembering
def build_system(flat: ModelDescription, ph: PHCut | None = None) -> System:
    """Run every component's ``build`` and collect the equations, unknowns and states. A model
    error raised by a component carries the component's path (and the argument's, where the
    component knows it). Inputs bound in the model (``Input.bind``) are replaced by their
    expressions, like component outputs read as signals. ``ph``: run the port-Hamiltonian
    form's cut build instead (:mod:`.phform`), recording its symbols there."""
    params = {name: sp.Symbol(name, real=True) for name in flat.parameters}
    inputs = {name: sp.Symbol(name, real=True) for name, i in flat.inputs.items()
              if i.bind is None}
    built: dict[str, Built] = {}
    equations: list[Equation] = []
    orientation: dict[tuple[str, str], str] = {}
    for (tc, tp), (hc, hp) in flat.bonds:
        orientation[(tc, tp)] = "out"
        orientation[(hc, hp)] = "in"
    for name, comp in flat.components.items():
        prefix = flat.scopes[name]
        in_scope = flat.in_scope(prefix)

        def dotted(ref: str, prefix: str = prefix, in_scope: set[str] = in_scope) -> sp.Symbol | None:
            return sp.Symbol(prefix + ref, real=True) if ref.split(".")[0] in in_scope else None

        own = {port: o for (c, port), o in orientation.items() if c == name}
        builder = Builder(name, list(flat.ports[name]), flat.scope_names(prefix), dotted, own,
                          inputs.values())
        builder.ph = ph
        if not isinstance(comp, _Junction):
            try:
                comp.build(builder, **comp.parsed_args(builder))
            except ModelError as err:
                raise err.within(*flat.paths[name]) from None
        built[name] = builder.built
        equations += [Equation(r, name, doc) for r, doc in builder.built.equations]
        for pname, pv in builder.built.ports.items():
            if (name, pname) not in orientation:  # an unconnected optional port: no effort
                equations += [Equation(e, name, f"unconnected port {pname}: zero effort")
                              for e in _flat(pv.e)]

    bound = _resolve_signals(built, equations, _bound_inputs(flat), ph)

    aliases: dict[sp.Symbol, sp.Symbol] = {}
    for (tc, tp), (hc, hp) in flat.bonds:
        tail, head = built[tc].ports[tp], built[hc].ports[hp]
        for h, t in _pairs(head, tail):
            aliases[h] = t
    for name, comp in flat.components.items():
        if isinstance(comp, _Junction):
            equations += _junction_equations(name, comp, built[name], orientation)

    equations = [Equation(substituted(eq.residual, aliases), eq.component, eq.doc)
                 for eq in equations]
    states = [s.symbol for b in built.values() for s in b.states]
    derivatives = {s.derivative: s.symbol for b in built.values() for s in b.states}
    owner: dict[sp.Symbol, str] = {}
    for cname, b in built.items():
        for pv in b.ports.values():
            for sym in _flat(pv.e) + _flat(pv.f):
                owner.setdefault(aliases.get(sym, sym), cname)
        for s in b.states:
            owner[s.derivative] = cname
    unknowns = list(dict.fromkeys([*(u for u in owner if u not in derivatives), *derivatives]))
    known = {*params.values(), *inputs.values(), *states, TIME, *(ph.symbols if ph else ())}
    for b in built.values():
        b.intermediates = [(s, substituted(e, aliases)) for s, e in b.intermediates]
    port_variables = set(unknowns) - set(derivatives)
    defined = {s for b in built.values() for s, _ in b.intermediates}
    block_symbols = {s for b in built.values() for symbols, _, _ in b.blocks for s in symbols}
    blocks = []
    for cname, b in built.items():
        for symbols, A, rhs in b.blocks:
            stray = (A.free_symbols | rhs.free_symbols) - known - defined - block_symbols
            if stray:
                raise UnknownParameterError(
                    f"component {cname!r}: implicit block {symbols[0]}.. may depend on states, "
                    "parameters, time, intermediates and other blocks' unknowns only, not on "
                    f"{', '.join(sorted(map(str, stray)))}")
            blocks.append((symbols, A, rhs))
    intermediates, _, blocks = _ordered_intermediates(built, known, port_variables, blocks)
    port_level = _reaching(intermediates, port_variables)
    known |= {s for s, _ in intermediates} | {s for symbols, _, _ in blocks for s in symbols}
    for eq in equations:
        stray = eq.residual.free_symbols - known - set(unknowns)
        if stray:
            raise UnknownParameterError(
                f"component {eq.component!r} refers to {', '.join(sorted(map(str, stray)))}, which "
                "is not a parameter, state or port variable of the model"
            )
    return System(flat, built, params, equations, unknowns, states, derivatives, aliases, inputs,
                  bound, owner, blocks, intermediates, port_level)


def _reaching(intermediates: list[tuple[sp.Symbol, sp.Expr]], leaves: set[sp.Symbol]
              ) -> set[sp.Symbol]:
    """The (ordered) intermediates that read one of ``leaves``, directly or through others."""
    found: set[sp.Symbol] = set()
    for symbol, expr in intermediates:
        if free_symbols(expr) & (leaves | found):
            found.add(symbol)
    return found


Block = tuple[list[sp.Symbol], sp.Matrix, sp.Matrix]


def _ordered_intermediates(built: dict[str, Built], known: set[sp.Symbol],
                           port_variables: set[sp.Symbol], blocks: list[Block]
                           ) -> tuple[list[tuple[sp.Symbol, sp.Expr]], set[sp.Symbol], list[Block]]:
    """The intermediates of all components in an order where each uses only earlier ones, by
    stage (see the module docstring): first those that depend on states, parameters and time only
    (position level), then those that also depend on the unknowns of implicit blocks (velocity
    level, e.g. body twists that read the velocities solved from M(q) v = p) or on port variables
    (port level, e.g. a friction's slip speed from its port's flow: ordered after :func:`solve`
    has solved the port variables, see :func:`_port_level`), each group in declaration order
    where it allows. Returns the ordered list, the set of the symbols above the position level
    and the blocks ordered by stage."""
    defs: dict[sp.Symbol, sp.Expr] = {}
    owner: dict[sp.Symbol, str] = {}
    for cname, b in built.items():
        for symbol, expr in b.intermediates:
            defs[symbol], owner[symbol] = expr, cname
    block_symbols = {s for symbols, _, _ in blocks for s in symbols}
    defined = set(defs)
    for symbol, expr in defs.items():
        stray = free_symbols(expr) - known - defined - block_symbols - port_variables
        if stray:
            raise UnknownParameterError(
                f"component {owner[symbol]!r}: intermediate {symbol} may depend on states, "
                "parameters, time, other intermediates, the unknowns of implicit blocks and port "
                f"variables only, not on {', '.join(sorted(map(str, stray)))}")
    return _order(defs, owner, port_variables, blocks)


def stages(defs: dict[sp.Symbol, sp.Expr], blocks: list[Block], unknowns: AbstractSet[sp.Symbol] = frozenset(),
           owner: dict[sp.Symbol, str] | None = None
           ) -> tuple[list[sp.Symbol], dict[sp.Symbol, int], list[int]]:
    """The stage of every intermediate (``defs``) and block (see the module docstring): a
    topological order of the intermediates (each after what it reads, in declaration order where
    that allows), their stages, and the stage of each block. ``unknowns`` (port variables not yet
    solved) count as stage 1. A cycle raises StructureError."""
    owner = owner or {}
    block_of = {s: i for i, (symbols, _, _) in enumerate(blocks) for s in symbols}
    order: list[sp.Symbol] = []
    state: dict[sp.Symbol, int] = {}          # 1: being placed, 2: placed

    def place(symbol: sp.Symbol) -> None:
        if state.get(symbol) == 2:
            return
        if state.get(symbol) == 1:
            raise StructureError(f"intermediate {symbol} depends on itself (through "
                                 f"component {owner.get(symbol, '?')!r})")
        state[symbol] = 1
        for dep in sorted(free_symbols(defs[symbol]) & defs.keys(), key=str):
            place(dep)
        state[symbol] = 2
        order.append(symbol)

    for symbol in defs:
        place(symbol)
    stage: dict[sp.Symbol, int] = {}
    block_stage: dict[int, int | None] = {}

    def level(symbol: sp.Symbol) -> int:
        if symbol in stage:
            return stage[symbol]
        if symbol in block_of:
            i = block_of[symbol]
            if i not in block_stage:
                block_stage[i] = None
                symbols, A, b = blocks[i]
                reads = (A.free_symbols | b.free_symbols) - set(symbols)
                block_stage[i] = 1 + max((level(s) for s in reads), default=0)
            found = block_stage[i]
            if found is None:
                raise StructureError(f"implicit block {blocks[i][0][0]}.. depends on its own "
                                     "unknowns")
            return found
        if symbol in defs:            # read by a block before its place in the order
            stage[symbol] = max((level(d) for d in free_symbols(defs[symbol])), default=0)
            return stage[symbol]
        return 1 if symbol in unknowns else 0

    for symbol in order:
        level(symbol)
    return order, stage, [level(blocks[i][0][0]) for i in range(len(blocks))]


def _order(defs: dict[sp.Symbol, sp.Expr], owner: dict[sp.Symbol, str],
           unknowns: set[sp.Symbol], blocks: list[Block]
           ) -> tuple[list[tuple[sp.Symbol, sp.Expr]], set[sp.Symbol], list[Block]]:
    """``defs`` in an order where each uses only earlier ones, by stage (:func:`stages`:
    those that read ``unknowns`` or block unknowns, directly or through others, after the
    position-level ones); the set of those above stage 0; the blocks sorted by stage."""
    order, stage, block_stages = stages(defs, blocks, unknowns, owner)
    ordered = sorted(order, key=lambda s: stage[s])            # stable: declaration order kept
    velocity = {s for s in order if stage[s] > 0}
    by_stage = [blocks[i] for i in sorted(range(len(blocks)), key=lambda i: block_stages[i])]
    return [(s, defs[s]) for s in ordered], velocity, by_stage


def _bound_inputs(flat: ModelDescription) -> dict[sp.Symbol, sp.Expr]:
    """The inputs bound in the model, symbol -> their expression (in the model's symbols;
    dotted names left as symbols for :func:`_resolve_signals`)."""
    bound: dict[sp.Symbol, sp.Expr] = {}
    for name, signal in flat.inputs.items():
        if signal.bind is None:
            continue
        key = f"input:{name}"
        prefix = flat.scopes[key]
        in_scope = flat.in_scope(prefix)

        def dotted(ref: str, prefix: str = prefix, in_scope: set[str] = in_scope
                   ) -> sp.Symbol | None:
            return sp.Symbol(prefix + ref, real=True) if ref.split(".")[0] in in_scope else None

        try:
            bound[sp.Symbol(name, real=True)] = parse(
                signal.bind, flat.scope_names(prefix), f"input {name!r} binding", dotted)
        except ModelError as err:
            raise err.within(*flat.paths[key], "bind") from None
    return bound


def _resolve_signals(built: dict[str, Built], equations: list[Equation],
                     bound: dict[sp.Symbol, sp.Expr] | None = None, ph: PHCut | None = None
                     ) -> dict[sp.Symbol, sp.Expr]:
    """Replace dotted references to other components' outputs (signals, e.g. ``walker.foot1.z``)
    and the inputs bound in the model (``bound``) by their expressions, everywhere a component
    may have used them; returns the bound inputs' expressions so resolved."""
    outputs = {sp.Symbol(name, real=True): expr for b in built.values()
               for name, expr in b.outputs.items()}
    outputs.update(bound or {})
    if not outputs:
        return {}
    for _ in range(8):  # outputs may read outputs; resolve a few levels
        changed = False
        for sym, expr in list(outputs.items()):
            new = substituted(expr, outputs)
            if new != expr:
                outputs[sym], changed = new, True
        if not changed:
            break

    def sub(e: sp.Expr) -> sp.Expr:
        return substituted(e, outputs)

    for eq in equations:
        eq.residual = sub(eq.residual)
    for b in built.values():
        b.energy, b.dissipation, b.supply = sub(b.energy), sub(b.dissipation), sub(b.supply)
        b.outputs = {n: sub(e) for n, e in b.outputs.items()}
        b.intermediates = [(s, sub(e)) for s, e in b.intermediates]
        b.blocks = [(syms, A.applyfunc(sub), r.applyfunc(sub)) for syms, A, r in b.blocks]
        b.matrices = {n: m.applyfunc(sub) for n, m in b.matrices.items()}
        b.samples = [(sub(T), [(s, sub(v)) for s, v in updates]) for T, updates in b.samples]
    if ph is not None:              # the cut build's records read signals too
        for d in ph.dissipators:
            d.z, d.w = [sub(e) for e in d.z], [sub(e) for e in d.w]
            if d.coefficient is not None:
                d.coefficient = d.coefficient.applyfunc(sub)
        for source in ph.sources:
            source.value, source.conjugate = sub(source.value), sub(source.conjugate)
    return {sym: outputs[sym] for sym in bound or {}}


def substituted(expr: sp.Expr, rule: Mapping[sp.Symbol, sp.Expr]) -> sp.Expr:
    """``expr.xreplace(rule)`` for a ``rule`` of symbols that are never bound variables (port
    variables, signals, solved unknowns): ``expr`` itself when it reads none of them, as its
    remembered free symbols tell without xreplace's walk of the whole tree (most expressions
    read none: the substitutions of :func:`build_system` and :func:`solve`)."""
    return expr if free_symbols(expr).isdisjoint(rule) else expr.xreplace(rule)


def _flat(x: Any) -> list[sp.Symbol]:
    return list(x) if isinstance(x, sp.MatrixBase) else [x]


def _pairs(a: PortVars, b: PortVars) -> list[tuple[sp.Symbol, sp.Symbol]]:
    return list(zip(_flat(a.e) + _flat(a.f), _flat(b.e) + _flat(b.f)))


def _junction_equations(name: str, comp: _Junction, built: Built,
                        orientation: dict[tuple[str, str], str]) -> list[Equation]:
    ports = list(built.ports.values())
    if not ports:
        return []
    common, summed = ("e", "f") if comp.common == "e" else ("f", "e")
    sign = {p.port.name: (1 if orientation[(name, p.port.name)] == "in" else -1) for p in ports}
    out = []
    first = ports[0]
    for p in ports[1:]:
        for a, b in zip(_flat(getattr(p, common)), _flat(getattr(first, common))):
            out.append(Equation(a - b, name, f"common {'effort' if common == 'e' else 'flow'}"))
    dim = first.port.dim
    for k in range(dim):
        total = sum(sign[p.port.name] * _flat(getattr(p, summed))[k] for p in ports)
        out.append(Equation(total, name, f"sum of {'flows' if summed == 'f' else 'efforts'}"))
    return out


def _solvable(residual: sp.Expr, unknown: sp.Symbol, unknowns: set[sp.Symbol]) -> bool:
    coefficient = derivative(residual, unknown)
    return coefficient != 0 and not (coefficient.free_symbols & unknowns)


@remembering
def solve(system: System) -> Solution:
    """Assign causality (matching), check structure, order and solve the equations explicitly."""
    eqs, unknowns = system.equations, system.unknowns
    uset = set(unknowns)
    graph: nx.Graph[tuple[str, Any]] = nx.Graph()
    eq_nodes = [("eq", i) for i in range(len(eqs))]
    graph.add_nodes_from(eq_nodes)
    graph.add_nodes_from(("u", u) for u in unknowns)
    appears: list[set[sp.Symbol]] = []
    for i, eq in enumerate(eqs):
        present = eq.residual.free_symbols & uset
        appears.append(present)
        for u in sorted(present, key=str):
            if _solvable(eq.residual, u, uset):
                graph.add_edge(("eq", i), ("u", u))
    matching = nx.bipartite.hopcroft_karp_matching(graph, top_nodes=eq_nodes)
    matched = {i: matching[("eq", i)][1] for i in range(len(eqs)) if ("eq", i) in matching}
    if len(matched) < max(len(eqs), len(unknowns)):
        _report_singular(system, appears, matched)

    by_unknown = {u: i for i, u in matched.items()}
    deps: nx.DiGraph[int] = nx.DiGraph()
    deps.add_nodes_from(range(len(eqs)))
    for i, present in enumerate(appears):
        for u in present:
            j = by_unknown[u]
            if j != i:
                deps.add_edge(j, i)
    loops = [c for c in nx.strongly_connected_components(deps) if len(c) > 1]
    if loops:
        loop = sorted(loops[0])
        comps = sorted({eqs[i].component for i in loop})
        variables = sorted(str(matched[i]) for i in loop)
        raise AlgebraicLoopError(
            f"algebraic loop through components {', '.join(comps)} (variables "
            f"{', '.join(variables)}): they determine each other instantaneously. Put a storage "
            "(C or I) between them, or merge the dissipators into one"
        )
    order = []
    values: dict[sp.Symbol, sp.Expr] = {}
    for i in nx.lexicographical_topological_sort(deps):
        u = matched[i]
        residual = eqs[i].residual
        coefficient = derivative(residual, u)
        rest = residual.xreplace({u: 0})
        expr = (-rest / coefficient).xreplace(values)
        values[u] = expr
        order.append((u, expr, eqs[i]))
    if system.port_level:
        system.intermediates = _port_level(system, values)
    return Solution(system, order)


def _port_level(system: System, values: dict[sp.Symbol, sp.Expr]
                ) -> list[tuple[sp.Symbol, sp.Expr]]:
    """The intermediates with the port variables that port-level ones read replaced by their
    solutions (in states, parameters, time, block unknowns and intermediates), reordered. A port
    variable whose solution reads the intermediate that reads it is an algebraic loop."""
    owner = {s: c for c, b in system.built.items() for s, _ in b.intermediates}
    defs = {s: (e.xreplace(values) if s in system.port_level else e)
            for s, e in system.intermediates}
    try:
        ordered, _, system.blocks = _order(defs, owner, set(), system.blocks)
    except StructureError as err:
        raise AlgebraicLoopError(
            f"{err}: it reads port variables whose solution reads it back (an algebraic loop "
            "through a port-level intermediate). Put a storage (C or I) in the loop") from None
    return ordered


def _report_singular(system: System, appears: list[set[sp.Symbol]],
                     matched: dict[int, sp.Symbol]) -> NoReturn:
    eqs = system.equations
    by_unknown = {u: i for i, u in matched.items()}
    unmatched_eqs = [i for i in range(len(eqs)) if i not in matched]
    over: set[int] = set()
    frontier = list(unmatched_eqs)
    while frontier:
        i = frontier.pop()
        if i in over:
            continue
        over.add(i)
        frontier += [by_unknown[u] for u in appears[i] if u in by_unknown]
    storages = sorted({eqs[i].component for i in over if system.built[eqs[i].component].storage_ports})
    comps = sorted({eqs[i].component for i in over})
    free = [u for u in system.unknowns if u not in by_unknown]
    if len(storages) >= 2:
        ports = sorted({f"{c}.{p}" for c in storages for p in system.built[c].storage_ports})
        raise DerivativeCausalityError(
            f"dependent storages {', '.join(storages)} (ports {', '.join(ports)}): their states are "
            "not independent, one would need derivative causality. Merge them into one storage, or "
            "put a compliance (C) or a dissipator (R) between them"
        )
    kinds = {c: getattr(system.flat.components.get(c), "kind", "") for c in comps}
    sources = [c for c in comps if kinds[c] in ("Se", "Sf")]
    if len(storages) == 1 and sources:
        imposed = "flow" if kinds[sources[0]] == "Sf" else "effort"
        named = ", ".join(f"{storages[0]}.{p}" for p in system.built[storages[0]].storage_ports)
        raise DerivativeCausalityError(
            f"source {sources[0]!r} ({kinds[sources[0]]}) imposes the {imposed} of storage "
            f"{storages[0]!r} (port {named}): the storage's state would be dictated by the source "
            "(derivative causality) instead of integrated. Put a compliance (C) or a dissipator "
            f"(R) between them, or drive the storage with {'an effort' if imposed == 'flow' else 'a flow'}"
            " source")
    detail = []
    if comps:
        detail.append(f"over-determined laws in {', '.join(comps)}")
    if free:
        owners = sorted({system.owner.get(u, "?") for u in free})
        detail.append(f"nothing determines {', '.join(sorted(map(str, free)))} (components "
                      f"{', '.join(owners)}); a nonlinear law can only be used in the causality it is "
                      "written in (e.g. give an R its law as flow = f(e) instead of effort = f(f))")
    raise StructureError("the model's equations are structurally singular: " + "; ".join(detail))
