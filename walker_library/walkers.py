"""Builders of the classic rigid-impact walkers, from the framework's bodies and joints.

Every builder returns a :class:`~walker_library.protocol.Walker` whose swing phase and impact are
multibody models (:class:`porthamiltonian.Multibody`; no equation of motion is typed in) and whose
parameters are named, with units, sources and ranges. Every walker takes its slope as ``slope``
(rad), implemented by rotating gravity into the slope frame: g (sin γ, 0, −cos γ).

* :func:`simplest_walker` — Garcia, Chatterjee, Ruina & Coleman (1998), "The simplest walking
  model: stability, complexity, and scaling", J. Biomech. Eng. 120:281–288. Point hip mass M,
  point feet m = β M on massless rigid legs of length l; nondimensional (M = l = g = 1). Garcia's
  results are the limit β -> 0; the default β = 1e-9 is checked to move the published numbers by
  less than 1e-7 (tests/walkers/test_rigid_walkers.py).
* :func:`compass_gait` — Goswami, Thuilot & Espiau (1998), "A study of the passive gait of a
  compass-like biped robot: symmetry and chaos", Int. J. Robot. Res. 17(12):1282–1301: hip mass
  m_H = 10 kg, leg masses m = 5 kg as point masses at a = 0.5 m from the foot (b = 0.5 m from the
  hip), leg length l = a + b = 1 m, slope 3°.
* :func:`rimless_wheel` — McGeer (1990), "Passive dynamic walking", Int. J. Robot. Res.
  9(2):62–82, and Coleman, Chatterjee & Ruina (1997), "Motions of a rimless spoked wheel: a simple
  3D system with impacts", Dynamics and Stability of Systems 12(3):139–160: mass m = 1 kg at the
  hub, n = 8 massless spokes of length l = 1 m; slope 0.08 rad (as in Tedrake's Underactuated
  Robotics notes and Drake's RimlessWheel example).

Model files (``models/<name>.toml``) hold the swing-phase model as an ordinary porthamiltonian
model (so ``porthamiltonian check-energy`` and ``show`` work on them) plus a ``[model.walker]``
table naming the builder; :func:`load_walker` rebuilds the walker from the builder and the file's
parameter values and refuses a file whose components differ from what the builder generates
(edit the builder, then ``walker export``).
"""
from __future__ import annotations

import inspect
import math
import tomllib
from pathlib import Path
from typing import Any

import tomli_w

from porthamiltonian import Model, Multibody, Revolute, RigidBody, Translational, Weld
from porthamiltonian import io as ph_io
from porthamiltonian.errors import ModelFileError, ParameterValueError

from .protocol import ParameterSpec
from .rigid import (MODE_PARAMETERS, IntegrationOptions, LeggedRigidWalker, RigidImpactWalker,
                    RimlessWheelWalker)

__all__ = ["BUILDERS", "simplest_walker", "compass_gait", "rimless_wheel", "load_walker",
           "export_model_file", "available_walkers", "builder_options"]

_GRAVITY = ["g*sin(slope)", 0, "-g*cos(slope)"]
_INF = math.inf

GARCIA = "Garcia et al. 1998, J. Biomech. Eng. 120:281"
GOSWAMI = "Goswami, Thuilot & Espiau 1998, Int. J. Robot. Res. 17(12):1282"
MCGEER = "McGeer 1990, Int. J. Robot. Res. 9(2):62; Coleman et al. 1997"


def _spec(name, value, unit, doc, source="", low=-_INF, high=_INF, low_inclusive=False):
    return ParameterSpec(name, float(value), unit, doc, source, low, high, low_inclusive)


def _common_specs(length: str) -> list[ParameterSpec]:
    return [
        _spec("contact_margin", 1e-12, "m", "hysteresis of the heel-strike guard: the swing foot "
              "strikes when it is this far below the surface", "numerical", 0.0, 1e-3, True),
        _spec("fall_fraction", 0.5, "1", f"the walker has fallen when the hip is lower than this "
              f"fraction of the leg length ({length}) above the stance foot", "numerical", 0.0, 1.0),
    ]


