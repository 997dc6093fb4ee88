"""Exception types of porthamiltonian.

Every error raised for bad user input is a :class:`ModelError` (a ``ValueError``) or one of its
subclasses, and its message names the component, port, parameter or file involved and says what
to do. Tests pin the type, the names in the message and the hint.

Where it is known, an error also carries a structured :attr:`~ModelError.path`: the key path of
what it is about in a model's description, as a model file spells it (``("components", "arm",
"bodies", "leg", "mass")``, ``("events", 0, "guard")``), relative to whatever raised it until a
caller that knows more prefixes its part (:meth:`ModelError.within`); the model-file reader maps
it to a line. Checks that can find several problems at once raise one error listing them all,
with each problem (an error of its own type and path) in :attr:`~ModelError.problems`.
"""
from __future__ import annotations

from collections.abc import Sequence


class ModelError(ValueError):
    """Base class of all user-facing modeling errors.

    path : the key path of what the error is about (see the module docstring); ``()`` if unknown.
    problems : the single problems an error that lists several is made of; ``()`` otherwise.
    """

    def __init__(self, message: str = "", *, path: Sequence[str | int] = (),
                 problems: Sequence[ModelError] = ()):
        super().__init__(message)
        self.path: tuple[str | int, ...] = tuple(path)
        self.problems: tuple[ModelError, ...] = tuple(problems)

    def within(self, *prefix: str | int) -> ModelError:
        """This error, its path prefixed by ``prefix`` (where the raiser sits); for re-raising."""
        self.path = (*prefix, *self.path)
        return self

    def __reduce__(self) -> tuple:      # keep the path and problems across processes (sweeps)
        return _rebuild, (type(self), str(self), self.path, self.problems)


def _rebuild(cls: type[ModelError], message: str, path: tuple,
             problems: tuple) -> ModelError:
    error = cls.__new__(cls)
    ModelError.__init__(error, message, path=path, problems=problems)
    return error


class ValidationError(ModelError):
    """A model has several problems; :attr:`problems` lists them (each with its own type, names
    and path) and the message shows them all, one per line."""


class DuplicateNameError(ModelError):
    """A component, port, parameter or state name is used twice."""


class UnknownComponentError(ModelError):
    """A component type or component name that does not exist."""


class UnknownPortError(ModelError):
    """A port name that the component does not declare."""


class ConnectError(ModelError):
    """Two ports cannot be joined by a bond."""


class DomainMismatchError(ConnectError):
    """The two ports belong to different energy domains."""


class DimensionMismatchError(ConnectError):
    """The two ports carry efforts/flows of different dimensions."""


class OrientationError(ConnectError):
    """The bond's power direction contradicts a port's fixed orientation."""


class DanglingPortError(ModelError):
    """A declared power port is not connected to anything."""


class UnknownParameterError(ModelError):
    """An expression or a run-time binding names a parameter the model does not have."""


class ParameterValueError(ModelError):
    """A parameter value is non-finite or outside its documented range."""


class OptionError(ModelError):
    """A numerical option or argument of a public entry point (``simulate``'s tolerances, step
    sizes, ``t_eval``, ...) has the wrong type or is outside its range; the message names the
    option and the rule."""


class ExpressionError(ModelError):
    """A constitutive-law expression cannot be parsed."""


class StructureError(ModelError):
    """The model's equations cannot be brought into explicit state-space form."""


class AlgebraicLoopError(StructureError):
    """Some port variables depend on each other instantaneously (no storage in between)."""


class DerivativeCausalityError(StructureError):
    """Storages are not independent: one of them would need derivative causality."""


class ModelFileError(ModelError):
    """A model file is malformed; the message names the file and, where known, the line."""


class DataError(ModelError):
    """Measured data for a fit is malformed or does not match the model: a file that is not a
    table of numbers, a column that names no output, an output without samples; the message
    names the file, line and column where known, and says what is expected."""


class StateError(ModelError):
    """An initial state or a state name is wrong (unknown name, wrong length, non-finite)."""


class InputError(ModelError):
    """A model's inputs are bound wrongly at run time: an input left unbound, an unknown input
    name, a value of the wrong shape or type, samples that do not cover the simulated span."""


class PassivityError(ModelError):
    """A component declared as a dissipator is active (its law would make the port-Hamiltonian
    form's R indefinite, or its z(w)·w negative); the message names the component."""



class CostError(ModelError):
    """Work that would exceed a bound — memory, generated code, the cases of a sweep — is
    refused before it starts; the message gives the estimate, the bound and how to raise it."""


class CompilerError(ModelError):
    """The C back end cannot build a model: no C compiler was found, or it failed. The message
    shows the command and the path of a file holding the compiler's output, and what to do."""


class FrameError(ModelError):
    """Screw quantities (poses, twists, wrenches) combined across different frames, or a matrix
    that is not a rotation or a pose; the message names the frames or shows the matrix."""


class SceneError(ModelError):
    """A scene of the 3D viewer (:mod:`porthamiltonian.interfaces.viewer`) is malformed: a shape, a pose, the
    times, the ground; the message names the body, shape or frame and says what is expected."""


class ExportError(ModelError):
    """A model cannot be exported as asked (e.g. an FMU of a model whose events or actions are
    Python callables); the message says why and what can be exported instead."""
