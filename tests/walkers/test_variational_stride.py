"""The exact stride Jacobian (walker_library.core.variational, the default ``jacobian="variational"``
of walker_library.analyses.monodromy) against finite differences of ``HybridWalker.walk``:

* rigid walkers (a pinned swing phase, a plastic impact and relabelling at heel strike, the
  impact's Jacobian by differences with an error estimate): central differences of strides at
  the files' DOP853, rtol 1e-12, are accurate to ~1e-8 there; the rimless wheel's one multiplier
  is cos² 2α in closed form (McGeer 1990; Coleman, Chatterjee & Ruina 1997);
* the compliant-contact compass walker (contacts switched by events, no state reset): central
  differences have an O(h²) error with a large constant (the stiff contact), 3e-3 at h = 1e-5;
  their Richardson extrapolation (h = 2e-5, 1e-5, at rtol 1e-12) converges at O(h⁴) and agrees
  with the exact Jacobian computed at the file's own rtol 1e-9;
* every compliant walker: the exact multipliers at the file's tolerances against those of a run
  at 1/100 of them (the multipliers' error, ≤ 1e-6 on every shipped walker), within the error
  bound reported.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from porthamiltonian.errors import ModelError
from walker_library.analyses.monodromy import floquet, stride_jacobian
from walker_library.analyses.poincare import find_fixed_point
from walker_library.analyses.poincare import jacobian as fd_jacobian
from walker_library.core.files import load_walker

#: the compass walker's fixed point at rtol 1e-11 (tests/walkers/test_compass_walker.py; the
#: friction at the rolling contact point since issue 14)
COMPASS_FIXED_POINT = [-0.206804111206, 0.206603239163, 0.607219067185, -0.118749925976,
                       0.824827471111, 0.827100015272]


def _eig(J: np.ndarray) -> np.ndarray:
    return np.array(sorted(np.linalg.eigvals(J), key=lambda c: (-abs(c), -c.imag)))


def _fixed_point(walker) -> np.ndarray:
    """The fixed point to the walker's own gait tolerance (1e-10 stalls at a residual ~4e-10 on
    the compliant walkers at rtol 1e-9: the integration's own noise)."""
    fp = find_fixed_point(walker, walker.initial_guess(),
                          tol=float(getattr(walker, "gait_tolerance", 1e-10)))
    assert fp.converged
    return fp.z


@pytest.mark.parametrize("name", ["simplest_walker", "compass_gait", "rigid_compass_walker",
                                  "rimless_wheel"])
def test_rigid_walkers_agree_with_finite_differences(name):
    """At the fixed point: the exact Jacobian (Rodas5P with its variational equations at the
    file's rtol) and central differences of strides (step 1e-6, the file's DOP853 at rtol 1e-12)
    agree to 1e-6 of max|J| (measured 5e-11 to 1e-8), their multipliers to 1e-6, and the
    multipliers' error bounds are below 1e-6; so does the finite-difference ladder (the
    cross-check, ``jacobian="fd"``), within its own bounds."""
    walker = load_walker(name)
    z = _fixed_point(walker)
    exact = stride_jacobian(walker, z)
    fd = fd_jacobian(walker, z, step=1e-6)
    assert exact.method == "variational"
    assert np.max(np.abs(exact.matrix - fd)) < 1e-6 * np.max(np.abs(fd))
    assert np.max(np.abs(_eig(exact.matrix) - _eig(fd))) < 1e-6
    fl, ladder = floquet(walker, z), floquet(walker, z, jacobian="fd")
    assert fl.error < 1e-6 and fl.certain
    assert np.max(np.abs(fl.multipliers - ladder.multipliers)) < max(1e-6, 2 * ladder.error)


