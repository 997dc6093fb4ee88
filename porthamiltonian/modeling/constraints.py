"""Physical constraints on component arguments (a mass > 0, a damping >= 0, μ_c <= μ_st), checked
the same way whether the argument is a number in the model or a parameter bound at run time.

A component declares them (``Arg(rule=">")`` for one argument, ``Component.relations`` between
two, :meth:`~porthamiltonian.modeling.component.Builder.require` for a nested field); the builder checks a
constraint at once when both sides are numbers, and otherwise records it as a
:class:`Constraint` whose two sides are written in the expression language over the model's
(flat) parameter names. The compiler stores the records in the compiled model's metadata (and so
in the cache); :meth:`CompiledModel.params` evaluates them for every parameter vector it builds,
with the numeric evaluator of :mod:`porthamiltonian.modeling.expressions` (no sympy at run time). An
argument that depends on states or time (a modulated stiffness) is checked only where it is a
number.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from collections.abc import Set as AbstractSet
from dataclasses import asdict, dataclass
from typing import Any

from ..errors import ParameterValueError
from .expressions import Expression, parse_text

#: The rules, by the text used in messages and metadata: value ``rule`` bound; ``"real"``: the
#: value is a finite real number (an expression such as sqrt(k) or 1/k at the values bound).
RULES: dict[str, Callable[[float, float], bool]] = {">": lambda a, b: a > b, ">=": lambda a, b: a >= b, "<=": lambda a, b: a <= b,
         "!=": lambda a, b: a != b, "real": lambda a, b: True}


@dataclass(frozen=True)
class Constraint:
    """``expression rule bound`` for the argument ``argument`` of ``component``.

    ``argument`` is what messages call the argument (``"argument 'mass'"``, ``"body 'leg'
    mass"``); ``expression`` and ``bound`` are text in the expression language over the model's
    flat parameter names; ``bound_name`` names the bound when it is another argument.
    """

    component: str
    argument: str
    expression: str
    rule: str
    bound: str = "0"
    bound_name: str = ""

    def to_dict(self) -> dict[str, str]:
        """The constraint as a JSON-ready table (the compiled model's metadata)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Constraint:
        """The constraint of a :meth:`to_dict` table."""
        return cls(**{k: str(v) for k, v in data.items()})


def violation(constraint: Constraint, value: float, bound: float, symbolic: bool = True) -> str | None:
    """The message for ``constraint`` at these values, or None when it holds. ``symbolic``: the
    argument is an expression in parameters (the message shows it)."""
    if math.isfinite(value) and math.isfinite(bound) and RULES[constraint.rule](value, bound):
        return None
    side = f" = {constraint.expression}" if symbolic else ""
    if constraint.rule == "real":
        return (f"component {constraint.component!r} {constraint.argument}{side} must be a finite "
                f"real number, got {value:g}")
    target = (f"{constraint.bound_name} ({bound:g})" if constraint.bound_name
              else f"{bound:g}")
    return (f"component {constraint.component!r} {constraint.argument}{side} must be "
            f"{constraint.rule} {target}, got {value:g}")


#: how many value sets a :class:`ConstraintChecker` remembers as satisfying its constraints
_PASSED = 64


class ConstraintChecker:
    """The constraints of a compiled model, parsed once; :meth:`check` evaluates them, and
    remembers the last value sets that satisfied them all (a walker's every stride binds the
    same parameters again: their check took 14 % of a compass-walker stride)."""

    def __init__(self, model_name: str, constraints: list[Mapping[str, Any]]):
        self.model_name = model_name
        self.constraints = [Constraint.from_dict(c) for c in constraints]
        self._parsed: list[tuple[Constraint, Expression, Expression]] = [
            (c, parse_text(c.expression), parse_text(c.bound)) for c in self.constraints]
        self._reads = [expr.names | bound.names for _, expr, bound in self._parsed]
        #: value sets (name, value) in the caller's order that satisfied every constraint
        self._passed: dict[tuple[tuple[str, float], ...], None] = {}

    def check(self, values: Mapping[str, float], changed: AbstractSet[str] | None = None) -> None:
        """Raise ParameterValueError naming every violated constraint and the parameters;
        ``changed``: evaluate only the constraints that read one of these parameters (the others
        held before). Values that passed before (the same names and values; NaN never does)
        pass again without evaluating anything: the constraints are functions of them alone."""
        key = tuple(values.items())
        if key in self._passed:
            return
        problems = []
        for (constraint, expr, bound), reads in zip(self._parsed, self._reads):
            if changed is not None and not reads & changed:
                continue
            try:
                message = violation(constraint, expr.evaluate(values), bound.evaluate(values))
            except (ArithmeticError, ValueError) as err:
                message = (f"component {constraint.component!r} {constraint.argument} = "
                           f"{constraint.expression} cannot be evaluated ({err})")
            if message:
                names = sorted(reads & set(values))
                problems.append(f"{message} (with {', '.join(f'{n} = {values[n]:g}' for n in names)})")
        if problems:
            raise ParameterValueError(f"model {self.model_name!r}: " + "; ".join(problems)
                                      + "; choose parameter values that satisfy "
                                      + ("these constraints" if len(problems) > 1 else "it"))
        if len(self._passed) >= _PASSED:        # bounded: forget them all (no order to keep)
            self._passed.clear()
        self._passed[key] = None


__all__ = ["RULES", "Constraint", "ConstraintChecker", "violation"]
