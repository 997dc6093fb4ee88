"""walker_library: passive and controlled walkers as port-Hamiltonian models plus a hybrid
description, and their gait analyses.

The package follows its data flow, one sub-package per stage:

* :mod:`.core` — a model file's ``[walker]`` table → a runnable walker: the table read into
  dataclasses (:class:`WalkerSpec`, expressions parsed), checked against the names the model
  compiles to (a :class:`~.core.plan.WalkerPlan`), compiled and bound into :class:`HybridWalker`
  (the one class that runs every walker; :func:`build_walker`), the mode machine, resets, the
  stride recorder, the exact stride Jacobian, the :class:`Walker` protocol the analyses use, and
  walker files (:func:`load_walker`, :func:`save_walker`, the shipped walkers by name);
* :mod:`.analyses` — walker → numbers: stride map and fixed points, Floquet multipliers,
  continuation and bifurcations, the gait analysis and its metrics, step-down, basins, the Gait
  Sensitivity Norm, the analyses as sweep case functions, the thesis's calibration checks;
* :mod:`.report` — numbers → pages and pictures: the main job's HTML report, figures,
  animations, the 3D scene, the thesis's studies (``walker reproduce``);
* :mod:`.cli` — the ``walker`` command.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from porthamiltonian.lazy import lazy_names

#: where each public name lives: imported when first used, so that ``import walker_library``
#: (and the ``walker`` command) loads only what it needs (a warm ``walker gait`` needs neither
#: sympy nor networkx)
_NAMES = {
    **{n: "analyses.continuation" for n in ("ContinuationResult", "ParameterPath",
                                            "continue_gait")},
    **{n: "analyses.gait" for n in ("GaitResult", "WalkResult", "analyze_gait", "walk")},
    **{n: "analyses.metrics" for n in ("GaitMetrics", "gait_metrics")},
    **{n: "analyses.monodromy" for n in ("FloquetResult", "floquet", "stride_jacobian")},
    **{n: "analyses.poincare" for n in ("FixedPointResult", "PeriodResult", "detect_period",
                                        "find_fixed_point", "iterate", "jacobian",
                                        "stride_map")},
    **{n: "core.files" for n in ("available_walkers", "compass_gait", "compass_walker",
                                 "compliant_leg_walker", "load_walker", "read_walker",
                                 "rigid_compass_walker", "rimless_wheel", "save_walker",
                                 "simplest_walker", "variable_stiffness_walker")},
    **{n: "core.hybrid" for n in ("Completion", "Foot", "Integration", "Rule", "Section",
                                  "Terrain", "WalkerSpec")},
    **{n: "core.protocol" for n in ("ParameterSpec", "Stride", "Walker")},
    "walker_spec": "core.reading",
    **{n: "core.walker" for n in ("HybridWalker", "build_walker")},
}


#: the public names, imported on first use (with :mod:`.report.display`, which registers the
#: results' notebook views)
__getattr__, __dir__ = lazy_names(__name__, _NAMES, first="report.display")


if TYPE_CHECKING:
    from .analyses.continuation import ContinuationResult, ParameterPath, continue_gait
    from .analyses.gait import GaitResult, WalkResult, analyze_gait, walk
    from .analyses.metrics import GaitMetrics, gait_metrics
    from .analyses.monodromy import FloquetResult, floquet, stride_jacobian
    from .analyses.poincare import (
        FixedPointResult,
        PeriodResult,
        detect_period,
        find_fixed_point,
        iterate,
        jacobian,
        stride_map,
    )
    from .core.files import (
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
    from .core.hybrid import Completion, Foot, Integration, Rule, Section, Terrain, WalkerSpec
    from .core.protocol import ParameterSpec, Stride, Walker
    from .core.reading import walker_spec
    from .core.walker import HybridWalker, build_walker

__all__ = [
    "Completion", "ContinuationResult", "FixedPointResult", "FloquetResult", "Foot", "GaitMetrics", "GaitResult",
    "HybridWalker", "Integration", "ParameterPath", "ParameterSpec", "PeriodResult", "Rule", "Section", "Stride",
    "Terrain", "WalkResult", "Walker", "WalkerSpec", "analyze_gait", "available_walkers", "build_walker",
    "compass_gait", "compass_walker", "compliant_leg_walker", "continue_gait", "detect_period",
    "find_fixed_point", "floquet", "gait_metrics", "iterate", "jacobian", "load_walker",
    "read_walker", "rigid_compass_walker", "rimless_wheel", "save_walker", "simplest_walker",
    "stride_jacobian", "stride_map", "variable_stiffness_walker", "walk", "walker_spec",
]
