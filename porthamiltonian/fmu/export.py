"""``export_fmu``: a compiled model as a Functional Mock-up Unit (FMI 2.0 or 3.0).

Steps: check the arguments (Python-level events and actions are refused, the event program is
checked against the model), build the variable table, write the C sources (``model.c`` and the
runtime templates), compile them with the C back end's compiler into the platform's shared
library (a compiler failure raises :class:`~porthamiltonian.errors.CompilerError` naming the file
that holds the compiler's output), write ``modelDescription.xml``, the documentation and, for
FMI 3.0, ``sources/buildDescription.xml``, and zip everything into the FMU (written next to its
destination and renamed into place: an existing file is replaced only by a complete FMU).
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import platform
import re
import sys
import tempfile
import time
import uuid
import zipfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import userfiles
from ..backends import native
from ..errors import ExportError, OptionError
from ..integrators import TABLEAUS
from ..version import __version__
from .csource import ENTRY, TEMPLATES, entry_source, model_source, template, unit_files
from .description import Experiment, Interface, build_description, model_description
from .documentation import Page, index_html
from .program import EventProgram, check_actions
from .variables import Variable, variable_table

if TYPE_CHECKING:
    from ..simulation.compiled import CompiledModel

__all__ = ["FMI_VERSIONS", "KINDS", "export_fmu", "platform_folder"]

#: the FMI versions written
FMI_VERSIONS = (2, 3)
#: what an FMU offers: model exchange, co-simulation, or both
KINDS = {"me": ("me",), "cs": ("cs",), "both": ("me", "cs")}
_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def platform_folder(fmi: int) -> tuple[str, str]:
    """(the binaries/ folder of this platform for FMI ``fmi``, the shared library's suffix)."""
    machine = platform.machine().lower()
    arch = {"amd64": "x86_64", "x64": "x86_64", "arm64": "aarch64"}.get(machine, machine)
    bits = "64" if sys.maxsize > 2**32 else "32"
    if sys.platform.startswith("win"):
        return ("win" + bits if fmi == 2 else f"{arch}-windows"), ".dll"
    if sys.platform == "darwin":
        return ("darwin" + bits if fmi == 2 else f"{arch}-darwin"), ".dylib"
    return ("linux" + bits if fmi == 2 else f"{arch}-linux"), ".so"


def _identifier(name: str, given: str | None) -> str:
    if given is not None:
        if not isinstance(given, str) or not _IDENTIFIER.match(given):
            raise ExportError(f"model_identifier {given!r} must be a C identifier (letters, "
                              "digits, _; not starting with a digit): it names the FMU's "
                              "shared library")
        return given
    ident = re.sub(r"\W", "_", name, flags=re.ASCII) or "model"
    return f"_{ident}" if ident[0].isdigit() else ident


def _positive(name: str, value: Any, allow_inf: bool = False) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise OptionError(f"{name} must be a number, got {value!r}") from None
    if not (value > 0.0 and (math.isfinite(value) or (allow_inf and value == math.inf))):
        raise OptionError(f"{name} must be a positive{'' if allow_inf else ', finite'} number, "
                          f"got {value!r}")
    return value


def export_fmu(model: CompiledModel, path: str | os.PathLike[str], *, fmi: int | str = 2,
               kind: str = "both", program: EventProgram | None = None,
               events: Sequence[Any] = (), actions: Mapping[str, Callable] | None = None,
               x0: Mapping[str, float] | np.ndarray | None = None,
               params: Mapping[str, float] | None = None,
               inputs: Mapping[str, float] | None = None, outputs: Sequence[str] | None = None,
               method: str = "Rodas5P", rtol: float = 1e-8, atol: float = 1e-10,
               max_step: float = math.inf, start_time: float = 0.0,
               stop_time: float | None = None, step_size: float | None = None,
               description: str = "", model_identifier: str | None = None) -> Path:
    """Write ``model`` as an FMU at ``path`` (also ``compiled.export_fmu(path, ...)``).

    Parameters
    ----------
    fmi : 2 or 3 (FMI 2.0 or 3.0; ``"2.0"``, ``"3.0"`` too).
    kind : ``"me"`` (model exchange: the importer integrates the states and handles the events
        through the event indicators), ``"cs"`` (co-simulation: the FMU integrates with its own
        compiled Rosenbrock loop between communication points) or ``"both"``.
    program : what the model's events do, as data (:class:`~.program.EventProgram`: mode
        switches, the ledger's booking of their energy jumps, counters, the end of the run);
        default: nothing (events are counted; a terminal event ends the simulation).
    events, actions : Python-level events and actions (the arguments of
        :func:`porthamiltonian.simulate`) cannot run inside an FMU: given, they raise an
        :class:`~porthamiltonian.errors.ExportError` that says why.
    x0 : start values of the model states (an array or ``{state: value}`` over the initial
        state); default: the FMU computes the initial state from its parameters at
        initialization, as the model does (a state set before initialization keeps its value).
    params : parameter start values by name (defaults for the others).
    inputs : start values of the model's inputs by name (default 0): the FMI input variables
        (``[inputs]``, ``Model.input``), which the importer sets. In co-simulation an input is
        held over the communication step (FMI 2.0: extrapolated linearly when the importer gives
        its derivative, ``fmi2SetRealInputDerivatives``).
    outputs : the named outputs that are FMI outputs (default: the model's declared outputs,
        ``[outputs]``, or all named outputs when it declares none); the others are local
        variables. The ledger (``ledger.H``, ``ledger.E_diss``, ``ledger.E_in``,
        ``ledger.residual``) and the events' counts and times are outputs always.
    method, rtol, atol, max_step : the co-simulation integrator (a compiled method:
        ``"Rodas5P"`` or ``"Rodas4"``) and its settings (``solver.*`` parameters of the FMU).
    start_time, stop_time, step_size, rtol : the FMU's DefaultExperiment.
    description : the model's description (``modelDescription.xml`` and the documentation).
    model_identifier : the name of the shared library (default: the model's name as a C
        identifier).

    Returns the path written. Building needs a C compiler (the one the C back end uses, see
    :mod:`porthamiltonian.backends.native`); its failure raises
    :class:`~porthamiltonian.errors.CompilerError` with the path of the compiler's log. The
    variables, events and the co-simulation step are described in docs/fmu.md.
    """
    check_actions(model, events, actions)
    path = _destination(Path(path))
    version = _fmi_version(fmi)
    if kind not in KINDS:
        raise OptionError(f"kind must be 'me', 'cs' or 'both', got {kind!r}")
    kinds = KINDS[kind]
    program = EventProgram() if program is None else program
    if not isinstance(program, EventProgram):
        raise OptionError(f"program must be an EventProgram (porthamiltonian.fmu), got "
                          f"{type(program).__name__}")
    program.check(model)
    if not model.c_source:
        raise ExportError(f"model {model.name!r} carries no generated C code (a CompiledModel "
                          "made outside compile_model): compile it with compile_model")
    if method not in TABLEAUS:
        raise OptionError(f"method {method!r}: the co-simulation integrator is a compiled "
                          f"method, one of {', '.join(TABLEAUS)}")
    rtol = _positive("rtol", rtol)
    if rtol >= 1.0:
        raise OptionError(f"rtol must be below 1, got {rtol!r}")
    solver = (rtol, _positive("atol", atol), _positive("max_step", max_step, allow_inf=True))
    start_time = float(start_time)
    if not math.isfinite(start_time):
        raise OptionError(f"start_time must be finite, got {start_time!r}")
    if stop_time is not None and not (float(stop_time) > start_time and
                                      math.isfinite(float(stop_time))):
        raise OptionError(f"stop_time must be a finite time after start_time, got {stop_time!r}")
    if step_size is not None:
        step_size = _positive("step_size", step_size)
    p = _input_starts(model, model.params(params), inputs)
    states_from_parameters = x0 is None
    if x0 is None or isinstance(x0, Mapping):
        x_start = model.initial_state(p, x0)
    else:
        x_start = np.array(x0, dtype=float)
        if x_start.shape != (model.n_states,) or not np.all(np.isfinite(x_start)):
            raise OptionError(f"x0 must be {model.n_states} finite values "
                              f"({', '.join(model.state_names)}), got shape {x_start.shape}")
    if outputs is None:
        chosen = list(model.declared_outputs or model.output_names)
    else:
        chosen = list(outputs)
    unknown = sorted(set(chosen) - set(model.output_names))
    if unknown:
        raise OptionError(f"outputs: model {model.name!r} has no output(s) {', '.join(unknown)}")
    identifier = _identifier(model.name, model_identifier)
    periods = _sample_periods(model, start_time, x_start, p)
    if step_size is None and periods:
        step_size = min(periods)
    hmax = solver[2] if math.isfinite(solver[2]) else 1e300
    variables = variable_table(model, program=program, param_start=p, x_start=x_start,
                               states_from_parameters=states_from_parameters, outputs=chosen, solver=(solver[0], solver[1], hmax),
                               cosimulation="cs" in kinds, method=method)
    token = _token(model, variables, version, kinds, program, method, identifier)
    folder, suffix = platform_folder(version)
    files = {name: template(name) for name in TEMPLATES if name in ("ph_fmu.h", "runtime.c",
                                                                    f"fmi{version}.c")}
    files[ENTRY] = entry_source(version)

    def source(linked: bool) -> str:
        return model_source(model, variables, program=program, param_start=p, x_start=x_start,
                            states_from_parameters=states_from_parameters, method=method,
                            solver=(solver[0], solver[1], hmax), token=token,
                            model_exchange="me" in kinds, co_simulation="cs" in kinds,
                            linked=linked)

    binary = {**files, "model.c": source(linked=True)}
    library = _build("\n".join(binary[name] for name in unit_files(version)), model.meta.kernels)
    files["model.c"] = source(linked=False)
    tool = f"porthamiltonian {__version__}"
    date = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    xml = model_description(
        version, variables, model_name=model.name, token=token, description=description,
        interface=Interface(identifier, "me" in kinds, "cs" in kinds, (ENTRY,)),
        n_event_indicators=len(model.events),
        experiment=Experiment(start_time, None if stop_time is None else float(stop_time),
                              rtol, step_size),
        tool=tool, date=date)
    page = index_html(model, variables, program, Page(version, kinds, identifier, method, solver,
                                                      tool, date, folder, description,
                                                      tuple(periods)))
    members: dict[str, bytes] = {"modelDescription.xml": xml,
                                 f"binaries/{folder}/{identifier}{suffix}": library,
                                 "documentation/index.html": page.encode()}
    if version == 3:
        members["documentation/licenses/license.txt"] = (
            b"The runtime and integration loop in sources/ are part of porthamiltonian, "
            b"distributed under the BSD-3-Clause license.\nThe model is its author's.\n")
        members["sources/buildDescription.xml"] = build_description(identifier, ENTRY)
    members.update({f"sources/{name}": text.encode() for name, text in files.items()})
    return _write_zip(path, members)


def _input_starts(model: CompiledModel, p: np.ndarray,
                  inputs: Mapping[str, float] | None) -> np.ndarray:
    """``p`` with the input slots of the inputs' start values (constants: u = a, rate 0)."""
    if inputs is None:
        return p
    if not isinstance(inputs, Mapping):
        raise OptionError(f"inputs must be a mapping {{input: start value}}, got "
                          f"{type(inputs).__name__}")
    unknown = sorted(set(inputs) - set(model.input_names))
    if unknown:
        raise OptionError(f"inputs: model {model.name!r} has no input(s) {', '.join(unknown)}; "
                          f"inputs: {', '.join(model.input_names) or 'none'}")
    p = np.array(p, dtype=float)
    for name, value in inputs.items():
        try:
            value = float(value)
        except (TypeError, ValueError):
            value = math.nan
        if not math.isfinite(value):
            raise OptionError(f"inputs: the start value of input {name!r} must be a finite "
                              f"number, got {inputs[name]!r}")
        p[len(model.param_names) + model.input_names.index(name)] = value
    return p


def _sample_periods(model: CompiledModel, t0: float, x: np.ndarray, p: np.ndarray) -> list[float]:
    """The sample periods T (s) of the model's discrete-time blocks at the start (the FMU reads
    them again at its initialization, from the parameters it is given); an
    :class:`~porthamiltonian.errors.ExportError` names a block whose period is not > 0."""
    periods = []
    for block in model.discrete:
        period = float(model.output(block.period, t0, x, p))
        if not (math.isfinite(period) and period > 0.0):
            raise ExportError(f"model {model.name!r}: discrete block {block.component!r} has the "
                              f"sample period {block.period} = {period!r}: it must be a finite "
                              "number > 0")
        periods.append(period)
    return periods


def _fmi_version(fmi: int | str) -> int:
    text = str(fmi).strip()
    version = {"2": 2, "2.0": 2, "3": 3, "3.0": 3}.get(text)
    if version is None:
        raise OptionError(f"fmi must be 2 or 3 (FMI 2.0 or 3.0), got {fmi!r}")
    return version


def _token(model: CompiledModel, variables: Sequence[Variable], version: int,
           kinds: Sequence[str], program: EventProgram, method: str, identifier: str) -> str:
    """The FMU's GUID / instantiation token: a hash of what makes its interface and behaviour."""
    blob = json.dumps({"key": model.key, "variables": [repr(v) for v in variables],
                       "fmi": version, "kinds": list(kinds), "program": repr(program),
                       "method": method, "identifier": identifier,
                       "source": hashlib.sha256(model.c_source.encode()).hexdigest()},
                      sort_keys=True)
    return "{" + str(uuid.UUID(hashlib.sha256(blob.encode()).hexdigest()[:32])) + "}"


def _build(unit: str, kernels: Sequence[str]) -> bytes:
    """The shared library of the translation unit ``unit`` (:func:`~.csource.unit_files`, its
    ``model.c`` the linked version, :func:`~.csource.model_source`) linked with the loops' and
    the ``kernels``' objects (:data:`porthamiltonian.backends.native.linked_objects`). The unit
    compiles in the background meanwhile: the first export in a cache compiles the loops'
    object too."""
    advice = ("Set CC to a working C compiler: an FMU's binary is compiled C whatever back end "
              "the model was compiled with")
    if native.linked_objects is None:       # (compile_model's package sets it)
        raise ExportError("the FMU's binary links objects that porthamiltonian.compiler keeps: "
                          "compile the model with compile_model")
    job = native.start_object(unit, "fmu")
    try:
        objects = native.linked_objects(kernels, job.source, advice)
        data, _ = native.link((job.wait(None, advice=advice)[0], *objects), "fmu", None,
                              job.source, advice)
    finally:
        job.close()
    return data


def _destination(path: Path) -> Path:
    """``path``, checked before any work: a file name in a folder that exists, where nothing
    that a file must not replace is (a device, a socket, a pipe:
    :func:`~porthamiltonian.userfiles.replace_problem`)."""
    if path.is_dir():
        raise ExportError(f"{path} is a folder: give the FMU's file name (e.g. model.fmu)")
    problem = userfiles.replace_problem(path)
    if problem is not None:
        raise ExportError(f"{path} {problem}: the FMU would replace it; give the FMU's file name "
                          "(e.g. model.fmu)")
    if not path.parent.is_dir():
        raise ExportError(f"cannot write {path}: the folder {path.parent} does not exist")
    return path


def _write_zip(path: Path, members: Mapping[str, bytes]) -> Path:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh, zipfile.ZipFile(fh, "w", zipfile.ZIP_DEFLATED) as zf:
            for name, data in members.items():
                info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_DEFLATED
                info.external_attr = 0o644 << 16
                zf.writestr(info, data)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
