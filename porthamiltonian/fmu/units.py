"""SI units of the model as FMI unit definitions: a unit's exponents of the SI base units.

The model's units are strings such as ``"N*s/m^2"`` or ``"kg*m^2"``: symbols joined by ``*`` and
``/`` (everything after a ``/`` up to the next ``*`` divides), each with an optional integer
exponent ``^k``. :func:`base_unit` gives the exponents of kg, m, s, A, K, mol, cd and rad (FMI's
``BaseUnit``) and the factor to SI (1 for SI units, 1e-3 for g, π/180 for deg), or None for a
string it does not read (the FMU then declares the unit by name only).
"""
from __future__ import annotations

import math
import re

__all__ = ["BASE", "base_unit"]

#: FMI's base units, in the order of the BaseUnit attributes
BASE = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")


def _u(factor: float = 1.0, **exponents: int) -> tuple[float, dict[str, int]]:
    return factor, exponents


#: symbol -> (factor to SI, exponents of the base units)
_SYMBOLS: dict[str, tuple[float, dict[str, int]]] = {
    "1": _u(), "kg": _u(kg=1), "g": _u(1e-3, kg=1), "m": _u(m=1), "s": _u(s=1), "A": _u(A=1),
    "K": _u(K=1), "mol": _u(mol=1), "cd": _u(cd=1), "rad": _u(rad=1),
    "deg": _u(math.pi / 180.0, rad=1),
    "N": _u(kg=1, m=1, s=-2), "J": _u(kg=1, m=2, s=-2), "W": _u(kg=1, m=2, s=-3),
    "Pa": _u(kg=1, m=-1, s=-2), "Hz": _u(s=-1), "C": _u(A=1, s=1),
    "V": _u(kg=1, m=2, s=-3, A=-1), "ohm": _u(kg=1, m=2, s=-3, A=-2),
    "Ohm": _u(kg=1, m=2, s=-3, A=-2), "F": _u(kg=-1, m=-2, s=4, A=2),
    "H": _u(kg=1, m=2, s=-2, A=-2), "Wb": _u(kg=1, m=2, s=-2, A=-1), "T": _u(kg=1, s=-2, A=-1),
    "S": _u(kg=-1, m=-2, s=3, A=2),
}
_FACTOR = re.compile(r"^([A-Za-z]+|1)(?:\^([+-]?\d+))?$")


def base_unit(unit: str) -> tuple[float, dict[str, int]] | None:
    """(factor to SI, nonzero exponents by base unit) of ``unit``, or None if it cannot be
    read (see the module docstring)."""
    text = unit.replace(" ", "")
    if not text:
        return None
    factor, exponents = 1.0, dict.fromkeys(BASE, 0)
    sign = 1
    for i, token in enumerate(re.split(r"([*/])", text)):
        if i % 2:
            sign = -1 if token == "/" else 1
            continue
        m = _FACTOR.match(token)
        if m is None or m.group(1) not in _SYMBOLS:
            return None
        power = sign * int(m.group(2) or 1)
        f, exps = _SYMBOLS[m.group(1)]
        factor *= f ** power
        for name, e in exps.items():
            exponents[name] += e * power
    return factor, {k: v for k, v in exponents.items() if v}
