"""The generic case of a model sweep: simulate a model with the case's parameter values.

``porthamiltonian sweep MODEL --grid k=1:10:5 ...`` runs :func:`simulate_case` for each case: the
model (a name from ``models/`` or a path) compiled once per process (:class:`ModelCache`),
simulated to ``t_end`` with the case's values bound as parameters and the model file's
``[simulation]`` settings, and summarised as JSON:

``status``, ``message``, ``t_final`` (s), ``nfev``, ``n_events``
    the run (a run that fails or diverges is a row with that status, not a lost sweep);
``energy``
    the ledger at the end: ``H0``, ``HT``, ``dissipated``, ``supplied``, ``residual`` (J) and
    ``max_abs_residual`` (J), ``relative_residual`` (1);
``final``, ``min``, ``max``
    of each name in ``outputs`` (states or named outputs; default: every state), in its unit;
    ``min`` and ``max`` from the run's dense output (:meth:`Trajectory.extrema
    <porthamiltonian.simulation.trajectory.Trajectory.extrema>`), not from the steps alone;
``settling_time``
    with ``settle=NAME``: :func:`settling_time` of that state or output (s), None when it is
    still outside its band at the end of the run.

:func:`prepare_simulation` compiles the model once in the main process and checks every case's
parameter names and values, the names in ``outputs``/``settle`` and the options before any case
runs.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InputError, ModelError, StateError, ValidationError
from ..simulation.trajectory import sampled_times

if TYPE_CHECKING:
    from ..modeling.model import Model
    from ..simulation.compiled import CompiledModel
    from ..simulation.trajectory import Trajectory
    from .io import ModelFile

__all__ = ["ModelCache", "SimulationModel", "check_settings", "model_cache",
           "prepare_simulation", "settling_time", "simulate_case", "simulation_settings"]

#: integration settings of a model file's [simulation] table when it does not give them
DEFAULT_SETTINGS = {"method": "auto", "rtol": 1e-9, "atol": 1e-12, "energy_tolerance": 1e-6}


def simulation_settings(file_settings: Mapping[str, Any]) -> dict[str, Any]:
    """A model file's ``[simulation]`` table completed with :data:`DEFAULT_SETTINGS`."""
    return {**DEFAULT_SETTINGS, **file_settings}


@dataclass(frozen=True)
class SimulationModel:
    """A model loaded from its file and compiled: the description, the compiled model, and its
    file's simulation settings (completed by :func:`simulation_settings`)."""

    model: Model
    compiled: CompiledModel
    settings: dict[str, Any]

    @classmethod
    def load(cls, model: str, backend: str | None = None) -> SimulationModel:
        """Load ``model`` (a name from ``models/`` or a path) and compile it with ``backend``
        (None: "auto"). A file loaded before (the same text, path, back end, package and C
        compiler) starts from its snapshot (:mod:`.warm`: no sympy, no networkx; the model
        read in full when first used beyond its name); a file read in full leaves one."""
        from . import io, warm
        path = io.model_path(model)
        source = str(path)
        text = io.read_text(path, limit=io.MAX_FILE_SIZE, label=source, kind="model file",
                            language="TOML")
        kept = warm.restore(source, text, backend, lambda: io.reads(text, source).model)
        if kept is not None:
            return cls(*kept)
        entry = cls.from_file(io.reads(text, source), backend)
        warm.keep(entry.model, entry.compiled, entry.settings, source, text, backend)
        return entry

    @classmethod
    def from_file(cls, record: ModelFile, backend: str | None = None) -> SimulationModel:
        """The model of a model file already read (``record``), compiled with ``backend``
        (None: "auto"): a file that can be read once only (a pipe) is read once."""
        compiled = record.compile(backend=backend or "auto")
        with record.located():
            check_settings(compiled, record.simulation)
        return cls(record.model, compiled, simulation_settings(record.simulation))

    def simulate(self, t_end: float | None, params: Mapping[str, float] | None = None, *,
                 dense_output: bool = False,
                 progress: Callable[[float, int], None] | None = None,
                 method: str | None = None) -> Trajectory:
        """Simulate to ``t_end`` (None: the file's ``t_end``) with ``params`` and the file's
        ``initial`` state values, method (``method``: another one), rtol, atol, max_step and
        constant ``inputs``; a :class:`~porthamiltonian.errors.ModelError` when no end is
        known.
        ``progress``: see :func:`~porthamiltonian.simulation.simulate.simulate`."""
        t_end = self.t_end(t_end)
        sim = self.settings
        options = {"max_step": sim["max_step"]} if "max_step" in sim else {}
        method = sim["method"] if method is None else method
        if self.compiled.input_names:
            options["inputs"] = sim.get("inputs")     # the file's constant inputs
        return self.compiled.simulate(t_end, sim.get("initial"), params=params, method=method,
                                      rtol=sim["rtol"], atol=sim["atol"],
                                      dense_output=dense_output, progress=progress, **options)

    def t_end(self, t_end: float | None) -> float:
        """``t_end`` (s), else the file's; ModelError when neither is given."""
        t_end = self.settings.get("t_end") if t_end is None else t_end
        if t_end is None:
            raise ModelError(f"model {self.model.name!r} has no [simulation] t_end; pass --t-end")
        return float(t_end)


