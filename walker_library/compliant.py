"""The thesis's nominal walker (MODEL-SPEC.md §1): rigid legs, arc feet, Hunt–Crossley contact with
SCVS friction, the scuffing rule, on a slope. No impact map: the heel strike is resolved by the
compliant contact, and the whole stride is one simulation of one floating-base multibody model.

Model (built from framework components only; :func:`compass_walker` is the builder)
------------------------------------------------------------------------------------
* Slope frame: x down the slope, z along the slope normal; gravity g (sin γ, 0, −cos γ); the
  surface under foot k is the plane z = ground<k> of that frame (``surface = "plane"``,
  ``height = "ground<k>"``; 0, or −h after a step-down of h), so its normal is the slope normal
  exactly. The contact gap of foot k is (foot centre z) − R − ground<k>.
* ``walker`` (:class:`~porthamiltonian.Multibody`, plane xz): the hip (point mass M) on a
  translational x/z joint ``hip_joint`` from the world; legs ``leg1``, ``leg2`` (mass m_leg at
  mid-leg, no inertia) on revolute joints about y at the hip, absolute angles α (α = 0: leg along
  −z; a foot in front of the hip has α < 0); a foot body (point mass m_foot) welded at each
  leg's end (joint ``ankle<k>``), the foot centre (leg length l is hip to foot centre). The
  points ``foot<k>`` (centre) and ``sole<k>`` belong to the foot body, so a walker that carries
  the foot on another joint (:mod:`walker_library.compliant_legs`: a prismatic joint with a
  spring) moves them with it (:func:`contact_walker_model` takes the foot joint).
* Arc foot, contact point convention: **offset along the surface normal** (MODEL-SPEC.md §1 "Arc
  foot", the geometrically consistent choice): the contact ``floor<k>`` (HuntCrossley, n, K, λ)
  is bonded to the foot centre ``foot<k>`` and reads the contact point x = c_x, z = c_z − R, so
  its penetration is R − (height of the centre), exact for a circle, with rate −ċ_z: the port
  flow (the ledger closes). The normal force passes through the foot centre (a circle's normal
  force has no moment about its centre).
* Friction ``fric<k>`` (SCVSFriction, normal force ``floor<k>.Fn``) acts at the foot's material
  point ``sole<k>``, R beyond the foot centre along the leg axis: the foot's material point that
  is the contact point when the leg is normal to the slope. Its tangential velocity is
  ċ_x + ω R cos α: the rolling foot's material-point velocity ċ_x + ω R (the thesis's choice:
  the foot body's twist at the contact point) up to the factor cos α (≥ 0.97 for |α| < 0.25 rad on
  this gait). A bond at the exact rolling contact point would need a point port whose body-frame
  position depends on the joint angle, which Multibody does not offer (a possible core feature).
* Mode flags ``c1``, ``c2`` (parameters, 0/1) multiply each contact (``active``); event actions
  implement the scuffing rule: a contact starts when the foot centre's penetration crosses 0
  upward (guard ``floor<k>.z``) *and* the foot is in front of the other foot; it ends when the foot
  rises ``liftoff_margin`` above the surface (guard ``floor<k>.z + liftoff_margin``). Both
  switches happen where the stored contact energy is zero, so H is continuous.
* Step-down (``walk(..., ground_drop=h)``, MODEL-SPEC.md §5): the surface heights ``ground1``,
  ``ground2`` are mode parameters too. A walk starts with the leading foot 1 on ground1 = 0; the
  trailing foot's surface becomes −h when its contact goes off (at the start if it starts in the
  air, else at its lift-off), and so does every later lift-off's: the surface drops once, ahead
  of the stance foot, before the first heel strike, and stays down. A surface moved under a foot
  whose contact is off does not change H, so the ledger stays closed.

Poincaré section (heel strike)
------------------------------
The thesis's section φ − 2θ = 0 "with equal penetration" is not a state-space surface of the
compliant model (the stance foot penetrates at heel strike). Here the section is the touchdown
of the leading foot: the instant its contact starts by the scuffing rule (penetration 0, rising,
foot in front). On the section the along-slope position is cyclic and the leading foot's
penetration is 0, so the state is fixed by six coordinates: z = (α_lead, α_trail, ẋ_hip, ż_hip,
ω_lead, ω_trail) (the hip height is l cos α_lead + R; :meth:`CompliantWalker.lift` computes it
from the model's kinematics, so walkers with more joints per leg reuse it). Thesis coordinates
(same six, linear):
(θ, φ, ẋ_hip, ż_hip, θ̇, φ̇) with θ = −α_lead (stance = the leading leg, θ > 0), φ = α_trail −
α_lead, θ̇ = −ω_lead, φ̇ = ω_trail − ω_lead, as :mod:`walker_library.rigid` does.

The section state is the state at touchdown, *before* the compliant impact (the impact takes
the first ≈ 10 ms of the stride); ``fixed_point`` of ``walker gait`` is that state. The leading
foot starts a stride 1e-9 m inside the surface (off its guard's zero); the trailing foot's contact
starts on unless the state puts it above the lift-off level. A bounce of the leading foot (its
contact ends and restarts) is not a new step: a step is the touchdown of the *other* foot.

Fall: the hip lower than ``fall_fraction`` l above the surface, or no heel strike within
``max_step_time``.

Contact damping λ (lost in the thesis): :func:`calibrate_damping` does it the thesis's way (the
smallest λ that maximises the energy dissipated per impact): from the gait's heel-strike state,
the dissipation over the impact window rises from 0.0036 J at λ = 1e5 (the foot bounces) to a
plateau of 0.0927 J from λ ≈ 3e7 on (max 0.09269 J at 1.8e9; within 0.1 % from 3.16e7), so
λ = 3.16e7 N·s/m² (App. A's garbled "Kd = e7" is of that order).

Measured at γ = 0.009 (λ = 3.16e7; tests/walkers/test_compass_walker.py): stable period-1 gait,
step period 1.008 s, step length 0.307 m, speed 0.305 m/s (thesis 0.274), 0.0874 J dissipated
per step (thesis 0.08) = the potential released (cost of transport = sin γ), Floquet multipliers
−0.093 ± 0.262i (|λ| = 0.278) and four below 2e-4 (perturbation 1e-4; error estimate 4e-4).

Step-down: from the fixed point, a drop of 1 mm is survived (back on the fixed point within
1e-7 after 20 steps, ledger residual 5e-8 J), a drop of 5 cm is a fall in the second step.

Integration: numba back end and the compiled Rodas4 loop (≈ 0.04–0.1 s per step once compiled,
depending on the machine's load; the compilation, ≈ 30 s, is cached on disk); the python back
end is ≈ 100× slower on this stiff model.
"""
from __future__ import annotations

