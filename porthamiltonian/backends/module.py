"""The ``python`` and ``numba`` back ends: the generated Python as an imported module.

``python``  the generated straight-line code run by CPython on Python floats (``x.tolist()``),
            measured ~4x faster than numpy-vectorized lambdify on this project's models.
``numba``   the model's functions of the same source compiled by ``numba.njit(cache=True)`` at
            their first call (numba keeps the machine code beside the module); the integration
            loops are compiled once for all models (:mod:`.numba_loops`).

Both run the integration loops of :func:`porthamiltonian.integrators.python_loops`, made once
per process for every model (python: :func:`python_loop_module`; numba: :mod:`.numba_loops`)
and bound to each model's functions, which they take as their first argument.
"""
from __future__ import annotations

import functools
import importlib.util
import linecache
import math
import sys
import types
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, cast

import numpy as np

from ..errors import CompilerError
from ..integrators import LOOPS, python_loops
from . import Functions, beyond_floats, numba_loops

_HEADERS = {
    "numba": numba_loops.HEADER,
    "python": "import math\nimport numpy as np\n\n\ndef _jit(f):\n    return f\n",
}
_NAMES = ("rhs", "jac", "energy", "outputs", "guards", "initial")


#: The loops' forcing of parameter sensitivities calls ``jac_p``; a model compiled without it
#: has this stub (no parameter columns)
JAC_P_STUB = ('@_jit\ndef jac_p(t, x, p):\n    """No parameter Jacobian generated '
              '(compile_model(..., jac_p=[...])): no columns."""\n'
              '    return np.zeros((x.shape[0], 0))\n')


def module_text(body: str, backend: str) -> str:
    """The module of ``backend``: its header and the generated body (and :data:`JAC_P_STUB` when
    it has no ``jac_p``). The integration loops are a module of their own, bound to the body's
    functions by :func:`load` (python: :func:`python_loop_module`; numba:
    :func:`.numba_loops.loops_text`)."""
    stub = "" if "def jac_p(" in body else JAC_P_STUB
    return addon_text(body, backend) + "\n\n" + stub


def addon_text(body: str, backend: str) -> str:
    """The module of ``backend`` for the body of an add-on of a model's cache entry (e.g. its
    port-Hamiltonian form's functions: :mod:`porthamiltonian.compiler`): the body's docstring,
    the back end's header, the body; no loops call its functions (:func:`load_addon`)."""
    doc = ""
    if body.startswith('"""'):          # the module's docstring first, so that it is __doc__
        end = body.index('\n"""', 3) + 4
        doc, body = body[:end] + "\n", body[end:].lstrip("\n")
    return doc + _HEADERS[backend] + "\n\n" + body


def shown_text(body: str, backend: str) -> str:
    """What ``backend`` (python, numba) runs for the model of ``body``: its module
    (:func:`module_text`) and the loop module of all models after it (``show --code``)."""
    loops = numba_loops.loops_text() if backend == "numba" else _python_loops_text()
    where = ("porthamiltonian.backends.numba_loops" if backend == "numba"
             else "porthamiltonian.backends.module.python_loop_module")
    return (module_text(body, backend) + "\n\n# --- the integration loops: one module, made "
            f"once for all models ({where}) ---\n" + loops)


#: the file name of :func:`python_loop_module`'s code (in tracebacks, with its lines)
_PYTHON_LOOPS_FILE = "<porthamiltonian python loops>"


def _python_loops_text() -> str:
    """The text of :func:`python_loop_module`: a docstring, the python header, the loops."""
    return ('"""The python back end\'s integration loops: one module for every model, bound '
            'to its functions."""\n' + _HEADERS["python"] + "\n\n" + python_loops())


