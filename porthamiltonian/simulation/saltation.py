"""Saltation matrices, the sensitivities of a hybrid run, Poincaré sections. Numeric, no sympy.

Sensitivities. ``simulate(..., sensitivity=True)`` integrates, beside the state, the matrix
Φ(t) = ∂x(t)/∂x₀ · V of the model state's derivatives along m directions V (the columns of the
``sensitivity`` argument; True: V = I, all model states): between events Φ' = J(t, x) Φ (the
variational equation, integrated by the compiled loops with the trajectory;
porthamiltonian/integrators/rosenbrock_loop.py), and at every event the simulator handles
(a terminal event, with or without an action) Φ jumps by the event's saltation matrix S:

    S = R_x + (f⁺ − R_x f⁻) g_xᵀ / (g_t + g_x · f⁻),

where g(t, x) is the guard that fired (g_x its gradient, g_t its time derivative), f⁻ = f(t, x⁻,
p⁻) and f⁺ = f(t, x⁺, p⁺) the flow just before and just after the event (an action that switches
modes changes the parameters, so f changes even without a reset), and R_x = ∂x⁺/∂x⁻ the
Jacobian of the reset map x⁺ = R(x⁻) (the identity when the action does not move the state;
given by the action as ``Reset(jacobian=...)`` when it does). Derivation: a perturbation δx₀
moves the crossing time by δτ = −g_x Φ⁻ δx₀ / (g_t + g_x f⁻); just after the event the
perturbed state is R(x⁻ + Φ⁻δx₀ + f⁻δτ) while the nominal one has moved on by f⁺δτ, so
δx⁺ = R_x Φ⁻ δx₀ + (R_x f⁻ − f⁺) δτ (Aizerman & Gantmacher 1958; Hiskens & Pai, IEEE Trans.
Circuits Syst. I 47, 204 (2000), with resets; Leine & Nijmeijer, *Dynamics and Bifurcations of
Non-smooth Mechanical Systems*, Springer 2004, §7.2). The gradient of the guard is taken by
central differences of the compiled guard (:mod:`porthamiltonian.simulation.differences`; error ~1e-11 of
its scale, estimated and kept in the :class:`Crossing`): events are few, and a generated guard
Jacobian would add code to every model for them.

Where a run stops at an event (a terminal event without action, or an action's ``stop``), the
state it ends in lies on the event's surface, which moves with x₀: time stops there, f⁺ = 0,

    S_stop = R_x (I − f⁻ g_xᵀ / (g_t + g_x · f⁻)),

the projection along the flow onto the surface g = 0 (then the reset): the run's final Φ is
then the Jacobian of a Poincaré map whose section is that surface (:attr:`Sensitivity.final`).
Its image is tangent to the section (to R(section) after a reset); in coordinates z of the
section (k of them, e.g. n − 1), the map's Jacobian is ``∂z'/∂z = Z · final · X`` with
X = ∂x/∂z the section's parametrization (seeds of the run: ``sensitivity=X``) and Z = ∂z/∂x the
coordinates of a state (:func:`section_jacobian`; :func:`surface_lift` gives X when the section
is parametrized by all states but one, which is solved from g). Its eigenvalues are the Floquet
multipliers of the periodic orbit through a fixed point; the full n × n monodromy Φ(T) has one
more, 1 (the flow direction), which the projection replaces by 0.

Parameter sensitivities (``sensitivity=[names]`` or :class:`Seeds` with ``parameters``):
columns S = ∂x/∂p beside Φ, seeded with ∂x₀/∂p, integrated by the same loops with the forcing
f_p (Φ' = f_x Φ + f_p Π, the model's generated ``jac_p``), where Π = ∂p(t)/∂(column) is the
dependence of the parameter vector in force on the differentiated quantities: a unit column
for p itself, zero for a state direction, changed by actions that set parameters. At an event
the state, the ledger and the parameters jump together: with the augmented state
w = (x, E_diss, E_in, p) (flow (f, P_diss, P_in, 0)), guard g(t, x, p), reset
w⁺ = (R(x⁻, p), E ± (H(x⁺, p⁺) − H(x⁻, p)), P(x⁻, p)) and its Jacobian M,

    S_w = M + (f_w⁺ − M f_w⁻) [g_x, 0, g_p]ᵀ / (g_t + g_x · f⁻),      Ψ⁺ = S_w Ψ⁻,

the formula above in more coordinates (Hiskens & Pai 2000; Galán, Feehery & Barton 1999): the
parameter terms are the columns of g_p (a guard that reads p), of R_p (a reset that reads p:
``Reset(jacobian_p=...)``) and of P (a mode set from the state or from p:
``Reset(params_jacobian=...)``); the event's time moves by τ = −(g_x Φ⁻ + g_p Π⁻) / (g_t + g_x
f⁻) per column (:attr:`Crossing.time_sensitivity`). The ledger is differentiated too, through
the generated ∂H/∂[x, p] (``energy_jac``) at the events' booking of H⁺ − H⁻.

Limits: in runs without parameters the ledger states are not differentiated (their rows are
restarted at each event), and where an action sets a parameter from the state (p⁺ = P(x⁻)) and
that parameter enters the flow after the event, ∂p⁺/∂x⁻ is not included (with parameters it
is, when the action gives it); at a grazing crossing (g_t + g_x·f⁻ = 0) the derivative does not
exist and Φ becomes NaN.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from ..errors import StateError

__all__ = ["Crossing", "Seeds", "Sensitivity", "compose", "saltation_matrix", "section_jacobian",
           "section_projection", "surface_lift"]

#: |g_t + g_x·f⁻| below this fraction of |g_t| + |g_x||f⁻|: a grazing crossing
GRAZING = 1e-12


def _crossing_rate(f_minus: np.ndarray, g_x: np.ndarray, g_t: float) -> float:
    """dg/dt along the flow at the crossing; NaN when it grazes (see :data:`GRAZING`)."""
    rate = float(g_t + g_x @ f_minus)
    if not abs(rate) > GRAZING * (abs(g_t) + float(np.linalg.norm(g_x) * np.linalg.norm(f_minus))):
        return float("nan")
    return rate


def saltation_matrix(f_minus: np.ndarray, f_plus: np.ndarray, g_x: np.ndarray,
                     reset_jacobian: np.ndarray | None = None, g_t: float = 0.0) -> np.ndarray:
    """S = R_x + (f⁺ − R_x f⁻) g_xᵀ / (g_t + g_x · f⁻) (module docstring): the jump of the
    sensitivities Φ⁺ = S Φ⁻ at an event with guard gradient ``g_x`` (and ∂g/∂t ``g_t``), flow
    ``f_minus`` before and ``f_plus`` after (zeros: the run stops there), reset Jacobian
    ``reset_jacobian`` (None: the identity). NaN everywhere at a grazing crossing."""
    f_minus = np.asarray(f_minus, dtype=float)
    f_plus = np.asarray(f_plus, dtype=float)
    g_x = np.asarray(g_x, dtype=float)
    n = f_minus.shape[0]
    R = np.eye(n) if reset_jacobian is None else np.asarray(reset_jacobian, dtype=float)
    if f_plus.shape != (n,) or g_x.shape != (n,) or R.shape != (n, n):
        raise StateError(f"saltation_matrix: f_minus, f_plus and g_x must have {n} entries and "
                         f"the reset Jacobian {n} x {n}; got {f_plus.shape}, {g_x.shape}, "
                         f"{R.shape}")
    rate = _crossing_rate(f_minus, g_x, float(g_t))
    return R + np.outer(f_plus - R @ f_minus, g_x) / rate


def section_projection(f: np.ndarray, g_x: np.ndarray, g_t: float = 0.0) -> np.ndarray:
    """P = I − f g_xᵀ / (g_t + g_x · f): the Jacobian of the flow's projection onto the surface
    g = 0 along f (a run stopping at an event without reset; :func:`saltation_matrix` with
    f⁺ = 0)."""
    f = np.asarray(f, dtype=float)
    return saltation_matrix(f, np.zeros_like(f), g_x, None, g_t)


def compose(flows: Sequence[np.ndarray], saltations: Sequence[np.ndarray]) -> np.ndarray:
    """Φ_K S_{K−1} Φ_{K−1} … S_1 Φ_1: the monodromy of K segments with flow Jacobians ``flows``
    (each from its segment's start, n x n; the first may be n x m) and the K − 1 saltation
    matrices between them (a run with sensitivities composes this as it goes)."""
    if len(saltations) != len(flows) - 1:
        raise StateError(f"compose: {len(flows)} segments need {len(flows) - 1} saltation "
                         f"matrices, got {len(saltations)}")
    out = np.asarray(flows[0], dtype=float)
    for S, Phi in zip(saltations, flows[1:]):
        out = np.asarray(Phi, dtype=float) @ (np.asarray(S, dtype=float) @ out)
    return out


def surface_lift(g_x: np.ndarray, coordinates: Sequence[int]) -> np.ndarray:
    """X = ∂x/∂z (n x k) of the surface g(x) = 0 parametrized by the states ``coordinates``
    (z = x[coordinates], k = n − 1), the remaining state solved from g (its entry of g_x must not
    vanish): the identity on the coordinates, −g_x[coordinates] / g_x[r] in the row r solved."""
    g_x = np.asarray(g_x, dtype=float)
    n = g_x.shape[0]
    coordinates = list(coordinates)
    rest = [i for i in range(n) if i not in coordinates]
    if len(rest) != 1 or len(set(coordinates)) != n - 1:
        raise StateError(f"surface_lift: give {n - 1} distinct coordinates of the {n} states, "
                         f"got {coordinates}")
    r = rest[0]
    if g_x[r] == 0.0:
        raise StateError(f"surface_lift: the guard does not depend on state {r}, which cannot be "
                         "solved from it; choose other coordinates")
    X = np.zeros((n, n - 1))
    X[coordinates, range(n - 1)] = 1.0
    X[r] = -g_x[coordinates] / g_x[r]
    return X


def section_jacobian(final: np.ndarray, project: np.ndarray,
                     lift: np.ndarray | None = None) -> np.ndarray:
    """∂z'/∂z = Z · final · X of a Poincaré map in section coordinates (module docstring):
    ``final`` the run's final Φ (n x k when the run was seeded with X = ``lift``, else n x n and
    ``lift`` is applied here), ``project`` Z = ∂z/∂x (k x n) at the final state."""
    out: np.ndarray = np.asarray(project, dtype=float) @ np.asarray(final, dtype=float)
    return out if lift is None else out @ np.asarray(lift, dtype=float)


@dataclass(frozen=True)
class Seeds:
    """What ``simulate(..., sensitivity=Seeds(...))`` differentiates the run by.

    states : the directions V in the initial model state (n x m0), True for all of them (the
        identity), False for none.
    parameters : parameter names: one column ∂x/∂p each after the state directions.
    initial : ∂x₀/∂p (n x len(parameters)), the initial state's dependence on the parameters;
        None: that of the model's initial values (when ``x0`` is None or a mapping), else zero.
    """

    states: Any = True
    parameters: Sequence[str] = ()
    initial: Any = None


@dataclass(frozen=True)
class Crossing:
    """An event a run with sensitivities went through (module docstring; model-state vectors of
    length n).

    t, event : time and event name; x_minus, x_plus : the state before and after the action;
    f_minus, f_plus : the flow before and after (f_plus zero where the run stopped);
    guard_gradient, guard_rate : g_x and g_t (g_t = 0 for an autonomous guard); guard_error : an
    estimate of the largest error of the difference g_x (:mod:`porthamiltonian.simulation.differences`);
    reset_jacobian : R_x; saltation : S; stop : the run stopped here; phi_minus, phi_plus : the
    sensitivities (n x m, the parameter columns after the state directions) before and after
    (phi_plus = saltation @ phi_minus without parameters).
    time_sensitivity : how the event's time moves per column (m), −(g_x Φ⁻ + g_p Π⁻) / (g_t +
        g_x · f⁻) (NaN when the guard gradient was not needed: no sensitivities of the time).
    augmented : with parameters, S_w over (x, E_diss, E_in, p) (module docstring), else None.
    guard_parameters : with parameters, g_p by parameter name (those differentiated).
    params_minus : with parameters, Π⁻ = ∂p/∂(columns) of the parameters in force before the
        event (len(param_names) x m), else None.
    """

    t: float
    event: str
    x_minus: np.ndarray
    x_plus: np.ndarray
    f_minus: np.ndarray
    f_plus: np.ndarray
    guard_gradient: np.ndarray
    guard_rate: float
    guard_error: float
    reset_jacobian: np.ndarray
    saltation: np.ndarray
    stop: bool
    phi_minus: np.ndarray
    phi_plus: np.ndarray
    time_sensitivity: np.ndarray
    augmented: np.ndarray | None = None
    guard_parameters: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    params_minus: np.ndarray | None = None


@dataclass(frozen=True)
class Sensitivity:
    """The sensitivities of a run (``Trajectory.sensitivity``; module docstring).

    seeds : V (n x m), the directions in the initial model state; phi : Φ at every stored point
        of the trajectory (len(t) x n x m; at an event's time the point before it holds the
        limit from before, the point after it the limit from after); crossings : the events the
        run went through, in order (:class:`Crossing`); final : Φ where the run ended — at a
        stop at an event, the Jacobian of the state on the event's surface (S_stop Φ⁻), else
        Φ at the last point.
    error : the largest error estimate of Φ's accepted sub-steps over the run (relative to Φ,
        in the norm of the state's error control), in units of rtol: at most 10, the
        sub-steps' tolerance, unless a limit of the sub-stepping was reached (a sub-step of
        1e-9 of a step, 400 sub-steps in one step); Φ is then less accurate there. (Φ has its
        own error control, in sub-steps of the steps chosen for x, which stay as they are.)

    With parameters (module docstring): parameter_names : the differentiated parameters;
    parameters : ∂x/∂p by name at every stored point (len(t) x n, the state order of the
    trajectory); final_parameters : ∂x/∂p where the run ended (n x k; on the event's surface
    at a stop, as ``final``); ledger : ∂(E_diss, E_in) at every stored point (len(t) x 2 x
    (m + k): the state directions' columns, then the parameters'); final_ledger : the same where
    the run ended (2 x (m + k)); final_params : ∂p/∂(columns) of the parameter vector in force
    where the run ended (len(param_names) x (m + k): unit rows for the differentiated
    parameters, and the modes an action set from the state or from them). Without parameters
    these are empty or None.
    """

    seeds: np.ndarray
    phi: np.ndarray
    crossings: tuple[Crossing, ...]
    final: np.ndarray
    error: float
    parameter_names: tuple[str, ...] = ()
    parameters: Mapping[str, np.ndarray] = field(default_factory=lambda: MappingProxyType({}))
    final_parameters: np.ndarray | None = None
    ledger: np.ndarray | None = None
    final_ledger: np.ndarray | None = None
    final_params: np.ndarray | None = None

    def __post_init__(self) -> None:
        for array in (self.seeds, self.phi, self.final, self.final_parameters, self.ledger,
                      self.final_ledger, self.final_params, *self.parameters.values()):
            if array is not None:
                array.flags.writeable = False
        object.__setattr__(self, "parameters", MappingProxyType(dict(self.parameters)))
