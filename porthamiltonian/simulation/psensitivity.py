"""Parameter sensitivities of a run: the parameter columns' state and their jump at events.
Numeric, no sympy.

A run with parameter sensitivities (:mod:`.saltation`, module docstring) integrates columns
S = ∂x/∂(column) for the state directions and the parameters together; beside them it keeps
Π = ∂p/∂(column), the dependence of the parameter vector in force on each column (a unit row per
differentiated parameter; a mode that an action sets from the state or from a differentiated
parameter gets a row too). The compiled loops integrate S' = f_x S + f_p Π with the model's
generated ``jac_p`` over the parameters of :attr:`ParameterColumns.compiled` (their rows of Π
are the loops' ``gain``); a mode whose row becomes nonzero at an event joins them (the model
compiles itself again with it, once, and the run continues with that build: its right-hand side
is the same code).

:func:`parameter_jump` is the augmented saltation matrix at one event, over w = (x, E_diss,
E_in, p):

    M = ∂w⁺/∂w⁻ = [[R_x, 0, R_p], [±∂J/∂x, I, ±∂J/∂p], [P_x, 0, P_p]],
    J = H(x⁺, p⁺) − H(x⁻, p⁻) (the jump the action books: − into E_diss, + into E_in),
    S_w = M + (f_w⁺ − M f_w⁻) [g_x, 0, g_p]ᵀ / (g_t + g_x · f⁻),

(f_w = (ẋ, P_diss, P_in, 0); at a stop f_w⁺ = 0). ∇H comes from the generated ``energy_jac``
(exact, also where a contact's H is only C¹: on the very surfaces where its events fire), its
parameter columns for a parameter outside the build (a mode an action sets) by central
differences; g_x and g_p from the generated ``guard_jac`` (exact) for a model event, g_t and a
parameter outside the build by central differences of the guard (:mod:`.differences`), as all
of them for a guard given as a function.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ModelError, StateError
from .differences import gradient, jacobian
from .saltation import saltation_matrix

if TYPE_CHECKING:
    from .compiled import CompiledModel

__all__ = ["JumpResult", "ParameterColumns", "jac_p_build", "output_gradient",
           "parameter_jump"]


def jac_p_build(model: CompiledModel, names: Sequence[str]) -> CompiledModel:
    """The model with ``jac_p`` over at least ``names`` (itself when it has them; else compiled
    again with them, once: the build a run with parameter sensitivities by ``names`` starts
    with)."""
    if set(names) <= set(model.jac_p_names):
        return model
    return model.extended(jac_p=list(names))


class ParameterColumns:
    """Π, and the build of the model whose loops integrate the columns (module docstring).

    model : the compiled model run; names : the differentiated parameters; m : the number of
    columns (state directions, then one per parameter). ``pi`` (len(param_names) x m) starts
    with a unit entry per differentiated parameter.
    """

    def __init__(self, model: CompiledModel, names: Sequence[str], m: int):
        self.model = model
        self.names = tuple(names)
        n_p = len(model.param_names)
        self.pi = np.zeros((n_p, m))
        for c, name in enumerate(self.names):
            self.pi[model.param_names.index(name), m - len(self.names) + c] = 1.0
        self.build = self._build(list(self.names))

    def _build(self, names: list[str]) -> CompiledModel:
        return jac_p_build(self.model, names)

    @property
    def compiled(self) -> list[str]:
        """The parameters of the build's ``jac_p``, in its order."""
        return list(self.build.jac_p_names)

    def live(self) -> np.ndarray:
        """Indices of the parameters whose row of Π is not zero."""
        return np.flatnonzero(np.any(self.pi != 0.0, axis=1))

    def gain(self) -> np.ndarray:
        """The loops' gain: the rows of Π of the build's ``jac_p`` parameters, in its order
        (no rows when they are all zero: no forcing)."""
        rows = self.pi[[self.model.param_names.index(n) for n in self.compiled]]
        return np.ascontiguousarray(rows if np.any(rows) else rows[:0])

    def guard_jacobian(self, k: int, t: float, y: np.ndarray, p: np.ndarray
                       ) -> tuple[np.ndarray, dict[int, float]] | None:
        """(∂g_k/∂x over the model states, ∂g_k/∂p_i by parameter index for the build's
        ``jac_p`` parameters) of the model's guard ``k`` at (t, y, p), exact: the generated
        ``guard_jac``; None when the build has none (a guard reading a kernel output without
        tangents)."""
        fun = self.build.functions.extra.get("guard_jac")
        if fun is None:
            return None
        n = self.model.n_states
        row = np.asarray(fun(t, y, self.build.native_params(p)), dtype=float)[k]
        index = self.model.param_names.index
        return row[:n].copy(), {index(name): float(v)
                                for name, v in zip(self.compiled, row[n:])}

    def follow(self) -> None:
        """After an event the run continues from: a parameter whose row became nonzero joins
        the build's (a new build, once per set of names)."""
        names = [self.model.param_names[i] for i in self.live()]
        missing = [n for n in names if n not in self.compiled]
        if missing:
            self.build = self._build(self.compiled + missing)


