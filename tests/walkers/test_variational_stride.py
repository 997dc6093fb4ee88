"""The exact stride Jacobian from one run with sensitivities (tests/walkers/variational_stride.py,
a prototype of the wiring into walker_library) against finite differences of
``HybridWalker.stride``:

* rigid walkers (a pinned swing phase, a plastic impact and relabelling at heel strike, the
  reset's Jacobian by differences with an error estimate): central differences of strides at
  the files' rtol 1e-12 are accurate to ~1e-8 there; the rimless wheel's one multiplier is
  cos² 2α in closed form (McGeer 1990; Coleman, Chatterjee & Ruina 1997);
* the compliant-contact compass walker (contacts switched by events, no state reset): central
  differences have an O(h²) error with a large constant (the stiff contact), 3e-3 at h = 1e-5;
  their Richardson extrapolation (h = 2e-5, 1e-5, at rtol 1e-12) converges at O(h⁴) and agrees
  with the exact Jacobian computed at the file's own rtol 1e-9.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from variational_stride import stride_jacobian

from walker_library.poincare import find_fixed_point
from walker_library.poincare import jacobian as fd_jacobian
from walker_library.walkers import load_walker

#: the compass walker's fixed point at rtol 1e-11 (tests/walkers/test_compass_walker.py)
COMPASS_FIXED_POINT = [-0.206411020523, 0.206209813786, 0.606829889921, -0.118612721153,
                       0.825427285873, 0.827699297548]


def _eig(J: np.ndarray) -> np.ndarray:
    return np.array(sorted(np.linalg.eigvals(J), key=lambda c: (-abs(c), -c.imag)))


@pytest.mark.parametrize("name", ["simplest_walker", "compass_gait", "rigid_compass_walker",
                                  "rimless_wheel"])
def test_rigid_walkers_agree_with_finite_differences(name):
    """At the fixed point: the exact Jacobian (Rodas5P at the file's rtol) and central
    differences of strides (step 1e-6, the file's DOP853 at rtol 1e-12) agree to 1e-6 of max|J|
    (measured 5e-11 to 1e-8), their multipliers to 1e-6; the run's own error estimates are
    small (Φ within its sub-step tolerance, the difference Jacobians below 1e-5)."""
    walker = load_walker(name, backend="c")
    z = find_fixed_point(walker, walker.initial_guess()).z
    exact = stride_jacobian(walker, z)
    fd = fd_jacobian(walker, z, step=1e-6)
    assert np.max(np.abs(exact.J - fd)) < 1e-6 * np.max(np.abs(fd))
    assert np.max(np.abs(_eig(exact.J) - _eig(fd))) < 1e-6
    assert np.max(np.abs(exact.z_next - z)) < 1e-8
    assert exact.phi_error <= 10.0 and exact.difference_error < 1e-5


def test_rimless_wheel_multiplier_is_cos_squared_two_alpha():
    """The rimless wheel's stride map has one multiplier, cos² 2α (α = π/n_spokes: 0.5 for 8
    spokes), exactly: the exact Jacobian gives it to 1e-10."""
    walker = load_walker("rimless_wheel", backend="c")
    z = find_fixed_point(walker, walker.initial_guess()).z
    (mult,) = np.linalg.eigvals(stride_jacobian(walker, z).J)
    alpha = math.pi / walker.parameters["n_spokes"]
    assert mult.real == pytest.approx(math.cos(2 * alpha) ** 2, abs=1e-10)


def test_compass_walker_against_extrapolated_differences():
    """The compliant compass walker at its fixed point: the exact Jacobian at the file's rtol 1e-9
    against Richardson-extrapolated central differences R = (4 D(h/2) − D(h))/3 of strides at
    rtol 1e-12 (h = 2e-5): J to 1e-6 of max|J| and the multipliers to 3e-6 (measured 2e-7 and
    6e-7; R's own error, O(h⁴), is ~3e-6 at h = 4e-5), where a single central difference at
    h = 1e-5 is 30x further off (3e-3 of J)."""
    walker = load_walker("compass_walker", backend="c")
    z = np.array(COMPASS_FIXED_POINT)
    exact = stride_jacobian(walker, z)
    tight = walker.with_options(rtol=1e-12, atol=1e-14)
    d1, d2 = (fd_jacobian(tight, z, step=h) for h in (2e-5, 1e-5))
    rich = (4 * d2 - d1) / 3
    scale = np.max(np.abs(rich))
    assert np.max(np.abs(exact.J - rich)) < 1e-6 * scale
    assert np.max(np.abs(_eig(exact.J)[:2] - _eig(rich)[:2])) < 3e-6
    assert np.max(np.abs(d2 - exact.J)) > 30 * np.max(np.abs(exact.J - rich))
    assert exact.phi_error <= 10.0
