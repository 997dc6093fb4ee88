"""Code generation: one intermediate program per model, printed as Python and as C99.

:func:`program` turns a :class:`~.assemble.SymbolicModel` into a :class:`Program` — straight-line
functions of common-subexpression-eliminated assignments, implicit linear blocks and the
chain-rule Jacobian — once; :mod:`.printers` prints it as Python (run by CPython or compiled by
numba) and as C99 (compiled by the machine's C compiler), so that every back end evaluates the same
assignments in the same order. The functions, each taking the time ``t``, the state vector ``x``
(model states then the ledger states E_diss, E_in) and the parameter vector ``p``:

``rhs(t, x, p)``      ẋ, length n + 2
``jac(t, x, p)``      ∂ẋ/∂x, (n + 2) x (n + 2), analytic
``energy(t, x, p)``   [H, P_diss, P_in]
``outputs(t, x, p)``  every named output (port efforts and flows, component and model outputs)
``guards(t, x, p)``   the model's event guards
``initial(p)``        the initial model states (n) from the parameters
``matrix_<k>(t, x, p)`` the named matrices (e.g. mass matrices), in the order of the metadata
``jac_u(t, x, p)``    ∂ẋ/∂u by the model's inputs, (n + 2) x m (models with inputs)
``out_jac(t, x, p)``  ∂y/∂[x, u] of the declared outputs y by the model states and inputs (a
                      program of its own, :func:`output_jacobian_program`: built on demand)
``jac_p(t, x, p)``    ∂ẋ/∂p by the parameters asked for (``program(model, jac_p=[...])``)
``energy_jac(t, x, p)`` ∂H/∂[x, p] by the states and those parameters (with ``jac_p``: the
                      parameter sensitivities' energy ledger at events)
``guard_jac(t, x, p)`` ∂g/∂[x, p] of the event guards by the model states and those parameters
                      (with ``jac_p``: the guard's gradient in the saltation matrix at events)
``outputs_jac(t, x, p)`` ∂y/∂[x, p] of every named output, likewise (with ``jac_p``: outputs'
                      parameter sensitivities, e.g. a gait's step length)
``update_<j>(t, x, p)`` the new discrete states of discrete-time block j at a sampling instant

The parameter vector ``p`` holds the parameters, then two slots per input (:func:`input_slots`):
input k of m is ``u_k(t) = p[P + k] + p[P + m + k] t``, so that the compiled functions and loops
see a bound input (a constant, a held sample, a piece of a linear interpolation) as parameters.

Every Jacobian comes from one algorithm, :func:`jacobian_function`: the derivatives of any
expressions of the model by any of its symbols (states, inputs, parameters), exact, through the
intermediates by the forward chain rule and through the implicit blocks by implicit
differentiation. A new derivative (e.g. ∂ẋ/∂p for parameter sensitivities) is one call of it.

Implicit blocks ``A(t, x, p) v = b(t, x, p)`` (e.g. M(q) q̇ = p of a multibody) are solved
numerically at the top of every function that needs ``v``; in the Jacobian, v's derivative is
``A⁻¹ (∂b/∂x − ∂(A v)/∂x|_v)`` (implicit differentiation), never a symbolic inverse.
Intermediates may read the blocks' unknowns (velocity-level intermediates, e.g. the body twists
of a multibody, and the port-level ones of :mod:`.structure` once their port variables are
solved); the chain rule then adds ∂w/∂v · ∂v/∂x to their rows. Every function's
documentation lists the order of its arguments' and its result's entries by name.

Kernel calls (:mod:`porthamiltonian.modeling.calls`, e.g. a multibody's recursion) are evaluated
once where their outputs are first needed (:class:`Call`); in the Jacobian their outputs' rows
come from the kernel's own tangents (:class:`CallTangent`: the rows of the inputs in, the rows of
the outputs out), between the chain rule's segments before and after them; in such a model only
the intermediates the state equations read get Jacobian rows.
"""
from __future__ import annotations

import bisect
import dataclasses
import functools
import graphlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import sympy as sp
from sympy.core.symbol import Str

from ..errors import CompilerError
from ..mechanics.sources import digest as kernel_digest
from ..modeling.calls import KernelOutput
from ..modeling.differentiation import derivative, free_symbols, remembering
from ..modeling.expressions import TIME
from .assemble import SymbolicModel
from .cse import cse
from .structure import stages

#: Bumped whenever generated code changes meaning; part of the cache key (with a hash of the
#: kernels' templates, which generated modules include or link).
CODEGEN_VERSION = "10." + kernel_digest()


# --- the intermediate program ------------------------------------------------------------------
@dataclass(frozen=True)
class Let:
    """``name = expr``: a scalar local."""

    name: str
    expr: sp.Expr


@dataclass(frozen=True)
class Array:
    """A local float array (the function's result when named ``out``): zero-filled when
    ``zero`` (only its nonzero entries are stored), else every entry is stored."""

    name: str
    shape: tuple[int, ...]
    zero: bool


@dataclass(frozen=True)
class Store:
    """``array[index] = expr``; ``comment``: what the entry is (raw text, e.g. an output's name;
    printers escape it), or empty."""

    array: str
    index: tuple[int, ...]
    expr: sp.Expr
    comment: str = ""


@dataclass(frozen=True)
class Solve:
    """Solve ``A v = b`` (arrays of shape (n, n) and (n,), filled before) into the scalars
    ``targets`` (LU with partial pivoting; closed forms for n <= 2)."""

    A: str
    b: str
    targets: tuple[str, ...]


@dataclass(frozen=True)
class IndexTable:
    """``name``: a constant table of integers."""

    name: str
    values: tuple[int, ...]


@dataclass(frozen=True)
class ChainRule:
    """For k in range(start, stop): ``array[rows[k], :] += coefs[k] * array[cols[k], :]`` — the
    forward chain rule through intermediates, one step per nonzero partial ∂w_m/∂w_j (j < m) in
    row order, as one loop over the index tables ``rows`` and ``cols`` (a compiler builds one
    loop, not one statement per partial); ``coefs`` is a float array, ``array`` has ``ncols``
    columns, of which row ``cols[k]`` is zero outside the columns ``lo[k]`` to ``hi[k] - 1``
    (index tables too: a printer may restrict the row operation to them)."""

    array: str
    coefs: str
    rows: str
    cols: str
    start: int
    stop: int
    ncols: int
    lo: str
    hi: str


