"""Independent validation of the framework's simplest walker against a hand-written one.

``handwritten_walkers.py`` (beside this file) types in Garcia et al.'s (1998, J. Biomech. Eng.
120:281) equations of motion and heel-strike map (β = m/M -> 0) and integrates them with
scipy's DOP853; ``walker_library.simplest_walker`` builds the same walker from multibody
components with a generic plastic impact map (β = 1e-9). Their fixed points, found by the same
Newton iteration, must agree to well below 1e-8 (the β effect is O(1e-9)), and one stride from
the framework's fixed point must land on the same next state. One stride of compass_walker checks
the legs' rotational inertia and the friction at the rolling contact point (and one of
compass_walker_sole_friction the sole point's) against typed-in Lagrange equations; the compliant-contact walkers'
gaits are compared in ``benchmarks/bench_walkers.py``.
"""
from __future__ import annotations

import handwritten_walkers as hw
import numpy as np
import pytest

from walker_library import find_fixed_point, simplest_walker

GARCIA_LONG = (0.20031090049483, -0.19983247291764)     # θ*, θ̇* at γ = 0.009 (Table 1)


@pytest.fixture(scope="module")
def framework():
    w = simplest_walker()
    fp = find_fixed_point(w)
    assert fp.converged
    th_dot, phi, phi_dot = w.to_thesis(fp.z)
    return w, fp, np.array([phi / 2, th_dot, phi_dot])


def test_hand_written_fixed_point_matches_garcia_and_the_framework(framework):
    _, _, z_fw = framework
    h = hw.SimplestWalkerHand()
    res = hw.newton_fixed_point(h.stride, [0.2, -0.2, -0.015], tol=1e-10)
    assert res.converged
    assert res.z[:2] == pytest.approx(GARCIA_LONG, abs=2e-10)
    assert np.max(np.abs(res.z - z_fw)) < 1e-9


def test_one_stride_agrees_with_the_framework(framework):
    w, fp, z_fw = framework
    th_dot, phi, phi_dot = w.to_thesis(w.stride(fp.z).z_next)
    z_hand = hw.SimplestWalkerHand().stride(z_fw)
    assert np.max(np.abs(z_hand - np.array([phi / 2, th_dot, phi_dot]))) < 1e-8


def test_legs_inertia_of_compass_walker_against_hand_written_lagrange():
    """The legs as rigid bodies: compass_walker's legs are rods with I_leg = m_leg l²/12 about
    their centres; the hand-written equations of motion (Lagrange's, typed in: the legs' term
    m_leg l²/4 + I_leg + m_foot l²) give the same stride from the walker's guess to 1e-8
    (measured 6e-10; without I_leg in either the states differ by 1e-3)."""
    from walker_library import compass_walker
    fw = compass_walker()
    z = fw.initial_guess()
    a = fw.stride(z).z_next
    b = hw.CompassWalkerHand().walk(z, 1)[0].z_next
    assert np.max(np.abs(a - b)) < 1e-8
    c = hw.CompassWalkerHand(I_leg=0.0).walk(z, 1)[0].z_next
    assert np.max(np.abs(a - c)) > 1e-4


def test_the_legs_stay_uniform_rods_when_the_leg_length_changes():
    """compass_walker's legs are uniform rods, their inertia the expression m_leg l²/12 (not a
    number): with l = 0.65 the stride is the hand-written walker's with I_leg = m_leg 0.65²/12
    to 1e-8, and differs by more than 1e-5 from the one whose legs kept the inertia of the
    0.7 m rod (what a number in the file gave)."""
    from walker_library import compass_walker
    fw = compass_walker(l=0.65)
    z = fw.initial_guess()
    a = fw.stride(z).z_next
    b = hw.CompassWalkerHand(l=0.65, I_leg=0.01 * 0.65**2 / 12).walk(z, 1)[0].z_next
    assert np.max(np.abs(a - b)) < 1e-8
    c = hw.CompassWalkerHand(l=0.65, I_leg=0.01 * 0.7**2 / 12).walk(z, 1)[0].z_next
    assert np.max(np.abs(a - c)) > 1e-5


def test_friction_point_of_compass_walker_against_hand_written_lagrange():
    """The friction's point: compass_walker puts it on the rolling arc's material contact point
    (checked above, slip ẋ − (l cos a + R) ȧ), compass_walker_sole_friction on the sole point R
    beyond the foot centre along the leg (slip ẋ − (l + R) cos a ȧ); the hand-written walker with
    the sole gives the latter's stride from the same guess to 1e-8, and the two friction points'
    strides differ by more than 1e-5 (so the check can tell them apart)."""
    from walker_library import load_walker
    sole = load_walker("compass_walker_sole_friction")
    z = sole.initial_guess()
    a = sole.stride(z).z_next
    b = hw.CompassWalkerHand(rolling=False).walk(z, 1)[0].z_next
    assert np.max(np.abs(a - b)) < 1e-8
    c = hw.CompassWalkerHand().walk(z, 1)[0].z_next
    assert np.max(np.abs(a - c)) > 1e-5
