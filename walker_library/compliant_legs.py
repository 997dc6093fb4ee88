"""The thesis's compliant-leg walkers (MODEL-SPEC.md §3, §4; thesis ch. 3 and App. D): the nominal
walker of :mod:`walker_library.compliant` with a spring–damper along each leg.

Model (built from framework components only)
--------------------------------------------
Everything of ``compass_walker`` (hip point mass M on a translational x/z joint, legs on revolute
hip joints, arc feet with Hunt–Crossley contact + SCVS friction, the scuffing rule and the contact
events, step-down surfaces; :func:`~walker_library.compliant.contact_walker_model`), except that
each foot mass m sits on a **prismatic joint** ``ankle<k>`` at the leg's end, along the leg
(thesis §3.1, Fig. 3.2: "a linear spring connects the leg to the center of mass of the foot";
§2.2: the weld joints "can be replaced by z-translational joints"). Its coordinate s_k (m) is the
extension: the foot centre sits l + s_k from the hip along the leg (s_k > 0 longer, < 0
compressed); axis −z of the leg frame.

A spring–damper ``spring<k>`` (:class:`~porthamiltonian.library.SpringDamper`, or
:class:`~porthamiltonian.library.VariableSpringDamper` for §4) is bonded to the joint's port
(``walker.ankle<k> -> spring<k>.p``): its length state integrates the joint velocity (it equals
s_k: the walker sets it so when it lifts a section state), and its force −(K (s_k − L0) + D ṡ_k)
acts on the joint. The stored energy ½ K (s_k − L0)² and the damper dissipation D ṡ_k² enter
the ledger through the component.

* Damper (thesis Eq. 3.1): D = 2 α √((m + M) K), α = 0.15, the same in swing and stance (the
  thesis: since M ≈ 30 m, the stance rule is close to critical damping in swing — here
  ζ_swing = α √((m + M)/m) = 0.84 — and one damper serves both phases). **Masses:** the thesis
  sums the foot mass m = 0.1 kg and the hip mass M = 3 kg ("m is the foot mass, M is the hip
  mass"; App. D: ``sqrt(3.1*C)``); the leg masses (0.01 kg each) are left out. The component
  gets ``mass = "M + m_foot"`` (3.1 kg).
* Rest length / preload: the thesis mentions none; App. B starts the compliant-leg walker with
  the "suspension joint" at 0 and the same hip height (0.7405 m) as the rigid walker, i.e. the
  spring is relaxed at the nominal leg length l. That is the default here (``preload`` = 0,
  rest length L0 = preload/K = 0): under the static load the stance leg is shorter than l by
  δ = W_above / K, W_above = (M + 2 m_leg + m) g cos γ the weight above the stance spring (hip,
  both legs, the swing foot; the stance foot is below the spring) — 5.10 mm at K = 6000 N/m
  (0.73 % of l). A ``preload`` F0 (N) shifts the rest length to F0/K: F0 = W_above makes the
  statically loaded stance leg exactly l long, but also lengthens the swing leg by F0/K (no end
  stop), so the swing foot scuffs deeper; not what the thesis did.
* Leg stiffness K: default 6000 N/m, inside the thesis's stable range 1500–10 000 N/m for
  α = 0.15 (§3.1, Fig. 3.4; here stable from 1750 N/m up) and above the stiffnesses from which
  the thesis's compliant walker outpaces (3000 N/m) and outlasts (4500 N/m) the rigid-leg walker;
  it is also the first row of Table 3.1 and the K1 of its variable-stiffness rows.

Variable stiffness (§4, :func:`variable_stiffness_walker`; thesis Eq. 3.3 and App. D)
--------------------------------------------------------------------------------------
K_k = K1 + (K2 − K1)·mid_k·|φ|/φ_max, φ = α_1 − α_2 (the angle between the legs; App. D uses the
hip joint angle), and D_k = 2 α √(3.1 K_k) follows it. ``mid1``, ``mid2`` are mode parameters
(App. D's ``MidL = contactl and mid``): the walker's action of the event ``midstance<k>`` (guard
α_k − α_other rising through 0: the legs parallel, leg k passing from in front of the other to
behind it) sets mid_k = 1 when leg k is in stance (c_k = 1); the lift-off of foot k clears it. So
leg k stiffens from mid-stance to take-off and is K1 in swing. Setting mid_k does not change H
(at mid-stance |φ| = 0); clearing it at the lift-off drops K to K1 while the spring is still
≈ 1 mm compressed (its force balanced by the damper and the light foot), and that jump of H
(≈ −1 mJ per step at the defaults, 5 % of the energy the stiffening supplies) is booked as
supplied energy (``Reset(energy="supplied")``). During stance the compiler books the
modulation power ½ K̇ z² (z = s − L0) as supplied energy E_in
(:mod:`porthamiltonian.library.springs`). φ_max, "the peak value for φ with the fixed stiffness of
K1", is measured: the largest |φ| over a step of this walker's gait with K2 = K1 (the
constant-K1 gait, same α = 0.2) — the default 0.4370 rad (see :data:`PHI_MAX_K1`). Defaults
K1 = 6000, K2 = 8000 N/m, α = 0.2: Table 3.1's first variable-stiffness row (for which the thesis
found α = 0.15 chaotic and used 0.2).

Section (:class:`~walker_library.compliant.CompliantWalker` with ``extra_joints=("ankle",)``)
---------------------------------------------------------------------------------------------
The touchdown of the leading foot, as for ``compass_walker``; the six rigid-leg coordinates are
followed by s_lead (m), ``trail_contact_force`` (N) and ṡ_lead, ṡ_trail (m/s):
``walker.q.ankle_lead``, ``trail_contact_force``, ``walker.v.ankle_lead``,
``walker.v.ankle_trail`` (the same in the thesis's terms, ``ankle_lead``, ``trail_contact_force``,
``ankle_lead_dot``, ``ankle_trail_dot``). The hip height follows from the leading foot touching
the surface, (l + s_lead) cos α_lead + R; the trailing leg's extension s_trail from the trailing
foot's contact force F = K·(penetration) (see :meth:`CompliantLegWalker.lift`: a coordinate
in which a perturbation of 1e-4 does not lift the trailing foot off the surface). ``walker gait``
reports s_trail too (``walker.q.ankle_trail``).

Measured (γ = 0.009; tests/walkers/test_compliant_leg_walker.py and
test_variable_stiffness_walker.py give the details)
---------------------------------------------------
=============================  =========  =========  ==========  ==============  ========
walker                         θ (rad)    speed m/s  E_diss J    ground J        max |λ|
=============================  =========  =========  ==========  ==============  ========
compass_walker (rigid legs)    0.2064     0.3050     0.0874      0.0874          0.278
compliant_leg_walker (6000)    0.2489     0.3370     0.0987      0.0052          0.319
variable_stiffness_walker      0.2447     0.3373     0.1180      0.0053          0.282
=============================  =========  =========  ==========  ==============  ========

(E_diss per step; "ground" = contact + friction, :func:`dissipation_breakdown`; the variable
walker's E_diss = the potential released 0.0986 J + 0.0195 J supplied by the stiffening.)
About 0.16 s per step (numba + Rodas4 at rtol 1e-8, atol 1e-10, a quiet machine; compass_walker
0.04 s: the leg springs' oscillations take ≈ 3× the integration steps); compilation ≈ 35–70 s
once per model, cached on disk.
"""
from __future__ import annotations

