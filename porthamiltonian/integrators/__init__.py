"""Integration loops compiled together with a model's generated functions.

``rosenbrock_loop.py`` and ``rosenbrock_loop.c`` are source templates of one step loop (stages,
LU, error control, dense output, event location) for the Rosenbrock methods of
:mod:`.tableaus` (Rodas4, Rodas5P). The back ends append a template and each method's tables and
entry point to every generated model module (Python for the ``python`` and ``numba`` back ends,
one C translation unit for ``c``), where the loop calls that module's ``rhs``, ``jac`` and
``guards`` directly: under numba and C the whole step loop is machine code, under the python
back end the same algorithm runs as a reference.

Every entry point takes ``(t0, y0, t_end, p, rtol, atol, h0, hmax, directions, terminal,
mask_index, mask_sign, n_model, bound, max_steps, store_cap, tgrad_step)`` and returns the
14-tuple documented in ``rosenbrock_loop.py`` (``_rosenbrock``); the variational entry points
``integrate_<method>_variational`` take the initial sensitivities ``phi0`` (n x m) as one more
argument and return the 17-tuple (Φ at the end, at the stored points, its error estimate).
"""
from pathlib import Path

from .tableaus import TABLEAUS, Tableau, c_entry, python_entry

_HERE = Path(__file__).parent


def python_loops() -> str:
    """The Python loop template, a copy of its loop for runs without sensitivities, and every
    method's tables and entry point.

    The copy, ``_rosenbrock_plain``, is ``_rosenbrock`` (the template's last function) with the
    Φ step replaced by the no-op ``_no_variational``: numba compiles a function with everything
    it calls, so the plain entry points would otherwise compile the variational code too
    (measured, CPU time of the pendulum's first numba run: 23 s without the copy, 16 s with it,
    15.5 s before sensitivities existed)."""
    text = (_HERE / "rosenbrock_loop.py").read_text()
    loop = text[text.index("@_jit\ndef _rosenbrock("):]
    plain = (loop.replace("def _rosenbrock(", "def _rosenbrock_plain(", 1)
             .replace("_variational_step(", "_no_variational("))
    return "\n\n".join([text, plain, *(python_entry(tab) for tab in TABLEAUS.values())])


def c_loops() -> str:
    """The C loop template followed by every method's tables and exported entry point."""
    text = (_HERE / "rosenbrock_loop.c").read_text()
    return "\n".join([text, *(c_entry(tab) for tab in TABLEAUS.values())])


__all__ = ["TABLEAUS", "Tableau", "c_loops", "python_loops"]