@functools.cache
def python_loop_module() -> types.ModuleType:
    """The python back end's integration loops (:func:`porthamiltonian.integrators.
    python_loops`), compiled once per process: :func:`load` binds their entry points to each
    model's functions (the loops' first argument ``fn``), as the numba back end binds its
    loop module's. (Appended to every model's module instead, they were compiled again for
    every model: 13 ms of a 20 ms load of compass_walker's module.) Tracebacks show its
    lines."""
    text = _python_loops_text()
    linecache.cache[_PYTHON_LOOPS_FILE] = (len(text), None, text.splitlines(True),
                                           _PYTHON_LOOPS_FILE)
    module = types.ModuleType("_porthamiltonian_python_loops")
    module.__file__ = _PYTHON_LOOPS_FILE
    exec(compile(text, _PYTHON_LOOPS_FILE, "exec"), module.__dict__)  # noqa: S102 - our code
    return module


def load(path: Path, backend: str, n_matrices: int = 0, extra: Sequence[str] = (), *,
         source: str | None = None, attach: Callable[[Any], None] | None = None,
         loops: types.ModuleType | None = None) -> Functions:
    """Import the generated module at ``path`` and wrap its functions for ``backend``.

    ``extra``: the names of its further generated functions (e.g. ``jac_u``). ``source``: the
    module's text, already verified by the caller: it is compiled as it is (the file is not read
    again, and no bytecode is written or read). ``attach``: called with each numba dispatcher of
    the module before any is called (e.g. to give it a verified on-disk cache). ``loops``: the
    numba back end's loop module (:func:`.numba_loops.loops_text`), whose loops are bound to
    this module's functions."""
    module = import_module(path, source, attach)
    f = {name: getattr(module, name) for name in _NAMES}
    matrices = [getattr(module, f"matrix_{k}") for k in range(n_matrices)]
    called = tuple(getattr(module, name) for name in numba_loops.LOOP_FUNCTIONS)  # by the loops
    if backend == "python":
        shared = python_loop_module()
        bound: Mapping[str, Callable[..., Any]] = {
            name: functools.partial(getattr(shared, f"integrate_{symbol}"), called)
            for name, symbol in LOOPS.items()}
        variational: Mapping[str, Callable[..., Any]] = {
            name: functools.partial(getattr(shared, f"integrate_{symbol}_variational"), called)
            for name, symbol in LOOPS.items()}
        rhs, jac, energy, outputs, guards = (_on_lists(f[n]) for n in _NAMES[:5])
        return Functions("python", rhs, jac, energy, outputs, guards, f["initial"],
                         tuple(_on_lists(m) for m in matrices), bound, variational,
                         {name: _on_lists(getattr(module, name)) for name in extra})
    if loops is None:
        raise CompilerError(f"{path}: the numba back end needs its loop module")
    bound, variational = numba_loops.bind(loops, called)
    rhs, jac, energy, outputs, guards, initial = (f[n] for n in _NAMES)
    return Functions("numba", rhs, jac, energy, outputs, guards, initial, tuple(matrices), bound,
                     variational, {name: getattr(module, name) for name in extra})


def load_addon(path: Path, backend: str, names: Sequence[str], *, source: str | None = None,
               attach: Callable[[Any], None] | None = None) -> dict[str, Callable[..., Any]]:
    """Import the module of an add-on (:func:`addon_text`) at ``path`` and wrap its functions
    ``names`` for ``backend`` as :func:`load` wraps a model's further functions, by name
    (``source``, ``attach``: as for :func:`load`)."""
    module = import_module(path, source, attach)
    wrap = _on_lists if backend == "python" else (lambda fn: fn)
    return {name: wrap(getattr(module, name)) for name in names}


#: ``math``'s functions as numpy's, which answer as C's libm does where ``math``'s raise: NaN
#: outside the domain (``sqrt(-1)``, ``log(-1)``, ``acos(2)``), ±inf at a pole (``log(0)``) or
#: beyond the float range (``exp(1000)``); the others (``pi``, ``erf``, ...) are ``math``'s own
_IEEE_NAMES = {"sqrt": "sqrt", "exp": "exp", "expm1": "expm1", "log": "log", "log10": "log10",
               "log2": "log2", "log1p": "log1p", "sin": "sin", "cos": "cos", "tan": "tan",
               "asin": "arcsin", "acos": "arccos", "atan": "arctan", "atan2": "arctan2",
               "sinh": "sinh", "cosh": "cosh", "tanh": "tanh", "asinh": "arcsinh",
               "acosh": "arccosh", "atanh": "arctanh", "pow": "power", "fmod": "fmod",
               "hypot": "hypot", "cbrt": "cbrt", "fabs": "fabs"}
