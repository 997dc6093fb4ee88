"""SCVS friction (static, Coulomb, viscous, Stribeck), exactly as 20-sim defines it.

Law (the thesis's App. A, 20-sim's SCVS friction)
--------------------------------------------------------------
For the tangential velocity v (m/s) of the contact point and the normal force Fn (N):

    F_t = −Fn · ( (μ_c + (μ_st·|tanh(s·v)| − μ_c)·exp(−(v/v_st)²))·sign(v) + μ_v·v ),

the friction force on the body along the surface tangent (N; F_t = 0 at v = 0). Parameters:
static friction μ_st (1), Coulomb friction μ_c (1, 0 ≤ μ_c ≤ μ_st), viscous friction μ_v (s/m,
multiplies Fn), ``slope`` s (s/m: the steepness of the tanh that regularizes the sign at v = 0;
20-sim's name) and the Stribeck velocity v_st (m/s, > 0). Thesis values: μ_st = 0.5, μ_c = 0.25,
μ_v = 0.025, s = 500, v_st = 0.02.

The generated code uses the identity (exact for s ≥ 0, since |tanh(s v)|·sign(v) = tanh(s v))

    (μ_c + (μ_st|tanh(s v)| − μ_c) E) sign v = μ_st tanh(s v) E + μ_c sign(v) (1 − E),
    E = exp(−(v/v_st)²),

which is the same function of v everywhere (the tests compare it with the literal formula) but is
differentiable without Dirac deltas: the remaining sign(v) is multiplied by 1 − E = O(v²), and is
written as a Piecewise. The coefficient μ(v) = −F_t/Fn is odd in v, 0 at v = 0, rises with slope
μ_st·s to nearly μ_st within a few 1/s (≈ 5 mm/s for the thesis values), decays towards μ_c
over a few v_st (the Stribeck effect: ≈ μ_c + (μ_st − μ_c)/e at v = v_st), then grows as
μ_c + μ_v v. Because μ(v) is smooth, there is no true sticking: a block held by friction creeps
at the speed v* where μ(v*) equals the ratio of tangential to normal load (small: the
"regularization" of stiction).

Connection and energy role
--------------------------
One power port ``p`` (translation, dimension 2, world (x, z), orientation ``"in"``) at the same
body point as the normal contact, through a 1-junction (common velocity):
``"walker.foot1 -> j"``, ``"j -> floor.p"``, ``"j -> friction.p"``. The normal force is a signal
``normal_force = "floor.Fn"`` (the ``Fn`` output of a contact component); the friction acts along
that contact's surface tangent t (its outputs ``tx``/``tz``), with v = t·f (f the port flow).
Port effort: the reaction −F_t·t (force of the body on the friction element). A tensile normal
force (a Kelvin–Voigt contact without clipping) gives no friction: Fn is taken as max(Fn, 0).
A pure dissipator: P_diss = e·f = max(Fn, 0)·μ(v)·v ≥ 0 at all times (each term of μ(v)·v is
≥ 0). No state, no stored energy.

Outputs: ``Ft`` (tangential force on the body, N), ``v`` (slip velocity, m/s), ``mu`` (μ(v)).

Errors: no ``normal_force`` (:class:`~porthamiltonian.errors.DanglingPortError`); a normal force
that does not read a contact's ``Fn`` (:class:`~porthamiltonian.errors.UnknownParameterError`);
numeric μ_st, μ_c, μ_v or slope < 0, v_st ≤ 0 or μ_c > μ_st
(:class:`~porthamiltonian.errors.ParameterValueError`); each names the component and argument.

References: 20-sim reference manual, "Friction — SCVS" (Controllab Products); B. Armstrong-Hélouvry,
P. Dupont, C. Canudas de Wit, "A survey of models, analysis tools and compensation methods for
the control of machines with friction", Automatica 30 (1994) 1083–1138 (the Stribeck curve).
"""
from __future__ import annotations

import sympy as sp

from ..errors import DanglingPortError, ParameterValueError, UnknownParameterError
from ..modeling.component import Arg, Builder, Component, register
from ..modeling.ports import Port


