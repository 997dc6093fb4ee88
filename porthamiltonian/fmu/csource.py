"""The FMU's C sources: the generated ``model.c`` and the runtime templates beside it.

``model.c`` is the compiled model's C body (:attr:`CompiledModel.c_source
<porthamiltonian.simulation.compiled.CompiledModel>`, what the C back end compiles) with its
entry points made static (``PH_EXPORT``), the integration loops
(:func:`porthamiltonian.backends.native.translation_unit`), the compiled kernels the model calls
(a kernel multibody's recursion, :func:`porthamiltonian.mechanics.sources.c_object_source`: the
C back end links them as objects of their own, an FMU's one unit holds them), and the tables
the runtime reads: the variables by value reference, the start values, the events' directions
and flags, the rules of the :class:`~.program.EventProgram`, the co-simulation settings.
That is ``sources/model.c``, which an importer compiles alone; the FMU's own binary is compiled
from its ``linked`` version (the loops and kernels declared, their hidden objects linked:
:func:`porthamiltonian.compiler.fmu_objects`), the same code otherwise.
Strings from the model (names) are written as C string literals with every byte outside
``[A-Za-z0-9_ .]`` escaped in octal. The templates (``templates/``) are package data, copied as
they are.
"""
from __future__ import annotations

import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..backends.native import LOOP_PRAGMA, model_unit, translation_unit
from ..errors import ExportError
from ..integrators import TABLEAUS, c_entry_declarations
from .program import OPERATORS, EventProgram
from .variables import KINDS, Variable

if TYPE_CHECKING:
    from ..simulation.compiled import CompiledModel

__all__ = ["ENTRY", "TEMPLATES", "c_string", "entry_source", "model_source", "template",
           "unit_files"]

_HERE = Path(__file__).parent / "templates"
#: the runtime's files, copied into sources/ (the header first)
TEMPLATES = ("ph_fmu.h", "runtime.c", "fmi2.c", "fmi3.c")
#: the translation unit an importer compiles (sources/fmu.c)
ENTRY = "fmu.c"
#: the divergence bound of the co-simulation loop (as porthamiltonian.simulate's default)
DIVERGENCE_BOUND = 1e12
_ACCESS = {"read": "PH_READ_ONLY", "before_init": "PH_BEFORE_INIT", "tunable": "PH_TUNABLE"}
_SAFE = set(b"abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_ .")


def template(name: str) -> str:
    """The text of the runtime template ``name`` (one of :data:`TEMPLATES`)."""
    return (_HERE / name).read_text()


def c_string(text: str) -> str:
    """``text`` (UTF-8) as a C string literal; bytes outside a safe set as octal escapes."""
    return '"' + "".join(chr(b) if b in _SAFE else f"\\{b:03o}" for b in text.encode()) + '"'


def _double(value: float) -> str:
    if math.isnan(value):
        return "NAN"
    if math.isinf(value):
        return "INFINITY" if value > 0 else "(-INFINITY)"
    return repr(float(value))


def _array(ctype: str, name: str, items: Sequence[str], size: str) -> str:
    body = ",\n    ".join(items) if items else "0"
    return f"static const {ctype} {name}[{size}] = {{\n    {body}\n}};"


