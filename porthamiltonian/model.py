"""Model: components and bonds in a networkx graph, addressed by name; hierarchical sub-models.

A :class:`Model` is a description only (a builder, like Drake's DiagramBuilder): values of the
parameters given here are defaults, bound again at run time. ``Model.graph`` is a
``networkx.MultiDiGraph`` whose nodes are component names and whose edges are bonds, drawn in the
direction of positive power (tail -> head), with the port names as edge attributes.

Names: ``component.port`` for ports, ``component.state`` for states; inside a sub-model ``sub``
everything is prefixed ``sub.`` once flattened.
"""
from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import networkx as nx

from .component import Component
from .errors import (
    DanglingPortError,
    DuplicateNameError,
    ModelError,
    ParameterValueError,
    UnknownComponentError,
    UnknownPortError,
)
from .expressions import CONSTANTS, check_name
from .ports import Port, check_bond

#: names a parameter cannot take (the time, the constants of the expression language)
_RESERVED = {"t", *CONSTANTS}


@dataclass
class Parameter:
    """A model parameter: default value (SI), unit and description."""

    value: float
    unit: str = ""
    doc: str = ""

    def __post_init__(self) -> None:
        if isinstance(self.value, bool) or not isinstance(self.value, (int, float)):
            raise ParameterValueError(f"parameter value must be a number, got {self.value!r}")
        if not math.isfinite(self.value):
            raise ParameterValueError(f"parameter value must be finite, got {self.value!r}")
        self.value = float(self.value)


@dataclass(frozen=True)
class EventSpec:
    """A named event guard g(t, x, p) (an expression); fires when g crosses zero.

    ``direction`` +1 fires on rising crossings only, -1 on falling ones, 0 on both. ``terminal``
    events stop the integration unless the simulation has an action for them.
    """

    name: str
    guard: str
    direction: int = 0
    terminal: bool = False


@dataclass
class FlatModel:
    """A flattened model: full component names, bonds between full port names, all parameters."""

    name: str
    components: dict[str, Component]
    scopes: dict[str, str]                      # full component name -> prefix ("" or "sub.")
    bonds: list[tuple[tuple[str, str], tuple[str, str]]]   # ((tail comp, port), (head comp, port))
    parameters: dict[str, Parameter]
    events: list[EventSpec]
    outputs: dict[str, str] = field(default_factory=dict)


