"""Walker model files: loading, saving and listing them; the shipped walkers by name.

A walker file (``models/<name>.toml``) is an ordinary porthamiltonian model file — its
components, bonds, parameters and events are the walker's mechanism, so ``porthamiltonian show``
and ``check-energy`` work on it — plus a ``[walker]`` table, the hybrid description
(:mod:`.hybrid`, read by :mod:`.reading`; docs/walkers.md). The file is the walker: :func:`load_walker`
builds it from the file alone, so editing a component (a contact law, a friction, a spring, a
foot radius) changes the walker that every ``walker`` command analyses.

The functions named after the shipped walkers (:func:`simplest_walker`, :func:`compass_gait`,
...) load their files with parameter values given as keyword arguments:
``compass_walker(slope=0.01)`` is ``load_walker("compass_walker", {"slope": 0.01})``.
"""
from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path

from porthamiltonian import collector
from porthamiltonian import io as ph_io
from porthamiltonian.compiler import prepare
from porthamiltonian.errors import ModelFileError, ParameterValueError
from porthamiltonian.userfiles import replace_problem, write_atomic

from . import warm
from .hybrid import Integration, WalkerSpec
from .reading import file_spec
from .walker import HybridWalker, build_walker

__all__ = ["SHIPPED", "available_walkers", "check_target", "compass_gait", "compass_walker",
           "compliant_leg_walker", "load_walker", "read_walker", "rigid_compass_walker",
           "rimless_wheel", "save_walker", "simplest_walker", "variable_stiffness_walker"]

#: the walkers shipped in models/ (their files are the reference; docs/walkers.md describes them):
#: the classic rigid-impact walkers, the thesis's, the thesis's recommendations (its §4.2), and
#: the thesis's two main walkers with point-mass legs (the variants shipped before I_leg)
SHIPPED = ("simplest_walker", "compass_gait", "rimless_wheel", "rigid_compass_walker",
           "compass_walker", "compliant_leg_walker", "variable_stiffness_walker",
           "hip_and_leg_spring_walker", "ankle_stiffness_walker", "smooth_stiffness_walker",
           "compass_walker_point_legs", "compliant_leg_walker_point_legs")


def read_walker(name_or_path: str | Path) -> tuple[WalkerSpec, str]:
    """The :class:`~.hybrid.WalkerSpec` of a walker file (by name in models/ or by path) and
    the file's text. Raises ModelFileError (file, line, part) for a file that is not a walker
    file or whose ``[walker]`` table is wrong."""
    record = ph_io.reads(*reversed(_file_text(name_or_path)))
    return file_spec(record), record.text


def _file_text(name_or_path: str | Path) -> tuple[str, str]:
    """(the path, the text) of a model file by name or path, as :func:`porthamiltonian.io.read`
    finds and reads it."""
    path = ph_io.model_path(name_or_path)
    return str(path), ph_io.read_text(path, limit=ph_io.MAX_FILE_SIZE, label=str(path),
                                      kind="model file", language="TOML")


@collector.paused()
def load_walker(name_or_path: str | Path, overrides: Mapping[str, float] | None = None, *,
                backend: str | None = None, options: Integration | None = None) -> HybridWalker:
    """The walker of a walker file (a name in models/, or a path), with its ``[parameters]``
    values, ``overrides`` applied (validated against ``[walker.ranges]``).

    ``backend``: None for the file's own (``[walker.integration] backend``); ``options``:
    integrator settings replacing the file's. Raises ModelFileError for a bad file (before
    anything is compiled) and ParameterValueError for unknown or out-of-range parameters.

    A walker loaded before from the same text (and package, compiler and back end) starts from
    its snapshot (:mod:`.warm`: no sympy, no networkx); a walker loaded in full leaves one.
    """
    source, text = _file_text(name_or_path)
    asked = backend or (options.backend if options is not None else None)
    try:
        walker = warm.restore(source, text, asked, values=overrides, options=options)
        if walker is not None:
            return walker
        prepare(asked or "auto")    # the C loops compile while the file is read and built
        record = ph_io.reads(text, source)
        walker = build_walker(file_spec(record), backend=backend, options=options,
                              values=overrides, text=record.text)
    except ParameterValueError as err:
        raise ParameterValueError(f"{source}: {err}") from None
    warm.keep(walker, source, text, asked)
    return walker


