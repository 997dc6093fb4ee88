"""Shared by the validation tests: ``c_run``, the session's memo of runs of the shipped models on
the C back end."""
from __future__ import annotations

from collections.abc import Callable

import pytest


@pytest.fixture(scope="session")
def c_run(isolated_cache) -> Callable:
    """``c_run(name, t_end, method, rtol, atol)`` -> the Trajectory of ``models/<name>.toml``
    (C back end, its default parameters and initial state) from 0 to ``t_end``, memoized for the
    session: test_rodas.py and test_qbdf.py compare their compiled methods with the same scipy
    Radau runs (one per model, not one per compiled method, order-of-convergence case and file;
    scipy's integrators are the costly part of those tests). A Trajectory is immutable and its
    arrays read-only, so the tests sharing one cannot change what another reads."""
    from porthamiltonian import compile_model, io

    runs: dict[tuple, object] = {}

    def _run(name: str, t_end: float, method: str, rtol: float, atol: float):
        key = (name, t_end, method, rtol, atol)
        if key not in runs:
            model = compile_model(io.load(name), backend="c")
            runs[key] = model.simulate(t_end, method=method, rtol=rtol, atol=atol)
        return runs[key]

    return _run
