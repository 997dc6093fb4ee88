"""Hand-written numpy + scipy versions of the walkers of ``walker_library``, as a competent
researcher would write them without the framework: equations of motion typed in from the physics,
``scipy.integrate.solve_ivp`` with events, no numba, no analytic Jacobian (the stiff solver gets
scipy's own finite differences, ``jac=None``, the usual hand-written choice), and a plain Newton
iteration with a forward-difference Jacobian for the fixed point. Used by
``tests/validation/test_handwritten_walkers.py`` (independent validation of the framework's
simplest walker) and by ``benchmarks/bench_walkers.py`` (timing against the framework in the same
run; it imports this module from here).

Simplest walker (Garcia, Chatterjee, Ruina & Coleman 1998, "The simplest walking model:
stability, complexity, and scaling", J. Biomech. Eng. 120:281–288), nondimensional, β = m/M -> 0
-----------------------------------------------------------------------------------------------
State (θ, θ̇, φ, φ̇): θ the stance-leg angle to the slope normal, φ the angle between the legs.
Swing phase (Garcia's eqs. 3–4):  θ̈ = sin(θ − γ),  φ̈ = sin φ (θ̇² − cos(θ − γ)) + sin(θ − γ).
Heel strike where φ − 2θ = 0 (swing foot on the slope) crossing upwards *after* mid-stance
(θ < 0: the swing foot in front of the stance foot; the mid-stance crossing, foot scuffing, is
ignored as Garcia does): the event function is φ − 2θ for θ < 0 and −1 before (its jump at θ = 0
is between two negative values, so it never makes a false root). Plastic impact, legs swap
(Garcia's eq. 5, β -> 0): θ⁺ = −θ⁻, φ⁺ = −2θ⁻, θ̇⁺ = cos 2θ⁻ · θ̇⁻,
φ̇⁺ = cos 2θ⁻ (1 − cos 2θ⁻) θ̇⁻. Section just after heel strike: (θ, θ̇, φ̇) (φ = 2θ).
Integrated by DOP853 at the framework walker's tolerances.

Nominal compliant-contact walker (the thesis's ch. 2; models/compass_walker.toml)
----------------------------------------------------------------------------------------------
Slope frame (x down the slope, z along its normal), gravity g (sin γ, 0, −cos γ), surface z = 0.
Coordinates q = (x, z, a1, a2): hip position and the absolute leg angles (a = 0: leg along −z; a
foot in front of the hip has a < 0); velocities v = q̇; state y = (q, v). Each leg: a rod of mass
m_leg, centre at l/2, moment of inertia I_leg about it, and a foot mass m_foot at l from the hip.
With S = m_leg l/2 + m_foot l, I = m_leg l²/4 + I_leg + m_foot l², m_t = M + 2 (m_leg + m_foot)
(Lagrange's equations, by hand):

    M(q) = [[m_t, 0, −S cos a1, −S cos a2],
            [0, m_t,  S sin a1,  S sin a2],
            [−S cos a1, S sin a1, I, 0],
            [−S cos a2, S sin a2, 0, I]]
    M v̇ = [ −S Σ sin a_k ȧ_k² + m_t g sin γ + Q_x,
            −S Σ cos a_k ȧ_k² − m_t g cos γ + Q_z,
            −g S sin(a_k + γ) + Q_ak ]

Contact of foot k (arc foot of radius R, centre at the leg's end, contact point R below the
centre along the slope normal): penetration δ = R − (z − l cos a), δ̇ = −(ż + l sin a ȧ);
Hunt–Crossley with exponent 1, F = c_k δ (K + λ δ̇) for δ > 0 and K + λ δ̇ > 0, else 0, acting
along +z on the foot centre: Q_z += F, Q_a += F l sin a. SCVS friction F_t = −F μ(v) with the
20-sim law μ(v) = (μ_c + (μ_st |tanh(s v)| − μ_c) exp(−(v/v_st)²)) sign(v) + μ_v v, at the
rolling arc's material contact point (``rolling=True``, models/compass_walker.toml): the point
R below the foot centre, fixed in the leg at that instant, slip v = ẋ − (l cos a + R) ȧ, Q_x +=
F_t, Q_a −= (l cos a + R) F_t; or (``rolling=False``, models/compass_walker_sole_friction.toml) at
the leg's material point R beyond the foot centre (the "sole", l + R from the hip), slip
v = ẋ − (l + R) cos a ȧ, Q_a −= (l + R) cos a F_t. c_k ∈ {0, 1} are the contact flags.

Scuffing rule (contact flags switched by events, as the framework's walker does): a touchdown
(δ_k rising through 0) of an inactive foot starts its contact if the foot is the leading foot
(a bounce) or is more than ``front_margin`` in front of the other foot (a heel strike: a new step,
the section); otherwise (the mid-stance pass of the straight swing leg) it is ignored. A contact
ends when δ_k + liftoff_margin falls through 0. Fall: the hip lower than fall_fraction · l. Each
mode switch is a terminal event of ``solve_ivp``; the integration restarts from the event state
with the new flags (only the guards that can change a flag are watched in a segment: touchdown of
inactive, lift-off of active feet). An ignored touchdown restarts with its guard held on its new
side at the restart point, so that it does not fire again at the same crossing (the framework's
rule too). A stride starts at the leading foot's touchdown, 1e-9 m inside the surface, both
contacts on (the trailing foot's off if it starts above the lift-off level), and ends at the next
touchdown of the other foot in front. Section: (a_lead, a_trail, ẋ, ż, ȧ_lead, ȧ_trail).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

__all__ = [
    "CompassWalkerHand",
    "CompliantLegWalkerHand",
    "NewtonResult",
    "SimplestWalkerHand",
    "newton_fixed_point",
]


# ------------------------------------------------------------------------------------------------
# the simplest walking model (Garcia et al. 1998)
# ------------------------------------------------------------------------------------------------
def _garcia_heel_strike(t, y):
    """φ − 2θ after mid-stance (θ < 0), −1 before: the heel-strike guard, rising through 0."""
    th, ph = y[0], y[2]
    return ph - 2.0 * th if th < 0.0 else -1.0


_garcia_heel_strike.terminal = True
_garcia_heel_strike.direction = 1


def _garcia_fall(t, y):
    """The hip below half the leg length above the stance foot (cos θ = 1/2)."""
    return math.cos(y[0]) - 0.5


_garcia_fall.terminal = True
_garcia_fall.direction = -1


class SimplestWalkerHand:
    """Garcia et al.'s (1998) simplest walker, β -> 0, nondimensional. Section z = (θ, θ̇, φ̇)
    just after heel strike (φ = 2θ)."""

    def __init__(self, slope: float = 0.009, *, method: str = "DOP853", rtol: float = 1e-12,
                 atol: float = 1e-24, max_step: float = 0.25, max_time: float = 20.0):
        self.gamma = slope
        self.method, self.rtol, self.atol, self.max_step = method, rtol, atol, max_step
        self.max_time = max_time
        self.nfev = 0
        self.nsteps = 0

    def rhs(self, t, y):
        th, thd, ph, phd = y
        s = math.sin(th - self.gamma)
        return np.array([thd, s, phd, math.sin(ph) * (thd * thd - math.cos(th - self.gamma)) + s])

    heel_strike = staticmethod(_garcia_heel_strike)
    fall = staticmethod(_garcia_fall)

    @staticmethod
    def impact(y):
        th, thd = y[0], y[1]
        c = math.cos(2.0 * th)
        return np.array([-th, c * thd, -2.0 * th, c * (1.0 - c) * thd])

    def walk(self, z, n_steps: int) -> list[np.ndarray | None]:
        """Section states after each of n_steps heel strikes (None once the walker fell)."""
        th, thd, phd = (float(a) for a in z)
        y = np.array([th, thd, 2.0 * th, phd])
        out: list[np.ndarray | None] = []
        for _ in range(n_steps):
            sol = solve_ivp(self.rhs, (0.0, self.max_time), y, method=self.method, rtol=self.rtol,
                            atol=self.atol, max_step=self.max_step,
                            events=[self.heel_strike, self.fall])
            self.nfev += sol.nfev
            self.nsteps += len(sol.t) - 1
            if sol.status != 1 or len(sol.t_events[0]) == 0:
                out.append(None)
                return out
            y = self.impact(sol.y_events[0][0])
            out.append(np.array([y[0], y[1], y[3]]))
        return out

    def stride(self, z):
        return self.walk(z, 1)[0]


# ------------------------------------------------------------------------------------------------
# Newton on S(z) − z with a forward-difference Jacobian (the framework's algorithm, by hand)
# ------------------------------------------------------------------------------------------------
@dataclass
class NewtonResult:
    converged: bool
    z: np.ndarray
    residual: float
    iterations: int
    strides: int = 0
    history: list = field(default_factory=list)


def newton_fixed_point(S, z0, *, tol: float = 1e-10, fd_step: float = 1e-6,
                       max_iter: int = 30) -> NewtonResult:
    """Fixed point of the stride map S (z -> z_next or None on a fall) by Newton's method with a
    forward-difference Jacobian (step ``fd_step``) and step halving."""
    z = np.asarray(z0, dtype=float)
    n = len(z)
    calls = [0]

    def F(w):
        calls[0] += 1
        s = S(w)
        return None if s is None else s - w

    Fz = F(z)
    if Fz is None:
        return NewtonResult(False, z, math.inf, 0, calls[0])
    res = float(np.max(np.abs(Fz)))
    hist = [res]
    for it in range(1, max_iter + 1):
        if res < tol:
            return NewtonResult(True, z, res, it - 1, calls[0], hist)
        J = np.empty((n, n))
        for j in range(n):
            e = np.zeros(n)
            e[j] = fd_step
            Fj = F(z + e)
            if Fj is None:
                return NewtonResult(False, z, res, it, calls[0], hist)
            J[:, j] = (Fj - Fz) / fd_step
        dz = -np.linalg.solve(J, Fz)
        lam, ok = 1.0, False
        for _ in range(12):
            trial = z + lam * dz
            Ft = F(trial)
            if Ft is not None:
                rt = float(np.max(np.abs(Ft)))
                if rt < res or rt < tol:
                    z, Fz, res, ok = trial, Ft, rt, True
                    break
            lam /= 2
        hist.append(res)
        if not ok:
            break
    return NewtonResult(res < tol, z, res, len(hist) - 1, calls[0], hist)


# ------------------------------------------------------------------------------------------------
# the thesis's nominal compliant-contact walker
# ------------------------------------------------------------------------------------------------
COMPASS_DEFAULTS = {"slope": 0.009, "M": 3.0, "m_leg": 0.01, "I_leg": 0.01 * 0.7**2 / 12,
                    "m_foot": 0.1, "l": 0.7, "R": 0.05,
                    "g": 9.81, "K": 1.0e6, "lam": 3.16e7, "mu_st": 0.5, "mu_c": 0.25,
                    "mu_v": 0.025, "s_fric": 500.0, "v_st": 0.02, "liftoff_margin": 1e-6,
                    "front_margin": 0.01, "fall_fraction": 0.5}
START_PENETRATION = 1e-9


@dataclass
class StrideRecord:
    """One step of :meth:`CompassWalkerHand.walk`: the section state at its end (None: fell)."""

    z_next: np.ndarray | None
    t: float
    reason: str = ""
    y: np.ndarray | None = None        # the state at the heel strike (touchdown)
    lead: int = 0                      # the new leading leg (0 or 1)


class CompassWalkerHand:
    """The nominal compliant-contact walker by hand (see the module docstring)."""

    def __init__(self, *, method: str = "Radau", rtol: float = 1e-8, atol: float = 1e-10,
                 max_step: float = 0.01, max_step_time: float = 3.0, jac=None,
                 rolling: bool = True, **params):
        P = dict(COMPASS_DEFAULTS)
        unknown = set(params) - set(P)
        if unknown:
            raise KeyError(f"unknown parameters {sorted(unknown)}")
        P.update(params)
        self.P = P
        self.method, self.rtol, self.atol, self.max_step = method, rtol, atol, max_step
        self.max_step_time = max_step_time
        self.jac = jac                     # None: scipy's finite differences; "fd": our own
        self.rolling = rolling             # friction at the rolling contact point, or the sole
        l, ml, mf = P["l"], P["m_leg"], P["m_foot"]
        self.S = ml * l / 2 + mf * l
        self.I = ml * l * l / 4 + P["I_leg"] + mf * l * l
        self.mt = P["M"] + 2 * (ml + mf)
        self.stats = {"nfev": 0, "njev": 0, "nlu": 0, "steps": 0, "segments": 0, "events": 0}

    # --- mechanics ------------------------------------------------------------------------------
    def mass_matrix(self, q):
        S, I, mt = self.S, self.I, self.mt
        c1, s1, c2, s2 = math.cos(q[2]), math.sin(q[2]), math.cos(q[3]), math.sin(q[3])
        return np.array([[mt, 0.0, -S * c1, -S * c2],
                         [0.0, mt, S * s1, S * s2],
                         [-S * c1, S * s1, I, 0.0],
                         [-S * c2, S * s2, 0.0, I]])

    def potential(self, q):
        P, S, mt = self.P, self.S, self.mt
        g, gam = P["g"], P["slope"]
        zc = mt * q[1] - S * (math.cos(q[2]) + math.cos(q[3]))       # Σ m z
        xc = mt * q[0] - S * (math.sin(q[2]) + math.sin(q[3]))       # Σ m x
        return g * (math.cos(gam) * zc - math.sin(gam) * xc)

    def mu(self, v):
        P = self.P
        if v == 0.0:
            return 0.0
        E = math.exp(-(v / P["v_st"]) ** 2)
        sgn = 1.0 if v > 0 else -1.0
        return ((P["mu_c"] + (P["mu_st"] * abs(math.tanh(P["s_fric"] * v)) - P["mu_c"]) * E) * sgn
                + P["mu_v"] * v)

    def lever(self, r, a):
        """∂(x of the friction's point)/∂a for a foot centre r from the hip at leg angle a: the
        rolling contact point's r cos a + R, or the sole's (r + R) cos a."""
        R = self.P["R"]
        return r * math.cos(a) + R if self.rolling else (r + R) * math.cos(a)

    def contact_forces(self, y, c):
        """(F_n, F_t) of both feet at state y with flags c."""
        P = self.P
        l, R, K, lam = P["l"], P["R"], P["K"], P["lam"]
        z, zd, vx = y[1], y[5], y[4]
        out = []
        for k in (0, 1):
            a, w = y[2 + k], y[6 + k]
            F = Ft = 0.0
            if c[k]:
                d = R - z + l * math.cos(a)
                if d > 0.0:
                    dd = -(zd + l * math.sin(a) * w)
                    law = K + lam * dd
                    if law > 0.0:
                        F = d * law
                        Ft = -F * self.mu(vx - self.lever(l, a) * w)
            out.append((F, Ft))
        return out

    def rhs(self, t, y, c):
        P = self.P
        S, mt, l = self.S, self.mt, P["l"]
        g, gam = P["g"], P["slope"]
        a1, a2, w1, w2 = y[2], y[3], y[6], y[7]
        s1, c1, s2, c2 = math.sin(a1), math.cos(a1), math.sin(a2), math.cos(a2)
        b = np.array([-S * (s1 * w1 * w1 + s2 * w2 * w2) + mt * g * math.sin(gam),
                      -S * (c1 * w1 * w1 + c2 * w2 * w2) - mt * g * math.cos(gam),
                      -g * S * math.sin(a1 + gam),
                      -g * S * math.sin(a2 + gam)])
        for k, (F, Ft) in enumerate(self.contact_forces(y, c)):
            if F != 0.0:
                a = y[2 + k]
                b[0] += Ft
                b[1] += F
                b[2 + k] += F * l * math.sin(a) - self.lever(l, a) * Ft
        M = np.array([[mt, 0.0, -S * c1, -S * c2],
                      [0.0, mt, S * s1, S * s2],
                      [-S * c1, S * s1, self.I, 0.0],
                      [-S * c2, S * s2, 0.0, self.I]])
        return np.concatenate((y[4:], np.linalg.solve(M, b)))

    def fd_jac(self, c):
        """A forward-difference Jacobian, the hand-writer's own (the ``jac="fd"`` variant)."""
        def jac(t, y):
            f0 = self.rhs(t, y, c)
            n = len(y)
            J = np.empty((n, n))
            for j in range(n):
                h = 1e-8 * max(1.0, abs(y[j]))
                yj = y.copy()
                yj[j] += h
                J[:, j] = (self.rhs(t, yj, c) - f0) / h
            return J
        return jac

    # --- kinematics -----------------------------------------------------------------------------
    def penetration(self, y, k):
        P = self.P
        return P["R"] - y[1] + P["l"] * math.cos(y[2 + k])

    def foot_x(self, y, k):
        return y[0] - self.P["l"] * math.sin(y[2 + k])

    def lift(self, z):
        """Section state (leg 1 leading) -> y."""
        a_lead, a_trail, vx, vz, w_lead, w_trail = (float(a) for a in z)
        P = self.P
        return np.array([0.0, P["l"] * math.cos(a_lead) + P["R"] - START_PENETRATION, a_lead,
                         a_trail, vx, vz, w_lead, w_trail])

    @staticmethod
    def project(y, lead):
        i, j = (2, 3) if lead == 0 else (3, 2)
        return np.array([y[i], y[j], y[4], y[5], y[4 + i], y[4 + j]])

    # --- the walk ------------------------------------------------------------------------------
    def walk(self, z, n_steps: int) -> list[StrideRecord]:
        """``n_steps`` steps from section state z (leg 1 leading)."""
        return self.walk_from(self.lift(z), n_steps)

    def walk_from(self, y, n_steps: int) -> list[StrideRecord]:
        """``n_steps`` steps from the state y at the leading foot's (leg 1's) touchdown."""
        P = self.P
        margin = P["liftoff_margin"]
        y = np.array(y, dtype=float)
        c = [1, 1]
        if not self.penetration(y, 1) + margin > 0:
            c[1] = 0
        lead, steps, t = 0, 0, 0.0
        t_end = self.max_step_time * n_steps
        masked = None                        # (kind, k): hold this guard on its new side at t
        out: list[StrideRecord] = []
        st = self.stats
        while True:
            kinds = []
            fns = []
            for k in (0, 1):
                if c[k]:
                    def g(t_, y_, k=k):
                        return self.penetration(y_, k) + margin
                    g.direction = -1
                    kinds.append(("liftoff", k))
                else:
                    def g(t_, y_, k=k):
                        return self.penetration(y_, k)
                    g.direction = 1
                    kinds.append(("touchdown", k))
                fns.append(g)

            def fall(t_, y_):
                return y_[1] - P["fall_fraction"] * P["l"]
            fall.direction = -1
            kinds.append(("fall", -1))
            fns.append(fall)
            for i, f in enumerate(fns):
                if masked is not None and kinds[i] == masked:
                    def held(t_, y_, f=f, t0=t):
                        v = f(t_, y_)
                        return f.direction * max(abs(v), 1e-300) if t_ == t0 else v
                    held.direction = f.direction
                    f = fns[i] = held
                f.terminal = True
            cc = tuple(c)
            jac = self.fd_jac(cc) if self.jac == "fd" else None
            sol = solve_ivp(lambda t_, y_, cc=cc: self.rhs(t_, y_, cc), (t, t_end), y, method=self.method,
                            rtol=self.rtol, atol=self.atol, max_step=self.max_step, events=fns,
                            jac=jac)
            st["nfev"] += sol.nfev
            st["njev"] += sol.njev
            st["nlu"] += sol.nlu
            st["steps"] += len(sol.t) - 1
            st["segments"] += 1
            if sol.status != 1:
                out.append(StrideRecord(None, float(sol.t[-1]),
                                        "time_limit" if sol.status == 0 else sol.message))
                return out
            st["events"] += 1
            hits = [(te[0], i) for i, te in enumerate(sol.t_events) if len(te)]
            t, i = min(hits)
            y = sol.y_events[i][0].copy()
            kind, k = kinds[i]
            masked = None
            if kind == "fall":
                out.append(StrideRecord(None, t, "fall"))
                return out
            if kind == "liftoff":
                c[k] = 0
                continue
            # touchdown of an inactive foot
            other = 1 - k
            if k == lead:                                   # a bounce of the leading foot
                c[k] = 1
            elif self.foot_x(y, k) - self.foot_x(y, other) > P["front_margin"]:
                c[k] = 1                                    # heel strike: a new step
                lead = k
                steps += 1
                out.append(StrideRecord(self.project(y, k), t, y=y.copy(), lead=k))
                if steps >= n_steps:
                    return out
            else:                                           # scuffing: the foot passes through
                masked = ("touchdown", k)

    def stride(self, z):
        return self.walk(z, 1)[0].z_next


# ------------------------------------------------------------------------------------------------
# the compliant-leg walker (the thesis's §3.1; models/compliant_leg_walker.toml)
# ------------------------------------------------------------------------------------------------
class CompliantLegWalkerHand(CompassWalkerHand):
    """The nominal walker with each foot mass on a prismatic joint along its leg (extension s_k:
    the foot centre l + s_k from the hip) and a spring–damper on it, force
    −(K (s − preload/K) + D ṡ), D = 2 α √((M + m_foot) K) (thesis §3.1).

    The masses are points (hip M; leg k: m_leg at l/2; foot k: m_foot at r_k = l + s_k) plus each
    leg's moment of inertia I_leg about its centre, so the equations of motion are written the
    point-mass way: with p_i(q) each mass's position, J_i = ∂p_i/∂q and the convective
    acceleration c_i = J̇_i q̇, M(q) = Σ m_i J_iᵀ J_i + I_leg on the legs' angles and
    M q̈ = Σ J_iᵀ (m_i g − m_i c_i) + Q (contact, friction, spring) (a leg's rotation about its
    own centre, at the rate ȧ_k, adds ½ I_leg ȧ_k² and nothing else).
    q = (x, z, a1, a2, s1, s2), y = (q, q̇). Contact and friction as for the rigid-leg walker at
    the foot centre (penetration δ = R − z + r cos a) and at the rolling contact point (slip
    ẋ − ṡ sin a − (r cos a + R) ȧ) or the sole, R beyond it along the leg.
    Section: (a_lead, a_trail, ẋ, ż, ȧ_lead, ȧ_trail, s_lead, s_trail, ṡ_lead, ṡ_trail)."""

    def __init__(self, *, K_leg: float = 6000.0, alpha: float = 0.15, preload: float = 0.0,
                 **kw):
        super().__init__(**kw)
        P = self.P
        self.K_leg, self.alpha, self.preload = K_leg, alpha, preload
        self.D_leg = 2.0 * alpha * math.sqrt((P["M"] + P["m_foot"]) * K_leg)

    def _points(self, y):
        """For each point mass: (mass, J (2 x 6), c (2,)), and the feet's (r, sin a, cos a)."""
        P = self.P
        l, ml, mf = P["l"], P["m_leg"], P["m_foot"]
        pts = []
        J = np.zeros((2, 6))
        J[0, 0] = J[1, 1] = 1.0
        pts.append((P["M"], J, np.zeros(2)))
        for k in (0, 1):
            a, w = y[2 + k], y[8 + k]
            sa, ca = math.sin(a), math.cos(a)
            h = l / 2
            J = np.zeros((2, 6))
            J[0, 0] = J[1, 1] = 1.0
            J[0, 2 + k], J[1, 2 + k] = -h * ca, h * sa
            pts.append((ml, J, np.array([h * w * w * sa, h * w * w * ca])))
            r, sd = l + y[4 + k], y[10 + k]
            J = np.zeros((2, 6))
            J[0, 0] = J[1, 1] = 1.0
            J[0, 2 + k], J[1, 2 + k] = -r * ca, r * sa
            J[0, 4 + k], J[1, 4 + k] = -sa, -ca
            pts.append((mf, J, np.array([-2.0 * sd * w * ca + r * w * w * sa,
                                         2.0 * sd * w * sa + r * w * w * ca])))
        return pts

    def _leg_inertia(self) -> np.ndarray:
        D = np.zeros((6, 6))
        D[2, 2] = D[3, 3] = self.P["I_leg"]
        return D

    def mass_matrix(self, q):
        y = np.concatenate([np.asarray(q, dtype=float), np.zeros(6)])
        return sum(m * J.T @ J for m, J, _ in self._points(y)) + self._leg_inertia()

    def potential(self, q):
        P = self.P
        g, gam, l = P["g"], P["slope"], P["l"]
        V = P["M"] * g * (math.cos(gam) * q[1] - math.sin(gam) * q[0])
        for k in (0, 1):
            sa, ca = math.sin(q[2 + k]), math.cos(q[2 + k])
            for m, r in ((P["m_leg"], l / 2), (P["m_foot"], l + q[4 + k])):
                V += m * g * (math.cos(gam) * (q[1] - r * ca) - math.sin(gam) * (q[0] - r * sa))
        V += 0.5 * self.K_leg * sum((q[4 + k] - self.preload / self.K_leg) ** 2 for k in (0, 1))
        return V

    def rhs(self, t, y, c):
        P = self.P
        g, gam, l, R, K, lam = P["g"], P["slope"], P["l"], P["R"], P["K"], P["lam"]
        gv = np.array([g * math.sin(gam), -g * math.cos(gam)])
        M = self._leg_inertia()
        b = np.zeros(6)
        for m, J, cc in self._points(y):
            M += m * (J.T @ J)
            b += J.T @ (m * (gv - cc))
        x_d, z_d = y[6], y[7]
        for k in (0, 1):
            a, w, s, sd = y[2 + k], y[8 + k], y[4 + k], y[10 + k]
            sa, ca = math.sin(a), math.cos(a)
            b[4 + k] -= self.K_leg * s - self.preload + self.D_leg * sd
            if not c[k]:
                continue
            r = l + s
            d = R - y[1] + r * ca
            if d <= 0.0:
                continue
            dd = -(z_d - sd * ca + r * sa * w)
            law = K + lam * dd
            if law <= 0.0:
                continue
            F = d * law
            lever = self.lever(r, a)
            Ft = -F * self.mu(x_d - sd * sa - lever * w)
            # normal force (0, F) at the foot centre, friction (Ft, 0) at the contact point (or
            # the sole)
            b[0] += Ft
            b[1] += F
            b[2 + k] += F * r * sa - lever * Ft
            b[4 + k] += -F * ca - sa * Ft
        return np.concatenate((y[6:], np.linalg.solve(M, b)))

    def penetration(self, y, k):
        P = self.P
        return P["R"] - y[1] + (P["l"] + y[4 + k]) * math.cos(y[2 + k])

    def foot_x(self, y, k):
        return y[0] - (self.P["l"] + y[4 + k]) * math.sin(y[2 + k])

    def lift(self, z):
        z = [float(a) for a in z]
        a_lead, a_trail, vx, vz, w_lead, w_trail, s_lead, s_trail, sd_lead, sd_trail = z
        P = self.P
        return np.array([0.0, (P["l"] + s_lead) * math.cos(a_lead) + P["R"] - START_PENETRATION,
                         a_lead, a_trail, s_lead, s_trail,
                         vx, vz, w_lead, w_trail, sd_lead, sd_trail])

    @staticmethod
    def project(y, lead):
        i, j = (2, 3) if lead == 0 else (3, 2)
        return np.array([y[i], y[j], y[6], y[7], y[6 + i], y[6 + j],
                         y[2 + i], y[2 + j], y[8 + i], y[8 + j]])