@dataclass(frozen=True)
class SparseProduct:
    """``dst += F @ src`` for F of shape ``shape`` given by its nonzero ``entries`` (i, j, expr);
    src and dst have ``ncols`` columns; row j of src is zero outside the columns
    ``ranges[j][0]`` to ``ranges[j][1] - 1`` (a printer may restrict row operations to them)."""

    dst: str
    entries: tuple[tuple[int, int, sp.Expr], ...]
    shape: tuple[int, int]
    src: str
    ncols: int
    ranges: tuple[tuple[int, int], ...]


@dataclass(frozen=True)
class SolveRows:
    """``R = A⁻¹ R`` for A of shape (n, n) and R of shape (n, ncols)."""

    A: str
    R: str
    n: int
    ncols: int


@dataclass(frozen=True)
class KernelInvocation:
    """What every kernel call statement holds: the routine ``entry`` of ``kernel`` on the
    integer ``table``, the ``constants`` and ``inputs`` (expressions), with ``n_outputs``
    outputs; ``label`` names its local arrays. ``keep``: the name of the local that keeps the
    entry's work (it calls ``<entry>_keep``), ``reuse``: the name of such a local of an earlier
    call in the same function that this one reads (it calls ``<entry>_reuse``; see
    :class:`porthamiltonian.modeling.calls.KernelCall`'s ``after``); "" for none."""

    label: str
    kernel: str
    entry: str
    table: tuple[int, ...]
    constants: tuple[sp.Expr, ...]
    inputs: tuple[sp.Expr, ...]
    n_outputs: int
    keep: str = dataclasses.field(default="", kw_only=True)
    reuse: str = dataclasses.field(default="", kw_only=True)


@dataclass(frozen=True)
class Call(KernelInvocation):
    """A kernel call (:mod:`porthamiltonian.modeling.calls`) writing its outputs into the local
    array ``<label>o``, which expressions index."""


@dataclass(frozen=True)
class CallTangent(KernelInvocation):
    """A kernel call with tangents, in the Jacobian: the directions of its inputs are the rows
    ``rows[j]`` — ``("x", i)`` the unit row of variable i (the Jacobian's column i),
    ``(array, m)`` row m of the array (``Dw`` or ``R``), None a zero row —, each ``ncols`` long;
    the derivatives of output k go to row m of ``array`` for every ``(k, array, m)`` of ``into``
    (the other fields as in :class:`KernelInvocation`)."""

    ncols: int
    rows: tuple[tuple[str, int] | None, ...]
    into: tuple[tuple[int, str, int], ...]


Statement = (Let | Array | Store | Solve | IndexTable | ChainRule | SparseProduct | SolveRows | Call
             | CallTangent)


@dataclass(frozen=True)
class Function:
    """One generated function: ``name(*args) -> out`` of shape ``shape``; ``doc`` holds raw
    lines (names from the model: printers escape them for their language). ``aliases``: (name,
    symbol or array entry) of the locals folded into what they equal (a cse'd intermediate
    equal to another local, a state or a parameter): printers print the target wherever the
    name occurs, in place, so that no expression is rebuilt (the order of every sum and product,
    hence every rounding, is the one before the folding)."""

    name: str
    args: tuple[str, ...]
    doc: tuple[str, ...]
    body: tuple[Statement, ...]
    shape: tuple[int, ...]
    aliases: tuple[tuple[str, sp.Expr], ...] = ()


@dataclass(frozen=True)
class Program:
    """A model's generated functions and its layout (``n`` integration states, ``n_params``,
    ``n_guards`` guard slots, ``n_outputs`` output slots; ``header``: raw lines;
    ``unavailable``: (function, why) of the derivatives the model cannot have, e.g. ``out_jac``
    when a declared output reads a kernel output without tangents)."""

    model_name: str
    header: tuple[str, ...]
    functions: tuple[Function, ...]
    n: int
    n_params: int
    n_guards: int
    n_outputs: int
    unavailable: tuple[tuple[str, str], ...] = ()


# --- building ------------------------------------------------------------------------------------
#: ``str`` of a free symbol that is not a plain Symbol (an array entry ``x[0]``, an array ``x``:
#: the printers' array names too), remembered: sympy prints it through its printer every time
_printed = functools.lru_cache(maxsize=1 << 14)(str)


def _names(exprs: Iterable[sp.Expr]) -> set[str]:
    """The names of the symbols and array entries ``exprs`` read, as ``str`` gives them."""
    return {s.name if type(s) is sp.Symbol else _printed(s) for e in exprs for s in free_symbols(e)}