import math
import textwrap
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from porthamiltonian import Model, Multibody, Reset, Revolute, RigidBody, Translational, Weld
from porthamiltonian.errors import ParameterValueError
from porthamiltonian.library import HuntCrossley, KelvinVoigt, SCVSFriction

from .protocol import ParameterSpec, Stride, check_parameters
from .results import JSONResult
from .rigid import _compiled

__all__ = ["CONTACT_KINDS", "CONTACT_MODES", "CompliantWalker", "CompliantOptions", "DampingCalibration",
           "calibrate_damping", "compass_walker", "compass_walker_specs", "contact_specs",
           "contact_walker_model"]

THESIS = "MODEL-SPEC.md §1 (thesis Table 2.3, App. A)"
_GRAVITY = ["g*sin(slope)", 0, "-g*cos(slope)"]
#: mode parameters set by the walker's event actions, not by the user (``load_walker`` skips
#: them in a model file): contact flags, surface height under each foot (step-down), mid-stance
#: flags (the variable-stiffness walker of :mod:`walker_library.compliant_legs`)
CONTACT_MODES = ("c1", "c2", "ground1", "ground2", "mid1", "mid2")
#: the leading foot starts a stride this far inside the surface (m), off its touchdown guard's
#: zero (a run that starts on a guard's zero sees it fire at t = 0); force K·1e-9 = 1e-3 N
START_PENETRATION = 1e-9
#: the contact laws a compliant walker can use (``contact = ...`` in its ``[model.walker]``
#: table, the builders' ``contact`` argument); the first is the default (the thesis's)
CONTACT_KINDS = ("HuntCrossley", "KelvinVoigt")
#: Kelvin–Voigt damping B (N·s/m) of the walkers with ``contact = "KelvinVoigt"``: calibrated the
#: thesis's way, as λ is (:func:`calibrate_damping` with ``parameter="B_contact"``; see
#: :func:`contact_specs`)
B_CONTACT = 1.0e3


@dataclass(frozen=True)
class CompliantOptions:
    """Integrator settings: ``method`` (a porthamiltonian.simulate method), ``rtol``, ``atol``,
    ``max_step`` (s), ``max_step_time`` (s: no heel strike within it is a fall)."""

    method: str = "Radau"
    rtol: float = 1e-8
    atol: float = 1e-10
    max_step: float = 0.02
    max_step_time: float = 3.0


def _spec(name, value, unit, doc, source="", low=-math.inf, high=math.inf, low_inclusive=False):
    return ParameterSpec(name, float(value), unit, doc, source, low, high, low_inclusive)


def compass_walker_specs() -> list[ParameterSpec]:
    inf = math.inf
    return [
        _spec("slope", 0.009, "rad", "slope angle γ", THESIS + " §2.7", -0.2, 0.2),
        _spec("M", 3.0, "kg", "hip mass", THESIS, 0.0),
        _spec("m_leg", 0.01, "kg", "mass of each leg (at mid-leg)", THESIS, 0.0, inf, True),
        _spec("m_foot", 0.1, "kg", "mass of each foot, at the leg's end", THESIS, 0.0),
        _spec("l", 0.7, "m", "leg length, hip to foot centre", THESIS, 0.0),
        _spec("R", 0.05, "m", "arc-foot radius", THESIS, 0.0),
        _spec("g", 9.81, "m/s^2", "acceleration of gravity", "", 0.0),
        _spec("K", 1.0e6, "N/m", "contact stiffness (App. A Kp = 1.0e6)", THESIS, 0.0),
        _spec("lam", 3.16e7, "N*s/m^2", "Hunt-Crossley damping λ (lost in the thesis; calibrated "
              "the thesis's way, see walker_library.calibration)", "calibrated", 0.0, inf, True),
        _spec("mu_st", 0.5, "1", "SCVS static friction", THESIS, 0.0, inf, True),
        _spec("mu_c", 0.25, "1", "SCVS Coulomb friction", THESIS, 0.0, inf, True),
        _spec("mu_v", 0.025, "s/m", "SCVS viscous friction", THESIS, 0.0, inf, True),
        _spec("s_fric", 500.0, "s/m", "SCVS tanh slope (20-sim 'slope')", THESIS, 0.0, inf, True),
        _spec("v_st", 0.02, "m/s", "SCVS Stribeck velocity", THESIS, 0.0),
        _spec("liftoff_margin", 1e-6, "m", "a contact ends when the foot rises this far above the "
              "surface (hysteresis against chatter)", "numerical", 0.0, 1e-3, True),
        _spec("front_margin", 0.01, "m", "scuffing rule: a touchdown starts a contact only when the "
              "foot is at least this far in front of the other foot (the swing foot enters the "
              "surface exactly beside the stance foot at mid-stance)", "numerical", 0.0, 1.0, True),
        _spec("fall_fraction", 0.5, "1", "fallen when the hip is lower than this fraction of l "
              "above the surface", "numerical", 0.0, 1.0),
        _spec("theta0", 0.2064, "rad", "initial guess: θ at heel strike (φ = 2θ)",
              "rough: the period-1 gait of this model, rounded", 0.0, math.pi / 2),
        _spec("theta_dot0", -0.8254, "rad/s", "initial guess: θ̇ at heel strike (before the "
              "compliant impact: the leading leg's rate, negated)", "rough, as theta0"),
        _spec("phi_dot0", 0.0023, "rad/s", "initial guess: φ̇ at heel strike (before the impact)",
              "rough, as theta0"),
    ]


