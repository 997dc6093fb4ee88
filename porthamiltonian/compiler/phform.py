"""The explicit port-Hamiltonian form of a model, with dissipation variables (as in pyphs).

    [ẋ; w; y] = (J(x) − R(x)) · [∇H(x); z(w); u],   J = −Jᵀ,  R = Rᵀ ⪰ 0,  z(w)ᵀw ≥ 0,

over the states of the storages (the *physical* states; signal blocks' states stay out), with
w, z(w) the flows and efforts of the nonlinear dissipators (a contact's damping, friction), u the
imposed port variables (sources, actuators, open ports) and y their conjugates with pyphs' sign:
the power the model gives to its environment is uᵀy, so the supplied power is −uᵀy. Then
dH/dt = ∇Hᵀẋ + ∂H/∂t|_mod = −[∇H; z; u]ᵀR[∇H; z; u] − zᵀw − uᵀy + (modulation power).

How it is derived (no component needs code of its own beyond its laws). The compiler builds the
model a second time, the *cut build* (:class:`~porthamiltonian.modeling.component.PHCut`): every
constitutive law — a storage's co-energy ∂H/∂x (:meth:`Builder.coenergy`), a dissipator's output
(:meth:`Builder.resistive`), a source's value (:meth:`Builder.source`) — is replaced by a symbol
(η, ζ, υ), and a multibody's dynamics by its Poisson structure (:mod:`porthamiltonian.mechanics.
poisson`). Solving that system with the same causality analysis gives the junction structure
(junctions, transformers, gyrators, the kinematics of bodies, modulated by x) as one linear map,

    [ẋ; w_all; y] = M₀(x) [η; ζ_all; υ],

skew-symmetric when the structure is power-conserving (a Dirac structure): checked, not assumed.
A linear dissipator (z = C(x) w: a damper, a resistor) is then eliminated, z_l = C w_l, which
gives the reduced M = J − R over [∇H; z; u] with R = G C Gᵀ ⪰ 0 exactly when every C ⪰ 0; a
dissipator whose C is indefinite (an active element declared as one) is named in a
:class:`~porthamiltonian.errors.PassivityError`.

∇H is the gradient of the stored energy as the state equations see it: for each storage, the
derivative of its energy by its own states, and by the states it reads *through its ports*
(``energy(..., via_ports=True)``: a contact's spring on a body's coordinates); the dependence of
a modulated storage on other states (a stiffness K(φ)) is a modulation, supplied power, not part
of ∇H. It is generated exactly, by the chain rule of :func:`.codegen.jacobian_function`.

What is generated (:func:`ph_functions`, ``compile_model(..., ph=True)``, compiled as an add-on
of the model's cache entry: :func:`ph_program`): ``ph_M0`` (M₀),
``ph_grad`` (∂H_c/∂x per storage component c, combined by the layout's mask), ``ph_values``
(z and w of every dissipator and u of every source from the model's solution, the linear
dissipators' coefficients). :mod:`porthamiltonian.simulation.phmatrices` evaluates them at a
point: J, R, [∇H; z; u], and the checks — M[∇H; z; u] reproduces the compiled right-hand side,
M₀ + M₀ᵀ = 0, R ⪰ 0, z(w)ᵀw ≥ 0.
"""
from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field
from typing import Any

import sympy as sp

from ..errors import PassivityError
from ..modeling.component import Dissipator, PHCut, Source
from ..modeling.differentiation import derivative
from ..modeling.model import ModelDescription
from .assemble import SymbolicModel, _needed
from .codegen import (
    Function,
    FunctionBuilder,
    Program,
    addon_program,
    gathered,
    jacobian_function,
    symbol_map,
)
from .structure import Solution, build_system, solve