class FunctionBuilder:
    """Builds the functions. The intermediates and block solves (the prologue) are cse'd once and
    shared; each function cse's its own results, then takes in dependency order only the prologue
    nodes it needs, then its result. The cse (:func:`.cse.cse`) also maps the model's symbols to
    the code's names (``mapping``, :func:`symbol_map`) as it rebuilds the expressions."""

    def __init__(self, mapping: dict[sp.Symbol, sp.Expr], model: SymbolicModel,
                 fold: bool = True):
        self.mapping = mapping
        #: fold the pure aliases of every function (:func:`_aliases_folded`)
        self.fold = fold
        #: the derivatives the program's Jacobians took, by (expression, variable): they share
        #: most of them (:func:`jacobian_function`)
        self.derivatives: dict[tuple[sp.Expr, sp.Symbol], sp.Expr] = {}
        regular = [(w, e) for w, e in model.intermediates if not isinstance(e, KernelOutput)]
        pre: list[sp.Expr] = [expr for _, expr in regular]
        for _, A, b in model.blocks:
            pre += list(A) + list(b)
        replacements, reduced = cse(pre, "s", mapping)
        # nodes: (targets, dependencies, statements)
        self.nodes: list[tuple[list[str], set[str], list[Statement]]] = [
            ([str(sym)], _names([expr]), [Let(str(sym), expr)]) for sym, expr in replacements]
        k = 0
        for symbol, _ in regular:
            target = str(mapping[symbol])
            self.nodes.append(([target], _names([reduced[k]]), [Let(target, reduced[k])]))
            k += 1
        #: the kernel calls: name -> (label, mapped constants, mapped inputs, [(index, symbol)])
        self.calls: dict[str, tuple[str, tuple[sp.Expr, ...], tuple[sp.Expr, ...],
                                    list[tuple[int, sp.Symbol]]]] = {}
        #: the calls whose work a later call reuses (:class:`KernelInvocation`)
        self.kept = {call.after for call in model.calls.values() if call.after}
        for name, (inputs, outs) in _call_groups(model).items():
            call = model.calls[name]
            label = f"kern{len(self.calls)}"        # its outputs: kern<i>o[k] (see program)
            constants = tuple(_float(sp.sympify(c).xreplace(mapping)) for c in call.constants)
            args = tuple(_float(sp.sympify(u).xreplace(mapping)) for u in inputs)
            self.calls[name] = (label, constants, args, outs)
            reads = _names(constants + args)
            reuse = ""
            if call.after in self.calls:        # after the call whose work it reuses
                first = self.calls[call.after]
                reuse = f"{first[0]}w"
                reads |= {str(mapping[w]) for _, w in first[3]}
            stmt = Call(label, call.kernel, call.entry, call.table, constants, args,
                        call.n_outputs, keep=f"{label}w" if name in self.kept else "",
                        reuse=reuse)
            self.nodes.append(([str(mapping[w]) for _, w in outs], reads, [stmt]))
        for index, (syms, A, b) in enumerate(model.blocks):
            n = len(syms)
            an, bn = f"A{index}", f"b{index}"
            stmts: list[Statement] = [Array(an, (n, n), True), Array(bn, (n,), False)]
            deps: set[str] = set()
            for i in range(n):
                for j in range(n):
                    if reduced[k] != 0:
                        stmts.append(Store(an, (i, j), reduced[k]))
                        deps |= _names([reduced[k]])
                    k += 1
            for i in range(n):
                stmts.append(Store(bn, (i,), reduced[k]))
                deps |= _names([reduced[k]])
                k += 1
            targets = tuple(str(mapping[s]) for s in syms)
            stmts.append(Solve(an, bn, targets))
            self.nodes.append((list(targets), deps, stmts))
        self.owner = {t: i for i, (targets, _, _) in enumerate(self.nodes) for t in targets}

    def prologue(self, needed: set[str]) -> list[Statement]:
        """The prologue statements that ``needed`` depends on, in dependency order."""
        wanted, stack = set(), [self.owner[n] for n in needed if n in self.owner]
        while stack:
            i = stack.pop()
            if i in wanted:
                continue
            wanted.add(i)
            stack += [self.owner[d] for d in self.nodes[i][1] if d in self.owner]
        order: graphlib.TopologicalSorter[int] = graphlib.TopologicalSorter()
        for i in sorted(wanted):
            order.add(i, *sorted({self.owner[d] for d in self.nodes[i][1] if d in self.owner}))
        return [st for i in order.static_order() for st in self.nodes[i][2]]

    def function(self, name: str, doc: list[str], groups: list[tuple[Any, ...]],
                 shape: tuple[int, ...],
                 args: tuple[str, ...] = ("t", "x", "p")) -> Function:
        """``groups``, in the order of their statements: ("array", array, expressions, shape[,
        labels]) (a matrix's zero entries are not stored; ``labels``: each entry's comment),
        ("entries", array, nonzero entries (i, j, expr), shape) for a matrix that is zero elsewhere, ("product", dst, entries (i, j, expr) of F,
        shape of F, src, ncols, the column range of each row of src) for ``dst += F @ src``, or ("statement", statement) for a
        statement without expressions; every expression is cse'd together. The result is the
        array ``out``."""
        flat = [e for g in groups for e in _expressions(g)]
        replacements, reduced = cse(flat, "c", self.mapping)
        body: list[Statement] = [Let(str(sym), expr) for sym, expr in replacements]
        needed = _names(expr for _, expr in replacements)
        k = 0
        for group in groups:
            kind = group[0]
            if kind == "statement":
                body.append(group[1])
            elif kind == "call":
                body.append(group[1])
                needed |= _names(group[1].constants + group[1].inputs)
            elif kind == "array":
                _, array, exprs, ashape, *labels = group
                names = labels[0] if labels else [""] * len(exprs)
                sparse = len(ashape) == 2
                body.append(Array(array, ashape, sparse))
                for index in range(len(exprs)):
                    expr = reduced[k]
                    k += 1
                    if sparse and expr == 0:
                        continue
                    needed |= _names([expr])
                    body.append(Store(array, divmod(index, ashape[1]) if sparse else (index,),
                                      expr, names[index]))
            else:
                kept = []
                for i, j, _ in group[2]:
                    if reduced[k] != 0:
                        kept.append((i, j, reduced[k]))
                        needed |= _names([reduced[k]])
                    k += 1
                if kind == "entries":
                    body.append(Array(group[1], group[3], True))
                    body += [Store(group[1], (i, j), e) for i, j, e in kept]
                elif kept:
                    _, dst, _, fshape, src, ncols, ranges = group
                    body.append(SparseProduct(dst, tuple(kept), fshape, src, ncols, ranges))
        pre = self.prologue(needed)       # (initial(p) needs only nodes of the parameters)
        statements, aliases = _aliases_folded(pre + body) if self.fold else (pre + body, {})
        return Function(name, args, tuple(doc), tuple(statements), shape,
                        tuple(aliases.items()))


def _aliases_folded(body: list[Statement]) -> tuple[list[Statement], dict[str, sp.Expr]]:
    """``body`` without its pure aliases (``Let(a, b)`` with ``b`` a local, a state, a
    parameter or an entry of an array), and the name each of them stands for (followed through
    chains of aliases): :attr:`Function.aliases`."""
    aliases: dict[str, sp.Expr] = {}
    kept: list[Statement] = []
    for st in body:
        if isinstance(st, Let) and isinstance(st.expr, (sp.Symbol, sp.Indexed)):
            target = st.expr
            while isinstance(target, sp.Symbol) and target.name in aliases:
                target = aliases[target.name]
            aliases[st.name] = target
        else:
            kept.append(st)
    return kept, aliases


def _expressions(group: tuple[Any, ...]) -> list[sp.Expr]:
    """The expressions of a group of :meth:`FunctionBuilder.function`, in the order of its statements."""
    if group[0] in ("statement", "call"):
        return []
    if group[0] == "array":
        return list(group[2])
    return [e for _, _, e in group[2]]


def _float(expr: sp.Expr) -> sp.Expr:
    """Numbers as floats (the arrays a kernel call is handed are of doubles)."""
    return sp.Float(float(expr)) if expr.is_number else expr


def _call_groups(model: SymbolicModel
                 ) -> dict[str, tuple[tuple[sp.Expr, ...], list[tuple[int, sp.Symbol]]]]:
    """Each kernel call of the model's intermediates: name -> (its inputs, [(output index,
    symbol)]) in the order of the intermediates (see :func:`gathered`)."""
    out: dict[str, tuple[tuple[sp.Expr, ...], list[tuple[int, sp.Symbol]]]] = {}
    for w, e in model.intermediates:
        if isinstance(e, KernelOutput):
            out.setdefault(e.call, (e.inputs, []))[1].append((e.index, w))
    return out


