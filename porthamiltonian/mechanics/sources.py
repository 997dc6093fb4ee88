"""The source templates of the kernels the code generator inserts into generated modules.

:mod:`porthamiltonian.modeling.calls` names the kernels; the printers
(:mod:`porthamiltonian.compiler.printers`) insert a kernel's Python template
(:mod:`.kernel`, run by CPython or compiled by numba with the model's module) or C template
(``kernel.c``, compiled in the model's translation unit) once into every module that calls it.
"""
from __future__ import annotations

from functools import cache
from pathlib import Path

_HERE = Path(__file__).parent
#: kernel name -> (Python template, C template), files of this package
_FILES = {"multibody": ("kernel.py", "kernel.c")}


@cache
def python_template(kernel: str) -> str:
    """The Python source of ``kernel`` (its functions decorated with the module's ``_jit``)."""
    return (_HERE / _FILES[kernel][0]).read_text()


@cache
def c_template(kernel: str) -> str:
    """The C99 source of ``kernel`` (static functions ``ph_<entry>``)."""
    return (_HERE / _FILES[kernel][1]).read_text()


__all__ = ["c_template", "python_template"]
