"""Model: the builder of a port-based model, and the frozen description it ends in.

A :class:`Model` is a builder (like Drake's DiagramBuilder): components, bonds, parameters,
events and outputs, addressed by name; values of the parameters given here are defaults, bound
again at run time. ``Model.graph`` is a ``networkx.MultiDiGraph`` whose nodes are component names
and whose edges are bonds, drawn in the direction of positive power (tail -> head), with the port
names as edge attributes. A bond to a junction makes a new port *on the graph* (node attribute
``bond_ports``): components are immutable values, and one instance may serve in several models.

Building ends in :meth:`Model.freeze`: a :class:`ModelDescription`, flattened (sub-models
inlined), immutable, with a canonical text form (:meth:`ModelDescription.canonical`, what the
compiled-model cache keys on) and :meth:`ModelDescription.validate`, which collects every problem
(unconnected ports, expressions that do not parse or name unknown parameters, an empty model) and
raises them together (like ``sympy.physics.mechanics``' ``validate_system``). What a model file
adds (``[simulation]`` defaults, the description, tables for other libraries) is not part of the
model: see :class:`porthamiltonian.interfaces.io.ModelFile`.

Names: ``component.port`` for ports, ``component.state`` for states; inside a sub-model ``sub``
everything is prefixed ``sub.`` once flattened.
"""
from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Collection, Iterator, Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

import networkx as nx
import sympy as sp

from ..errors import (
    ConnectError,
    DanglingPortError,
    DuplicateNameError,
    ExpressionError,
    ModelError,
    ParameterValueError,
    UnknownComponentError,
    UnknownPortError,
    ValidationError,
)
from .component import Component
from .elements import _Junction
from .expressions import CONSTANTS, check_name, parse
from .ports import Port, check_bond

#: names a parameter cannot take (the time, the constants of the expression language)
_RESERVED = {"t", *CONSTANTS}

Path = tuple[str | int, ...]


@dataclass(frozen=True)
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
        object.__setattr__(self, "value", float(self.value))


@dataclass(frozen=True)
class Input:
    """A model input: a signal of time declared by the model (``[inputs]`` in a model file,
    :meth:`Model.input`), usable in every expression like a parameter, and bound when the model
    is simulated (:mod:`porthamiltonian.simulation.inputs`: a constant, samples held or
    interpolated, a Python callable, or a controller compiled into the model). ``unit``: its SI
    unit; ``doc``: one line."""

    unit: str = ""
    doc: str = ""
    #: an expression (e.g. a controller's output ``"pid.y"``) the input is bound to in the
    #: model: then it is compiled with the model and is no longer an input of the compiled model
    bind: str | None = None

    def __post_init__(self) -> None:
        for name in ("unit", "doc"):
            if not isinstance(getattr(self, name), str):
                raise ModelError(f"input {name} must be a string, got {getattr(self, name)!r}")
        if self.bind is not None and not isinstance(self.bind, (str, int, float)):
            raise ModelError(f"input bind must be an expression (text), got {self.bind!r}")


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


def _scope_path(prefix: str) -> Path:
    """The key path of the sub-model with flattened prefix ``prefix`` (``"a.b."``) in a model
    file: ``("components", "a", "model", "components", "b", "model")``."""
    return tuple(part for name in prefix.split(".")[:-1] for part in ("components", name, "model"))


