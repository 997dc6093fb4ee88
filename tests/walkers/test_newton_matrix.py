"""Newton's matrix in find_fixed_point (walker_library/analyses/poincare.py):

* "auto" (the exact Jacobian from a run with sensitivities, Broyden-updated) reaches the fixed
  point of the old forward-difference Newton ("fd") to 1e-10 on compass_gait (tolerance 1e-11;
  measured 2e-12) with fewer strides (measured 7 against 13, a run with sensitivities counted as
  one stride);
* where the walker's runs cannot carry sensitivities (a ModelError), "auto" is "fd" exactly (the
  same iterates, bit for bit) and "variational" says it could not;
* an unknown option is an OptionError.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from porthamiltonian.batch.progress import counting
from porthamiltonian.errors import ModelError, OptionError
from walker_library import find_fixed_point, load_walker

TOL = 1e-11


class _NoSensitivities:
    """The walker, whose runs with sensitivities cannot be made."""

    def __init__(self, walker: Any):
        self._walker = walker

    def __getattr__(self, name: str) -> Any:
        return getattr(self._walker, name)

    def stride_sensitivity(self, *args: Any, **kwargs: Any) -> Any:
        raise ModelError("sensitivities of runs with discrete-time blocks are not supported")


@pytest.fixture(scope="module")
def walker():
    return load_walker("compass_gait")


@pytest.fixture(scope="module")
def fd(walker):
    return find_fixed_point(walker, tol=TOL, jacobian="fd")


def _strides(run) -> tuple[Any, int]:
    n = [0]
    with counting(lambda what, k: n.__setitem__(0, n[0] + k)):
        result = run()
    return result, n[0]


def test_the_exact_matrix_finds_the_same_fixed_point_in_fewer_strides(walker, fd):
    _, fd_strides = _strides(lambda: find_fixed_point(walker, tol=TOL, jacobian="fd"))
    exact, exact_strides = _strides(lambda: find_fixed_point(walker, tol=TOL))
    assert fd.converged and exact.converged
    assert exact.residual < TOL
    np.testing.assert_allclose(exact.z, fd.z, rtol=0, atol=1e-10)
    assert exact_strides < fd_strides


def test_without_sensitivities_auto_is_finite_differences(walker, fd):
    plain = _NoSensitivities(walker)
    auto = find_fixed_point(plain, tol=TOL)
    assert auto.converged
    np.testing.assert_array_equal(auto.z, fd.z)
    assert auto.history == fd.history
    exact = find_fixed_point(plain, tol=TOL, jacobian="variational")
    assert not exact.converged and "sensitivities" in exact.message


def test_an_unknown_matrix_is_refused(walker):
    with pytest.raises(OptionError, match="jacobian must be one of"):
        find_fixed_point(walker, jacobian="secant")
