"""walker_library: passive walkers built from porthamiltonian components, and their gait analyses.

* :mod:`.walkers` — builders of the classic rigid-impact walkers (simplest walker, compass gait,
  rimless wheel) and the loader of walker model files (``models/*.toml`` with ``[model.walker]``);
* :mod:`.rigid` — swing phase pinned at the stance foot + the generic plastic impact map;
* :mod:`.compliant` — the thesis's nominal walker (``compass_walker``): one floating-base model
  with Hunt–Crossley contacts, SCVS friction, arc feet and the scuffing rule; the calibration of
  the lost contact damping λ (:func:`~.compliant.calibrate_damping`);
* :mod:`.compliant_legs` — the thesis's compliant-leg walkers: a spring–damper on a prismatic
  leg–foot joint (``compliant_leg_walker``, MODEL-SPEC.md §3) and its variable-stiffness version
  (``variable_stiffness_walker``, §4); :func:`~.compliant_legs.dissipation_breakdown`;
* :mod:`.protocol` — the :class:`Walker` interface the analyses use (compliant-contact walkers
  implement it too), :class:`Stride`, :class:`ParameterSpec`;
* :mod:`.poincare` — stride map, fixed points (Newton), Floquet multipliers, period detection;
* :mod:`.gait`, :mod:`.metrics` — the gait analysis behind ``walker gait`` and its metrics;
* :mod:`.robustness` — step-down, basin of attraction, Gait Sensitivity Norm;
* :mod:`.analyses` — those analyses as sweep case functions (``walker sweep``), with a cache of
  compiled walkers and gaits; :mod:`.studies` — the thesis's tables and figures
  (``walker reproduce``);
* :mod:`.results` — JSON serialization; :mod:`.cli` — the ``walker`` command.
"""
from .compliant import (
                        CompliantOptions,
                        CompliantWalker,
                        DampingCalibration,
                        calibrate_damping,
                        compass_walker,
)
from .compliant_legs import (
                        CompliantLegWalker,
                        VariableStiffnessWalker,
                        compliant_leg_walker,
                        dissipation_breakdown,
                        variable_stiffness_walker,
)
from .gait import GaitResult, WalkResult, analyze_gait, walk
from .metrics import GaitMetrics, gait_metrics
from .poincare import (
                        FixedPointResult,
                        FloquetResult,
                        PeriodResult,
                        detect_period,
                        find_fixed_point,
                        floquet,
                        iterate,
                        jacobian,
                        stride_map,
)
from .protocol import ParameterSpec, Stride, Walker
from .rigid import IntegrationOptions, LeggedRigidWalker, RigidImpactWalker, RimlessWheelWalker
from .walkers import (
                        BUILDERS,
                        available_walkers,
                        compass_gait,
                        export_model_file,
                        load_walker,
                        rimless_wheel,
                        simplest_walker,
)

__all__ = [
                        "BUILDERS",
                        "CompliantLegWalker",
                        "CompliantOptions",
                        "CompliantWalker",
                        "DampingCalibration",
                        "FixedPointResult",
                        "FloquetResult",
                        "GaitMetrics",
                        "GaitResult",
                        "IntegrationOptions",
                        "LeggedRigidWalker",
                        "ParameterSpec",
                        "PeriodResult",
                        "RigidImpactWalker",
                        "RimlessWheelWalker",
                        "Stride",
                        "VariableStiffnessWalker",
                        "WalkResult",
                        "Walker",
                        "analyze_gait",
                        "available_walkers",
                        "calibrate_damping",
                        "compass_gait",
                        "compass_walker",
                        "compliant_leg_walker",
                        "detect_period",
                        "dissipation_breakdown",
                        "export_model_file",
                        "find_fixed_point",
                        "floquet",
                        "gait_metrics",
                        "iterate",
                        "jacobian",
                        "load_walker",
                        "rimless_wheel",
                        "simplest_walker",
                        "stride_map",
                        "variable_stiffness_walker",
                        "walk",
]
