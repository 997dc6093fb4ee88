"""Numeric back ends: turn generated source into callables. No sympy here.

``c``       the generated functions and the integration loops as one C99 translation unit,
            compiled by the machine's C compiler into a shared library and called through
            ctypes (:mod:`.native`); picked by ``"auto"`` when a compiler works.
``numba``   the generated Python compiled with ``numba.njit(cache=True)`` (:mod:`.module`;
            ``pip install porthamiltonian[fast]``).
``python``  the reference: the generated straight-line Python run by CPython on Python floats.

A back end yields a :class:`Functions` record; models and analyses only see it (and
:class:`~porthamiltonian.simulation.compiled.CompiledModel`).

``"auto"`` tries ``c``, then ``numba`` (when installed), then ``python``; the environment
variable ``PORTHAMILTONIAN_BACKEND`` (``c``, ``numba`` or ``python``) makes ``"auto"`` mean that
back end instead (e.g. to run a test suite on the numba back end).
"""
from __future__ import annotations

import contextlib
import importlib.util
import os
import sys
import warnings
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ModelError


def beyond_floats(err: BaseException) -> bool:
    """Whether ``err``, raised by the python back end's generated code, is Python's arithmetic
    where C's gives inf or NaN: an ``ArithmeticError`` (an overflow, a division by zero), a
    ``math`` function outside its domain ("math domain error"), or a complex number (``**`` of
    a negative float to a fractional power) stored as a float (``TypeError``)."""
    return (isinstance(err, ArithmeticError) or str(err) == "math domain error"
            or (isinstance(err, TypeError) and "complex" in str(err)))


def at_points(fn: Callable, t: Any, xs: Any, p: Any) -> np.ndarray:
    """``fn(t_i, xs[i], p)`` (a model function of a :class:`Functions`) at every point, stacked
    (len(t), *shape): in one call where the back end has one (the C back end's ``fn.many``),
    else a call per point (each row made contiguous, as numba's signature wants)."""
    many = getattr(fn, "many", None)
    if many is not None:
        return np.asarray(many(t, xs, p))
    rows = np.ascontiguousarray(xs, dtype=float)
    return np.array([np.asarray(fn(tk, rows[k], p)) for k, tk in enumerate(t)])


#: The back ends, in the order ``"auto"`` tries them.
BACKENDS = ("c", "numba", "python")
#: The environment variable that chooses what ``"auto"`` means.
BACKEND_VARIABLE = "PORTHAMILTONIAN_BACKEND"
#: The environment variable that silences the one-line build reports (any non-empty value).
QUIET_VARIABLE = "PORTHAMILTONIAN_QUIET"


class BackendWarning(UserWarning):
    """The back end asked for (``"auto"``: the C back end) cannot be used; the message says why
    and which back end is used instead."""


@dataclass(frozen=True)
class Functions:
    """The numeric functions of a compiled model (see :mod:`porthamiltonian.compiler.codegen`).

    Each takes ``(t, x, p)`` (``initial`` takes ``p``) where ``x`` and ``p`` are float arrays and
    returns a float array. ``backend`` names what produced them. ``loops`` maps a method name
    (``"Rodas4"``, ``"Rodas5P"``, ``"QBDF"``) to its compiled integration loop, ``variational`` to the same
    loop integrating the sensitivities too (the calling conventions of
    :mod:`porthamiltonian.integrators`). ``extra`` maps the name of every further generated
    function (``jac_u``, ``out_jac``, ``jac_p``, the pH form's; see
    :mod:`porthamiltonian.compiler.codegen`) to its callable, ``(t, x, p)`` like ``jac``.
    """

    backend: str
    rhs: Callable
    jac: Callable
    energy: Callable
    outputs: Callable
    guards: Callable
    initial: Callable
    matrices: tuple[Callable, ...] = ()
    loops: Mapping[str, Callable] = field(default_factory=dict)
    variational: Mapping[str, Callable] = field(default_factory=dict)
    extra: Mapping[str, Callable] = field(default_factory=dict)

    @property
    def rodas(self) -> Callable:
        """The compiled Rodas4 loop (``loops["Rodas4"]``)."""
        return self.loops["Rodas4"]


def numba_available() -> bool:
    """True when numba can be imported (the ``fast`` extra)."""
    return importlib.util.find_spec("numba") is not None


def candidates(backend: str) -> tuple[str, ...]:
    """The back ends to try for ``backend``, in order: ``"auto"`` -> ``c``, ``numba`` (when
    installed), ``python`` (or the one ``$PORTHAMILTONIAN_BACKEND`` names); an explicit name ->
    itself (checked)."""
    if backend == "auto":
        forced = os.environ.get(BACKEND_VARIABLE, "").strip()
        if not forced:
            return tuple(b for b in BACKENDS if b != "numba" or numba_available())
        backend, source = forced, f"${BACKEND_VARIABLE}"
    else:
        source = "back end"
    if backend not in BACKENDS:
        raise ModelError(f"unknown {source} {backend!r}; choose 'auto', "
                         f"{', '.join(repr(b) for b in BACKENDS)}")
    if backend == "numba" and not numba_available():
        raise ModelError("back end 'numba' needs numba: pip install 'porthamiltonian[fast]'")
    return (backend,)


def fell_back(reason: str, instead: str) -> None:
    """Warn (one line) that the C back end is not used under ``"auto"``, and what is."""
    warnings.warn(f"C back end not used: {reason}; using the {instead} back end instead",
                  BackendWarning, stacklevel=3)


#: set while :func:`quiet` is in force (the command lines' ``--quiet``)
_SILENCED: list[bool] = []


def report(line: str) -> None:
    """One line on stderr about a build (nothing when ``$PORTHAMILTONIAN_QUIET`` is set or
    inside :func:`quiet`)."""
    if not os.environ.get(QUIET_VARIABLE) and not any(_SILENCED):
        print(line, file=sys.stderr, flush=True)


@contextlib.contextmanager
def quiet(enabled: bool = True) -> Iterator[None]:
    """Within this context no build line is printed when ``enabled`` (``--quiet``)."""
    _SILENCED.append(enabled)
    try:
        yield
    finally:
        _SILENCED.pop()


__all__ = ["BACKENDS", "BACKEND_VARIABLE", "QUIET_VARIABLE", "BackendWarning", "Functions",
           "at_points", "beyond_floats", "candidates", "fell_back", "numba_available", "quiet", "report"]
