"""Continuation of gaits and their bifurcations (walker_library.analyses.continuation), and the stability
verdict of the stride map's Jacobian (walker_library.analyses.monodromy: exact by default; finite
differences with the step chosen per coordinate as the cross-check).

Independent references:

* Garcia, Chatterjee, Ruina & Coleman (1998), "The simplest walking model: stability,
  complexity, and scaling", J. Biomech. Eng. 120(2):281–288 [GARCIA]: the long-period gait is
  stable for 0 < γ < 0.015 and period-doubles near γ = 0.0151 (their abstract and Fig. 4); the
  short-period gait at γ = 0.009, θ* = 0.19393736960624 (their Table 1), is unstable.
* Our own bisection of the flip on an independent integration of Garcia's equations
  (tests/validation/handwritten_walkers.py, scipy DOP853 at rtol 1e-13, central differences of
  1e-6): γ_flip = 0.01508843801 (measured; the bisection below repeats it to 1e-11).
* Goswami, Thuilot & Espiau (1998), "A study of the passive gait of a compass-like biped robot:
  symmetry and chaos", Int. J. Robot. Res. 17(12):1282–1301 [GOSWAMI]: the compass gait
  (m_H/m = 2, a = b) walks a stable period-1 gait on shallow slopes that period-doubles, then
  doubles again at a shorter interval, into chaos, as the slope grows (their bifurcation
  diagram); qualitatively reproduced here, the first flip located.
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pytest

from porthamiltonian.errors import ModelError
from walker_library import (
    ParameterPath,
    compass_gait,
    continue_gait,
    find_fixed_point,
    floquet,
    rimless_wheel,
    simplest_walker,
)
from walker_library.analyses.monodromy import eigen_errors
from walker_library.cli import main
from walker_library.core.protocol import Stride
from walker_library.core.variational import StrideSensitivity

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "validation"))
from handwritten_walkers import SimplestWalkerHand, newton_fixed_point

GARCIA_FLIP = 0.0151            # GARCIA: period doubling of the long-period gait
SHORT_THETA = 0.19393736960624  # GARCIA Table 1, short-period gait at γ = 0.009


def _reference_flip(lo: float = 0.0150, hi: float = 0.0152, tol: float = 1e-11) -> float:
    """Bisection on the sign of (smallest real multiplier + 1) of the hand-written simplest
    walker's period-1 gait (Newton to 1e-12, central differences of 1e-6)."""
    z = np.array([0.2367, -0.2315, -0.0255])

    def leading(gamma):
        nonlocal z
        w = SimplestWalkerHand(gamma, rtol=1e-13, atol=1e-24)
        r = newton_fixed_point(w.stride, z, tol=1e-12)
        assert r.converged
        z = r.z
        h = 1e-6
        J = np.column_stack([(w.stride(z + e) - w.stride(z - e)) / (2 * h)
                             for e in np.eye(3) * h])
        return min(c.real for c in np.linalg.eigvals(J) if abs(c.imag) < 1e-12)

    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if leading(mid) > -1 else (lo, mid)
    return 0.5 * (lo + hi)


@pytest.fixture(scope="module")
def simplest():
    return simplest_walker()


@pytest.fixture(scope="module")
def simplest_continuation(simplest):
    w = simplest.with_parameters(slope=0.002)
    fp = find_fixed_point(w, w.initial_guess())
    return continue_gait(simplest, "slope", 0.002, 0.016, guess=fp.z, doublings=1)


