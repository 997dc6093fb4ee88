"""The explicit port-Hamiltonian form of a compiled model at one point: J, R, [∇H; z; u], checks.

Evaluates the functions :mod:`porthamiltonian.compiler.phform` generates (``compile_model(...,
ph=True)``; ``model.ph_matrices`` compiles them on first use): the junction structure M₀, the
per-storage energy gradients and the dissipators' and ports' values, and forms

* ∇H (the physical states' order), z (the nonlinear dissipators), u (the ports);
* the reduced M = J − R over [∇H; z; u], the linear dissipators eliminated (z_l = C w_l);
* the prediction M [∇H; z; u] of [ẋ; w; y], to compare with the compiled right-hand side.

:meth:`PHMatrices.check` raises :class:`~porthamiltonian.errors.PassivityError` naming the
component when a linear dissipator's C has a negative eigenvalue or a nonlinear one's z·w < 0
there, and returns the measured errors (relative residual of the right-hand side, of M₀'s
skew-symmetry, R's least eigenvalue). No sympy here.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ModelError, PassivityError

if TYPE_CHECKING:
    from .compiled import CompiledModel


@dataclass(frozen=True)
class PHMatrices:
    """The form at one point (see the module docstring). ``J``, ``R``, ``M`` = J − R over
    [∇H; z; u] (names ``columns``), ``M0`` the junction structure over [∇H; z_all; u],
    ``gradient``, ``z``, ``u`` the parts of ``a``; ``predicted`` = M a, of which the first
    entries are ẋ of the physical states (``states``), ``xdot`` the compiled rates of those
    states, ``w`` the nonlinear dissipators' flows from the model's solution; ``dissipators``
    (component, name, z, w, C or None) of every dissipator."""

    states: tuple[str, ...]
    columns: tuple[str, ...]
    M0: np.ndarray
    M: np.ndarray
    J: np.ndarray
    R: np.ndarray
    gradient: np.ndarray
    z: np.ndarray
    u: np.ndarray
    w: np.ndarray
    predicted: np.ndarray
    xdot: np.ndarray
    dissipators: tuple[tuple[str, str, np.ndarray, np.ndarray, np.ndarray | None], ...]

    @property
    def a(self) -> np.ndarray:
        """[∇H; z; u]."""
        return np.concatenate([self.gradient, self.z, self.u])

    def errors(self) -> dict[str, float]:
        """The checks' measured errors: ``rhs`` max |M a − ẋ| over the physical states relative
        to the largest term of the products (so that a cancellation does not hide an error),
        ``w`` the same for the nonlinear dissipators' flows, ``skew`` max |M₀ + M₀ᵀ| / max |M₀|,
        ``R_min`` R's least eigenvalue / max |M| (≥ −round-off for a passive model)."""
        n = len(self.states)
        terms = np.abs(self.M) @ np.abs(self.a)
        scale = max(float(np.max(terms[:n], initial=0.0)), 1e-300)
        rhs = float(np.max(np.abs(self.predicted[:n] - self.xdot), initial=0.0)) / scale
        k = len(self.w)
        w_scale = max(float(np.max(terms[n:n + k], initial=0.0)), 1e-300)
        w_err = float(np.max(np.abs(self.predicted[n:n + k] - self.w), initial=0.0)) / w_scale
        skew = float(np.max(np.abs(self.M0 + self.M0.T), initial=0.0)) / max(
            float(np.max(np.abs(self.M0), initial=0.0)), 1e-300)
        big = max(float(np.max(np.abs(self.M), initial=0.0)), 1e-300)
        r_min = float(np.min(np.linalg.eigvalsh(self.R), initial=0.0)) / big
        return {"rhs": rhs, "w": w_err, "skew": skew, "R_min": r_min}

    def check(self, tol: float = 1e-10) -> dict[str, float]:
        """Raise PassivityError naming an active dissipator (a linear one's C with a negative
        eigenvalue, or a nonlinear one's z·w < 0, beyond ``tol`` relative); else the
        :meth:`errors`."""
        for component, name, z, w, C in self.dissipators:
            if C is not None:
                sym = (C + C.T) / 2
                least = float(np.min(np.linalg.eigvalsh(sym))) if sym.size else 0.0
                if least < -tol * max(float(np.max(np.abs(sym))), 1e-300):
                    raise PassivityError(
                        f"component {component!r} is declared as a dissipator ({name}) but its "
                        f"coefficient C has the eigenvalue {least:.3g} < 0 here: it would supply "
                        "energy (R indefinite); an active element is a source or an actuator")
            else:
                power = float(np.dot(z, w))
                if power < -tol * max(float(np.linalg.norm(z) * np.linalg.norm(w)), 1e-300):
                    raise PassivityError(
                        f"component {component!r} is declared as a dissipator ({name}) but "
                        f"z(w)·w = {power:.3g} < 0 here: it supplies energy; an active element "
                        "is a source or an actuator")
        return self.errors()


