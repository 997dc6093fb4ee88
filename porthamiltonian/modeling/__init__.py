"""The model layer: components → model.

Takes nothing from the layers after it. Gives the vocabulary every model is written in:
:mod:`.ports` (power ports, domains, the sign convention), :mod:`.component` (the Component base
class and the Builder its laws are written with), :mod:`.elements` (the bond-graph basics: C, I,
R, Se, Sf, TF, GY, junctions, multiport storages), :mod:`.expressions` (the expression language
of model files and guards: our own parser, nothing from a file runs as Python),
:mod:`.constraints` (physical rules on parameter values, checked on every binding) and
:mod:`.model` (:class:`~.model.Model`, the builder — a networkx graph of components and bonds —
and :class:`~.model.ModelDescription`, its frozen, flattened, validated form that the compiler
reads).
"""
