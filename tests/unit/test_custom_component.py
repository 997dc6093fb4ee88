"""A user-written component in a few lines: a cubic hardening spring F = k q + c q³.

It compiles like a built-in element, is loadable from a model file by its registered kind,
conserves energy in a lossless mass + cubic spring oscillator, and its period matches an
independent solve_ivp integration of m x'' = −k x − c x³ (Duffing oscillator without damping,
e.g. Nayfeh & Mook, *Nonlinear Oscillations*, Wiley 1979, ch. 4).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

import porthamiltonian as ph
from porthamiltonian import compile_model, io, symbolic


@ph.register
class CubicSpring(ph.Component):
    """Hardening spring F = k q + c q³ on a translational port (power in).

    State: q (m). Energy: ½ k q² + ¼ c q⁴ (J).
    """

    kind = "TestCubicSpring"
    arguments = {"k": ph.Arg("linear stiffness", "N/m"), "c": ph.Arg("cubic stiffness", "N/m^3"),
                 "q0": ph.Arg("initial elongation", "m", default=0)}

    def ports(self):
        return [ph.Port("p", "translation")]

    def build(self, b, k, c, q0):
        q, p = b.state("q", unit="m", initial=q0), b.port("p")
        b.storage(q, energy=k * q**2 / 2 + c * q**4 / 4, port=p, causality="C")


M, K, C3, X0 = 1.0, 1.0, 4.0, 0.8


def duffing_model() -> ph.Model:
    m = ph.Model("duffing")
    m.parameter("m", M, "kg")
    m.parameter("k", K, "N/m")
    m.parameter("c", C3, "N/m^3")
    m.parameter("x0", X0, "m")
    m.add("j", ph.OneJunction())
    m.add("mass", ph.I(inertance="m"))
    m.add("spring", CubicSpring(k="k", c="c", q0="x0"))
    m.connect("j", "mass.p")
    m.connect("j", "spring.p")
    return m


def _downward_zero_crossings(t, x, fun):
    """Times where x changes sign from + to −, refined with brentq on the dense output ``fun``."""
    idx = np.nonzero((x[:-1] > 0) & (x[1:] <= 0))[0]
    return np.array([brentq(fun, t[i], t[i + 1], xtol=1e-15, rtol=4 * np.finfo(float).eps)
                     for i in idx])


def test_custom_component_equations():
    """The compiled laws are q' = p/m, p' = −(k q + c q³), H = p²/(2m) + ½ k q² + ¼ c q⁴."""
    sym = symbolic(duffing_model())
    x = dict(zip(sym.state_names, sym.states))
    par = dict(zip(sym.param_names, sym.params))
    q, p = x["spring.q"], x["mass.p"]
    rhs = dict(zip(sym.state_names, sym.rhs))
    assert sp.simplify(rhs["spring.q"] - p / par["m"]) == 0
    assert sp.simplify(rhs["mass.p"] + par["k"] * q + par["c"] * q**3) == 0
    H = p**2 / (2 * par["m"]) + par["k"] * q**2 / 2 + par["c"] * q**4 / 4
    assert sp.simplify(sym.hamiltonian - H) == 0
    assert sym.p_diss == 0 and sym.p_in == 0


def test_cubic_spring_oscillator_conserves_energy():
    """Lossless: max |H(t) − H(0)| (= the ledger residual) < 1e-9 of H(0) over ~10 periods."""
    compiled = compile_model(duffing_model(), backend="python")
    traj = compiled.simulate(20.0, method="DOP853", dense_output=True, rtol=1e-12, atol=1e-14)
    assert traj.status == "finished", traj.message
    H0 = 0.5 * K * X0**2 + 0.25 * C3 * X0**4
    assert traj.h0 == pytest.approx(H0, rel=1e-14)
    assert np.max(np.abs(traj.H - H0)) / H0 < 1e-9
    assert traj.relative_residual < 1e-9
    # also with the stiff default method at its default tolerances, looser
    radau = compiled.simulate(5.0)
    assert radau.relative_residual < 1e-6


def test_cubic_spring_period_matches_independent_solve_ivp():
    """Period of the library's simulation (time between downward zero crossings of q, on the dense
    output) equals that of scipy's solve_ivp on m x'' = −k x − c x³ (written here, independently)
    to 1e-6 relative, and both agree with the quadrature
    T = 4 ∫₀^A dx / √(2 (V(A) − V(x))/m), V = ½ k x² + ¼ c x⁴ (Nayfeh & Mook ch. 4)."""
    compiled = compile_model(duffing_model(), backend="python")
    traj = compiled.simulate(12.0, method="DOP853", dense_output=True, rtol=1e-12, atol=1e-14)
    iq = compiled.state_index("spring.q")
    t = traj.t
    crossings = _downward_zero_crossings(t, traj["spring.q"], lambda s: traj.sol(s)[iq])
    assert len(crossings) >= 3
    period_lib = float(np.mean(np.diff(crossings)))

    ref = solve_ivp(lambda _, y: [y[1], -(K * y[0] + C3 * y[0] ** 3) / M], (0.0, 12.0),
                    [X0, 0.0], method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True)
    ref_crossings = _downward_zero_crossings(ref.t, ref.y[0], lambda s: ref.sol(s)[0])
    period_ref = float(np.mean(np.diff(ref_crossings)))
    assert abs(period_lib - period_ref) / period_ref < 1e-6

    # quadrature with x = A sin θ removes the endpoint singularity
    def V(x):
        return 0.5 * K * x**2 + 0.25 * C3 * x**4

    def integrand(th):
        return X0 * math.cos(th) / math.sqrt(2 * (V(X0) - V(X0 * math.sin(th))) / M)

    period_quad = 4 * quad(integrand, 0.0, math.pi / 2, epsabs=0, epsrel=1e-13)[0]
    assert abs(period_lib - period_quad) / period_quad < 1e-6
    assert period_quad < 2 * math.pi  # hardening: faster than the linear oscillator


def test_registered_kind_loads_from_a_model_file():
    text = io.dumps(duffing_model())
    assert 'type = "TestCubicSpring"' in text
    loaded = io.loads(text, source="<duffing>")
    assert symbolic(loaded).equations == symbolic(duffing_model()).equations