def test_rimless_wheel_multiplier_is_cos_squared_two_alpha():
    """The rimless wheel's stride map has one multiplier, cos² 2α (α = π/n_spokes: 0.5 for 8
    spokes), exactly: the exact Jacobian gives it to 1e-10."""
    walker = load_walker("rimless_wheel")
    (mult,) = np.linalg.eigvals(stride_jacobian(walker, _fixed_point(walker)).matrix)
    alpha = math.pi / walker.parameters["n_spokes"]
    assert mult.real == pytest.approx(math.cos(2 * alpha) ** 2, abs=1e-10)


def test_compass_walker_against_extrapolated_differences():
    """The compliant compass walker at its fixed point: the exact Jacobian at the file's rtol 1e-9
    against Richardson-extrapolated central differences R = (4 D(h/2) − D(h))/3 of strides at
    rtol 1e-12 (h = 2e-5): J to 1e-5 of max|J| and the multipliers to 3e-6 (R's own error,
    O(h⁴), is ~3e-6), where a single central difference at h = 1e-5 is 30x further off."""
    walker = load_walker("compass_walker")
    z = np.array(COMPASS_FIXED_POINT)
    exact = stride_jacobian(walker, z).matrix
    tight = walker.with_options(rtol=1e-12, atol=1e-14)
    d1, d2 = (fd_jacobian(tight, z, step=h) for h in (2e-5, 1e-5))
    rich = (4 * d2 - d1) / 3
    scale = np.max(np.abs(rich))
    assert np.max(np.abs(exact - rich)) < 1e-5 * scale
    assert np.max(np.abs(_eig(exact)[:2] - _eig(rich)[:2])) < 3e-6
    assert np.max(np.abs(d2 - exact)) > 30 * np.max(np.abs(exact - rich))


#: variants of compliant_leg_walker (a hip spring, point-mass legs, friction at the sole point:
#: the same contacts, events and variational equations as the walkers beside them): checked by
#: the numba pass only (tests/conftest.py, ``breadth``)
_BREADTH = pytest.mark.breadth


@pytest.mark.parametrize("name", ["compass_walker", "compliant_leg_walker",
                                  "smooth_stiffness_walker", "variable_stiffness_walker",
                                  "ankle_stiffness_walker",
                                  pytest.param("hip_and_leg_spring_walker", marks=_BREADTH),
                                  "compass_walker_point_legs",
                                  pytest.param("compliant_leg_walker_point_legs", marks=_BREADTH),
                                  "compass_walker_sole_friction",
                                  pytest.param("compliant_leg_walker_sole_friction",
                                               marks=_BREADTH)])
def test_compliant_walker_multipliers_to_1e_6(name):
    """The exact multipliers at the file's tolerances (rtol 1e-9) differ from those of a run at
    rtol 1e-11 by less than 1e-6 (measured 5e-9 to 1.1e-7; 8.3e-7 on smooth_stiffness_walker
    since the code generator folds zeros, which moved its step sequence) and by less than their
    reported error bounds (|λ(rtol) − λ(10 rtol)|, measured 2e-7 to 7e-7 on C, up to 5.3e-6 on
    numba, whose rounding moves the run at 10 rtol, and 1.45e-5 on smooth_stiffness_walker
    with folded zeros: the bound, a conservative estimate, is asserted < 3e-5; the error
    itself < 1e-6)."""
    walker = load_walker(name)
    z = _fixed_point(walker)
    fl = floquet(walker, z)
    ref = _eig(walker.stride_sensitivity(z, factor=1e-2).jacobian)
    err = np.array([np.min(np.abs(ref - lam)) for lam in fl.multipliers])
    assert np.max(err) < 1e-6
    assert np.all(err <= fl.errors)
    assert fl.error < 3e-5


def test_an_unknown_jacobian_method_is_named_with_the_choices():
    """``stride_sensitivity`` is part of the Walker protocol (every walker provides it); an
    unknown method gets a clear error naming the choices."""
    class Plain:
        name = "plain"

    with pytest.raises(ModelError, match="one of fd, variational"):
        stride_jacobian(Plain(), np.zeros(2), method="exact")