def check_contact(contact: str) -> str:
    """``contact`` if it is one of :data:`CONTACT_KINDS`, else ParameterValueError."""
    if not (isinstance(contact, str) and contact in CONTACT_KINDS):
        raise ParameterValueError(f"unknown contact kind {contact!r}; contact kinds: "
                                  f"{', '.join(CONTACT_KINDS)} (default {CONTACT_KINDS[0]})")
    return contact


def contact_specs(specs: list[ParameterSpec], contact: str) -> list[ParameterSpec]:
    """``specs`` (a compliant walker's parameters, with the Hunt–Crossley damping ``lam``) for
    the contact law ``contact``: unchanged for HuntCrossley; for KelvinVoigt, the linear damping
    ``B_contact`` (N·s/m) is added after ``lam`` (which that walker keeps but does not use, so
    a walker file's parameters stay valid when its contact is swapped).

    B_contact = 1e3 N·s/m is calibrated the thesis's way (the smallest damping that maximises the
    energy dissipated per impact: :func:`calibrate_damping` with ``parameter="B_contact"`` from
    compass_walker's initial guess, K = 1e6 N/m, window 0.05 s, grid 1e2 … 1e6 four per decade):
    the dissipation rises from 0.0165 J at B = 100 (the foot bounces) through 0.0830 J at 562 to
    a plateau of 0.0939 J from B = 1e3 on (0.093919 J; the grid's maximum is 0.093941 J at
    3.16e4, then it falls slowly to 0.093578 J at 1e6). The Hunt–Crossley walker's λ = 3.16e7
    dissipates 0.093973 J from the same state."""
    check_contact(contact)
    if contact == "HuntCrossley":
        return list(specs)
    out = []
    for s in specs:
        out.append(s)
        if s.name == "lam":
            out.append(_spec("B_contact", B_CONTACT, "N*s/m", "Kelvin-Voigt contact damping B "
                             "(contact = \"KelvinVoigt\" only; calibrated the thesis's way, see "
                             "walker_library.compliant.contact_specs)", "calibrated", 0.0,
                             math.inf, True))
    if len(out) == len(specs):
        raise ParameterValueError("a compliant walker's parameters need 'lam' to add 'B_contact'")
    return out