def gathered(model: SymbolicModel) -> SymbolicModel:
    """The model with every kernel call's outputs moved to the place of its first output (they
    all read the same inputs, which come before it) and each input that is not a symbol or a
    number made an intermediate of its own just before them (so that it has a Jacobian row); the
    model itself when it has no kernel calls. Idempotent. :func:`symbol_map`,
    :class:`FunctionBuilder` and :func:`jacobian_function` take a model in this form."""
    if not model.calls:
        return model
    groups: dict[str, list[tuple[sp.Symbol, KernelOutput]]] = {}
    for w, e in model.intermediates:
        if isinstance(e, KernelOutput):
            groups.setdefault(e.call, []).append((w, e))
    out: list[tuple[sp.Symbol, sp.Expr]] = []
    placed: set[str] = set()
    for w, e in model.intermediates:
        if not isinstance(e, KernelOutput):
            out.append((w, e))
            continue
        if e.call in placed:
            continue
        placed.add(e.call)
        if any(other.inputs != e.inputs for _, other in groups[e.call]):
            raise CompilerError(f"kernel call {e.call}: its outputs read different inputs")
        inputs = []
        for j, u in enumerate(e.inputs):
            if u.is_Symbol or u.is_number:
                inputs.append(u)
            else:
                symbol = sp.Symbol(f"{e.call}.in{j}", real=True)
                out.append((symbol, u))
                inputs.append(symbol)
        out += [(o, KernelOutput(Str(e.call), sp.Integer(other.index), *inputs))
                for o, other in groups[e.call]]
    return dataclasses.replace(model, intermediates=out)


def _reads(model: SymbolicModel, exprs: list[sp.Expr]) -> set[sp.Symbol]:
    """The intermediates (and other symbols) ``exprs`` read, directly or through intermediates
    and the implicit blocks whose unknowns they read."""
    wanted: set[sp.Symbol] = set()
    for e in exprs:
        wanted |= free_symbols(sp.sympify(e))
    blocks = list(model.blocks)
    while True:
        for w, e in reversed(model.intermediates):
            if w in wanted:
                wanted |= free_symbols(e)
        read = [blk for blk in blocks if set(blk[0]) & wanted]
        if not read:
            return wanted
        blocks = [blk for blk in blocks if not set(blk[0]) & wanted]
        for _, A, b in read:
            wanted |= A.free_symbols | b.free_symbols


def _check_call(model: SymbolicModel, name: str, call_name: str, w: sp.Symbol,
                variables: list[sp.Symbol]) -> None:
    """The Jacobian ``name`` reads ``w``, an output of the kernel call ``call_name``: a
    CompilerError when the call has no tangents or a variable is in its table (see
    :func:`jacobian_function`)."""
    call = model.calls[call_name]
    what = f"the kernel call {call_name} ({call.kernel}.{call.entry})"
    if not call.tangents:
        raise CompilerError(
            f"the derivative {name} of model {model.name!r} needs the derivatives of {w}, an "
            f"output of {what}, which has none: such outputs (e.g. a body's pose) may feed "
            "outputs, guards and matrices only")
    in_table = set().union(*(sp.sympify(c).free_symbols for c in call.constants)) \
        & set(variables)
    if in_table:
        names = ", ".join(sorted(str(v) for v in in_table))
        raise CompilerError(
            f"the derivative {name} of model {model.name!r} by {names} is not available: "
            f"{names} enter(s) the numeric tables of {what} (masses, inertias, joint origins, "
            "points, gravity), through which the kernel has no derivatives; set the "
            "component's formulation = 'symbolic' to differentiate by them")


def jacobian(exprs: list[sp.Expr], variables: list[sp.Symbol],
             memo: dict[tuple[sp.Expr, sp.Symbol], sp.Expr] | None = None
             ) -> list[tuple[int, int, sp.Expr]]:
    """The nonzero entries (i, j, ∂exprs[i]/∂variables[j]), row by row and in column order
    within a row, each expression differentiated only by the variables it contains (``memo``:
    the derivatives found so far, :func:`~porthamiltonian.modeling.differentiation.derivative`)."""
    index = {v: j for j, v in enumerate(variables)}
    out = []
    for i, expr in enumerate(exprs):
        for v in sorted(free_symbols(sp.sympify(expr)) & index.keys(), key=index.__getitem__):
            d = derivative(expr, v, memo)
            if d != 0:
                out.append((i, index[v], d))
    return out


def _padded(exprs: list[sp.Expr]) -> list[sp.Expr]:
    return list(exprs) or [sp.Integer(0)]


def _listing(title: str, names: list[str]) -> list[str]:
    return [title] + [f"  [{i}] {name}" for i, name in enumerate(names)]


def symbol_map(model: SymbolicModel) -> dict[sp.Symbol, sp.Expr]:
    """The model's symbols as generated code names them: states and ledger states ``x[i]``,
    parameters ``p[j]``, input k ``p[P + k] + p[P + m + k]·t`` (:func:`input_slots`), time
    ``t``, intermediates ``w<i>``, the outputs of kernel call i ``kern<i>o[k]`` (read from the
    call's array) and the implicit blocks' unknowns ``v<i>``. ``model``: as :func:`gathered`
    returns it."""
    x = sp.IndexedBase("x")
    p = sp.IndexedBase("p")
    all_states = [*model.states, *model.ledger_states]
    mapping: dict[sp.Symbol, sp.Expr] = {s: x[i] for i, s in enumerate(all_states)}
    mapping.update({s: p[j] for j, s in enumerate(model.params)})
    mapping[TIME] = sp.Symbol("t")
    n_par, n_in = len(model.params), len(model.inputs)
    mapping.update({u: p[n_par + k] + p[n_par + n_in + k] * mapping[TIME]
                    for k, u in enumerate(model.inputs)})
    ws = [w for w, _ in model.intermediates]
    vs = [s for syms, _, _ in model.blocks for s in syms]
    mapping.update({w: sp.Symbol(f"w{i}") for i, w in enumerate(ws)})
    mapping.update({v: sp.Symbol(f"v{i}") for i, v in enumerate(vs)})
    for i, (_, outs) in enumerate(_call_groups(model).values()):   # read from the call's array
        array = sp.IndexedBase(f"kern{i}o")
        mapping.update({w: array[k] for k, w in outs})
    return mapping