def _model_with(name: str, doc: str, specs: list[ParameterSpec], modes: bool) -> Model:
    m = Model(name, doc)
    for s in specs:
        m.parameter(s.name, s.value, s.unit, f"{s.doc} [{s.source}]" if s.source else s.doc)
    if modes:
        m.parameter("stance_x", 0.0, "m", "mode: stance-foot position along the slope (set at heel strike)")
        m.parameter("stance_z", 0.0, "m", "mode: stance-foot position along the slope normal")
        m.parameter("ground_z", 0.0, "m", "mode: height of the surface the swing foot strikes")
    return m


def _legged_models(name: str, doc: str, specs: list[ParameterSpec], *, hip_mass: str,
                   leg_mass: str | None, leg_com_from_hip: str, leg_inertia: str | None,
                   foot_mass: str | None, length: str, t_end: float = 1.0,
                   atol: float = 1e-13) -> tuple[Model, Model]:
    """Swing (pinned) and floating-base multibody models of a two-legged rigid walker."""
    L = f"({length})"
    inertia = [leg_inertia] * 3 if leg_inertia else 0

    def leg(points: dict[str, list]) -> RigidBody:
        if leg_mass:
            return RigidBody(mass=leg_mass, com=[0, 0, f"-({leg_com_from_hip})"], inertia=inertia,
                             points=points)
        return RigidBody(mass=foot_mass, com=[0, 0, f"-{L}"], points=points)

    # swing phase: world -> stance foot (revolute) -> stance leg -> hip (revolute) -> swing leg
    bodies: dict[str, RigidBody] = {}
    joints: dict[str, Any] = {
        "stance": Revolute(parent="world", child="stance_leg", axis="y",
                           origin=["stance_x", 0, "stance_z"], q0="-theta0", v0="-theta_dot0"),
        "hip": Revolute(parent="stance_leg", child="swing_leg", axis="y", origin=[0, 0, L],
                        q0="2*theta0", v0="phi_dot0"),
    }
    if leg_mass:
        bodies["stance_leg"] = RigidBody(mass=leg_mass, com=[0, 0, f"{L} - ({leg_com_from_hip})"],
                                         inertia=inertia, points={"stance_foot": [0, 0, 0]})
        bodies["hip_body"] = RigidBody(mass=hip_mass, points={"hip_centre": [0, 0, 0]})
        joints["pelvis"] = Weld(parent="stance_leg", child="hip_body", origin=[0, 0, L])
    else:
        bodies["stance_leg"] = RigidBody(mass=hip_mass, com=[0, 0, L],
                                         points={"hip_centre": [0, 0, L], "stance_foot": [0, 0, 0]})
    bodies["swing_leg"] = leg({"swing_foot": [0, 0, f"-{L}"]})
    if foot_mass:
        bodies["stance_foot_body"] = RigidBody(mass=foot_mass)
        joints["stance_ankle"] = Weld(parent="stance_leg", child="stance_foot_body", origin=[0, 0, 0])
        if leg_mass:
            bodies["swing_foot_body"] = RigidBody(mass=foot_mass)
            joints["swing_ankle"] = Weld(parent="swing_leg", child="swing_foot_body",
                                         origin=[0, 0, f"-{L}"])
    swing = _model_with(name, doc, specs, modes=True)
    swing.add("walker", Multibody(bodies=bodies, joints=joints, gravity=_GRAVITY, plane="xz"))
    # guards in joint coordinates (a guard cannot read the multibody's point outputs): the swing
    # foot's height above the surface, walker.swing_foot.z - ground_z, and the hip's height
    # above the stance foot, walker.hip_centre.z - stance_z (tests pin both to the outputs).
    # Not terminal in the model (a plain simulation records them); the walker's actions (the
    # impact, and stopping at a fall) make them terminal in its runs.
    swing.event("heel_strike", f"{L}*cos(walker.q.stance) - {L}*cos(walker.q.stance + walker.q.hip)"
                " + stance_z - ground_z + contact_margin", direction=-1)
    swing.event("fall", f"{L}*cos(walker.q.stance) - fall_fraction*{L}", direction=-1)
    swing.simulation = {"t_end": t_end, "method": "DOP853", "rtol": 1e-11, "atol": atol,
                        "energy_tolerance": 1e-8}

    # impact: hip on a translational x/z joint, each leg on a revolute joint (absolute angles)
    fbodies = {"hip_body": RigidBody(mass=hip_mass, points={"hip_centre": [0, 0, 0]})}
    fjoints: dict[str, Any] = {"hip_joint": Translational(parent="world", child="hip_body",
                                                          axes=("x", "z"))}
    for k in (1, 2):
        fbodies[f"leg{k}"] = leg({f"foot{k}": [0, 0, f"-{L}"]})
        fjoints[f"leg{k}"] = Revolute(parent="hip_body", child=f"leg{k}", axis="y")
        if foot_mass and leg_mass:
            fbodies[f"foot{k}_body"] = RigidBody(mass=foot_mass)
            fjoints[f"ankle{k}"] = Weld(parent=f"leg{k}", child=f"foot{k}_body", origin=[0, 0, f"-{L}"])
    floating = _model_with(f"{name}_floating", f"{doc} (floating base, for the impact map)",
                           [s for s in specs if s.name not in ("theta0", "theta_dot0", "phi_dot0",
                                                                "contact_margin", "fall_fraction")],
                           modes=False)
    floating.add("walker", Multibody(bodies=fbodies, joints=fjoints, gravity=_GRAVITY, plane="xz"))
    return swing, floating