def contact_walker_model(name: str, doc: str, specs: list[ParameterSpec], *,
                         foot_joint: Callable[[int], Any] | None = None,
                         contact: str = "HuntCrossley") -> Model:
    """The floating-base walker with arc feet, Hunt–Crossley contacts and SCVS friction (see the
    module docstring), shared by every compliant-contact walker.

    ``foot_joint(k)`` gives the joint record that carries foot body ``foot<k>_body`` on leg k
    (default: a weld at the leg's end, the rigid leg; :mod:`walker_library.compliant_legs`
    passes a prismatic joint along the leg). The contact point ``foot<k>`` and the friction
    point ``sole<k>`` sit on the foot body, so they move with it. Mode parameters (set by the
    walker's event actions, :data:`CONTACT_MODES`): ``c1``, ``c2`` and the surface heights
    ``ground1``, ``ground2``.

    ``contact`` (one of :data:`CONTACT_KINDS`) is the law of both feet's contacts ``floor1``,
    ``floor2``: HuntCrossley (stiffness K, damping ``lam``, n = 1) or KelvinVoigt (stiffness K,
    damping ``B_contact``, clipped at F >= 0; ``specs`` from :func:`contact_specs`); same ports,
    point and surface, so the rest of the model does not change."""
    check_contact(contact)
    if contact == "KelvinVoigt" and not any(s.name == "B_contact" for s in specs):
        raise ParameterValueError(f"{name}: contact = 'KelvinVoigt' needs the parameter "
                                  "'B_contact' (build the specs with contact_specs)")
    m = Model(name, doc)
    for s in specs:
        m.parameter(s.name, s.value, s.unit, f"{s.doc} [{s.source}]" if s.source else s.doc)
    for k, on in ((1, 1.0), (2, 0.0)):
        m.parameter(f"c{k}", on, "1",
                    f"mode: contact of foot {k} active (set by the scuffing rule)")
    for k in (1, 2):
        m.parameter(f"ground{k}", 0.0, "m", f"mode: height of the surface under foot {k} along the "
                    "slope normal (0; -h after a step-down of h, set at the foot's lift-off)")
    bodies = {"hip_body": RigidBody(mass="M", points={"hip_centre": [0, 0, 0]})}
    joints = {"hip_joint": Translational(parent="world", child="hip_body", axes=("x", "z"),
                                         q0=[0, "l*cos(theta0) + R"], v0=[0, 0])}
    for k, q0 in ((1, "-theta0"), (2, "theta0")):
        bodies[f"leg{k}"] = RigidBody(mass="m_leg", com=[0, 0, "-l/2"])
        joints[f"leg{k}"] = Revolute(parent="hip_body", child=f"leg{k}", axis="y", q0=q0)
        bodies[f"foot{k}_body"] = RigidBody(mass="m_foot", points={f"foot{k}": [0, 0, 0],
                                                                   f"sole{k}": [0, 0, "-R"]})
        joints[f"ankle{k}"] = (foot_joint(k) if foot_joint is not None else
                               Weld(parent=f"leg{k}", child=f"foot{k}_body", origin=[0, 0, "-l"]))
    m.add("walker", Multibody(bodies=bodies, joints=joints, gravity=_GRAVITY, plane="xz"))
    for k in (1, 2):
        point = {"x": f"walker.foot{k}.x", "z": f"walker.foot{k}.z - R", "stiffness": "K"}
        where = {"surface": "plane", "height": f"ground{k}", "active": f"c{k}"}
        m.add(f"floor{k}", HuntCrossley(**point, damping="lam", exponent=1, **where)
              if contact == "HuntCrossley" else
              KelvinVoigt(**point, damping="B_contact", **where))
        m.add(f"fric{k}", SCVSFriction(normal_force=f"floor{k}.Fn", mu_st="mu_st", mu_c="mu_c",
                                       mu_v="mu_v", slope="s_fric", v_st="v_st"))
        m.connect(f"walker.foot{k}", f"floor{k}.p")
        m.connect(f"walker.sole{k}", f"fric{k}.p")
        m.event(f"touchdown{k}", f"floor{k}.z", direction=1)
        m.event(f"liftoff{k}", f"floor{k}.z + liftoff_margin", direction=-1)
    m.event("fall", "walker.q.hip_joint.z - fall_fraction*l", direction=-1)
    m.simulation = {"t_end": 1.0, "method": "Radau", "rtol": 1e-8, "atol": 1e-10,
                    "energy_tolerance": 1e-6}
    return m


def compass_walker_model(specs: list[ParameterSpec], contact: str = "HuntCrossley") -> Model:
    law = "Hunt-Crossley" if contact == "HuntCrossley" else "Kelvin-Voigt"
    doc = ("Thesis nominal walker (MODEL-SPEC.md §1): rigid legs, arc feet (normal offset), "
           f"{law} contact + SCVS friction per foot, scuffing rule, on a slope.")
    return contact_walker_model("compass_walker", doc, specs, contact=contact)


