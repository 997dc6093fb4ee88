"""Design by optimization: a walker's parameters tuned by a gradient method on its gait.

:func:`optimize_gait` minimises (or maximises) one gait quantity over some parameters subject
to bounds and to inequality constraints on others — the quantities of
:data:`~.gradients.GAIT_QUANTITIES`, e.g. the cost of transport with the largest multiplier
≤ 0.6, or the largest multiplier at a given speed — with scipy's SLSQP (or trust-constr), each
evaluation of the objective and constraints one *gait evaluation*: the fixed point by Newton
with the exact stride Jacobian (:func:`~.gradients.solve_gait`, started from the last fixed
point moved along its exact tangent dz*/dp, so that Newton needs one or two runs), then the
exact gradients of every quantity (:func:`~.gradients.gait_gradient`; the multiplier's by its
documented scheme, only when the objective or a constraint needs it).

Minimising the largest multiplier's modulus ρ (``formulation="epigraph"``, the default for that
objective): ρ is not differentiable where two multipliers of the largest modulus meet, often
at the optimum, and a smooth method cycles across that kink. The epigraph problem is smooth:
minimise t over (p, t) subject to ρ(p) ≤ t written with smooth functions —
Jury's conditions t² − P ≥ 0, t² + P ∓ s t ≥ 0 on the sum s and product P of the cluster of
the largest modulus, and t ≥ r, the largest modulus outside it (:mod:`.gradients`,
:attr:`~.gradients.GaitGradient.spectrum`) — so that the optimizer sees both branches of a
collision at once; t is scaled by the starting ρ. ``formulation="direct"`` differentiates ρ
itself (the only choice for other objectives).

The variables are the parameters relative to their starting values, u_j = p_j / p_j⁰ (the
optimizer works in units of order 1); the objective is divided by its starting magnitude and
each constraint by its bound's, so that the tolerance ``tol`` is relative. A gait evaluation
whose walker falls or has no fixed point near the last one (the full gait search then tried
from the walker's own guess finds none either) is infeasible: its objective is the last feasible
one plus 10 (in those units) and every constraint violated by 10, with zero gradients, so that
the line search steps back.

Every gait evaluation is recorded (``record``: a JSON Lines file in the sweep results format,
:mod:`porthamiltonian.batch.resultsfile`: a header naming the problem, then one row per
evaluation with the parameters as its ``case`` and the fixed point, the quantities, their
gradients, the multipliers in its ``result``); an optimization run again with the same file
and problem reads its rows and re-simulates nothing it has (the optimizer is deterministic, so
it asks for the same points). A non-smooth measure — the step-down test
(:func:`~.robustness.step_down`), the largest drop of the ground the walker survives — is
evaluated, never differentiated, at the start and the optimum (``step_down="ends"``) or also at
every iterate the optimizer accepts (``"path"``), and recorded.
"""
from __future__ import annotations

import hashlib
import json
import math
import operator
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from porthamiltonian.batch.errors import SweepFileError
from porthamiltonian.batch.resultsfile import FORMAT, VERSION, ResultsFile, Scan
from porthamiltonian.errors import ModelError, OptionError
from porthamiltonian.simulation.options import check_integer, check_number

from ..core.gradients import check_names
from ..core.protocol import Walker
from .gait import GaitStatus, analyze_gait
from .gradients import GAIT_QUANTITIES, GaitGradient, gait_gradient
from .results import JSONResult

if TYPE_CHECKING:
    from ..core.walker import HybridWalker

__all__ = ["Constraint", "OptimizationResult", "optimize_gait", "parse_constraint"]

_OPS = {"<=": operator.le, ">=": operator.ge}
#: the step in scaled units that marks an infeasible evaluation (module docstring)
_INFEASIBLE = 10.0
#: significant digits of a point's key: nearer points are one gait evaluation
_DIGITS = 10
#: the epigraph variable's bounds (t over the starting ρ)
_T_BOUNDS = (1e-3, 10.0)
#: the names of the epigraph's constraints (module docstring)
_JURY = ("t^2 - P >= 0", "t^2 + P - s t >= 0", "t^2 + P + s t >= 0", "t - r >= 0")