# --- the walkers ------------------------------------------------------------------------------------
def simplest_walker(*, backend: str = "python", options: IntegrationOptions | None = None,
                    **values: float) -> LeggedRigidWalker:
    """Garcia et al.'s (1998) simplest walking model, nondimensional (M = l = g = 1 by default).

    Parameters (names, SI or nondimensional units): slope γ, M (hip mass), beta = m/M (foot mass
    ratio; Garcia's model is the limit beta -> 0), l, g, and the rough initial guess theta0,
    theta_dot0, phi_dot0 (θ, θ̇, φ̇ just after heel strike, Garcia's signs).
    """
    specs = [
        _spec("slope", 0.009, "rad", "slope angle γ", GARCIA, -math.pi / 4, math.pi / 4),
        _spec("M", 1.0, "kg", "hip mass (point mass); 1 in Garcia's nondimensional units", GARCIA, 0.0),
        _spec("beta", 1e-9, "1", "foot mass / hip mass; Garcia's model is the limit beta -> 0",
              GARCIA, 0.0, 1.0),
        _spec("l", 1.0, "m", "leg length, hip to foot; 1 nondimensional", GARCIA, 0.0),
        _spec("g", 1.0, "m/s^2", "acceleration of gravity; 1 nondimensional", GARCIA, 0.0),
        _spec("theta0", 0.2, "rad", "initial guess: stance angle θ just after heel strike", GARCIA,
              0.0, math.pi / 2),
        _spec("theta_dot0", -0.2, "rad/s", "initial guess: θ̇ just after heel strike", GARCIA),
        _spec("phi_dot0", -0.015, "rad/s", "initial guess: φ̇ just after heel strike", GARCIA),
        *_common_specs("l"),
    ]
    doc = ("Simplest walking model (Garcia et al. 1998): point hip mass M, point feet beta*M, "
           "massless rigid legs of length l, plastic heel strike, scuffing ignored.")
    swing, floating = _legged_models("simplest_walker", doc, specs, hip_mass="M", leg_mass=None,
                                     leg_com_from_hip="l", leg_inertia=None, foot_mass="beta*M",
                                     length="l", t_end=4.0, atol=1e-20)
    # momenta of the feet are O(beta): absolute tolerance scaled to them
    opts = options or IntegrationOptions(method="DOP853", rtol=1e-12, atol=1e-24, max_step=0.25,
                                         max_step_time=20.0)
    return LeggedRigidWalker("simplest_walker", {s.name: s for s in specs}, swing, floating,
                             values=values, backend=backend, options=opts, doc=doc,
                             builder="simplest_walker", leg_length=lambda P: P["l"],
                             total_mass=lambda P: P["M"] * (1 + 2 * P["beta"]))


