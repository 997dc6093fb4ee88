"""Printing of a :class:`~.codegen.Program` as Python (python and numba back ends) and as C99.

Both printers give the language's constructs the same meaning:

* ``Heaviside(x)`` is 1 for x > 0, 1/2 at 0 (sympy's default, or the given H(0)), 0 for x < 0;
* ``sign(x)`` is 0 when x == 0, else copysign(1, x) (so −1 or +1, also for NaN by its sign bit);
* ``Min``/``Max`` fold left as Python's ``min``/``max`` do (``b if b < a else a``), NaNs
  included; ``Mod`` is Python's floored ``%`` of floats;
* ``Piecewise`` takes the first true condition (NaN when none is; the parser always ends with
  ``True``);
* ``DiracDelta`` (derivatives of Heaviside, sign, Abs) is 0: a jump is an event, not an impulse;
* floats are printed exactly (``repr``), π and e as their double values;
* sums and products keep sympy's order of terms (no re-sorting for display), so both languages
  evaluate them in the same order.

Names from the model (the docstrings and comments listing states, parameters and outputs) are
escaped by :mod:`.literals`. The C translation unit uses only C99 and ``<math.h>``.
"""
from __future__ import annotations

import math
import re
from collections.abc import Callable

import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.precedence import PRECEDENCE, PRECEDENCE_FUNCTIONS, PRECEDENCE_VALUES
from sympy.printing.pycode import PythonCodePrinter

from ..backends.native import FUNCTION_MARK, FUNCTIONS_END, LOOP_FUNCTIONS
from ..mechanics.sources import c_declarations, python_template
from .codegen import (
    Array,
    Call,
    CallTangent,
    ChainRule,
    Function,
    IndexTable,
    Let,
    Program,
    Solve,
    SolveRows,
    SparseProduct,
    Statement,
    Store,
    _printed,
)
from .literals import c_comment, printable, python_docstring

_C_STACK_DOUBLES = 16384  # larger local arrays go to the heap (thread stacks are small)


def _float(value: float) -> str:
    if math.isnan(value):
        return "NAN"
    if math.isinf(value):
        return "INFINITY" if value > 0 else "(-INFINITY)"
    return repr(value)


def _mul_precedence(item: sp.Basic) -> int:
    """sympy's ``precedence_Mul`` without ``could_extract_minus_sign``, which builds ``-item``
    to compare it with ``item`` (only a ``zoo`` factor makes them equal: not a product the
    compiler prints): a product with a negative number first prints with a leading minus."""
    if any(hasattr(arg, "precedence") and isinstance(arg, sp.Function)
           and arg.precedence < PRECEDENCE["Mul"] for arg in item.args):
        return int(PRECEDENCE["Mul"])
    c = item.args[0]
    return int(PRECEDENCE["Add"] if c.is_Number and c.is_extended_negative else PRECEDENCE["Mul"])


#: each expression type's precedence rule, found once (sympy's ``precedence`` walks the type's
#: MRO at every call): a constant, or a function of the expression
_PRECEDENCE_RULES: dict[type, int | Callable[[sp.Basic], int]] = {}


def _precedence(item: sp.Basic) -> int:
    """sympy's ``precedence(item)``, its rule cached by type (:func:`_mul_precedence` for
    products)."""
    if hasattr(item, "precedence"):
        return int(item.precedence)
    rule = _PRECEDENCE_RULES.get(type(item))
    if rule is None:
        rule = PRECEDENCE["Atom"]
        for cls in type(item).mro():
            if cls.__name__ == "Mul":
                rule = _mul_precedence
            elif cls.__name__ in PRECEDENCE_FUNCTIONS:
                rule = PRECEDENCE_FUNCTIONS[cls.__name__]
            elif cls.__name__ in PRECEDENCE_VALUES:
                rule = PRECEDENCE_VALUES[cls.__name__]
            else:
                continue
            break
        _PRECEDENCE_RULES[type(item)] = rule
    return rule if isinstance(rule, int) else rule(item)


