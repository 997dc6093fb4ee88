"""Code generation: common-subexpression elimination and printing of straight-line Python source.

The generated module defines, each taking the time ``t``, the state vector ``x`` (model states
then the ledger states E_diss, E_in) and the parameter vector ``p``:

``rhs(t, x, p)``      ẋ, length n + 2
``jac(t, x, p)``      ∂ẋ/∂x, (n + 2) x (n + 2), analytic
``energy(t, x, p)``   [H, P_diss, P_in]
``outputs(t, x, p)``  every named output (port efforts and flows, component and model outputs)
``guards(t, x, p)``   the model's event guards
``initial(p)``        the initial model states (n) from the parameters
``matrix_<k>(t, x, p)`` the named matrices (e.g. mass matrices), in the order of the metadata

Implicit blocks ``A(t, x, p) v = b(t, x, p)`` (e.g. M(q) q̇ = p of a multibody) are solved
numerically at the top of every function that needs ``v``; in the Jacobian, v's derivative is
``A⁻¹ (∂b/∂x − ∂(A v)/∂x|_v)`` (implicit differentiation), never a symbolic inverse.
Intermediates may read the blocks' unknowns (velocity-level intermediates, e.g. the body twists
of a multibody); the chain rule then adds ∂w/∂v · ∂v/∂x to their rows.

The source uses only ``math``, ``numpy`` array creation, ``np.linalg.solve`` and indexing, so the
same text runs as plain Python (the reference back end) and under ``numba.njit`` (the compiled back
end). The layout of ``x`` and ``p`` is written in the module docstring.
"""
from __future__ import annotations

import graphlib

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from ..expressions import TIME
from .assemble import SymbolicModel
from .literals import python_docstring

#: Bumped whenever generated code changes meaning; part of the cache key.
CODEGEN_VERSION = "3"


class _Printer(PythonCodePrinter):
    def __init__(self):
        # order "none": terms as sympy holds them, not re-sorted for display (4x faster printing)
        super().__init__({"standard": "python3", "fully_qualified_modules": True, "order": "none"})

    def _print_Float(self, expr):
        return repr(float(expr))

    def _print_Heaviside(self, expr):
        # H(x) with H(0) = 1/2 (sympy's default), as a conditional expression
        x = self._print(expr.args[0])
        return f"(1.0 if {x} > 0 else (0.5 if {x} == 0 else 0.0))"

    def _print_DiracDelta(self, expr):
        # derivatives of Abs/sign/Heaviside: zero almost everywhere (the jump itself is an event)
        return "0.0"