def ph_matrices(model: CompiledModel, t: float, y: np.ndarray, p: np.ndarray) -> PHMatrices:
    """The form of ``model`` (compiled with ``ph=True``) at (t, y, p): y the integration state,
    p the parameter vector with its input slots."""
    layout = model.ph_layout
    if layout is None:
        raise ModelError(f"model {model.name!r} was compiled without its port-Hamiltonian form: "
                         "compile it with ph=True, or call model.ph_matrices(...)")
    pn = model.native_params(p)
    extra = model.functions.extra
    M0 = np.asarray(extra["ph_M0"](t, y, pn), dtype=float)
    G = np.asarray(extra["ph_grad"](t, y, pn), dtype=float)
    values = np.asarray(extra["ph_values"](t, y, pn), dtype=float)
    states = layout["states"]
    n = len(states)
    gradient = np.zeros(n)
    for row, (_, indices) in enumerate(layout["energies"]):
        gradient[indices] += G[row, indices]
    sizes = [d["size"] for d in layout["dissipators"]]
    total = sum(sizes)
    z_all, w_all = values[:total], values[total:2 * total]
    m = len(layout["ports"])
    u = values[2 * total:2 * total + m]
    coefficients = values[2 * total + m:]
    kept, linear, blocks, dissipators = list(range(n)), [], [], []
    start, c_at = 0, 0
    z_kept, w_kept = [], []
    for d, size in zip(layout["dissipators"], sizes):
        idx = list(range(n + start, n + start + size))
        z, w = z_all[start:start + size], w_all[start:start + size]
        start += size
        C = None
        if d["linear"]:
            C = coefficients[c_at:c_at + size * size].reshape(size, size)
            c_at += size * size
            linear += idx
            blocks.append(C)
        else:
            kept += idx
            z_kept.append(z)
            w_kept.append(w)
        dissipators.append((d["component"], d["name"], z, w, C))
    kept += list(range(n + total, n + total + m))
    M = M0[np.ix_(kept, kept)]
    if linear:
        C = _block_diag(blocks)
        Mll = M0[np.ix_(linear, linear)]
        gain = C @ np.linalg.inv(np.eye(len(linear)) - Mll @ C) if np.any(Mll) else C
        M = M + M0[np.ix_(kept, linear)] @ gain @ M0[np.ix_(linear, kept)]
    z = np.concatenate(z_kept) if z_kept else np.zeros(0)
    w = np.concatenate(w_kept) if w_kept else np.zeros(0)
    a = np.concatenate([gradient, z, u])
    rhs = np.asarray(model.functions.rhs(t, y, pn), dtype=float)
    phys = [model.state_index(s) for s in states]
    columns = [c for i, c in enumerate(layout["columns"]) if i in set(kept)]
    return PHMatrices(tuple(states), tuple(columns), M0, M, (M - M.T) / 2, -(M + M.T) / 2,
                      gradient, z, u, w, M @ a, rhs[phys], tuple(dissipators))


def _block_diag(blocks: list[np.ndarray]) -> np.ndarray:
    size = sum(b.shape[0] for b in blocks)
    out = np.zeros((size, size))
    k = 0
    for b in blocks:
        out[k:k + b.shape[0], k:k + b.shape[0]] = b
        k += b.shape[0]
    return out


__all__ = ["PHMatrices", "ph_matrices"]
