"""Saltation matrices and the section projection (walker_library.saltation) on a bouncing ball,
against its closed form.

The ball: state x = (z, v), ż = v, v̇ = −g; an impact where z falls through 0, reset
v⁺ = −e v⁻ (restitution e). The stand-in for the integration loops' sensitivity variant is
scipy's DOP853 on the flow and its variational equation Φ̇ = ∂f/∂x Φ together (rtol 1e-12).

Closed forms (w = √(v₀² + 2 g z₀) the impact speed, t_b = (v₀ + w)/g the impact time, τ = T − t_b):
after one bounce z(T) = e w τ − g τ²/2, v(T) = e w − g τ, differentiated by hand below; the map
"just after a bounce" → "just after the next" is v ↦ e v (derivative e, and the flow direction
maps onto itself: the trivial multiplier 1); apex to apex, h ↦ e² h (derivative e²).
Stand-in note: the integration loops will provide the flows' Φ and the events; the algebra
(saltation, projection, composition) is what is tested here.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from walker_library.saltation import compose, saltation, section_projection

G, E = 9.81, 0.7
A = np.array([[0.0, 1.0], [0.0, 0.0]])            # ∂f/∂x of the flight
R_X = np.diag([1.0, -E])                           # ∂R/∂x of the impact
GRAD_G = np.array([1.0, 0.0])                      # the guard z


def f(x):
    return np.array([x[1], -G])


def flight(x0, t_end=None, until_impact=True):
    """(x at the end, Φ, t): the flow and its state-transition matrix, to the impact (z falling
    through 0, after leaving it) or over t_end."""
    def rhs(t, y):
        Phi = y[2:].reshape(2, 2)
        return np.concatenate([f(y[:2]), (A @ Phi).ravel()])

    def impact(t, y):
        return y[0]
    impact.terminal, impact.direction = True, -1
    y0 = np.concatenate([x0, np.eye(2).ravel()])
    span = (0.0, 100.0 if t_end is None else t_end)
    sol = solve_ivp(rhs, span, y0, method="DOP853", rtol=1e-12, atol=1e-14,
                    events=impact if until_impact else None)
    y = sol.y[:, -1]
    return y[:2], y[2:].reshape(2, 2), sol.t[-1]


def bounce(x):
    return np.array([x[0], -E * x[1]])


def closed_form(z0, v0, T):
    w = math.sqrt(v0 * v0 + 2 * G * z0)
    tb = (v0 + w) / G
    tau = T - tb
    dw = np.array([G / w, v0 / w])
    dtau = -np.array([1.0 / w, (1.0 + v0 / w) / G])
    dz = E * dw * tau + (E * w - G * tau) * dtau
    dv = E * dw - G * dtau
    return np.array([E * w * tau - G * tau**2 / 2, E * w - G * tau]), np.vstack([dz, dv])


def test_saltation_over_a_bounce_matches_the_closed_form():
    """Flow to the impact, saltation matrix, flow to T: the state-transition matrix over [0, T]
    equals the closed form's derivative to 1e-9 (and the state to 1e-10); without the saltation
    term (∂R/∂x alone) it is wrong by O(1)."""
    x0, T = np.array([1.0, 0.5]), 0.9
    x1, Phi1, tb = flight(x0)
    S = saltation(R_X, f(x1), f(bounce(x1)), GRAD_G)
    x2, Phi2, _ = flight(bounce(x1), T - tb, until_impact=False)
    M = compose([Phi1, Phi2], [S])
    x_ref, M_ref = closed_form(*x0, T)
    assert np.max(np.abs(x2 - x_ref)) < 1e-10
    assert np.max(np.abs(M - M_ref)) < 1e-9
    assert np.max(np.abs(compose([Phi1, Phi2], [R_X]) - M_ref)) > 0.1


def test_bounce_to_bounce_map_has_derivative_e_and_a_trivial_multiplier():
    """From just after a bounce (z = 0, v₀ > 0) to just after the next: M = S Φ carries a
    perturbation to the nominal time just after the second bounce, and maps the flow direction
    just after the first bounce onto the one just after the second (the trivial multiplier 1).
    Projected on the section (the guard z = 0, with the field after the bounce), the derivative
    of the bounce-to-bounce map v ↦ e v is e (to 1e-10), a perturbation stays on the section,
    and the flow direction goes to 0."""
    v0 = 3.0
    x_start = np.array([0.0, v0])
    x1, Phi, _ = flight(x_start)
    x_after = bounce(x1)
    S = saltation(R_X, f(x1), f(x_after), GRAD_G)
    M = compose([Phi], [S])
    assert x_after[1] == pytest.approx(E * v0, abs=1e-10)
    np.testing.assert_allclose(M @ f(x_start), f(x_after), atol=1e-9)
    assert abs(M[1, 1] - E) > 1                        # not yet on the section
    P = section_projection(f(x_after), GRAD_G) @ M
    assert P[1, 1] == pytest.approx(E, abs=1e-10)      # δv₀ (in the section) -> δv
    assert abs(P[0, 1]) < 1e-10                        # ... stays on the section z = 0
    np.testing.assert_allclose(P @ f(x_start), 0.0, atol=1e-9)


def test_apex_to_apex_map_by_the_section_projection():
    """Apex (v = 0) to apex through one bounce: h ↦ e² h. The monodromy Φ₂ S Φ₁ projected on the
    section v = 0 (Π = I − f ∇hᵀ/(∇h·f)) gives dh'/dh = e² to 1e-9 and keeps a perturbation on
    the section (δv = 0); unprojected, a perturbation of h changes v at the nominal time."""
    h0 = 1.2
    x1, Phi1, _ = flight(np.array([h0, 0.0]))
    S = saltation(R_X, f(x1), f(bounce(x1)), GRAD_G)
    t_up = E * math.sqrt(2 * G * h0) / G                      # rise time to the next apex
    x2, Phi2, _ = flight(bounce(x1), t_up, until_impact=False)
    assert x2[0] == pytest.approx(E**2 * h0, abs=1e-10) and abs(x2[1]) < 1e-10
    P = section_projection(f(x2), np.array([0.0, 1.0])) @ compose([Phi1, Phi2], [S])
    assert P[0, 0] == pytest.approx(E**2, abs=1e-9)
    assert abs(P[1, 0]) < 1e-10
    assert abs(compose([Phi1, Phi2], [S])[1, 0]) > 1e-2


def test_grazing_and_bad_shapes_are_refused():
    with pytest.raises(ValueError, match="grazing"):
        saltation(R_X, np.array([0.0, -G]), np.array([0.0, -G]), GRAD_G)
    with pytest.raises(ValueError, match="tangent"):
        section_projection(np.array([1.0, 0.0]), np.array([0.0, 1.0]))
    with pytest.raises(ValueError, match="event matrices"):
        compose([np.eye(2)], [np.eye(2), np.eye(2)])