@dataclass(frozen=True)
class JumpResult:
    """:func:`parameter_jump`'s result: the columns after the event (``phi``, n + 2 rows;
    ``pi``), the augmented saltation matrix, the time sensitivity per column, g_t, g_x, g_p by
    parameter index, the guard gradient's error estimate."""

    phi: np.ndarray
    pi: np.ndarray
    augmented: np.ndarray
    time_sensitivity: np.ndarray
    g_t: float
    g_x: np.ndarray
    g_p: Mapping[int, float]
    guard_error: float


def _energy_gradient(columns: ParameterColumns, t: float, y: np.ndarray, p: np.ndarray,
                     params: Sequence[int]) -> tuple[np.ndarray, dict[int, float]]:
    """(∂H/∂x over the model states, ∂H/∂p_i for i in ``params``) at (t, y, p): the generated
    ``energy_jac``, differences for a parameter outside the build."""
    build, model = columns.build, columns.model
    n = model.n_states
    g = np.asarray(build.functions.extra["energy_jac"](t, y, build.native_params(p)),
                   dtype=float)[0]
    compiled = columns.compiled
    out: dict[int, float] = {}
    for i in params:
        name = model.param_names[i]
        if name in compiled:
            out[i] = float(g[n + 2 + compiled.index(name)])
        else:
            def energy(v: np.ndarray, i: int = i) -> float:
                q = p.copy()
                q[i] = v[0]
                return float(model.energy(t, y, q)[0])
            out[i] = float(gradient(energy, np.array([p[i]]), 1.0).value[0])
    return g[:n], out