import math
import textwrap

import numpy as np

from porthamiltonian import Model, Prismatic
from porthamiltonian.library import SpringDamper, VariableSpringDamper

from .compliant import (
    CompliantOptions,
    CompliantWalker,
    _spec,
    check_contact,
    compass_walker_specs,
    contact_specs,
    contact_walker_model,
)
from .protocol import ParameterSpec

__all__ = ["CompliantLegWalker", "PHI_MAX_K1", "VariableStiffnessWalker", "compliant_leg_walker",
           "dissipation_breakdown", "variable_stiffness_walker"]

THESIS3 = "MODEL-SPEC.md §3 (thesis §3.1, Eq. 3.1, Figs. 3.3-3.5)"
THESIS4 = "MODEL-SPEC.md §4 (thesis §3.2, Eq. 3.3, Table 3.1, App. D)"

#: φ_max default of :func:`variable_stiffness_walker` (rad): the largest |φ| over a step of the
#: gait of ``variable_stiffness_walker(K2=6000)`` (constant K1 = 6000 N/m, α = 0.2), measured
#: with ``analyze_gait`` (tests/walkers/test_variable_stiffness_walker.py checks it)
PHI_MAX_K1 = 0.4370

_RIGID_GUESS = ("theta0", "theta_dot0", "phi_dot0")


def _prismatic_foot(k: int) -> Prismatic:
    return Prismatic(parent=f"leg{k}", child=f"foot{k}_body", origin=[0, 0, "-l"], axis=[0, 0, -1])


