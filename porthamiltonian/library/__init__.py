"""The component library: contact, friction, springs and the surfaces they act on.

Importing this package registers its component types for model files:

* :mod:`.contact`  — ``HuntCrossley``, ``KelvinVoigt`` normal contact of a body point with a
  surface;
* :mod:`.friction` — ``SCVSFriction``, 20-sim's static/Coulomb/viscous/Stribeck friction;
* :mod:`.contact3d` — ``HuntCrossley3D``, ``KelvinVoigt3D``: a sphere or point on a surface in 3D
  (or the x-z plane), on a multibody's world-aligned frame (twist/wrench port);
* :mod:`.friction3d` — ``SCVSFriction3D``: the SCVS law as a vector law in the tangent plane at a
  sphere's material contact point, with optional rolling resistance and spin friction;
* :mod:`.springs`  — ``SpringDamper`` (linear), ``VariableSpringDamper`` (modulated stiffness,
  damper rule D = 2 α √(m K)) and ``ActuatedSpringDamper`` (the stiffness a state set through a
  power port);
* :mod:`.surfaces` — plane, slope and slope with a step down (helpers, not components);
* :mod:`.signals`  — signal blocks and controllers (``Gain``, ``Sum``, ``Integrator``,
  ``Derivative``, ``PID``, ``TransferFunction``, ``StateSpace``, ``Saturation``, ``LookupTable``,
  ``Sensor``; discrete-time ``ZeroOrderHold``, ``DiscretePID``, ``DiscreteStateSpace``) and the
  ``Actuator``, a modulated source that books its energy.

Each module's docstring gives the law, units, frames, signs, energy role and references.
"""
from .contact import HuntCrossley, KelvinVoigt
from .contact3d import HuntCrossley3D, KelvinVoigt3D
from .friction import SCVSFriction, scvs_coefficient
from .friction3d import SCVSFriction3D
from .signals import (
    PID,
    Actuator,
    Derivative,
    DiscretePID,
    DiscreteStateSpace,
    Gain,
    Integrator,
    LookupTable,
    Saturation,
    Sensor,
    StateSpace,
    Sum,
    TransferFunction,
    ZeroOrderHold,
)
from .springs import ActuatedSpringDamper, SpringDamper, VariableSpringDamper
from .surfaces import SURFACES, Surface, make_surface

__all__ = [
    "PID",
    "SURFACES",
    "ActuatedSpringDamper",
    "Actuator",
    "Derivative",
    "DiscretePID",
    "DiscreteStateSpace",
    "Gain",
    "HuntCrossley",
    "HuntCrossley3D",
    "Integrator",
    "KelvinVoigt",
    "KelvinVoigt3D",
    "LookupTable",
    "SCVSFriction",
    "SCVSFriction3D",
    "Saturation",
    "Sensor",
    "SpringDamper",
    "StateSpace",
    "Sum",
    "Surface",
    "TransferFunction",
    "VariableSpringDamper",
    "ZeroOrderHold",
    "make_surface",
    "scvs_coefficient",
]
