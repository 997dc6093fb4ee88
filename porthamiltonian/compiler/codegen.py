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

The source uses only ``math``, ``numpy`` array creation, ``np.linalg.solve`` and indexing, so the
same text runs as plain Python (the reference back end) and under ``numba.njit`` (the compiled back
end). The layout of ``x`` and ``p`` is written in the module docstring.
"""
from __future__ import annotations

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from ..expressions import TIME
from .assemble import SymbolicModel

#: Bumped whenever generated code changes meaning; part of the cache key.
CODEGEN_VERSION = "2"


class _Printer(PythonCodePrinter):
    def __init__(self):
        super().__init__({"standard": "python3", "fully_qualified_modules": True})

    def _print_Float(self, expr):
        return repr(float(expr))


class _Writer:
    """Writes one generated function: cse'd assignments, block solves, array stores."""

    def __init__(self, mapping: dict[sp.Symbol, sp.Expr], blocks, printer: _Printer):
        self.mapping = mapping
        self.blocks = blocks
        self.printer = printer
        self.block_symbols = {s for syms, _, _ in blocks for s in syms}

    def function(self, name: str, args: str, groups: list[tuple[str, list[sp.Expr], tuple]],
                 tail: list[str] | None = None, with_blocks: bool = True) -> str:
        """``groups``: (array name, flat expressions, shape); ``tail``: extra lines before return."""
        blocks = self.blocks if with_blocks else []
        prologue: list[sp.Expr] = []
        for _, A, b in blocks:
            prologue += list(A) + list(b)
        flat = prologue + [e for _, exprs, _ in groups for e in exprs]
        flat = [sp.sympify(e).xreplace(self.mapping) for e in flat]
        replacements, reduced = sp.cse(flat, symbols=sp.numbered_symbols("_c"), order="none")
        lines = [f"def {name}({args}):"]
        # replacements that do not depend on block unknowns go before the solves
        late = {self.mapping[s] for s in self.block_symbols if s in self.mapping}
        before, after = [], []
        for sym, expr in replacements:
            (after if expr.free_symbols & late else before).append((sym, expr))
            if expr.free_symbols & late:
                late.add(sym)
        lines += [f"    {s} = {self.printer.doprint(e)}" for s, e in before]
        k = 0
        for index, (syms, A, b) in enumerate(blocks):
            n = len(syms)
            lines.append(f"    _A{index} = np.empty(({n}, {n}))")
            lines.append(f"    _b{index} = np.empty({n})")
            for i in range(n):
                for j in range(n):
                    lines.append(f"    _A{index}[{i}, {j}] = {self.printer.doprint(reduced[k])}")
                    k += 1
            for i in range(n):
                lines.append(f"    _b{index}[{i}] = {self.printer.doprint(reduced[k])}")
                k += 1
            lines.append(f"    _v{index} = np.linalg.solve(_A{index}, _b{index})")
            for i, s in enumerate(syms):
                lines.append(f"    {self.printer.doprint(self.mapping[s])} = _v{index}[{i}]")
        lines += [f"    {s} = {self.printer.doprint(e)}" for s, e in after]
        for array, exprs, shape in groups:
            if len(shape) == 2:
                lines.append(f"    {array} = np.zeros(({shape[0]}, {shape[1]}))")
            else:
                lines.append(f"    {array} = np.empty({shape[0]})")
            for index in range(len(exprs)):
                expr = reduced[k]
                k += 1
                if len(shape) == 2:
                    i, j = divmod(index, shape[1])
                    if expr != 0:
                        lines.append(f"    {array}[{i}, {j}] = {self.printer.doprint(expr)}")
                else:
                    lines.append(f"    {array}[{index}] = {self.printer.doprint(expr)}")
        lines += tail or []
        lines.append(f"    return {groups[0][0] if not tail else 'out'}")
        return "\n".join(lines)


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
    block_syms = [s for syms, _, _ in model.blocks for s in syms]
    mapping.update({s: sp.Symbol(f"_w{i}") for i, s in enumerate(block_syms)})
    writer = _Writer(mapping, model.blocks, printer)
    n = len(all_states)
    rhs = sp.Matrix(model.rhs)
    header = ['"""Generated by porthamiltonian for model %r. Do not edit.' % model.name, "",
              "State layout x:"]
    header += [f"  x[{i}] = {s}" for i, s in enumerate(all_states)]
    header += ["Parameter layout p:"] + [f"  p[{j}] = {s}" for j, s in enumerate(model.params)]
    header += ['"""']
    parts = ["\n".join(header), writer.function("rhs", "t, x, p", [("out", model.rhs, (n,))])]
    if block_syms:
        nv = len(block_syms)
        A = sp.diag(*[blk[1] for blk in model.blocks])
        b = sp.Matrix.vstack(*[blk[2] for blk in model.blocks])
        v = sp.Matrix(block_syms)
        dres = b.jacobian(all_states) - (A * v).jacobian(all_states)   # v held fixed
        parts.append(writer.function("jac", "t, x, p", [
            ("_Fx", list(rhs.jacobian(all_states)), (n, n)),
            ("_Fv", list(rhs.jacobian(v)), (n, nv)),
            ("_Rb", list(dres), (nv, n)),
            ("_Ab", list(A), (nv, nv)),
        ], tail=["    out = _Fx + _Fv @ np.linalg.solve(_Ab, _Rb)"]))
    else:
        parts.append(writer.function("jac", "t, x, p", [("out", list(rhs.jacobian(all_states)),
                                                         (n, n))]))
    parts += [
        writer.function("energy", "t, x, p", [("out", [model.hamiltonian, model.p_diss,
                                                       model.p_in], (3,))]),
        writer.function("outputs", "t, x, p", [("out", _padded(list(model.outputs.values())),
                                                    (max(len(model.outputs), 1),))]),
        writer.function("guards", "t, x, p", [("out", _padded([g for _, g in model.events]),
                                                   (max(len(model.events), 1),))]),
        writer.function("initial", "p", [("out", _padded(model.initial),
                                              (max(len(model.initial), 1),))], with_blocks=False),
    ]
    for k, (name, matrix) in enumerate(model.matrices.items()):
        parts.append(writer.function(f"matrix_{k}", "t, x, p",
                                     [("out", list(matrix), matrix.shape)]))
    return "\n\n\n".join(parts) + "\n"