_IEEE_MATH = types.SimpleNamespace(**{name: getattr(math, name) for name in dir(math)
                                      if not name.startswith("_")})
for _name, _numpy_name in _IEEE_NAMES.items():
    setattr(_IEEE_MATH, _name, getattr(np, _numpy_name))


def _on_numpy_floats(fn: Callable[..., Any]) -> Callable[..., Any]:
    """``fn`` (a function of a generated module) and the module's other functions, which it may
    call, with :data:`_IEEE_MATH` for ``math``: the same code on numpy's functions."""
    namespace = dict(fn.__globals__, math=_IEEE_MATH)
    for name, value in fn.__globals__.items():
        if isinstance(value, types.FunctionType) and value.__globals__ is fn.__globals__:
            namespace[name] = types.FunctionType(value.__code__, namespace, value.__name__,
                                                 value.__defaults__, value.__closure__)
    return cast(Callable[..., Any], namespace[fn.__name__])


def _on_lists(fn: Callable[..., Any]) -> Callable[..., Any]:
    """A generated function of the python back end called with the state as a list: plain
    CPython is fastest on Python floats (the caller passes p as a list too, see
    CompiledModel.native_params).

    Python's floats raise where C's and numba's give inf or NaN (``1e200**2``: OverflowError,
    ``1/0.0``: ZeroDivisionError, e.g. for a state or parameter near the float range), and so
    do ``math``'s functions outside their domain (``math.sqrt(-1)``: "math domain error", e.g.
    an output ``sqrt(q)`` along a run where q < 0), and ``q**1.5`` of a negative q is a complex
    number that a result refuses (``TypeError``): such a call is made again on numpy's floats
    and functions (:func:`_on_numpy_floats`), which give inf and NaN as the other back ends do,
    so that a run fails or diverges as a result instead of raising out of the integrator, and
    an output is NaN where it is undefined, as on C."""
    ieee: list[Callable[..., Any]] = []

    @functools.wraps(fn)                   # its name, docstring and __wrapped__
    def on_lists(t: float, x: Any, p: Any) -> Any:
        try:
            return fn(t, x.tolist() if isinstance(x, np.ndarray) else x, p)
        except (ArithmeticError, ValueError, TypeError) as err:
            if not beyond_floats(err):
                raise
            if not ieee:
                ieee.append(_on_numpy_floats(fn))
            with np.errstate(all="ignore"):
                return ieee[0](t, np.asarray(x, dtype=float), np.asarray(p, dtype=float))
    return on_lists


def import_module(path: Path, source: str | None = None,
                  attach: Callable[[Any], None] | None = None) -> types.ModuleType:
    """The generated module at ``path``, imported once per process (named after the file's
    stem): ``source`` (its text, verified by the caller) compiled as it is, else the file;
    ``attach`` called with each of its numba dispatchers (see :func:`load`)."""
    module_name = f"_porthamiltonian_generated_{path.stem}"
    module = sys.modules.get(module_name)
    if module is None:
        if source is None:
            spec = importlib.util.spec_from_file_location(module_name, path)
            if spec is None or spec.loader is None:
                raise CompilerError(f"{path}: not a Python module")
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
        else:
            module = types.ModuleType(module_name)
            module.__file__ = str(path)
            exec(compile(source, str(path), "exec"), module.__dict__)  # noqa: S102 - our code
        if attach is not None:
            for value in list(vars(module).values()):
                if hasattr(value, "py_func") and hasattr(value, "_cache"):
                    attach(value)
        sys.modules[module_name] = module
    return module