def _jsonable(value: Any) -> Any:
    """``value`` for the canonical JSON text: sympy expressions and other objects by their text,
    numpy arrays as lists, dataclass records as tables."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"record": type(value).__name__, **dataclasses.asdict(value)}
    if hasattr(value, "tolist"):
        return value.tolist()
    return str(value)


#: a bond: ``((tail component, port), (head component, port))``
Bond = tuple[tuple[str, str], tuple[str, str]]


@dataclass(frozen=True)
class ModelDescription:
    """A model, flattened and frozen: what the compiler reads.

    Attributes (read-only mappings, in the order of the model)
    ----------------------------------------------------------
    name : the model's name.
    components : full component name (``sub.spring``) -> component.
    ports : full component name -> its ports (declared ones, then those its bonds made).
    bonds : ``((tail component, port), (head component, port))``, full names.
    parameters : full parameter name -> :class:`Parameter`.
    events, outputs : the model events (full names) and outputs (full name -> expression).
    inputs : full input name -> :class:`Input` (signals bound at run time).
    scopes : full component name, ``"event:<name>"`` or ``"output:<name>"`` -> the prefix of the
        (sub-)model it was declared in (``""`` or ``"sub."``); names in its expressions are local
        to that scope.
    paths : the same keys -> the key path of its declaration in a model file (for errors).
    """

    name: str
    components: Mapping[str, Component]
    ports: Mapping[str, tuple[Port, ...]]
    bonds: tuple[Bond, ...]
    parameters: Mapping[str, Parameter]
    events: tuple[EventSpec, ...]
    outputs: Mapping[str, str]
    scopes: Mapping[str, str]
    paths: Mapping[str, Path]
    inputs: Mapping[str, Input] = field(default_factory=lambda: MappingProxyType({}))
    #: what :meth:`problems` found in each expression, by (scope key, key path, names taken to
    #: exist), and :meth:`scope_names` by prefix: a description is read, laid out and compiled,
    #: each validating it, and its expressions do not change (:meth:`with_outputs` hands the
    #: first on to the description it makes; ``dataclasses.replace`` starts afresh)
    _memo: dict[Any, Any] = field(default_factory=dict, init=False, compare=False, repr=False)

    def scope_names(self, prefix: str) -> dict[str, sp.Symbol]:
        """The parameters and inputs visible in the scope ``prefix``, by their local names (the
        symbols carry the full names); a new dict at each call."""
        found = self._memo.get(("scope", prefix))
        if found is None:
            found = self._memo[("scope", prefix)] = {
                full[len(prefix):]: sp.Symbol(full, real=True)
                for full in (*self.parameters, *self.inputs)
                if full.startswith(prefix) and "." not in full[len(prefix):]}
        return dict(found)

    def input_symbols(self) -> set[sp.Symbol]:
        """The symbols of the model's inputs (full names)."""
        return {sp.Symbol(name, real=True) for name in self.inputs}

    def in_scope(self, prefix: str) -> set[str]:
        """The local names of the components (and sub-models) of the scope ``prefix``."""
        return {n[len(prefix):].split(".")[0] for n in self.components if n.startswith(prefix)}

    def with_outputs(self, outputs: Mapping[str, str]) -> ModelDescription:
        """This description with more model outputs, declared at its top level (as
        :meth:`Model.output` then :meth:`Model.freeze` would give, without freezing again): each
        an expression over the model's parameters, states, port variables and outputs."""
        for name in outputs:
            check_name(name, f"model {self.name!r}: output name")
            if name in self.outputs:
                raise DuplicateNameError(f"model {self.name!r}: output {name!r} declared twice")
        new = dict(outputs)
        made = dataclasses.replace(
            self, outputs=MappingProxyType({**self.outputs, **new}),
            scopes=MappingProxyType({**self.scopes, **{f"output:{n}": "" for n in new}}),
            paths=MappingProxyType({**self.paths, **{f"output:{n}": ("outputs", n) for n in new}}))
        made._memo.update(self._memo)     # the same parameters, inputs, components and scopes
        return made

    # --- canonical form ----------------------------------------------------------------------
    def canonical(self) -> str:
        """A canonical text (JSON) of everything in the description that determines the
        compiled model: the name, parameters (value and unit), components (kind, class, arguments,
        ports) in order, bonds, events, outputs and scopes. Equal descriptions give equal texts;
        parameter docs and anything a model file adds (descriptions, ``[simulation]``) are not in
        it."""
        data = {
            "name": self.name,
            "parameters": [[n, p.value, p.unit] for n, p in self.parameters.items()],
            "components": [[n, c.kind, f"{type(c).__module__}.{type(c).__qualname__}",
                            dict(c.args), [dataclasses.astuple(p) for p in self.ports[n]]]
                           for n, c in self.components.items()],
            "bonds": [list(b) for b in self.bonds],
            "events": [dataclasses.astuple(e) for e in self.events],
            "outputs": list(self.outputs.items()),
            "scopes": sorted(self.scopes.items()),
        }
        if self.inputs:
            data["inputs"] = [[n, i.unit, i.bind] for n, i in self.inputs.items()]
        return json.dumps(data, sort_keys=True, default=_jsonable, separators=(",", ":"))

    # --- validation --------------------------------------------------------------------------
    def problems(self, *, missing: Collection[str] | None = None) -> list[ModelError]:
        """Every problem of the description, each a typed error with its path: an empty model,
        unconnected ports, expressions (component arguments, event guards, outputs) that do not
        parse or name unknown parameters. Whether a dotted name (``spring.q``) exists is checked
        when the model compiles.

        ``missing``: the full names of components and parameters a reader could not read (their
        problems are reported already); then only the expressions are checked, with those names
        taken to exist, so that nothing is reported twice."""
        found: list[ModelError] = []
        if missing is None:
            found += self._structure_problems()
        for name, comp in self.components.items():
            for path, value, what, local in comp.expression_fields():
                found += self._parse_problem(value, f"component {name!r} {what}", name, local,
                                             (*self.paths[name], *path), missing or ())
        for event in self.events:
            key = f"event:{event.name}"
            found += self._parse_problem(event.guard, f"event {event.name!r} guard", key, (),
                                         (*self.paths[key], "guard"), missing or ())
        for name, text in self.outputs.items():
            key = f"output:{name}"
            found += self._parse_problem(text, f"output {name!r}", key, (), self.paths[key],
                                         missing or ())
        for name, signal in self.inputs.items():
            if signal.bind is not None:
                key = f"input:{name}"
                found += self._parse_problem(signal.bind, f"input {name!r} binding", key, (),
                                             (*self.paths[key], "bind"), missing or ())
        return found

    def _structure_problems(self) -> list[ModelError]:
        if not self.components:
            return [ModelError(f"model {self.name!r} is empty: it has no components; add some (in "
                               "a model file: [components.NAME] tables with a type) before "
                               "compiling")]
        found: list[ModelError] = []
        bonded = {end for bond in self.bonds for end in bond}
        for name, ports in self.ports.items():
            for port in ports:
                if (name, port.name) not in bonded and not port.optional:
                    found.append(DanglingPortError(
                        f"port {name}.{port.name} ({port.domain}) is not connected; connect it, or "
                        "remove the component", path=self.paths[name]))
        return found

    def _parse_problem(self, text: Any, where: str, key: str, local: tuple[str, ...],
                       path: Path, missing: Collection[str]) -> list[ModelError]:
        memo = ("problems", key, path, tuple(sorted(missing)))
        found = self._memo.get(memo)
        if found is None:
            found = self._memo[memo] = self._parsed(text, where, key, local, path, missing)
        return list(found)

    def _parsed(self, text: Any, where: str, key: str, local: tuple[str, ...], path: Path,
                missing: Collection[str]) -> list[ModelError]:
        prefix = self.scopes[key]
        absent = {n[len(prefix):] for n in missing
                  if n.startswith(prefix) and "." not in n[len(prefix):]}
        scope = self.in_scope(prefix) | absent
        names = {**self.scope_names(prefix), **{n: sp.Symbol(n, real=True) for n in local},
                 **{n: sp.Symbol(prefix + n, real=True) for n in absent}}

        def dotted(ref: str) -> sp.Symbol | None:
            return sp.Symbol(prefix + ref, real=True) if ref.split(".")[0] in scope else None

        try:
            parse(text, names, where, dotted)
        except ModelError as err:
            return [err.within(*path)]
        except Exception as err:  # noqa: BLE001 - sympy failing its own way: still a model error
            return [ExpressionError(f"{where}: cannot parse {text!r} ({type(err).__name__}: "
                                    f"{err})", path=path)]
        return []

    def validate(self) -> ModelDescription:
        """This description if it has no problem (:meth:`problems`); else raise: the problem
        itself when there is one (its own type: DanglingPortError, UnknownParameterError, ...), a
        :class:`~porthamiltonian.errors.ValidationError` listing them all when there are more."""
        found = self.problems()
        if len(found) == 1:
            raise found[0]
        if found:
            raise ValidationError(f"model {self.name!r} has {len(found)} problems:\n" + "\n".join(
                f"  {error}" for error in found), problems=found)
        return self


