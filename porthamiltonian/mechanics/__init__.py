"""3D rigid-body mechanics: screw theory (poses, twists, wrenches, spatial inertia).

See :mod:`porthamiltonian.mechanics.screw` for the ordering, frame and sign conventions.
"""
from .screw import (
    Ad,
    Pose,
    Twist,
    Wrench,
    ad,
    ad_star,
    exp_se3,
    exp_so3,
    hat3,
    hat6,
    kinetic_energy,
    log_se3,
    log_so3,
    planar_pose,
    pose_inverse,
    pose_matrix,
    spatial_inertia,
    vee3,
    vee6,
)

__all__ = [
    "Ad",
    "Pose",
    "Twist",
    "Wrench",
    "ad",
    "ad_star",
    "exp_se3",
    "exp_so3",
    "hat3",
    "hat6",
    "kinetic_energy",
    "log_se3",
    "log_so3",
    "planar_pose",
    "pose_inverse",
    "pose_matrix",
    "spatial_inertia",
    "vee3",
    "vee6",
]

from .bodies import Free, Prismatic, Revolute, RigidBody, Spherical, Translational, Universal, Weld
from .multibody import Multibody  # noqa: E402  (registers the component type)

__all__ += ["Free", "Multibody", "Prismatic", "Revolute", "RigidBody", "Spherical",
            "Translational", "Universal", "Weld"]

from .free_body import FreeBody  # noqa: E402  (registers the component type)

__all__ += ["FreeBody"]