class _Direct:
    """Printing of one expression at a time without sympy's overheads, to the same text:
    ``doprint`` is ``_print`` (sympy's ``CodePrinter.doprint`` first rebuilds the whole
    expression, ``replace`` of ``re`` around unevaluated expressions, which the compiler never
    builds, then formats the line; together as long as the printing itself); ``parenthesize``
    and ``_print_Add`` are sympy's (``StrPrinter``) with :func:`_precedence`. Anything
    ``_print`` does not give as one line with no number constant to declare (``_print_Pi``,
    ``_print_Exp1`` print theirs inline) goes to sympy's ``doprint``."""

    _number_symbols: set[tuple[sp.Basic, str]]
    _print: Callable[[sp.Basic], str]

    def doprint(self, expr: sp.Basic, assign_to: sp.Basic | None = None) -> str:
        if assign_to is None and isinstance(expr, sp.Basic):
            self._number_symbols = set()
            text = self._print(expr)
            if not self._number_symbols and "\n" not in text:
                return text
        return str(super().doprint(expr, assign_to))    # type: ignore[misc]

    def parenthesize(self, item: sp.Basic, level: int, strict: bool = False) -> str:
        p = _precedence(item)
        return f"({self._print(item)})" if p < level or (not strict and p <= level) \
            else self._print(item)

    def _print_Add(self, expr: sp.Basic, order: str | None = None) -> str:
        prec = _precedence(expr)
        out: list[str] = []
        for term in self._as_ordered_terms(expr, order=order):   # type: ignore[attr-defined]
            t = self._print(term)
            sign = "+"
            if t.startswith("-") and not term.is_Add:
                sign, t = "-", t[1:]
            out += [sign, f"({t})" if _precedence(term) < prec or term.is_Add else t]
        first = out.pop(0)
        return ("" if first == "+" else first) + " ".join(out)


class PythonPrinter(_Direct, PythonCodePrinter):
    """sympy -> Python expressions (``math`` functions, ``np`` only for arrays)."""

    def __init__(self) -> None:
        super().__init__({"standard": "python3", "fully_qualified_modules": True, "order": "none"})
        #: the folded aliases of the function being printed (:attr:`.codegen.Function.aliases`)
        self.aliases: dict[str, sp.Expr] = {}

    def _print_Symbol(self, expr: sp.Basic) -> str:
        target = self.aliases.get(expr.name)
        return str(super()._print_Symbol(expr) if target is None else self._print(target))

    def _print_Float(self, expr: sp.Basic) -> str:
        return repr(float(expr))

    def _print_Indexed(self, expr: sp.Basic) -> str:
        """sympy's (``str`` of the array, then the printed indices), the array's name
        remembered."""
        return f"{_printed(expr.base)}[{', '.join(self._print(i) for i in expr.indices)}]"

    def _print_Heaviside(self, expr: sp.Basic) -> str:
        x = self._print(expr.args[0])
        h0 = self._print(sp.Float(expr.args[1] if len(expr.args) > 1 else 0.5))
        return f"(1.0 if {x} > 0 else ({h0} if {x} == 0 else 0.0))"

    def _print_DiracDelta(self, expr: sp.Basic) -> str:
        return "0.0"

    def _print_ITE(self, expr: sp.Basic) -> str:
        c, a, b = (self._print(x) for x in expr.args)
        return f"(({a}) if ({c}) else ({b}))"