@dataclass
class PHForm:
    """The explicit port-Hamiltonian form of a model (see the module docstring).

    states : the physical states (∇H's order); dissipators, sources : what the cut build
    recorded (their z, w, value, conjugate expressions over the cut build's symbols);
    M0 : the junction structure [ẋ; w_all; y] = M0 [η; ζ_all; υ], a sympy matrix whose entries
    may read the cut build's ``intermediates`` (position-level: functions of q) by their symbols;
    rows, columns : its rows and columns as expressions and symbols; energies : per storage component (name, energy, the indices of the
    states its gradient counts for); values : the normal model's z, w (every dissipator,
    flattened), u and the linear dissipators' coefficient entries, as expressions of the model.
    """

    name: str
    states: list[sp.Symbol]
    dissipators: list[Dissipator]
    sources: list[Source]
    intermediates: list[tuple[sp.Symbol, sp.Expr]]
    blocks: list[tuple[list[sp.Symbol], sp.Matrix, sp.Matrix]]
    rows: list[sp.Expr] = field(default_factory=list, repr=False)
    columns: list[sp.Symbol] = field(default_factory=list, repr=False)
    energies: list[tuple[str, sp.Expr, list[int]]] = field(default_factory=list, repr=False)
    values: list[sp.Expr] = field(default_factory=list, repr=False)
    #: every intermediate of the model's own solved system (z and w may read some that its
    #: state equations do not, e.g. a friction's slip)
    normal_intermediates: list[tuple[sp.Symbol, sp.Expr]] = field(default_factory=list,
                                                                 repr=False)

    @functools.cached_property
    def M0(self) -> sp.Matrix:
        """The junction structure [ẋ; w_all; y] = M0 [η; ζ_all; υ] (symbolic; the
        intermediates that read η, ζ, υ inlined, the others kept as their symbols)."""
        return _matrix(self.rows, self.columns, self.intermediates, set(self.columns))

    # --- names ---------------------------------------------------------------------------------
    @property
    def state_names(self) -> list[str]:
        """The physical states, in the order of ∇H."""
        return [str(s) for s in self.states]

    def dissipator_names(self, linear: bool | None = None) -> list[str]:
        """``component.name[i]`` of the dissipators' variables (all, or only the linear or
        nonlinear ones)."""
        return [f"{d.component}.{d.name}" + ("" if len(d.z) == 1 else f"[{i}]")
                for d in self.dissipators if linear is None or (d.coefficient is not None) == linear
                for i in range(len(d.z))]

    @property
    def port_names(self) -> list[str]:
        """``component.port`` of the imposed port variables u."""
        return [f"{s.component}.{s.name}" for s in self.sources]

    # --- the reduced form -------------------------------------------------------------------------
    def _split(self) -> tuple[list[int], list[int], sp.Matrix]:
        """(kept indices, linear-dissipator indices, their block-diagonal coefficient C)."""
        n = len(self.states)
        kept, linear, blocks = list(range(n)), [], []
        k = n
        for d in self.dissipators:
            idx = list(range(k, k + len(d.z)))
            k += len(d.z)
            if d.coefficient is None:
                kept += idx
            else:
                linear += idx
                blocks.append(d.coefficient)
        kept += list(range(k, k + len(self.sources)))
        return kept, linear, sp.diag(*blocks) if blocks else sp.zeros(0, 0)

    def reduced(self) -> sp.Matrix:
        """M = J − R over [∇H; z; u] (the linear dissipators eliminated, see the module
        docstring), symbolic."""
        kept, linear, C = self._split()
        M0 = self.M0
        Mkk = M0.extract(kept, kept)
        if not linear:
            return Mkk
        Mll = M0.extract(linear, linear)
        inner = sp.eye(len(linear)) - Mll * C
        gain = C if Mll.is_zero_matrix else C * inner.inv()
        return Mkk + M0.extract(kept, linear) * gain * M0.extract(linear, kept)

    @property
    def J(self) -> sp.Matrix:
        """The skew-symmetric part of the reduced M."""
        M = self.reduced()
        return (M - M.T) / 2

    @property
    def R(self) -> sp.Matrix:
        """R = −(M + Mᵀ)/2 of the reduced M (⪰ 0 for a passive model)."""
        M = self.reduced()
        return -(M + M.T) / 2

    def layout(self) -> dict[str, Any]:
        """The form's layout for a compiled model's metadata (JSON): names and sizes, each
        dissipator's size and whether it is linear, and the ∇H mask."""
        return {
            "states": self.state_names,
            "dissipators": [{"component": d.component, "name": d.name, "size": len(d.z),
                             "linear": d.coefficient is not None}
                            for d in self.dissipators],
            "ports": self.port_names,
            "energies": [[name, indices] for name, _, indices in self.energies],
            "rows": [str(r) for r in self.row_names()],
            "columns": [str(c) for c in self.column_names()],
        }

    def row_names(self) -> list[str]:
        """Names of M₀'s rows: d(state)/dt, w of each dissipator variable, y of each port."""
        return ([f"d({s})/dt" for s in self.state_names]
                + [f"w[{n}]" for n in self.dissipator_names()]
                + [f"y[{n}]" for n in self.port_names])

    def column_names(self) -> list[str]:
        """Names of M₀'s columns: dH/d(state), z of each dissipator variable, u of each port."""
        return ([f"dH/d({s})" for s in self.state_names]
                + [f"z[{n}]" for n in self.dissipator_names()]
                + [f"u[{n}]" for n in self.port_names])


