"""The FMU's XML files: ``modelDescription.xml`` (FMI 2.0 and 3.0) and, for FMI 3.0,
``sources/buildDescription.xml``.

Written with :mod:`xml.etree.ElementTree` (every attribute escaped; characters XML 1.0 does not
allow are dropped from names and descriptions). The elements and attributes are those of the
standards' schemas, in their order; ``fmpy.validation.validate_fmu`` checks the result in the
tests. Variables come from :func:`~.variables.variable_table`.
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass

from .units import BASE, base_unit
from .variables import Variable

__all__ = ["Experiment", "Interface", "build_description", "model_description"]

_XML_BAD = re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")
_STRUCTURED = re.compile(r"^(?:der\()?[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*\)?$")
#: the log categories the runtime writes under
LOG_CATEGORIES = (("logEvents", "events, their rules and the end of a run"),
                  ("logStatusError", "errors: what was refused or failed, and why"))


@dataclass(frozen=True)
class Experiment:
    """The DefaultExperiment: start and stop time (s), tolerance, output step (s)."""

    start: float
    stop: float | None
    tolerance: float
    step: float | None


@dataclass(frozen=True)
class Interface:
    """What the FMU offers: its model identifier, model exchange and/or co-simulation, the
    source files of its sources/ folder (the one to compile first)."""

    identifier: str
    model_exchange: bool
    co_simulation: bool
    sources: tuple[str, ...]


def _text(value: str) -> str:
    return _XML_BAD.sub("", value)


def _number(value: float) -> str:
    return repr(float(value))


def _naming(variables: Sequence[Variable]) -> str:
    ok = all(_STRUCTURED.match(v.name) and (v.name.startswith("der(") == v.name.endswith(")"))
             for v in variables)
    return "structured" if ok else "flat"


def _units(parent: ET.Element, variables: Sequence[Variable]) -> None:
    units = sorted({v.unit for v in variables if v.unit})
    if not units:
        return
    defs = ET.SubElement(parent, "UnitDefinitions")
    for unit in units:
        el = ET.SubElement(defs, "Unit", name=_text(unit))
        base = base_unit(unit)
        if base is not None:
            factor, exponents = base
            attrs = {k: str(exponents[k]) for k in BASE if k in exponents}
            if factor != 1.0:
                attrs["factor"] = _number(factor)
            ET.SubElement(el, "BaseUnit", attrs)


def _head(root: ET.Element, variables: Sequence[Variable], experiment: Experiment) -> None:
    _units(root, variables)
    cats = ET.SubElement(root, "LogCategories")
    for name, doc in LOG_CATEGORIES:
        ET.SubElement(cats, "Category", name=name, description=doc)
    attrs = {"startTime": _number(experiment.start), "tolerance": _number(experiment.tolerance)}
    if experiment.stop is not None:
        attrs["stopTime"] = _number(experiment.stop)
    if experiment.step is not None:
        attrs["stepSize"] = _number(experiment.step)
    ET.SubElement(root, "DefaultExperiment", attrs)


def _common(v: Variable) -> dict[str, str]:
    attrs = {"name": _text(v.name), "valueReference": str(v.vr)}
    if v.description:
        attrs["description"] = _text(v.description)
    attrs["causality"] = v.causality
    attrs["variability"] = v.variability
    if v.initial is not None:
        attrs["initial"] = v.initial
    return attrs


def _serialize(root: ET.Element) -> bytes:
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n"


def model_description(fmi: int, variables: Sequence[Variable], *, model_name: str, token: str,
                      description: str, interface: Interface, n_event_indicators: int,
                      experiment: Experiment, tool: str, date: str) -> bytes:
    """``modelDescription.xml`` of FMI ``fmi`` (2 or 3) for ``variables``."""
    root = ET.Element("fmiModelDescription")
    root.set("fmiVersion", "2.0" if fmi == 2 else "3.0")
    root.set("modelName", _text(model_name))
    root.set("guid" if fmi == 2 else "instantiationToken", token)
    if description:
        root.set("description", _text(description))
    root.set("generationTool", _text(tool))
    root.set("generationDateAndTime", date)
    root.set("variableNamingConvention", _naming(variables))
    if fmi == 2:
        root.set("numberOfEventIndicators", str(n_event_indicators))
        _fmi2(root, variables, interface, experiment)
    else:
        _fmi3(root, variables, interface, experiment)
    return _serialize(root)


def _initial_unknown(v: Variable) -> bool:
    return ((v.causality == "output" and v.initial in ("approx", "calculated"))
            or v.causality == "calculatedParameter"
            or (v.kind in ("state", "rate") and v.initial in ("approx", "calculated")))


def _fmi2(root: ET.Element, variables: Sequence[Variable], interface: Interface,
          experiment: Experiment) -> None:
    common = {"modelIdentifier": interface.identifier, "canNotUseMemoryManagementFunctions": "true",
              "canGetAndSetFMUstate": "true", "canSerializeFMUstate": "true",
              "providesDirectionalDerivative": "true"}
    kinds: list[tuple[str, dict[str, str]]] = []
    if interface.model_exchange:
        kinds.append(("ModelExchange", {}))
    if interface.co_simulation:
        extra = {"canHandleVariableCommunicationStepSize": "true"}
        if any(v.causality == "input" for v in variables):
            extra["canInterpolateInputs"] = "true"      # fmi2SetRealInputDerivatives, order 1
        kinds.append(("CoSimulation", extra))
    for tag, extra in kinds:
        el = ET.SubElement(root, tag, {"modelIdentifier": common["modelIdentifier"], **extra,
                                       **{k: v for k, v in common.items()
                                          if k != "modelIdentifier"}})
        files = ET.SubElement(el, "SourceFiles")
        for name in interface.sources:
            ET.SubElement(files, "File", name=name)
    _head(root, variables, experiment)
    index = {v.vr: i + 1 for i, v in enumerate(variables)}     # 1-based ScalarVariable index
    mvs = ET.SubElement(root, "ModelVariables")
    for v in variables:
        sv = ET.SubElement(mvs, "ScalarVariable", _common(v))
        attrs = {}
        if v.start is not None:
            attrs["start"] = _number(v.start)
        if v.unit and v.type == "Real":
            attrs["unit"] = _text(v.unit)
        if v.derivative_of is not None:
            attrs["derivative"] = str(index[v.derivative_of])
        ET.SubElement(sv, v.type, attrs)
    structure = ET.SubElement(root, "ModelStructure")
    for tag, chosen in (("Outputs", [v for v in variables if v.causality == "output"]),
                        ("Derivatives", [v for v in variables if v.derivative_of is not None]),
                        ("InitialUnknowns", [v for v in variables if _initial_unknown(v)])):
        if chosen:
            el = ET.SubElement(structure, tag)
            for v in chosen:
                ET.SubElement(el, "Unknown", index=str(index[v.vr]))


def _fmi3(root: ET.Element, variables: Sequence[Variable], interface: Interface,
          experiment: Experiment) -> None:
    common = {"canGetAndSetFMUState": "true", "canSerializeFMUState": "true",
              "providesDirectionalDerivatives": "true"}
    if interface.model_exchange:
        ET.SubElement(root, "ModelExchange", {"modelIdentifier": interface.identifier,
                                              "needsCompletedIntegratorStep": "true", **common})
    if interface.co_simulation:
        ET.SubElement(root, "CoSimulation", {"modelIdentifier": interface.identifier,
                                             "canHandleVariableCommunicationStepSize": "true",
                                             **common, "hasEventMode": "false"})
    _head(root, variables, experiment)
    mvs = ET.SubElement(root, "ModelVariables")
    for v in variables:
        attrs = _common(v)
        if v.unit and v.type == "Real":
            attrs["unit"] = _text(v.unit)
        if v.start is not None:
            attrs["start"] = _number(v.start)
        if v.derivative_of is not None:
            attrs["derivative"] = str(v.derivative_of)
        ET.SubElement(mvs, "Float64" if v.type == "Real" else "Int32", attrs)
    structure = ET.SubElement(root, "ModelStructure")
    for tag, chosen in (("Output", [v for v in variables if v.causality == "output"]),
                        ("ContinuousStateDerivative",
                         [v for v in variables if v.derivative_of is not None]),
                        ("InitialUnknown", [v for v in variables if _initial_unknown(v)]),
                        ("EventIndicator", [v for v in variables if v.kind == "indicator"])):
        for v in chosen:
            ET.SubElement(structure, tag, valueReference=str(v.vr))


def build_description(identifier: str, entry: str) -> bytes:
    """``sources/buildDescription.xml`` (FMI 3.0): one C99 translation unit, ``entry``, linked
    with the maths library."""
    root = ET.Element("fmiBuildDescription", fmiVersion="3.0")
    config = ET.SubElement(root, "BuildConfiguration", modelIdentifier=identifier,
                           description="one C99 translation unit; only the FMI functions are "
                                       "exported")
    files = ET.SubElement(config, "SourceFileSet", language="C99")
    ET.SubElement(files, "SourceFile", name=entry)
    ET.SubElement(config, "Library", name="m", description="the C maths library (libm)")
    return _serialize(root)