class CPrinter(_Direct, C99CodePrinter):
    """sympy -> C99 expressions with the Python printer's meaning (see the module docstring)."""

    def __init__(self) -> None:
        super().__init__({"strict": True, "order": "none"})
        #: the folded aliases of the function being printed (:attr:`.codegen.Function.aliases`)
        self.aliases: dict[str, sp.Expr] = {}

    def _print_Symbol(self, expr: sp.Basic) -> str:
        target = self.aliases.get(expr.name)
        return str(super()._print_Symbol(expr) if target is None else self._print(target))

    def _print_Indexed(self, expr: sp.Basic) -> str:
        return f"{_printed(expr.base)}[{int(expr.indices[0])}]"

    def _print_Float(self, expr: sp.Basic) -> str:
        return _float(float(expr))

    def _print_Integer(self, expr: sp.Basic) -> str:
        return f"{int(expr)}.0" if expr >= 0 else f"({int(expr)}.0)"

    _print_Zero = _print_One = _print_NegativeOne = _print_Integer

    def _print_Pi(self, expr: sp.Basic) -> str:
        return repr(math.pi)

    def _print_Exp1(self, expr: sp.Basic) -> str:
        return repr(math.e)

    def _print_BooleanTrue(self, expr: sp.Basic) -> str:
        return "1"

    def _print_BooleanFalse(self, expr: sp.Basic) -> str:
        return "0"

    def _print_Pow(self, expr: sp.Basic) -> str:
        base, e = expr.args
        if e.is_Integer and 2 <= abs(int(e)) <= 4:          # exact products, no pow() call
            b = self.parenthesize(base, 1000)       # atoms only, anything else bracketed
            product = "*".join([b] * abs(int(e)))
            return f"({product})" if e > 0 else f"(1.0/({product}))"
        if e == -1:
            return f"(1.0/{self.parenthesize(base, 1000)})"
        if e == sp.S.Half:
            return f"sqrt({self._print(base)})"
        if e == -sp.S.Half:
            return f"(1.0/sqrt({self._print(base)}))"
        return f"pow({self._print(base)}, {self._print(e)})"

    def _print_Heaviside(self, expr: sp.Basic) -> str:
        x = self._print(expr.args[0])
        h0 = _float(float(expr.args[1])) if len(expr.args) > 1 else "0.5"
        return f"(({x}) > 0 ? 1.0 : (({x}) == 0 ? {h0} : 0.0))"

    def _print_DiracDelta(self, expr: sp.Basic) -> str:
        return "0.0"

    def _print_sign(self, expr: sp.Basic) -> str:
        x = self._print(expr.args[0])
        return f"(({x}) == 0 ? 0.0 : copysign(1.0, {x}))"

    def _fold(self, name: str, args: tuple[sp.Basic, ...]) -> str:
        out: str = self._print(args[0])
        for arg in args[1:]:
            out = f"{name}({out}, {self._print(arg)})"
        return out

    def _print_Min(self, expr: sp.Basic) -> str:
        return self._fold("ph_min", expr.args)

    def _print_Max(self, expr: sp.Basic) -> str:
        return self._fold("ph_max", expr.args)

    def _print_Mod(self, expr: sp.Basic) -> str:
        return f"ph_mod({self._print(expr.args[0])}, {self._print(expr.args[1])})"

    def _print_Piecewise(self, expr: sp.Basic) -> str:
        out = "NAN"
        for value, cond in reversed(expr.args):
            if cond == sp.true:
                out = self._print(value)
            else:
                out = f"(({self._print(cond)}) ? ({self._print(value)}) : ({out}))"
        return out

    def _print_Relational(self, expr: sp.Basic) -> str:
        return f"({self._print(expr.lhs)} {expr.rel_op} {self._print(expr.rhs)})"

    def _print_ITE(self, expr: sp.Basic) -> str:
        """if-then-else directly (sympy's rewrite as a Piecewise sorts the conditions, which
        took minutes on conditions reading a kernel's output array)."""
        c, a, b = (self._print(x) for x in expr.args)
        return f"(({c}) ? ({a}) : ({b}))"


def _closed_form(st: Solve, entry: Callable[[int, int], str]) -> list[tuple[str, str]]:
    """(name, value) assignments solving a 1 x 1 or 2 x 2 system ``st`` by Cramer's rule;
    ``entry(i, j)`` prints A's entry in the language."""
    b, v = st.b, st.targets
    if len(v) == 1:
        return [(v[0], f"{b}[0] / {entry(0, 0)}")]
    det = f"det{st.A}"
    return [(det, f"{entry(0, 0)} * {entry(1, 1)} - {entry(0, 1)} * {entry(1, 0)}"),
            (v[0], f"({b}[0] * {entry(1, 1)} - {entry(0, 1)} * {b}[1]) / {det}"),
            (v[1], f"({entry(0, 0)} * {b}[1] - {b}[0] * {entry(1, 0)}) / {det}")]


def _c_entry(array: str, n: int) -> Callable[[int, int], str]:
    """Prints entry (i, j) of the row-major n x n C ``array``."""
    return lambda i, j: f"{array}[{i * n + j}]"


# --- Python ---------------------------------------------------------------------------------------
def _python_index(index: tuple[int, ...]) -> str:
    return ", ".join(str(i) for i in index)


