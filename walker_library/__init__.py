"""walker_library: passive walkers as port-Hamiltonian models plus a hybrid description, and their
gait analyses.

* :mod:`.hybrid` — the ``[walker]`` table of a model file as dataclasses (:class:`WalkerSpec`:
  feet, modes, rules, relabelling, section, angles, guess, ranges, terrain, integration);
* :mod:`.core` — :class:`HybridWalker`, the one class that runs every walker from its spec;
  :mod:`.machine` (the mode machine: transitions returning simulation resets),
  :mod:`.resets` (relabelling and the rigid plastic impact), :mod:`.strides` (the stride recorder);
* :mod:`.walkers` — walker files: :func:`load_walker`, :func:`save_walker`, the shipped walkers by
  name (models/, described in docs/walkers.md);
* :mod:`.calibration` (the thesis's contact-damping calibration), :mod:`.dissipation` (energy
  dissipated by element), :mod:`.standing` (the compliant leg's standing check);
* :mod:`.protocol` — the :class:`Walker` interface the analyses use, :class:`Stride`,
  :class:`ParameterSpec`;
* :mod:`.poincare` — stride map, fixed points (Newton), period detection; :mod:`.monodromy` —
  the stride map's Jacobian (the variational equations with saltation matrices,
  :mod:`porthamiltonian.saltation`, or finite differences with the step chosen per coordinate)
  and Floquet multipliers with error bounds; :mod:`.continuation` —
  branches of gaits over a parameter, their bifurcations, period doubling (``walker continue``);
* :mod:`.gait`, :mod:`.metrics` — the gait analysis behind ``walker gait`` and its metrics;
* :mod:`.robustness` — step-down, basin of attraction, Gait Sensitivity Norm; :mod:`.series`
  (time series for plots); :mod:`.report` (the HTML report);
* :mod:`.analyses` — those analyses as sweep case functions (``walker sweep``), with a cache of
  compiled walkers and gaits; :mod:`.studies` — the thesis's tables and figures
  (``walker reproduce``);
* :mod:`.results` — JSON serialization; :mod:`.cli` — the ``walker`` command.
"""
from .continuation import ContinuationResult, ParameterPath, continue_gait
from .core import HybridWalker
from .gait import GaitResult, WalkResult, analyze_gait, walk
from .hybrid import Completion, Foot, Integration, Rule, Section, Terrain, WalkerSpec, walker_spec
from .metrics import GaitMetrics, gait_metrics
from .monodromy import FloquetResult, floquet, stride_jacobian
from .poincare import (
                       FixedPointResult,
                       PeriodResult,
                       detect_period,
                       find_fixed_point,
                       iterate,
                       jacobian,
                       stride_map,
)
from .protocol import ParameterSpec, Stride, Walker
from .walkers import (
                       available_walkers,
                       compass_gait,
                       compass_walker,
                       compliant_leg_walker,
                       load_walker,
                       read_walker,
                       rigid_compass_walker,
                       rimless_wheel,
                       save_walker,
                       simplest_walker,
                       variable_stiffness_walker,
)

__all__ = [
    "Completion", "ContinuationResult", "FixedPointResult", "FloquetResult", "Foot", "GaitMetrics", "GaitResult",
    "HybridWalker", "Integration", "ParameterPath", "ParameterSpec", "PeriodResult", "Rule", "Section", "Stride",
    "Terrain", "WalkResult", "Walker", "WalkerSpec", "analyze_gait", "available_walkers",
    "compass_gait", "compass_walker", "compliant_leg_walker", "continue_gait", "detect_period",
    "find_fixed_point", "floquet", "gait_metrics", "iterate", "jacobian", "load_walker",
    "read_walker", "rigid_compass_walker", "rimless_wheel", "save_walker", "simplest_walker",
    "stride_jacobian", "stride_map", "variable_stiffness_walker", "walk", "walker_spec",
]