def compass_gait(*, backend: str = "python", options: IntegrationOptions | None = None,
                 **values: float) -> LeggedRigidWalker:
    """Goswami et al.'s (1998) compass-gait biped: hip mass m_H, leg masses m at a from the foot
    (b from the hip), legs of length a + b, on a slope (default 3°)."""
    specs = [
        _spec("slope", math.radians(3.0), "rad", "slope angle (3° in Goswami's nominal case)",
              GOSWAMI, -math.pi / 4, math.pi / 4),
        _spec("m_H", 10.0, "kg", "hip mass (point mass)", GOSWAMI, 0.0),
        _spec("m", 5.0, "kg", "mass of each leg (point mass on the leg)", GOSWAMI, 0.0),
        _spec("a", 0.5, "m", "distance of the leg mass from the foot", GOSWAMI, 0.0),
        _spec("b", 0.5, "m", "distance of the leg mass from the hip", GOSWAMI, 0.0),
        _spec("g", 9.81, "m/s^2", "acceleration of gravity", GOSWAMI, 0.0),
        _spec("theta0", 0.27, "rad", "initial guess: stance angle θ just after heel strike", GOSWAMI,
              0.0, math.pi / 2),
        _spec("theta_dot0", -1.1, "rad/s", "initial guess: θ̇ just after heel strike", GOSWAMI),
        _spec("phi_dot0", -0.7, "rad/s", "initial guess: φ̇ just after heel strike", GOSWAMI),
        *_common_specs("a + b"),
    ]
    doc = ("Compass-gait biped (Goswami et al. 1998): point hip mass m_H, leg point masses m at a "
           "from the foot, legs of length a + b, plastic heel strike, scuffing ignored.")
    swing, floating = _legged_models("compass_gait", doc, specs, hip_mass="m_H", leg_mass="m",
                                     leg_com_from_hip="b", leg_inertia=None, foot_mass=None,
                                     length="a + b", t_end=1.0)
    opts = options or IntegrationOptions(method="DOP853", rtol=1e-12, atol=1e-13, max_step=0.03,
                                         max_step_time=5.0)
    return LeggedRigidWalker("compass_gait", {s.name: s for s in specs}, swing, floating,
                             values=values, backend=backend, options=opts, doc=doc,
                             builder="compass_gait", leg_length=lambda P: P["a"] + P["b"],
                             total_mass=lambda P: P["m_H"] + 2 * P["m"])


def rigid_compass_walker(*, backend: str = "python", options: IntegrationOptions | None = None,
                         **values: float) -> LeggedRigidWalker:
    """The thesis's nominal walker's mass distribution (MODEL-SPEC.md §1, Table 2.3) with point
    feet and a rigid plastic heel strike instead of the compliant contact: hip M = 3 kg, legs
    m_leg = 0.01 kg at mid-leg, feet m_foot = 0.1 kg at the leg ends, l = 0.7 m. It is the limit of
    ``compass_walker`` with R -> 0 and an ever stiffer, plastic contact (tested)."""
    thesis = "MODEL-SPEC.md §1 (thesis Table 2.3)"
    specs = [
        _spec("slope", 0.009, "rad", "slope angle γ", thesis, -math.pi / 4, math.pi / 4),
        _spec("M", 3.0, "kg", "hip mass (point mass)", thesis, 0.0),
        _spec("m_leg", 0.01, "kg", "mass of each leg, at mid-leg", thesis, 0.0),
        _spec("m_foot", 0.1, "kg", "mass of each (point) foot, at the leg's end", thesis, 0.0),
        _spec("l", 0.7, "m", "leg length, hip to foot", thesis, 0.0),
        _spec("g", 9.81, "m/s^2", "acceleration of gravity", "", 0.0),
        _spec("theta0", 0.2, "rad", "initial guess: θ just after heel strike", "rough", 0.0,
              math.pi / 2),
        _spec("theta_dot0", -0.75, "rad/s", "initial guess: θ̇ just after heel strike", "rough"),
        _spec("phi_dot0", -0.05, "rad/s", "initial guess: φ̇ just after heel strike", "rough"),
        *_common_specs("l"),
    ]
    doc = ("Thesis nominal walker's masses (hip 3 kg, legs 0.01 kg at mid-leg, feet 0.1 kg) with "
           "point feet and a plastic heel strike: the rigid-impact limit of compass_walker.")
    swing, floating = _legged_models("rigid_compass_walker", doc, specs, hip_mass="M",
                                     leg_mass="m_leg", leg_com_from_hip="l/2", leg_inertia=None,
                                     foot_mass="m_foot", length="l", t_end=1.0, atol=1e-13)
    opts = options or IntegrationOptions(method="DOP853", rtol=1e-12, atol=1e-14, max_step=0.03,
                                         max_step_time=5.0)
    return LeggedRigidWalker("rigid_compass_walker", {s.name: s for s in specs}, swing, floating,
                             values=values, backend=backend, options=opts, doc=doc,
                             builder="rigid_compass_walker", leg_length=lambda P: P["l"],
                             total_mass=lambda P: P["M"] + 2 * (P["m_leg"] + P["m_foot"]))


