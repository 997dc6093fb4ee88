"""3D rigid-body mechanics: screw theory (poses, twists, wrenches, spatial inertia; re-exported
from :mod:`.screw`), the Multibody and FreeBody components, and the body and joint records.

See :mod:`porthamiltonian.mechanics.screw` for the ordering, frame and sign conventions.
"""
from . import screw
from .bodies import Free, Prismatic, Revolute, RigidBody, Spherical, Translational, Universal, Weld
from .free_body import FreeBody  # registers the component type
from .multibody import Multibody  # registers the component type
from .screw import *  # screw's public names, listed once in screw.__all__

__all__ = ["Free", "FreeBody", "Multibody", "Prismatic", "Revolute", "RigidBody", "Spherical",
           "Translational", "Universal", "Weld"]
__all__ += screw.__all__
