"""Functional Mock-up Units: a compiled model exported for the tools that import FMI 2.0 / 3.0.

:func:`export_fmu` (also ``compiled.export_fmu(path, ...)`` and ``porthamiltonian export-fmu``)
writes a standard FMU: ``modelDescription.xml``; the shared library for this platform, built by
the C back end's compiler from the model's generated C (what the C back end compiles), the
compiled Rosenbrock loop and a small runtime; the C sources under ``sources/`` (with a
``buildDescription.xml`` for FMI 3.0) so that it can be rebuilt elsewhere; a documentation page.

* Model exchange: the states (the model's, then the ledger's E_diss and E_in), their derivatives,
  the events' guards as event indicators, mode switches in the event update
  (``fmi2NewDiscreteStates`` / ``fmi3UpdateDiscreteStates``), the Jacobian through directional
  derivatives.
* Co-simulation: the compiled Rodas loop inside ``doStep`` with its own events and tolerances;
  its steps do not depend on the communication points, so the trajectory and the event times are
  those of :func:`porthamiltonian.simulate` with the same method and settings.

What events do is data here, an :class:`EventProgram` (rules that set modes, book the energy
jump in the ledger, count, stop): Python callables cannot run in an FMU and are refused
(:class:`~porthamiltonian.errors.ExportError`). A walker's mode machine is such a program
(``walker export-fmu``).

This sub-package belongs to the back-end stage (it packages the C back end's translation unit),
so that :class:`~porthamiltonian.simulation.compiled.CompiledModel` can offer ``export_fmu`` as a
method, as it offers ``simulate``. docs/fmu.md is the user's guide.
"""
from .export import FMI_VERSIONS, KINDS, export_fmu, platform_folder
from .program import EventProgram, EventRule, RuleChange, RuleCondition

__all__ = ["FMI_VERSIONS", "KINDS", "EventProgram", "EventRule", "RuleChange", "RuleCondition",
           "export_fmu", "platform_folder"]
