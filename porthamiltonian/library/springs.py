"""Spring–dampers on a one-dimensional port: linear, with a variable (modulated) stiffness, and
with an actuated stiffness (a state with its own power port, :class:`ActuatedSpringDamper`).

Both components have one power port ``p`` (default domain translation, dimension 1, orientation
``"in"``) and one state ``q``, the spring's length (m; rad in the rotation domain), which
integrates the port flow: dq/dt = f (the rate of elongation, m/s). The elongation is
z = q − L0 with the ``rest_length`` L0 (m; default 0, then q is the elongation itself). The port
effort is the spring–damper force (N), positive in tension (it pulls the port's two ends
together when z > 0); power e·f is positive into the component.

A ``SpringDamper`` may instead read its length as a signal, ``length`` (an expression in other
components' states, e.g. ``"walker.q.leg1 - walker.q.leg2"`` for a torsional spring between two
legs): it then has no state, and its energy ½ K z² is paid through its port (like a contact's),
which must therefore carry the length's rate as its flow (the bonds' business: e.g. a
0-junction between the two joints' ports); the ledger's residual checks it. A spring whose length
is a configuration coordinate this way cannot drift from it (no state to initialize).

Laws
----
* ``SpringDamper`` (linear): e = K z + D ż, H = ½ K z², P_diss = D ż² ≥ 0. K (N/m) and D (N·s/m)
  may depend on parameters only.
* ``VariableSpringDamper``: H = ½ K z² with K any expression in time, states of other components
  and parameters (a modulation input, e.g. the thesis's (§3.2) K = K1 + (K2 − K1)|φ|/φ_max after
  mid-stance, with a mode parameter switched by events); e = ∂H/∂q + D ż (= K z + D ż unless K
  depends on q itself, then the force includes ½ (∂K/∂q) z², so that the storage stays
  conservative); P_diss = D ż². Abs/sign/Heaviside/Max/Min in K are rewritten as Piecewise so that
  the generated Jacobian has no Dirac deltas.

Damper rule (both): give ``damping`` D, or ``alpha`` α and ``mass`` m for D = 2 α √(m K)
(thesis §3.1: α ≈ 0.15, m = m + M the mass the leg carries; for a variable K the
damper follows the stiffness), or neither (no damper).

Energy role
-----------
Stored: ½ K z². Dissipated: D ż². Supplied: when K depends on time or on other components' states,
the compiler books the power the modulation injects, ∂H/∂K·K̇ = ½ K̇ z² (plus ∂H/∂x ẋ for each
foreign state x), as supplied energy E_in (``b.energy`` without ``via_ports``:
:mod:`porthamiltonian.compiler.assemble`). When K depends on a mode parameter switched by an
event action, H jumps by ½ ΔK z² at the event: return ``Reset(params=..., energy="supplied")``
from the action so the jump is booked as supplied energy (the default books it as dissipated).

Errors (:class:`~porthamiltonian.errors.ParameterValueError`, naming the component and argument):
stiffness, damping, alpha or mass < 0 (a number when the model compiles, a parameter value
whenever parameters are bound; a stiffness that depends on states or time is not checked); damping together with alpha; alpha without mass
(or mass without alpha); a ``SpringDamper`` stiffness or damping that depends on time or states
(use ``VariableSpringDamper``).

References: D. Karnopp, D. Margolis, R. Rosenberg, *System Dynamics*, 5th ed. (2012), ch. 4
(C- and R-elements, modulated storages); M. Jafarian (2010), MSc report 022CE2010, University of Twente, ch. 3.
"""
from __future__ import annotations

import sympy as sp

from ..errors import ParameterValueError
from ..modeling.component import Arg, Builder, Component, register
from ..modeling.differentiation import derivative
from ..modeling.ports import DOMAINS, Port

_COMMON = {
    "damping": Arg("damping coefficient D (or give alpha and mass)", "N*s/m", default=None,
                   rule=">="),
    "alpha": Arg("damping ratio α of the rule D = 2 α sqrt(m K)", "1", default=None, rule=">="),
    "mass": Arg("mass m of the rule D = 2 α sqrt(m K)", "kg", default=None, rule=">="),
    "rest_length": Arg("rest length L0 (elongation z = q - L0)", "m", default=0),
    "q0": Arg("initial length q(0) (default: the rest length)", "m", default=None),
    "length": Arg("the length as a signal (then no state; SpringDamper only)", "m", default=None),
    "domain": Arg("energy domain of the port", symbolic=False, default="translation"),
}