class _Writer:
    """Writes the generated functions. The intermediates and block solves (the prologue) are
    cse'd once and shared; each function cse's its own outputs, then emits in dependency order
    only the prologue nodes it needs, then its output arrays."""

    def __init__(self, mapping: dict[sp.Symbol, sp.Expr], model: SymbolicModel, printer: _Printer):
        self.mapping = mapping
        self.printer = printer
        pr = printer.doprint
        pre: list[sp.Expr] = [expr for _, expr in model.intermediates]
        for _, A, b in model.blocks:
            pre += list(A) + list(b)
        pre = [sp.sympify(e).xreplace(mapping) for e in pre]
        replacements, reduced = sp.cse(pre, symbols=sp.numbered_symbols("_p"), order="none")
        # assignment nodes: (target names, dependencies, lines)
        self.nodes: list[tuple[list[str], set[str], list[str]]] = [
            ([str(sym)], {str(s) for s in expr.free_symbols}, [f"    {sym} = {pr(expr)}"])
            for sym, expr in replacements]
        k = 0
        for symbol, _ in model.intermediates:
            target = str(mapping[symbol])
            self.nodes.append(([target], {str(s) for s in reduced[k].free_symbols},
                               [f"    {target} = {pr(reduced[k])}"]))
            k += 1
        for index, (syms, A, b) in enumerate(model.blocks):
            n = len(syms)
            lines = [f"    _A{index} = np.empty(({n}, {n}))", f"    _b{index} = np.empty({n})"]
            deps: set[str] = set()
            for i in range(n):
                for j in range(n):
                    lines.append(f"    _A{index}[{i}, {j}] = {pr(reduced[k])}")
                    deps |= {str(s) for s in reduced[k].free_symbols}
                    k += 1
            for i in range(n):
                lines.append(f"    _b{index}[{i}] = {pr(reduced[k])}")
                deps |= {str(s) for s in reduced[k].free_symbols}
                k += 1
            targets = [str(mapping[s]) for s in syms]
            if n == 1:   # small systems in closed form: no LAPACK call per evaluation
                lines.append(f"    {targets[0]} = _b{index}[0] / _A{index}[0, 0]")
            elif n == 2:
                a, b = f"_A{index}", f"_b{index}"
                lines.append(f"    _det{index} = {a}[0, 0] * {a}[1, 1] - {a}[0, 1] * {a}[1, 0]")
                lines.append(f"    {targets[0]} = ({b}[0] * {a}[1, 1] - {a}[0, 1] * {b}[1]) / _det{index}")
                lines.append(f"    {targets[1]} = ({a}[0, 0] * {b}[1] - {b}[0] * {a}[1, 0]) / _det{index}")
            else:
                lines.append(f"    _s{index} = np.linalg.solve(_A{index}, _b{index})")
                lines += [f"    {t} = _s{index}[{i}]" for i, t in enumerate(targets)]
            self.nodes.append((targets, deps, lines))
        self.owner = {t: i for i, (targets, _, _) in enumerate(self.nodes) for t in targets}

    def function(self, name: str, args: str, groups: list[tuple], tail: list[str] | None = None,
                 prologue: bool = True, result: str | None = None) -> str:
        """``groups``: ("array", name, flat expressions, shape), ("scalars", names, exprs) or
        ("sparse", name, expressions, shape, their (i, j) indices) for a matrix that is zero
        elsewhere. ``tail``: extra lines before ``return result`` (default: the first group)."""
        pr = self.printer.doprint
        flat = [sp.sympify(e).xreplace(self.mapping) for g in groups for e in g[2]]
        replacements, reduced = sp.cse(flat, symbols=sp.numbered_symbols("_c"), order="none")
        local = [f"    {sym} = {pr(expr)}" for sym, expr in replacements]
        needed = {str(s) for _, expr in replacements for s in expr.free_symbols}
        body: list[str] = []
        k = 0
        for group in groups:
            kind, gname, exprs = group[0], group[1], group[2]
            if kind in ("array", "sparse"):
                shape = group[3]
                if len(shape) == 2:
                    body.append(f"    {gname} = np.zeros(({shape[0]}, {shape[1]}))")
                else:
                    body.append(f"    {gname} = np.empty({shape[0]})")
            for index in range(len(exprs)):
                expr = reduced[k]
                k += 1
                needed |= {str(s) for s in expr.free_symbols}
                if kind == "scalars":
                    body.append(f"    {gname[index]} = {pr(expr)}")
                elif kind == "sparse":
                    i, j = group[4][index]
                    body.append(f"    {gname}[{i}, {j}] = {pr(expr)}")
                elif len(group[3]) == 2:
                    i, j = divmod(index, group[3][1])
                    if expr != 0:
                        body.append(f"    {gname}[{i}, {j}] = {pr(expr)}")
                else:
                    body.append(f"    {gname}[{index}] = {pr(expr)}")
        pre_lines: list[str] = []
        if prologue:
            wanted, stack = set(), [self.owner[n] for n in needed if n in self.owner]
            while stack:
                i = stack.pop()
                if i in wanted:
                    continue
                wanted.add(i)
                stack += [self.owner[d] for d in self.nodes[i][1] if d in self.owner]
            order = graphlib.TopologicalSorter()
            for i in sorted(wanted):
                order.add(i, *sorted({self.owner[d] for d in self.nodes[i][1] if d in self.owner}))
            for i in order.static_order():
                pre_lines += self.nodes[i][2]
        lines = [f"def {name}({args}):", *pre_lines, *local, *body, *(tail or [])]
        lines.append(f"    return {result or groups[0][1]}")
        return "\n".join(lines)


def derivative(expr: sp.Expr, v: sp.Symbol) -> sp.Expr:
    """∂expr/∂v: sums, products and numeric powers by hand (the bulk of generated expressions,
    about ten times faster than sympy's general ``diff``), anything else by ``sympy.diff``."""
    if expr == v:
        return sp.S.One
    if v not in expr.free_symbols:
        return sp.S.Zero
    if expr.is_Add:
        return sp.Add(*[derivative(a, v) for a in expr.args if v in a.free_symbols])
    if expr.is_Mul:
        args, terms = expr.args, []
        for i, a in enumerate(args):
            if v in a.free_symbols:
                d = derivative(a, v)
                if d != 0:
                    terms.append(sp.Mul(*args[:i], d, *args[i + 1:]))
        return sp.Add(*terms)
    if expr.is_Pow and expr.exp.is_Number:
        return expr.exp * expr.base ** (expr.exp - 1) * derivative(expr.base, v)
    return sp.diff(expr, v)


def jacobian(exprs: sp.Matrix, variables: list[sp.Symbol]) -> sp.Matrix:
    """∂exprs/∂variables, differentiating each entry only by the variables it contains."""
    index = {v: j for j, v in enumerate(variables)}
    out = sp.zeros(exprs.shape[0], len(variables))
    for i, expr in enumerate(exprs):
        for v in expr.free_symbols:
            if v in index:
                out[i, index[v]] = derivative(expr, v)
    return out