def ph_form(description: ModelDescription, sym: SymbolicModel, normal: Solution) -> PHForm:
    """The :class:`PHForm` of a model: its description, its assembled symbolic model and the
    solution of its own structure (``normal``); a linear dissipator with a constant negative
    coefficient raises PassivityError."""
    cut = PHCut()
    system = build_system(description, ph=cut)
    solution = solve(system)
    values = {u: expr for u, expr, _ in solution.order}
    aliases = system.aliases
    roles = dict(zip(sym.states, sym.state_roles))
    states = [s for s in sym.states if roles[s] == "storage"]
    derivative_of = {state: d for d, state in system.derivatives.items()}

    def solved(expr: sp.Expr) -> sp.Expr:
        return sp.sympify(expr).xreplace(aliases).xreplace(values)

    for d in cut.dissipators:
        _check_coefficient(d)
    rows = ([values[derivative_of[s]] for s in states]
            + [solved(w) for d in cut.dissipators for w in d.w]
            + [-solved(s.conjugate) for s in cut.sources])
    columns = ([cut.eta(s) for s in states] + [z for d in cut.dissipators for z in d.zeta]
               + [s.upsilon for s in cut.sources])
    intermediates = _needed(system.intermediates, rows)

    nvalues = {u: expr for u, expr, _ in normal.order}

    def evaluated(expr: sp.Expr) -> sp.Expr:
        return sp.sympify(expr).xreplace(normal.system.aliases).xreplace(nvalues)

    index = {s: i for i, s in enumerate(states)}
    energies = []
    for cname, b in normal.system.built.items():
        energy = b.energy.xreplace(normal.system.aliases)
        if energy == 0:
            continue
        owned = {s.symbol for s in b.states}
        counted = [index[s] for s in states if s in owned or b.energy_via_ports]
        if counted:
            energies.append((cname, energy, counted))
    vals = ([evaluated(z) for d in cut.dissipators for z in d.z]
            + [evaluated(w) for d in cut.dissipators for w in d.w]
            + [evaluated(s.value) for s in cut.sources]
            + [evaluated(c) for d in cut.dissipators if d.coefficient is not None
               for c in d.coefficient])
    # the values may read intermediates of the cut build the model's own lacks (a contact's
    # height from a multibody whose tree the model evaluates by its kernel, the cut build
    # symbolically): of the positions, they hold in the model too
    known = {w for w, _ in normal.system.intermediates}
    extra = [(w, e) for w, e in _needed(system.intermediates, vals) if w not in known]
    return PHForm(sym.name, states, cut.dissipators, cut.sources, intermediates,
                  system.blocks, rows, columns, energies, vals,
                  extra + list(normal.system.intermediates))


def ph_text(form: PHForm) -> str:
    """The form as text (``porthamiltonian show MODEL --ph``): the states, the nonlinear
    dissipators' z(w), the linear ones' coefficients, the ports' u, and the nonzero entries of
    J and R over [∇H; z; u] (intermediates of positions shown by name, e.g. a multibody's)."""
    M = form.reduced()
    J, R = (M - M.T) / 2, -(M + M.T) / 2
    kept, _, _ = form._split()
    names = form.column_names()
    cols = [names[i] for i in kept]
    rows = [form.row_names()[i] for i in kept]
    lines = [(f"port-Hamiltonian form of model {form.name!r}: [dx/dt; w; y] = (J - R) "
              "[dH/dx; z(w); u]"),
             f"x (the storages' states): {', '.join(form.state_names) or 'none'}"]
    for d in form.dissipators:
        kind = "linear, z = C w, in R" if d.coefficient is not None else "z(w)"
        lines.append(f"dissipator {d.component}.{d.name} ({kind}): w = {_short(d.w)}, "
                     f"z = {_short(d.z)}" + (f", C = {_short(list(d.coefficient))}"
                                             if d.coefficient is not None else ""))
    for source in form.sources:
        lines.append(f"port {source.component}.{source.name}: u = {source.value}, y = "
                     f"-{source.conjugate} (supplied power -u*y)")
    for label, matrix in (("J", J), ("R", R)):
        entries = [(i, j, sp.simplify(matrix[i, j])) for i in range(matrix.rows)
                   for j in range(matrix.cols) if matrix[i, j] != 0]
        entries = [(i, j, v) for i, j, v in entries if v != 0]
        lines.append(f"{label}: {len(entries)} nonzero entries (rows {', '.join(rows)}; columns "
                     f"{', '.join(cols)})" if entries else f"{label} = 0")
        lines += [f"  {label}[{rows[i]}, {cols[j]}] = {v}" for i, j, v in entries]
    return "\n".join(lines) + "\n"