def rimless_wheel(*, backend: str = "python", options: IntegrationOptions | None = None,
                  **values: float) -> RimlessWheelWalker:
    """A rimless wheel: hub mass m (radius of gyration r_gyr about the hub, 0: a point mass),
    n_spokes massless spokes of length l, on a slope (default 0.08 rad)."""
    specs = [
        _spec("slope", 0.08, "rad", "slope angle", MCGEER, -math.pi / 4, math.pi / 4),
        _spec("m", 1.0, "kg", "wheel mass, at the hub", MCGEER, 0.0),
        _spec("l", 1.0, "m", "spoke length", MCGEER, 0.0),
        _spec("n_spokes", 8.0, "1", "number of spokes (angle 2π/n between spokes)", MCGEER, 3.0,
              1000.0, True),
        _spec("r_gyr", 0.0, "m", "radius of gyration about the hub (0: point mass)", MCGEER, 0.0,
              _INF, True),
        _spec("g", 9.81, "m/s^2", "acceleration of gravity", MCGEER, 0.0),
        _spec("omega0", 1.0, "rad/s", "initial guess: wheel rate just after a spoke strikes", MCGEER),
        *_common_specs("l"),
    ]
    doc = ("Rimless wheel (McGeer 1990; Coleman et al. 1997): hub mass m, n_spokes massless spokes "
           "of length l, plastic impacts.")
    two_alpha = "2*pi/n_spokes"
    swing = _model_with("rimless_wheel", doc, specs, modes=True)
    swing.add("walker", Multibody(
        bodies={"wheel": RigidBody(
            mass="m", com=[0, 0, "l"], inertia=["m*r_gyr**2"] * 3,
            points={"hub": [0, 0, "l"],
                    "next_tip": [f"l*sin({two_alpha})", 0, f"l - l*cos({two_alpha})"],
                    "prev_tip": [f"-l*sin({two_alpha})", 0, f"l - l*cos({two_alpha})"]})},
        joints={"stance": Revolute(parent="world", child="wheel", axis="y",
                                   origin=["stance_x", 0, "stance_z"], q0="-pi/n_spokes", v0="omega0")},
        gravity=_GRAVITY, plane="xz"))
    # guards in the joint coordinate: heights of the next and previous spoke tips above the
    # surface (walker.next_tip.z - ground_z, walker.prev_tip.z - ground_z; pinned by the tests)
    swing.event("heel_strike", f"l*cos(walker.q.stance) - l*cos(walker.q.stance - {two_alpha})"
                " + stance_z - ground_z + contact_margin", direction=-1)
    swing.event("rolled_back", f"l*cos(walker.q.stance) - l*cos(walker.q.stance + {two_alpha})"
                " + stance_z - ground_z + contact_margin", direction=-1)
    swing.simulation = {"t_end": 1.5, "method": "DOP853", "rtol": 1e-11, "atol": 1e-13,
                        "energy_tolerance": 1e-8}
    floating = _model_with("rimless_wheel_floating", f"{doc} (floating base, for the impact map)",
                           [s for s in specs if s.name not in ("omega0", "contact_margin",
                                                                "fall_fraction")], modes=False)
    # the spokes body carries the rotational inertia only: the wheel's mass sits on the hub body
    # (a Multibody body needs a mass entry; "0*m" is an exact zero)
    floating.add("walker", Multibody(
        bodies={"hub_body": RigidBody(mass="m", points={"hub": [0, 0, 0]}),
                "spokes": RigidBody(mass="0*m", inertia=["m*r_gyr**2"] * 3,
                                    points={"next_tip": [f"l*sin({two_alpha})", 0, f"-l*cos({two_alpha})"],
                                            "stance_tip": [0, 0, "-l"]})},
        joints={"hub_joint": Translational(parent="world", child="hub_body", axes=("x", "z")),
                "spin": Revolute(parent="hub_body", child="spokes", axis="y")},
        gravity=_GRAVITY, plane="xz"))
    opts = options or IntegrationOptions(method="DOP853", rtol=1e-12, atol=1e-13, max_step=0.03,
                                         max_step_time=5.0)
    return RimlessWheelWalker("rimless_wheel", {s.name: s for s in specs}, swing, floating,
                              values=values, backend=backend, options=opts, doc=doc,
                              builder="rimless_wheel", leg_length=lambda P: P["l"],
                              total_mass=lambda P: P["m"])