def test_simplest_walker_flip_at_garcias_period_doubling(simplest_continuation):
    """From γ = 0.002 the period-1 branch is followed to 0.016: one flip, located at
    γ = 0.0150884378 ± 1e-10 (from its exact multiplier's error bound), within 1e-7 of our
    bisection on the hand-written integration (measured difference 2.2e-10) and within 2e-4 of
    Garcia's 0.0151. The period-1 gait is stable below it (|λ| < 1) and unstable above it."""
    r = simplest_continuation
    flips = [b for b in r.bifurcations if b.kind == "flip"]
    assert len(flips) == 1 and flips[0].period == 1 and flips[0].branch == 0
    flip = flips[0]
    assert abs(flip.mu - _reference_flip()) < 1e-7
    assert abs(flip.mu - GARCIA_FLIP) < 2e-4
    assert flip.mu_error < 1e-8
    assert flip.multiplier.real == pytest.approx(-1.0, abs=1e-6)
    # regression pin: 0.0150884378 with the exact Jacobian (0.0150884384 with the
    # finite-difference ladder, whose multipliers err by ~2e-7 there)
    assert flip.mu == pytest.approx(0.0150884378, abs=1e-9)
    main_branch = r.branches[0]
    assert main_branch.points[0].mu == 0.002 and main_branch.points[-1].mu == 0.016
    assert all(p.stable for p in main_branch.points if p.mu < flip.mu - 1e-6)
    assert not any(p.stable for p in main_branch.points if p.mu > flip.mu + 1e-6)
    assert r.bifurcations == [flip]                      # no fold, no Neimark–Sacker on the way


def test_period_two_branch_beyond_the_flip(simplest, simplest_continuation):
    """The branch switched onto at the flip is a stable period-2 gait beyond it (Garcia's
    period doubling): its two steps differ (two section states, two step periods), each a
    fixed point of S², not of S; its multipliers at γ = 0.016 are checked against a fresh
    floquet() of the period-2 orbit (to 1e-5: the branch takes one central difference per
    coordinate at the steps its last ladder chose)."""
    r = simplest_continuation
    two = r.branches[1]
    assert two.period == 2 and "flip of branch 0" in two.origin
    assert r.bifurcations[0].child == 1
    assert two.points[-1].mu == pytest.approx(0.016, abs=1e-15)
    assert all(p.mu > r.bifurcations[0].mu for p in two.points)
    end = two.points[-1]
    assert end.stable
    assert abs(end.durations[0] - end.durations[1]) > 1e-3
    w = simplest.with_parameters(slope=0.016)
    s1, s2 = w.walk(end.z, 2)
    assert np.max(np.abs(s2.z_next - end.z)) < 1e-9 and np.max(np.abs(s1.z_next - end.z)) > 1e-3
    fl = floquet(w, end.z, period=2)
    diff = np.abs(np.sort_complex(fl.multipliers) - np.sort_complex(end.multipliers))
    assert np.max(diff) < 1e-5, diff


def test_short_period_branch_is_unstable_throughout(simplest):
    """Garcia's short-period gait, continued from his Table 1 point at γ = 0.009 up to 0.019:
    θ* there to 1e-9, a real multiplier above 1 everywhere (≈ 4.0 at 0.009, rising with γ),
    no bifurcation."""
    guess = simplest.from_thesis([-0.205, 2 * 0.193, -0.015])
    r = continue_gait(simplest, "slope", 0.009, 0.019, guess=guess, doublings=0)
    br = r.branches[0]
    assert br.points[0].mu == 0.009 and br.points[-1].mu == 0.019
    w = simplest.with_parameters(slope=0.009)
    assert w.section_state(br.points[0].z)["theta"] == pytest.approx(SHORT_THETA, abs=1e-9)
    assert br.points[0].max_modulus == pytest.approx(4.0039, abs=1e-3)
    assert not any(p.stable for p in br.points)
    assert [p.max_modulus for p in br.points] == sorted(p.max_modulus for p in br.points)
    assert r.bifurcations == []


def test_stability_verdict_does_not_depend_on_the_settings(simplest):
    """Just above the flip (γ = 0.01512) the exact leading multiplier is −1.0068813(4 ± 0.3):
    the verdict 'unstable' is certain. The finite-difference ladder (``jacobian="fd"``) agrees
    whatever step it starts from (1e-1 to 1e-5 of the coordinates), within 2e-7 and its error
    bounds; a single fixed step does not: 1e-3 (the thesis's, App. C) gives −0.9916, 'stable';
    1e-2 a complex pair of modulus 1.37 (before the guards were sampled inside scipy's steps, a
    perturbed stride of 1e-2 missed its grazing heel strike there and fell)."""
    from walker_library.analyses.poincare import jacobian
    w = simplest.with_parameters(slope=0.01512)
    fp = find_fixed_point(w, w.from_thesis([-0.2319, 2 * 0.2369, -0.0256]))
    assert fp.converged
    exact = floquet(w, fp.z)
    assert exact.method == "variational" and not exact.stable and exact.certain
    assert exact.multipliers[0].real == pytest.approx(-1.00688134, abs=1e-8)     # pin
    assert exact.errors[0] < 1e-7
    for h in (1e-1, 1e-2, 1e-3, 1e-5):
        fl = floquet(w, fp.z, step=h, jacobian="fd")
        assert not fl.stable and fl.certain
        assert abs(fl.multipliers[0] - exact.multipliers[0]) < max(2e-7, fl.errors[0])
    thesis_step = np.linalg.eigvals(jacobian(w, fp.z, step=1e-3))
    assert max(abs(thesis_step)) < 1.0                    # the wrong verdict
    coarse = np.linalg.eigvals(jacobian(w, fp.z, step=1e-2))
    assert max(abs(coarse.imag)) > 1.0                    # the wrong multipliers


