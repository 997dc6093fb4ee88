"""Gait analyses on any :class:`~walker_library.core.protocol.Walker`: walker → numbers.

Takes walkers through their protocol only. Gives :mod:`.poincare` (stride map, fixed points,
periods), :mod:`.monodromy` (stride Jacobians, Floquet multipliers with error bounds),
:mod:`.continuation` (branches, folds, flips), :mod:`.gait` and :mod:`.metrics` (the gait
analysis of ``walker gait``), :mod:`.robustness` (step-down, basin, Gait Sensitivity Norm),
:mod:`.series` (time series for plots), :mod:`.results` (JSON), :mod:`.cases` (the analyses as
sweep case functions), :mod:`.studies` (the thesis's tables and figures), and the thesis's
:mod:`.calibration`, :mod:`.dissipation` and :mod:`.standing` checks.
"""
