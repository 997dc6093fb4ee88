"""The walker core: a model file's ``[walker]`` table → a runnable hybrid walker.

Takes a model (porthamiltonian) and its walker table; gives a :class:`~.walker.HybridWalker`
through a pipeline of typed products, each built once: :mod:`.reading` (per-part readers: the
table → :class:`~.hybrid.WalkerSpec`, the dataclasses of :mod:`.hybrid`, expressions parsed) →
:mod:`.plan` (the spec checked against the names the model compiles to → a
:class:`~.plan.WalkerPlan` of frozen records) → :mod:`.walker` (the plan's model compiled and
bound → :class:`~.walker.CompiledWalker`; :class:`~.walker.HybridWalker`, the one class that runs
every walker, with its :class:`~.walker.RunValues`). Beside them: :mod:`.problems` (the table's
errors), :mod:`.machine` (the mode machine), :mod:`.resets` (relabelling, plastic impact),
:mod:`.strides` (the stride recorder), :mod:`.variational` (the stride's exact Jacobian),
:mod:`.protocol` (the :class:`~.protocol.Walker` interface the analyses use) and :mod:`.files`
(walker files: load, save, the shipped walkers by name).
"""