def zeros_folded(model: SymbolicModel) -> SymbolicModel:
    """The model without its intermediates that are identically zero (e.g. the out-of-plane
    velocities of a planar walker's feet), each replaced by 0 wherever it is read — in the
    intermediates after it (which may vanish in turn), the blocks, the state equations, the
    energy ledger, the outputs, guards, matrices and discrete updates. Sympy drops the terms
    ``+ 0`` and the products ``0·y``, which leaves every finite result unchanged (the folded
    code adds no zero and multiplies nothing by zero, which only a non-finite y or a signed
    zero could have told apart). Intermediates a kernel call's table reads are kept."""
    pinned = set().union(*(sp.sympify(c).free_symbols for call in model.calls.values()
                           for c in call.constants))
    zero: dict[sp.Basic, sp.Basic] = {}
    kept: list[tuple[sp.Symbol, sp.Expr]] = []
    for w, e in model.intermediates:
        e = e.xreplace(zero) if zero else e
        if e.is_number and e == 0 and w not in pinned:
            zero[w] = sp.S.Zero
        else:
            kept.append((w, e))
    if not zero:
        return model

    def fold(e: Any) -> Any:
        return sp.sympify(e).xreplace(zero)

    return dataclasses.replace(
        model, intermediates=kept, rhs=[fold(e) for e in model.rhs],
        hamiltonian=fold(model.hamiltonian), p_diss=fold(model.p_diss), p_in=fold(model.p_in),
        outputs={k: fold(e) for k, e in model.outputs.items()},
        events=[(ev, fold(g)) for ev, g in model.events],
        initial=[fold(e) for e in model.initial],
        blocks=[(syms, A.xreplace(zero), b.xreplace(zero)) for syms, A, b in model.blocks],
        matrices={k: m.xreplace(zero) for k, m in model.matrices.items()},
        discrete=[(c, period, states, [fold(e) for e in values])
                  for c, period, states, values in model.discrete])


def input_slots(names: list[str]) -> list[str]:
    """The names of the parameter-vector slots of the inputs ``names``: input k of m reads
    u_k(t) = p[P + k] + p[P + m + k] · t (P parameters before them), so that a constant, a
    held sample or one piece of a linear interpolation is bound by setting two numbers
    (:mod:`porthamiltonian.simulation.inputs`)."""
    return [f"{n} (input, at t = 0)" for n in names] + [f"{n} (input, rate)" for n in names]


@remembering
def program(model: SymbolicModel, jac_p: list[str] | None = None, fold: bool = True) -> Program:
    """The model's numeric functions as one intermediate program (see the module docstring).

    ``jac_p``: parameter names whose Jacobian ``jac_p`` (∂ẋ/∂p over those parameters, in that
    order) is generated too, by the chain rule of ``jac``. ``fold``: fold the intermediates that
    are zero (:func:`zeros_folded`) and the pure aliases (:attr:`Function.aliases`); False
    keeps every assignment as the model and cse give it (to check that folding changes no
    result)."""
    model, builder, doc = _prepared(model, fold)
    header, n, n_params, n_guards, n_out = _frame(model)
    all_states = [*model.states, *model.ledger_states]
    state_names = [str(s) for s in all_states]
    params_doc = _params_doc(n_params)
    outputs = list(model.outputs)
    events = [ev.name for ev, _ in model.events]

    n_init = max(len(model.initial), 1)
    initial_summary = (f"The initial state of model {model.name!r} from its parameters: out "
                       f"({n_init}), the model states of x.")
    initial_doc = [initial_summary, params_doc]
    rates = [f"d({name})/dt" for name in state_names]
    functions = [
        builder.function("rhs", doc(f"dx/dt of model {model.name!r}: out[i] = d(x[i])/dt.", []),
                         [("array", "out", model.rhs, (n,), rates)], (n,)),
        jacobian_function(builder, model, "jac", model.rhs, all_states, doc(
            f"The Jacobian of rhs of model {model.name!r}: out[i, j] = d(rhs[i])/d(x[j]), "
            f"{n} x {n}, row-major.", [])),
        builder.function("energy", doc(f"The energy ledger's rates of model {model.name!r}: "
                                       "out = [H, P_diss, P_in].", []),
                         [("array", "out", [model.hamiltonian, model.p_diss, model.p_in], (3,),
                           ["H", "P_diss", "P_in"])], (3,)),
        builder.function("outputs", doc(f"The named outputs of model {model.name!r}, in the "
                                        "order of their comments.", []),
                         [("array", "out", _padded(list(model.outputs.values())), (n_out,),
                           outputs or ["(no outputs)"])], (n_out,)),
        builder.function("guards", doc(f"The event guards of model {model.name!r}, in the order "
                                       "of their comments.", []),
                         [("array", "out", _padded([g for _, g in model.events]), (n_guards,),
                           events or ["(no events)"])], (n_guards,)),
        builder.function("initial", initial_doc,
                         [("array", "out", _padded(model.initial), (n_init,),
                           state_names[:len(model.initial)] or ["(no states)"])], (n_init,),
                         args=("p",)),
    ]
    for k, (name, matrix) in enumerate(model.matrices.items()):
        functions.append(builder.function(
            f"matrix_{k}", doc(f"The matrix {name!r} of model {model.name!r}, "
                               f"{matrix.shape[0]} x {matrix.shape[1]}, row-major.", []),
            [("array", "out", list(matrix), matrix.shape)], tuple(matrix.shape)))
    unavailable: dict[str, str] = {}
    functions += _derivative_functions(builder, model, jac_p or [], doc, unavailable)
    return Program(model.name, header, tuple(functions), n, n_params, n_guards, n_out,
                   tuple(unavailable.items()))


def output_jacobian_program(model: SymbolicModel) -> Program:
    """``out_jac``, the exact ∂y/∂[x, u] of the model's declared outputs y, as a program of its
    own with :func:`program`'s layout (:func:`addon_program`): the add-on of the model's cache
    entry that a first linearization builds (:mod:`porthamiltonian.compiler`), printed as
    :func:`program` printed it among the model's functions (the same builder's prologue and
    steps). The model must declare outputs that its kernels give derivatives of (else
    :func:`program` says why in :attr:`Program.unavailable`)."""
    model, builder, doc = _prepared(model, True)
    return addon_program(model, [_output_jacobian(builder, model, doc)])


def _prepared(model: SymbolicModel, fold: bool
              ) -> tuple[SymbolicModel, FunctionBuilder, Callable[[str, list[str]], list[str]]]:
    """What every program of ``model`` starts from: the model gathered (:func:`gathered`) and,
    with ``fold``, its zero intermediates folded (:func:`zeros_folded`), its
    :class:`FunctionBuilder`, and the maker of a function's docstring lines (a summary, the
    result's lines, then the arguments')."""
    model = gathered(model)
    if fold:
        model = zeros_folded(model)
    builder = FunctionBuilder(symbol_map(model), model, fold)
    _, n, n_params, _, _ = _frame(model)
    args_doc = [f"x: the state ({n}), {_params_doc(n_params)}"]

    def doc(summary: str, result: list[str]) -> list[str]:
        return [summary, *result, *args_doc]
    return model, builder, doc


