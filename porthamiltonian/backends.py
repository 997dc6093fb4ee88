"""Numeric back ends: turn generated source into callables. No sympy here.

``python``  the reference: the generated straight-line code run by CPython on Python floats
            (``x.tolist()``), which BACKENDS.md measured ~4x faster than numpy-vectorized lambdify.
``numba``   the same source compiled with ``numba.njit(cache=True)``; picked automatically when
            numba is installed (``pip install porthamiltonian[fast]``).

A back end yields a :class:`Functions` record. A later fully compiled integration loop (RHS,
Jacobian and guards compiled together with the stepper) plugs in here as another back end: models
and analyses only see :class:`Functions` and :class:`~porthamiltonian.compiled.CompiledModel`.
"""
from __future__ import annotations

import importlib.util
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import ModelError
from .integrators import RODAS_SOURCE

_NUMBA_HEADER = "import math\nimport numpy as np\nfrom numba import njit as _njit\n_jit = _njit(cache=True)\n"
_PYTHON_HEADER = "import math\nimport numpy as np\n\n\ndef _jit(f):\n    return f\n"
_NAMES = ("rhs", "jac", "energy", "outputs", "guards", "initial")
#: The back ends, in the order ``"auto"`` tries them.
BACKENDS = ("numba", "python")


@dataclass(frozen=True)
class Functions:
    """The numeric functions of a compiled model (see :mod:`porthamiltonian.compiler.codegen`).

    Each takes ``(t, x, p)`` (``initial`` takes ``p``) where ``x`` and ``p`` are float arrays and
    returns a float array. ``backend`` names what produced them.
    """

    backend: str
    rhs: Callable
    jac: Callable
    energy: Callable
    outputs: Callable
    guards: Callable
    initial: Callable
    matrices: tuple[Callable, ...] = ()
    #: the compiled Rodas4 step loop (see porthamiltonian/integrators/rodas_loop.py)
    rodas: Callable | None = None


def numba_available() -> bool:
    """True when numba can be imported (the ``fast`` extra)."""
    return importlib.util.find_spec("numba") is not None


def resolve(backend: str) -> str:
    """``"auto"`` -> ``"numba"`` when installed, else ``"python"``; validate explicit names."""
    if backend == "auto":
        return "numba" if numba_available() else "python"
    if backend not in ("python", "numba"):
        raise ModelError(f"unknown back end {backend!r}; choose 'auto', 'python' or 'numba'")
    if backend == "numba" and not numba_available():
        raise ModelError("back end 'numba' needs numba: pip install 'porthamiltonian[fast]'")
    return backend


def source_with_header(body: str, backend: str) -> str:
    """Full module text: back-end header + generated body with each function decorated + the
    compiled integration loop (which calls the body's functions directly)."""
    header = _NUMBA_HEADER if backend == "numba" else _PYTHON_HEADER
    decorated = body.replace("\ndef ", "\n@_jit\ndef ")
    return header + "\n\n" + decorated + "\n\n" + RODAS_SOURCE


def load(path: Path, backend: str, n_matrices: int = 0) -> Functions:
    """Import the generated module at ``path`` and wrap its functions for ``backend``."""
    module_name = f"_porthamiltonian_generated_{path.stem}"
    module = sys.modules.get(module_name)
    if module is None:
        spec = importlib.util.spec_from_file_location(module_name, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        sys.modules[module_name] = module
    f = {name: getattr(module, name) for name in _NAMES}
    matrices = [getattr(module, f"matrix_{k}") for k in range(n_matrices)]
    if backend == "python":
        # plain CPython is fastest on Python floats: hand the generated code lists (the caller
        # passes p as a list too, see CompiledModel.native_params)
        def wrap(fn):
            return lambda t, x, p: fn(t, x.tolist() if isinstance(x, np.ndarray) else x, p)
        return Functions("python", *(wrap(f[n]) for n in _NAMES[:5]), f["initial"],
                         tuple(wrap(m) for m in matrices), module.rodas_integrate)
    return Functions("numba", *(f[n] for n in _NAMES), tuple(matrices), module.rodas_integrate)