from .compliant import CONTACT_KINDS, CONTACT_MODES, compass_walker  # noqa: E402  (after the rigid builders)
from .compliant_legs import compliant_leg_walker, variable_stiffness_walker  # noqa: E402

BUILDERS = {"simplest_walker": simplest_walker, "compass_gait": compass_gait,
            "rimless_wheel": rimless_wheel, "compass_walker": compass_walker,
            "rigid_compass_walker": rigid_compass_walker,
            "compliant_leg_walker": compliant_leg_walker,
            "variable_stiffness_walker": variable_stiffness_walker}


# --- model files ------------------------------------------------------------------------------------
#: keyword arguments of a builder that are not options of its model file
_NOT_OPTIONS = ("backend", "options")


def builder_options(builder) -> dict[str, Any]:
    """The options a builder takes from its model file's ``[model.walker]`` table, with their
    defaults: its keyword-only arguments other than ``backend`` and ``options`` (the compliant
    walkers: ``contact``; the rigid walkers: none)."""
    return {name: par.default for name, par in inspect.signature(builder).parameters.items()
            if par.kind is inspect.Parameter.KEYWORD_ONLY and name not in _NOT_OPTIONS
            and par.default is not inspect.Parameter.empty}


def _contact_neutral(components: Any) -> Any:
    """``components`` (a model dict's) with the contact law left out of every contact component
    (``type``, ``damping``, ``exponent``, ``clip`` of a HuntCrossley or KelvinVoigt): the law
    is the walker file's ``contact`` option, the rest (point, stiffness, surface, mode flag) is
    the mechanism."""
    if not isinstance(components, dict):
        return components
    out = {}
    for name, comp in components.items():
        if isinstance(comp, dict) and comp.get("type") in CONTACT_KINDS:
            comp = {k: v for k, v in comp.items()
                    if k not in ("type", "damping", "exponent", "clip")}
        out[name] = comp
    return out


def export_model_file(walker: RigidImpactWalker, path: str | Path, header: str = "") -> Path:
    """Write ``walker``'s swing-phase model as a porthamiltonian model file with a
    ``[model.walker]`` table naming its builder (parameters at the walker's current values) and
    the builder's options that differ from their defaults (``contact = "KelvinVoigt"``; none for
    a default walker, whose file is unchanged)."""
    data = ph_io.model_to_dict(walker.swing_model)
    for name, value in walker.parameters.items():
        entry = data["parameters"][name]
        if isinstance(entry, dict):
            entry["value"] = value
        else:
            data["parameters"][name] = value
    table: dict[str, Any] = {"builder": walker.builder}
    defaults = builder_options(BUILDERS[walker.builder]) if walker.builder in BUILDERS else {}
    for name, value in (getattr(walker, "builder_options", None) or {}).items():
        if name in defaults and value != defaults[name]:
            table[name] = value
    data["model"]["walker"] = table
    text = tomli_w.dumps(data)
    path = Path(path)
    path.write_text((header.rstrip() + "\n\n" if header else "") + text)
    return path