def _params_doc(n_params: int) -> str:
    return f"p: the parameters ({n_params}), in the layout of the module's header."


def _frame(model: SymbolicModel) -> tuple[tuple[str, ...], int, int, int, int]:
    """What every program of ``model`` shares besides its functions: the header (the state
    and parameter layouts), the number of integration states, of parameter slots, of guard
    slots and of output slots."""
    all_states = [*model.states, *model.ledger_states]
    param_names = [str(s) for s in model.params] + input_slots(model.input_names)
    header = (f"Generated by porthamiltonian for model {model.name!r}. Do not edit.",
              *_listing("State layout x:", [str(s) for s in all_states]),
              *_listing("Parameter layout p:", param_names))
    return (header, len(all_states), len(param_names), max(len(model.events), 1),
            max(len(model.outputs), 1))


def addon_program(model: SymbolicModel, functions: Iterable[Function]) -> Program:
    """A program of ``functions`` alone (an add-on of the model's cache entry, e.g. the
    port-Hamiltonian form's: :mod:`porthamiltonian.compiler`) with the layout of
    :func:`program`'s: the same header and sizes, so that it is printed and called as the
    model's own functions are."""
    header, n, n_params, n_guards, n_out = _frame(model)
    return Program(model.name, header, tuple(functions), n, n_params, n_guards, n_out)


def _derivative_functions(builder: FunctionBuilder, model: SymbolicModel, jac_p: list[str],
                          doc: Callable[[str, list[str]], list[str]],
                          unavailable: dict[str, str]) -> list[Function]:
    """The exact Jacobians beside ``jac``, each by :func:`jacobian_function`: ``jac_u``
    (∂ẋ/∂u, when the model has inputs), ``jac_p`` (∂ẋ/∂p
    over the parameters ``jac_p``) and with it ``energy_jac`` (∂H/∂[x, p] over the states, the
    ledger's included, and those parameters) and ``guard_jac`` (∂g/∂[x, p] of the event guards
    over the model states and those parameters) and ``outputs_jac`` (∂y/∂[x, p] of every named
    output, likewise; each not when one of its expressions reads a kernel output without
    tangents). ``out_jac`` (∂y/∂[x, u] of the declared outputs y) is not among them: it is
    built on demand (:func:`output_jacobian_program`); when one of the declared outputs reads a
    kernel output without tangents (e.g. a kernel multibody's body pose), ``unavailable`` says
    why it cannot be."""
    out: list[Function] = []
    n = len(model.rhs)
    states = list(model.states)
    if model.inputs:
        out.append(jacobian_function(builder, model, "jac_u", model.rhs, model.inputs, doc(
            f"The Jacobian of rhs of model {model.name!r} by its inputs: out[i, k] = "
            f"d(rhs[i])/d(u[k]), {n} x {len(model.inputs)}, row-major.",
            _listing("inputs u:", model.input_names))))
    blocked = _without_tangents(model, [model.outputs[y] for y in model.declared_outputs])
    if blocked:
        unavailable["out_jac"] = (
            f"model {model.name!r}: the declared output(s) "
            f"{', '.join(repr(model.declared_outputs[i]) for i in blocked)} read values that "
            "its kernel evaluates without derivatives (a multibody's body pose), so C and D of "
            "a linearization are not available; declare a point's position "
            "('<multibody>.<point>.x') instead, or set the multibody's formulation = "
            "'symbolic'")
    for j, (component, _, states_j, values) in enumerate(model.discrete):
        out.append(builder.function(f"update_{j}", doc(
            f"The sampling of the discrete-time block {component!r} of model {model.name!r}: "
            "the new values of its discrete states from the state just before the instant.",
            _listing(f"out ({len(values)}):", [str(s) for s in states_j])),
            [("array", "out", values, (len(values),))], (len(values),)))
    if jac_p:
        index = {str(s): s for s in model.params}
        unknown = [name for name in jac_p if name not in index]
        if unknown:
            from ..errors import UnknownParameterError
            raise UnknownParameterError(
                f"model {model.name!r} has no parameter(s) {', '.join(unknown)} for jac_p; "
                f"parameters: {', '.join(index) or 'none'}")
        out.append(jacobian_function(builder, model, "jac_p", model.rhs,
                                     [index[name] for name in jac_p], doc(
            f"The Jacobian of rhs of model {model.name!r} by parameters: out[i, k] = "
            f"d(rhs[i])/d(p[k]), {n} x {len(jac_p)}, row-major.",
            _listing("parameters:", list(jac_p)))))
        all_states = [*model.states, *model.ledger_states]
        out.append(jacobian_function(builder, model, "energy_jac", [model.hamiltonian],
                                     all_states + [index[name] for name in jac_p], doc(
            f"The gradient of the Hamiltonian H of model {model.name!r} by the states and "
            f"parameters: out[0, j] = dH/d([x, p][j]), 1 x {n + len(jac_p)}.",
            _listing("parameters (after the states):", list(jac_p)))))
        variables = states + [index[name] for name in jac_p]
        for fname, what, exprs in (("guard_jac", "event guards g", [g for _, g in model.events]),
                                   ("outputs_jac", "named outputs y", list(model.outputs.values()))):
            if not exprs:
                continue
            if _without_tangents(model, exprs):
                unavailable[fname] = (f"model {model.name!r}: some {what} read values its "
                                      "kernel evaluates without derivatives (a body's pose)")
                continue
            try:
                out.append(jacobian_function(builder, model, fname, exprs, variables, doc(
                    f"The Jacobian of the {what} of model {model.name!r} by the model states "
                    f"and parameters: out[k, j] = d({what[-1]}[k])/d([x, p][j]), {len(exprs)} x "
                    f"{len(variables)}, row-major (not by the time).",
                    _listing("parameters (after the states):", list(jac_p)))))
            except CompilerError as error:     # a parameter in a kernel's table (raised before
                unavailable[fname] = str(error)  # the function is built): differences instead
    return out


def _output_jacobian(builder: FunctionBuilder, model: SymbolicModel,
                     doc: Callable[[str, list[str]], list[str]]) -> Function:
    """``out_jac``: ∂y/∂[x, u] of the declared outputs y by the model states and the inputs
    (:func:`output_jacobian_program`)."""
    ys = [model.outputs[name] for name in model.declared_outputs]
    states = list(model.states)
    return jacobian_function(builder, model, "out_jac", ys, states + model.inputs, doc(
        f"The Jacobian of the declared outputs y of model {model.name!r} by the model "
        f"states and the inputs: out[i, j] = d(y[i])/d([x, u][j]), {len(ys)} x "
        f"{len(states) + len(model.inputs)}, row-major.",
        _listing("outputs y:", model.declared_outputs)))