class _SpringDamper(Component):
    variable = False

    def ports(self) -> list[Port]:
        return [Port("p", self.value("domain"), orientation="in")]

    def build(self, b: Builder, stiffness: sp.Expr, damping: sp.Expr | None, alpha: sp.Expr | None,
              mass: sp.Expr | None, rest_length: sp.Expr, q0: sp.Expr | None, domain: str,
              length: sp.Expr | None) -> None:
        where = f"{self.kind} {b.name!r}"
        if damping is not None and (alpha is not None or mass is not None):
            raise ParameterValueError(f"{where}: give either 'damping' or 'alpha' and 'mass' (the "
                                      "rule D = 2 alpha sqrt(mass K)), not both")
        if (alpha is None) != (mass is None):
            raise ParameterValueError(f"{where}: the damper rule D = 2 alpha sqrt(mass K) needs "
                                      f"both 'alpha' and 'mass'; got only "
                                      f"{'alpha' if mass is None else 'mass'}")
        if self.variable:
            stiffness = stiffness.rewrite(sp.Piecewise) if stiffness.has(
                sp.Abs, sp.sign, sp.Heaviside, sp.Max, sp.Min) else stiffness
        else:
            params = set(b._names.values())
            for name, value in (("stiffness", stiffness), ("damping", damping)):
                if value is not None and not value.free_symbols <= params:
                    raise ParameterValueError(
                        f"{where} argument {name!r} = {self.value(name)!r} depends on time or "
                        "states; a SpringDamper is linear (parameters only): use "
                        "VariableSpringDamper for a modulated stiffness")
        port = b.port("p")
        dom = DOMAINS[domain]               # units: m and N/m, or rad and N*m/rad
        if length is not None:
            if self.variable:
                raise ParameterValueError(f"{where}: 'length' (a signal) is for a SpringDamper; "
                                          "a VariableSpringDamper integrates its own length")
            if q0 is not None:
                raise ParameterValueError(f"{where}: give 'length' (a signal) or 'q0' (the "
                                          "initial value of the length state), not both")
            z = length - rest_length
            energy = stiffness * z**2 / 2
            b.energy(energy, via_ports=True)
            force = b.stored_via_ports(stiffness * z)
        else:
            q = b.state("q", unit=dom.displacement_unit,
                        initial=rest_length if q0 is None else q0)
            z = q - rest_length
            energy = stiffness * z**2 / 2
            b.energy(energy)
            b.equation(b.der(q), port.f, "dq/dt = f")
            force = b.coenergy(q, derivative(energy, q))
        if damping is None:
            damping = 2 * alpha * sp.sqrt(mass * stiffness) if alpha is not None else sp.Integer(0)
        b.equation(port.e, force + b.resistive(damping * port.f, port.f, "damper"),
                   "e = dH/dq + D f")
        b.built.storage_ports.append("p")
        b.dissipate(damping * port.f**2)
        b.output("z", z, dom.displacement_unit)
        b.output("K", stiffness, f"{dom.effort_unit}/{dom.displacement_unit}")
        b.output("D", damping, f"{dom.effort_unit}*s/{dom.displacement_unit}")


@register
class SpringDamper(_SpringDamper):
    """Linear spring–damper e = K (q − L0) + D q̇ on a 1-D port.

    Ports: ``p`` (in). State: ``q`` length (m), dq/dt = f; none when ``length`` reads it as a
    signal (see the module docstring). Parameters: ``stiffness`` K (N/m), ``damping`` D (N·s/m)
    or ``alpha``/``mass`` for D = 2 α √(m K), ``rest_length`` L0 (m), ``q0`` (m). Energy ½ K z²;
    dissipation D ż². Outputs ``z``, ``K``, ``D``.
    """

    kind = "SpringDamper"
    arguments = {"stiffness": Arg("stiffness K (parameters only)", "N/m", rule=">="), **_COMMON}