def _padded(exprs: list[sp.Expr]) -> list[sp.Expr]:
    return list(exprs) or [sp.Integer(0)]


def generate(model: SymbolicModel) -> str:
    """Python source (without back-end header) of the model's numeric functions."""
    printer = _Printer()
    x = sp.IndexedBase("x")
    p = sp.IndexedBase("p")
    all_states = [*model.states, *model.ledger_states]
    mapping: dict[sp.Symbol, sp.Expr] = {s: x[i] for i, s in enumerate(all_states)}
    mapping.update({s: p[j] for j, s in enumerate(model.params)})
    mapping[TIME] = sp.Symbol("t")
    ws = [w for w, _ in model.intermediates]
    vs = [s for syms, _, _ in model.blocks for s in syms]
    mapping.update({w: sp.Symbol(f"_w{i}") for i, w in enumerate(ws)})
    mapping.update({v: sp.Symbol(f"_v{i}") for i, v in enumerate(vs)})
    writer = _Writer(mapping, model, printer)
    n = len(all_states)
    rhs = sp.Matrix(model.rhs)
    header = [(f'"""Generated by porthamiltonian for model {python_docstring(repr(model.name))}. '
               "Do not edit."), "", "State layout x:"]
    header += [f"  x[{i}] = {python_docstring(str(s))}" for i, s in enumerate(all_states)]
    header += ["Parameter layout p:"] + [f"  p[{j}] = {python_docstring(str(s))}"
                                         for j, s in enumerate(model.params)]
    header += ['"""']
    parts = ["\n".join(header), writer.function("rhs", "t, x, p", [("array", "out", model.rhs, (n,))])]
    parts.append(_jacobian_function(writer, model, rhs, all_states, ws, vs))
    parts += [
        writer.function("energy", "t, x, p", [("array", "out", [model.hamiltonian, model.p_diss,
                                                                  model.p_in], (3,))]),
        writer.function("outputs", "t, x, p", [("array", "out", _padded(list(model.outputs.values())),
                                                  (max(len(model.outputs), 1),))]),
        writer.function("guards", "t, x, p", [("array", "out", _padded([g for _, g in model.events]),
                                                 (max(len(model.events), 1),))]),
        writer.function("initial", "p", [("array", "out", _padded(model.initial),
                                            (max(len(model.initial), 1),))], prologue=False),
    ]
    for k, (name, matrix) in enumerate(model.matrices.items()):
        parts.append(writer.function(f"matrix_{k}", "t, x, p",
                                     [("array", "out", list(matrix), matrix.shape)]))
    return "\n\n\n".join(parts) + "\n"


def _jacobian_function(writer: _Writer, model: SymbolicModel, rhs: sp.Matrix, xs, ws, vs) -> str:
    """∂ẋ/∂x through intermediates w (forward chain rule, row by row with only the nonzero
    partials) and implicit blocks A v = b (v' = A⁻¹ ∂(b − A v)/∂x, v held fixed).

    Intermediates come ordered, those of states only first (A and b use only these), then
    those that also read the blocks' unknowns v (e.g. body twists); the latter's rows of ∂w/∂x
    receive ∂w/∂v · v' once v' is known."""
    n, nw, nv = len(xs), len(ws), len(vs)
    if not ws and not vs:
        return writer.function("jac", "t, x, p", [("array", "out", list(jacobian(rhs, xs)), (n, n))])
    npos = _position_level(model, vs)
    if npos < nw:
        return _jacobian_with_velocity_intermediates(writer, model, rhs, xs, ws, vs, npos)
    groups: list[tuple] = [("array", "_Fx", list(jacobian(rhs, xs)), (n, n))]
    tail: list[str] = []
    if nw:
        defs = sp.Matrix([expr for _, expr in model.intermediates])
        Gw = jacobian(defs, ws)
        chain = [(m, j) for m in range(nw) for j in range(nw) if Gw[m, j] != 0]
        groups += [("array", "_Fw", list(jacobian(rhs, ws)), (n, nw)),
                   ("array", "_Gx", list(jacobian(defs, xs)), (nw, n)),
                   ("scalars", [f"_g{m}_{j}" for m, j in chain], [Gw[m, j] for m, j in chain])]
        tail.append("    _Dw = _Gx")
        for m, j in chain:  # rows in order: _Dw[j] is final before it is used (j < m)
            tail.append(f"    _Dw[{m}, :] += _g{m}_{j} * _Dw[{j}, :]")
        tail.append("    out = _Fx + _Fw @ _Dw")
    else:
        tail.append("    out = _Fx")
    if nv:
        A = sp.diag(*[blk[1] for blk in model.blocks])
        b = sp.Matrix.vstack(*[blk[2] for blk in model.blocks])
        res = b - A * sp.Matrix(vs)
        groups += [("array", "_Fv", list(jacobian(rhs, vs)), (n, nv)),
                   ("array", "_Bx", list(jacobian(res, xs)), (nv, n)),
                   ("array", "_Ab", list(A), (nv, nv))]
        if nw:
            groups.append(("array", "_Bw", list(jacobian(res, ws)), (nv, nw)))
            tail.append("    _R = _Bx + _Bw @ _Dw")
        else:
            tail.append("    _R = _Bx")
        tail.append("    out = out + _Fv @ np.linalg.solve(_Ab, _R)")
    return writer.function("jac", "t, x, p", groups, tail=tail, result="out")