def save_walker(walker: HybridWalker | WalkerSpec, path: str | Path, header: str = "", *,
                overwrite: bool = True) -> Path:
    """Write a walker file: the model and its ``[walker]`` table (a walker's current parameter
    values as the defaults). ``header``: comment lines put at the top. Loading the file gives the
    same description, model and gait.

    The file is written whole or not at all (a temporary file beside it, then renamed), and a
    symbolic link at ``path`` is replaced by the file, never written through. ``overwrite=False``
    refuses (ModelFileError) when anything is at ``path`` already (``walker export`` without
    ``--force``)."""
    import tomli_w  # (here: only a written file needs it)

    spec = walker.spec if isinstance(walker, HybridWalker) else walker
    data = ph_io.model_to_dict(ph_io.ModelFile(
        spec.model, description=spec.description, meta={"units": spec.units} if spec.units else {}))
    data["walker"] = spec.to_table()
    if isinstance(walker, HybridWalker):
        for name, value in walker.parameters.items():
            entry = data["parameters"][name]
            if isinstance(entry, dict):
                entry["value"] = value
            else:
                data["parameters"][name] = value
    text = tomli_w.dumps(data)
    if header:
        text = "".join(f"# {line}".rstrip() + "\n" for line in header.splitlines()) + "\n" + text
    path = check_target(path, overwrite=overwrite)
    write_atomic(path, text, plain_mode=True)
    return path


def check_target(path: str | Path, *, overwrite: bool) -> Path:
    """``path`` as a Path if a walker file may be written there: in a folder that exists, not a
    directory, a device, a socket or a pipe, and, unless ``overwrite``, nothing there yet (a file, a link, even a
    broken one); else a ModelFileError saying what is there and what to do."""
    path = Path(path)
    if os.path.isdir(path):
        raise ModelFileError(f"{path} is a directory; give the path of the walker file to write")
    problem = replace_problem(path)
    if problem is not None:             # not even with --force: the file would replace it
        raise ModelFileError(f"{path} {problem}; give the path of the walker file to write")
    if not os.path.isdir(path.parent):      # (else the error names the temporary file)
        raise ModelFileError(f"cannot write {path}: the folder {path.parent} does not exist")
    if not overwrite and os.path.lexists(path):
        kind = "a symbolic link" if os.path.islink(path) else "a file"
        raise ModelFileError(f"{path}: {kind} is there already; give --force to replace it (a "
                             "link is replaced, not written through), or another path")
    return path


def available_walkers() -> list[str]:
    """Names of the model files found by name (models/, $PORTHAMILTONIAN_MODELS) that have a
    ``[walker]`` table."""
    import tomllib  # (here: a warm run parses no TOML)

    out = []
    for name in ph_io.available_models():
        try:
            path = ph_io.model_path(name)
            data = tomllib.loads(ph_io.read_text(path, limit=ph_io.MAX_FILE_SIZE, label=str(path),
                                                 kind="model file", language="TOML"))
        except (tomllib.TOMLDecodeError, RecursionError, ModelFileError):
            continue
        if isinstance(data.get("walker"), dict):
            out.append(name)
    return out


def _by_name(name: str) -> Callable[..., HybridWalker]:
    def make(*, backend: str | None = None, options: Integration | None = None,
             **values: float) -> HybridWalker:
        """(replaced below)"""
        return load_walker(name, values, backend=backend, options=options)
    make.__name__ = make.__qualname__ = name
    make.__doc__ = (f"The walker of models/{name}.toml (docs/walkers.md), parameter values as "
                    "keyword arguments; ``backend`` and ``options`` as for :func:`load_walker`.")
    return make


simplest_walker = _by_name("simplest_walker")
compass_gait = _by_name("compass_gait")
rimless_wheel = _by_name("rimless_wheel")
rigid_compass_walker = _by_name("rigid_compass_walker")
compass_walker = _by_name("compass_walker")
compliant_leg_walker = _by_name("compliant_leg_walker")
variable_stiffness_walker = _by_name("variable_stiffness_walker")