def _with(options: dict[str, Any]) -> str:
    return (" with " + ", ".join(f"{k} = {v!r}" for k, v in options.items())) if options else ""


def available_walkers() -> list[str]:
    """Names of the model files in ``models/`` that declare a ``[model.walker]`` table."""
    out = []
    for name in ph_io.available_models():
        try:
            data = tomllib.loads(ph_io.model_path(name).read_text())
        except (OSError, tomllib.TOMLDecodeError, ModelFileError):
            continue
        if isinstance(data.get("model"), dict) and isinstance(data["model"].get("walker"), dict):
            out.append(name)
    return out


def load_walker(name_or_path: str | Path, overrides: dict[str, float] | None = None, *,
                backend: str | None = "python", check_components: bool = True):
    """Load a walker by model name (``models/<name>.toml``), by path, or by builder name.

    The file's ``[model.walker]`` table names the builder; its other entries are the builder's
    options, passed as keyword arguments (:func:`builder_options`: ``contact = "HuntCrossley"``
    or ``"KelvinVoigt"`` for the compliant walkers); its ``[parameters]`` give the values (the
    mode parameters stance_x, stance_z, ground_z, c1, c2 excepted), ``overrides`` change them. ``backend`` None: the builder's own default (python for the rigid walkers, numba for
    the compliant-contact walker).
    Raises :class:`~porthamiltonian.errors.ModelFileError` for a file that is not a walker file or
    whose components differ from what its builder generates with the file's options (the contact
    law of the contact components excepted: the ``contact`` option chooses it, so a file swaps its
    contact by that one line), or with an unknown option, and
    :class:`~porthamiltonian.errors.ParameterValueError` for unknown or out-of-range parameters.
    """
    try:
        path = ph_io.model_path(name_or_path)
    except ModelFileError:
        if str(name_or_path) in BUILDERS:
            kw = {} if backend is None else {"backend": backend}
            return BUILDERS[str(name_or_path)](**kw, **(overrides or {}))
        raise
    text = path.read_text()
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ModelFileError(f"{path}: TOML syntax error: {err}") from None
    head = data.get("model", {})
    table = head.get("walker") if isinstance(head, dict) else None
    if not isinstance(table, dict) or "builder" not in table:
        raise ModelFileError(f"{path}: not a walker file: it needs a [model.walker] table with "
                             f"builder = one of {', '.join(BUILDERS)}")
    builder = BUILDERS.get(str(table["builder"]))
    if builder is None:
        raise ModelFileError(f"{path}: unknown walker builder {table['builder']!r}; builders: "
                             f"{', '.join(BUILDERS)}")
    allowed = builder_options(builder)
    options = {k: v for k, v in table.items() if k != "builder"}
    for key in options:
        if key not in allowed:
            raise ModelFileError(
                f"{path}: [model.walker] option {key!r} is not an option of the builder "
                f"{table['builder']!r}; its options: "
                + (", ".join(f"{k} (default {v!r})" for k, v in allowed.items()) or "none"))
    values: dict[str, float] = {}
    for name, spec in (data.get("parameters") or {}).items():
        if name in MODE_PARAMETERS or name in CONTACT_MODES:
            continue
        values[name] = spec["value"] if isinstance(spec, dict) else spec
    try:
        walker = builder(**({} if backend is None else {"backend": backend}), **options,
                         **values)
    except ParameterValueError as err:
        raise ParameterValueError(f"{path}: {err}") from None
    if check_components:
        mine = ph_io.model_to_dict(walker.swing_model)
        if (_contact_neutral(mine.get("components")) != _contact_neutral(data.get("components"))
                or mine.get("bonds", []) != data.get("bonds", [])
                or mine.get("events") != data.get("events")):
            raise ModelFileError(
                f"{path}: its components or events differ from what the builder "
                f"{table['builder']!r} generates{_with(options)}; walker files are generated (walker export "
                f"{table['builder']} {path}): change the builder, not the file")
    if overrides:
        walker = walker.with_parameters(**overrides)
    return walker