def _python_statement(st: Statement, pr: Callable[[sp.Basic], str], lines: list[str],
                      count: list[int]) -> None:
    if isinstance(st, Let):
        lines.append(f"    {st.name} = {pr(st.expr)}")
    elif isinstance(st, Array):
        shape = f"({st.shape[0]}, {st.shape[1]})" if len(st.shape) == 2 else str(st.shape[0])
        lines.append(f"    {st.name} = np.{'zeros' if st.zero else 'empty'}({shape})")
    elif isinstance(st, Store):
        comment = f"  # {printable(st.comment)}" if st.comment else ""
        lines.append(f"    {st.array}[{_python_index(st.index)}] = {pr(st.expr)}{comment}")
    elif isinstance(st, Solve):
        if len(st.targets) <= 2:   # small systems in closed form: no LAPACK call
            lines += [f"    {name} = {value}" for name, value in
                      _closed_form(st, lambda i, j: f"{st.A}[{i}, {j}]")]
        else:
            lines.append(f"    {', '.join(st.targets)} = np.linalg.solve({st.A}, {st.b})")
    elif isinstance(st, IndexTable):
        lines.append(f"    {st.name} = np.array({list(st.values)})")
    elif isinstance(st, ChainRule):
        lines += [f"    for k in range({st.start}, {st.stop}):",
                  f"        a, b = {st.lo}[k], {st.hi}[k]",
                  f"        {st.array}[{st.rows}[k], a:b] += {st.coefs}[k] * {st.array}[{st.cols}[k], a:b]"]
    elif isinstance(st, SparseProduct):
        if not st.entries:
            return
        f = f"F{count[0]}"
        count[0] += 1
        lines.append(f"    {f} = np.zeros(({st.shape[0]}, {st.shape[1]}))")
        lines += [f"    {f}[{i}, {j}] = {pr(e)}" for i, j, e in st.entries]
        lines.append(f"    {st.dst} += {f} @ {st.src}")
    elif isinstance(st, SolveRows):
        lines.append(f"    {st.R} = np.linalg.solve({st.A}, {st.R})")
    elif isinstance(st, Call):
        lines += _python_call(st, pr, "np.zeros((1, 0))", "o", 0)
    elif isinstance(st, CallTangent):
        d = f"{st.label}d"
        lines.append(f"    {d} = np.zeros(({len(st.inputs)}, {st.ncols}))")
        for j, row in enumerate(st.rows):
            if row is not None:
                lines.append(f"    {d}[{j}, {row[1]}] = 1.0" if row[0] == "x" else
                             f"    {d}[{j}, :] = {row[0]}[{row[1]}, :]")
        lines += _python_call(st, pr, d, "e", 1)
        lines += [f"    {array}[{m}, :] = {st.label}e[{k}, :]" for k, array, m in st.into]
    else:  # pragma: no cover
        raise TypeError(st)


def _python_call(st: Call | CallTangent, pr: Callable[[sp.Basic], str], din: str, suffix: str,
                 which: int) -> list[str]:
    """A kernel call's Python lines: ``<label><suffix>`` its result ``which`` (0 the outputs, 1
    their tangents); with ``keep`` also its work, with ``reuse`` the work it reads."""
    call = (f"{_entry_name(st)}({_table_name(st.table)}, "
            f"np.array([{', '.join(pr(c) for c in st.constants)}], dtype=np.float64), "
            f"np.array([{', '.join(pr(u) for u in st.inputs)}], dtype=np.float64), "
            f"{din}{', ' + st.reuse if st.reuse else ''})")
    if not st.keep:
        return [f"    {st.label}{suffix} = {call}[{which}]"]
    return [f"    {st.label}r = {call}", f"    {st.label}{suffix} = {st.label}r[{which}]",
            f"    {st.keep} = {st.label}r[2]"]


_KERNEL_ARRAY = re.compile(r"kern\d+o$")


def _copy_run(body: tuple[Statement, ...], start: int, flat: Callable[[str, tuple[int, ...]], int]
              ) -> tuple[int, str, int, str, int] | None:
    """A run of at least 4 statements from ``body[start]`` that copy consecutive entries of a
    kernel call's output array into consecutive entries of one array (``flat(array, index)``:
    the flat position): (count, destination array, first destination, source array, first
    source); else None."""
    first = body[start]
    if not (isinstance(first, Store) and isinstance(first.expr, sp.Indexed)
            and _KERNEL_ARRAY.match(str(first.expr.base))):
        return None
    base, dst0, src0 = str(first.expr.base), flat(first.array, first.index), int(first.expr.indices[0])
    count = 1
    while start + count < len(body):
        st = body[start + count]
        if not (isinstance(st, Store) and st.array == first.array and isinstance(st.expr, sp.Indexed)
                and str(st.expr.base) == base and flat(st.array, st.index) == dst0 + count
                and int(st.expr.indices[0]) == src0 + count):
            break
        count += 1
    return (count, first.array, dst0, base, src0) if count >= 4 else None


def _run_names(stores: tuple[Statement, ...], escape: Callable[[str], str]) -> list[str]:
    """The names of the entries a run of copies (:func:`_copy_run`) stores, escaped, as one
    comment's text (none when they have no names)."""
    names = [escape(st.comment) for st in stores if isinstance(st, Store) and st.comment]
    return [", ".join(names)] if names else []


def _table_name(table: tuple[int, ...]) -> str:
    """The module-level name of a kernel call's integer table (one per distinct table)."""
    return f"_KT{abs(hash(table)) % 10**12:012d}"


def _kernel_calls(prog: Program) -> list[Call | CallTangent]:
    return [st for fn in prog.functions for st in fn.body if isinstance(st, (Call, CallTangent))]