class Model:
    """A port-based model: named components, bonds and parameters.

    Example::

        m = Model("mass_spring_damper")
        m.parameter("k", 4.0, "N/m")
        m.add("spring", C(stiffness="k"))
        m.add("j", OneJunction())
        m.connect("j", "spring.p")        # power flows from the junction into the spring
    """

    def __init__(self, name: str = "model"):
        self.name = name
        self.graph: nx.MultiDiGraph[str] = nx.MultiDiGraph()
        self.parameters: dict[str, Parameter] = {}
        self.exposed: dict[str, tuple[str, str]] = {}
        self.events: list[EventSpec] = []
        self.outputs: dict[str, str] = {}
        self.inputs: dict[str, Input] = {}
        #: exposed port -> "effort" or "flow": what the environment imposes there when it is
        #: left open (see :meth:`expose`)
        self._open_causality: dict[str, str] = {}

    # --- construction ---------------------------------------------------------------------------
    def _check_value_name(self, name: str, what: str) -> None:
        """A parameter's or input's name: a plain name, not reserved, not taken by either."""
        if name in _RESERVED:
            raise ModelError(f"model {self.name!r}: {name!r} is not a valid {what} name (it "
                             "means the time or a constant in expressions)")
        check_name(name, f"model {self.name!r}: {what} name")
        if name in self.parameters or name in self.inputs:
            taken = "parameter" if name in self.parameters else "input"
            raise DuplicateNameError(f"model {self.name!r}: {name!r} is declared twice (already "
                                     f"a {taken})")

    def parameter(self, name: str, value: float, unit: str = "", doc: str = "") -> None:
        """Declare a parameter with its default value (SI units)."""
        self._check_value_name(name, "parameter")
        self._unclaimed(name, "parameter")
        try:
            self.parameters[name] = Parameter(value, unit, doc)
        except ParameterValueError as err:
            raise ParameterValueError(f"model {self.name!r} parameter {name!r}: {err}") from None

    def input(self, name: str, unit: str = "", doc: str = "", bind: str | None = None) -> None:
        """Declare an input ``name`` (SI ``unit``): a signal of time that every expression may
        read like a parameter (e.g. ``Se(effort="F")``), bound when the model is simulated
        (``simulate(..., inputs={"F": ...})``: a constant, samples, a callable; see
        :mod:`porthamiltonian.simulation.inputs`) and a column of the linearization's B and D.
        ``bind``: an expression to bind it to in the model instead (:meth:`bind_input`)."""
        self._check_value_name(name, "input")
        self._unclaimed(name, "input")
        self.inputs[name] = Input(unit, doc, bind)

    def bind_input(self, name: str, expression: str | None) -> None:
        """Bind the input ``name`` to ``expression`` in the model — typically a controller's
        output (``"pid.y"``) or any signal (``"2*sin(t)"``): the binding is compiled with the
        model (the compiled model no longer has that input); None unbinds it. Swapping the
        controller is :meth:`replace`."""
        if name not in self.inputs:
            raise ModelError(f"model {self.name!r} has no input {name!r}; inputs: "
                             f"{', '.join(self.inputs) or 'none'}")
        self.inputs[name] = replace(self.inputs[name], bind=expression)

    def add(self, name: str, component: Component | Model) -> Component | Model:
        """Add a component (or a sub-model) under ``name``; return it. The component is a value:
        the model records its bonds (and a junction's ports) itself, so one instance may serve
        in several models, or under several names."""
        check_name(name, f"model {self.name!r}: component name")
        if name in self.graph:
            raise DuplicateNameError(f"model {self.name!r}: a component is already called {name!r}")
        self._unclaimed(name, "component")
        if not isinstance(component, (Component, Model)):
            raise ModelError(f"model {self.name!r}: {name!r} must be a Component or a Model, got "
                             f"{type(component).__name__}")
        self.graph.add_node(name, component=component, bond_ports={})
        return component

    def replace(self, name: str, component: Component | Model) -> Component | Model:
        """Put ``component`` in place of the component called ``name``, keeping its bonds (by
        port name): the swap of a contact law or a spring for another. Every bond of ``name`` is
        checked again as :meth:`connect` checks it (the port exists; domain, dimension and
        orientation match); on a mismatch nothing changes and the
        :class:`~porthamiltonian.errors.ConnectError` (or UnknownPortError) names the bond.
        Returns the new component."""
        old = self.component(name)                            # UnknownComponentError if absent
        if not isinstance(component, (Component, Model)):
            raise ModelError(f"model {self.name!r}: {name!r} must be a Component or a Model, got "
                             f"{type(component).__name__}")
        self.graph.nodes[name]["component"] = component
        try:
            for u, v, d in self.graph.edges(data=True):
                if name in (u, v):
                    tail, head = f"{u}.{d['tail']}", f"{v}.{d['head']}"
                    t_spec, h_spec = self._resolve(tail)[2], self._resolve(head)[2]
                    if t_spec is not None and h_spec is not None:
                        check_bond(tail, t_spec, head, h_spec)
        except ModelError:
            self.graph.nodes[name]["component"] = old
            raise
        return component

    def component(self, name: str) -> Component | Model:
        """The component (or sub-model) called ``name``."""
        try:
            comp: Component | Model = self.graph.nodes[name]["component"]
        except KeyError:
            raise UnknownComponentError(
                f"model {self.name!r} has no component {name!r}; components: "
                f"{', '.join(self.graph.nodes) or 'none'}"
            ) from None
        return comp

    def _junction(self, name: str) -> _Junction:
        """The junction called ``name``: a component whose bonds make its ports (for which
        :meth:`_resolve` gives no port spec until the bond is made)."""
        comp = self.component(name)
        if not isinstance(comp, _Junction):
            raise ModelError(f"model {self.name!r}: component {name!r} declares free ports but is "
                             "no junction; only junctions make ports as they are bonded")
        return comp

    def _existing(self, ref: str) -> Port:
        """The spec of the existing port ``ref`` (``component.port``)."""
        comp_name, port_name, spec = self._resolve(ref)
        if spec is None:
            raise UnknownPortError(f"model {self.name!r}: junction {comp_name!r} has no port "
                                   f"{port_name!r}")
        return spec

    def components(self) -> Iterator[tuple[str, Component | Model]]:
        """``(name, component or sub-model)`` in the order they were added."""
        for name, data in self.graph.nodes(data=True):
            yield name, data["component"]

    def ports(self, name: str) -> list[Port]:
        """The power ports of component ``name`` in this model: those it declares, then the ports
        its bonds made on it (a junction's)."""
        comp = self.component(name)
        if isinstance(comp, Model):
            return [replace(comp.port_spec(exposed), name=exposed) for exposed in comp.exposed]
        return [*comp.ports(), *self.graph.nodes[name]["bond_ports"].values()]

    def _resolve(self, ref: str) -> tuple[str, str, Port | None]:
        """Resolve ``comp.port`` (or ``junction`` for a new junction port) to a port spec."""
        comp_name, _, port_name = ref.partition(".")
        comp = self.component(comp_name)
        if isinstance(comp, Model):
            if port_name not in comp.exposed:
                raise UnknownPortError(f"sub-model {comp_name!r} exposes no port {port_name!r}; "
                                       f"exposed: {', '.join(comp.exposed) or 'none'}")
            return comp_name, port_name, comp.port_spec(port_name)
        ports = {p.name: p for p in self.ports(comp_name)}
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
        return self._existing(f"{comp_name}.{port_name}")

    def connect(self, tail: str, head: str) -> None:
        """Bond from ``tail`` to ``head`` (power positive from tail to head).

        Each is ``component.port``, or a junction's name alone for a new junction port. Checks
        domain, dimension and orientation; raises a :class:`~porthamiltonian.errors.ConnectError`
        naming both ports.
        """
        for end, ref in (("tail", tail), ("head", head)):
            if not isinstance(ref, str):
                raise ConnectError(f"model {self.name!r}: connect's {end} must be a string "
                                   f"\"component.port\" (or a junction's name), got "
                                   f"{type(ref).__name__} {ref!r}")
        t_comp, t_port, t_spec = self._resolve(tail)
        h_comp, h_port, h_spec = self._resolve(head)
        new: list[tuple[str, Port]] = []     # junction ports this bond makes (kept if it is made)
        if t_spec is None:
            like = h_spec
            if like is None:
                declared = [self._junction(c).value("domain") for c in (t_comp, h_comp)]
                domain = next((d for d in declared if d is not None), None)
                if domain is None:
                    raise ModelError(f"cannot connect two new junction ports ({tail} -> {head}): "
                                     "the bond's domain is unknown; give one junction a 'domain'")
                like = Port("bond", domain)
            t_spec = self._junction_port(t_comp, t_port, like, new)
            t_port = t_spec.name
        if h_spec is None:
            h_spec = self._junction_port(h_comp, h_port, t_spec, new)
            h_port = h_spec.name
        check_bond(f"{t_comp}.{t_port}", t_spec, f"{h_comp}.{h_port}", h_spec)
        for comp, port in ((t_comp, t_port), (h_comp, h_port)):
            if self._bonded(comp, port):
                raise ModelError(f"port {comp}.{port} is already connected; a port takes one bond "
                                 "(use a junction to join more)")
        for comp, made in new:
            self.graph.nodes[comp]["bond_ports"][made.name] = made
        self.graph.add_edge(t_comp, h_comp, tail=t_port, head=h_port)

    def _junction_port(self, comp_name: str, port_name: str, like: Port,
                       pending: list[tuple[str, Port]]) -> Port:
        """A new port of the junction ``comp_name`` matching ``like`` (domain, dimension, frame),
        named ``port_name`` or ``p<k>``, appended to ``pending``: the caller keeps the pending
        ports on this model's graph once the bond is made (the junction itself never changes)."""
        junction = self._junction(comp_name)
        junction.check_domain(like)
        made = self.graph.nodes[comp_name]["bond_ports"]
        name = port_name or f"p{len(made) + 1 + sum(c == comp_name for c, _ in pending)}"
        if name in made:
            raise DuplicateNameError(f"model {self.name!r}: junction {comp_name!r} already has a "
                                     f"port {name!r}")
        port = Port(name, like.domain, like.dim, None, like.frame)
        pending.append((comp_name, port))
        return port

    def _bonded(self, comp: str, port: str) -> bool:
        return any((u == comp and d["tail"] == port) or (v == comp and d["head"] == port)
                   for u, v, d in self.graph.edges(data=True))

    def expose(self, name: str, target: str, causality: str | None = None) -> None:
        """Expose the port ``target`` (``component.port``) of this model as its port ``name``.

        A port this model exposes and leaves unconnected when it is compiled on its own is an
        open power port at the model's boundary: an input/output pair. The environment imposes
        the port's effort (``causality="effort"``, the default) or flow (``"flow"``) as the input
        ``name`` (its unit the domain's), the conjugate variable is the declared output
        ``<name>.y``, and the power input × output goes to the ledger as supplied (an effort or
        flow source named ``name`` stands at the port)."""
        if causality not in (None, "effort", "flow"):
            raise ModelError(f"model {self.name!r}: exposed port {name!r}: causality must be "
                             f"'effort' or 'flow', got {causality!r}")
        comp_name, port_name, spec = self._resolve(target)
        new: list[tuple[str, Port]] = []
        if spec is None:
            junction = self._junction(comp_name)
            if junction.value("domain") is None:
                raise ModelError(f"model {self.name!r}: give junction {comp_name!r} a domain to "
                                 "expose one of its ports")
            spec = self._junction_port(comp_name, port_name, Port("x", junction.value("domain")),
                                       new)
            port_name = spec.name
        if name in self.exposed:
            raise DuplicateNameError(f"model {self.name!r} already exposes a port {name!r}")
        for comp, port in new:
            self.graph.nodes[comp]["bond_ports"][port.name] = port
        self.exposed[name] = (comp_name, port_name)
        self._open_causality[name] = causality or "effort"

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
        self._unclaimed(name, "output")
        self.outputs[name] = expression

    def _unclaimed(self, name: str, kind: str) -> None:
        """Refuse a new ``kind`` called ``name`` when a parameter, input, component or output of
        this model already has that name: they share one namespace (``k`` in an expression, or in
        ``trajectory["k"]``, must mean one thing)."""
        for other, taken in (("parameter", name in self.parameters),
                             ("input", name in self.inputs),
                             ("component", name in self.graph),
                             ("output", name in self.outputs)):
            if taken and other != kind:
                raise DuplicateNameError(f"model {self.name!r}: the {kind} {name!r} has the name "
                                         f"of its {other} {name!r}; parameters, inputs, components "
                                         "and outputs share one namespace: rename one of them")

    # --- the frozen description ------------------------------------------------------------------
    def freeze(self) -> ModelDescription:
        """The frozen, flattened :class:`ModelDescription` of this model as it is now (later
        changes to the model do not reach it). Not checked: see :meth:`validate`."""
        parts: dict[str, dict[str, Any]] = {key: {} for key in (
            "components", "ports", "parameters", "outputs", "scopes", "paths", "inputs")}
        bonds: list[Bond] = []
        events: list[EventSpec] = []
        ends = self._flatten_into(parts, bonds, events, "")
        self._open_ports(parts, bonds, ends)
        frozen = {key: MappingProxyType(value) for key, value in parts.items()}
        return ModelDescription(self.name, bonds=tuple(bonds), events=tuple(events), **frozen)

    def _open_ports(self, parts: dict[str, dict[str, Any]], bonds: list[Bond],
                    ends: dict[tuple[str, str], tuple[str, str]]) -> None:
        """The exposed ports of this (top-level) model left unconnected: each an effort (or flow)
        source named as the port, driven by the input of that name, its conjugate the declared
        output ``<name>.y`` (see :meth:`expose`)."""
        from .elements import Se, Sf
        from .ports import domain

        bonded = {end for bond in bonds for end in bond}
        for name, (comp, port) in self.exposed.items():
            end = ends[(comp, port)]
            if end in bonded:
                continue
            spec = self._existing(f"{comp}.{port}")
            if spec.dim != 1 or spec.orientation == "out":
                raise ModelError(f"model {self.name!r}: exposed port {name!r} ({comp}.{port}) is "
                                 "left open, but only a one-dimensional port that takes power "
                                 "in can be an input/output pair; connect it (e.g. to a source)")
            if name in parts["components"] or name in parts["inputs"] or name in parts["parameters"]:
                raise DuplicateNameError(f"model {self.name!r}: the open port {name!r} needs the "
                                         "name for its source and input; rename the port")
            dom = domain(spec.domain)
            effort = self._open_causality.get(name, "effort") == "effort"
            source = (Se(effort=name, domain=spec.domain) if effort
                      else Sf(flow=name, domain=spec.domain))
            parts["components"][name] = source
            parts["ports"][name] = tuple(source.ports())
            parts["scopes"][name] = ""
            parts["paths"][name] = ("exposed", name)
            parts["inputs"][name] = Input(dom.effort_unit if effort else dom.flow_unit,
                                          f"open port {name}: the {'effort' if effort else 'flow'}"
                                          " the environment imposes")
            parts["scopes"][f"input:{name}"] = ""
            parts["paths"][f"input:{name}"] = ("exposed", name)
            output = f"{name}.y"
            parts["outputs"][output] = f"{name}.p.{'f' if effort else 'e'}"
            parts["scopes"][f"output:{output}"] = ""
            parts["paths"][f"output:{output}"] = ("exposed", name)
            bonds.append(((name, "p"), end))

    def validate(self) -> ModelDescription:
        """The frozen description, checked: every problem at once (see
        :meth:`ModelDescription.validate`)."""
        return self.freeze().validate()

    def _flatten_into(self, parts: dict[str, dict[str, Any]], bonds: list[Bond],
                      events: list[EventSpec],
                      prefix: str) -> dict[tuple[str, str], tuple[str, str]]:
        here = _scope_path(prefix)
        for pname, par in self.parameters.items():
            parts["parameters"][prefix + pname] = par
        for iname, signal in self.inputs.items():
            parts["inputs"][prefix + iname] = signal
            parts["scopes"].setdefault(f"input:{prefix}{iname}", prefix)
            parts["paths"].setdefault(f"input:{prefix}{iname}", (*here, "inputs", iname))
        ends: dict[tuple[str, str], tuple[str, str]] = {}  # (local comp, port) -> (full comp, port)
        for name, comp in self.components():
            if isinstance(comp, Model):
                inner = comp._flatten_into(parts, bonds, events, f"{prefix}{name}.")
                for exposed, target in comp.exposed.items():
                    ends[(name, exposed)] = inner[target]
            else:
                full = prefix + name
                parts["components"][full] = comp
                parts["scopes"][full] = prefix
                parts["paths"][full] = (*here, "components", name)
                parts["ports"][full] = tuple(self.ports(name))
                for port in parts["ports"][full]:
                    ends[(name, port.name)] = (full, port.name)
        for u, v, data in self.graph.edges(data=True):
            bonds.append((ends[(u, data["tail"])], ends[(v, data["head"])]))
        for index, ev in enumerate(self.events):
            key = f"event:{prefix}{ev.name}"
            events.append(EventSpec(prefix + ev.name, ev.guard, ev.direction, ev.terminal))
            parts["scopes"].setdefault(key, prefix)
            parts["paths"].setdefault(key, (*here, "events", index))
        for oname, expr in self.outputs.items():
            key = f"output:{prefix}{oname}"
            parts["outputs"][prefix + oname] = expr
            parts["scopes"].setdefault(key, prefix)
            parts["paths"].setdefault(key, (*here, "outputs", oname))
        return ends

    def __repr__(self) -> str:
        return (f"Model({self.name!r}: {self.graph.number_of_nodes()} components, "
                f"{self.graph.number_of_edges()} bonds, {len(self.parameters)} parameters)")
