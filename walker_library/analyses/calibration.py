"""The thesis's calibration of the contact damping that its text lost.

The contact damping of the nominal walker (the Hunt–Crossley λ; the thesis's App. A reads a
garbled "Kd = e7") is set the thesis's way (M. Jafarian 2010, MSc report 022CE2010, University of
Twente, §2.3.2): the smallest damping that maximises the energy dissipated per impact — a
near-plastic impact. :func:`calibrate_damping` starts the walker at a heel-strike section state
and measures the energy the ledger books as dissipated over the impact window, for a grid of
damping values.

Measured for compass_walker (models/compass_walker.toml) from its initial guess: the dissipation
over 0.05 s rises from 0.0036 J at λ = 1e5 N·s/m² (the foot bounces) to a plateau of 0.0927 J from
λ ≈ 3e7 on (max 0.09269 J at 1.8e9; within 0.1 % from 3.16e7): λ = 3.16e7 N·s/m². For a
Kelvin–Voigt contact (damping B, N·s/m) the same procedure gives B = 1e3 N·s/m: 0.0165 J at
B = 100, 0.0830 J at 562, a plateau of 0.0939 J from 1e3 on.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from porthamiltonian import Component

from ..core.walker import HybridWalker
from .results import JSONResult

__all__ = ["DampingCalibration", "calibrate_damping"]


@dataclass
class DampingCalibration(JSONResult):
    """Result of :func:`calibrate_damping` (SI units): the damping grid (``lam``: N·s/m² for
    Hunt–Crossley, N·s/m for Kelvin–Voigt), the energy dissipated per impact at each value (J),
    its maximum, and the calibrated value: the smallest grid value whose dissipation is within
    ``rel_tol`` of the maximum."""

    lam: list[float]
    dissipated: list[float]
    max_dissipated: float
    lam_at_max: float
    calibrated_lam: float
    rel_tol: float
    window: float
    #: the damping parameter varied (``lam``; ``B_contact`` for a Kelvin–Voigt walker, N·s/m)
    parameter: str = "lam"


def _damping_parameter(walker: HybridWalker) -> str:
    """The parameter named by the first foot's contact component as its damping."""
    foot = next(f for f in walker.spec.feet if f.contact)
    contact = walker.spec.model.component(str(foot.contact))
    value = contact.args.get("damping") if isinstance(contact, Component) else None
    return str(value) if isinstance(value, str) else "lam"


def calibrate_damping(walker: HybridWalker, z: np.ndarray | None = None,
                      lams: np.ndarray | None = None, *, window: float = 0.05,
                      rel_tol: float = 1e-3, parameter: str | None = None) -> DampingCalibration:
    """Calibrate the contact damping the thesis's way (module docstring).

    For each value of ``lams`` (default: 10^5 … 10^10, four per decade) the walker is started at
    the heel-strike section state ``z`` (default: its initial guess, the pre-impact state of the
    gait) with its start modes (both feet's contacts on) and simulated for ``window`` seconds
    (the impact transient: ≈ 1 ms to 40 ms) without mode switches; the ledger's E_diss at the
    end is the energy the impact dissipated (contact damping, plus the little friction work of
    the window). "The smallest damping that maximises" is the smallest grid value within
    ``rel_tol`` (relative) of the maximum over the grid. ``parameter``: the damping varied
    (default: the one the feet's contact component reads, e.g. ``lam`` or ``B_contact``).
    """
    parameter = parameter or _damping_parameter(walker)
    z = walker.initial_guess() if z is None else np.asarray(z, dtype=float)
    lams = np.logspace(5, 10, 21) if lams is None else np.asarray(lams, dtype=float)
    out = []
    n = walker.model.n_states
    o = walker.options
    for lam in lams:
        w = walker.with_parameters(**{parameter: float(lam)})
        p0 = w.start_params()
        x0 = w.lift(z, p0)
        tr = w.model.simulate(window, x0=x0, params=dict(zip(w.model.param_names, p0)),
                              method=o.method, rtol=o.rtol, atol=o.atol, max_step=o.max_step)
        out.append(float(tr.y[n, -1]) if tr.status == "finished" else math.nan)
    d = np.array(out)
    k_max = int(np.nanargmax(d))
    good = np.nonzero(d >= d[k_max] * (1 - rel_tol))[0]
    return DampingCalibration([float(v) for v in lams], out, float(d[k_max]), float(lams[k_max]),
                              float(lams[good[0]]), rel_tol, window, parameter)
