"""Whether an explicit method's steps were limited by stability rather than accuracy.

An explicit Runge–Kutta method is stable on y' = λ y only while h λ lies in its stability
domain, which meets the negative real axis at about −3.3 for Dormand–Prince 5(4) (scipy's
``RK45``) and about −6 for Dormand–Prince 8(5,3) (``DOP853``): E. Hairer, G. Wanner, *Solving
Ordinary Differential Equations II*, 2nd ed., Springer 1996, §IV.2 (the stability domains of
explicit Runge–Kutta methods, DOPRI5 and DOP853 among them). On a stiff model (a contact stiffness, a large damping)
the step-size controller then holds h ρ(J) near that bound, whatever the tolerance asks for:
millions of tiny steps where a stiff method (``Rodas5P``, ``QBDF``, ``Radau``) takes hundreds.
A run on a non-stiff model keeps h ρ(J) below the bound: measured on the shipped pendulum,
mass–spring (undamped), double pendulum and heavy top over hundreds of periods, at most 0.33 of
it (RK45) and 0.44 (DOP853) at rtol 1e-3, 0.08 and 0.18 at 1e-6; on a stiff one the controller
holds it at 1.1 of the bound (the mass–spring–damper at c = 1e4 N·s/m: 3.7 and 6.4).

:class:`StiffnessWatch` samples h ρ(J) (ρ the spectral radius of the model states' block of the
Jacobian, h the step just taken) every :data:`EVERY` steps of such a run; when the largest
sample reached :data:`LIMITED` of the method's bound, the run ends with a
:class:`StiffnessWarning` that says so and names the methods to use instead (the command line
prints it as ``warning: …``). The run itself, its status and its numbers are unchanged.
"""
from __future__ import annotations

import math
import warnings

import numpy as np

#: the extent of each explicit method's stability domain along the negative real axis, |h λ|
#: (Hairer and Wanner, module docstring)
BOUNDS = {"RK45": 3.3, "DOP853": 6.0}
#: steps between two samples (the first after this many: a short run is not judged), also those
#: between two calls of a scipy method's progress (simulate)
EVERY = 1000
#: the part of the bound from which the steps count as limited by stability
LIMITED = 0.75


class StiffnessWarning(UserWarning):
    """An explicit method's steps were held by its stability bound: the model is stiff there,
    and a stiff method would take far fewer steps (:mod:`porthamiltonian.simulation.stiffness`)."""


class StiffnessWatch:
    """The largest h ρ(J) seen at the samples of one run of the explicit method ``method`` (a
    key of :data:`BOUNDS`) on a model of ``n`` states."""

    def __init__(self, method: str, n: int):
        self.method, self.n = method, n
        self.bound = BOUNDS[method]
        self.largest = 0.0          # the largest h ρ(J) sampled
        self.at = math.nan          # its time (s)

    def sample(self, t: float, J: np.ndarray, h: float) -> None:
        """Record h ρ(J) for the Jacobian ``J`` of the integration state at time ``t`` (s), after
        a step of length ``h`` (s): ρ of its block of the model states; a Jacobian that is not
        finite (a run about to fail) is not judged."""
        block = np.asarray(J, dtype=float)[:self.n, :self.n]
        if self.n == 0 or not np.all(np.isfinite(block)):
            return
        value = abs(h) * float(np.max(np.abs(np.linalg.eigvals(block))))
        if value > self.largest:
            self.largest, self.at = value, t

    def warn(self, model: str) -> None:
        """Warn (:class:`StiffnessWarning`) when the largest sample reached :data:`LIMITED` of
        the bound."""
        if self.largest < LIMITED * self.bound:
            return
        warnings.warn(StiffnessWarning(
            f"model {model!r}: {self.method}'s steps were limited by its stability, not by the "
            f"tolerance (h·ρ(J) reached {self.largest:.1f} at t = {self.at:.3g} s; its stability "
            f"bound is about {self.bound:g}): the model is stiff, and a stiff method (method "
            f"'auto', 'Rodas5P', 'QBDF' or 'Radau') takes far fewer steps"), stacklevel=2)


__all__ = ["BOUNDS", "EVERY", "LIMITED", "StiffnessWarning", "StiffnessWatch"]
