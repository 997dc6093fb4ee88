"""porthamiltonian: port-based physical modeling with an energy ledger.

Build a :class:`Model` from components joined by power bonds, compile it with
:func:`compile_model` into port-Hamiltonian state equations (with H, dissipated and supplied
power), and :func:`simulate` it with stiff integrators, events and resets.
"""
from . import (
    errors,
    library,  # registers the contact, friction and spring components
)
from .compiled import CompiledModel
from .compiler import compile_model, power_balance, symbolic
from .component import Arg, Builder, Component, register
from .elements import GY, TF, C, I, OneJunction, R, Se, Sf, Storage, ZeroJunction
from .mechanics import Multibody
from .mechanics.bodies import Prismatic, Revolute, RigidBody, Translational, Weld
from .model import Model, ModelDescription, Parameter
from .ports import DOMAINS, Port
from .simulate import Event, Reset, simulate
from .trajectory import Status, Trajectory

__version__ = "0.1.0"

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
    "library",
    "power_balance",
    "register",
    "simulate",
    "symbolic",
]