class CompliantWalker:
    """A two-legged walker with compliant contacts (the :class:`~.protocol.Walker` interface).

    One floating-base model (see the module docstring); a stride runs from one leading-foot
    touchdown to the next, both contacts active at the start (the trailing foot still in stance;
    its contact starts off when a perturbed state puts it above the lift-off level).
    Leg 1 leads at the start of every :meth:`walk`; the legs alternate.

    Extensions (for :mod:`walker_library.compliant_legs`): ``extra_joints`` names per-leg joint
    families beyond the hip's revolute joints (``("ankle",)``: joints ``ankle1``, ``ankle2`` with
    a coordinate each); their coordinates and rates become extra section coordinates,
    ``walker.q.<family>_lead``, ``walker.q.<family>_trail`` then ``walker.v.<family>_lead``,
    ``walker.v.<family>_trail``, after the six of the rigid-leg walker (the thesis's names:
    ``<family>_lead``, ``<family>_trail``, ``<family>_lead_dot``, ``<family>_trail_dot``,
    unchanged). ``mirrors`` maps a state that integrates a joint's velocity (a spring's length
    on a joint port) to that joint coordinate (``{"spring1.q": "walker.q.ankle1"}``): a lifted
    section state sets it equal to the joint coordinate. A model with the events
    ``midstance1``/``midstance2`` and mode parameters ``mid1``/``mid2`` gets the mid-stance
    actions of the variable-stiffness walker (see :meth:`walk`).
    """

    legged = True
    _base_section = ("walker.q.lead", "walker.q.trail", "walker.v.hip_joint.x",
                     "walker.v.hip_joint.z", "walker.v.lead", "walker.v.trail")
    _base_thesis = ("theta", "phi", "hip_vx", "hip_vz", "theta_dot", "phi_dot")

    def __init__(self, name, specs, model, *, values=None, backend="numba", options=None, doc="",
                 builder="", extra_joints: tuple[str, ...] = (), mirrors: dict | None = None,
                 file_header: tuple[str, ...] | None = None):
        self.name, self.doc, self.builder = name, doc, builder
        self.specs = specs
        self.swing_model = model
        self.backend = backend
        self.options = options or CompliantOptions()
        self.extra_joints = tuple(extra_joints)
        self.mirrors = dict(mirrors or {})
        if file_header is not None:
            self.file_header = tuple(file_header)
        ends = ("lead", "trail")
        fams = self.extra_joints
        self.section = self._base_section + tuple(
            f"walker.{qv}.{fam}_{end}" for qv in ("q", "v") for fam in fams for end in ends)
        self.thesis_section = self._base_thesis + tuple(
            f"{fam}_{end}{dot}" for dot in ("", "_dot") for fam in fams for end in ends)
        self.parameters = check_parameters(specs, dict(values or {}))
        self.swing = _compiled(model, backend)
        self._setup()

    @property
    def contact(self) -> str:
        """The contact law of the feet (one of :data:`CONTACT_KINDS`): the kind of ``floor1``."""
        return self.swing_model.component("floor1").kind

    @property
    def builder_options(self) -> dict[str, Any]:
        """The builder's options that made this walker (``[model.walker]`` of its model file,
        beside ``builder``): ``{"contact": kind}``."""
        return {"contact": self.contact}

    def _setup(self):
        c = self.swing
        self._p = c.params({k: v for k, v in self.parameters.items() if k in c.param_names})
        self._out = {name: i for i, name in enumerate(c.output_names)}
        # joint coordinates in the multibody's order (the order of the mass matrix's rows)
        self._coords = [s[len("walker.q."):] for s in c.state_names if s.startswith("walker.q.")]
        self._iq = [c.state_names.index(f"walker.q.{j}") for j in self._coords]
        self._ip = [c.state_names.index(f"walker.p.{j}") for j in self._coords]
        self._col = {j: i for i, j in enumerate(self._coords)}
        self._ihz = c.state_names.index("walker.q.hip_joint.z")
        self._mirror_idx = [(c.state_names.index(dst), c.state_names.index(src))
                            for dst, src in self.mirrors.items()]
        self._imode = {name: c.param_names.index(name) for name in CONTACT_MODES
                       if name in c.param_names}
        self._ic = {k: self._imode[f"c{k}"] for k in (1, 2)}
        events = {e.name for e in c.events}
        self._midstance = all(f"midstance{k}" in events and f"mid{k}" in self._imode
                              for k in (1, 2))

    def with_parameters(self, **values):
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.parameters = check_parameters(self.specs, {**self.parameters, **values})
        new._setup()
        return new

    # --- properties -------------------------------------------------------------------------------
    @property
    def total_mass(self) -> float:
        P = self.parameters
        return P["M"] + 2 * (P["m_leg"] + P["m_foot"])

    @property
    def weight(self) -> float:
        return self.total_mass * self.parameters["g"]

    @property
    def leg_length(self) -> float:
        return self.parameters["l"]

    # --- kinematics -------------------------------------------------------------------------------
    def _mass_matrix(self, x, p):
        return self.swing.matrix("walker.M", 0.0, x, p)

    def outputs(self, t, x, p):
        y = self.swing.augment(x) if len(x) == self.swing.n_states else x
        return np.asarray(self.swing.functions.outputs(t, y, self.swing.native_params(p)))

    def _joint_values(self, z) -> tuple[dict, dict]:
        """Section coordinates (leg 1 leading) -> joint coordinates and velocities by joint name
        (the hip height left at 0)."""
        z = [float(a) for a in z]
        a_lead, a_trail, vx, vz, w_lead, w_trail = z[:6]
        q = {"hip_joint.x": 0.0, "hip_joint.z": 0.0, "leg1": a_lead, "leg2": a_trail}
        v = {"hip_joint.x": vx, "hip_joint.z": vz, "leg1": w_lead, "leg2": w_trail}
        n = 2 * len(self.extra_joints)
        for i, fam in enumerate(self.extra_joints):
            q[f"{fam}1"], q[f"{fam}2"] = z[6 + 2 * i], z[7 + 2 * i]
            v[f"{fam}1"], v[f"{fam}2"] = z[6 + n + 2 * i], z[7 + n + 2 * i]
        return q, v

    def lift(self, z, p=None):
        """Section coordinates (leg 1 leading) -> model state: the hip at the height that puts
        foot 1's contact point ``START_PENETRATION`` into the surface z = 0 (ground1 = 0)."""
        p = self._p if p is None else p
        if len(z) != len(self.section):
            raise ValueError(f"{self.name}: a section state has {len(self.section)} coordinates "
                             f"({', '.join(self.section)}), got {len(z)}")
        q, v = self._joint_values(z)
        x = np.zeros(self.swing.n_states)
        x[self._iq] = [q[j] for j in self._coords]
        for dst, src in self._mirror_idx:
            x[dst] = x[src]
        foot_z = float(self.outputs(0.0, x, p)[self._out["walker.foot1.z"]])   # hip at 0
        x[self._ihz] = self.parameters["R"] - START_PENETRATION - foot_z
        x[self._ip] = self._mass_matrix(x, p) @ np.array([v[j] for j in self._coords])
        return x

    def project(self, x, p, lead: int) -> np.ndarray:
        """Model state -> section coordinates, leg ``lead`` leading."""
        q = x[self._iq]
        v = np.linalg.solve(self._mass_matrix(x, p), x[self._ip])
        c = self._col
        L, T = (1, 2) if lead == 1 else (2, 1)
        z = [q[c[f"leg{L}"]], q[c[f"leg{T}"]], v[c["hip_joint.x"]], v[c["hip_joint.z"]],
             v[c[f"leg{L}"]], v[c[f"leg{T}"]]]
        for vec in (q, v):
            for fam in self.extra_joints:
                z += [vec[c[f"{fam}{L}"]], vec[c[f"{fam}{T}"]]]
        return np.array(z, dtype=float)

    def to_thesis(self, z):
        z = np.asarray(z, dtype=float)
        a_lead, a_trail, vx, vz, w_lead, w_trail = z[:6]
        return np.concatenate([[-a_lead, a_trail - a_lead, vx, vz, -w_lead, w_trail - w_lead],
                               z[6:]])

    def from_thesis(self, w):
        w = np.asarray(w, dtype=float)
        theta, phi, vx, vz, theta_dot, phi_dot = w[:6]
        return np.concatenate([[-theta, phi - theta, vx, vz, -theta_dot, phi_dot - theta_dot],
                               w[6:]])

    def section_state(self, z):
        z = np.asarray(z, dtype=float)
        th = self.to_thesis(z)
        d = dict(zip(self.section, (float(v) for v in z)))
        d.update({"walker.q.hip_joint.z": float(self.lift(z)[self._ihz]) + START_PENETRATION,
                  "theta": float(th[0]), "phi": float(th[1]), "theta_dot": float(th[4]),
                  "phi_dot": float(th[5]), "hip_speed": float(math.hypot(z[2], z[3]))})
        return d

    def _guess_extras(self, theta: float) -> np.ndarray:
        """Section coordinates of the extra joints for the initial guess (none here)."""
        return np.zeros(4 * len(self.extra_joints))

    def _rolling_radius(self) -> float:
        """Distance from the hip to the trailing foot's contact point at heel strike (m)."""
        return self.parameters["l"] + self.parameters["R"]

    def initial_guess(self):
        """The section state (just before the compliant impact) with θ = theta0, φ = θ + the
        trailing angle of :meth:`_trail_angle` (2θ for rigid legs), θ̇ = theta_dot0,
        φ̇ = phi_dot0 and the hip velocity of the trailing leg rolling on its arc foot
        (instantaneous centre at the contact point, :meth:`_rolling_radius` below the hip along
        the leg); extra joints from :meth:`_guess_extras`."""
        P = self.parameters
        return self.section_from(P["theta0"], P["theta_dot0"], P["phi_dot0"])

    def basin_state(self, z_star, theta: float, theta_dot: float) -> np.ndarray:
        """Section state for a basin-of-attraction grid point (:mod:`~.robustness`): thesis θ and
        θ̇ given, φ̇ from the fixed point ``z_star``, the rest completed as :meth:`initial_guess`
        does (trailing foot rolling, both feet at the surface)."""
        phi_dot = float(self.to_thesis(np.asarray(z_star, dtype=float))[5])
        return self.section_from(theta, theta_dot, phi_dot)

    def section_from(self, th: float, thd: float, phd: float) -> np.ndarray:
        """Section state from thesis θ, θ̇, φ̇ at touchdown (see :meth:`initial_guess`)."""
        extras = self._guess_extras(th)
        w_trail = phd - thd
        a_trail = self._trail_angle(th, extras)
        r = self._rolling_radius()
        vx, vz = r * w_trail * math.cos(a_trail), -r * w_trail * math.sin(a_trail)
        return self.from_thesis(np.concatenate([[th, th + a_trail, vx, vz, thd, phd], extras]))

    def _trail_angle(self, theta: float, extras: np.ndarray) -> float:
        """Trailing leg's angle at heel strike for the initial guess (rad): θ (equal legs, both
        feet on the surface: φ = 2θ)."""
        return theta

    #: the explanation written at the top of the walker's model file (``walker export``)
    file_header = tuple(textwrap.wrap(
        "The components and events below are the whole walker: one floating-base multibody (hip "
        "on a translational x/z joint, legs on revolute hip joints, foot masses welded at the leg "
        "ends), one Hunt-Crossley contact (floor1, floor2: arc foot, contact point R below the "
        "foot centre along the slope normal, on the plane z = ground1 / ground2) and one SCVS "
        "friction (fric1, fric2) per foot, in the slope frame (gravity rotated by the slope). "
        "c1, c2 (contact flags) and ground1, ground2 (surface height under each foot, m: 0, or "
        "-h after a step-down of h) are mode parameters that the walker's event actions switch "
        "(the scuffing rule; the step-down lowers a foot's surface at its lift-off); "
        "`porthamiltonian check-energy` simulates the model as written (modes fixed). "
        "[model.walker] names the builder; `walker gait compass_walker` rebuilds the walker from "
        "it and the [parameters] below. Edit parameter values here; change the mechanism in the "
        "builder and re-export (a file whose components differ is refused). lam = 3.16e7 "
        "N*s/m^2 is calibrated the thesis's way (walker_library.compliant.calibrate_damping).",
        95, break_on_hyphens=False))

    #: Newton tolerance of the gait search (the stride map is computed to ≈ 1e-9 by the
    #: integrator at rtol 1e-8; a tolerance of 1e-10 is out of reach)
    gait_tolerance = 1e-8

    # --- strides ----------------------------------------------------------------------------------
    def stride(self, z, *, details=False, record=False):
        return self.walk(z, 1, details=details, record=record)[0]

    def walk(self, z, n_steps, *, details=False, record=False, ground_drop=0.0):
        """``n_steps`` strides from section state ``z`` in one simulation (one energy ledger).

        Modes: at the start both contacts are on (the trailing foot's off if it starts above
        the lift-off level), foot 1 (leading) on ground1 = 0. ``ground_drop`` h (m, >= 0): the
        surface under a foot is set to −h whenever that foot's contact is off: the trailing
        foot's at the start if it starts in the air, else at its lift-off, and every later
        lift-off (a lift-off of the leading foot is a bounce and keeps its surface). A switch
        of surface height with the contact off does not change H, so the ledger stays closed.
        Mid-stance flags (models with events ``midstance<k>``, thesis App. D): ``mid<k>`` is set
        when the hip angle crosses zero with leg k in stance (its contact on) and cleared at
        leg k's lift-off; at the start, mid1 = 0 and mid2 = c2. The action returns
        ``energy="supplied"``: a stiffness that depends on ``mid<k>`` jumps at the lift-off
        while the spring is (slightly) loaded, and the jump of H is work of the stiffness
        actuator (MODEL-SPEC.md §4)."""
        if not (math.isfinite(ground_drop) and ground_drop >= 0.0):
            raise ParameterValueError(
                f"ground_drop = {ground_drop!r} must be a finite height >= 0 (m)")
        low = -float(ground_drop)
        z = np.asarray(z, dtype=float)
        im = self._imode
        p0 = self._p.copy()
        p0[im["c1"]] = p0[im["c2"]] = 1.0
        p0[im["ground1"]] = p0[im["ground2"]] = 0.0
        if self._midstance:
            p0[im["mid1"]], p0[im["mid2"]] = 0.0, 1.0
        try:
            x0 = self.lift(z, p0)
        except (np.linalg.LinAlgError, ValueError) as err:
            return [Stride("fell", None, 0.0, reason=f"invalid_state: {err}")]
        if not np.all(np.isfinite(x0)):
            return [Stride("fell", None, 0.0, reason="invalid_state")]
        out = self._out
        # the trailing foot is in contact at the start only if it is not above the lift-off level
        # (a perturbed section state may start it in the air: then its contact is off, as if it
        # had lifted off, and the scuffing rule applies to it)
        if not self.outputs(0.0, x0, p0)[out["floor2.z"]] + self.parameters["liftoff_margin"] > 0:
            p0[im["c2"]] = 0.0
            p0[im["ground2"]] = low
            if self._midstance:
                p0[im["mid2"]] = 0.0
        log: list[dict] = []
        state = {"steps": 0, "lead": 1,
                 "foot_x": float(self.outputs(0.0, x0, p0)[out["walker.foot1.x"]])}

        def touchdown(k):
            other = 3 - k

            def action(t, x, p):
                if p[self._ic[k]] != 0.0:
                    return Reset()
                if k == state["lead"]:                # the leading foot bounced: it restarts its
                    return Reset(params={f"c{k}": 1.0})   # contact, no new step
                y = self.outputs(t, x, p)
                if not (y[out[f"walker.foot{k}.x"]] - y[out[f"walker.foot{other}.x"]]
                        > self.parameters["front_margin"]):
                    return Reset()            # scuffing: the foot behind passes through
                fx = float(y[out[f"walker.foot{k}.x"]])
                log.append({"t": t, "lead": k, "x": x.copy(), "p": p.copy(),
                            "step_length": fx - state["foot_x"]})
                state["foot_x"] = fx
                state["lead"] = k
                state["steps"] += 1
                return Reset(params={f"c{k}": 1.0}, stop=state["steps"] >= n_steps)
            return action

        def liftoff(k):
            def action(t, x, p):
                if p[self._ic[k]] == 0.0:
                    return Reset()
                modes = {f"c{k}": 0.0}
                if k != state["lead"]:                # not a bounce of the stance foot
                    modes[f"ground{k}"] = low
                if self._midstance:
                    modes[f"mid{k}"] = 0.0
                return Reset(params=modes, energy="supplied")
            return action

        def midstance(k):
            def action(t, x, p):
                return Reset(params={f"mid{k}": 1.0}) if p[self._ic[k]] != 0.0 else Reset()
            return action

        actions = {"touchdown1": touchdown(1), "touchdown2": touchdown(2),
                   "liftoff1": liftoff(1), "liftoff2": liftoff(2),
                   "fall": lambda t, x, p: Reset(stop=True)}
        if self._midstance:
            actions.update({"midstance1": midstance(1), "midstance2": midstance(2)})
        opts = self.options
        names = dict(zip(self.swing.param_names, p0))
        traj = self.swing.simulate(
            opts.max_step_time * n_steps, x0=x0, params=names, method=opts.method,
            rtol=opts.rtol, atol=opts.atol, max_step=opts.max_step, actions=actions,
            max_events=100 * n_steps + 100)
        return self._strides(traj, log, details, record, n_steps)

    def _strides(self, traj, log, details, record, n_steps):
        t, Y = traj.t, traj.y
        params = np.concatenate([np.repeat(seg.p[None, :], len(seg.t), axis=0)
                                 for seg in traj.segments])
        n = self.swing.n_states
        iV = self._out["walker.V"]
        i1, i2 = (self._iq[self._col[f"leg{k}"]] for k in (1, 2))

        def at(i):
            pn = self.swing.native_params(params[i])
            y = np.ascontiguousarray(Y[:, i])
            H = float(self.swing.functions.energy(t[i], y, pn)[0])
            V = float(self.swing.functions.outputs(t[i], y, pn)[iV])
            return H, V, float(Y[n, i]), float(Y[n + 1, i])

        def maxima(i0, i1_, lead):
            a1, a2 = Y[i1, i0:i1_ + 1], Y[i2, i0:i1_ + 1]
            a_lead, a_trail = (a1, a2) if lead == 1 else (a2, a1)
            return float(np.max(np.abs(a_lead))), float(np.max(np.abs(a_trail - a_lead)))

        strides: list[Stride] = []
        t_prev, i_prev, prev, lead = 0.0, 0, at(0), 1
        for info in log:
            idx = int(np.nonzero(t == info["t"])[0][-1])
            now = at(idx)
            z_next = self.project(info["x"], info["p"], info["lead"])
            s = Stride("step", z_next, info["t"] - t_prev, step_length=float(info["step_length"]),
                       energy_dissipated=now[2] - prev[2], potential_released=prev[1] - now[1],
                       energy_residual=(now[0] - prev[0]) + (now[2] - prev[2]) - (now[3] - prev[3]),
                       info={"lead": info["lead"], "t_end": info["t"],
                             "energy_supplied": now[3] - prev[3]})
            if details:
                s.max_theta, s.max_phi = maxima(i_prev, idx, lead)
            strides.append(s)
            t_prev, i_prev, prev, lead = info["t"], idx, now, info["lead"]
        if len(log) < n_steps:
            if traj.status == "finished":
                reason = "time_limit"
            elif traj.status == "event" and traj.events:
                reason = traj.events[-1][1]
            else:
                reason = traj.status
            fell = Stride("fell", None, float(traj.t_final - t_prev), reason=reason,
                          info={"message": traj.message, "status": traj.status})
            strides.append(fell)
        if record and strides:
            strides[-1].info["trajectory"] = traj
        return strides


