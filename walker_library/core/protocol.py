"""The small interface between walker models and the gait analyses.

The analyses (:mod:`walker_library.poincare`, :mod:`walker_library.gait`) see a walker only through
:class:`Walker`: a stride function on a Poincaré section just after heel strike, the names of the
section's independent coordinates, a rough initial guess, and the conversions of a section state
into named quantities (SI, and the thesis's θ, θ̇, φ, φ̇ where the walker has legs). Every walker
of walker_library is a :class:`~walker_library.core.HybridWalker` — rigid-impact and
compliant-contact walkers alike, configured by their model files (docs/walkers.md) — so every
analysis applies to all of them; another implementation plugs in by providing the members of
:class:`Walker`.

:meth:`Walker.walk` simulates consecutive steps in one run (one energy ledger) and returns one
:class:`Stride` per step, each ending on the section (for a compliant walker: the touchdown of
the new foot in front), with the energy fields taken from the ledger (E_diss increments, H and
the potential energy at the section crossings) and ``status="fell"`` for a fall;
:meth:`Walker.stride` is ``walk(z, 1)[0]``.
``details=True`` asks for max |θ| and max |φ|; ``record=True`` for the trajectory in
``info["trajectory"]`` of the last stride; ``ground_drop=h`` lowers the surface by h before the
first heel strike (the step-down test).

Conventions (Garcia et al. 1998; docs/walkers.md): θ is the stance-leg angle to the slope normal,
φ the angle between the legs, positive as in Garcia's paper: just after heel strike θ > 0 (the new
stance foot ahead of the hip), θ̇ < 0 while walking downhill, and φ = 2θ at heel strike.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from porthamiltonian.errors import ParameterValueError

if TYPE_CHECKING:
    from .variational import StrideSensitivity

__all__ = ["ParameterSpec", "Stride", "StrideStatus", "Walker", "check_parameters"]


@dataclass(frozen=True)
class ParameterSpec:
    """A walker parameter: default value (SI), unit, meaning and source, and its valid range
    ``low < value < high`` (``<=`` at an end that is ``*_inclusive``; a whole number if
    ``integer``); ``limits``: the components' constraints the range comes from, if any (e.g.
    "component 'walker' body 'leg1' mass must be > 0")."""

    name: str
    value: float
    unit: str
    doc: str
    source: str = ""
    low: float = -math.inf
    high: float = math.inf
    low_inclusive: bool = False
    high_inclusive: bool = False
    integer: bool = False
    limits: str = ""

    def check(self, value: float) -> float:
        """``value`` as a float if it is in range, else ParameterValueError naming the range."""
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise ParameterValueError(f"parameter {self.name!r} must be a number, got {value!r}") from None
        ok_low = value >= self.low if self.low_inclusive else value > self.low
        ok_high = value <= self.high if self.high_inclusive else value < self.high
        if not (math.isfinite(value) and ok_low and ok_high):
            lo, hi = "[" if self.low_inclusive else "(", "]" if self.high_inclusive else ")"
            raise ParameterValueError(
                f"parameter {self.name!r} = {value:g} is out of range: it must lie in "
                f"{lo}{self.low:g}, {self.high:g}{hi} {self.unit} ({self.doc}"
                f"{f'; {self.limits}' if self.limits else ''})")
        if self.integer and value != round(value):
            raise ParameterValueError(f"parameter {self.name!r} = {value:g} must be a whole number "
                                      f"({self.doc})")
        return value


def check_parameters(specs: Mapping[str, ParameterSpec],
                     values: Mapping[str, float]) -> dict[str, float]:
    """Validated values by name (defaults for the others); unknown names raise."""
    unknown = set(values) - set(specs)
    if unknown:
        raise ParameterValueError(f"unknown parameter(s) {', '.join(sorted(unknown))}; parameters: "
                                  f"{', '.join(specs)}")
    out = {name: spec.value for name, spec in specs.items()}
    for name, value in values.items():
        out[name] = specs[name].check(value)
    return out


class StrideStatus(StrEnum):
    """How a stride ended. A ``str``: ``stride.status == "fell"`` holds, and the value is what
    the JSON results show."""

    STEP = "step"      #: a heel strike ended the step (the state is on the section again)
    FELL = "fell"      #: the walker fell (the stride's ``reason`` says how)


@dataclass
class Stride:
    """One step of a walker from a section state to the next (SI units).

    status : :class:`StrideStatus` ``"step"`` (a heel strike ended the step) or ``"fell"``.
    z_next : section coordinates just after the heel strike that ended the step (None if fell).
    duration : step period (s). step_length : distance along the slope between the successive
        stance feet (m). energy_dissipated : energy booked as dissipated in the ledger during the
        step, the impact loss included (J). potential_released : decrease of the potential energy
        over the step (J). energy_residual : ledger residual H(end) − H(0) + E_diss − E_in (J).
    max_theta, max_phi : max |θ| and max |φ| over the step (rad), NaN when not computed.
    reason : why the walker fell (``"fall"``, ``"time_limit"``, ...), or ``""``.
    info : walker-specific extras (e.g. the impact impulse, the trailing foot's velocity).
    """

    status: StrideStatus
    z_next: np.ndarray | None
    duration: float
    step_length: float = math.nan
    energy_dissipated: float = math.nan
    potential_released: float = math.nan
    energy_residual: float = math.nan
    max_theta: float = math.nan
    max_phi: float = math.nan
    reason: str = ""
    info: dict = field(default_factory=dict)

    @property
    def fell(self) -> bool:
        """True when the stride ended in a fall (status other than "step")."""
        return self.status != StrideStatus.STEP


@runtime_checkable
class Walker(Protocol):
    """What the gait analyses need from a walker model (every member is used by some analysis;
    an analysis reads nothing else). Its data members are read-only properties."""

    @property
    def name(self) -> str:
        """The model name."""

    @property
    def legged(self) -> bool:
        """True when θ, φ (and their rates) are defined."""

    @property
    def section(self) -> tuple[str, ...]:
        """Names of the independent coordinates of the Poincaré section just after heel strike,
        in the model's own terms (joint angles and rates, SI)."""

    @property
    def thesis_section(self) -> tuple[str, ...]:
        """Names of the thesis's section coordinates (:meth:`to_thesis`)."""

    @property
    def parameters(self) -> Mapping[str, float]:
        """Current parameter values by name (SI)."""

    @property
    def specs(self) -> Mapping[str, ParameterSpec]:
        """The :class:`ParameterSpec` (unit, meaning, range, default) of every parameter the user
        may set."""

    @property
    def mode_names(self) -> tuple[str, ...]:
        """Parameters the walker sets itself during a walk (not to be set or continued)."""

    @property
    def run_time_parameters(self) -> tuple[str, ...]:
        """Parameters bound at run time (a continuation moves only those)."""

    @property
    def gait_tolerance(self) -> float:
        """The Newton tolerance of the gait search (section units)."""

    @property
    def leg_length(self) -> float:
        """The length scale of the step-down grids (m)."""

    @property
    def weight(self) -> float:
        """Total weight m g (N), for the cost of transport."""

    def with_parameters(self, **values: float) -> Walker:
        """A walker with some parameters changed (validated: out of range raises)."""

    def initial_guess(self) -> np.ndarray:
        """A rough section state to start the limit-cycle search from."""

    def stride(self, z: np.ndarray, *, details: bool = False) -> Stride:
        """Simulate one step from section coordinates ``z`` (``details``: also max θ, max φ)."""

    def walk(self, z: np.ndarray, n_steps: int, *, details: bool = False,
             record: bool = False, ground_drop: float = 0.0,
             until: Callable[[np.ndarray], bool] | None = None,
             reuse: bool = True) -> list[Stride]:
        """``n_steps`` consecutive strides from ``z`` (stops at the first fall, or after the
        first stride whose end section state satisfies ``until``). ``reuse``: a walk that
        repeats the last one may be cut from its trajectory (the same strides, not integrated
        again); False integrates it in every case (e.g. to time the integration).

        ``ground_drop`` h (m, >= 0): the surface drops by h once, ahead of the stance foot, before
        the first heel strike, and stays down (the thesis's step-down, §2.6): the first step's new
        foot lands h lower (along the slope normal) than the stance foot, later steps on the
        lowered surface. The section coordinates are translation-invariant, so the strides after
        the drop are comparable with the gait's fixed point."""

    def stride_sensitivity(self, z: np.ndarray, period: int = 1, *, factor: float = 1.0,
                           deadline: float = math.inf) -> StrideSensitivity:
        """The exact Jacobian of the stride map S^period at ``z`` (the strides integrated with
        their variational equations at the walker's tolerances times ``factor``); runs that
        pass ``deadline`` (a ``time.perf_counter()``) are stopped, the result says so
        (``stopped``)."""

    def section_state(self, z: np.ndarray) -> dict[str, float]:
        """The section state by name (SI), with theta, theta_dot, phi, phi_dot if legged."""

    def to_thesis(self, z: np.ndarray) -> np.ndarray:
        """Section coordinates in the thesis's terms (see :attr:`thesis_section`)."""

    def from_thesis(self, w: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`to_thesis`."""

    def basin_state(self, z_star: np.ndarray, theta: float, theta_dot: float) -> np.ndarray | None:
        """The walker's own basin grid point for thesis θ, θ̇ near the fixed point ``z_star``,
        or None: the analyses keep the fixed point's other coordinates."""
