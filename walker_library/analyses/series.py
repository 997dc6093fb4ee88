"""Time series of a walk for plots, reports and animations (SI units, thesis conventions).

:func:`walk_series` walks ``n_steps`` from a section state in one recorded simulation and returns
a :class:`GaitSeries`: at every stored integration point the thesis's θ, φ and their rates
(θ the stance leg's angle to the slope normal, φ the angle between the legs: the walker's
``[walker.angles]``, in the section's labelling under the parameters in force at that point, so
that θ jumps at each heel strike as the legs exchange roles), the energies (H, the multibody's
potential V and kinetic T, the ledger's E_diss and E_in, the residual), the step index, and the
stick figure (the hip's and the feet's points in the slope frame: x down the slope, z along its
normal) for animations. One conversion serves every walker (:class:`~.core.HybridWalker`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from numbers import Integral
from typing import TYPE_CHECKING

import numpy as np

from porthamiltonian.errors import OptionError

from ..core.protocol import Stride

if TYPE_CHECKING:        # (the command line reads MAX_SERIES_STEPS without loading walkers)
    from ..core.walker import HybridWalker

__all__ = ["GaitSeries", "walk_series"]


@dataclass
class GaitSeries:
    """Arrays over the stored points of one recorded walk (length N each, SI units).

    t (s); step (0-based index of the step in progress); theta, phi (rad), theta_dot, phi_dot
    (rad/s) — phi and phi_dot are NaN for a walker without φ (the rimless wheel); H, V, T,
    E_diss, E_in, residual (J); hip (N × 2: x, z in m) and feet (N × F × 2: the walker's F feet
    or spoke tips, m); strides: the :class:`~.protocol.Stride` records of the walk; events:
    (time, name) of every model event of the run (each stored as repeated time points: the state
    just before it, and after its reset).
    """

    t: np.ndarray
    step: np.ndarray
    theta: np.ndarray
    phi: np.ndarray
    theta_dot: np.ndarray
    phi_dot: np.ndarray
    H: np.ndarray
    V: np.ndarray
    T: np.ndarray
    E_diss: np.ndarray
    E_in: np.ndarray
    residual: np.ndarray
    hip: np.ndarray
    feet: np.ndarray
    strides: list[Stride]
    events: list[tuple[float, str]] = field(default_factory=list)

    @property
    def step_times(self) -> np.ndarray:
        """Times (s) at which the steps end (heel strikes), cumulative."""
        return np.cumsum([s.duration for s in self.strides if not s.fell])


#: the most steps :func:`walk_series` records: one simulation keeps every integrator step (60
#: strides of the compass walker for a report: 0.5 GB), and the series is drawn and animated;
#: :func:`~walker_library.analyses.gait.walk` walks any number of steps in bounded memory
MAX_SERIES_STEPS = 100


def check_series_steps(option: str, n_steps: int) -> None:
    """``n_steps`` of a recorded walk: a whole number from 1 to :data:`MAX_SERIES_STEPS`, else
    an OptionError naming ``option`` (a command's ``--steps``, the API's ``n_steps``)."""
    if isinstance(n_steps, bool) or not isinstance(n_steps, Integral) or not (
            1 <= n_steps <= MAX_SERIES_STEPS):
        raise OptionError(f"{option} must be a whole number from 1 to {MAX_SERIES_STEPS}, got "
                          f"{n_steps!r}: a recorded walk (figures, animation) keeps every "
                          "integrator step; `walker walk MODEL --steps N` walks any number of "
                          "steps with their records and ledger")


def walk_series(walker: HybridWalker, z: np.ndarray, n_steps: int, *, ground_drop: float = 0.0,
                max_step: float | None = None) -> GaitSeries:
    """Walk ``n_steps`` (at most :data:`MAX_SERIES_STEPS`) from section state ``z`` (recorded)
    and convert (module docstring). ``max_step`` (s) caps the integrator's step for smooth
    curves (the stored points are the integrator's own; an explicit method on a smooth swing
    phase takes few, long steps)."""
    check_series_steps("n_steps", n_steps)
    if max_step is not None and max_step < walker.options.max_step:
        walker = walker.with_options(max_step=float(max_step))
    strides = walker.walk(np.asarray(z, dtype=float), n_steps, record=True, ground_drop=ground_drop)
    traj = strides[-1].info["trajectory"]
    t = traj.t
    ends = np.cumsum([s.duration for s in strides if not s.fell])
    step = np.minimum(np.searchsorted(ends, t, side="left"), len(strides) - 1)
    P = traj.p
    n = walker.model.n_states
    N = len(t)
    angles = {k: np.full(N, np.nan) for k in ("theta", "phi", "theta_dot", "phi_dot")}
    hip = np.empty((N, 2))
    feet = np.empty((N, len(walker.feet), 2))
    Y = traj.outputs
    col = walker.model.output_index
    for i in range(N):
        x = traj.y[:n, i]
        xc, v, _ = walker.canonical(x, P[i])
        for k, value in walker.angles(xc, v).items():
            angles[k][i] = value
    if walker.hip:
        hip[:] = Y[:, [col(f"{walker.hip}.x"), col(f"{walker.hip}.z")]]
    for j, point in enumerate(walker.feet):
        feet[:, j] = Y[:, [col(f"{point}.x"), col(f"{point}.z")]]
    mb = walker.multibody
    return GaitSeries(t=t, step=step, H=traj.H, V=np.asarray(traj[f"{mb}.V"]),
                      T=np.asarray(traj[f"{mb}.T"]), E_diss=traj.E_diss, E_in=traj.E_in,
                      residual=traj.residual, hip=hip, feet=feet, strides=strides,
                      events=list(traj.events), **angles)