def compass_walker(*, backend: str = "numba", options: CompliantOptions | None = None,
                   contact: str = "HuntCrossley", **values: float) -> CompliantWalker:
    """The thesis's nominal walker (MODEL-SPEC.md §1), see the module docstring.

    ``contact``: the feet's contact law, "HuntCrossley" (default, the thesis's) or "KelvinVoigt"
    (linear damping ``B_contact``, see :func:`contact_specs`).
    The default back end is numba with the compiled Rodas4 loop (≈ 0.1 s per step once the model
    is compiled and cached; the python back end takes ≈ 10 s per step on this stiff model)."""
    specs = contact_specs(compass_walker_specs(), check_contact(contact))
    model = compass_walker_model(specs, contact)
    opts = options or CompliantOptions(method="Rodas4", rtol=1e-8, atol=1e-10, max_step=0.01,
                                       max_step_time=3.0)
    return CompliantWalker("compass_walker", {s.name: s for s in specs}, model, values=values,
                           backend=backend, options=opts, doc=model.doc, builder="compass_walker")


@dataclass
class DampingCalibration(JSONResult):
    """Result of :func:`calibrate_damping` (SI units): the λ grid (N·s/m²), the energy dissipated
    per impact at each λ (J), its maximum, and the calibrated λ: the smallest grid value whose
    dissipation is within ``rel_tol`` of the maximum."""

    lam: list[float]
    dissipated: list[float]
    max_dissipated: float
    lam_at_max: float
    calibrated_lam: float
    rel_tol: float
    window: float
    #: the damping parameter varied (``lam``; ``B_contact`` for a Kelvin–Voigt walker, N·s/m)
    parameter: str = "lam"