def kernels(prog: Program) -> list[str]:
    """The kernels the program calls (the C back end links their objects)."""
    return sorted({st.kernel for st in _kernel_calls(prog)})


def _shared(pr: Callable[[sp.Basic], str], printed: dict[int, str] | None
            ) -> Callable[[Let], str]:
    """Prints a Let's expression, once per statement object when ``printed`` is given: the
    functions of a program share their prologue's statements (the same objects), whose names
    and aliases are the same in every function, so each prints the same text in each."""
    if printed is None:
        return lambda st: pr(st.expr)

    def shared(st: Let) -> str:
        text = printed.get(id(st))
        if text is None:
            text = printed[id(st)] = pr(st.expr)
        return text
    return shared


def python_function(fn: Function, printer: PythonPrinter | None = None,
                    printed: dict[int, str] | None = None) -> str:
    """One function as Python source, decorated with ``@_jit`` (the back end's header defines
    it: numba's ``njit`` or the identity). ``printed``: the texts of the program's statements
    printed so far (:func:`python_source`; by statement object)."""
    printer = printer or PythonPrinter()
    printer.aliases = dict(fn.aliases)
    pr = printer.doprint
    let = _shared(pr, printed)
    doc = "\n".join(f"    {python_docstring(line)}" if i else python_docstring(line)
                    for i, line in enumerate(fn.doc))
    lines = ["@_jit", f"def {fn.name}({', '.join(fn.args)}):", f'    """{doc}\n    """']
    count = [0]
    ncols: dict[str, int] = {"out": fn.shape[1] if len(fn.shape) == 2 else 0}
    position = 0
    while position < len(fn.body):
        st = fn.body[position]
        if isinstance(st, Array):
            ncols[st.name] = st.shape[1] if len(st.shape) == 2 else 0
        run = _copy_run(fn.body, position,
                        lambda a, i: i[0] * ncols[a] + i[1] if len(i) == 2 else i[0])
        if run is not None:              # a block of a kernel's outputs: one slice copy
            n, array, dst, src, first = run
            target = array if not ncols[array] else f"{array}.reshape(-1)"
            lines += [f"    # {text}" for text in _run_names(fn.body[position:position + n],
                                                            printable)]
            lines.append(f"    {target}[{dst}:{dst + n}] = {src}[{first}:{first + n}]")
            position += n
            continue
        if isinstance(st, Let):
            lines.append(f"    {st.name} = {let(st)}")
        else:
            _python_statement(st, pr, lines, count)
        position += 1
    lines.append("    return out")
    return "\n".join(lines)


def python_source(prog: Program) -> str:
    """The program as the body of a Python module (no imports: see porthamiltonian.backends);
    with kernel calls, the kernels' templates and the calls' integer tables first."""
    printer = PythonPrinter()
    header = "\n".join(python_docstring(line) for line in prog.header)
    parts = [f'"""{header}\n"""']
    calls = _kernel_calls(prog)
    for kernel in sorted({st.kernel for st in calls}):
        parts.append(python_template(kernel))
    if calls:
        tables = {st.table: None for st in calls}
        parts.append("\n".join(f"{_table_name(t)} = np.array({list(t)}, dtype=np.int64)"
                               for t in tables))
    printed: dict[int, str] = {}
    parts += [python_function(fn, printer, printed) for fn in prog.functions]
    return "\n\n\n".join(parts) + "\n"