def model_source(model: CompiledModel, variables: Sequence[Variable], *, program: EventProgram,
                 param_start: np.ndarray, x_start: np.ndarray, states_from_parameters: bool,
                 method: str, solver: Sequence[float], token: str, model_exchange: bool,
                 co_simulation: bool, linked: bool = False) -> str:
    """The text of ``model.c`` (see the module docstring). ``linked``: the version the FMU's
    own binary is compiled from, the same but for the loops and the kernels: declared, not
    held (their hidden objects, :func:`porthamiltonian.compiler.fmu_objects`, are linked with
    it, compiled once per compiler for every FMU instead of once per FMU)."""
    n, n_par, n_out = model.n_states, len(model.param_names), len(model.output_names)
    n_in, n_slots, blocks = len(model.input_names), model.n_slots, model.discrete
    n_ev, rules = len(model.events), program.rules
    counters = [name for name, _ in program.counters]
    actions = set(program.actions())
    conditions: list[str] = []
    changes: list[str] = []
    rule_rows: list[str] = []
    for r in rules:
        first_c, first_ch = len(conditions), len(changes)
        conditions += [f"{{{c.output}, {OPERATORS.index(c.op)}}}" for c in r.conditions]
        changes += [f"{{{ch.param}, {-1 if ch.output is None else ch.output}, "
                    f"{_double(ch.constant if ch.constant is not None else 0.0)}}}"
                    for ch in r.changes]
        counter = -1 if r.counter is None else counters.index(r.counter)
        rule_rows.append(f"{{{r.event}, {first_c}, {len(r.conditions)}, {first_ch}, "
                         f"{len(r.changes)}, {int(r.energy == 'supplied')}, {int(r.stop)}, "
                         f"{counter}}}")
    kinds = {name: f"PH_{name.upper()}" for name in KINDS}
    var_rows = [f"{{{kinds[v.kind]}, {v.index}, {int(v.type == 'Integer')}, {_ACCESS[v.access]}}}"
                f"  /* {v.vr} */" for v in variables]
    y_start = [*(float(x) for x in x_start), 0.0, 0.0]
    block_states = [model.state_index(name) for block in blocks for name in block.states]
    firsts = np.cumsum([0, *(len(block.states) for block in blocks)])[:-1]
    sizes = {"PH_NX": n, "PH_NX1": max(n, 1), "PH_NP": n_par, "PH_NP1": max(n_par, 1),
             "PH_NU": n_in, "PH_NU1": max(n_in, 1), "PH_NS": n_slots, "PH_NS1": max(n_slots, 1),
             "PH_ND": len(blocks), "PH_ND1": max(len(blocks), 1),
             "PH_NO": n_out, "PH_NO1": max(n_out, 1), "PH_NE": n_ev, "PH_NE1": max(n_ev, 1),
             "PH_NC": len(counters), "PH_NC1": max(len(counters), 1), "PH_NR": len(rules),
             "PH_NR1": max(len(rules), 1), "PH_NVARS": len(variables),
             "PH_AUTONOMOUS": int(model.autonomous),
             "PH_STATES_FROM_PARAMETERS": int(states_from_parameters),
             "PH_HAS_ME": int(model_exchange), "PH_HAS_CS": int(co_simulation)}
    if linked:          # the loops after the pragma in the one unit: the rest at -O2 alike
        code = [model_unit(model.c_source), c_entry_declarations(), LOOP_PRAGMA]
    else:
        from ..mechanics.sources import c_object_source  # (the mechanics import sympy)

        code = [translation_unit(model.c_source),
                *(c_object_source(kernel) for kernel in model.meta.kernels)]
    parts = [
        (f"/* The model {c_comment_safe(model.name)} and its FMU tables, generated by "
         "porthamiltonian (docs/fmu.md).\n * Compiled as part of fmu.c: its entry points are "
         "static. */"),
        "#define PH_EXPORT static",
        *code,
        "/* --- the FMU's tables ---------------------------------------------------------- */",
        "\n".join(f"#define {k} {v}" for k, v in sizes.items()),
        f"#define PH_INTEGRATE ph_integrate_{TABLEAUS[method].symbol}",
        f"#define PH_DIVERGENCE_BOUND {_double(DIVERGENCE_BOUND)}",
        f"static const char PH_TOKEN[] = {c_string(token)};",
        f"static const char PH_MODEL_NAME[] = {c_string(model.name)};",
        _array("ph_variable", "ph_variables", var_rows, "PH_NVARS"),
        _array("double", "ph_param_start", [_double(v) for v in param_start], "PH_NS1"),
        _array("double", "ph_state_start", [_double(v) for v in y_start], "PH_N"),
        _array("double", "ph_solver_defaults", [_double(v) for v in solver], "3"),
        _array("int64_t", "ph_event_directions", [str(int(e.direction)) for e in model.events],
               "PH_NE1"),
        _array("uint8_t", "ph_event_terminal",
               [str(int(e.terminal or k in actions)) for k, e in enumerate(model.events)],
               "PH_NE1"),
        _array("uint8_t", "ph_event_action", [str(int(k in actions)) for k in range(n_ev)],
               "PH_NE1"),
        _array("char *const", "ph_event_names", [c_string(e.name) for e in model.events],
               "PH_NE1"),
        _array("ph_condition", "ph_conditions", conditions or ["{0, 0}"],
               str(max(len(conditions), 1))),
        _array("ph_change", "ph_changes", changes or ["{0, -1, 0.0}"],
               str(max(len(changes), 1))),
        _array("ph_rule", "ph_rules", rule_rows or ["{-2, 0, 0, 0, 0, 0, 0, -1}"], "PH_NR1"),
        "/* the discrete-time blocks: their period (an output), their states, their update */",
        _array("int", "ph_block_period", [str(model.output_index(b.period)) for b in blocks],
               "PH_ND1"),
        _array("int", "ph_block_first", [str(int(f)) for f in firsts], "PH_ND1"),
        _array("int", "ph_block_count", [str(len(b.states)) for b in blocks], "PH_ND1"),
        _array("int", "ph_block_states", [str(i) for i in block_states],
               str(max(len(block_states), 1))),
        _array("char *const", "ph_block_names", [c_string(b.component) for b in blocks],
               "PH_ND1"),
        _array("ph_update_fn", "ph_block_update", [_update_name(b.update) for b in blocks],
               "PH_ND1"),
    ]
    return "\n\n".join(parts) + "\n"


def _update_name(name: str) -> str:
    """A discrete block's generated update function (``update_<j>``), checked before it is
    written into C."""
    if not re.fullmatch(r"update_[0-9]+", name):
        raise ExportError(f"discrete block update function {name!r} is not a generated one")
    return name


def c_comment_safe(text: str) -> str:
    """``text`` for a C comment: no comment delimiters, printable ASCII only."""
    out = "".join(ch if 32 <= ord(ch) < 127 else "?" for ch in text)
    return out.replace("*/", "* /").replace("/*", "/ *")


def unit_files(fmi: int) -> tuple[str, ...]:
    """The files of ``sources/`` that ``fmu.c`` includes, in its order: together, the one
    translation unit."""
    return ("ph_fmu.h", "model.c", "runtime.c", f"fmi{fmi}.c")


def entry_source(fmi: int) -> str:
    """``fmu.c``: the one translation unit an importer compiles."""
    return ("/* An FMU exported by porthamiltonian (docs/fmu.md): compile this file alone, e.g.\n"
            " *   cc -O1 -std=c99 -shared -fPIC -o <modelIdentifier>.so fmu.c -lm\n"
            " * (the other files of sources/ are included from here). */\n"
            + "".join(f'#include "{name}"\n' for name in unit_files(fmi)))
