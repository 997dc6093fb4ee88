"""Gait metrics from the strides of one period of a gait (SI units).

* step_period (s): mean duration of a step; step_length (m): mean distance along the slope
  between successive stance feet; speed (m/s): total length / total time (along the slope);
* energy_dissipated_per_step (J): mean energy booked as dissipated in the ledger per step (for a
  rigid walker, the impact's kinetic-energy loss); potential_released_per_step (J): mean drop of
  the potential energy per step (equal to the dissipation on a periodic gait);
* max_theta, max_phi (rad): the largest |θ| and |φ| over the period (thesis convention);
* cost_of_transport (1): specific cost of transport, energy dissipated / (weight × distance);
  for a passive walker on a slope γ it equals sin γ (the energy comes from the descent).
"""
from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass

from ..core.protocol import Stride

__all__ = ["GaitMetrics", "gait_metrics"]


@dataclass
class GaitMetrics:
    step_period: float
    step_length: float
    speed: float
    energy_dissipated_per_step: float
    potential_released_per_step: float
    max_theta: float
    max_phi: float
    cost_of_transport: float
    energy_residual_per_step: float

    def to_dict(self) -> dict:
        """Every metric by name."""
        return asdict(self)


def _nanmax(values: Iterable[float | None]) -> float:
    vals = [v for v in values if v is not None and math.isfinite(v)]
    return max(vals) if vals else math.nan


def gait_metrics(strides: list[Stride], weight: float) -> GaitMetrics:
    """Metrics of the gait made of ``strides`` (one period), for a walker of ``weight`` (N)."""
    steps = [s for s in strides if not s.fell]
    if not steps:
        nan = math.nan
        return GaitMetrics(nan, nan, nan, nan, nan, nan, nan, nan, nan)
    n = len(steps)
    T = sum(s.duration for s in steps)
    D = sum(s.step_length for s in steps)
    E = sum(s.energy_dissipated for s in steps)
    V = sum(s.potential_released for s in steps)
    R = max(abs(s.energy_residual) for s in steps)
    return GaitMetrics(
        step_period=T / n, step_length=D / n, speed=D / T if T > 0 else math.nan,
        energy_dissipated_per_step=E / n, potential_released_per_step=V / n,
        max_theta=_nanmax(s.max_theta for s in steps), max_phi=_nanmax(s.max_phi for s in steps),
        cost_of_transport=E / (weight * D) if D != 0 else math.nan,
        energy_residual_per_step=R)
