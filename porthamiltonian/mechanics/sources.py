"""The source templates of the kernels the code generator inserts into generated modules.

:mod:`porthamiltonian.modeling.calls` names the kernels; the printers
(:mod:`porthamiltonian.compiler.printers`) insert a kernel's Python template
(:mod:`.kernel`, run by CPython or compiled by numba with the model's module) or C template
(``kernel.c``, compiled in the model's translation unit) once into every module that calls it.
"""
from __future__ import annotations

import hashlib
from functools import cache
from pathlib import Path

from ..modeling.calls import KERNELS, WORK

_HERE = Path(__file__).parent
#: kernel name -> (Python template, C template), files of this package
_FILES = {"multibody": ("kernel.py", "kernel.c")}
#: kernel name -> its entries without tangents, appended to both templates: entry -> (the
#: quantity's code in _mb_position_values / mb_positions_entry, what the entry returns)
_POSITION_ENTRIES = {"multibody": {
    "mb_mass": (0, "The mass matrix M(q) (nv x nv, row-major)"),
    "mb_jacobians": (1, "Per site the world Jacobian of its velocity (3 x nv, row-major)"),
    "mb_poses": (2, "Per site its world position and its link's unit quaternion (7)"),
    "mb_momenta": (3, "M(q) v for values (q, v)"),
}}


@cache
def python_template(kernel: str) -> str:
    """The Python source of ``kernel`` (its functions decorated with the module's ``_jit``)
    followed by its entries without tangents (``_POSITION_ENTRIES``)."""
    return (_HERE / _FILES[kernel][0]).read_text() + "".join(
        f'\n\n@_jit\ndef {entry}(s, c, values, din):\n    """{doc}, no tangents: (out, empty)."""\n'
        f"    return _mb_position_values({what}, s, c, values), np.zeros((0, 0))\n"
        for entry, (what, doc) in _POSITION_ENTRIES[kernel].items())


@cache
def c_template(kernel: str) -> str:
    """The C99 source of ``kernel`` (functions ``ph_<entry>``, static unless ``MB_ENTRY`` is
    defined before it)."""
    return (_HERE / _FILES[kernel][1]).read_text() + "".join(
        f"\n/* {doc}, no tangents (K, din, dout unused) */\n"
        f"MB_ENTRY void ph_{entry}(const int *s, const double *c, const double *in, double *out, "
        "int K,\n                        const double *din, double *dout)\n"
        f"{{\n    (void)K; (void)din; (void)dout;\n    mb_positions_entry({what}, s, c, in, out);\n}}\n"
        for entry, (what, doc) in _POSITION_ENTRIES[kernel].items())


_HIDDEN = ('#if defined(__GNUC__) && !defined(PH_HIDDEN)\n'
           '#define PH_HIDDEN __attribute__((visibility("hidden")))\n'
           '#elif !defined(PH_HIDDEN)\n#define PH_HIDDEN\n#endif\n')


def c_object_source(kernel: str) -> str:
    """A translation unit of ``kernel`` alone, its entries ``ph_<entry>`` external but hidden
    (not exported from the library they are linked into): compiled once and linked into every
    model library that calls it (:func:`porthamiltonian.backends.native.compile_object`)."""
    return ("#include <math.h>\n#include <stdint.h>\n#include <stdlib.h>\n#include <string.h>\n"
            + _HIDDEN + "#define MB_ENTRY PH_HIDDEN\n" + c_template(kernel))


def c_declarations(kernel: str) -> str:
    """The declarations of ``kernel``'s entries, for a translation unit that calls them (with
    the ``_keep`` and ``_reuse`` twins of :data:`~porthamiltonian.modeling.calls.WORK`'s)."""
    keeps, reuses = WORK.get(kernel, (set(), set()))
    entries = [(entry, "") for entry in sorted(KERNELS[kernel][0] | KERNELS[kernel][1])]
    entries += [(f"{entry}_keep", ", double **work") for entry in sorted(keeps)]
    entries += [(f"{entry}_reuse", ", const double *work") for entry in sorted(reuses)]
    return _HIDDEN + "".join(
        f"PH_HIDDEN void ph_{entry}(const int *s, const double *c, const double *in, double *out, "
        f"int K, const double *din, double *dout{work});\n" for entry, work in entries)


@cache
def digest() -> str:
    """A short hash of every kernel template (part of the code generator's version)."""
    h = hashlib.sha256()
    for kernel in sorted(_FILES):
        h.update(python_template(kernel).encode() + b"\0" + c_template(kernel).encode())
    return h.hexdigest()[:12]


__all__ = ["c_declarations", "c_object_source", "c_template", "digest", "python_template"]