@register
class VariableSpringDamper(_SpringDamper):
    """Spring–damper with a modulated stiffness K(t, x, p): H = ½ K z², e = ∂H/∂q + D q̇.

    Ports: ``p`` (in). State: ``q`` length (m). Parameters: ``stiffness`` K (N/m, any expression:
    the modulation input), ``damping`` D or ``alpha``/``mass`` (D = 2 α √(m K), following K),
    ``rest_length``, ``q0``. Energy ½ K z²; dissipation D ż²; supplied ½ K̇ z² (booked by the
    compiler). See the module docstring.
    """

    kind = "VariableSpringDamper"
    variable = True
    arguments = {"stiffness": Arg("stiffness K: expression in t, states and parameters", "N/m",
                                  rule=">="), **_COMMON}


@register
class ActuatedSpringDamper(Component):
    """Spring–damper whose stiffness K is a state, changed through its own power port ``k`` (a
    variable-stiffness actuator): H = ½ K z², e_p = K z + D ż, and on ``k`` (stiffness domain)
    flow K̇, effort ∂H/∂K = ½ z², so that whatever drives ``k`` (an Actuator imposing K̇) pays the
    power ½ z² K̇ the stiffening takes from it — the energy a VSA's motor spends, booked per
    actuator (:class:`porthamiltonian.library.signals.Actuator`) instead of as a modulation.

    Ports: ``p`` (in; the spring's length port), ``k`` (in; stiffness domain). States: ``q``
    length (m), ``K`` stiffness (N/m; initial ``stiffness0``). Damper: ``damping`` D, or
    ``alpha``/``mass`` for D = 2 α √(m K) following the state K. Energy ½ K z²; dissipation D ż².
    """

    kind = "ActuatedSpringDamper"
    arguments = {"stiffness0": Arg("initial stiffness K(0)", "N/m", rule=">="),
                 **{k: v for k, v in _COMMON.items() if k != "length"}}

    def ports(self) -> list[Port]:
        return [Port("p", self.value("domain"), orientation="in"),
                Port("k", "stiffness", orientation="in",
                     description="stiffness port: flow dK/dt, effort z^2/2")]

    def build(self, b: Builder, stiffness0: sp.Expr, damping: sp.Expr | None,
              alpha: sp.Expr | None, mass: sp.Expr | None, rest_length: sp.Expr,
              q0: sp.Expr | None, domain: str) -> None:
        where = f"{self.kind} {b.name!r}"
        if damping is not None and (alpha is not None or mass is not None):
            raise ParameterValueError(f"{where}: give either 'damping' or 'alpha' and 'mass'")
        if (alpha is None) != (mass is None):
            raise ParameterValueError(f"{where}: the damper rule D = 2 alpha sqrt(mass K) needs "
                                      "both 'alpha' and 'mass'")
        dom = DOMAINS[domain]
        port, kport = b.port("p"), b.port("k")
        q = b.state("q", unit=dom.displacement_unit, initial=rest_length if q0 is None else q0)
        K = b.state("K", unit=f"{dom.effort_unit}/{dom.displacement_unit}", initial=stiffness0)
        z = q - rest_length
        energy = K * z**2 / 2
        b.energy(energy)
        if damping is None:         # (K >= 0 physically; max(K, 0) keeps the root real anywhere)
            damping = (2 * alpha * sp.sqrt(mass * sp.Max(K, 0)) if alpha is not None
                       else sp.Integer(0))
        b.equation(b.der(q), port.f, "dq/dt = f")
        b.equation(b.der(K), kport.f, "dK/dt = f_k")
        b.equation(port.e, b.coenergy(q, derivative(energy, q))
                   + b.resistive(damping * port.f, port.f, "damper"), "e = dH/dq + D f")
        b.equation(kport.e, b.coenergy(K, derivative(energy, K)), "e_k = dH/dK = z^2/2")
        b.built.storage_ports += ["p", "k"]
        b.dissipate(damping * port.f**2)
        b.output("z", z, dom.displacement_unit)
        b.output("D", damping, f"{dom.effort_unit}*s/{dom.displacement_unit}")


__all__ = ["ActuatedSpringDamper", "SpringDamper", "VariableSpringDamper"]
