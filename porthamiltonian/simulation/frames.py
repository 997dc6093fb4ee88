"""Trajectories as pandas data frames (pandas is the optional ``frames`` extra, in ``.[all]``).

:func:`trajectory_frame` (``Trajectory.to_dataframe()``) gives one row per stored point, indexed by
time ``t`` (s), with one column per state, the energy ledger (``H``, ``E_diss``, ``E_in``,
``residual``, J) and the named outputs. An event that restarts the integration (a reset, a
mode change) stores the state just before it and after it at the same time, so the index is
sorted but may repeat there. The units (SI) are
in ``df.attrs["units"]`` by column (``""`` where the model does not know one); ``df.attrs`` also
holds the model's name, the run's status and its events. With xarray installed,
``df.to_xarray()`` makes an ``xarray.Dataset`` of it (pandas' own conversion): no second code
path here.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .trajectory import Trajectory

__all__ = ["LEDGER_UNITS", "require_pandas", "trajectory_columns", "trajectory_frame"]

#: the ledger's columns and their unit
LEDGER_UNITS = {"H": "J", "E_diss": "J", "E_in": "J", "residual": "J"}


def require_pandas() -> Any:
    """The pandas module, or ImportError saying how to install it."""
    try:
        import pandas
    except ImportError:
        raise ImportError("data frames need pandas: pip install 'porthamiltonian[frames]'") from None
    return pandas


def trajectory_columns(traj: Trajectory, outputs: bool | Sequence[str] = True
                       ) -> dict[str, tuple[Any, str]]:
    """``{column: (values over t, unit)}``: the states, the ledger, then the outputs (all,
    none, or the names given, which may also be states or ledger terms)."""
    model = traj.model
    units = getattr(model, "units", {}) or {}
    cols: dict[str, tuple[Any, str]] = {}
    x = traj.x
    for i, name in enumerate(model.state_names):
        cols[name] = (x[:, i], units.get(name, ""))
    ledger = {"H": traj.H, "E_diss": traj.E_diss, "E_in": traj.E_in, "residual": traj.residual}
    for name, values in ledger.items():
        cols[name] = (values, LEDGER_UNITS[name])
    if outputs is True:
        Y = traj.outputs
        for i, name in enumerate(model.output_names):
            cols[name] = (Y[:, i], units.get(name, ""))
    elif outputs:
        for name in outputs:
            if name not in cols:
                cols[name] = (traj[name], units.get(name, ""))
    return cols


def trajectory_frame(traj: Trajectory, outputs: bool | Sequence[str] = True) -> Any:
    """The trajectory as a :class:`pandas.DataFrame` (see the module docstring). ``outputs``:
    every named output (True), none (False), or the names listed."""
    pd = require_pandas()
    cols = trajectory_columns(traj, outputs)
    frame = pd.DataFrame({name: values for name, (values, _) in cols.items()},
                         index=pd.Index(traj.t, name="t"))
    frame.attrs["units"] = {"t": "s", **{name: unit for name, (_, unit) in cols.items()}}
    frame.attrs["model"] = traj.model.name
    frame.attrs["status"] = traj.status
    frame.attrs["events"] = [(float(t), str(name)) for t, name in traj.events]
    return frame