def _guess_specs(theta0: float, theta_dot0: float, phi_dot0: float,
                 source: str) -> list[ParameterSpec]:
    return [
        _spec("theta0", theta0, "rad", "initial guess: θ at heel strike (φ: both feet on the "
              "surface, the trailing leg statically compressed)", source, 0.0, math.pi / 2),
        _spec("theta_dot0", theta_dot0, "rad/s", "initial guess: θ̇ at heel strike (before the "
              "compliant impact: the leading leg's rate, negated)", source),
        _spec("phi_dot0", phi_dot0, "rad/s", "initial guess: φ̇ at heel strike (before the impact)",
              source),
    ]


def _leg_specs(variable: bool) -> list[ParameterSpec]:
    base = [s for s in compass_walker_specs() if s.name not in _RIGID_GUESS]
    inf = math.inf
    damper = _spec("alpha", 0.2 if variable else 0.15, "1", "leg damper ratio α of D = 2 α "
                   "sqrt((m_foot + M) K) (the same damper in swing and stance)",
                   (THESIS4 + " (Table 3.1: 0.2 for 6000 -> 8000 N/m)") if variable else
                   (THESIS3 + " (0.15; good range 0.13-0.25)"), 0.0, 1.0, True)
    preload = _spec("preload", 0.0, "N", "leg spring force at zero extension (rest length = "
                    "preload / K); 0: the spring is relaxed at the leg length l (the thesis: "
                    "App. B starts with the suspension joint at 0)", THESIS3, 0.0, inf, True)
    if variable:
        leg = [
            _spec("K1", 6000.0, "N/m", "leg stiffness in swing and before mid-stance", THESIS4,
                  0.0),
            _spec("K2", 8000.0, "N/m", "leg stiffness reached at |φ| = phi_max after mid-stance "
                  "(K = K1 + (K2 - K1)|φ|/phi_max)", THESIS4, 0.0),
            damper,
            _spec("phi_max", PHI_MAX_K1, "rad", "peak |φ| of the constant-K1 gait (measured: "
                  "this walker with K2 = K1)", THESIS4 + "; measured here", 0.0),
            preload,
        ]
        guess = _guess_specs(0.2447, -0.8858, 0.0087, "rough: the period-1 gait of this model, "
                             "rounded")
    else:
        leg = [
            _spec("K_leg", 6000.0, "N/m", "leg spring stiffness (prismatic foot joint)",
                  THESIS3 + " (stable 1500-10000 N/m at α = 0.15)", 0.0),
            damper,
            preload,
        ]
        guess = _guess_specs(0.2489, -0.8642, 0.0203, "rough: the period-1 gait of this model, "
                             "rounded")
    return [*base, *leg, *guess]