def _without_tangents(model: SymbolicModel, exprs: list[sp.Expr]) -> list[int]:
    """The indices of ``exprs`` that read (through intermediates) an output of a kernel call
    without tangents."""
    if not model.calls:
        return []
    blocked = {w for w, e in model.intermediates
               if isinstance(e, KernelOutput) and not model.calls[e.call].tangents}
    return [i for i, e in enumerate(exprs) if _reads(model, [e]) & blocked]


def _stage_layout(model: SymbolicModel, rows: list[sp.Symbol]) -> tuple[list[int], list[int]]:
    """The stage of each implicit block and where each stage's run of the Jacobian's ``rows``
    (intermediates of the model, in its order) ends (:func:`.structure.stages`; the compiler
    orders the intermediates by stage): ``ends[s]`` is one past the last row of stage s, for
    s = 0 .. the highest block stage. A row of a lower stage after rows of a higher one (a kernel
    call's input that :func:`gathered` placed beside the call's outputs) is taken in the higher
    stage (its chain rule then comes later, still after everything it reads); a block that reads
    such a row would be solved before it, and raises a CompilerError."""
    defs = dict(model.intermediates)
    _, stage, block_stages = stages(defs, model.blocks)
    top = max(block_stages, default=0)
    ends: list[int] = []
    s = 0
    placed: dict[sp.Symbol, int] = {}
    for k, w in enumerate(rows):
        while stage[w] > s:
            ends.append(k)
            s += 1
        placed[w] = s
    ends += [len(rows)] * (top + 1 - len(ends))
    for (symbols, A, b), block_stage in zip(model.blocks, block_stages):
        late = sorted((str(w) for w in A.free_symbols | b.free_symbols
                       if placed.get(w, 0) >= block_stage), key=str)
        if late:
            raise CompilerError(f"model {model.name!r}: the implicit block {symbols[0]}.. (stage "
                                f"{block_stage}) reads {', '.join(late)}, placed among the "
                                "intermediates of its own or a later stage")
    return block_stages, ends


class _Columns:
    """Which columns (states) each row of the Jacobian's work arrays can be nonzero in, followed
    through the statements of :func:`jacobian_function` in their order (bit j: column j)."""

    def __init__(self, rows: int):
        self.masks = [0] * rows

    def set(self, entries: Iterable[tuple[int, int, sp.Expr]]) -> None:
        for i, j, _ in entries:
            self.masks[i] |= 1 << j

    def add(self, dst: _Columns, entries: Iterable[tuple[int, int, sp.Expr]]) -> None:
        """dst rows += F @ self for F's entries."""
        for i, j, _ in entries:
            dst.masks[i] |= self.masks[j]

    def ranges(self) -> tuple[tuple[int, int], ...]:
        """The column range of each row (:func:`_span`)."""
        return tuple(_span(m) for m in self.masks)


def _span(mask: int) -> tuple[int, int]:
    """(first column set in ``mask``, last + 1); (0, 0) for no column."""
    return ((mask & -mask).bit_length() - 1, mask.bit_length()) if mask else (0, 0)