class Model:
    """A port-based model: named components, bonds and parameters.

    Example::

        m = Model("mass_spring_damper")
        m.parameter("k", 4.0, "N/m")
        m.add("spring", C(stiffness="k"))
        m.add("j", OneJunction())
        m.connect("j", "spring.p")        # power flows from the junction into the spring
    """

    def __init__(self, name: str = "model", doc: str = ""):
        self.name = name
        self.doc = doc
        self.graph = nx.MultiDiGraph()
        self.parameters: dict[str, Parameter] = {}
        self.exposed: dict[str, tuple[str, str]] = {}
        self.events: list[EventSpec] = []
        self.outputs: dict[str, str] = {}
        self.simulation: dict[str, Any] = {}
        #: the file this model was loaded from, if any (compile errors then name it)
        self.source: str | None = None
        #: further [model] keys of a model file, kept on save
        self.meta: dict[str, Any] = {}
        #: further top-level tables of a model file that other libraries read (e.g. [walker]),
        #: kept on save (porthamiltonian.io.PASSED_THROUGH)
        self.sections: dict[str, Any] = {}

    # --- construction ---------------------------------------------------------------------------
    def parameter(self, name: str, value: float, unit: str = "", doc: str = "") -> None:
        """Declare a parameter with its default value (SI units)."""
        if name in _RESERVED:
            raise ModelError(f"model {self.name!r}: {name!r} is not a valid parameter name (it "
                             "means the time or a constant in expressions)")
        check_name(name, f"model {self.name!r}: parameter name")
        if name in self.parameters:
            raise DuplicateNameError(f"model {self.name!r}: parameter {name!r} declared twice")
        try:
            self.parameters[name] = Parameter(value, unit, doc)
        except ParameterValueError as err:
            raise ParameterValueError(f"model {self.name!r} parameter {name!r}: {err}") from None

    def add(self, name: str, component: Component | Model) -> Component | Model:
        """Add a component (or a sub-model) under ``name``; return it."""
        check_name(name, f"model {self.name!r}: component name")
        if name in self.graph:
            raise DuplicateNameError(f"model {self.name!r}: a component is already called {name!r}")
        if not isinstance(component, (Component, Model)):
            raise ModelError(f"model {self.name!r}: {name!r} must be a Component or a Model, got "
                             f"{type(component).__name__}")
        self.graph.add_node(name, component=component)
        return component

    def component(self, name: str) -> Component | Model:
        """The component (or sub-model) called ``name``."""
        try:
            return self.graph.nodes[name]["component"]
        except KeyError:
            raise UnknownComponentError(
                f"model {self.name!r} has no component {name!r}; components: "
                f"{', '.join(self.graph.nodes) or 'none'}"
            ) from None

    def components(self) -> Iterator[tuple[str, Component | Model]]:
        for name, data in self.graph.nodes(data=True):
            yield name, data["component"]

    def _resolve(self, ref: str) -> tuple[str, str, Port | None]:
        """Resolve ``comp.port`` (or ``junction`` for a new junction port) to a port spec."""
        comp_name, _, port_name = ref.partition(".")
        comp = self.component(comp_name)
        if isinstance(comp, Model):
            if port_name not in comp.exposed:
                raise UnknownPortError(f"sub-model {comp_name!r} exposes no port {port_name!r}; "
                                       f"exposed: {', '.join(comp.exposed) or 'none'}")
            return comp_name, port_name, comp.port_spec(port_name)
        ports = {p.name: p for p in comp.all_ports()}
        if port_name in ports:
            return comp_name, port_name, ports[port_name]
        if comp.free_ports:
            return comp_name, port_name, None  # created once the other side is known
        raise UnknownPortError(
            f"component {comp_name!r} ({comp.kind}) has no port {port_name!r}; ports: "
            f"{', '.join(ports) or 'none'}"
        )

    def port_spec(self, exposed_name: str) -> Port:
        """The port spec behind an exposed port of this (sub-)model."""
        comp_name, port_name = self.exposed[exposed_name]
        return self._resolve(f"{comp_name}.{port_name}")[2]

    def connect(self, tail: str, head: str) -> None:
        """Bond from ``tail`` to ``head`` (power positive from tail to head).

        Each is ``component.port``, or a junction's name alone for a new junction port. Checks
        domain, dimension and orientation; raises a :class:`~porthamiltonian.errors.ConnectError`
        naming both ports.
        """
        t_comp, t_port, t_spec = self._resolve(tail)
        h_comp, h_port, h_spec = self._resolve(head)
        if t_spec is None and h_spec is None:
            declared = [self.component(c).value("domain") for c in (t_comp, h_comp)]
            domain = next((d for d in declared if d is not None), None)
            if domain is None:
                raise ModelError(f"cannot connect two new junction ports ({tail} -> {head}): the "
                                 "bond's domain is unknown; give one junction a 'domain'")
            t_spec = self._new_junction_port(t_comp, t_port, Port("bond", domain))
            t_port = t_spec.name
        if t_spec is None:
            t_spec = self._new_junction_port(t_comp, t_port, h_spec)
            t_port = t_spec.name
        if h_spec is None:
            h_spec = self._new_junction_port(h_comp, h_port, t_spec)
            h_port = h_spec.name
        check_bond(f"{t_comp}.{t_port}", t_spec, f"{h_comp}.{h_port}", h_spec)
        for comp, port in ((t_comp, t_port), (h_comp, h_port)):
            if self._bonded(comp, port):
                raise ModelError(f"port {comp}.{port} is already connected; a port takes one bond "
                                 "(use a junction to join more)")
        self.graph.add_edge(t_comp, h_comp, tail=t_port, head=h_port)

    def _new_junction_port(self, comp_name: str, port_name: str, like: Port) -> Port:
        junction = self.component(comp_name)
        junction.check_domain(like)
        return junction.new_port(like, port_name or None)

    def _bonded(self, comp: str, port: str) -> bool:
        return any((u == comp and d["tail"] == port) or (v == comp and d["head"] == port)
                   for u, v, d in self.graph.edges(data=True))

    def expose(self, name: str, target: str) -> None:
        """Expose the port ``target`` (``component.port``) of this model as its port ``name``."""
        comp_name, port_name, spec = self._resolve(target)
        if spec is None:
            junction = self.component(comp_name)
            if junction.value("domain") is None:
                raise ModelError(f"model {self.name!r}: give junction {comp_name!r} a domain to "
                                 "expose one of its ports")
            spec = junction.new_port(Port("x", junction.value("domain")), port_name or None)
            port_name = spec.name
        if name in self.exposed:
            raise DuplicateNameError(f"model {self.name!r} already exposes a port {name!r}")
        self.exposed[name] = (comp_name, port_name)

    def event(self, name: str, guard: str, direction: int = 0, terminal: bool = False) -> None:
        """Declare a named event guard (an expression in t, parameters, states and port variables)."""
        check_name(name, f"model {self.name!r}: event name")
        if direction not in (-1, 0, 1):
            raise ModelError(f"event {name!r}: direction must be -1, 0 or 1")
        if any(e.name == name for e in self.events):
            raise DuplicateNameError(f"model {self.name!r}: event {name!r} declared twice")
        self.events.append(EventSpec(name, guard, direction, terminal))

    def output(self, name: str, expression: str) -> None:
        """Declare a named output (an expression in t, parameters, states and port variables)."""
        check_name(name, f"model {self.name!r}: output name")
        if name in self.outputs:
            raise DuplicateNameError(f"model {self.name!r}: output {name!r} declared twice")
        self.outputs[name] = expression

    # --- flattening -----------------------------------------------------------------------------
    def flatten(self) -> FlatModel:
        """Flatten sub-models; check that every power port has exactly one bond."""
        flat = FlatModel(self.name, {}, {}, [], {}, [], {})
        self._flatten_into(flat, "")
        bonded = {end for bond in flat.bonds for end in bond}
        for name, comp in flat.components.items():
            for port in comp.all_ports():
                if (name, port.name) not in bonded and not port.optional:
                    raise DanglingPortError(
                        f"port {name}.{port.name} ({port.domain}) is not connected; connect it, "
                        "or remove the component"
                    )
        return flat

    def _flatten_into(self, flat: FlatModel, prefix: str) -> dict[tuple[str, str], tuple[str, str]]:
        for pname, par in self.parameters.items():
            flat.parameters[prefix + pname] = par
        ends: dict[tuple[str, str], tuple[str, str]] = {}  # (local comp, port) -> (full comp, port)
        for name, comp in self.components():
            if isinstance(comp, Model):
                inner = comp._flatten_into(flat, f"{prefix}{name}.")
                for exposed, target in comp.exposed.items():
                    ends[(name, exposed)] = inner[target]
            else:
                flat.components[prefix + name] = comp
                flat.scopes[prefix + name] = prefix
                for port in comp.all_ports():
                    ends[(name, port.name)] = (prefix + name, port.name)
        for u, v, data in self.graph.edges(data=True):
            flat.bonds.append((ends[(u, data["tail"])], ends[(v, data["head"])]))
        for ev in self.events:
            flat.events.append(EventSpec(prefix + ev.name, ev.guard, ev.direction, ev.terminal))
            flat.scopes.setdefault(f"event:{prefix}{ev.name}", prefix)
        for oname, expr in self.outputs.items():
            flat.outputs[prefix + oname] = expr
            flat.scopes.setdefault(f"output:{prefix}{oname}", prefix)
        return ends

    def __repr__(self) -> str:
        return (f"Model({self.name!r}: {self.graph.number_of_nodes()} components, "
                f"{self.graph.number_of_edges()} bonds, {len(self.parameters)} parameters)")