class CompliantLegWalker(CompliantWalker):
    """A :class:`~walker_library.compliant.CompliantWalker` whose feet sit on prismatic joints
    with spring–dampers (see the module docstring); the extra section coordinates are the
    leading leg's extension s_lead (m), the trailing foot's contact force (N, standing for
    s_trail: see :meth:`lift`) and the extension rates (m/s). ``stiffness`` names the parameter
    of the stance spring's stiffness before mid-stance (``K_leg`` or ``K1``)."""

    stiffness = "K_leg"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # the trailing leg's extension is replaced by its foot's contact force (see lift)
        i = self.section.index("walker.q.ankle_trail")
        self.section = (*self.section[:i], "trail_contact_force", *self.section[i + 1:])
        self.thesis_section = (*self.thesis_section[:i], "trail_contact_force",
                               *self.thesis_section[i + 1:])
        self._i_trail = i

    def _extension_trail(self, z, p) -> float:
        """s_trail (m) of section state ``z``: the extension that puts the trailing foot's
        contact point F/K into the surface (F = ``trail_contact_force``, K the contact
        stiffness). The penetration grows by cos α_trail per metre of extension."""
        raw = np.array(z, dtype=float)
        raw[self._i_trail] = 0.0
        x = super().lift(raw, p)
        d0 = float(self.outputs(0.0, x, p)[self._out["floor2.z"]])
        return (z[self._i_trail] / self.parameters["K"] - d0) / math.cos(z[1])

    def lift(self, z, p=None):
        """Section coordinates (leg 1 leading) -> model state.

        The trailing leg's section coordinate is not its extension s_trail but the elastic part
        of its foot's normal contact force, F = K·(penetration) (N; negative: the foot is −F/K
        above the surface). With s_trail, a perturbation of 1e-4 m (the Floquet Jacobian's
        step) of either extension would lift the trailing foot off the surface (its static
        penetration is ≈ W/K = 3e-5 m) and the scuffing rule would not let it land again;
        with F, perturbing any other coordinate keeps the trailing foot's contact as it is."""
        p = self._p if p is None else p
        raw = np.array(z, dtype=float)
        raw[self._i_trail] = self._extension_trail(raw, p)
        return super().lift(raw, p)

    def project(self, x, p, lead: int) -> np.ndarray:
        z = super().project(x, p, lead)
        trail = 2 if lead == 1 else 1
        penetration = float(self.outputs(0.0, x, p)[self._out[f"floor{trail}.z"]])
        z[self._i_trail] = self.parameters["K"] * penetration
        return z

    def section_state(self, z):
        d = super().section_state(z)
        d["walker.q.ankle_trail"] = self._extension_trail(np.asarray(z, dtype=float), self._p)
        return d

    @property
    def load_above_spring(self) -> float:
        """Static load on a stance leg's spring in single support, legs normal to the surface:
        the weight of the hip, both legs and the swing foot along the slope normal,
        (M + 2 m_leg + m_foot) g cos γ (N)."""
        P = self.parameters
        return (P["M"] + 2 * P["m_leg"] + P["m_foot"]) * P["g"] * math.cos(P["slope"])

    @property
    def static_compression(self) -> float:
        """Static shortening of the stance leg under :attr:`load_above_spring`: (load −
        preload)/K (m, > 0 shorter than l)."""
        P = self.parameters
        return (self.load_above_spring - P["preload"]) / P[self.stiffness]

    def _guess_extras(self, theta: float) -> np.ndarray:
        """Leading (swing) foot: hanging on its spring, extension (m_foot g cos θ + preload)/K;
        trailing foot: contact force the whole weight (the trailing leg carries it just before
        heel strike); extension rates 0."""
        P = self.parameters
        K = P[self.stiffness]
        s_lead = (P["m_foot"] * P["g"] * math.cos(theta) + P["preload"]) / K
        force = (P["M"] + 2 * P["m_leg"] + 2 * P["m_foot"]) * P["g"]
        return np.array([s_lead, force, 0.0, 0.0])

    def _trail_angle(self, theta: float, extras: np.ndarray) -> float:
        """Both feet on the surface: (l + s_lead) cos θ = (l + s_trail) cos α_trail, the
        trailing leg statically compressed."""
        length = self.parameters["l"]
        s_trail = -self.static_compression * math.cos(theta)
        return math.acos(min(1.0, (length + extras[0]) * math.cos(theta) / (length + s_trail)))

    def _rolling_radius(self) -> float:
        return self.parameters["l"] + self.parameters["R"] - self.static_compression

    #: Newton tolerance of the gait search (m, rad, m/s, rad/s)
    gait_tolerance = 1e-8

    def stand(self, t_end: float = 3.0):
        """The standing check: the walker on leg 1 on a level surface (slope 0), both legs
        along the surface normal (α = 0, an equilibrium by symmetry), foot 1's contact on, foot 2
        hanging (contact off), released from the springs' rest lengths with foot 1 touching the
        surface, and simulated for ``t_end`` s (the stance spring's oscillation, ζ = α, has
        settled by 3 s at the defaults). Returns the :class:`~porthamiltonian.Trajectory`;
        at the end ``walker.q.ankle1`` ≈ −(M + 2 m_leg + m_foot) g / K + preload/K (the stance
        leg's static compression) and ``walker.q.ankle2`` ≈ (m_foot g + preload)/K (the
        hanging foot)."""
        P = self.parameters
        c = self.swing
        x0 = {"walker.q.hip_joint.x": 0.0, "walker.q.hip_joint.z": P["l"] + P["R"] - 1e-9}
        for k in (1, 2):
            x0.update({f"walker.q.leg{k}": 0.0, f"walker.q.ankle{k}": 0.0, f"spring{k}.q": 0.0})
        params = {**{k: v for k, v in self.parameters.items() if k in c.param_names},
                  "slope": 0.0, "c1": 1.0, "c2": 0.0, "ground1": 0.0, "ground2": 0.0}
        o = self.options
        return c.simulate(t_end, x0=x0, params=params, method=o.method, rtol=o.rtol, atol=o.atol,
                          max_step=o.max_step)


