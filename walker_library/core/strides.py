"""The stride recorder: a walk's trajectory cut into :class:`~.protocol.Stride` records.

A step ends at a heel strike (a transition with ``heel_strike``; :class:`~.machine.WalkLog`
lists them). Per step, from the ledger (SI units): the duration (s); the step length, the
distance along the slope between the striking foot's point and the previous one's (the first
step's from the section's stance foot at the start; m); the energy booked as dissipated (J, an
impact's loss included), the potential energy released (J; the multibody's ``V``) and the
ledger residual H(end) − H(0) + E_diss − E_in (J), all between the stored points just after the
heel strikes; the energy supplied (J, ``info["energy_supplied"]``, e.g. by a modulated
stiffness); with ``details``, max |θ| and max |φ| over the step in the section's labelling of
the step (from the dense output, refined, when the integrator has one; else over the stored
points). ``info`` also holds the state and parameters before and after the heel strike, the
transitions that fired during the step (``info["fired"]``: :class:`~.machine.Fired`), and the
impact's record for a rigid walker. A walk that ends without its last heel strike (and not
stopped by its ``until``) adds a Stride with status ``"fell"`` and the reason: ``"time_limit"``, the event that ended it (e.g.
``"fall"``), or the integrator's status and message (e.g. ``"failed: more than 100000 steps
..."``: a stride beyond the walker's ``max_steps_per_stride``).
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, cast

import numpy as np

from porthamiltonian import Trajectory

from .machine import WalkLog
from .protocol import Stride, StrideStatus

if TYPE_CHECKING:
    from .walker import HybridWalker

__all__ = ["cut_strides"]


def _fall_reason(traj: Trajectory) -> str:
    if traj.status == "finished":
        return "time_limit"
    if traj.status == "event" and traj.events:
        return traj.events[-1][1]
    return f"{traj.status}: {traj.message}" if traj.message else str(traj.status)


def _angle_columns(walker: HybridWalker, X: np.ndarray) -> np.ndarray:
    """θ and φ (rad; NaN where the walker has none) of the states in the columns of ``X``, in
    their own labelling, as rows of (θ, φ): :meth:`~.walker.HybridWalker.angles` of every column
    at once (the angles are linear in the coordinates)."""
    angles = walker.compiled.angles
    q = X[list(walker.compiled.coordinates)]
    return np.column_stack([angles[k] @ q if k in angles else np.full(X.shape[1], math.nan)
                            for k in ("theta", "phi")])


def _maxima(walker: HybridWalker, traj: Trajectory, X: np.ndarray, i0: int, i1: int,
            t0: float, t1: float, p: np.ndarray) -> tuple[float, float]:
    """max |θ|, max |φ| over a step (rad), in the section's labelling under the step's
    parameters ``p``: from the dense output (refined) when the run has one, else over the stored
    points i0..i1."""
    if not t1 > t0:
        return math.nan, math.nan
    n = walker.model.n_states
    relabel = walker.compiled.relabel
    flip = relabel is not None and walker.relabelled(X[:n, i0], p)
    y0 = walker.outputs(0.0, X[:n, i0], p) if flip else None

    def thph(x: np.ndarray) -> tuple[float, float]:
        a = walker.angles(relabel.state(x[:n], y0) if relabel is not None and y0 is not None
                          else x[:n])
        return a.get("theta", math.nan), a.get("phi", math.nan)

    if not any(seg.sol is not None for seg in traj.segments):
        values = (np.array([thph(X[:, i]) for i in range(i0, i1 + 1)]) if y0 is not None
                  else _angle_columns(walker, X[:n, i0:i1 + 1]))
        theta, phi = (float(np.max(np.abs(values[:, j]))) if np.all(np.isfinite(values[:, j]))
                      else math.nan for j in range(2))
        return theta, phi
    grid = np.linspace(t0, t1, 401)
    eps = 1e-12 * max(1.0, t1)
    grid[0], grid[-1] = t0 + eps, t1 - eps
    S = traj.sol(grid)
    angles = np.array([thph(S[:, k]) for k in range(len(grid))])
    out = []
    for j in range(2):
        vals = np.abs(angles[:, j])
        if not np.all(np.isfinite(vals)):
            out.append(math.nan)
            continue
        k = int(np.argmax(vals))
        best = vals[k]
        if 0 < k < len(grid) - 1:       # refine an interior maximum
            from scipy.optimize import minimize_scalar  # here: scipy.optimize takes ~0.2 s
            res = minimize_scalar(lambda s, j=j: -abs(thph(traj.sol(s))[j]),
                                  bounds=(grid[k - 1], grid[k + 1]), method="bounded",
                                  options={"xatol": 1e-10})
            best = max(best, -float(res.fun))
        out.append(float(best))
    return out[0], out[1]


def cut_strides(walker: HybridWalker, traj: Trajectory, log: WalkLog, *, details: bool,
                record: bool, x0: np.ndarray, p0: np.ndarray) -> list[Stride]:
    """The Strides of one walk (see the module docstring)."""
    t, Y = traj.t, traj.y
    n = walker.model.n_states
    iV = walker.model.output_index(f"{walker.multibody}.V")

    def at(i: int) -> tuple[float, float, float, float]:
        """(H, V, E_diss, E_in) at stored point i."""
        y = np.ascontiguousarray(Y[:, i])
        p = traj.p_at(i)
        H = float(walker.model.energy(t[i], y, p)[0])
        V = float(walker.outputs(t[i], y[:n], p)[iV])
        return H, V, float(Y[n, i]), float(Y[n + 1, i])

    stance = walker.spec.foot(walker.spec.section.stance).point
    foot_x = walker.output(f"{stance}.x", x0, p0)
    strides: list[Stride] = []
    t_prev, i_prev, prev, p_step = 0.0, 0, at(0), p0
    fired = iter(log.fired)
    pending = next(fired, None)
    for hs in log.heel_strikes:
        during = []
        while pending is not None and pending is not hs:
            during.append(pending)
            pending = next(fired, None)
        pending = next(fired, None)
        idx = int(np.nonzero(t == hs.t)[0][-1])
        now = at(idx)
        foot = walker.spec.foot(cast(str, hs.transition.foot))   # a heel strike names its foot
        x_new = walker.output(f"{foot.point}.x", hs.x_minus,
                              hs.p_minus, hs.t)
        info = {"t_end": hs.t, "foot": hs.transition.foot, "energy_supplied": now[3] - prev[3],
                "x_minus": hs.x_minus, "p_minus": hs.p_minus, "x_plus": hs.x_plus,
                "p_plus": hs.p_plus, "fired": [*during, hs], **hs.info}
        s = Stride(StrideStatus.STEP, walker.project(hs.x_plus, hs.p_plus), hs.t - t_prev,
                   step_length=x_new - foot_x, energy_dissipated=now[2] - prev[2],
                   potential_released=prev[1] - now[1],
                   energy_residual=(now[0] - prev[0]) + (now[2] - prev[2]) - (now[3] - prev[3]),
                   info=info)
        if details:
            s.max_theta, s.max_phi = _maxima(walker, traj, Y, i_prev, idx, t_prev, hs.t, p_step)
        strides.append(s)
        t_prev, i_prev, prev, p_step, foot_x = hs.t, idx, now, hs.p_plus, x_new
    if len(strides) < log.target and not log.met:
        fell = Stride(StrideStatus.FELL, None, float(traj.t_final - t_prev), reason=_fall_reason(traj),
                      info={"message": traj.message, "status": traj.status})
        if details and traj.t_final > t_prev:
            fell.max_theta, fell.max_phi = _maxima(walker, traj, Y, i_prev, len(t) - 1, t_prev,
                                                   float(traj.t_final), p_step)
        strides.append(fell)
    if record and strides:
        strides[-1].info["trajectory"] = traj
    return strides