@dataclass(frozen=True)
class Constraint:
    """``quantity op bound`` with op ``<=`` or ``>=``."""

    quantity: str
    op: str
    bound: float

    def __str__(self) -> str:
        return f"{self.quantity} {self.op} {self.bound:g}"


def parse_constraint(text: str) -> Constraint:
    """``"max_multiplier_modulus <= 0.6"`` as a :class:`Constraint` (a gait quantity, ``<=`` or
    ``>=``, a finite number); OptionError otherwise."""
    for op in ("<=", ">="):
        name, sep, value = text.partition(op)
        if sep:
            name = name.strip()
            try:
                bound = float(value)
            except ValueError:
                bound = math.nan
            if name in GAIT_QUANTITIES and math.isfinite(bound):
                return Constraint(name, op, bound)
            break
    raise OptionError(f"constraint {text!r}: expected QUANTITY<=NUMBER or QUANTITY>=NUMBER, "
                      f"QUANTITY one of {', '.join(GAIT_QUANTITIES)}")


@dataclass
class OptimizationResult(JSONResult):
    """What :func:`optimize_gait` found (SI units).

    model, vary (the parameters), objective, maximize, constraints (text), bounds ({name:
    [low, high]}); start, optimum ({name: value}); values, gradients (the quantities and their
    gradients at the optimum); multipliers (at the optimum); success, message, iterations
    (the optimizer's), evaluations (gait evaluations, counted once per distinct point; those
    read back from the record file too), reused (how many of them came from the file);
    kkt ({"gradient_of_lagrangian": |∇f + Σ μ ∇g| in the scaled units, "gradient": |∇f|,
    "multipliers": {constraint: μ}, "active": [...]}: the first-order conditions at the
    optimum); path (the iterates accepted:
    parameters, objective, feasibility, step-down); step_down ({"start": m, "optimum": m}).
    """

    model: str
    vary: list[str]
    objective: str
    maximize: bool
    constraints: list[str]
    bounds: dict[str, list[float]]
    start: dict[str, float]
    optimum: dict[str, float] = field(default_factory=dict)
    values: dict[str, float] = field(default_factory=dict)
    gradients: dict[str, dict[str, float]] = field(default_factory=dict)
    multipliers: list[complex] = field(default_factory=list)
    success: bool = False
    message: str = ""
    iterations: int = 0
    evaluations: int = 0
    reused: int = 0
    kkt: dict[str, Any] = field(default_factory=dict)
    path: list[dict] = field(default_factory=list)
    step_down: dict[str, float | None] = field(default_factory=dict)
    seconds: float = 0.0
    #: "direct", or "epigraph" (module docstring; then kkt is the epigraph problem's)
    formulation: str = "direct"


