"""The numba back end's integration loops, compiled once for all models.

The loop templates (:mod:`porthamiltonian.integrators`) take the model's functions as their first
argument, ``fn = (rhs, jac, guards, jac_p)``. Under the numba back end they live in one module of
their own, :func:`loops_text`, which the compiler keeps in a cache entry of its own (keyed by the
text) with numba's on-disk cache verified like a model's (:mod:`porthamiltonian.compiler.
numba_cache`). Each entry point is compiled for ``fn`` typed as a tuple of numba first-class
function types (``numba.types.FunctionType``: the functions' signatures, not the functions), so
that one compiled loop, one file of numba's cache, serves every model whose functions have those
signatures — every generated model: ``(float64, float64[::1], float64[::1])`` to a C-contiguous
float64 array. A model then JITs only its own functions (rhs, jac, guards, jac_p, ...); the loop
calls them through their addresses with numba's own calling convention (an exception raised in a
model function, e.g. a division by zero, reaches the caller as usual).

:class:`BoundLoop` is a loop entry point bound to one model's functions, called as the loops of
the other back ends are (the conventions of :mod:`porthamiltonian.integrators`).
"""
from __future__ import annotations

import threading
import types as pytypes
import warnings
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ..errors import OptionError
from ..integrators import LOOPS, python_loops

#: The header of the numba back end's modules (a model's functions, the loops).
HEADER = ("import math\nimport numpy as np\nfrom numba import njit as _njit\n"
          "_jit = _njit(cache=True)\n")
#: The model functions a loop calls, in the order of its argument ``fn``.
LOOP_FUNCTIONS = ("rhs", "jac", "guards", "jac_p")
#: One compile at a time in a process: two threads starting the same loop (the Floquet pair's
#: runs) compile it once, and the warnings filter set around a compile is not undone by the
#: other thread's compile finishing first.
_COMPILING = threading.Lock()


def loops_text() -> str:
    """The source of the numba back end's loop module: the header and every loop template with
    its methods' entry points (each taking ``fn`` first)."""
    return ('"""The integration loops of porthamiltonian\'s numba back end, compiled once for '
            'all models. Do not edit."""\n' + HEADER + "\n\n" + python_loops())


#: The kinds of a loop entry point's arguments after ``fn`` (:mod:`porthamiltonian.integrators`):
#: f a float, i an integer, v a float vector, d the event directions (integers), b the terminal
#: flags (booleans); a variational entry point's ``phi0`` and ``gain`` (m: float matrices) follow.
_KINDS = "fvfvfvffdbififiif"


def _argument(kind: str, value: Any) -> Any:
    """``value`` as the loop's argument of ``kind`` (:data:`_KINDS`): a Python float or int, or
    a contiguous, writable array of the kind's type — so that every call has the argument
    types the loop was compiled for (numba compiles a function once per argument types)."""
    if kind == "f":
        return float(value)
    if kind == "i":
        return int(value)
    dtype, ndim = {"v": (np.float64, 1), "d": (np.int64, 1), "b": (np.bool_, 1),
                   "m": (np.float64, 2)}[kind]
    out: np.ndarray = np.ascontiguousarray(value, dtype=dtype)
    if out.ndim != ndim:
        raise OptionError(f"a loop argument of {ndim} dimension(s) has shape {out.shape}")
    return out if out.flags.writeable else out.copy()


def _numba_type(kind: str) -> Any:
    from numba import types

    return {"f": types.float64, "i": types.int64, "v": types.float64[::1],
            "d": types.int64[::1], "b": types.boolean[::1], "m": types.float64[:, ::1]}[kind]


class BoundLoop:
    """A loop entry point of the shared module bound to one model's functions ``fn`` (numba
    dispatchers), called as the other back ends' loops are: ``loop(*args)`` converts the
    arguments to the types the loop is compiled for (:func:`_argument`) and runs the entry point
    compiled with ``fn`` typed as first-class functions — compiled, or read from numba's cache,
    at the first call in a process, the model's functions compiled for the loop's argument
    types ``(float64, float64[::1], float64[::1])`` then."""

    def __init__(self, entry: Any, fn: tuple[Any, ...], variational: bool) -> None:
        self.entry = entry
        self.fn = fn
        self.kinds = _KINDS + ("mm" if variational else "")
        self._run: Callable[..., Any] | None = None

    def __call__(self, *args: Any) -> Any:
        if len(args) != len(self.kinds):
            raise OptionError(f"the loop takes {len(self.kinds)} arguments, got {len(args)}")
        run = self._run or self._compile()
        return run(self.fn, *(_argument(k, a) for k, a in zip(self.kinds, args)))

    def _compile(self) -> Callable[..., Any]:
        from numba import types
        from numba.core.errors import NumbaExperimentalFeatureWarning

        arguments = (types.float64, types.float64[::1], types.float64[::1])
        with _COMPILING:
            if self._run is not None:              # compiled by another thread meanwhile
                return self._run
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", NumbaExperimentalFeatureWarning)
                signatures = []
                for f in self.fn:
                    f.compile(arguments)
                    signatures.append(types.FunctionType(f.overloads[arguments].signature))
                full = (types.Tuple(signatures), *(_numba_type(k) for k in self.kinds))
                self.entry.compile(full)
            self._run = self.entry.overloads[full].entry_point
        return self._run


def bind(loops: pytypes.ModuleType, fn: tuple[Any, ...]
         ) -> tuple[Mapping[str, BoundLoop], Mapping[str, BoundLoop]]:
    """(the plain loops, the variational loops) of the shared module ``loops``, by method name,
    bound to the model's functions ``fn`` (:data:`LOOP_FUNCTIONS`)."""
    def bound(symbol: str, variational: bool) -> BoundLoop:
        return BoundLoop(getattr(loops, f"integrate_{symbol}"), fn, variational)

    return ({name: bound(symbol, False) for name, symbol in LOOPS.items()},
            {name: bound(f"{symbol}_variational", True) for name, symbol in LOOPS.items()})


__all__ = ["HEADER", "LOOP_FUNCTIONS", "BoundLoop", "bind", "loops_text"]
