"""porthamiltonian: port-based physical modeling with an energy ledger.

Build a :class:`Model` from components joined by power bonds, compile it with
:func:`compile_model` into port-Hamiltonian state equations (with H, dissipated and supplied
power), and :func:`simulate` it with stiff integrators, events and resets.
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from . import errors
from .version import __version__ as __version__

#: where each public name lives (imported when first used: ``import porthamiltonian`` stays
#: light, so that a command that needs no compiler, e.g. a warm ``walker gait``, loads neither
#: sympy nor networkx)
_NAMES = {
    "compile_model": "compiler", "power_balance": "compiler", "symbolic": "compiler",
    "Multibody": "mechanics",
    **{n: "mechanics.bodies" for n in ("Prismatic", "Revolute", "RigidBody", "Translational",
                                       "Weld")},
    **{n: "modeling.component" for n in ("Arg", "Builder", "Component", "register")},
    **{n: "modeling.elements" for n in ("GY", "TF", "C", "I", "OneJunction", "R", "Se", "Sf",
                                        "Storage", "ZeroJunction")},
    **{n: "modeling.model" for n in ("Model", "ModelDescription", "Parameter")},
    "DOMAINS": "modeling.ports", "Port": "modeling.ports",
    "CompiledModel": "simulation.compiled",
    "FitResult": "simulation.fitting", "fit": "simulation.fitting",
    **{n: "simulation.simulate" for n in ("Event", "Reset", "simulate")},
    "Status": "simulation.trajectory", "Trajectory": "simulation.trajectory",
}
#: the public sub-modules among the names
_MODULES = {"io": "interfaces.io", "library": "library"}


def __getattr__(name: str) -> Any:
    """The public name ``name``, imported on first use. A name of the model layers or the
    compiler comes with the component library and the mechanics, which register their component
    types for model files (as the package did when it imported everything at once); ``io``
    registers them itself when it reads a file."""
    if name in _MODULES:
        value = importlib.import_module(f".{_MODULES[name]}", __name__)
    elif name in _NAMES:
        if not _NAMES[name].startswith("simulation."):
            importlib.import_module(".library", __name__)
            importlib.import_module(".mechanics", __name__)
        value = getattr(importlib.import_module(f".{_NAMES[name]}", __name__), name)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_NAMES, *_MODULES})


if TYPE_CHECKING:
    from . import library
    from .compiler import compile_model, power_balance, symbolic
    from .interfaces import io
    from .mechanics import Multibody
    from .mechanics.bodies import Prismatic, Revolute, RigidBody, Translational, Weld
    from .modeling.component import Arg, Builder, Component, register
    from .modeling.elements import GY, TF, C, I, OneJunction, R, Se, Sf, Storage, ZeroJunction
    from .modeling.model import Model, ModelDescription, Parameter
    from .modeling.ports import DOMAINS, Port
    from .simulation.compiled import CompiledModel
    from .simulation.fitting import FitResult, fit
    from .simulation.simulate import Event, Reset, simulate
    from .simulation.trajectory import Status, Trajectory

__all__ = [
    "DOMAINS",
    "GY",
    "TF",
    "Arg",
    "Builder",
    "C",
    "CompiledModel",
    "Component",
    "Event",
    "FitResult",
    "I",
    "Model",
    "ModelDescription",
    "Multibody",
    "OneJunction",
    "Parameter",
    "Port",
    "Prismatic",
    "R",
    "Reset",
    "Revolute",
    "RigidBody",
    "Se",
    "Sf",
    "Status",
    "Storage",
    "Trajectory",
    "Translational",
    "Weld",
    "ZeroJunction",
    "compile_model",
    "errors",
    "fit",
    "io",
    "library",
    "power_balance",
    "register",
    "simulate",
    "symbolic",
]