# --- C ------------------------------------------------------------------------------------------
_C_PRELUDE = """\
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* the entry points' linkage; a translation unit that embeds the model (an FMU) defines it first */
#ifndef PH_EXPORT
#if defined(_WIN32)
#define PH_EXPORT __declspec(dllexport)
#else
#define PH_EXPORT __attribute__((visibility("default")))
#endif
#endif
#if defined(__GNUC__) && !defined(PH_HIDDEN)
#define PH_HIDDEN __attribute__((visibility("hidden")))
#elif !defined(PH_HIDDEN)
#define PH_HIDDEN
#endif

/* min/max as Python's: b if b < a (b > a) else a */
static inline double ph_min(double a, double b) { return b < a ? b : a; }
static inline double ph_max(double a, double b) { return b > a ? b : a; }

/* Python's floored % of floats */
static inline double ph_mod(double a, double b)
{
    double r = fmod(a, b);
    if (r != 0.0) {
        if ((b < 0.0) != (r < 0.0))
            r += b;
    } else {
        r = copysign(0.0, b);
    }
    return r;
}

static double *ph_alloc(size_t n)
{
    double *a = calloc(n, sizeof(double));
    if (a == NULL)
        abort();
    return a;
}

/* The two loop nests of the generated functions, compiled at -O3 under GCC (they run at every
 * evaluation; the straight-line code around them stays at -O1, where it builds fast). */
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC push_options
#pragma GCC optimize ("O3")
#endif

/* dst[rows[k], lo[k]:hi[k]] += f[k] * src[cols[k], lo[k]:hi[k]] for k in [0, count), for the
 * row-major arrays dst and src of m columns (the same array when rows[k] != cols[k]: the forward
 * chain rule), where row cols[k] of src is zero outside lo[k]..hi[k] - 1 */
static void ph_rows_axpy(double *dst, const double *src, const double *f, const int *rows,
                         const int *cols, const int *lo, const int *hi, int count, int m)
{
    for (int k = 0; k < count; ++k) {
        double *d = dst + rows[k] * m;
        const double *s = src + cols[k] * m;
        const double fk = f[k];
        for (int c = lo[k]; c < hi[k]; ++c)
            d[c] += fk * s[c];
    }
}

/* A X = B for A n x n and B n x m (row-major), in place: Gaussian elimination with partial
 * pivoting (A is destroyed, X replaces B); one division per pivot */
static void ph_solve_rows(int n, int m, double *A, double *B)
{
    for (int k = 0; k < n; ++k) {
        int piv = k;
        double big = fabs(A[k * n + k]);
        for (int i = k + 1; i < n; ++i)
            if (fabs(A[i * n + k]) > big) {
                big = fabs(A[i * n + k]);
                piv = i;
            }
        if (piv != k) {
            for (int j = 0; j < n; ++j) {
                double t = A[k * n + j]; A[k * n + j] = A[piv * n + j]; A[piv * n + j] = t;
            }
            for (int j = 0; j < m; ++j) {
                double t = B[k * m + j]; B[k * m + j] = B[piv * m + j]; B[piv * m + j] = t;
            }
        }
        const double r = 1.0 / A[k * n + k];
        A[k * n + k] = r;
        for (int i = k + 1; i < n; ++i) {
            const double f = A[i * n + k] * r;
            if (f == 0.0)
                continue;
            for (int j = k + 1; j < n; ++j)
                A[i * n + j] -= f * A[k * n + j];
            for (int j = 0; j < m; ++j)
                B[i * m + j] -= f * B[k * m + j];
        }
    }
    for (int i = n - 1; i >= 0; --i) {
        const double r = A[i * n + i];
        for (int j = 0; j < m; ++j)
            B[i * m + j] *= r;
        for (int l = 0; l < i; ++l) {
            const double a = A[l * n + i];
            if (a != 0.0)
                for (int j = 0; j < m; ++j)
                    B[l * m + j] -= a * B[i * m + j];
        }
    }
}
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC pop_options
#endif
"""


def _size(shape: tuple[int, ...]) -> int:
    return math.prod(shape)


def _c_flat(index: tuple[int, ...], shape: tuple[int, ...]) -> int:
    return index[0] * shape[1] + index[1] if len(index) == 2 else index[0]




