"""Exception types of porthamiltonian.

Every error raised for bad user input is a :class:`ModelError` (a ``ValueError``) or one of its
subclasses, and its message names the component, port, parameter or file involved and says what
to do. Tests pin both the type and the names in the message.
"""
from __future__ import annotations


class ModelError(ValueError):
    """Base class of all user-facing modeling errors."""


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


class StateError(ModelError):
    """An initial state or a state name is wrong (unknown name, wrong length, non-finite)."""



class SceneError(ModelError):
    """A scene of the 3D viewer (:mod:`porthamiltonian.viewer`) is malformed: a shape, a pose, the
    times, the ground; the message names the body, shape or frame and says what is expected."""