class _Evaluator:
    """The gait evaluations of one optimization, cached by point and recorded (module
    docstring)."""

    def __init__(self, walker: HybridWalker, vary: list[str], scale: np.ndarray, multiplier: bool,
                 record: ResultsFile | None, known: dict[str, dict],
                 log: Callable[[str], None] | None):
        self.walker, self.vary, self.scale, self.multiplier = walker, vary, scale, multiplier
        self.record, self.known, self.log = record, known, log
        self.cache: dict[str, dict] = {}
        self.z: np.ndarray | None = None         # the last fixed point, and its parameters
        self.p: np.ndarray | None = None
        self.dzdp: np.ndarray | None = None
        self.period = 1
        self.count = 0
        self.reused = 0

    def key(self, p: np.ndarray) -> str:
        """The point's key: its parameters to :data:`_DIGITS` significant digits (points the
        optimizer proposes closer than that — its last steps — are one gait evaluation: the
        gait's quantities are accurate to the runs' tolerance, far coarser)."""
        return json.dumps([float(f"{v:.{_DIGITS}g}") for v in p])

    def __call__(self, u: np.ndarray) -> dict:
        p = np.asarray(u, dtype=float) * self.scale
        key = self.key(p)
        if key in self.cache:
            return self.cache[key]
        if key in self.known:
            out = self.known[key]
            self.reused += 1
        else:
            out = self._evaluate(p)
            if self.record is not None:
                self.record.append({"case_id": self.count, "case": dict(zip(self.vary,
                                                                            p.tolist())),
                                    "status": "finished", "result": out, "key": key})
        self.count += 1
        if out["feasible"]:
            self.z = np.array(out["fixed_point"])
            self.p = p
            self.dzdp = np.array(out["dzdp"])
            self.period = out["period"]
        self.cache[key] = out
        if self.log is not None:
            self.log(f"gait evaluation {self.count}: " + ", ".join(
                f"{n} = {v:.6g}" for n, v in zip(self.vary, p)) + (
                "" if out["feasible"] else f": no gait ({out['reason']})"))
        return out

    def _evaluate(self, p: np.ndarray) -> dict:
        t0 = time.perf_counter()
        w = self.walker.with_parameters(**dict(zip(self.vary, p.tolist())))
        g: GaitGradient | None = None
        if self.z is not None:                   # predicted along the exact tangent
            guess = self.z + self.dzdp @ (p - self.p)
            g = gait_gradient(w, guess, self.vary, self.period, multiplier=self.multiplier)
        if g is None or g.fell:
            found = analyze_gait(w, self.z, max_period=4, continuation=False)
            if found.status != GaitStatus.PERIODIC or not found.stable:
                reason = g.fell if g is not None else found.message
                return {"feasible": False, "reason": reason,
                        "seconds": time.perf_counter() - t0}
            z = np.array([found.fixed_point[k] for k in w.section])
            g = gait_gradient(w, z, self.vary, found.period_steps, multiplier=self.multiplier)
            if g.fell:
                return {"feasible": False, "reason": g.fell,
                        "seconds": time.perf_counter() - t0}
        dzdp = [[g.fixed_point_gradient[c][n] for n in self.vary] for c in w.section]
        return {"feasible": True, "fixed_point": g.fixed_point, "period": g.period,
                "values": g.values, "gradients": g.gradients, "errors": g.errors,
                "multipliers": [[m.real, m.imag] for m in g.multipliers],
                "spectrum": g.spectrum,
                "stable": bool(g.values["max_multiplier_modulus"] < 1.0), "dzdp": dzdp,
                "runs": g.runs, "seconds": time.perf_counter() - t0}


def _identity(walker: HybridWalker, vary: Sequence[str], objective: str, maximize: bool,
              constraints: Sequence[Constraint], bounds: Mapping[str, tuple[float, float]],
              method: str, formulation: str) -> dict:
    return {"model": walker.name, "parameters": dict(walker.parameters), "vary": list(vary),
            "objective": objective, "maximize": maximize, "formulation": formulation,
            "constraints": [str(c) for c in constraints],
            "bounds": {k: list(v) for k, v in bounds.items()}, "method": method,
            "options": {"rtol": walker.options.rtol, "method": walker.options.method}}