def parameter_jump(columns: ParameterColumns, phi: np.ndarray, t: float, y_minus: np.ndarray,
                   p_minus: np.ndarray, y_plus: np.ndarray, p_plus: np.ndarray,
                   reset_x: np.ndarray, reset_p: Mapping[str, np.ndarray] | None,
                   changed: Mapping[str, np.ndarray | None], booking: str, stop: bool,
                   moved: bool, guard: Callable[[float, np.ndarray, np.ndarray], float],
                   scale: np.ndarray, event: str, guard_index: int | None = None) -> JumpResult:
    """The columns (``phi``: n + 2 x m; Π in ``columns``) across one event (module docstring).

    y_minus, p_minus, y_plus, p_plus : integration state and parameters before and after the
    action; reset_x : R_x; reset_p : ∂x⁺/∂p by name (the action's ``jacobian_p``, a name left
    out: not read; needed when ``moved``); changed : the parameters the action set,
    each with the gradient of its new value by [x⁻, p] (n + len(param_names)) or None
    (constant); booking : "dissipated" or "supplied"; stop : the run ends on the event's
    surface (f⁺ = 0); guard : g(t, x, p) of the model state x; scale : the typical size of
    (t, x) for the guard's differences; event : its name, for messages; guard_index : the
    index of a model event's guard among the model's (its generated gradient is used), None
    for a guard given as a function (differences)."""
    model = columns.model
    n, names = model.n_states, model.param_names
    N, n_p = n + 2, len(names)
    live = columns.live()
    index = {name: i for i, name in enumerate(names)}
    # the reset's parameter columns
    R_p = np.zeros((n, n_p))
    if moved:
        if reset_p is None:
            raise ModelError(f"the action of event {event!r} moved the state at t = {t:.6g}: "
                             "with parameter sensitivities it must also return "
                             "Reset(jacobian_p={name: dx_plus/dp}) for the parameters its map "
                             "reads (an empty mapping if it reads none)")
        for name, column in reset_p.items():
            column = np.asarray(column, dtype=float)
            if name not in index or column.shape != (n,) or not np.all(np.isfinite(column)):
                raise StateError(f"the action of event {event!r} returned jacobian_p[{name!r}] "
                                 f"of shape {column.shape} (must be a parameter's name and "
                                 f"{n} finite numbers)")
            R_p[:, index[name]] = column
    # the parameters' map
    rows: dict[int, np.ndarray] = {}
    for name, row in changed.items():
        i = index[name]
        if row is None:
            rows[i] = np.zeros(n + n_p)
            continue
        row = np.asarray(row, dtype=float)
        if row.shape != (n + n_p,) or not np.all(np.isfinite(row)):
            raise StateError(f"the action of event {event!r} returned params_jacobian[{name!r}] "
                             f"of shape {row.shape} (must be {n} + {n_p} finite numbers: by "
                             "the model states, then by every parameter)")
        rows[i] = row
    f_minus = np.asarray(model.functions.rhs(t, y_minus, model.native_params(p_minus)))[:N]
    f_plus = (np.zeros(N) if stop else
              np.asarray(model.functions.rhs(t, y_plus, model.native_params(p_plus)))[:N])
    g_t, g_x, g_p, guard_error = _guard_gradient(columns, guard, guard_index, t, y_minus,
                                                 p_minus, live, scale)
    # the ledger's jump J = H(x⁺, p⁺) − H(x⁻, p⁻)
    moving = [i for i, row in rows.items() if np.any(row[:n]) or np.any(row[n:][live])]
    dH_minus, Hp_minus = _energy_gradient(columns, t, y_minus, p_minus, list(live))
    dH_plus, Hp_plus = _energy_gradient(columns, t, y_plus, p_plus,
                                        sorted(set(live) | set(moving)))
    dJ_dx = dH_plus @ reset_x - dH_minus
    dJ_dp = dH_plus @ R_p
    for i in live:
        if i not in rows:
            dJ_dp[i] += Hp_plus[i]
        dJ_dp[i] -= Hp_minus[i]
    for i in moving:
        dJ_dx += Hp_plus[i] * rows[i][:n]
        dJ_dp += Hp_plus[i] * rows[i][n:]
    # M over w = (x, E_diss, E_in, p)
    M = np.zeros((N + n_p, N + n_p))
    M[:n, :n] = reset_x
    M[:n, N:] = R_p
    M[n:N, n:N] = np.eye(2)
    ledger, sign = (n, -1.0) if booking == "dissipated" else (n + 1, 1.0)
    M[ledger, :n] += sign * dJ_dx
    M[ledger, N:] += sign * dJ_dp
    for i in range(n_p):
        if i in rows:
            M[N + i, :n] = rows[i][:n]
            M[N + i, N:] = rows[i][n:]
        else:
            M[N + i, N + i] = 1.0
    # only the columns of the live parameters meet nonzero rows of Π
    keep = np.zeros(n_p, dtype=bool)
    keep[live] = True
    M[:, N:][:, ~keep] = 0.0
    for i in range(n_p):
        if not keep[i] and i not in rows:
            M[N + i, N + i] = 1.0
    g_w = np.zeros(N + n_p)
    g_w[:n] = g_x
    g_w[N + live] = g_p
    S = saltation_matrix(np.concatenate([f_minus, np.zeros(n_p)]),
                         np.concatenate([f_plus, np.zeros(n_p)]), g_w, M, g_t)
    psi = np.vstack([phi, columns.pi])
    rate = g_t + g_x @ f_minus[:n]
    tau = -(g_w @ psi) / rate
    out = S @ psi
    return JumpResult(out[:N], out[N:], S, tau, g_t, g_x,
                      {int(i): float(v) for i, v in zip(live, g_p)}, guard_error)


