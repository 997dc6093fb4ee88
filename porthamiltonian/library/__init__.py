"""The component library: contact, friction, springs and the surfaces they act on.

Importing this package registers its component types for model files:

* :mod:`.contact`  — ``HuntCrossley``, ``KelvinVoigt`` normal contact of a body point with a
  surface;
* :mod:`.friction` — ``SCVSFriction``, 20-sim's static/Coulomb/viscous/Stribeck friction;
* :mod:`.springs`  — ``SpringDamper`` (linear) and ``VariableSpringDamper`` (modulated stiffness,
  damper rule D = 2 α √(m K));
* :mod:`.surfaces` — plane, slope and slope with a step down (helpers, not components).

Each module's docstring gives the law, units, frames, signs, energy role and references.
"""
from .contact import HuntCrossley, KelvinVoigt
from .friction import SCVSFriction, scvs_coefficient
from .springs import SpringDamper, VariableSpringDamper
from .surfaces import SURFACES, Surface, make_surface

__all__ = [
           "SURFACES",
           "HuntCrossley",
           "KelvinVoigt",
           "SCVSFriction",
           "SpringDamper",
           "Surface",
           "VariableSpringDamper",
           "make_surface",
           "scvs_coefficient",
]
