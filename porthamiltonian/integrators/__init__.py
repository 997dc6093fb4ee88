"""Integration loops: compiled with a model's generated functions (C), or once for all models
(numba), or run as Python (the reference).

``rosenbrock_loop.py`` and ``rosenbrock_loop.c`` are source templates of one step loop (stages,
LU, error control, dense output, event location) for the Rosenbrock methods of
:mod:`.tableaus` (Rodas4, Rodas5P); ``bdf_loop.py`` and ``bdf_loop.c`` the loop of QBDF
(:mod:`.bdf`: variable-order BDF reusing its Jacobian and LU over steps), which uses the
Rosenbrock template's LU, dense output, event location and sensitivity step;
``common_loop.py`` and ``common_loop.c`` hold what both loops do alike (the result buffers, the
checks before a step, the end of an accepted step: events, Φ, the stored point). The C back end
appends the C templates and each method's entry point to every model's translation unit, where
the loops call the model's ``rhs``, ``jac`` and ``guards`` directly. The Python templates take
the model's functions as their first argument ``fn = (rhs, jac, guards, jac_p)``: the python
back end compiles them once per process, in a module of their own, and binds ``fn`` to each
model's functions (the same algorithm run as a reference:
:func:`porthamiltonian.backends.module.python_loop_module`); the numba back end compiles them
once, in a module of their own, for ``fn`` typed as first-class functions, and every model's
loops call that one compiled code (:mod:`porthamiltonian.backends.numba_loops`). Under numba
and C the whole step loop is machine code.

Every entry point takes ``(t0, y0, t_end, p, rtol, atol, h0, hmax, directions, terminal,
mask_index, mask_sign, n_model, bound, max_steps, store_cap, tgrad_step)`` (after ``fn`` in the
Python templates; bound by the back ends) and returns the
15-tuple documented in ``rosenbrock_loop.py`` (``_rosenbrock``); the variational entry points
``integrate_<method>_variational`` take the initial sensitivities ``phi0`` (n x m) as one more
argument and return the 18-tuple (Φ at the end, at the stored points, its error estimate).
"""
from pathlib import Path

from . import bdf
from .tableaus import TABLEAUS, Tableau, c_entry, python_entry

_HERE = Path(__file__).parent

#: Every compiled method: its name in ``simulate(method=...)`` -> its symbol in generated code
#: (entry points ``integrate_<symbol>`` in Python, ``ph_integrate_<symbol>`` in C, each with a
#: ``_variational`` twin).
LOOPS: dict[str, str] = {**{name: tab.symbol for name, tab in TABLEAUS.items()},
                         bdf.NAME: bdf.SYMBOL}
#: The names of the compiled methods.
COMPILED_METHODS: tuple[str, ...] = tuple(LOOPS)


def _plain(text: str, loop: str) -> str:
    """A copy of the function ``loop`` (the last one of ``text``) named ``<loop>_plain``, with
    the Φ step replaced by the no-op ``_no_variational`` and the end of a step by its copy
    ``_finish_step_plain``."""
    body = text[text.index(f"@_jit\ndef {loop}("):]
    return (body.replace(f"def {loop}(", f"def {loop}_plain(", 1)
            .replace("_variational_step(", "_no_variational(")
            .replace("_finish_step(", "_finish_step_plain("))


def python_loops() -> str:
    """The Python loop templates, a copy of each loop for runs without sensitivities, and every
    method's tables and entry point.

    The copies, ``_rosenbrock_plain`` and ``_bdf_plain``, are the loops (each template's last
    function) calling ``_finish_step_plain``, the copy of the shared end of a step
    (``common_loop.py``) with the Φ step replaced by the no-op ``_no_variational``: numba
    compiles a function with everything it calls, so the plain entry points would otherwise
    compile the variational code too (measured, CPU time of the pendulum's first numba run: 23 s
    without the copy, 16 s with it, 15.5 s before sensitivities existed)."""
    rosenbrock = (_HERE / "rosenbrock_loop.py").read_text()
    common = (_HERE / "common_loop.py").read_text()
    multistep = (_HERE / "bdf_loop.py").read_text()
    return "\n\n".join([rosenbrock, common, _plain(common, "_finish_step"),
                        _plain(rosenbrock, "_rosenbrock"),
                        *(python_entry(tab) for tab in TABLEAUS.values()),
                        multistep, _plain(multistep, "_bdf"), bdf.python_entry()])


def c_loops(multistep: bool = True) -> str:
    """The C loop templates followed by every method's tables and exported entry point:
    ``common_loop.c`` (which calls the Rosenbrock template's helpers and is called by both loops)
    stands between the helpers of ``rosenbrock_loop.c`` and its loop ``rosenbrock``; without
    ``multistep``, the Rosenbrock methods alone (QBDF's loop left out: an FMU's co-simulation
    runs one of :data:`TABLEAUS`)."""
    rosenbrock = (_HERE / "rosenbrock_loop.c").read_text()
    cut = rosenbrock.index("static int rosenbrock(")
    return "\n".join([rosenbrock[:cut], (_HERE / "common_loop.c").read_text(),
                      rosenbrock[cut:], *(c_entry(tab) for tab in TABLEAUS.values()),
                      *([(_HERE / "bdf_loop.c").read_text(), bdf.c_entry()] if multistep
                        else [])])


#: the lines of rosenbrock_loop.c around the macros of the entry points' parameters
_PARAMS = ("/* ph: the entry points' parameters */",
           "/* ph: end of the entry points' parameters */")


def c_entry_declarations() -> str:
    """The loops' entry points declared for a translation unit that calls them but is linked
    with the loops' object instead of holding them (an FMU's binary): the parameter macros of
    ``rosenbrock_loop.c`` and, for every method of :data:`TABLEAUS`, ``ph_integrate_<symbol>``
    and its ``_variational`` twin, hidden (``PH_HIDDEN``, which the unit defines)."""
    text = (_HERE / "rosenbrock_loop.c").read_text()
    params = text[text.index(_PARAMS[0]):text.index(_PARAMS[1]) + len(_PARAMS[1])]
    return params + "\n" + "".join(
        f"PH_HIDDEN int ph_integrate_{tab.symbol}(PH_LOOP_PARAMS);\n"
        f"PH_HIDDEN int ph_integrate_{tab.symbol}_variational(PH_LOOP_PARAMS, PH_PHI_PARAMS);\n"
        for tab in TABLEAUS.values())


__all__ = ["COMPILED_METHODS", "LOOPS", "TABLEAUS", "Tableau", "c_entry_declarations", "c_loops",
           "python_loops"]