def _short(exprs: list[sp.Expr]) -> str:
    text = ", ".join(str(e) for e in exprs)
    return f"[{text}]" if len(exprs) > 1 else text


def _check_coefficient(d: Dissipator) -> None:
    """A linear dissipator whose coefficient is a constant with a negative eigenvalue (or a
    negative symmetric part) is active: PassivityError naming it."""
    C = d.coefficient
    if C is None or C.free_symbols:
        return
    sym_part = (C + C.T) / 2
    values = [complex(v).real for v in sym_part.evalf().eigenvals(multiple=True)]
    if min(values) < 0:
        raise PassivityError(
            f"component {d.component!r} is declared as a dissipator ({d.name}) but its law "
            f"z = C w has C = {C.tolist()}, which is not positive semi-definite: it would "
            "supply energy (R indefinite). An active element is a source (Se, Sf) or an "
            "actuator, not a dissipator", path=())


def _matrix(rows: list[sp.Expr], columns: list[sp.Symbol],
            intermediates: list[tuple[sp.Symbol, sp.Expr]], cut: set[sp.Symbol]) -> sp.Matrix:
    """∂rows/∂columns symbolically: the intermediates that read the cut symbols (e.g. the
    twists of bodies, linear in η) inlined, the others kept as their symbols."""
    reads: dict[sp.Symbol, sp.Expr] = {}
    for symbol, expr in intermediates:
        expr = expr.xreplace(reads)
        if expr.free_symbols & cut:
            reads[symbol] = expr
    full = [sp.sympify(r).xreplace(reads) for r in rows]
    return sp.Matrix(len(full), len(columns), lambda i, j: derivative(full[i], columns[j]))


def ph_program(sym: SymbolicModel, form: PHForm) -> Program:
    """The form's functions (:func:`ph_functions`) as a program of their own, with the model's
    layout (:func:`.codegen.addon_program`): the ``ph`` add-on of the model's cache entry,
    compiled beside the model's own library, not into it."""
    return addon_program(sym, ph_functions(sym, form))


def ph_functions(sym: SymbolicModel, form: PHForm) -> list[Function]:
    """The generated functions of the form (see the module docstring): ``ph_M0``, ``ph_grad``,
    ``ph_values``, built with the same program machinery as the model's own functions (their
    own builders: nothing is shared with the model's program, so they are the same code
    whether printed with it or alone)."""
    # the cut build calls no kernel (a multibody writes its Poisson structure out symbolically)
    cut_model = dataclasses.replace(sym, intermediates=form.intermediates, blocks=form.blocks,
                                    calls={})
    mapping = symbol_map(cut_model)
    mapping.update({c: sp.Integer(0) for c in form.columns})
    cut_builder = FunctionBuilder(mapping, cut_model)
    n_rows = len(form.rows)
    doc = [f"The port-Hamiltonian form of model {sym.name!r}."]
    functions = [jacobian_function(cut_builder, cut_model, "ph_M0", form.rows, form.columns,
                                   [*doc, (f"out: M0, {n_rows} x {n_rows}, row-major: rows "
                                           "[dx/dt; w; y], columns [dH/dx; z; u].")])]
    extra = [e for _, e, _ in form.energies] + list(form.values)
    used = [*extra, *sym.rhs, *(e for _, A, b in sym.blocks for e in (*A, *b))]
    normal_model = gathered(dataclasses.replace(
        sym, intermediates=_needed(form.normal_intermediates, used)))
    builder = FunctionBuilder(symbol_map(normal_model), normal_model)
    energies = [e for _, e, _ in form.energies] or [sp.Integer(0)]
    functions.append(jacobian_function(builder, normal_model, "ph_grad", energies, form.states,
                                       [*doc, "out: dH_c/dx of each storage component c."]))
    values = list(form.values) or [sp.Integer(0)]
    functions.append(builder.function("ph_values", [*doc, "out: z, w, u, coefficients."],
                                      [("array", "out", values, (len(values),))],
                                      (len(values),)))
    return functions


__all__ = ["PHForm", "ph_form", "ph_functions", "ph_program", "ph_text"]