def check_settings(compiled: CompiledModel, settings: Mapping[str, Any]) -> None:
    """The names of a model file's ``[simulation] initial`` and ``inputs`` tables are states and
    inputs of ``compiled``: else one error listing every name it does not have, each problem
    with its key path (the file's line), before any run."""
    found: list[ModelError] = []
    for table, names, kind, error in (("initial", compiled.state_names, "state", StateError),
                                      ("inputs", compiled.input_names, "input", InputError)):
        for name in settings.get(table, {}):
            if name not in names:
                found.append(error(f"[simulation] {table}: model {compiled.name!r} has no {kind} "
                                   f"{name!r}; its {kind}s: {', '.join(names) or 'none'}",
                                   path=("simulation", table, name)))
    if len(found) == 1:
        raise found[0]
    if found:
        raise ValidationError(f"[simulation]: {len(found)} problems", problems=found)


class ModelCache:
    """The models of this process, loaded and compiled once per (model, back end): a sweep's
    workers compile (or load from the on-disk cache) once and bind each case's parameters."""

    def __init__(self) -> None:
        self._models: dict[tuple[str, str], SimulationModel] = {}

    def get(self, model: str, backend: str | None = None) -> SimulationModel:
        """The compiled ``model`` (a name from ``models/`` or a path) with ``backend``
        (None: "auto")."""
        key = (str(model), backend or "auto")
        if key not in self._models:
            self._models[key] = SimulationModel.load(*key)
        return self._models[key]

    def clear(self) -> None:
        """Forget every model (the next ``get`` loads and compiles again)."""
        self._models.clear()


_PROCESS_MODELS = ModelCache()


def model_cache() -> ModelCache:
    """This process's :class:`ModelCache` (forked workers inherit the parent's)."""
    return _PROCESS_MODELS


