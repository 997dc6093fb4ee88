"""The bond-graph basics: storages (C, I, multiport), dissipators (R), sources (Se, Sf, modulated
by any expression), transformers (TF/MTF), gyrators (GY/MGY) and 0-/1-junctions.

Orientation follows :mod:`porthamiltonian.modeling.ports`: storages and dissipators have power-in ports,
sources power-out ports, TF/GY take power in on ``p1`` and give it out on ``p2``, junction ports are
set by their bonds. Every symbolic argument may depend on parameters, ``t`` and other states; a
storage whose energy so depends is *modulated* and the compiler books the power it receives from
the modulation as supplied.
"""
from __future__ import annotations

from collections.abc import Iterator
from typing import Any, ClassVar, TypeVar

import sympy as sp

from ..errors import ModelError
from .component import Arg, Builder, Component, ExpressionField, register
from .ports import DOMAINS, Port, domain


def _check_domain(value: object) -> None:
    """A domain name, or (a multiport storage) a table of them."""
    for name in value.values() if isinstance(value, dict) else [value]:
        if not isinstance(name, str):
            raise ModelError(f"a domain is a name ({', '.join(sorted(DOMAINS))}), got {name!r}")
        domain(name)


def _check_dim(value: object) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ModelError(f"R: dim must be a whole number >= 1, got {value!r}")


_DOMAIN = Arg("energy domain of the port(s)", symbolic=False, default="translation",
              check=_check_domain)


T = TypeVar("T")


def _exactly_one(kind: str, given: dict[str, T | None]) -> tuple[str, T]:
    """The one argument of ``given`` that is set: ``(name, value)``."""
    chosen = [(k, v) for k, v in given.items() if v is not None]
    if len(chosen) != 1:
        raise ModelError(f"{kind} needs exactly one of {', '.join(given)}; got "
                         f"{[k for k, _ in chosen] or 'none'}")
    return chosen[0]


class _OnePortIn(Component):
    def ports(self) -> list[Port]:
        return [Port("p", self.value("domain"), orientation="in")]


@register
class C(_OnePortIn):
    """Capacitive storage (spring, capacitor, tank).

    Ports: ``p`` (power in). State: ``q`` (displacement m, charge C, volume m^3...), dq/dt = f.
    Energy: ``energy`` in q, or ½ k q² with ``stiffness`` k, or q²/(2c) with ``compliance`` c.
    Effort e = ∂H/∂q (force, voltage, pressure).
    """

    kind = "C"
    arguments = {
        "domain": _DOMAIN,
        "stiffness": Arg("stiffness k (N/m, 1/F, ...)", default=None),
        "compliance": Arg("compliance c = 1/k (m/N, F, ...)", default=None, rule="!="),
        "energy": Arg("stored energy H(q) (J)", default=None, local=("q",)),
        "q0": Arg("initial value of q", default=0),
    }

    def build(self, b: Builder, domain: str, stiffness: sp.Expr | None, compliance: sp.Expr | None,
              energy: sp.Expr | None, q0: sp.Expr) -> None:
        chosen, law = _exactly_one("C", {"stiffness": stiffness, "compliance": compliance,
                                         "energy": energy})
        q = b.state("q", initial=q0)
        H = {"stiffness": lambda: law * q**2 / 2, "compliance": lambda: q**2 / (2 * law),
             "energy": lambda: law.xreplace({sp.Symbol("q", real=True): q})}[chosen]()
        b.storage(q, H, b.port("p"), "C")


@register
class I(_OnePortIn):
    """Inertial storage (mass, rotational inertia, inductor).

    Ports: ``p`` (power in). State: ``p`` (momentum N s, angular momentum, flux linkage), dp/dt = e.
    Energy: ``energy`` in p, or p²/(2 m) with ``inertance`` m (kg, kg m^2, H). Flow f = ∂H/∂p.
    """

    kind = "I"
    arguments = {
        "domain": _DOMAIN,
        "inertance": Arg("mass, moment of inertia or inductance (kg, kg m^2, H)", default=None,
                         rule=">"),
        "energy": Arg("stored energy H(p) (J)", default=None, local=("p",)),
        "p0": Arg("initial momentum", default=0),
    }

    def build(self, b: Builder, domain: str, inertance: sp.Expr | None, energy: sp.Expr | None,
              p0: sp.Expr) -> None:
        chosen, law = _exactly_one("I", {"inertance": inertance, "energy": energy})
        p = b.state("p", initial=p0)
        H = p**2 / (2 * law) if chosen == "inertance" else law.xreplace(
            {sp.Symbol("p", real=True): p})
        b.storage(p, H, b.port("p"), "I")