def test_eigen_error_bound_covers_a_known_perturbation():
    """The first-order bound |y|ᵀE|x|/|yᴴx| covers the change of each eigenvalue of a
    non-normal matrix under a perturbation within E (checked against the eigenvalues of the
    perturbed matrix)."""
    rng = np.random.default_rng(3)
    J = np.array([[0.5, 3.0, 0.0], [0.0, -0.4, 1.0], [0.1, 0.0, 0.2]])
    E = np.full((3, 3), 1e-7)
    lam, err = eigen_errors(J, E)
    for _ in range(20):
        lam2 = np.linalg.eigvals(J + E * rng.uniform(-1, 1, (3, 3)))
        for lam_i, e_i in zip(lam, err):
            assert min(abs(lam2 - lam_i)) <= 1.01 * e_i


# --- bad input, before any work ------------------------------------------------------------------
@pytest.mark.parametrize("args,message", [
    (["--param", "wobble=0.001:0.01"], "no parameter 'wobble' to continue in"),
    (["--param", "slop=0.001:0.01"], "did you mean slope"),
    (["--param", "stance_x=0:1"], "mode of the walker's hybrid description"),
    (["--param", "slope=0.01"], "NAME=START:STOP"),
    (["--param", "slope=0.01:0.01"], "two different finite numbers"),
    (["--param", "slope=0.01:2"], "out of range"),
])
def test_continue_bad_input(args, message, capsys):
    assert main(["continue", "simplest_walker", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err and "Traceback" not in err


def test_continue_structural_parameter_is_refused(capsys):
    """The rimless wheel's number of spokes is a whole number: it changes the walker's make-up,
    and continuation refuses it by name."""
    assert main(["continue", "rimless_wheel", "--param", "n_spokes=6:10"]) == 2
    assert "structural" in capsys.readouterr().err
    with pytest.raises(ModelError, match="structural"):
        ParameterPath.single(rimless_wheel(), "n_spokes", 6, 10)


def test_continue_from_where_no_gait_exists_says_so(capsys):
    """Uphill (γ = −0.01) the simplest walker has no gait: the start's search (the guess, the
    walker's own motion, the continuation from the file's nominal gait) finds none and the
    command says so, before following any branch."""
    assert main(["continue", "simplest_walker", "--param", "slope=-0.01:0.01", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "no gait at the start of the range (slope = -0.01)" in err


def test_compass_gait_first_flip_by_the_command(tmp_path, capsys, without_views):
    """GOSWAMI's compass gait over the slope, by ``walker continue --json --out``: the period-1
    gait loses stability through a flip (located at 0.07663563 rad = 4.391°, regression pin to
    1e-8) and a stable period-2 gait takes over; the cascade beyond it is checked below and in
    REPRODUCTION.md (`walker continue compass_gait --param slope=0.075:0.09 --doublings 3`).
    The JSON has the branch table and the bifurcations; --out writes them and the figure."""
    out = tmp_path / "c"
    assert main(["continue", "compass_gait", "--param", "slope=0.0755:0.0775", "--doublings",
                 "1", "--json", "--quiet", "--out", str(out)]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["parameter"] == "slope" and d["range"] == [0.0755, 0.0775]
    flips = [b for b in d["bifurcations"] if b["kind"] == "flip"]
    assert len(flips) == 1 and flips[0]["period_steps"] == 1 and flips[0]["child_branch"] == 1
    assert flips[0]["mu"] == pytest.approx(0.07663563, abs=1e-8)
    assert math.degrees(flips[0]["mu"]) == pytest.approx(4.39, abs=0.01)
    one, two = d["branches"]
    assert one["points"][0]["stable"] and not one["points"][-1]["stable"]
    assert two["period_steps"] == 2 and two["points"][-1]["stable"]
    assert two["points"][-1]["mu"] == pytest.approx(0.0775)
    assert {"fixed_point", "floquet_multipliers", "step_periods", "max_multiplier"} <= \
        set(one["points"][0])
    assert (out / "bifurcation_diagram.png").stat().st_size > 10_000
    assert json.loads((out / "continuation.json").read_text())["bifurcations"][0]["kind"] == "flip"


#: GOSWAMI's cascade located by the continuation (regression pins; REPRODUCTION.md):
#: the flips 1 → 2, 2 → 4 and 4 → 8 (rad)
COMPASS_FLIPS = (0.0766356316, 0.0857664701, 0.0874835425)


@pytest.mark.parametrize("period,start,stop,guess,flip", [
    (2, 0.0855, 0.0860, [-0.298574, 1.157657, -1.011954], COMPASS_FLIPS[1]),
    # the next flip of the cascade, by the same code: the numba pass only (conftest: breadth)
    pytest.param(4, 0.0872, 0.0877, [-0.295132, 1.160227, -1.000589], COMPASS_FLIPS[2],
                 marks=pytest.mark.breadth),
])
def test_compass_gait_cascade_flips(period, start, stop, guess, flip):
    """GOSWAMI's period-doubling cascade: the stable period-2 gait (continued from a point of
    its orbit at 0.0855 rad) flips at 0.0857664701 rad (4.9141°), the stable period-4 gait
    (from 0.0872) at 0.0874835425 rad (5.0125°); each to 1e-10 (their error bounds are
    2e-11; runs from other starts agree to 6e-12), stable below the flip, unstable above. The
    intervals between the flips shrink like a Feigenbaum cascade: (0.0857665 − 0.0766356) /
    (0.0874835 − 0.0857665) = 5.32, against δ = 4.669 in the limit (the next ratio, with the
    8 → 16 flip at 0.0878507 of REPRODUCTION.md, is 4.68)."""
    w = compass_gait()
    r = continue_gait(w, "slope", start, stop, guess=guess, period=period, doublings=0)
    (bif,) = r.bifurcations
    assert bif.kind == "flip" and bif.period == period and bif.branch == 0
    assert bif.mu == pytest.approx(flip, abs=1e-10) and bif.mu_error < 1e-10
    br = r.branches[0]
    assert br.period == period and br.points[-1].mu == pytest.approx(stop, abs=1e-15)
    assert all(p.stable == (p.mu < bif.mu) for p in br.points)
    one, two, four = COMPASS_FLIPS
    assert (two - one) / (four - two) == pytest.approx(5.32, abs=0.01)


# --- synthetic stride maps: bifurcations known in closed form -------------------------------------
class _SyntheticMap:
    """A stride map z' = f(z; μ) on a two-coordinate section with its exact Jacobian, run
    through the :class:`~walker_library.core.protocol.Walker` interface (one "stride" per map
    iteration), so the continuation's branch logic is checked against closed forms in
    milliseconds."""

    name = "synthetic"
    legged = False
    section = thesis_section = ("x", "y")
    gait_tolerance = 1e-12
    weight = leg_length = 1.0
    specs = MappingProxyType({})
    mode_names = ()
    run_time_parameters = ("mu",)

    def __init__(self, mu: float):
        self.parameters = {"mu": float(mu)}
        self.mu = float(mu)

    def with_parameters(self, **values):
        return type(self)(values.get("mu", self.mu))

    def walk(self, z, n_steps, **options):
        z, out = np.asarray(z, dtype=float), []
        for _ in range(n_steps):
            z = self.f(z)
            out.append(Stride("step", z, 1.0, 1.0))
        return out

    def stride(self, z, **options):
        return self.walk(z, 1)[0]

    def stride_sensitivity(self, z, period=1, *, factor=1.0, deadline=math.inf):
        z, J = np.asarray(z, dtype=float), np.eye(2)
        for _ in range(period):
            J, z = self.jac(z) @ J, self.f(z)
        return StrideSensitivity(z, J, 0.0, np.zeros((2, 2)), 1e-12, "closed form")

    def section_state(self, z):
        return dict(zip(self.section, map(float, z)))

    def to_thesis(self, z):
        return np.asarray(z, dtype=float)

    from_thesis = to_thesis

    def initial_guess(self):
        return np.zeros(2)

    def basin_state(self, z_star, theta, theta_dot):
        return None


class _Bubbles(_SyntheticMap):
    """u' = a(μ) u + u³, v' = v/2 + u²/10 (u = x − 1, v = y − 2): the fixed point z = (1, 2)
    has the multipliers a(μ) and 1/2, so it flips where a = −1; where a < −1 a stable period-2
    orbit u = ±√(−1 − a), v = u²/5 exists (multipliers (3 + 2a)² and 1/4): a closed bubble
    between each pair of flips. ``shape`` "two": a = −1 + cos(πμ)/2, flips at μ = ±0.5, ±1.5
    (two bubbles in [−2, 2]); "one": a = −1 − (1 − μ²)/2, flips at ±1 (one bubble)."""

    name = "bubbles"

    def __init__(self, mu: float, shape: str = "two"):
        super().__init__(mu)
        self.shape = shape

    def with_parameters(self, **values):
        return _Bubbles(values.get("mu", self.mu), self.shape)

    def a(self):
        if self.shape == "two":
            return -1.0 + 0.5 * math.cos(math.pi * self.mu)
        return -1.0 - 0.5 * (1.0 - self.mu**2)

    def f(self, z):
        u, v = z[0] - 1.0, z[1] - 2.0
        return np.array([1.0 + self.a() * u + u**3, 2.0 + 0.5 * v + 0.1 * u * u])

    def jac(self, z):
        u = z[0] - 1.0
        return np.array([[self.a() + 3.0 * u * u, 0.0], [0.2 * u, 0.5]])


def _bubbles(shape: str, **options):
    return continue_gait(_Bubbles(-2.0, shape), "mu", -2.0, 2.0, guess=[1.0, 2.0], doublings=1,
                         **options)


@pytest.fixture(scope="module")
def bubbles():
    return _bubbles("two")


def test_a_bubble_found_from_its_second_flip_joins_the_known_branch(bubbles):
    """The fixed point's four flips are located where a = −1 (to 1e-9; the one at −1.5 falls
    on a point of the branch, where the flip test is exactly 0); the period-2 orbit switched
    onto at −1.5 is followed round its bubble to −0.5, and the orbit found at −0.5 is
    recognised as that branch (the same bubble, met from its other end; its points are the
    known ones shifted by one step): it joins branch 1 and is not followed or listed again;
    the bubble between 0.5 and 1.5 (another orbit) is a branch of its own. Its period-2 points
    match the closed form, u² = −1 − a and the multipliers (3 + 2a)², 1/4 (to 1e-8); no fold
    or branch point is reported where a bubble closes. The same with one bubble (flips at ±1)."""
    r = bubbles
    assert [b.kind for b in r.bifurcations] == ["flip"] * 4
    assert [b.mu for b in r.bifurcations] == pytest.approx([-1.5, -0.5, 0.5, 1.5], abs=1e-9)
    assert [b.child for b in r.bifurcations] == [1, 1, 2, 2]
    assert [b.joins for b in r.bifurcations] == [False, True, False, True]
    assert [br.period for br in r.branches] == [1, 2, 2]
    for br, (lo, hi) in zip(r.branches[1:], [(-1.5, -0.5), (0.5, 1.5)]):
        assert all(lo - 1e-6 < p.mu < hi + 1e-6 for p in br.points)
        for p in br.points:
            a = _Bubbles(p.mu).a()
            u = [z[0] - 1.0 for z in p.orbit]
            assert u[0] == pytest.approx(-u[1], abs=1e-9)
            assert u[0] ** 2 == pytest.approx(-1.0 - a, abs=1e-9)
            assert sorted(abs(p.multipliers)) == pytest.approx(sorted([(3 + 2 * a) ** 2, 0.25]),
                                                               abs=1e-8)
            assert p.stable
    d = r.to_dict()
    assert [b["joins_known_branch"] for b in d["bifurcations"]] == [False, True, False, True]
    assert len(d["branches"]) == 3
    one = _bubbles("one")
    assert [b.mu for b in one.bifurcations] == pytest.approx([-1.0, 1.0], abs=1e-9)
    assert [(b.child, b.joins) for b in one.bifurcations] == [(1, False), (1, True)]
    assert len(one.branches) == 2


def test_a_period_doubled_branch_ends_where_it_rejoins_its_parent(bubbles):
    """The rule that ends a period-2 branch where it rejoins its parent, at the parent's other
    flip, named: after one pass round the bubble (μ increasing throughout, the last point
    within 1e-3 of that flip), where the next step would have gone through the parent onto the
    same orbits shifted by one step (the default steps: the halves swapped) or, with short
    steps (ds_max = 0.02), where the orbit's two halves meet. Without either the branch would
    go round the closed bubble again and again, until max_points."""
    cases = [(bubbles.branches[1], bubbles.bifurcations[1], "halves swapped"),
             (bubbles.branches[2], bubbles.bifurcations[3], "halves swapped"),
             (_bubbles("one", ds_max=0.02).branches[1], None, "its halves meet")]
    for branch, flip, why in cases:
        other = branch.rejoined
        assert other is not None and other.branch == 0 and other.joins
        if flip is not None:
            assert other is flip
        assert branch.end.startswith(f"rejoined the period-1 branch 0 at its flip at mu = "
                                     f"{other.mu:.10g} (") and why in branch.end
        mus = [p.mu for p in branch.points]
        assert mus == sorted(mus) and len(mus) < 100
        assert mus[-1] == pytest.approx(other.mu, abs=1e-3)


class _SFold(_SyntheticMap):
    """x' = x + (μ − ε(u³ − 3u))/5, y' = y/2 + 1 (u = x − 1, ε = 0.01): fixed points on the
    S-curve μ = ε(u³ − 3u), with folds at u = ±1 (μ = ∓2ε); the multiplier
    1 − ε(3u² − 3)/5 makes the outer branches stable (|u| > 1) and the middle one unstable.
    Between the folds the curve spans 4ε of μ: nearly normal to the parameter axis."""

    name = "s_fold"
    eps = 0.01

    def f(self, z):
        u = z[0] - 1.0
        return np.array([z[0] + 0.2 * (self.mu - self.eps * (u**3 - 3 * u)), 0.5 * z[1] + 1.0])

    def jac(self, z):
        u = z[0] - 1.0
        return np.array([[1.0 - 0.2 * self.eps * (3 * u * u - 3), 0.0], [0.0, 0.5]])


def test_a_branch_ends_on_the_end_of_the_range_after_folds_near_it():
    """Continued from μ = 0.5 to −3ε, the branch turns at both folds (located at ∓2ε to 1e-9)
    and leaves the range, nearly normal to μ, where the corrector (not the predictor) crossed
    its end: it lands on μ = −3ε exactly and ends there, every point inside the range, on the
    curve and with the closed-form stability. (Before, the corrected point was taken beyond the
    end and the branch followed out to μ ≈ −60 until max_points.)"""
    eps = _SFold.eps
    # the guess: near the outer root u ≈ 3.83 of ε(u³ − 3u) = 0.5 (Newton refines it)
    r = continue_gait(_SFold(0.5), "mu", 0.5, -3 * eps, guess=[4.8, 2.0], doublings=0)
    br = r.branches[0]
    assert [b.kind for b in r.bifurcations] == ["fold", "fold"]
    assert [b.mu for b in r.bifurcations] == pytest.approx([-2 * eps, 2 * eps], abs=1e-9)
    assert br.end == f"reached mu = {-3 * eps:.10g} (end of the range)"
    assert br.points[-1].mu == pytest.approx(-3 * eps, abs=1e-15)
    assert all(-3 * eps - 1e-15 <= p.mu <= 0.5 for p in br.points)
    for p in br.points:
        u = p.z[0] - 1.0
        assert eps * (u**3 - 3 * u) == pytest.approx(p.mu, abs=1e-10)
        assert p.stable == (abs(u) > 1.0)
    assert min(p.z[0] - 1.0 for p in br.points) < -2.0      # round both folds to the left branch