def _open_record(path: Path, identity: dict) -> tuple[ResultsFile, dict[str, dict]]:
    """The record file (created, or its rows read back when it is this problem's)."""
    blob = json.dumps(identity, sort_keys=True)
    header = {"format": FORMAT, "version": VERSION,
              "sweep": {"function": "walker_library.analyses.optimize:optimize_gait",
                        "fixed": identity, "n_cases": 0,
                        "cases_sha256": hashlib.sha256(blob.encode()).hexdigest()},
              "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    line = (json.dumps(header) + "\n").encode()

    def check(found: Scan | None) -> dict[str, dict]:
        if found is None:
            return {}
        theirs = found.header["sweep"].get("fixed")
        if theirs != json.loads(blob):
            raise SweepFileError(f"{path}: an optimization record of another problem "
                                 f"({theirs}); write to another file, or delete it")
        return {row["key"]: row["result"] for _, row in found.rows if "key" in row}

    return ResultsFile.open(path, line, check)


#: the largest ``max_evaluations``: scipy's optimizers count their iterations in a C int
MAX_EVALUATIONS = 2**31 - 1


def optimize_gait(walker: HybridWalker, vary: Sequence[str], objective: str, *,
                  maximize: bool = False, constraints: Sequence[Constraint | str] = (),
                  bounds: Mapping[str, tuple[float, float]] | None = None,
                  method: str = "SLSQP", max_evaluations: int = 30, tol: float = 1e-6,
                  record: str | Path | None = None, step_down: str = "ends",
                  guess: ArrayLike | None = None, log: Callable[[str], None] | None = None,
                  formulation: str = "auto") -> OptimizationResult:
    """Optimize ``objective`` (a gait quantity; minimised, or maximised with ``maximize``) over
    the parameters ``vary`` within ``bounds`` ({name: (low, high)}, SI) subject to
    ``constraints`` (:class:`Constraint` or text ``"speed >= 0.33"``) by ``method`` ("SLSQP" or
    "trust-constr") with exact gradients; at most ``max_evaluations`` gait evaluations, relative
    tolerance ``tol``; ``record``: the JSON Lines file of every evaluation (resumable);
    ``step_down``: "none", "ends" or "path" (module docstring); ``guess``: a section state near
    the starting gait; ``formulation``: "epigraph", "direct" or "auto" (the epigraph when
    minimising max_multiplier_modulus; module docstring)."""
    from scipy.optimize import Bounds, NonlinearConstraint, minimize

    t0 = time.perf_counter()
    vary = list(check_names(walker, vary))
    if objective not in GAIT_QUANTITIES:
        raise OptionError(f"objective {objective!r}: one of {', '.join(GAIT_QUANTITIES)}")
    if method not in ("SLSQP", "trust-constr"):
        raise OptionError(f"method {method!r}: SLSQP or trust-constr")
    if step_down not in ("none", "ends", "path"):
        raise OptionError(f"step_down {step_down!r}: none, ends or path")
    # scipy's iteration counter is a C int: 10**400 failed after the first gait, as a
    # SystemError of scipy's slsqp
    if check_integer("max_evaluations", max_evaluations) > MAX_EVALUATIONS:
        raise OptionError(f"max_evaluations must be at most {MAX_EVALUATIONS} (scipy's iteration "
                          f"counter), got {max_evaluations}")
    tol = check_number("tol", tol, positive=True)
    epigraph_ok = objective == "max_multiplier_modulus" and not maximize
    if formulation == "auto":
        formulation = "epigraph" if epigraph_ok else "direct"
    if formulation not in ("epigraph", "direct") or (formulation == "epigraph"
                                                      and not epigraph_ok):
        raise OptionError(f"formulation {formulation!r}: direct, auto, or epigraph (which "
                          "minimises max_multiplier_modulus)")
    epigraph = formulation == "epigraph"
    cons = [c if isinstance(c, Constraint) else parse_constraint(c) for c in constraints]
    bounds = {k: (float(a), float(b)) for k, (a, b) in (bounds or {}).items()}
    unknown = set(bounds) - set(vary)
    if unknown:
        raise OptionError(f"bounds for {', '.join(sorted(unknown))}, which are not varied")
    p0 = np.array([walker.parameters[n] for n in vary], dtype=float)
    scale = np.where(p0 != 0.0, np.abs(p0), 1.0)
    lo = np.array([bounds.get(n, (-np.inf, np.inf))[0] for n in vary]) / scale
    hi = np.array([bounds.get(n, (-np.inf, np.inf))[1] for n in vary]) / scale
    u0 = p0 / scale
    if np.any(u0 < lo) or np.any(u0 > hi):
        raise OptionError(f"the starting values {dict(zip(vary, p0.tolist()))} lie outside the "
                          "bounds")
    needs = {objective, *(c.quantity for c in cons)}
    file: ResultsFile | None = None
    known: dict[str, dict] = {}
    if record is not None:
        file, known = _open_record(Path(record), _identity(walker, vary, objective, maximize,
                                                           cons, bounds, method, formulation))
    evaluate = _Evaluator(walker, vary, scale, "max_multiplier_modulus" in needs, file, known,
                          log)
    if guess is not None:
        evaluate.z = np.asarray(guess, dtype=float)
        evaluate.p, evaluate.dzdp = p0.copy(), np.zeros((len(evaluate.z), len(vary)))
    try:
        first = evaluate(u0)
        if not first["feasible"]:
            raise ModelError(f"{walker.name}: no stable gait at the starting values "
                             f"({first['reason']}); start where the walker walks")
        sign = -1.0 if maximize else 1.0
        f_scale = max(abs(first["values"][objective]), 1e-12)
        g_scale = [max(abs(c.bound), 1e-12) for c in cons]
        state = {"f": 0.0}
        q = len(vary)
        n_g = len(cons) + (4 if epigraph else 0)
        part = (lambda x: np.asarray(x)[:q]) if epigraph else np.asarray

        def f(x: np.ndarray) -> float:
            if epigraph:
                return float(x[-1])
            out = evaluate(x)
            if not out["feasible"]:
                return state["f"] + _INFEASIBLE
            state["f"] = sign * out["values"][objective] / f_scale
            return state["f"]

        def df(x: np.ndarray) -> np.ndarray:
            if epigraph:
                return np.eye(q + 1)[q]
            out = evaluate(x)
            if not out["feasible"]:
                return np.zeros(q)
            g = np.array([out["gradients"][objective][n] for n in vary])
            return sign * g * scale / f_scale

        def gvec(x: np.ndarray) -> np.ndarray:
            out = evaluate(part(x))
            if not out["feasible"]:
                return np.full(n_g, -_INFEASIBLE)
            values = [(c.bound - out["values"][c.quantity] if c.op == "<=" else
                       out["values"][c.quantity] - c.bound) / s for c, s in zip(cons, g_scale)]
            if epigraph:
                values += list(_jury(out, float(x[-1]), f_scale, vary, scale)[0])
            return np.array(values)

        def dg(x: np.ndarray) -> np.ndarray:
            out = evaluate(part(x))
            width = q + 1 if epigraph else q
            if not out["feasible"]:
                return np.zeros((n_g, width))
            rows = [np.array([out["gradients"][c.quantity][n] for n in vary]) * scale / s
                    * (-1.0 if c.op == "<=" else 1.0) for c, s in zip(cons, g_scale)]
            if not epigraph:
                return np.array(rows)
            _, du, dt = _jury(out, float(x[-1]), f_scale, vary, scale)
            return np.vstack([np.hstack([np.array(rows).reshape(len(cons), q),
                                         np.zeros((len(cons), 1))]),
                              np.hstack([du, dt[:, None]])])

        path: list[dict] = []

        def accepted(xk: np.ndarray, *args: Any) -> None:
            u = part(xk)
            p = u * scale
            out = evaluate(u)
            entry = {"parameters": dict(zip(vary, p.tolist())),
                     "objective": out["values"][objective] if out["feasible"] else None,
                     "feasible": out["feasible"]}
            if step_down == "path" and out["feasible"]:
                entry["step_down"] = _step_down(walker, vary, p, out)
            path.append(entry)

        accepted(u0)
        box = Bounds(np.append(lo, _T_BOUNDS[0]) if epigraph else lo,
                     np.append(hi, _T_BOUNDS[1]) if epigraph else hi)
        x0 = np.append(u0, 1.0) if epigraph else u0
        if method == "SLSQP":
            # scipy-stubs type a constraint dict's "fun" as scalar-valued; SLSQP takes vectors
            res = minimize(f, x0, jac=df, method="SLSQP", bounds=box, callback=accepted,  # type: ignore[call-overload]
                           constraints=[{"type": "ineq", "fun": gvec, "jac": dg}] if n_g else [],
                           options={"maxiter": max_evaluations, "ftol": tol})
        else:
            nl = [NonlinearConstraint(gvec, 0.0, np.inf, jac=dg)] if n_g else []
            res = minimize(f, x0, jac=df, method="trust-constr", bounds=box, constraints=nl,
                           callback=lambda xk, *a: accepted(xk),
                           options={"maxiter": max_evaluations, "gtol": tol, "xtol": tol})
        u_best = part(res.x)
        best = evaluate(u_best)
        p_best = u_best * scale
        out = OptimizationResult(
            walker.name, vary, objective, maximize, [str(c) for c in cons],
            {k: list(v) for k, v in bounds.items()}, dict(zip(vary, p0.tolist())),
            optimum=dict(zip(vary, p_best.tolist())), success=bool(res.success),
            message=str(res.message), iterations=int(getattr(res, "nit", 0)),
            evaluations=evaluate.count, reused=evaluate.reused, path=path,
            formulation=formulation)
        if best["feasible"]:
            out.values, out.gradients = best["values"], best["gradients"]
            out.multipliers = [complex(a, b) for a, b in best["multipliers"]]
            out.kkt = (_kkt_epigraph(best, float(res.x[-1]), f_scale, cons, vary, scale,
                                     g_scale, lo, hi, u_best, tol) if epigraph else
                       _kkt(best, objective, sign / f_scale, cons, vary, scale, g_scale, lo, hi,
                            res.x, tol))
        if step_down != "none":
            out.step_down = {"start": _step_down(walker, vary, p0, first),
                             "optimum": (_step_down(walker, vary, p_best, best)
                                         if best["feasible"] else None)}
        out.seconds = time.perf_counter() - t0
        return out
    finally:
        if file is not None:
            file.close()


def _step_down(walker: Walker, vary: list[str], p: np.ndarray, out: dict) -> float | None:
    """The step-down test at the parameters p from the evaluation ``out`` (its fixed point)."""
    from .robustness import step_down
    w = walker.with_parameters(**dict(zip(vary, p.tolist())))
    gait = analyze_gait(w, np.array(out["fixed_point"]), max_period=out["period"],
                        continuation=False)
    return step_down(w, gait).max_step_down


def _jury(out: dict, tau: float, rho0: float, vary: list[str],
          scale: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The epigraph's constraints (:data:`_JURY`, each ≥ 0; module docstring) at t = τ ρ₀, in
    units of ρ₀² (the first three) and ρ₀, and their gradients by the scaled parameters u and
    by τ."""
    sp = out["spectrum"]
    grads = sp["gradients"]
    s, P, r = sp["cluster_sum"], sp["cluster_product"], sp["rest_modulus"]
    ds, dP, dr = (np.array([grads[key][n] for n in vary]) * scale
                  for key in ("cluster_sum", "cluster_product", "rest_modulus"))
    t, r2 = tau * rho0, rho0 ** 2
    values = np.array([(t * t - P) / r2, (t * t + P - s * t) / r2, (t * t + P + s * t) / r2,
                       (t - r) / rho0])
    du = np.array([-dP / r2, (dP - t * ds) / r2, (dP + t * ds) / r2, -dr / rho0])
    dt = np.array([2 * t / rho0, (2 * t - s) / rho0, (2 * t + s) / rho0, 1.0])
    return values, du, dt


def _bound_rows(vary: list[str], lo: np.ndarray, hi: np.ndarray, u: np.ndarray,
                tol: float) -> tuple[list[np.ndarray], list[str]]:
    """The active bounds' gradients (as constraints g(u) ≤ 0) and names."""
    rows, names = [], []
    for j, n in enumerate(vary):
        e = np.zeros(len(vary))
        if abs(u[j] - lo[j]) <= 1e3 * tol * max(abs(lo[j]), 1.0):
            e[j] = -1.0
            rows.append(e)
            names.append(f"{n} >= lower bound")
        elif abs(u[j] - hi[j]) <= 1e3 * tol * max(abs(hi[j]), 1.0):
            e[j] = 1.0
            rows.append(e)
            names.append(f"{n} <= upper bound")
    return rows, names


def _lagrangian(grad: np.ndarray, rows: list[np.ndarray], names: list[str]) -> dict[str, Any]:
    """Multipliers of the active constraints (rows: their gradients as g ≤ 0) by least squares
    and the gradient of the Lagrangian left."""
    if rows:
        A = np.array(rows)
        mu, *_ = np.linalg.lstsq(A.T, -grad, rcond=None)
        left = grad + A.T @ mu
    else:
        mu, left = np.zeros(0), grad
    return {"gradient_of_lagrangian": float(np.linalg.norm(left)),
            "gradient": float(np.linalg.norm(grad)),
            "multipliers": dict(zip(names, map(float, mu))), "active": names}


def _kkt(out: dict, objective: str, sign: float, cons: list[Constraint], vary: list[str],
         scale: np.ndarray, g_scale: list[float], lo: np.ndarray, hi: np.ndarray, u: np.ndarray,
         tol: float) -> dict[str, Any]:
    """The first-order (KKT) conditions at the optimum, in the optimizer's scaled units (module
    docstring; ``sign``: ±1 over the objective's scale): the active constraints and bounds,
    their multipliers by least squares (μ ≥ 0 at a true optimum), the norm of the objective's
    gradient and of the gradient of the Lagrangian left (≈ 0 at a first-order point)."""
    grad = sign * np.array([out["gradients"][objective][n] for n in vary]) * scale
    rows, names = [], []
    for c, s in zip(cons, g_scale):
        value = out["values"][c.quantity]
        g = np.array([out["gradients"][c.quantity][n] for n in vary]) * scale / s
        if abs(value - c.bound) <= 1e3 * tol * max(abs(c.bound), 1e-12):
            rows.append(g if c.op == "<=" else -g)          # ∇ of the active g(u) <= 0
            names.append(str(c))
    more, more_names = _bound_rows(vary, lo, hi, u, tol)
    return _lagrangian(grad, rows + more, names + more_names)


def _kkt_epigraph(out: dict, tau: float, rho0: float, cons: list[Constraint], vary: list[str],
                  scale: np.ndarray, g_scale: list[float], lo: np.ndarray, hi: np.ndarray,
                  u: np.ndarray, tol: float) -> dict[str, Any]:
    """:func:`_kkt` of the epigraph problem over (u, τ): minimise τ subject to the user's
    constraints and :data:`_JURY` (active where within 1e3 tol of 0)."""
    q = len(vary)
    grad = np.eye(q + 1)[q]
    rows, names = [], []
    for c, s in zip(cons, g_scale):
        value = out["values"][c.quantity]
        g = np.array([out["gradients"][c.quantity][n] for n in vary]) * scale / s
        if abs(value - c.bound) <= 1e3 * tol * max(abs(c.bound), 1e-12):
            rows.append(np.append(g if c.op == "<=" else -g, 0.0))
            names.append(str(c))
    values, du, dt = _jury(out, tau, rho0, vary, scale)
    for name, v, a, b in zip(_JURY, values, du, dt):
        if abs(v) <= 1e3 * tol:
            rows.append(-np.append(a, b))
            names.append(name)
    more, more_names = _bound_rows(vary, lo, hi, u, tol)
    out_ = _lagrangian(grad, rows + [np.append(r, 0.0) for r in more], names + more_names)
    out_["t"] = tau * rho0
    out_["epigraph_constraints"] = dict(zip(_JURY, map(float, values)))
    return out_
