"""The compiled model and its runs: compiled model → simulation → trajectory.

Takes a compiled model's layouts and numeric functions (from :mod:`porthamiltonian.compiler` and
:mod:`porthamiltonian.backends`); never calls sympy. Gives :mod:`.compiled`
(:class:`~.compiled.CompiledModel`: layouts, parameters, values at a point), :mod:`.simulate`
(:func:`~.simulate.simulate` and the Simulator: events, modes, reset maps, the ledger across
jumps), :mod:`.inputs` (binding inputs), :mod:`.sampling` (input samples and discrete-time
sampling instants), :mod:`.linearize` (derivative, exact Jacobians, linearization, trim),
:mod:`.phmatrices` (the port-Hamiltonian form at a point), :mod:`.options` (the rules of the
numerical options), :mod:`.saltation` (sensitivities of
a run: saltation matrices at events), :mod:`.psensitivity` (their parameter columns),
:mod:`.fitting` (parameters fitted to data with the exact Jacobian), :mod:`.differences` (central differences with an error
estimate), :mod:`.trajectory` (:class:`~.trajectory.Trajectory`, the immutable result) and its
views: :mod:`.frames` (pandas data frames with units) and :mod:`.display` (notebook tables and
quick plots).
"""
