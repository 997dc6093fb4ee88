"""The walker core: a model file's ``[walker]`` table → a runnable hybrid walker.

Takes a model (porthamiltonian) and its walker table. Gives :mod:`.hybrid` (the table as
dataclasses, :class:`~.hybrid.WalkerSpec`), :mod:`.names` (the names the model provides, checked
against the table), :mod:`.walker` (:class:`~.walker.HybridWalker`, the one class that runs every
walker), :mod:`.machine` (the mode machine), :mod:`.resets` (relabelling, plastic impact),
:mod:`.strides` (the stride recorder), :mod:`.variational` (the stride's exact Jacobian),
:mod:`.protocol` (the :class:`~.protocol.Walker` interface the analyses use) and :mod:`.files`
(walker files: load, save, the shipped walkers by name).
"""
