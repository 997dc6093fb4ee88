"""Rigid-impact walkers: a swing phase pinned at the stance foot, and a plastic impact map.

A rigid-impact walker is two multibody models of the same mechanism, built from the framework's
bodies and joints (:mod:`walker_library.walkers` has the builders):

* the *swing-phase* model, pinned at the stance foot: world -> revolute ``stance`` at the stance
  foot -> stance leg -> revolute ``hip`` -> swing leg (a rimless wheel: world -> revolute ->
  wheel). Its joint origin sits at the mode parameters (``stance_x``, ``stance_z``), the stance
  foot's position in the slope frame, so the potential energy stays continuous when the stance
  foot changes at heel strike (H jumps by the impact's kinetic-energy loss only, which
  :class:`porthamiltonian.Reset` books as dissipated);
* the *floating-base* model of the same bodies (hip on a translational x/z joint from the world,
  each leg on a revolute joint), whose mass matrix ``walker.M`` and point Jacobians
  ``walker.J.<foot>`` feed the generic impact map :func:`porthamiltonian.mechanics.impact.model_impact`.

The slope frame: x down the slope, z along the slope normal; gravity g (sin γ, 0, −cos γ).
Heel strike is the swing foot reaching the surface (z = ground_z) moving down *in front of* the
stance foot; the swing foot's mid-stance pass through the surface (foot scuffing) is ignored, as
Garcia et al. (1998) do. The guard carries a hysteresis margin ``contact_margin`` (1e-12 m;
measured to shift the simplest walker's fixed point by ~1.5e-11): the rear foot starts exactly on
the surface after a heel strike. A fall (the hip below
``fall_fraction`` of the leg length above the stance foot), rolling back onto the previous spoke,
or no heel strike within ``max_step_time`` ends the step with status "fell": a result, never an
exception.

Integration: the swing phase of these walkers is not stiff; an explicit 8th-order method
(DOP853, scipy) on the python back end was measured fastest (≈ 5 ms per step for the simplest
walker, against ≈ 0.2 s for the Rodas4 loop in pure Python, and 30 s of numba compilation for the
compiled loop), so it is the default; ``method`` and ``backend`` are options.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from porthamiltonian import Reset, compile_model
from porthamiltonian.compiler import cache
from porthamiltonian.errors import ModelError, ParameterValueError
from porthamiltonian.mechanics.impact import model_impact
from porthamiltonian.model import Model

from .protocol import ParameterSpec, Stride, check_parameters

__all__ = ["RigidImpactWalker", "LeggedRigidWalker", "RimlessWheelWalker", "IntegrationOptions"]

#: mode parameters of the swing model, set by the walker itself (never by the user)
MODE_PARAMETERS = ("stance_x", "stance_z", "ground_z")

_COMPILED: dict[tuple[str, str], object] = {}


def _stop(t, x, p) -> Reset:
    """Action of a fall event: end the run there."""
    return Reset(stop=True)


def _compiled(model: Model, backend: str):
    key = (cache.model_key(model), backend)
    if key not in _COMPILED:
        _COMPILED[key] = compile_model(model, backend=backend)
    return _COMPILED[key]


@dataclass(frozen=True)
class IntegrationOptions:
    """Integrator settings of the swing phase: ``method`` (a porthamiltonian.simulate method),
    ``rtol``, ``atol`` (absolute, in the states' units: momenta too, so a walker with a tiny mass
    ratio needs a tiny atol), ``max_step`` (s; also bounds how far apart the heel-strike guard is
    sampled), ``max_step_time`` (s: no heel strike within it is a fall)."""

    method: str = "DOP853"
    rtol: float = 1e-11
    atol: float = 1e-13
    max_step: float = 0.1
    max_step_time: float = 20.0


class RigidImpactWalker:
    """Common machinery of the rigid-impact walkers (see the module docstring).

    Subclasses define the section coordinates and the kinematic maps between the swing model,
    the floating model and the section: :meth:`lift`, :meth:`project`, :meth:`_impact`.
    """

    legged = True
    section: tuple[str, ...] = ()
    heel_strike_point = "swing_foot"     # swing-model point that strikes
    fall_events = ("fall",)

    def __init__(self, name: str, specs: dict[str, ParameterSpec], swing: Model, floating: Model,
                 *, values: dict[str, float] | None = None, backend: str = "python",
                 options: IntegrationOptions | None = None, doc: str = "", builder: str = "",
                 leg_length=None, total_mass=None):
        self.name = name
        self._leg_length = leg_length or (lambda P: P["l"])
        self._total_mass = total_mass
        self.doc = doc
        self.builder = builder
        self.specs = specs
        self.swing_model, self.floating_model = swing, floating
        self.backend = backend
        self.options = options or IntegrationOptions()
        self.parameters = check_parameters(specs, dict(values or {}))
        self._check_physical()
        self.swing = _compiled(swing, backend)
        self.floating = _compiled(floating, backend)
        self._p = self.swing.params({k: v for k, v in self.parameters.items()
                                     if k in self.swing.param_names})
        self._pf = self.floating.params({k: v for k, v in self.parameters.items()
                                         if k in self.floating.param_names})
        self._out = {name: i for i, name in enumerate(self.swing.output_names)}
        self._iq = [i for i, s in enumerate(self.swing.state_names) if s.startswith("walker.q.")]
        self._ip = [i for i, s in enumerate(self.swing.state_names) if s.startswith("walker.p.")]
        self._fq = {s: i for i, s in enumerate(self.floating.state_names) if s.startswith("walker.q.")}
        self._fp = [i for i, s in enumerate(self.floating.state_names) if s.startswith("walker.p.")]
        self._ix = self.swing.param_names.index("stance_x")

    # --- parameters -------------------------------------------------------------------------------
    def _check_physical(self) -> None:
        """Cross-parameter checks (subclasses)."""

    def with_parameters(self, **values: float):
        """A copy with some parameters changed (validated; the compiled models are shared)."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.parameters = check_parameters(self.specs, {**self.parameters, **values})
        new._check_physical()
        new._p = self.swing.params({k: v for k, v in new.parameters.items()
                                    if k in self.swing.param_names})
        new._pf = self.floating.params({k: v for k, v in new.parameters.items()
                                        if k in self.floating.param_names})
        return new

    def param(self, name: str) -> float:
        return float(self._p[self.swing.param_names.index(name)])

    def _params_with(self, p: np.ndarray, **values: float) -> np.ndarray:
        p = p.copy()
        for k, v in values.items():
            p[self.swing.param_names.index(k)] = v
        return p

    @property
    def weight(self) -> float:
        """Total weight m_total g (N)."""
        return self.total_mass * self.parameters["g"]

    @property
    def total_mass(self) -> float:
        """Total mass (kg)."""
        return float(self._total_mass(self.parameters))

    @property
    def leg_length(self) -> float:
        """Leg (spoke) length, hip to foot (m)."""
        return float(self._leg_length(self.parameters))

    # --- kinematics (subclasses) ------------------------------------------------------------------
    def lift(self, z: np.ndarray) -> np.ndarray:
        """Section coordinates -> swing-model state (stance foot at the origin)."""
        raise NotImplementedError

    def project(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Swing-model state just after heel strike -> section coordinates."""
        raise NotImplementedError

    def _impact(self, t: float, x: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, dict, dict]:
        """Heel strike at swing state x: (new swing state, new mode parameters, info)."""
        raise NotImplementedError

    # --- helpers ----------------------------------------------------------------------------------
    def outputs(self, t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        y = self.swing.augment(x) if len(x) == self.swing.n_states else x
        return np.asarray(self.swing.functions.outputs(t, y, self.swing.native_params(p)))

    def output(self, name: str, x: np.ndarray, p: np.ndarray, t: float = 0.0) -> float:
        return float(self.outputs(t, x, p)[self._out[name]])

    def velocities(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Joint rates v = M(q)⁻¹ p of the swing model (solved, not inverted)."""
        M = self.swing.matrix("walker.M", 0.0, x, p)
        return np.linalg.solve(M, x[self._ip])

    def state_from(self, q: np.ndarray, v: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Swing-model state with joint angles q and rates v (momenta p = M(q) v)."""
        x = np.zeros(self.swing.n_states)
        x[self._iq] = q
        x[self._ip] = self.swing.matrix("walker.M", 0.0, x, p) @ np.asarray(v, dtype=float)
        return x

    def _floating_state(self, qf: dict[str, float], vf: np.ndarray) -> np.ndarray:
        xf = np.zeros(self.floating.n_states)
        for name, value in qf.items():
            xf[self._fq[name]] = value
        xf[self._fp] = self.floating.matrix("walker.M", 0.0, xf, self._pf) @ vf
        return xf

    # --- the stride ---------------------------------------------------------------------------------
    def stride(self, z: np.ndarray, *, details: bool = False, record: bool = False) -> Stride:
        """One step from section coordinates ``z`` to the next heel strike (see :class:`Stride`).

        ``details`` also computes max |θ| and max |φ| on the dense output; ``record`` keeps the
        trajectory in ``stride.info["trajectory"]``.
        """
        return self.walk(z, 1, details=details, record=record)[0]

    def walk(self, z: np.ndarray, n_steps: int, *, details: bool = False,
             record: bool = False, ground_drop: float = 0.0) -> list[Stride]:
        """``n_steps`` consecutive strides from ``z`` in one simulation (one energy ledger); stops at
        the first fall. Returns one :class:`Stride` per step taken (the last may be a fall).

        ``ground_drop`` h (m): the surface ahead of the stance foot is h lower (``ground_z = −h``
        from the start); every later stance foot stands on it (the impact sets ``stance_z`` to
        the striking foot's height), so the drop happens once."""
        z = np.asarray(z, dtype=float)
        if not (math.isfinite(ground_drop) and ground_drop >= 0.0):
            raise ParameterValueError(f"ground_drop = {ground_drop!r} must be a finite height >= 0 (m)")
        p0 = self._params_with(self._p, stance_x=0.0, stance_z=0.0, ground_z=-float(ground_drop))
        try:
            x0 = self.lift(z)
        except (np.linalg.LinAlgError, ModelError, ValueError) as err:
            return [Stride("fell", None, 0.0, reason=f"invalid_state: {err}")]
        if not np.all(np.isfinite(x0)):
            return [Stride("fell", None, 0.0, reason="invalid_state")]
        opts = self.options
        log: list[dict] = []
        state = {"steps": 0, "ignored": 0}

        def heel_strike(t, x, p):
            out = self.outputs(t, x, p)
            front = out[self._out[f"walker.{self.heel_strike_point}.x"]] - p[self._ix]
            if not front > self._min_front(p):
                state["ignored"] += 1          # mid-stance scuffing, or a foot behind: ignored
                return Reset()
            x_new, modes, info = self._impact(t, x, p)
            info.update(t=t, x_minus=x.copy(), p_minus=p.copy(), x_plus=x_new.copy(),
                        step_length=modes["stance_x"] - p[self._ix])
            log.append(info)
            state["steps"] += 1
            return Reset(x=x_new, params=modes, stop=state["steps"] >= n_steps)

        t_limit = opts.max_step_time * n_steps
        names = dict(zip(self.swing.param_names, p0))
        traj = self.swing.simulate(
            t_limit, x0=x0, params=names, method=opts.method, rtol=opts.rtol, atol=opts.atol,
            max_step=opts.max_step,
            actions={"heel_strike": heel_strike, **{name: _stop for name in self.fall_events}},
            dense_output=details or record, max_events=50 * n_steps + 50)
        return self._strides(traj, z, log, details, record, n_steps)

    def _min_front(self, p: np.ndarray) -> float:
        """How far in front of the stance foot (m) the swing foot must be for a heel strike: a
        small fraction of the leg length (the scuffing crossing is exactly at 0)."""
        return 1e-6 * self.leg_length

    def _strides(self, traj, z0, log, details, record, n_steps) -> list[Stride]:
        t, Y = traj.t, traj.y
        params = np.concatenate([np.repeat(seg.p[None, :], len(seg.t), axis=0)
                                 for seg in traj.segments])
        n = self.swing.n_states
        iV = self._out["walker.V"]

        def at(i):
            """(H, V, E_diss, E_in) at stored point i."""
            pn = self.swing.native_params(params[i])
            y = np.ascontiguousarray(Y[:, i])
            H = float(self.swing.functions.energy(t[i], y, pn)[0])
            V = float(self.swing.functions.outputs(t[i], y, pn)[iV])
            return H, V, float(Y[n, i]), float(Y[n + 1, i])

        strides: list[Stride] = []
        t_prev, prev = 0.0, at(0)
        for info in log:
            # the post-impact point: the reset segment stored at the event time
            idx = int(np.nonzero(t == info["t"])[0][-1])
            now = at(idx)
            z_next = self.project(info["x_plus"], params[idx])
            stride = Stride(
                "step", z_next, info["t"] - t_prev, step_length=float(info["step_length"]),
                energy_dissipated=now[2] - prev[2], potential_released=prev[1] - now[1],
                energy_residual=(now[0] - prev[0]) + (now[2] - prev[2]) - (now[3] - prev[3]),
                info=dict(info))
            if details:
                stride.max_theta, stride.max_phi = self._maxima(traj, t_prev, info["t"])
            strides.append(stride)
            t_prev, prev = info["t"], now
        if len(log) < n_steps:
            reason = self._fall_reason(traj)
            fell = Stride("fell", None, float(traj.t_final - t_prev), reason=reason,
                          info={"message": traj.message, "status": traj.status})
            if details and traj.t_final > t_prev:
                fell.max_theta, fell.max_phi = self._maxima(traj, t_prev, traj.t_final)
            strides.append(fell)
        if record and strides:
            strides[-1].info["trajectory"] = traj
        return strides

    def _fall_reason(self, traj) -> str:
        if traj.status == "finished":
            return "time_limit"
        if traj.status == "event" and traj.events:
            return traj.events[-1][1]
        return traj.status

    # --- dense maxima ---------------------------------------------------------------------------
    def thesis_angles(self, x: np.ndarray) -> tuple[float, float]:
        """(θ, φ) of a swing-model state (rad)."""
        raise NotImplementedError

    def _maxima(self, traj, t0: float, t1: float) -> tuple[float, float]:
        if not t1 > t0:
            return math.nan, math.nan
        grid = np.linspace(t0, t1, 401)
        eps = 1e-12 * max(1.0, t1)
        grid[0], grid[-1] = t0 + eps, t1 - eps
        X = traj.sol(grid)
        angles = np.array([self.thesis_angles(X[:, k]) for k in range(len(grid))])
        out = []
        for j in range(2):
            vals = np.abs(angles[:, j])
            if not np.all(np.isfinite(vals)):
                out.append(math.nan)
                continue
            k = int(np.argmax(vals))
            best = vals[k]
            if 0 < k < len(grid) - 1:       # refine an interior maximum
                res = minimize_scalar(lambda s: -abs(self.thesis_angles(traj.sol(s))[j]),
                                      bounds=(grid[k - 1], grid[k + 1]), method="bounded",
                                      options={"xatol": 1e-10})
                best = max(best, -float(res.fun))
            out.append(float(best))
        return out[0], out[1]


class LeggedRigidWalker(RigidImpactWalker):
    """Two equal rigid legs of length ``l`` hinged at the hip, point feet, plastic heel strike.

    Swing model coordinates: ``walker.q.stance`` (stance-leg angle from the slope normal, positive
    forward: the hip ahead of the foot) and ``walker.q.hip`` (swing leg relative to the stance
    leg). Thesis/Garcia coordinates: θ = −q_stance, φ = q_hip, θ̇ = −v_stance, φ̇ = v_hip.
    Section (just after heel strike, both feet on the slope: q_hip = −2 q_stance): the model's own
    independent coordinates z = (q_stance, v_stance, v_hip); the thesis's (θ̇, φ, φ̇).
    """

    legged = True
    section = ("walker.q.stance", "walker.v.stance", "walker.v.hip")
    thesis_section = ("theta_dot", "phi", "phi_dot")

    def lift(self, z):
        q_st, v_st, v_hip = (float(a) for a in z)
        return self.state_from(np.array([q_st, -2.0 * q_st]), np.array([v_st, v_hip]), self._p)

    def project(self, x, p):
        q = x[self._iq]
        v = self.velocities(x, p)
        return np.array([q[0], v[0], v[1]])

    def thesis_angles(self, x):
        q = x[self._iq]
        return -float(q[0]), float(q[1])

    def to_thesis(self, z):
        q_st, v_st, v_hip = z
        return np.array([-v_st, -2.0 * q_st, v_hip])

    def from_thesis(self, w):
        theta_dot, phi, phi_dot = w
        return np.array([-phi / 2.0, -theta_dot, phi_dot])

    def section_state(self, z):
        q_st, v_st, v_hip = (float(a) for a in z)
        return {"walker.q.stance": q_st, "walker.q.hip": -2.0 * q_st, "walker.v.stance": v_st,
                "walker.v.hip": v_hip, "theta": -q_st, "theta_dot": -v_st, "phi": -2.0 * q_st,
                "phi_dot": v_hip, "hip_speed": abs(v_st) * self.leg_length}

    def thesis_state(self, z) -> np.ndarray:
        """(θ, θ̇, φ, φ̇) of section coordinates z."""
        s = self.section_state(z)
        return np.array([s["theta"], s["theta_dot"], s["phi"], s["phi_dot"]])

    def from_thesis_state(self, theta, theta_dot, phi_dot) -> np.ndarray:
        """Section coordinates from (θ, θ̇, φ̇) just after heel strike (φ = 2θ)."""
        return np.array([-theta, -theta_dot, phi_dot])

    def initial_guess(self):
        P = self.parameters
        return self.from_thesis_state(P["theta0"], P["theta_dot0"], P["phi_dot0"])

    def _impact(self, t, x, p):
        out = self.outputs(t, x, p)
        q = x[self._iq]
        v = self.velocities(x, p)
        J_hip = self.swing.matrix("walker.J.hip_centre", t, x, p)        # 2 x 2: hip (x, z) velocity
        hip_v = J_hip @ v
        qf = {"walker.q.hip_joint.x": out[self._out["walker.hip_centre.x"]],
              "walker.q.hip_joint.z": out[self._out["walker.hip_centre.z"]],
              "walker.q.leg1": q[0], "walker.q.leg2": q[0] + q[1]}
        vf = np.array([hip_v[0], hip_v[1], v[0], v[0] + v[1]])
        xf = self._floating_state(qf, vf)
        imp = model_impact(self.floating, xf, self._pf, ["walker.J.foot2"], "walker.M",
                           v_minus=vf)
        vplus = imp.impact.v_plus
        trailing = self.floating.matrix("walker.J.foot1", 0.0, imp.x_plus, self._pf) @ vplus
        q_new = np.array([q[0] + q[1], -q[1]])                    # leg 2 is the new stance leg
        v_new = np.array([vplus[3], vplus[2] - vplus[3]])
        modes = {"stance_x": float(out[self._out["walker.swing_foot.x"]]),
                 "stance_z": float(out[self._out["walker.swing_foot.z"]])}
        p_new = self._params_with(p, **modes)
        x_new = self.state_from(q_new, v_new, p_new)
        info = {"impact_energy_lost": imp.impact.energy_lost,
                "impulse": imp.impact.impulse.tolist(),
                "trailing_foot_normal_velocity": float(trailing[1]),
                "constraint_velocity": float(np.max(np.abs(imp.impact.constraint_velocity)))}
        return x_new, modes, info


class RimlessWheelWalker(RigidImpactWalker):
    """A rimless wheel: n spokes of length l at angles 2α = 2π/n, the mass at the hub.

    Swing model coordinate ``walker.q.stance``: angle of the stance spoke from the slope normal,
    positive forward. Just after a spoke strikes, q_stance = −α; the section is the model's own
    rate (``walker.v.stance``,); the thesis-style (θ, θ̇) = (−q, −v) are reported too.
    """

    legged = False
    section = ("walker.v.stance",)
    thesis_section = ("theta_dot",)
    heel_strike_point = "next_tip"
    fall_events = ("rolled_back",)

    @property
    def alpha(self) -> float:
        """Half the angle between neighbouring spokes, π/n (rad)."""
        return math.pi / self.parameters["n_spokes"]

    def _check_physical(self) -> None:
        n = self.parameters["n_spokes"]
        if n != round(n):
            raise ParameterValueError(f"parameter 'n_spokes' = {n:g} must be a whole number of spokes")

    def lift(self, z):
        return self.state_from(np.array([-self.alpha]), np.array([float(z[0])]), self._p)

    def project(self, x, p):
        return np.array([self.velocities(x, p)[0]])

    def thesis_angles(self, x):
        return -float(x[self._iq][0]), math.nan

    def to_thesis(self, z):
        return np.array([-z[0]])

    def from_thesis(self, w):
        return np.array([-w[0]])

    def section_state(self, z):
        v = float(z[0])
        return {"walker.q.stance": -self.alpha, "walker.v.stance": v, "theta": self.alpha,
                "theta_dot": -v, "hub_speed": abs(v) * self.leg_length}

    def initial_guess(self):
        return np.array([self.parameters["omega0"]])

    def _impact(self, t, x, p):
        out = self.outputs(t, x, p)
        q = x[self._iq]
        v = self.velocities(x, p)
        hub_v = self.swing.matrix("walker.J.hub", t, x, p) @ v
        qf = {"walker.q.hub_joint.x": out[self._out["walker.hub.x"]],
              "walker.q.hub_joint.z": out[self._out["walker.hub.z"]], "walker.q.spin": q[0]}
        vf = np.array([hub_v[0], hub_v[1], v[0]])
        xf = self._floating_state(qf, vf)
        imp = model_impact(self.floating, xf, self._pf, ["walker.J.next_tip"], "walker.M",
                           v_minus=vf)
        vplus = imp.impact.v_plus
        modes = {"stance_x": float(out[self._out["walker.next_tip.x"]]),
                 "stance_z": float(out[self._out["walker.next_tip.z"]])}
        p_new = self._params_with(p, **modes)
        x_new = self.state_from(np.array([q[0] - 2.0 * self.alpha]), np.array([vplus[2]]), p_new)
        trailing = self.floating.matrix("walker.J.stance_tip", 0.0, imp.x_plus, self._pf) @ vplus
        info = {"impact_energy_lost": imp.impact.energy_lost,
                "impulse": imp.impact.impulse.tolist(),
                "trailing_foot_normal_velocity": float(trailing[1]),
                "constraint_velocity": float(np.max(np.abs(imp.impact.constraint_velocity)))}
        return x_new, modes, info