def jacobian_function(builder: FunctionBuilder, model: SymbolicModel, name: str,
                      exprs: list[sp.Expr],
                      variables: list[sp.Symbol], doc: list[str]) -> Function:
    """The function ``name``: the exact Jacobian ∂exprs/∂variables, ``len(exprs)`` x
    ``len(variables)``, of expressions of the model (its right-hand side, its outputs) by any of
    its symbols — states, inputs, parameters — through intermediates w, implicit blocks A v = b
    and kernel calls, with only the nonzero partials. One algorithm for ``jac`` (by the states),
    ``jac_u`` (by the inputs), ``out_jac`` and ``jac_p`` (by parameters): with z the variables,

    Dw = ∂w/∂z; the chain rule Dw[m] += ∂w_m/∂w_j · Dw[j] (j < m) over the position-level rows,
    in segments between the kernel calls, each of which sets its outputs' rows from its inputs'
    (:class:`CallTangent`: a variable among the call's inputs is a unit row, another symbol a
    zero row); then stage by stage (:func:`_stage_layout`: the blocks of stage s read
    intermediates and unknowns of the stages below): R_s = A_s⁻¹ (∂r_s/∂z + ∂r_s/∂w · Dw
    + Σ_{t<s} ∂r_s/∂v_t · R_t) = ∂v_s/∂z with r_s = b_s − A_s v_s at fixed v_s (implicit
    differentiation); Dw[stage-s rows] += ∂w/∂v_t · R_t (t <= s); the chain rule over the
    stage-s rows (and calls); finally out = ∂e/∂z + ∂e/∂w · Dw + Σ_s ∂e/∂v_s · R_s. A model
    whose blocks are all of stage 1 (a multibody's M(q) v = p) has one R; closed kinematic loops
    add a stage-2 block (their accelerations and multipliers). In a model with kernel calls only
    the intermediates ``exprs`` read get rows. Each row operation is told the columns its source
    row can be nonzero in (a position-level row: the variables it reads; no row: e.g. the ledger
    quadratures).

    The kernel's tangents are by its inputs (states, port efforts), not by its table of
    constants: a variable in a table (a parameter that is a body's mass, a joint's origin, ...)
    raises a CompilerError naming it, as does an output without tangents (a body's pose) that
    ``exprs`` read. ``model``: as :func:`gathered` returns it.
    """
    # with kernel calls (many outputs read by outputs and matrices only), rows only for what
    # exprs read; without, every intermediate (the walkers' code kept as it was)
    reads = _reads(model, exprs) if model.calls else {w for w, _ in model.intermediates}
    memo = builder.derivatives
    rows = [(w, e) for w, e in model.intermediates if w in reads]     # the rows of Dw
    ws = [w for w, _ in rows]
    nrows, ncols, nw = len(exprs), len(variables), len(ws)
    block_stages, ends = _stage_layout(model, ws)
    row_of = {w: m for m, w in enumerate(ws)}
    calls = {w: e for w, e in rows if isinstance(e, KernelOutput)}
    defs = [sp.S.Zero if w in calls else e for w, e in rows]
    barriers: dict[int, str] = {}            # row of a call's first output -> the call
    for m, (w, e) in enumerate(rows):
        if w in calls and e.call not in barriers.values():
            _check_call(model, name, e.call, w, variables)
            barriers[m] = e.call
    groups: list[tuple[Any, ...]] = [("entries", "out", jacobian(exprs, variables, memo),
                                      (nrows, ncols))]
    chain = jacobian(defs, ws, memo)            # (m, j, ∂w_m/∂w_j) by rows: j < m
    chain_rows = [m for m, _, _ in chain]
    dw = _Columns(nw)
    chain_ranges: list[tuple[int, int]] = []
    z_index = {z: i for i, z in enumerate(variables)}
    #: a solved block unknown -> (its stage's array, its row there, that array's columns)
    unknown_at: dict[sp.Symbol, tuple[str, int, _Columns]] = {}

    def chain_rule(start: int, stop: int) -> list[tuple[Any, ...]]:
        for m, j, _ in chain[start:stop]:
            chain_ranges.append(_span(dw.masks[j]))
            dw.masks[m] |= dw.masks[j]
        return [("statement", ChainRule("Dw", "g", "gr", "gc", start, stop, ncols, "glo",
                                        "ghi"))] if stop > start else []

    def tangent(call_name: str) -> list[tuple[Any, ...]]:
        """The call with tangents (none when no input depends on the variables: its outputs'
        rows stay zero, e.g. the state equations' kernel call in ∂/∂u of a model whose input
        reaches no site)."""
        label, constants, inputs, outs = builder.calls[call_name]
        call = model.calls[call_name]
        source = _call_groups(model)[call_name][0]
        rows: list[tuple[str, int] | None] = []
        mask = 0
        for u in source:
            if u in z_index:
                rows.append(("x", z_index[u]))
                mask |= 1 << z_index[u]
            elif u in row_of:
                rows.append(("Dw", row_of[u]))
                mask |= dw.masks[row_of[u]]
            elif u in unknown_at:
                array, i, columns = unknown_at[u]
                rows.append((array, i))
                mask |= columns.masks[i]
            else:
                rows.append(None)
        if not mask:
            return []
        into = tuple((i, "Dw", row_of[w]) for i, w in outs if w in row_of)
        for _, _, m in into:
            dw.masks[m] = mask
        tangents.add(call_name)
        reuse = f"t{builder.calls[call.after][0]}w" if call.after in tangents else ""
        return [("call", CallTangent(f"t{label}", call.kernel, call.entry, call.table, constants,
                                     inputs, call.n_outputs, ncols, tuple(rows), into,
                                     keep=f"t{label}w" if call_name in builder.kept else "",
                                     reuse=reuse))]

    tangents: set[str] = set()              # the calls whose tangents are computed so far

    cursor = done = 0

    def rows_upto(end: int) -> list[tuple[Any, ...]]:
        """The chain rule over the rows not yet done below ``end``, with the kernel calls among
        them in place."""
        nonlocal cursor, done
        out = []
        for m0 in sorted(b for b in barriers if done <= b < end):
            stop = bisect.bisect_left(chain_rows, m0)
            out += chain_rule(cursor, stop)
            out += tangent(barriers[m0])
            cursor = stop
        stop = bisect.bisect_left(chain_rows, end)
        out += chain_rule(cursor, stop)
        cursor, done = stop, max(done, end)
        return out

    if nw:
        entries = jacobian(defs, variables, memo)
        dw.set(entries)
        groups.append(("entries", "Dw", entries, (nw, ncols)))
        groups += rows_upto(ends[0])
    solved: list[tuple[str, list[sp.Symbol], _Columns]] = []     # (array, unknowns, columns)
    for s in range(1, len(ends)):
        members = [blk for blk, st in zip(model.blocks, block_stages) if st == s]
        vs = [v for syms, _, _ in members for v in syms]
        nv = len(vs)
        if nv:
            R, Ab = ("R", "Ab") if s == 1 else (f"R{s}", f"Ab{s}")
            A = sp.diag(*[blk[1] for blk in members])
            b = sp.Matrix.vstack(*[blk[2] for blk in members])
            res = list(b - A * sp.Matrix(vs))
            entries, product = jacobian(res, variables, memo), jacobian(res, ws, memo)
            r = _Columns(nv)
            r.set(entries)
            dw_ranges = dw.ranges()
            dw.add(r, product)
            earlier = [(array, jacobian(res, prior, memo), prior, prior_cols)
                       for array, prior, prior_cols in solved]
            for _, part, _, prior_cols in earlier:
                prior_cols.add(r, part)
            union = 0
            for m in r.masks:
                union |= m
            r.masks = [union] * nv                  # the solve mixes the rows
            groups += [("entries", R, entries, (nv, ncols)),
                       ("array", Ab, list(A), (nv, nv)),
                       ("product", R, product, (nv, nw), "Dw", ncols, dw_ranges)]
            groups += [("product", R, part, (nv, len(prior)), array, ncols, prior_cols.ranges())
                       for array, part, prior, prior_cols in earlier]
            groups.append(("statement", SolveRows(Ab, R, nv, ncols)))
            solved.append((R, vs, r))
            unknown_at.update((v, (R, i, r)) for i, v in enumerate(vs))
        lo, hi = ends[s - 1], ends[s]
        for array, vs_t, r_t in solved:
            velocity = [(lo + i, j, e) for i, j, e in jacobian(defs[lo:hi], vs_t, memo)]
            groups.append(("product", "Dw", velocity, (nw, len(vs_t)), array, ncols,
                           r_t.ranges()))
            r_t.add(dw, velocity)
        groups += rows_upto(hi)
    groups += rows_upto(nw)
    groups.append(("product", "out", jacobian(exprs, ws, memo), (nrows, nw), "Dw", ncols,
                   dw.ranges()))
    groups += [("product", "out", jacobian(exprs, vs_t, memo), (nrows, len(vs_t)), array, ncols,
                r_t.ranges()) for array, vs_t, r_t in solved]
    if chain:
        groups[1:1] = [("array", "g", [e for _, _, e in chain], (len(chain),)),
                       ("statement", IndexTable("gr", tuple(m for m, _, _ in chain))),
                       ("statement", IndexTable("gc", tuple(j for _, j, _ in chain))),
                       ("statement", IndexTable("glo", tuple(lo for lo, _ in chain_ranges))),
                       ("statement", IndexTable("ghi", tuple(hi for _, hi in chain_ranges)))]
    return builder.function(name, doc, groups, (nrows, ncols))


__all__ = ["CODEGEN_VERSION", "Array", "Call", "CallTangent", "ChainRule", "Function",
           "IndexTable", "KernelInvocation", "Let", "Program", "Solve", "SolveRows",
           "SparseProduct", "Statement", "Store", "addon_program", "derivative", "gathered",
           "input_slots", "jacobian", "jacobian_function", "program", "symbol_map",
           "zeros_folded"]