@register
class R(_OnePortIn):
    """Dissipator (damper, resistor, friction).

    Ports: ``p`` (power in; ``dim`` components, e.g. 2 for a body point in a plane). Law:
    e = ``resistance``·f (per component), or e = ``effort``(f), or f = ``flow``(e) (``dim`` 1).
    Dissipation: e·f (W), which must be >= 0 for a passive law.
    """

    kind = "R"
    arguments = {
        "domain": _DOMAIN,
        "resistance": Arg("linear resistance e/f (N s/m, Ohm, ...)", default=None, rule=">="),
        "effort": Arg("effort as a function of the flow f", default=None, local=("f",)),
        "flow": Arg("flow as a function of the effort e", default=None, local=("e",)),
        "dim": Arg("dimension of the port (a vector port: the linear law acts per component)",
                   symbolic=False, default=1, check=_check_dim),
    }

    def ports(self) -> list[Port]:
        return [Port("p", self.value("domain"), self.value("dim"), "in")]

    def build(self, b: Builder, domain: str, resistance: sp.Expr | None, effort: sp.Expr | None,
              flow: sp.Expr | None, dim: int) -> None:
        chosen, law = _exactly_one("R", {"resistance": resistance, "effort": effort, "flow": flow})
        if dim != 1 and chosen != "resistance":
            raise ModelError("R: a vector port (dim > 1) takes a linear 'resistance' only")
        port = b.port("p")
        if chosen == "resistance":
            b.equation(port.e, b.resistive(law * port.f, port.f), "e = R f")
        elif chosen == "effort":
            b.equation(port.e, b.resistive(law.xreplace({sp.Symbol("f", real=True): port.f}),
                                           port.f), "e = law(f)")
        else:
            b.equation(port.f, b.resistive(law.xreplace({sp.Symbol("e", real=True): port.e}),
                                           port.e), "f = law(e)")
        b.dissipate(port.power)


