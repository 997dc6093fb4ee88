"""Trajectory: the immutable result of a simulation, with named access and the energy ledger.

Shaped like scipy's ``OdeResult`` (``t``, ``status``, ``message``, ``success``, ``nfev``) plus:

* ``traj["mass.p"]`` — a state, any named output (``"spring.p.e"``: the spring force), a
  parameter (its value in force at each point: modes change at events), an input, or a
  multibody's acceleration (``"arm.a.pivot"``), over ``t``;
* ``traj.p`` — the parameter values in force at each point;
* ``traj.H``, ``traj.E_diss``, ``traj.E_in``, ``traj.residual`` — the energy ledger
  (r = H − H(0) + E_diss − E_in), ``traj.energy_scale`` (the energy that moved during the run,
  blind to a constant offset of H) and ``traj.relative_residual``;
* ``traj.sol(t)`` — dense output (model states) at any time of the run;
* ``traj.events`` — (time, name) of every event, ``traj.jumps`` — H jumps booked at resets;
* ``to_csv`` / ``to_npz`` — export with named columns; ``to_dataframe`` — a pandas data frame
  with the units in ``df.attrs["units"]`` (:mod:`porthamiltonian.simulation.frames`);
* ``plot(*names)`` — a quick look, and a compact table in Jupyter (:mod:`porthamiltonian.simulation.display`).

A trajectory is made once, by :class:`porthamiltonian.simulation.simulate.Simulator`, and never changes:
its arrays are read-only (copy one to modify it); derived quantities (outputs, H) are computed
on first access and kept.
"""
from __future__ import annotations

import csv
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..backends import at_points
from ..errors import OptionError

if TYPE_CHECKING:
    from .compiled import CompiledModel
    from .saltation import Sensitivity


class Status(StrEnum):
    """How a simulation ended. A ``str``: ``traj.status == "finished"`` holds, and the value is
    what the command line and the JSON results show."""

    FINISHED = "finished"      #: reached t_end
    EVENT = "event"            #: stopped at a terminal event (or by an event action)
    FAILED = "failed"          #: the integrator failed (step size, too many steps or events)
    DIVERGED = "diverged"      #: max|x| exceeded the divergence bound, or became non-finite


