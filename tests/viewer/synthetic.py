"""Closed-form motions for the viewer's tests: a heavy symmetric top in steady precession and a
solid sphere rolling without slipping down a slope, and a stand-in for a trajectory.

Top (Goldstein, Classical Mechanics, 3rd ed., §5.7): precession by Ω t about the vertical,
constant tilt θ0 of the symmetry axis, spin ψ̇ t about it — the rotation Rz(Ω t) Ry(θ0) Rz(ψ̇ t);
steady precession needs m g l = Ω (I3 ω3 − I1 Ω cos θ0) with ω3 = ψ̇ + Ω cos θ0 (the slow
root is taken). Sphere: centre at s(t) = ½ (5/7) g sin γ t² down
the slope, at height r above it, turned by s/r about the lateral axis (rolling without slip).
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from porthamiltonian.interfaces.viewer.quaternions import about_axis, multiply

G = 9.81
#: top: mass (kg), distance pivot-centre of mass (m), moments (kg m²), tilt (rad), spin ω3 (rad/s)
TOP = {"m": 0.5, "l": 0.04, "I1": 4e-4, "I3": 6e-4, "theta": 0.5, "omega3": 60.0}
#: sphere: radius (m), slope (rad)
BALL = {"r": 0.05, "slope": 0.2}


def top_precession() -> float:
    """Ω (rad/s), the slow steady precession of :data:`TOP`."""
    p = TOP
    a, b, c = p["I1"] * math.cos(p["theta"]), -p["I3"] * p["omega3"], p["m"] * G * p["l"]
    return (-b - math.sqrt(b * b - 4 * a * c)) / (2 * a)


def top_pose(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(positions (N, 3), quaternions (N, 4)) of the top's body frame: origin at the pivot,
    z along the symmetry axis."""
    Om = top_precession()
    spin = TOP["omega3"] - Om * math.cos(TOP["theta"])
    q = multiply(multiply(about_axis([0, 0, 1], Om * t),
                          about_axis([0, 1, 0], np.full_like(t, TOP["theta"]))),
                 about_axis([0, 0, 1], spin * t))
    return np.zeros((len(t), 3)), q


def ball_slope_frame(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centre (N, 3), quaternions (N, 4)) of the rolling sphere in the slope frame (x down the
    slope, z along its normal)."""
    r, gamma = BALL["r"], BALL["slope"]
    s = 0.5 * (5 / 7) * G * math.sin(gamma) * t ** 2
    centre = np.stack([s, np.zeros_like(t), np.full_like(t, r)], axis=1)
    return centre, about_axis([0, 1, 0], s / r)


class FakeTrajectory:
    """What the adapter reads of a :class:`~porthamiltonian.simulation.trajectory.Trajectory`: ``t``, named
    columns (here all outputs) and the model's names."""

    def __init__(self, t: np.ndarray, columns: dict[str, np.ndarray], name: str = "synthetic"):
        self.t = np.asarray(t, dtype=float)
        self._columns = columns
        self.model = SimpleNamespace(name=name, state_names=[], output_names=list(columns),
                                     matrix_names=[])

    def __getitem__(self, name: str) -> np.ndarray:
        return self._columns[name]


def pose_columns(body: str, position: np.ndarray, q: np.ndarray) -> dict[str, np.ndarray]:
    """The seven pose outputs ``<body>.pose.x ... qz`` the adapter expects of a Multibody."""
    return {f"{body}.pose.{n}": v for n, v in
            zip(("x", "y", "z", "qw", "qx", "qy", "qz"), [*position.T, *q.T], strict=True)}