def calibrate_damping(walker: CompliantWalker, z=None, lams=None, *, window: float = 0.05,
                      rel_tol: float = 1e-3, parameter: str | None = None) -> DampingCalibration:
    """Calibrate the lost Hunt–Crossley damping λ the thesis's way (§2.3.2, MODEL-SPEC.md §1):
    the smallest λ that maximises the energy dissipated per impact (a near-plastic impact).

    For each λ of ``lams`` (default: 10^5 … 10^10, four per decade) the walker is started at the
    heel-strike section state ``z`` (default: its initial guess, the pre-impact state of the gait)
    and simulated for ``window`` seconds (the impact transient: ≈ 1 ms to 40 ms depending on λ)
    with both contacts active and no mode switches; the ledger's E_diss at the end is the energy
    dissipated by the impact (contact damping, plus the little friction work in the window).
    The dissipation rises with λ to a plateau (at low λ the foot bounces) and then barely
    changes; "the smallest λ that maximises" is read as the smallest grid λ within ``rel_tol``
    (relative) of the maximum over the grid.

    ``parameter``: the damping varied, default the walker's contact damping (``lam`` for
    Hunt–Crossley, ``B_contact`` for Kelvin–Voigt: then ``lams`` are values of B, N·s/m).
    """
    if parameter is None:
        parameter = "B_contact" if getattr(walker, "contact", "") == "KelvinVoigt" else "lam"
    z = walker.initial_guess() if z is None else np.asarray(z, dtype=float)
    lams = np.logspace(5, 10, 21) if lams is None else np.asarray(lams, dtype=float)
    out = []
    n = walker.swing.n_states
    for lam in lams:
        w = walker.with_parameters(**{parameter: float(lam)})
        p0 = w._p.copy()
        p0[w._ic[1]] = 1.0
        p0[w._ic[2]] = 1.0
        x0 = w.lift(z, p0)
        o = w.options
        tr = w.swing.simulate(window, x0=x0, params=dict(zip(w.swing.param_names, p0)),
                              method=o.method, rtol=o.rtol, atol=o.atol, max_step=o.max_step)
        out.append(float(tr.y[n, -1]) if tr.status == "finished" else math.nan)
    d = np.array(out)
    k_max = int(np.nanargmax(d))
    good = np.nonzero(d >= d[k_max] * (1 - rel_tol))[0]
    return DampingCalibration([float(v) for v in lams], out, float(d[k_max]), float(lams[k_max]),
                              float(lams[good[0]]), rel_tol, window, parameter)
