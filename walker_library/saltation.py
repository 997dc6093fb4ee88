"""The pieces of an exact monodromy matrix of a hybrid system (the ``"variational"`` method of
:func:`~.monodromy.stride_jacobian`): saltation matrices at events and resets, the projection on
a Poincaré section, and their composition with the flows' state-transition matrices.

For an autonomous hybrid system ẋ = f(x) with an event where the guard g(x) crosses zero and a
reset x⁺ = R(x⁻), a perturbation δx⁻ just before the event is carried to δx⁺ = S δx⁻ just after
it by the saltation matrix (Aizerman & Gantmacher 1958; Leine & Nijmeijer 2004, §7.1)

    S = ∂R/∂x + (f⁺ − ∂R/∂x f⁻) ∇gᵀ / (∇g · f⁻),

with f⁻ = f(x⁻) and f⁺ = f(x⁺) (the mode's vector field after the event): the perturbed
trajectory reaches the guard earlier or later by δt = −∇g·δx⁻ / ∇g·f⁻, and the correction
accounts for flowing that long under the other field. An event that only switches a mode's
parameters has ∂R/∂x = I; one that changes nothing (a recorded crossing) has S = I.

A Poincaré section h(x) = 0 crossed at the end of a stride removes the time shift of the return:
the Jacobian of the return map is Π M with Π = I − f ∇hᵀ / (∇h · f) (f the field there), M
the monodromy δx_end = M δx_start; restricted to perturbations in the section and read in
section coordinates, it is the stride map's Jacobian. When the section is an event with a reset
(a walker's heel strike), M ends with that event's saltation matrix — which carries the
perturbation to the same time just after the event, not onto the section — and Π takes the
field just after the event and the guard's gradient: Π(f⁺, ∇g) S Φ ⋯. Π maps the flow
direction to 0: the trivial multiplier 1 of M becomes 0 on the section.

:func:`compose` multiplies the segments' state-transition matrices Φ_i (integrated with the
flow: Φ̇ = ∂f/∂x Φ, Φ(start of segment) = I) and the events' saltation matrices in order:
M = S_k Φ_k ⋯ S_1 Φ_1. The integration loops' sensitivity variant will provide the Φ_i and the
events' states; these functions are the algebra, checked on a bouncing ball in closed form
(tests/validation/test_saltation.py).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["compose", "saltation", "section_projection"]


def saltation(reset_jacobian: np.ndarray, f_before: np.ndarray, f_after: np.ndarray,
              guard_gradient: np.ndarray) -> np.ndarray:
    """The saltation matrix S = ∂R/∂x + (f⁺ − ∂R/∂x f⁻) ∇gᵀ / (∇g · f⁻) of an event (module
    docstring). Raises ValueError for a grazing event (∇g · f⁻ = 0: the crossing time is not
    differentiable)."""
    Rx = np.asarray(reset_jacobian, dtype=float)
    fm, fp = np.asarray(f_before, dtype=float), np.asarray(f_after, dtype=float)
    dg = np.asarray(guard_gradient, dtype=float)
    rate = float(dg @ fm)
    if rate == 0.0:
        raise ValueError("grazing event: the guard's rate of change along the flow is zero, so "
                         "the saltation matrix is not defined")
    return Rx + np.outer(fp - Rx @ fm, dg) / rate


def section_projection(f: np.ndarray, section_gradient: np.ndarray) -> np.ndarray:
    """Π = I − f ∇hᵀ / (∇h · f): the change of the crossing time of the section h = 0 taken
    out of a perturbation at the crossing (f the field there). Raises ValueError where the flow
    is tangent to the section."""
    f = np.asarray(f, dtype=float)
    dh = np.asarray(section_gradient, dtype=float)
    rate = float(dh @ f)
    if rate == 0.0:
        raise ValueError("the flow is tangent to the section: the return time is not "
                         "differentiable there")
    return np.eye(len(f)) - np.outer(f, dh) / rate


def compose(flows: Sequence[np.ndarray], events: Sequence[np.ndarray]) -> np.ndarray:
    """M = S_k Φ_k ⋯ S_1 Φ_1 for segments' state-transition matrices ``flows`` (Φ_1 first) and
    the saltation matrices of the events that end them (``events``: one per flow, or one fewer
    when the last segment ends without an event)."""
    if not flows or len(events) not in (len(flows), len(flows) - 1):
        raise ValueError(f"compose: {len(flows)} flow(s) need {len(flows)} or "
                         f"{len(flows) - 1} event matrices, got {len(events)}")
    M = np.eye(np.asarray(flows[0]).shape[0])
    for i, Phi in enumerate(flows):
        M = np.asarray(Phi, dtype=float) @ M
        if i < len(events):
            M = np.asarray(events[i], dtype=float) @ M
    return M