def _frozen(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


#: the dense output's samples per step that :meth:`Trajectory.extrema` (and the sweeps' settling
#: time) look at: a compiled method's steps are long (30 to an oscillation's period at rtol 1e-9),
#: and a peak between two of them would be missed on the steps alone
SAMPLES_PER_STEP = 8
#: the most samples near the largest (and near the smallest) that :meth:`Trajectory.extrema`
#: looks at more closely
EXTREMUM_CANDIDATES = 8


def sampled_times(t: np.ndarray) -> np.ndarray:
    """The stored times ``t`` with :data:`SAMPLES_PER_STEP` - 1 equally spaced times inside each
    interval between them (the dense output's samples)."""
    t = np.asarray(t, dtype=float)
    fractions = np.arange(SAMPLES_PER_STEP) / SAMPLES_PER_STEP
    inner = t[:-1, None] + np.diff(t)[:, None] * fractions
    return np.append(inner.ravel(), t[-1])


@dataclass(frozen=True)
class Segment:
    """One continuous piece of the run between events, with the parameter values in force."""

    t: np.ndarray
    y: np.ndarray            # (n + 2, len(t)): model states and ledger states
    p: np.ndarray
    #: the interpolant over [sol.t_min, sol.t_max] (scipy's OdeSolution, or a compiled run's
    #: :class:`~.dense.StepInterpolant`), or None
    sol: Any
    phi: np.ndarray | None = None   # (len(t), n + 2, m): the sensitivities, when asked for
    #: callable inputs (scipy path): (t, x, p) -> p with their slots set, else None
    inputs: Any = None

    def __post_init__(self) -> None:
        for array in (self.t, self.y, self.p, self.phi):
            if array is not None:
                _frozen(array)


class Trajectory:
    """Result of :func:`porthamiltonian.simulation.simulate.simulate`. See the module docstring.

    Attributes
    ----------
    model : the compiled model simulated.
    segments : the continuous pieces of the run (:class:`Segment`), in time order.
    status : a :class:`Status`; ``message`` says why the run ended.
    nfev, njev, nlu : right-hand-side and Jacobian evaluations, LU decompositions.
    h0 : H at the start (J), the origin of the residual.
    sensitivity : the derivatives of the run by its initial state
        (:class:`~porthamiltonian.simulation.saltation.Sensitivity`), when ``simulate(...,
        sensitivity=...)`` asked for them; else None.
    """

    __slots__ = ("_cache", "_events", "_jumps", "h0", "message", "model", "nfev", "njev", "nlu",
                 "segments", "sensitivity", "status")
    model: CompiledModel
    segments: tuple[Segment, ...]
    status: Status
    message: str
    nfev: int
    njev: int
    nlu: int
    h0: float
    sensitivity: Sensitivity | None
    _events: tuple[tuple[float, str], ...]
    _jumps: tuple[tuple[float, str, float], ...]
    _cache: dict[str, np.ndarray]

    def __init__(self, model: CompiledModel, segments: Sequence[Segment],
                 events: Sequence[tuple[float, str]], jumps: Sequence[tuple[float, str, float]],
                 status: Status, message: str, *, nfev: int, njev: int, nlu: int, h0: float,
                 sensitivity: Sensitivity | None = None):
        values = {"model": model, "segments": tuple(segments), "_events": tuple(events),
                  "_jumps": tuple(jumps), "status": Status(status), "message": message,
                  "nfev": nfev, "njev": njev, "nlu": nlu, "h0": h0, "sensitivity": sensitivity,
                  "_cache": {}}
        for name, value in values.items():
            object.__setattr__(self, name, value)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"a Trajectory is immutable (cannot set {name!r}); simulate again, "
                             "or copy its arrays")

    @property
    def events(self) -> list[tuple[float, str]]:
        """(time, name) of every event, in time order (a new list)."""
        return list(self._events)

    @property
    def jumps(self) -> list[tuple[float, str, float]]:
        """(time, event name, jump of H in J) of every reset (a new list)."""
        return list(self._jumps)

    # --- access ---------------------------------------------------------------------------------
    @property
    def success(self) -> bool:
        """True when the run reached t_end or stopped at a terminal event (not failed/diverged)."""
        return self.status in (Status.FINISHED, Status.EVENT)

    @property
    def t(self) -> np.ndarray:
        """The times of the stored points (s); an event's time appears at the end of the segment
        before it and at the start of the one after it."""
        return self._concat("t", lambda s: s.t)

    @property
    def y(self) -> np.ndarray:
        """Integration states (n + 2, len(t)): model states then E_diss, E_in."""
        return self._concat("y", lambda s: s.y, axis=1)

    @property
    def x(self) -> np.ndarray:
        """Model states, shape (len(t), n)."""
        return self.y[: self.model.n_states].T

    @property
    def x_final(self) -> np.ndarray:
        """The model state at the end of the run (a copy)."""
        return self.segments[-1].y[: self.model.n_states, -1].copy()

    @property
    def t_final(self) -> float:
        """The time the run ended (s)."""
        return float(self.segments[-1].t[-1])

    @property
    def p(self) -> np.ndarray:
        """The parameter values in force at each point, shape (len(t), n_params); names in
        ``model.param_names`` (modes switched by event actions change them between segments)."""
        return self._concat("p", lambda s: np.repeat(s.p[None, :], len(s.t), axis=0))

    def p_at(self, i: int) -> np.ndarray:
        """The parameter values in force at stored point ``i`` (``p[i]``, without building
        :attr:`p`: a walker reads them at a few points of a long run)."""
        if "ends" not in self._cache:
            self._cache["ends"] = np.cumsum([len(s.t) for s in self.segments])
        ends = self._cache["ends"]
        i = int(i) + int(ends[-1]) if i < 0 else int(i)
        if not 0 <= i < ends[-1]:
            raise IndexError(f"point {i} of a trajectory of {int(ends[-1])} points")
        return self.segments[int(np.searchsorted(ends, i, side="right"))].p

    def _concat(self, key: str, get: Callable[[Segment], np.ndarray], axis: int = 0) -> np.ndarray:
        if key not in self._cache:
            parts = [get(s) for s in self.segments]
            self._cache[key] = _frozen(np.concatenate(parts, axis=axis) if parts else np.empty(0))
        return self._cache[key]

    def _per_point(self, key: str, fn: Callable[[float, np.ndarray, Any], Any]) -> np.ndarray:
        """``fn(t, y, p)`` (a back-end function) at every point, kept under ``key``."""
        if key not in self._cache:
            parts = [self._on_segment(s, fn, s.t, s.y.T) for s in self.segments if len(s.t)]
            self._cache[key] = _frozen(np.concatenate(parts) if parts else np.array([]))
        return self._cache[key]

    def _on_segment(self, s: Segment, fn: Callable[[float, np.ndarray, Any], Any],
                    t: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """``fn(t_k, rows[k], p)`` at points of segment ``s`` (integration states as rows),
        stacked: in one batch with the segment's parameters (converted once), or point by point
        with its inputs bound there (the scipy path's callable inputs)."""
        if s.inputs is None:
            return at_points(fn, t, rows, self.model.native_params(s.p))
        n = self.model.n_states
        return np.array([np.asarray(fn(tk, np.ascontiguousarray(yk),
                                       self.model.native_params(s.inputs(tk, yk[:n], s.p))))
                         for tk, yk in zip(t, rows)])

    @property
    def outputs(self) -> np.ndarray:
        """All named outputs, shape (len(t), n_outputs); names in ``model.output_names``."""
        return self._per_point("outputs", self.model.functions.outputs)

    def __getitem__(self, name: str) -> np.ndarray:
        """A state, a ledger column (``H``, ``E_diss``, ``E_in``, ``residual``), a named output or
        a parameter (its value in force at each point) over ``t``, looked up in that order."""
        if name in self.model.state_names:
            return self.x[:, self.model.state_index(name)]
        ledger = {"H": self.H, "E_diss": self.E_diss, "E_in": self.E_in, "residual": self.residual}
        if name in ledger:
            return ledger[name]
        if name in self.model.param_names and name not in self.model.output_names:
            return self.p[:, self.model.param_names.index(name)]
        if name in self.model.input_names and name not in self.model.output_names:
            return self.inputs[:, self.model.input_names.index(name)]
        from .linearize import acceleration_rows, acceleration_values  # (a multibody's v̇)

        rows = acceleration_rows(self.model)
        if name in rows and name not in self.model.output_names:
            values = self._per_point("accelerations", lambda t, y, pn: acceleration_values(
                self.model, t, y, pn))
            return values[:, list(rows).index(name)]
        return self.outputs[:, self.model.output_index(name)]

    @property
    def inputs(self) -> np.ndarray:
        """The inputs' values at each point, shape (len(t), m); names in
        ``model.input_names``."""
        if "inputs" not in self._cache:
            n, m, P = self.model.n_states, len(self.model.input_names), len(self.model.param_names)
            rows = []
            for s in self.segments:
                for k in range(len(s.t)):
                    p = s.inputs(s.t[k], s.y[:n, k], s.p) if s.inputs is not None else s.p
                    rows.append(p[P:P + m] + p[P + m:P + 2 * m] * s.t[k])
            self._cache["inputs"] = _frozen(np.array(rows).reshape(len(rows), m))
        return self._cache["inputs"]

    def sol(self, t: float | np.ndarray) -> np.ndarray:
        """Dense output: model states at time(s) ``t`` (shape (n,) or (n, len(t)))."""
        t_arr = np.atleast_1d(np.asarray(t, dtype=float))
        states = self._dense(t_arr, outputs=False)[0][: self.model.n_states]
        return states[:, 0] if np.ndim(t) == 0 else states

    def _dense(self, t: np.ndarray, outputs: bool) -> tuple[np.ndarray, np.ndarray]:
        """The integration states ((n + 2) x len(t)) at the times ``t`` from the segments'
        interpolants, and (``outputs``; else len(t) x 0) every named output there, computed
        with the parameters (and inputs) in force, in one call per segment where the back end
        has one (:func:`~porthamiltonian.backends.at_points`). A time on two segments (an event)
        takes the first's value. OptionError for a time outside the run or a run without dense
        output."""
        model = self.model
        ys = np.empty((model.n_states + 2, len(t)))
        outs = np.empty((len(t), len(model.output_names) if outputs else 0))
        todo = np.ones(len(t), dtype=bool)
        for s in self.segments:
            if s.sol is None:
                continue
            here = todo & (s.sol.t_min <= t) & (t <= s.sol.t_max)
            if not np.any(here):
                continue
            todo &= ~here
            ys[:, here] = np.asarray(s.sol(t[here]))
            if not outputs:
                continue
            outs[here] = self._on_segment(s, model.functions.outputs, t[here],
                                          np.ascontiguousarray(ys[:, here].T))
        if np.any(todo):
            raise OptionError(f"t = {t[todo][0]} is outside the simulated interval, or the "
                              "run was made without dense_output=True")
        return ys, outs

    def values_at(self, name: str, t: float | np.ndarray) -> np.ndarray:
        """A state or a named output (``traj[name]``'s units) at any time(s) ``t`` of a run made
        with ``dense_output=True`` (shape of ``t``): the states from the dense output (as
        :meth:`sol`), an output computed from them with the parameters (and inputs) in force
        there. A time on two segments (an event) takes the first's value."""
        t_arr = np.atleast_1d(np.asarray(t, dtype=float))
        values = self._pick(name, *self._dense(t_arr, name not in self.model.state_names))
        return np.asarray(values[0] if np.ndim(t) == 0 else values)

    def _pick(self, name: str, ys: np.ndarray, outs: np.ndarray) -> np.ndarray:
        """State or output ``name`` out of :meth:`_dense`'s arrays."""
        if name in self.model.state_names:
            return np.asarray(ys[self.model.state_index(name)])
        k = self.model.output_index(name)       # an unknown name fails here, naming the outputs
        return np.asarray(outs[:, k])

    def extrema(self, name: str) -> tuple[float, float]:
        """The smallest and the largest value (min, max) of a state or named output over the
        run, in its units, from a run made with ``dense_output=True``.

        The candidates: the stored points (both sides of every event) and the dense output at
        :data:`SAMPLES_PER_STEP` times per step; around each of the (at most
        :data:`EXTREMUM_CANDIDATES`) largest samples within 1 % of the samples' range of the
        largest (the sampling can rank two nearly equal peaks wrongly), 33 times over the
        intervals on both sides, then the vertex of the parabola through the best three; and
        the same for the smallest. A compiled method's steps are long (30 to an oscillation's
        period at rtol 1e-9): the stored points alone put a peak up to about 0.5 % of the
        amplitude too low; this finds it to the interpolant's accuracy. When a stored value is
        not finite (a run that diverged), the stored points' min and max (NaN propagates)."""
        points = np.asarray(self[name], dtype=float)
        if not np.all(np.isfinite(points)):
            return float(np.min(points)), float(np.max(points))
        output = name not in self.model.state_names
        if "sample_y" not in self._cache or (output and "sample_out" not in self._cache):
            times = sampled_times(self.t)      # kept: a sweep asks for several names
            ys, outs = self._dense(times, output)
            self._cache.update(sample_t=times, sample_y=ys, **({"sample_out": outs} if output
                                                                else {}))
        times = self._cache["sample_t"]
        values = self._pick(name, self._cache["sample_y"],
                            self._cache.get("sample_out", np.empty((len(times), 0))))
        spread = float(np.max(values) - np.min(values))
        last = len(times) - 1
        chosen, signs = [], []
        for sign in (-1.0, 1.0):             # the min as the max of −y
            signed = sign * values
            top = min(EXTREMUM_CANDIDATES, len(signed))
            order = np.argpartition(-signed, top - 1)[:top]
            near = order[signed[order] >= np.max(signed) - 0.01 * spread]
            chosen.append(near)
            signs.append(np.full(len(near), sign))
        picked = np.concatenate(chosen)
        lo, hi = times[np.maximum(picked - 1, 0)], times[np.minimum(picked + 1, last)]
        wide = hi > lo
        found = {sign: float(np.max(sign * np.concatenate([points, values])))
                 for sign in (-1.0, 1.0)}
        if np.any(wide):
            grid = lo[wide, None] + (hi - lo)[wide, None] * np.linspace(0.0, 1.0, 33)
            sign_of = np.concatenate(signs)[wide, None]
            z = sign_of * self.values_at(name, grid.ravel()).reshape(grid.shape)
            j = np.clip(np.argmax(z, axis=1), 1, 31)
            rows = np.arange(len(z))
            left, mid, right = z[rows, j - 1], z[rows, j], z[rows, j + 1]
            curvature = left - 2.0 * mid + right
            peak = curvature < 0.0             # a peak inside the window: its vertex
            shift = np.where(peak, 0.5 * (left - right) / np.where(peak, curvature, -1.0), 0.0)
            vertex = grid[rows, j] + np.clip(shift, -1.0, 1.0) * (grid[:, 1] - grid[:, 0])
            at_vertex = sign_of[:, 0] * self.values_at(name, vertex)
            for sign in (-1.0, 1.0):
                mine = sign_of[:, 0] == sign
                if np.any(mine):
                    found[sign] = max(found[sign], float(np.max(z[mine])),
                                      float(np.max(at_vertex[mine])))
        return -found[-1.0], found[1.0]

    # --- energy ledger --------------------------------------------------------------------------
    @property
    def power(self) -> np.ndarray:
        """[H, P_diss, P_in] at each time, shape (len(t), 3)."""
        return self._per_point("energy", self.model.functions.energy)

    @property
    def H(self) -> np.ndarray:
        """The Hamiltonian (stored energy, J) at each point."""
        return self.power[:, 0]

    @property
    def E_diss(self) -> np.ndarray:
        """The energy dissipated since the start (J), at each point."""
        return self.y[self.model.n_states, :]

    @property
    def E_in(self) -> np.ndarray:
        """The energy supplied since the start (J), at each point."""
        return self.y[self.model.n_states + 1, :]

    @property
    def residual(self) -> np.ndarray:
        """r(t) = H(t) − H(0) + E_diss(t) − E_in(t) (J); zero up to integration error (NaN where
        the energy is infinite: a run that overflowed; numpy's warning about it is not shown)."""
        with np.errstate(invalid="ignore", over="ignore"):
            r: np.ndarray = self.H - self.h0 + self.E_diss - self.E_in
        return r

    @property
    def energy_scale(self) -> float:
        """The scale of the residual (J): the energy in play during the run,

            Σ_stored max_t |H_k| + Σ_potential (max_t H_k − min_t H_k) + max_t |E_diss| + max_t |E_in|

        over the energy parts H_k of the model (``model.energy_parts``: each storage component's
        stored energy, a multibody's kinetic energy T, all zero at rest, and its potential energy
        V, measured from an arbitrary datum), but at least 64 ε max_t |H| (ε the float64 epsilon:
        below that the residual is the round-off of H itself).

        Why: a constant offset of H (a potential measured from a datum far away, a pendulum whose
        pivot is raised by 1e6 m) changes no range, no kinetic or elastic energy and no ledger
        total, so it cannot make a failing run pass; the old scale, max |H|, grew with the offset.
        Potentials enter by their range, the energy they exchange; the other storages by their
        size, so that a run whose energy stays in one storage (a spinning free body) is still
        measured against that energy."""
        moved = float(np.max(np.abs(self.E_diss)) + np.max(np.abs(self.E_in)))
        if self.model.energy_parts and len(self.t):
            columns = [self.model.output_index(name) for name, _ in self.model.energy_parts]
            parts = self.outputs[:, columns]
            for k, (_, kind) in enumerate(self.model.energy_parts):
                part = parts[:, k]
                moved += float(np.ptp(part) if kind == "potential" else np.max(np.abs(part)))
        floor = 64 * np.finfo(float).eps * float(np.max(np.abs(self.H)))
        return max(moved, floor, 1e-300)

    @property
    def relative_residual(self) -> float:
        """max_t |r(t)| / :attr:`energy_scale`: what ``check-energy`` compares with the model's
        ``energy_tolerance``."""
        return float(np.max(np.abs(self.residual)) / self.energy_scale)

    def ledger(self) -> dict[str, Any]:
        """The final ledger: H(0), H(T), dissipated, supplied, residual, relative residual, and
        (models with actuators, :class:`porthamiltonian.library.signals.Actuator`) the energy
        each actuator supplied, ``actuators`` = {name: J} (part of ``supplied``)."""
        out: dict[str, Any] = {
            "H0": self.h0, "HT": float(self.H[-1]), "dissipated": float(self.E_diss[-1]),
            "supplied": float(self.E_in[-1]), "residual": float(self.residual[-1]),
            "max_abs_residual": float(np.max(np.abs(self.residual))),
            "relative_residual": self.relative_residual}
        works = {name[:-len(".work")]: float(self.x[-1, i] - self.x[0, i])
                 for i, (name, role) in enumerate(zip(self.model.state_names,
                                                      self.model.state_roles))
                 if role == "quadrature" and name.endswith(".work")}
        if works:
            out["actuators"] = works
        return out

    # --- export ---------------------------------------------------------------------------------
    def columns(self, outputs: bool = False) -> dict[str, np.ndarray]:
        """Named columns: t, the states, the ledger (H, E_diss, E_in, residual), and the outputs
        if ``outputs`` (what :meth:`to_csv` and :meth:`to_npz` write)."""
        cols = {"t": self.t}
        cols.update({name: self.x[:, i] for i, name in enumerate(self.model.state_names)})
        cols.update({"H": self.H, "E_diss": self.E_diss, "E_in": self.E_in,
                     "residual": self.residual})
        if outputs:
            cols.update({n: self.outputs[:, i] for i, n in enumerate(self.model.output_names)})
        return cols

    def to_csv(self, path: str | Path, outputs: bool = False) -> None:
        """Write named columns (t, states, ledger[, outputs]) as CSV with a header row."""
        cols = self.columns(outputs)
        with open(path, "w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(cols)
            writer.writerows(zip(*(np.asarray(c).tolist() for c in cols.values())))

    def to_npz(self, path: str | Path, outputs: bool = False) -> None:
        """Write named arrays (t, states, ledger[, outputs]) plus status and message to ``.npz``."""
        arrays: dict[str, Any] = {"status": self.status, "message": self.message,
                                  **self.columns(outputs)}
        np.savez(path, **arrays)

    def to_dataframe(self, outputs: bool | list[str] = True) -> Any:
        """A pandas DataFrame indexed by t (s): states, ledger, outputs (all, none or those
        named), units in ``df.attrs["units"]`` (see :mod:`porthamiltonian.simulation.frames`)."""
        from .frames import trajectory_frame
        return trajectory_frame(self, outputs)

    def plot(self, *names: str, ax: Any = None, events: bool = True) -> Any:
        """Plot states, outputs or ledger terms over t (default: the states); returns the Axes
        (see :func:`porthamiltonian.simulation.display.plot_trajectory`)."""
        from .display import plot_trajectory
        return plot_trajectory(self, *names, ax=ax, events=events)

    def _repr_html_(self) -> str:
        from .display import trajectory_html
        return trajectory_html(self)

    def __repr__(self) -> str:
        return (f"Trajectory({self.model.name!r}, status={self.status.value!r}, t=[{self.t[0]:g}, "
                f"{self.t[-1]:g}], {len(self.t)} points, {len(self.events)} events)")