def _header(what: str, spring: str, modes: str) -> tuple[str, ...]:
    text = (
        f"The components and events below are the whole walker ({what}): one floating-base "
        "multibody (hip on a translational x/z joint, legs on revolute hip joints, each foot mass "
        "on a prismatic joint ankle1/ankle2 along its leg at the leg's end), one spring-damper "
        f"per leg bonded to that joint's port (spring1, spring2: {spring}), one Hunt-Crossley "
        "contact (floor1, floor2: arc foot, contact point R below the foot centre along the slope "
        "normal, on the plane z = ground1 / ground2) and one SCVS friction (fric1, fric2) per "
        "foot, in the slope frame (gravity rotated by the slope). c1, c2 (contact flags), "
        "ground1, ground2 (surface height under each foot, m: 0, or -h after a step-down of "
        f"h){modes} "
        "are mode parameters that the walker's event actions switch (the scuffing rule); "
        "`porthamiltonian check-energy` simulates the model as written (modes fixed). "
        "[model.walker] names the builder; `walker gait` rebuilds the walker from it and the "
        "[parameters] below. Edit parameter values here; change the mechanism in the builder and "
        "re-export (a file whose components differ is refused). lam = 3.16e7 N*s/m^2 is "
        "calibrated the thesis's way for the rigid-leg walker "
        "(walker_library.compliant.calibrate_damping).")
    return tuple(textwrap.wrap(text, 95, break_on_hyphens=False))


def compliant_leg_model(specs: list[ParameterSpec], contact: str = "HuntCrossley") -> Model:
    doc = ("Thesis compliant-leg walker (MODEL-SPEC.md §3): the nominal walker with each foot on a "
           "prismatic joint along the leg, a linear spring K_leg and a parallel damper "
           "D = 2 alpha sqrt((m_foot + M) K_leg) per leg.")
    m = contact_walker_model("compliant_leg_walker", doc, specs, foot_joint=_prismatic_foot,
                             contact=contact)
    for k in (1, 2):
        m.add(f"spring{k}", SpringDamper(stiffness="K_leg", alpha="alpha", mass="M + m_foot",
                                         rest_length="preload/K_leg", q0=0))
        m.connect(f"walker.ankle{k}", f"spring{k}.p")
    return m


def variable_stiffness_model(specs: list[ParameterSpec], contact: str = "HuntCrossley") -> Model:
    doc = ("Thesis variable-stiffness walker (MODEL-SPEC.md §4, App. D): the compliant-leg walker "
           "with K = K1 + (K2 - K1)|phi|/phi_max on a stance leg after mid-stance (else K1) and "
           "D = 2 alpha sqrt((m_foot + M) K).")
    m = contact_walker_model("variable_stiffness_walker", doc, specs, foot_joint=_prismatic_foot,
                             contact=contact)
    for k in (1, 2):
        m.parameter(f"mid{k}", 0.0, "1", f"mode: leg {k} in stance after mid-stance (its "
                    "stiffness rises; set at mid-stance, cleared at its lift-off)")
    for k in (1, 2):
        m.add(f"spring{k}", VariableSpringDamper(
            stiffness=f"K1 + (K2 - K1)*mid{k}*Abs(walker.q.leg1 - walker.q.leg2)/phi_max",
            alpha="alpha", mass="M + m_foot", rest_length="preload/K1", q0=0))
        m.connect(f"walker.ankle{k}", f"spring{k}.p")
        other = 3 - k
        m.event(f"midstance{k}", f"walker.q.leg{k} - walker.q.leg{other}", direction=1)
    return m


def _options() -> CompliantOptions:
    return CompliantOptions(method="Rodas4", rtol=1e-8, atol=1e-10, max_step=0.01,
                            max_step_time=3.0)


def compliant_leg_walker(*, backend: str = "numba", options: CompliantOptions | None = None,
                         contact: str = "HuntCrossley", **values: float) -> CompliantLegWalker:
    """The thesis's walker with a prismatic compliant leg–foot joint (MODEL-SPEC.md §3), see the
    module docstring. Numba back end and the compiled Rodas4 loop by default. ``contact``: the
    feet's contact law (see :func:`~walker_library.compliant.compass_walker`)."""
    specs = contact_specs(_leg_specs(variable=False), check_contact(contact))
    model = compliant_leg_model(specs, contact)
    return CompliantLegWalker(
        "compliant_leg_walker", {s.name: s for s in specs}, model, values=values, backend=backend,
        options=options or _options(), doc=model.doc, builder="compliant_leg_walker",
        extra_joints=("ankle",), mirrors={f"spring{k}.q": f"walker.q.ankle{k}" for k in (1, 2)},
        file_header=_header("MODEL-SPEC.md §3", "SpringDamper, stiffness K_leg, damper D = 2 alpha "
                            "sqrt((m_foot + M) K_leg), rest length preload/K_leg: relaxed at the "
                            "leg length l by default", ""))