class _Source(Component):
    """An ideal source on port ``p`` (power out): the argument named :attr:`imposed` (``effort``
    or ``flow``) is imposed on that port variable, the other is the environment's; it supplies
    the power e·f. A source class names its imposed variable and that variable's units in its
    class statement (``class Se(_Source, imposed="effort", units="N, ...")``), which give its
    arguments: the domain and the imposed variable."""

    #: the imposed port variable, also the name of the argument that gives it
    imposed: ClassVar[str]

    def __init_subclass__(cls, imposed: str = "", units: str = "", **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if imposed:                     # (a subclass of Se or Sf keeps its base's)
            cls.imposed = imposed
            cls.arguments = {"domain": _DOMAIN, imposed: Arg(f"imposed {imposed} ({units})")}

    def ports(self) -> list[Port]:
        return [Port("p", self.value("domain"), orientation="out")]

    def build(self, b: Builder, domain: str, **value: sp.Expr) -> None:
        port = b.port("p")
        pair = (port.e, port.f) if self.imposed == "effort" else (port.f, port.e)
        b.equation(pair[0], b.source(value[self.imposed], pair[1]), f"{self.imposed[0]} = source")
        b.supply(port.power)


@register
class Se(_Source, imposed="effort", units="N, N m, V, Pa"):
    """Effort source (force, torque, voltage), modulated when ``effort`` depends on t or states.

    Ports: ``p`` (power out). Law: e = ``effort``. Supplied power: e·f.
    """

    kind = "Se"


@register
class Sf(_Source, imposed="flow", units="m/s, rad/s, A, m^3/s"):
    """Flow source (velocity, current), modulated when ``flow`` depends on t or states.

    Ports: ``p`` (power out). Law: f = ``flow``. Supplied power: e·f.
    """

    kind = "Sf"


class _TwoPort(Component):
    def ports(self) -> list[Port]:
        d1 = self.value("domain1") or self.value("domain")
        d2 = self.value("domain2") or self.value("domain")
        return [Port("p1", d1, orientation="in"), Port("p2", d2, orientation="out")]


@register
class TF(_TwoPort):
    """Transformer (lever, gear, ideal transformer); modulated (MTF) when ``ratio`` varies.

    Ports: ``p1`` (power in), ``p2`` (power out). Law: f2 = n f1, e1 = n e2 (power conserving).
    """

    kind = "TF"
    arguments = {"domain": _DOMAIN,
                 "domain1": Arg("domain of p1", symbolic=False, default=None, check=_check_domain),
                 "domain2": Arg("domain of p2", symbolic=False, default=None, check=_check_domain),
                 "ratio": Arg("transformer modulus n = f2/f1")}

    def build(self, b: Builder, domain: str, domain1: str | None, domain2: str | None,
              ratio: sp.Expr) -> None:
        p1, p2 = b.port("p1"), b.port("p2")
        b.equation(p2.f, ratio * p1.f, "f2 = n f1")
        b.equation(p1.e, ratio * p2.e, "e1 = n e2")


@register
class GY(_TwoPort):
    """Gyrator (DC motor constant, gyroscopic coupling); modulated (MGY) when ``ratio`` varies.

    Ports: ``p1`` (power in), ``p2`` (power out). Law: e1 = r f2, e2 = r f1 (power conserving).
    """

    kind = "GY"
    arguments = TF.arguments | {"ratio": Arg("gyrator modulus r (e.g. motor constant N m/A = V s/rad)")}

    def build(self, b: Builder, domain: str, domain1: str | None, domain2: str | None,
              ratio: sp.Expr) -> None:
        p1, p2 = b.port("p1"), b.port("p2")
        b.equation(p1.e, ratio * p2.f, "e1 = r f2")
        b.equation(p2.e, ratio * p1.f, "e2 = r f1")


class _Junction(Component):
    free_ports = True
    #: the variable all ports share: "e" (0-junction) or "f" (1-junction)
    common: ClassVar[str]
    arguments = {"domain": Arg("energy domain (default: that of the first bond)", symbolic=False,
                               default=None, check=_check_domain)}

    def build(self, b: Builder, domain: str | None) -> None:  # the compiler writes its laws
        pass

    def check_domain(self, port: Port) -> None:
        wanted = self.value("domain")
        if wanted is not None and port.domain != domain(wanted).name:
            raise ModelError(f"{self.kind}-junction of domain {wanted!r} cannot take a "
                             f"{port.domain} bond")


@register
class ZeroJunction(_Junction):
    """0-junction (common effort): all efforts equal, Σ in-flows = Σ out-flows."""

    kind = "0"
    common = "e"


@register
class OneJunction(_Junction):
    """1-junction (common flow): all flows equal, Σ in-efforts = Σ out-efforts."""

    kind = "1"
    common = "f"


@register
class Storage(Component):
    """Multiport storage defined by a Hamiltonian over several states.

    Arguments: ``energy`` H(states) in J; ``states`` maps each state name to its causality "C"
    (dq/dt = f, e = ∂H/∂q) or "I" (dp/dt = e, f = ∂H/∂p); ``domain`` a domain name for all ports
    or a mapping state -> domain; ``initial`` maps state names to initial values.
    Ports: one per state, named as the state (power in).
    """

    kind = "Storage"
    arguments = {
        "energy": Arg("Hamiltonian H over the states (J)", symbolic=False),
        "states": Arg("state name -> 'C' or 'I'", symbolic=False),
        "domain": _DOMAIN,
        "initial": Arg("state name -> initial value", symbolic=False, default=None),
    }

    def ports(self) -> list[Port]:
        dom = self.value("domain")
        return [Port(s, dom[s] if isinstance(dom, dict) else dom, orientation="in")
                for s in self.value("states")]

    def expression_fields(self) -> Iterator[ExpressionField]:
        """The energy (in the state names) and the initial values (see
        :meth:`Component.expression_fields`)."""
        states = self.value("states")
        names = tuple(states) if isinstance(states, dict) else ()
        yield ("energy",), self.value("energy"), "argument 'energy'", names
        initial = self.value("initial")
        for name, value in (initial.items() if isinstance(initial, dict) else ()):
            yield ("initial", name), value, f"initial value of state {name!r}", ()

    def build(self, b: Builder, energy: str, states: dict[str, str], domain: str | dict[str, str],
              initial: dict[str, Any] | None) -> None:
        initial = initial or {}
        symbols = {n: b.state(n, initial=initial.get(n, 0)) for n in states}
        H = b.parse(energy, "argument 'energy'", symbols)
        b.energy(H)
        for name, causality in states.items():
            b.storage_law(symbols[name], H, b.port(name), causality)
