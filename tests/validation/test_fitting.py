"""Fitting parameters to data (porthamiltonian/simulation/fitting.py): synthetic data from the
model at known parameters plus seeded Gaussian noise, fitted from other starting values.

With the model linear in its noise and the noise Gaussian, the reported 95 % intervals should
contain the true values in about 95 % of the trials; the check: in at least 90 % of 50 seeded
trials, for every parameter. Independent of the model's own sensitivities: the truth is the
value the data were generated with. A parameter the data cannot determine is reported
(the rank of the sensitivity matrix), not fitted.
"""
from __future__ import annotations

import numpy as np
import pytest

import porthamiltonian as ph
from porthamiltonian import compile_model, io
from porthamiltonian.errors import DataError, OptionError

TRIALS = 50


@pytest.fixture(scope="module")
def msd():
    return compile_model(io.load("mass_spring_damper"), backend="c")


def _coverage(fits, truth: dict[str, float]) -> dict[str, int]:
    """How many fits' intervals contain each true value."""
    return {p: sum(f.intervals[p][0] <= v <= f.intervals[p][1] for f in fits)
            for p, v in truth.items()}


def test_mass_spring_damper_intervals_cover_the_truth(msd):
    """k = 4 N/m, c = 0.4 N s/m (ζ = 0.1); the spring's elongation at 20 times over 10 s with
    σ = 2 mm noise (2 % of the 0.1 m amplitude), the momentum at 10 other times with a gap
    (different sample times per output), fitted from k = 3, c = 0.6 with the noise's level
    estimated from the residuals (Student's t intervals): every fit converges, and the 95 %
    intervals contain the truth in ≥ 45 of 50 trials for k and for c (measured: 47 and 49)."""
    truth = {"k": 4.0, "c": 0.4}
    tq = np.linspace(0.5, 10.0, 20)
    tp = np.concatenate([np.linspace(0.3, 3.0, 5), np.linspace(6.0, 9.5, 5)])
    clean = msd.simulate(10.0, t_eval=np.union1d(tq, tp), rtol=1e-10, atol=1e-12,
                         method="Rodas5P")
    q = np.interp(tq, clean.t, clean["spring.q"])
    p = np.interp(tp, clean.t, clean["mass.p"])
    sigma = {"spring.q": 2e-3, "mass.p": 4e-3}
    fits = []
    for seed in range(TRIALS):
        rng = np.random.default_rng(seed)
        data = {"spring.q": (tq, q + sigma["spring.q"] * rng.standard_normal(tq.size)),
                "mass.p": (tp, p + sigma["mass.p"] * rng.standard_normal(tp.size))}
        f = ph.fit(msd, data, ["k", "c"], initial={"k": 3.0, "c": 0.6},
                   weights={k: 1 / s for k, s in sigma.items()})
        assert f.converged and f.identifiable and f.n_data == 30, f.message
        fits.append(f)
    covered = _coverage(fits, truth)
    print("coverage", covered)
    assert min(covered.values()) >= 0.9 * TRIALS, covered


@pytest.fixture(scope="module")
def ball():
    return compile_model(io.load("bouncing_ball"), backend="c")


def test_hunt_crossley_ball_stiffness_and_damping(ball):
    """The Hunt–Crossley floor K = 1e6 N/m, λ = 1e5 N s/m²: the first touchdown and lift-off and
    the second touchdown (σ = 20 µs, a 50 kHz force plate; the noise's level known: normal
    intervals; the model run at rtol 1e-7, whose error on these times, ~1e-8 s, is far below
    the noise) fitted from K = 9e5, λ = 1.1e5. The flight between the bounces measures the
    restitution (a function of λ v/K), the contact's duration (≈ 3 ms) the stiffness: both are
    identifiable, and the 95 % intervals contain the truth in ≥ 45 of 50 trials (measured:
    MEASURED_BALL)."""
    truth = {"K": 1e6, "lam": 1e5}
    clean = ball.simulate(1.0, rtol=1e-10, atol=1e-12, method="Rodas5P")
    times = {"touchdown": [], "liftoff": []}
    for t, name in clean.events:
        times[name].append(t)
    assert len(times["touchdown"]) == len(times["liftoff"]) == 2
    times["liftoff"] = times["liftoff"][:1]
    sigma_t = 2e-5
    weights = {"touchdown": 1 / sigma_t, "liftoff": 1 / sigma_t}
    fits = []
    for seed in range(TRIALS):
        rng = np.random.default_rng(100 + seed)
        events = {k: np.array(v) + sigma_t * rng.standard_normal(len(v))
                  for k, v in times.items()}
        f = ph.fit(ball, None, ["K", "lam"], events=events, t_end=0.86, weights=weights,
                   initial={"K": 9e5, "lam": 1.1e5}, absolute_sigma=True, rtol=1e-7, atol=1e-9)
        assert f.converged and f.identifiable, f.message
        fits.append(f)
    covered = _coverage(fits, truth)
    print("coverage", covered)
    assert min(covered.values()) >= 0.9 * TRIALS, covered