def _guard_gradient(columns: ParameterColumns,
                    guard: Callable[[float, np.ndarray, np.ndarray], float],
                    guard_index: int | None, t: float, y: np.ndarray, p: np.ndarray,
                    live: np.ndarray, scale: np.ndarray
                    ) -> tuple[float, np.ndarray, np.ndarray, float]:
    """(g_t, g_x, g_p over ``live``, error estimate) of the guard at the event (t, y, p).

    A model event's guard: g_x and g_p by the build's parameters from the generated
    ``guard_jac`` (exact), g_t and g_p by a parameter outside the build (a mode an action
    sets) by central differences along those coordinates only. A guard given as a function
    (or a model without ``guard_jac``): central differences along (t, x, p_live)."""
    n = columns.model.n_states
    exact = None if guard_index is None else columns.guard_jacobian(guard_index, t, y, p)
    if exact is None:
        rest = list(range(n + 1)) + [n + 1 + c for c in range(len(live))]
        g_x = np.zeros(n)
        known: dict[int, float] = {}
    else:
        g_x, known = exact
        rest = [0] + [n + 1 + c for c, i in enumerate(live) if i not in known]
    z = np.concatenate([[t], y[:n], p[live]])
    sizes = np.concatenate([scale, np.ones(len(live))])

    def g(w: np.ndarray) -> float:
        zz = z.copy()
        zz[rest] = w
        q = p.copy()
        q[live] = zz[n + 1:]
        return float(guard(float(zz[0]), zz[1:n + 1].copy(), q))

    grad = gradient(g, z[rest], sizes[rest])
    full = np.zeros(len(z))
    full[rest] = grad.value
    if exact is not None:
        full[1:n + 1] = g_x
        for c, i in enumerate(live):
            if i in known:
                full[n + 1 + c] = known[i]
    return float(full[0]), full[1:n + 1], full[n + 1:], grad.max_error


def output_gradient(model: CompiledModel, o: int, t: float, x: np.ndarray, p: np.ndarray,
                    rows: Sequence[int] | np.ndarray, build: CompiledModel | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """(∂y_o/∂x, ∂y_o/∂p) of output ``o`` at (t, x, p); ∂y_o/∂p over every parameter of the
    model, by those of ``rows`` (the parameters whose row of Π is not zero) and 0 by the
    others, which are not perturbed (a mode or an unrelated parameter). The chain rule with the
    run's columns gives the output's sensitivity: dy = ∂y/∂x S + ∂y/∂p Π.

    build : the model compiled with ``jac_p`` (the run's build): ∂y_o/∂x and ∂y_o/∂p by its
    ``jac_p`` parameters from its generated ``outputs_jac`` (exact); the rest (no build, no
    ``outputs_jac``, a parameter outside it) by central differences (:mod:`.differences`)."""
    index = np.asarray(rows, dtype=int)
    dp = np.zeros(len(model.param_names))
    fun = None if build is None else build.functions.extra.get("outputs_jac")
    if fun is not None and build is not None:
        n = model.n_states
        y = np.ascontiguousarray(x if len(x) == n + 2 else model.augment(x), dtype=float)
        row = np.asarray(fun(t, y, build.native_params(p)), dtype=float)[o]
        dx = np.zeros(len(x))
        dx[:n] = row[:n]
        exact = {model.param_names.index(name): float(v)
                 for name, v in zip(build.jac_p_names, row[n:])}
        dp[[i for i in index if i in exact]] = [exact[i] for i in index if i in exact]
        index = np.array([i for i in index if i not in exact], dtype=int)
    else:
        dx = jacobian(lambda xx: model.outputs(t, xx, p)[o:o + 1], x, 1.0).value[0]

    def by(v: np.ndarray) -> np.ndarray:
        q = p.copy()
        q[index] = v
        return model.outputs(t, x, q)[o:o + 1]

    if len(index):
        dp[index] = jacobian(by, p[index], 1.0).value[0]
    return dx, dp