class VariableStiffnessWalker(CompliantLegWalker):
    """:class:`CompliantLegWalker` with the stiffness of MODEL-SPEC.md §4 (K1 before mid-stance)."""

    stiffness = "K1"


def variable_stiffness_walker(*, backend: str = "numba", options: CompliantOptions | None = None,
                              contact: str = "HuntCrossley",
                              **values: float) -> VariableStiffnessWalker:
    """The thesis's variable-stiffness walker (MODEL-SPEC.md §4, App. D), see the module
    docstring. Numba back end and the compiled Rodas4 loop by default. ``contact``: the feet's
    contact law (see :func:`~walker_library.compliant.compass_walker`)."""
    specs = contact_specs(_leg_specs(variable=True), check_contact(contact))
    model = variable_stiffness_model(specs, contact)
    return VariableStiffnessWalker(
        "variable_stiffness_walker", {s.name: s for s in specs}, model, values=values,
        backend=backend, options=options or _options(), doc=model.doc,
        builder="variable_stiffness_walker", extra_joints=("ankle",),
        mirrors={f"spring{k}.q": f"walker.q.ankle{k}" for k in (1, 2)},
        file_header=_header(
            "MODEL-SPEC.md §4", "VariableSpringDamper, K = K1 + (K2 - K1)*mid_k*|phi|/phi_max, "
            "phi = leg1 - leg2, damper D = 2 alpha sqrt((m_foot + M) K) following K; the compiler "
            "books the power 1/2 dK/dt z^2 that the stiffness change injects as supplied energy",
            " and mid1, mid2 (leg k in stance after mid-stance: its stiffness rises; set by the "
            "midstance1/2 events, cleared at the leg's lift-off)"))


def dissipation_breakdown(walker: CompliantWalker, z, n_steps: int = 1) -> list[dict]:
    """Energy dissipated in each step from section state ``z``, by element (J).

    Walks ``n_steps`` (one simulation, ``record=True``) and integrates, over each step, the
    dissipated power of the friction elements (the power into ``fric<k>``: e·f ≥ 0) and of the
    leg dampers (D ṡ² of ``spring<k>``, if the walker has them) with the trapezoidal rule on the
    integrator's steps; the ground contacts' share (Hunt–Crossley damping, and the spring
    energy released in a clipped separation) is the rest of the ledger's P_diss. Per step:
    ``total`` (the ledger's E_diss increment), ``contact``, ``friction``, ``leg_dampers``,
    ``ground`` = contact + friction (what the ground takes: the thesis's "dissipated energy due
    to the impact"), and ``quadrature_error`` = ∫P_diss (trapezoid) − total, the error of the
    split. Steps that fell are left out."""
    strides = walker.walk(np.asarray(z, dtype=float), n_steps, record=True)
    traj = strides[-1].info["trajectory"]
    t, Y = traj.t, traj.outputs
    col = {name: i for i, name in enumerate(walker.swing.output_names)}
    friction = np.zeros(len(t))
    damper = np.zeros(len(t))
    for k in (1, 2):
        friction += sum(Y[:, col[f"fric{k}.p.e{i}"]] * Y[:, col[f"fric{k}.p.f{i}"]] for i in (0, 1))
        if f"spring{k}.D" in col:
            damper += Y[:, col[f"spring{k}.D"]] * Y[:, col[f"spring{k}.p.f"]] ** 2
    total = traj.power[:, 1]
    contact = total - friction - damper
    e_diss = traj.E_diss
    out, i0 = [], 0
    for s in strides:
        if s.fell:
            break
        i1 = int(np.nonzero(t == s.info["t_end"])[0][-1])
        sl = slice(i0, i1 + 1)

        def integral(power, sl=sl):
            return float(np.trapezoid(power[sl], t[sl]))

        row = {"total": float(e_diss[i1] - e_diss[i0]), "contact": integral(contact),
               "friction": integral(friction), "leg_dampers": integral(damper)}
        row["ground"] = row["contact"] + row["friction"]
        row["quadrature_error"] = integral(total) - row["total"]
        out.append(row)
        i0 = i1
    return out