def settling_time(t: np.ndarray, y: np.ndarray, band: float = 0.02,
                  y_of_t: Callable[[float], float] | None = None) -> float | None:
    """The time (s) after which ``y`` stays within ``band`` × its largest deviation from its
    final value (the 2 % settling time for ``band=0.02``; for a release from rest or a step this
    deviation is the step size, the textbook definition).

    The final value is the last sample ``y[-1]``: the run must be long enough for ``y`` to get
    there (a ramp "settles" into the band around its last sample). The last crossing of the band
    is found between the samples by a root of ``y_of_t`` (e.g. dense output) when given, else by
    linear interpolation. None when ``y`` is still outside the band at its second-to-last sample;
    ``t[0]`` when it never leaves the band."""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    final = y[-1]
    deviation = np.abs(y - final)
    limit = band * float(np.max(deviation))
    outside = np.nonzero(deviation > limit)[0]
    if limit == 0 or not len(outside):
        return float(t[0])
    i = int(outside[-1])
    if i >= len(t) - 2:
        return None
    if y_of_t is not None:
        from scipy.optimize import brentq  # here: scipy.optimize takes ~0.2 s

        try:
            return float(brentq(lambda s: abs(y_of_t(s) - final) - limit, t[i], t[i + 1],
                                xtol=1e-12, rtol=4 * np.finfo(float).eps))
        except ValueError:       # round-off at a sample exactly on the band: interpolate
            pass
    d0, d1 = deviation[i] - limit, deviation[i + 1] - limit
    return float(t[i] + (t[i + 1] - t[i]) * d0 / (d0 - d1))


def _check_names(compiled: CompiledModel, names: Sequence[str]) -> None:
    known = set(compiled.state_names) | set(compiled.output_names)
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ModelError(f"model {compiled.name!r} has no state or output "
                         f"{', '.join(repr(n) for n in unknown)}; states: "
                         f"{', '.join(compiled.state_names)}; outputs: "
                         f"{', '.join(compiled.output_names) or 'none'}")


def _check_band(band: float) -> None:
    if not (isinstance(band, (int, float)) and 0 < band < 1):
        raise ModelError(f"band must be a fraction between 0 and 1 (0.02: the 2 % settling "
                         f"time), got {band!r}")


def prepare_simulation(cases: Sequence[Mapping[str, Any]], *, model: str,
                       backend: str | None = None, t_end: float | None = None,
                       outputs: Sequence[str] | None = None, settle: str | None = None,
                       band: float = 0.02) -> None:
    """Compile ``model`` once here (forked workers inherit it) and check everything a case will
    use before any runs: the end time, the names, the band and each case's parameters."""
    entry = model_cache().get(model, backend)
    end = entry.t_end(t_end)
    if not (math.isfinite(end) and end > 0):
        raise ModelError(f"t_end must be a finite time > 0 s, got {end!r}")
    _check_names(entry.compiled, [*(outputs or ()), *([settle] if settle else [])])
    _check_band(band)
    for index, case in enumerate(cases):
        try:
            entry.compiled.params(case)
        except ModelError as err:
            raise type(err)(f"case {index} {dict(case)}: {err}") from None


def simulate_case(case: Mapping[str, Any], *, model: str, backend: str | None = None,
                  t_end: float | None = None, outputs: Sequence[str] | None = None,
                  settle: str | None = None, band: float = 0.02) -> dict:
    """Case function of a model sweep (see the module docstring): the case's values are
    parameters of ``model``; returns the run's status, ledger, final/min/max of ``outputs`` and
    the settling time of ``settle``."""
    entry = model_cache().get(model, backend)
    compiled = entry.compiled
    names = list(outputs) if outputs else list(compiled.state_names)
    _check_names(compiled, [*names, *([settle] if settle else [])])
    _check_band(band)
    traj = entry.simulate(t_end, dict(case), dense_output=True)
    extrema = {name: traj.extrema(name) for name in names}
    result: dict[str, Any] = {
        "status": traj.status, "message": traj.message, "t_final": traj.t_final,
        "nfev": traj.nfev, "n_events": len(traj.events), "energy": traj.ledger(),
        "final": {n: float(traj[n][-1]) for n in names},
        "min": {n: low for n, (low, _) in extrema.items()},
        "max": {n: high for n, (_, high) in extrema.items()},
    }
    if settle is not None:
        t_fine = sampled_times(traj.t)
        result["settling_time"] = settling_time(t_fine, traj.values_at(settle, t_fine), band,
                                                lambda s: float(traj.values_at(settle, s)))
    return result