def c_function(fn: Function, printer: CPrinter | None = None,
               printed: dict[int, str] | None = None) -> str:
    """One function as a ``static void`` C function writing its result into ``out`` (hidden
    external for :data:`LOOP_FUNCTIONS`); ``printed`` as for :func:`python_function`."""
    printer = printer or CPrinter()
    printer.aliases = dict(fn.aliases)
    pr = printer.doprint
    let = _shared(pr, printed)
    shapes: dict[str, tuple[int, ...]] = {"out": fn.shape}
    heap: list[str] = []
    comment = "\n".join(f"{' *' if i else '/*'} {c_comment(line)}" for i, line in
                        enumerate(fn.doc))
    params = "const double *p" if fn.args == ("p",) else "double t, const double *x, const double *p"
    linkage = "PH_HIDDEN" if fn.name in LOOP_FUNCTIONS else "static"
    lines = [f"{comment}\n */", f"{linkage} void {fn.name}({params}, double *out)", "{",
             "    " + " ".join(f"(void){arg};" for arg in fn.args)]
    position = 0
    while position < len(fn.body):
        st = fn.body[position]
        run = _copy_run(fn.body, position, lambda a, i: _c_flat(i, shapes[a]))
        position += 1
        if run is not None:              # a block of a kernel's outputs: one copy
            n, array, dst, src, first = run
            lines += [f"    /* {text} */" for text in
                      _run_names(fn.body[position - 1:position - 1 + n], c_comment)]
            lines.append(f"    memcpy({array} + {dst}, {src} + {first}, sizeof(double) * {n});")
            position += n - 1
            continue
        if isinstance(st, Let):
            lines.append(f"    const double {st.name} = {let(st)};")
        elif isinstance(st, Array):
            shapes[st.name] = st.shape
            size = _size(st.shape)
            if st.name == "out":
                if st.zero:
                    lines.append(f"    memset(out, 0, sizeof(double) * {size});")
            elif size > _C_STACK_DOUBLES:
                lines.append(f"    double *{st.name} = ph_alloc({size});")
                heap.append(st.name)
            else:
                lines.append(f"    double {st.name}[{size}]{' = {0}' if st.zero else ''};")
        elif isinstance(st, Store):
            comment = f" /* {c_comment(st.comment)} */" if st.comment else ""
            lines.append(f"    {st.array}[{_c_flat(st.index, shapes[st.array])}] = "
                         f"{pr(st.expr)};{comment}")
        elif isinstance(st, Solve):
            n = len(st.targets)
            if n <= 2:
                lines += [f"    const double {name} = {value};" for name, value in
                          _closed_form(st, _c_entry(st.A, n))]
            else:
                lines.append(f"    ph_solve_rows({n}, 1, {st.A}, {st.b});")
                solution = sp.IndexedBase(st.b)          # the unknowns are read from b in place
                printer.aliases.update((t, solution[i]) for i, t in enumerate(st.targets))
        elif isinstance(st, IndexTable):
            lines.append(f"    static const int {st.name}[{len(st.values)}] = "
                         f"{{{', '.join(map(str, st.values))}}};")
        elif isinstance(st, ChainRule):
            k0 = st.start
            lines.append(f"    ph_rows_axpy({st.array}, {st.array}, {st.coefs} + {k0}, "
                         f"{st.rows} + {k0}, {st.cols} + {k0}, {st.lo} + {k0}, {st.hi} + {k0}, "
                         f"{st.stop - k0}, {st.ncols});")
        elif isinstance(st, SparseProduct):
            if st.entries:
                k, m = len(st.entries), st.ncols
                coefs = ", ".join(pr(e) for _, _, e in st.entries)
                rows = ", ".join(str(i) for i, _, _ in st.entries)
                cols = ", ".join(str(j) for _, j, _ in st.entries)
                lo = ", ".join(str(st.ranges[j][0]) for _, j, _ in st.entries)
                hi = ", ".join(str(st.ranges[j][1]) for _, j, _ in st.entries)
                lines += ["    {", f"        const double f[{k}] = {{{coefs}}};",
                          f"        static const int r[{k}] = {{{rows}}};",
                          f"        static const int c[{k}] = {{{cols}}};",
                          f"        static const int lo[{k}] = {{{lo}}};",
                          f"        static const int hi[{k}] = {{{hi}}};",
                          f"        ph_rows_axpy({st.dst}, {st.src}, f, r, c, lo, hi, {k}, {m});",
                          "    }"]
        elif isinstance(st, SolveRows):
            lines.append(f"    ph_solve_rows({st.n}, {st.ncols}, {st.A}, {st.R});")
        elif isinstance(st, Call):
            lines += _c_call_arrays(st, pr)
            lines.append(f"    double {st.label}o[{max(st.n_outputs, 1)}];")
            if st.keep:
                lines.append(f"    double *{st.keep} = NULL;")
                heap.append(st.keep)
            lines.append(f"    ph_{_entry_name(st)}({st.label}s, {st.label}c, {st.label}i, "
                         f"{st.label}o, 0, NULL, NULL{_c_work(st)});")
        elif isinstance(st, CallTangent):
            n, label = st.ncols, st.label
            if st.keep:
                lines.append(f"    double *{st.keep} = NULL;")
                heap.append(st.keep)
            lines.append("    {")
            lines += ["    " + line for line in _c_call_arrays(st, pr)]
            lines += [f"        double {label}o[{max(st.n_outputs, 1)}];",
                      f"        double *{label}d = ph_alloc({max(len(st.inputs), 1) * n});",
                      f"        double *{label}e = ph_alloc({max(st.n_outputs, 1) * n});"]
            for j, row in enumerate(st.rows):
                if row is not None:
                    lines.append(f"        {label}d[{j * n + row[1]}] = 1.0;" if row[0] == "x" else
                                 f"        memcpy({label}d + {j * n}, {row[0]} + {row[1] * n}, "
                                 f"sizeof(double) * {n});")
            lines.append(f"        ph_{_entry_name(st)}({label}s, {label}c, {label}i, {label}o, "
                         f"{n}, {label}d, {label}e{_c_work(st)});")
            lines += [f"        memcpy({array} + {m * n}, {label}e + {k * n}, sizeof(double) * {n});"
                      for k, array, m in st.into]
            lines += [f"        free({label}d);", f"        free({label}e);", "    }"]
        else:  # pragma: no cover
            raise TypeError(st)
    lines += [f"    free({name});" for name in heap]
    lines.append("}")
    return "\n".join(lines)


