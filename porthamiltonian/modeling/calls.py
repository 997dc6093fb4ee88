"""Kernel calls: a component's quantities computed by a compiled numeric routine.

A component may hand part of its laws to a *kernel*: a fixed numeric routine (written once in C
and in Python, compiled with every model that uses it) driven by a table of integers (the
structure), a vector of constants (expressions in the parameters, evaluated at run time) and a
vector of inputs (expressions in states, port variables and other intermediates). The routine
returns its outputs and, when it propagates tangents, their directional derivatives
``dout = ∂out/∂in · din`` for given directions of its inputs, by which the compiler's chain rule
passes through it. :meth:`porthamiltonian.modeling.component.Builder.call` declares one; the
multibody kernel (:mod:`porthamiltonian.mechanics.kernel`) is the one the package ships.

Each output is an intermediate whose expression is ``KernelOutput(Str(call), k, *inputs)``: an
unevaluated function of the inputs, so that the compiler orders it after its inputs, substitutes
solved port variables in its inputs and knows what it depends on, like any intermediate. The code
generator evaluates each call once (:mod:`porthamiltonian.compiler.codegen`); nothing
differentiates a ``KernelOutput`` symbolically.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sympy as sp
from sympy.core.symbol import Str

#: the kernels the printers know: name -> entries with tangents, entries without
KERNELS = {
    "multibody": ({"mb_state", "mb_load", "mb_constrained"}, {"mb_mass", "mb_jacobians", "mb_poses", "mb_momenta"}),
}
#: kernel name -> entries that can keep their work, entries that can reuse it (see
#: :class:`KernelCall`'s ``after``): the printers call ``<entry>_keep`` and ``<entry>_reuse``
WORK = {"multibody": ({"mb_state"}, {"mb_constrained"})}


class KernelOutput(sp.Function):
    """Output ``k`` of the kernel call named ``call``: ``KernelOutput(Str(call), Integer(k),
    *inputs)`` (see the module docstring). Real, never evaluated, never differentiated."""

    is_real = True

    @property
    def call(self) -> str:
        """The qualified name of the call."""
        return str(self.args[0].name)

    @property
    def index(self) -> int:
        """The output's index in the call's output vector."""
        return int(self.args[1])

    @property
    def inputs(self) -> tuple[sp.Expr, ...]:
        """The call's input expressions."""
        return tuple(self.args[2:])


@dataclass(frozen=True)
class KernelCall:
    """One kernel call of a component (see the module docstring).

    ``name``: qualified, unique in the model (``component.name``); ``kernel`` and ``entry``: the
    routine (one of :data:`KERNELS`); ``table``: its integers; ``constants``: parameter
    expressions; ``n_inputs``, ``n_outputs``: the sizes of its vectors; ``tangents``: whether the
    entry propagates tangent directions (else its outputs may not reach the state equations);
    ``after``: the name of an earlier call of the same kernel whose outputs this call reads and
    whose work it may reuse (:data:`WORK`; e.g. the constrained entry of a multibody after its
    state entry: the tree, M's factors and the twists at the same (q, v) are computed once). The
    kernel checks that the work is at its own inputs (else it computes it), so sharing never
    changes a number.
    """

    name: str
    kernel: str
    entry: str
    table: tuple[int, ...]
    constants: tuple[sp.Expr, ...]
    n_inputs: int
    n_outputs: int
    tangents: bool
    after: str = ""


def outputs(call: str, inputs: list[Any], n_outputs: int) -> list[sp.Expr]:
    """The output expressions ``KernelOutput(Str(call), k, *inputs)`` of a call."""
    tag = Str(call)
    args = [sp.sympify(x) for x in inputs]
    return [KernelOutput(tag, sp.Integer(k), *args) for k in range(n_outputs)]


__all__ = ["KERNELS", "WORK", "KernelCall", "KernelOutput", "outputs"]
