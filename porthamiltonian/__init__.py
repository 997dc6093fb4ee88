"""porthamiltonian: port-based physical modeling with an energy ledger.

Build a :class:`Model` from components joined by power bonds, compile it with
:func:`compile_model` into port-Hamiltonian state equations (with H, dissipated and supplied
power), and :func:`simulate` it with stiff integrators, events and resets.
"""
from . import (
    errors,
    library,  # registers the contact, friction and spring components
)
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
from .version import __version__ as __version__

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