def _entry_name(st: Call | CallTangent) -> str:
    """The kernel entry a call runs (``<entry>_keep``, ``<entry>_reuse`` or ``<entry>``; ``ph_``
    before it in C)."""
    return f"{st.entry}_keep" if st.keep else f"{st.entry}_reuse" if st.reuse else st.entry


def _c_work(st: Call | CallTangent) -> str:
    """The work argument of a call that keeps or reuses work ("" otherwise)."""
    return f", &{st.keep}" if st.keep else f", {st.reuse}" if st.reuse else ""


def _c_call_arrays(st: Call | CallTangent, pr: Callable[[sp.Basic], str]) -> list[str]:
    """The integer table, constants and inputs of a kernel call as local C arrays."""
    def values(exprs: tuple[sp.Basic, ...]) -> str:
        return ", ".join(pr(e) for e in exprs) or "0.0"

    table = ", ".join(map(str, st.table))
    return [f"    static const int {st.label}s[{len(st.table)}] = {{{table}}};",
            f"    const double {st.label}c[{max(len(st.constants), 1)}] = {{{values(st.constants)}}};",
            f"    const double {st.label}i[{max(len(st.inputs), 1)}] = {{{values(st.inputs)}}};"]


#: generated functions called once per analysis, not at every step: ``jac_u`` (∂ẋ/∂u, for a
#: linearization, or an FMU's directional derivatives by its inputs) and ``out_jac`` (∂y/∂[x, u]
#: of the declared outputs, for a linearization). GCC compiles them at -O0 (the same IEEE
#: arithmetic): GCC's -O1 time grows faster than the length of a function; the Whipple
#: bicycle's 3400-line jac_u took 2.0 of its unit's 5.3 s of compile, its out_jac unit 2.2 s
#: (0.25 s at -O0)
COLD_FUNCTIONS = frozenset({"jac_u", "out_jac"})
_COLD_PUSH = ('#if defined(__GNUC__) && !defined(__clang__)\n#pragma GCC push_options\n'
              '#pragma GCC optimize ("O0")\n#endif')
_COLD_POP = '#if defined(__GNUC__) && !defined(__clang__)\n#pragma GCC pop_options\n#endif'


def c_source(prog: Program) -> str:
    """The program as a C99 translation unit: the functions (static), each followed by its
    exported wrapper ``ph_<name>`` (and preceded by
    :data:`~porthamiltonian.backends.native.FUNCTION_MARK`), ``ph_layout`` and
    the sizes the loop template needs (``PH_N``, ``PH_NG``)."""
    printer = CPrinter()
    header = "\n".join(f"{' *' if i else '/*'} {c_comment(line)}" for i, line in
                       enumerate(prog.header))
    parts = [f"{header}\n */", _C_PRELUDE]
    parts += [c_declarations(kernel) for kernel in kernels(prog)]
    parts.append(f"#define PH_N {prog.n}\n#define PH_NG {prog.n_guards}")
    printed: dict[int, str] = {}
    for fn in prog.functions:             # each function with its wrapper, after its marker
        if fn.args == ("p",):
            export = (f"PH_EXPORT void ph_{fn.name}(const double *p, double *out) "
                      f"{{ {fn.name}(p, out); }}")
        else:
            export = (f"PH_EXPORT void ph_{fn.name}(double t, const double *x, const double *p, "
                      f"double *out) {{ {fn.name}(t, x, p, out); }}")
        code = c_function(fn, printer, printed)
        if fn.name in COLD_FUNCTIONS:
            code = f"{_COLD_PUSH}\n{code}\n{_COLD_POP}"
        parts += [FUNCTION_MARK.format(fn.name), code, export]
    parts.append(FUNCTIONS_END)
    sizes = [prog.n, prog.n_params, prog.n_guards, prog.n_outputs,
             sum(1 for fn in prog.functions if fn.name.startswith("matrix_"))]
    parts.append("/* sizes: states (with the ledger), parameters, guard slots, output slots, "
                 "matrices */\nPH_EXPORT void ph_layout(int64_t *out)\n{\n" +
                 "".join(f"    out[{i}] = {v};\n" for i, v in enumerate(sizes)) + "}")
    return "\n\n".join(parts) + "\n"


__all__ = ["LOOP_FUNCTIONS", "CPrinter", "PythonPrinter", "c_function", "c_source", "kernels",
           "python_function", "python_source"]
