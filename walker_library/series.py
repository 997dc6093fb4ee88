"""Time series of a walk for plots, reports and animations (SI units, thesis conventions).

:func:`walk_series` walks ``n_steps`` from a section state in one recorded simulation and returns
a :class:`GaitSeries`: at every stored integration point the thesis's θ, φ and their rates
(MODEL-SPEC.md §1: θ the stance-leg angle to the slope normal, φ the angle between the legs; for
a compliant walker the "stance" leg is the one that touched down last), the energies (H, the
multibody's potential V and kinetic T, the ledger's E_diss and E_in, the residual), the step
index, and the stick figure (hip and feet positions in the slope frame: x down the slope, z
along its normal) for animations.

The three walker families keep their state differently (a swing model pinned at the stance foot
with the stance foot in mode parameters; a floating base with alternating leading leg), so the
conversion is per family: :class:`~.rigid.LeggedRigidWalker`, :class:`~.rigid.RimlessWheelWalker`
and :class:`~.compliant.CompliantWalker` (with its subclasses).
"""
from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass

import numpy as np

from .compliant import CompliantWalker
from .protocol import Stride, Walker
from .rigid import LeggedRigidWalker, RimlessWheelWalker

__all__ = ["GaitSeries", "walk_series"]


@dataclass
class GaitSeries:
    """Arrays over the stored points of one recorded walk (length N each, SI units).

    t (s); step (0-based index of the step in progress); theta, phi (rad), theta_dot, phi_dot
    (rad/s) — phi and phi_dot are NaN for the rimless wheel; H, V, T, E_diss, E_in, residual (J);
    hip (N × 2: x, z in m) and feet (N × F × 2: the walker's F feet or spoke tips, m);
    strides: the :class:`~.protocol.Stride` records of the walk.
    """

    t: np.ndarray
    step: np.ndarray
    theta: np.ndarray
    phi: np.ndarray
    theta_dot: np.ndarray
    phi_dot: np.ndarray
    H: np.ndarray
    V: np.ndarray
    T: np.ndarray
    E_diss: np.ndarray
    E_in: np.ndarray
    residual: np.ndarray
    hip: np.ndarray
    feet: np.ndarray
    strides: list[Stride]

    @property
    def step_times(self) -> np.ndarray:
        """Times (s) at which the steps end (heel strikes), cumulative."""
        return np.cumsum([s.duration for s in self.strides if not s.fell])


def _params_per_point(traj) -> np.ndarray:
    return np.concatenate([np.repeat(seg.p[None, :], len(seg.t), axis=0) for seg in traj.segments])


def walk_series(walker: Walker, z, n_steps: int, *, ground_drop: float = 0.0,
                max_step: float | None = None) -> GaitSeries:
    """Walk ``n_steps`` from section state ``z`` (recorded) and convert (module docstring).
    ``max_step`` (s) caps the integrator's step for smooth curves (the stored points are the
    integrator's own; an explicit method on a smooth swing phase takes few, long steps)."""
    if max_step is not None and max_step < walker.options.max_step:
        walker = copy.copy(walker)
        walker.options = dataclasses.replace(walker.options, max_step=float(max_step))
    strides = walker.walk(np.asarray(z, dtype=float), n_steps, record=True, ground_drop=ground_drop)
    traj = strides[-1].info["trajectory"]
    t = traj.t
    ends = np.cumsum([s.duration for s in strides if not s.fell])
    step = np.minimum(np.searchsorted(ends, t, side="left"), len(strides) - 1)
    P = _params_per_point(traj)
    X = traj.y[: traj.y.shape[0] - 2]          # states (n × N), without the ledger rows
    n = len(t)
    if isinstance(walker, CompliantWalker):
        kin = _compliant(walker, strides, X, P, step)
    elif isinstance(walker, LeggedRigidWalker):
        kin = _legged(walker, traj, X, P)
    elif isinstance(walker, RimlessWheelWalker):
        kin = _wheel(walker, traj, X, P)
    else:
        raise TypeError(f"walk_series: no time-series conversion for {type(walker).__name__}")
    return GaitSeries(t=t, step=step,
                      H=traj.H, V=np.asarray(traj["walker.V"]), T=np.asarray(traj["walker.T"]),
                      E_diss=traj.E_diss, E_in=traj.E_in, residual=traj.residual,
                      strides=strides, **{k: v[:n] for k, v in kin.items()})


def _legged(walker: LeggedRigidWalker, traj, X, P) -> dict:
    th, ph, thd, phd = (np.empty(len(traj.t)) for _ in range(4))
    for i in range(len(traj.t)):
        q = X[walker._iq, i]
        v = walker.velocities(X[:, i], P[i])
        th[i], ph[i], thd[i], phd[i] = -q[0], q[1], -v[0], v[1]
    names = walker.swing.param_names
    stance = np.stack([P[:, names.index("stance_x")], P[:, names.index("stance_z")]], axis=1)
    hip = np.stack([traj["walker.hip_centre.x"], traj["walker.hip_centre.z"]], axis=1)
    swing = np.stack([traj["walker.swing_foot.x"], traj["walker.swing_foot.z"]], axis=1)
    return dict(theta=th, phi=ph, theta_dot=thd, phi_dot=phd, hip=hip,
                feet=np.stack([stance, swing], axis=1))


def _wheel(walker: RimlessWheelWalker, traj, X, P) -> dict:
    q = X[walker._iq[0]]
    v = np.array([walker.velocities(X[:, i], P[i])[0] for i in range(len(traj.t))])
    names = walker.swing.param_names
    stance = np.stack([P[:, names.index("stance_x")], P[:, names.index("stance_z")]], axis=1)
    hub = np.stack([traj["walker.hub.x"], traj["walker.hub.z"]], axis=1)
    nxt = np.stack([traj["walker.next_tip.x"], traj["walker.next_tip.z"]], axis=1)
    nan = np.full(len(q), np.nan)
    return dict(theta=-q, phi=nan, theta_dot=-v, phi_dot=nan.copy(), hip=hub,
                feet=np.stack([stance, nxt], axis=1))


def _compliant(walker: CompliantWalker, strides, X, P, step) -> dict:
    lead_of_step = [1] + [s.info.get("lead", 1) for s in strides if not s.fell]
    th, ph, thd, phd = (np.empty(X.shape[1]) for _ in range(4))
    out = walker.swing.output_names
    feet = np.empty((X.shape[1], 2, 2))
    hip = np.empty((X.shape[1], 2))
    for i in range(X.shape[1]):
        x = X[:, i]
        q = x[walker._iq]
        v = np.linalg.solve(walker._mass_matrix(x, P[i]), x[walker._ip])
        lead = lead_of_step[min(int(step[i]), len(lead_of_step) - 1)]
        a, b = (2, 3) if lead == 1 else (3, 2)
        th[i], ph[i] = -q[a], q[b] - q[a]
        thd[i], phd[i] = -v[a], v[b] - v[a]
        y = walker.outputs(0.0, x, P[i])
        hip[i] = q[0], q[1]
        for k in (1, 2):
            feet[i, k - 1] = y[out.index(f"walker.foot{k}.x")], y[out.index(f"walker.foot{k}.z")]
    return dict(theta=th, phi=ph, theta_dot=thd, phi_dot=phd, hip=hip, feet=feet)