def scvs_coefficient(v: sp.Expr, mu_st: sp.Expr, mu_c: sp.Expr, mu_v: sp.Expr, slope: sp.Expr,
                     v_st: sp.Expr) -> sp.Expr:
    """μ(v) = −F_t/Fn of the SCVS law (sympy expressions), in the Dirac-free form of the module
    docstring."""
    E = sp.exp(-((v / v_st) ** 2))
    sign = sp.Piecewise((1, v > 0), (-1, v < 0), (0, True))
    return mu_st * sp.tanh(slope * v) * E + mu_c * sign * (1 - E) + mu_v * v


def normal_force_source(component: Component, where: str, normal_force: sp.Expr | None
                        ) -> tuple[str, sp.Expr]:
    """The name of the one contact whose ``Fn`` output the friction's ``normal_force`` reads,
    and that normal force (``where`` names the friction in messages)."""
    if normal_force is None:
        raise DanglingPortError(
            f"{where} has no normal-force source: give normal_force = \"<contact>.Fn\", the Fn "
            "output of the contact (HuntCrossley, KelvinVoigt or their 3D forms) at the same point")
    sources = sorted({str(s)[: -len(".Fn")] for s in normal_force.free_symbols
                      if str(s).endswith(".Fn")})
    if not sources:
        raise UnknownParameterError(
            f"{where} argument 'normal_force' = {component.value('normal_force')!r} does not read "
            "a contact's normal force: give normal_force = \"<contact>.Fn\" (the Fn output of a "
            "contact component)")
    if len(sources) > 1:
        raise ParameterValueError(
            f"{where} argument 'normal_force' reads the normal forces of several contacts "
            f"({', '.join(sources)}); use one friction element per contact")
    return sources[0], normal_force


@register
class SCVSFriction(Component):
    """20-sim SCVS friction along a contact's surface, driven by the contact's normal force.

    Ports: ``p`` (translation, (x, z), in), at the contact's body point through a 1-junction.
    Parameters: ``normal_force`` (signal, e.g. "floor.Fn"), ``mu_st``, ``mu_c`` (1), ``mu_v``
    (s/m), ``slope`` (s/m), ``v_st`` (m/s). Dissipation: max(Fn, 0) μ(v) v ≥ 0.
    See the module docstring for the law, its shape and references.
    """

    kind = "SCVSFriction"
    arguments = {
        "normal_force": Arg("normal force signal: a contact's Fn output, e.g. 'floor.Fn'", "N",
                            default=None),
        "mu_st": Arg("static friction coefficient μ_st", "1", rule=">="),
        "mu_c": Arg("Coulomb friction coefficient μ_c (<= μ_st)", "1", rule=">="),
        "mu_v": Arg("viscous friction coefficient μ_v (times Fn)", "s/m", default=0, rule=">="),
        "slope": Arg("steepness s of tanh(s v) at v = 0 (20-sim 'slope')", "s/m", rule=">="),
        "v_st": Arg("Stribeck velocity v_st", "m/s", rule=">"),
    }
    relations = (("mu_c", "<=", "mu_st"),)

    def ports(self) -> list[Port]:
        return [Port("p", "translation", 2, "in", "world",
                     "contact point: effort = force of the body on the friction, flow = velocity")]

    def build(self, b: Builder, normal_force: sp.Expr | None, mu_st: sp.Expr, mu_c: sp.Expr,
              mu_v: sp.Expr, slope: sp.Expr, v_st: sp.Expr) -> None:
        contact, normal_force = normal_force_source(self, f"SCVSFriction {b.name!r}",
                                                    normal_force)
        tx = sp.Symbol(f"{contact}.tx", real=True)     # the contact's tangent (signals)
        tz = sp.Symbol(f"{contact}.tz", real=True)
        port = b.port("p")
        v = tx * port.f[0] + tz * port.f[1]
        mu = scvs_coefficient(v, mu_st, mu_c, mu_v, slope, v_st)
        fn = sp.Piecewise((normal_force, normal_force > 0), (0, True))
        b.equation(port.e, b.resistive(sp.Matrix([fn * mu * tx, fn * mu * tz]), port.f,
                                       "friction"),
                   "e = -Ft t (reaction of the SCVS friction force on the body)")
        b.dissipate(fn * mu * v)
        b.output("Ft", -fn * mu, "N")
        b.output("v", v, "m/s")
        b.output("mu", mu, "1")


__all__ = ["SCVSFriction", "normal_force_source", "scvs_coefficient"]