def _position_level(model: SymbolicModel, vs: list[sp.Symbol]) -> int:
    """How many leading intermediates depend on no block unknown (directly or through others)."""
    reads_v = set(vs)
    for k, (symbol, expr) in enumerate(model.intermediates):
        if expr.free_symbols & reads_v:
            return k
    return len(model.intermediates)


def _sparse_jacobian(exprs: list, variables: list[sp.Symbol]) -> tuple[list, list]:
    """The nonzero entries of ∂exprs/∂variables as (expressions, (i, j) indices), each entry
    differentiated only by the variables it contains."""
    index = {v: j for j, v in enumerate(variables)}
    values, where = [], []
    for i, expr in enumerate(exprs):
        for v in sorted(sp.sympify(expr).free_symbols & index.keys(), key=index.get):
            d = derivative(expr, v)
            if d != 0:
                values.append(d)
                where.append((i, index[v]))
    return values, where


def _jacobian_with_velocity_intermediates(writer: _Writer, model: SymbolicModel, rhs: sp.Matrix,
                                          xs, ws, vs, npos: int) -> str:
    """The Jacobian when intermediates ``ws[npos:]`` read the block unknowns: the chain rule over
    the position-level rows, then v' = A⁻¹ (∂b/∂x − ∂(A v)/∂x) from those, then the
    velocity-level rows with ∂w/∂v · v' added before their own chain terms. The partials with
    respect to intermediates are sparse (each intermediate reads a few others) and are formed
    and written entry by entry."""
    n, nw, nv = len(xs), len(ws), len(vs)
    defs = [expr for _, expr in model.intermediates]
    A = sp.diag(*[blk[1] for blk in model.blocks])
    b = sp.Matrix.vstack(*[blk[2] for blk in model.blocks])
    res = list(b - A * sp.Matrix(vs))

    def sparse(name: str, exprs: list, variables: list, shape: tuple) -> tuple:
        values, where = _sparse_jacobian(exprs, variables)
        return ("sparse", name, values, shape, where)

    chain_values, chain = _sparse_jacobian(defs, ws)        # (m, j) by rows: j < m
    groups: list[tuple] = [
        ("array", "_Fx", list(jacobian(rhs, xs)), (n, n)),
        sparse("_Fw", list(rhs), ws, (n, nw)),
        ("array", "_Fv", list(jacobian(rhs, vs)), (n, nv)),
        sparse("_Gx", defs, xs, (nw, n)),
        sparse("_Gv", defs[npos:], vs, (nw - npos, nv)),
        ("array", "_Bx", list(jacobian(sp.Matrix(res), xs)), (nv, n)),
        ("array", "_Ab", list(A), (nv, nv)),
    ]
    if npos:
        groups.append(sparse("_Bw", res, ws[:npos], (nv, npos)))
    # the chain rule Dw[m] += ∂w_m/∂w_j · Dw[j], row by row, as one loop over index tables (a
    # compiled back end then builds one loop, not one array statement per partial)
    tail = ["    _Dw = _Gx"]
    npre = sum(1 for m, _ in chain if m < npos)
    if chain:
        groups.append(("array", "_gv", chain_values, (len(chain),)))
        tail += [f"    _cr = np.array({[m for m, _ in chain]})",
                 f"    _cc = np.array({[j for _, j in chain]})"]
    update = ["        _Dw[_cr[_k], :] += _gv[_k] * _Dw[_cc[_k], :]"]
    if npre:
        tail += [f"    for _k in range({npre}):", *update]
    tail.append(f"    _Vx = np.linalg.solve(_Ab, _Bx + _Bw @ _Dw[:{npos}, :])"
                if npos else "    _Vx = np.linalg.solve(_Ab, _Bx)")
    tail.append(f"    _Dw[{npos}:, :] += _Gv @ _Vx")
    if len(chain) > npre:
        tail += [f"    for _k in range({npre}, {len(chain)}):", *update]
    tail.append("    out = _Fx + _Fw @ _Dw + _Fv @ _Vx")
    return writer.function("jac", "t, x, p", groups, tail=tail, result="out")