def test_unidentifiable_parameters_are_reported_not_fitted(msd):
    """The free response of m x'' + c x' + k x = 0 from rest depends on k/m and c/m only:
    fitting m, k and c together is refused with the three named, the null direction (1, 1, 1)
    in relative units, rank 2, the estimates NaN."""
    clean = msd.simulate(10.0, t_eval=np.linspace(0.1, 10, 30), rtol=1e-10, atol=1e-12,
                         method="Rodas5P")
    f = ph.fit(msd, {"t": clean.t, "spring.q": clean["spring.q"]}, ["m", "k", "c"],
               initial={"m": 1.2, "k": 4.5, "c": 0.5})
    assert not f.identifiable and f.status == "unidentifiable" and f.rank == 2
    assert set(f.unidentifiable) == {"m", "k", "c"}
    (direction,) = f.null_directions
    v = np.array([direction[p] for p in ("m", "k", "c")])
    np.testing.assert_allclose(np.abs(v), np.full(3, 1 / np.sqrt(3)), atol=1e-4)
    assert all(np.isnan(f.estimates[p]) for p in ("m", "k", "c"))
    assert "cannot determine" in f.message


def test_fit_input_errors(msd):
    """Bad data and options are typed errors naming what is wrong."""
    with pytest.raises(DataError, match="no sample"):
        ph.fit(msd, {"spring.q": ([1.0, 2.0], [np.nan, np.nan])}, ["k"])
    with pytest.raises(DataError, match="times for"):
        ph.fit(msd, {"spring.q": ([1.0, 2.0], [1.0])}, ["k"])
    with pytest.raises(OptionError, match="distinct"):
        ph.fit(msd, {"spring.q": ([1.0], [0.0])}, ["k", "k"])
    with pytest.raises(OptionError, match="outside the bounds"):
        ph.fit(msd, {"spring.q": ([1.0], [0.0])}, ["k"], bounds={"k": (5.0, 6.0)})


def test_a_deadline_returns_the_best_point_reached_and_progress_sees_every_run(msd):
    """``progress`` hears of every run (its count and cost); a fit whose deadline has passed
    after its first run starts no other: its result is that run's point (the start), status
    "time_limit", not converged, with the statistics there; the fit without a deadline from
    the same start reaches a lower cost than any run the progress saw before its end."""
    t = np.linspace(0.5, 10.0, 20)
    q = msd.simulate(10.0, t_eval=t, rtol=1e-10, atol=1e-12, method="Rodas5P")["spring.q"]
    data = {"spring.q": (t, q + 2e-3 * np.random.default_rng(3).standard_normal(t.size))}
    heard: list[tuple[int, float]] = []
    full = ph.fit(msd, data, ["k", "c"], initial={"k": 3.0, "c": 0.6},
                  progress=lambda runs, cost: heard.append((runs, cost)))
    assert full.converged and [r for r, _ in heard] == list(range(1, len(heard) + 1))
    assert len(heard) >= full.nfev and full.cost == pytest.approx(min(c for _, c in heard),
                                                                  rel=1e-12)
    stopped = ph.fit(msd, data, ["k", "c"], initial={"k": 3.0, "c": 0.6}, deadline=0.0)
    assert stopped.status == "time_limit" and not stopped.converged and stopped.nfev == 1
    assert stopped.estimates == {"k": 3.0, "c": 0.6}
    assert stopped.cost == pytest.approx(heard[0][1], rel=1e-12) and stopped.cost > full.cost
    assert "stopped at the time limit after 1 runs" in stopped.message
    assert all(np.isfinite(v) for v in stopped.standard_errors.values())
