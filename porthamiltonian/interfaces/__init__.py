"""What users touch: model files, the command line, sweeps of model files, the 3D viewer.

Takes everything below it (models, the compiler, compiled models, simulation, batch sweeps).
Gives :mod:`.io` (TOML model files: read with every problem located by file and line, write,
round-trip), :mod:`.sweeps` (the generic sweep case: simulate a model file per case),
:mod:`.cli` (the ``porthamiltonian`` command) and :mod:`.viewer` (the interactive 3D page and
its still image).
"""
