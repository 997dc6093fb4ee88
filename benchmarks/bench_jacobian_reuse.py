"""Jacobian reuse: which compiled method, and where ``method="auto"`` should pick it.

Two studies, both on the C back end:

``--study`` (the choice of the method): one stiff stretch of the compass walker's stride (the
single stance from the first lift-off to the next touchdown, 0.47 s, contact of foot 1 on, no
events), integrated by

* Rodas5P, the compiled loop (a Jacobian and an LU at every step);
* ROS34PW2 (Rang & Angermann, BIT 45, 2005: 4 stages, order 3, L-stable, a W-method: its order
  holds with any matrix in place of the Jacobian), a numpy prototype with the Jacobian of each
  step and with a Jacobian reused until a step is rejected or it is 50 steps old;
* QBDF, the compiled variable-order BDF (porthamiltonian/integrators/bdf_loop.py);

at several tolerances (atol = rtol/100), each error measured against Rodas5P at rtol 1e-14: the
error, accepted steps, right-hand-side and Jacobian evaluations and LU factorizations.

Work-precision (default): models besides the walkers, each simulated with Rodas5P and QBDF at
several tolerances (atol = rtol/100 × the model's scale), the error of the final state against
Rodas5P at rtol 1e-13 (relative to the largest state of the reference run), the CPU time of one
``simulate`` call (``time.process_time``: the runs are single-threaded and short, and the CPU time
moves much less than the wall time with the load of a shared machine; median of ``--repeats``,
the runs interleaved) and, at each Rodas5P run's
error, QBDF's time interpolated log-log between its two runs whose errors bracket it: the ratio
QBDF / Rodas5P at equal accuracy (< 1: QBDF is faster). Models:

* ``bouncing_ball``: models/bouncing_ball.toml (Hunt–Crossley contact, touchdown and lift-off
  events recorded), 1.5 s;
* ``stiff_chain``: benchmarks/bench_compiler.py's chain of 10 masses with every second link
  stiff (k = 1e6 N/m, c = 2e4 N s/m: eigenvalues down to about −2e4 1/s), 10 s;
* ``sphere_on_slope``: models/sphere_on_slope.toml (a free rigid sphere on a slope, 3-D
  compliant contact and regularised friction: rolling), 1 s;
* ``dc_motor`` (stiff: time constants 0.5 ms and ~40 ms), ``mass_spring_damper``, ``pendulum``,
  ``double_pendulum``, ``free_rigid_body`` (smooth and not stiff), the files' t_end (at most 10 s).

Run::

    python benchmarks/bench_jacobian_reuse.py --study
    python benchmarks/bench_jacobian_reuse.py --repeats 7
    python benchmarks/bench_jacobian_reuse.py --models bouncing_ball,stiff_chain
"""
from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import numpy as np
from bench_walkers import time_at_error
from machine import machine_info

RODAS_RTOLS = (1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
QBDF_RTOLS = (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)
MODELS = ("bouncing_ball", "stiff_chain", "sphere_on_slope", "dc_motor", "mass_spring_damper", "pendulum",
          "double_pendulum", "free_rigid_body")


# ------------------------------------------------------------------------------------------------
# the study on the walker's stance
# ------------------------------------------------------------------------------------------------
_G = 4.3586652150845900e-01      # ROS34PW2 (Rang & Angermann 2005, Table 5.1), standard form
_ALPHA = np.array([[0, 0, 0, 0], [8.7173304301691801e-01, 0, 0, 0],
                   [8.4457060015369423e-01, -1.1299064236484185e-01, 0, 0], [0, 0, 1.0, 0]])
_GAMMA = np.array([[_G, 0, 0, 0], [-8.7173304301691801e-01, _G, 0, 0],
                   [-9.0338057013044082e-01, 5.4180672388095326e-02, _G, 0],
                   [2.4212380706095346e-01, -1.2232505839045147e+00, 5.4526025533510214e-01, _G]])
_B = np.array([2.4212380706095346e-01, -1.2232505839045147e+00, 1.5452602553351020e+00, _G])
_B_EMBEDDED = np.array([3.7810903145819369e-01, -9.6042292212423178e-02, 0.5,
                        2.1793326075422950e-01])


def ros34pw2(f, jac, t0, y0, t1, rtol, atol, hmax, reuse: bool):
    """ROS34PW2 with the standard step-size control; the Jacobian of every step, or (``reuse``)
    one kept until a rejection or 50 steps. Returns (y, steps, rhs, jac, lu)."""
    t, y, h = t0, y0.copy(), 1e-5
    n = len(y)
    steps = nf = nj = nlu = age = 0
    J = None
    while t < t1:
        h = min(h, t1 - t, hmax)
        if J is None or not reuse or age >= 50:
            J, age = jac(t, y), 0
            nj += 1
        lu = np.linalg.inv(np.eye(n) - h * _G * J)
        nlu += 1
        K = np.zeros((4, n))
        for i in range(4):
            fi = f(t, y + _ALPHA[i, :i] @ K[:i])
            nf += 1
            K[i] = lu @ (h * fi + (h * J @ (_GAMMA[i, :i] @ K[:i]) if i else 0.0))
        y1 = y + _B @ K
        sc = atol + rtol * np.maximum(np.abs(y), np.abs(y1))
        err = math.sqrt(np.mean((((_B - _B_EMBEDDED) @ K) / sc) ** 2))
        if err <= 1.0:
            t, y, steps, age = t + h, y1, steps + 1, age + 1
        elif reuse:
            J = None
        h *= min(6.0, max(0.2, 0.9 * err ** (-1 / 3))) if err > 0 else 6.0
    return y, steps, nf, nj, nlu


def study() -> None:
    from walker_library import compass_walker, find_fixed_point

    w = compass_walker(backend="c")
    z = find_fixed_point(w, tol=1e-8).z
    tr = w.walk(z, 1, record=True)[-1].info["trajectory"]
    seg = max(tr.segments, key=lambda s: len(s.t))
    t0, t1, y0 = float(seg.t[0]), float(seg.t[-1]), seg.y[:, 0].copy()
    m, F = w.model, w.model.functions
    pn, n, nm = m.native_params(seg.p), len(y0), m.n_states

    def loop(method, rtol):
        out = F.loops[method](t0, y0, t1, pn, rtol, np.full(n, rtol * 1e-2), 0.0, 0.01,
                              np.zeros(0, dtype=np.int64), np.zeros(0, dtype=bool), -1, 0.0,
                              nm, 1e12, 10**7, 10**6, 0.0)
        assert out[0] == 0
        return out[2], out[8], out[6], out[7], out[14]

    ref = loop("Rodas5P", 1e-14)[0]
    print(f"\n## The compass walker's single stance, t = {t0:.4f} ... {t1:.4f} s (no events)\n")
    print("| method | rtol | error | steps | rhs | jac | LU |")
    print("|---|---|---|---|---|---|---|")

    def row(label, rtol, res):
        y, steps, nf, nj, nlu = res
        err = float(np.max(np.abs(y[:nm] - ref[:nm])))
        print(f"| {label} | {rtol:g} | {err:.1e} | {steps} | {nf} | {nj} | {nlu} |", flush=True)

    for rtol in (1e-8, 1e-9, 1e-10):
        row("Rodas5P", rtol, loop("Rodas5P", rtol))
    for reuse in (False, True):
        for rtol in (1e-7, 1e-8, 1e-9):
            row("ROS34PW2, J " + ("reused" if reuse else "every step"), rtol,
                ros34pw2(lambda t, y: F.rhs(t, y, pn), lambda t, y: F.jac(t, y, pn), t0, y0, t1,
                         rtol, rtol * 1e-2, 0.01, reuse))
    for rtol in (1e-9, 1e-10, 1e-11, 1e-12):
        row("QBDF", rtol, loop("QBDF", rtol))


# ------------------------------------------------------------------------------------------------
# work-precision on other models
# ------------------------------------------------------------------------------------------------
def stiff_chain():
    """(compiled model, t_end, simulate keywords): bench_compiler's 10-mass chain, every second
    link stiff."""
    from bench_compiler import build_chain, initial_state

    from porthamiltonian import compile_model

    n = 10
    model = compile_model(build_chain(n), backend="c")
    params = {f"{key}{i}": value for i in range(2, n + 1, 2)
              for key, value in (("k", 1e6), ("c", 2e4))}
    return model, 10.0, {"x0": initial_state(n), "params": params}


def file_model(name: str):
    from porthamiltonian import compile_model, io

    model = compile_model(io.load(name), backend="c")
    longest = 1.0 if name == "sphere_on_slope" else 10.0
    t_end = min(longest, float(io.read(name).simulation.get("t_end", 10.0)))
    return model, t_end, {}


def work_precision(names: list[str], repeats: int) -> None:
    print("\n## Work-precision, Rodas5P and QBDF (C back end; CPU time of one simulate call, "
          f"median of {repeats} interleaved rounds)")
    summary = []
    for name in names:
        model, t_end, kw = stiff_chain() if name == "stiff_chain" else file_model(name)
        ref = model.simulate(t_end, method="Rodas5P", rtol=1e-13, atol=1e-15, **kw)
        scale = max(1.0, float(np.max(np.abs(ref.x))))
        runs = [(method, rtol) for method, rtols in (("Rodas5P", RODAS_RTOLS),
                                                      ("QBDF", QBDF_RTOLS)) for rtol in rtols]
        info, times = {}, {r: [] for r in runs}
        for method, rtol in runs:
            tr = model.simulate(t_end, method=method, rtol=rtol, atol=rtol * 1e-2 * scale, **kw)
            err = float(np.max(np.abs(tr.x_final - ref.x_final))) / scale
            info[method, rtol] = (tr.status, err, len(tr.t) - len(tr.segments), tr.nfev, tr.njev,
                                  tr.nlu)
        for _ in range(repeats):
            for method, rtol in runs:
                t0 = time.process_time()
                model.simulate(t_end, method=method, rtol=rtol, atol=rtol * 1e-2 * scale, **kw)
                times[method, rtol].append(time.process_time() - t0)
        print(f"\n### {name} (t_end {t_end:g} s, {model.n_states} states, state scale "
              f"{scale:.3g}; reference: {len(ref.t)} steps)\n")
        print("| method | rtol | status | error | steps | rhs | jac | LU | CPU [ms] |")
        print("|---|---|---|---|---|---|---|---|---|")
        for method, rtol in runs:
            status, err, steps, nf, nj, nlu = info[method, rtol]
            print(f"| {method} | {rtol:g} | {status} | {err:.1e} | {steps} | {nf} | {nj} | {nlu} "
                  f"| {1e3 * statistics.median(times[method, rtol]):.3f} |")
        qbdf = [(info["QBDF", r][1], statistics.median(times["QBDF", r])) for r in QBDF_RTOLS
                if info["QBDF", r][0] == "finished"]
        for rtol in RODAS_RTOLS:
            err = info["Rodas5P", rtol][1]
            t_q = time_at_error(qbdf, err)
            t_r = statistics.median(times["Rodas5P", rtol])
            summary.append((name, rtol, err, t_r, t_q))
    print("\n## At equal accuracy: QBDF's time interpolated to each Rodas5P run's error\n")
    print("| model | Rodas5P rtol | error | Rodas5P CPU [ms] | QBDF CPU [ms] | QBDF / Rodas5P |")
    print("|---|---|---|---|---|---|")
    for name, rtol, err, t_r, t_q in summary:
        print(f"| {name} | {rtol:g} | {err:.1e} | {1e3 * t_r:.3f} | "
              + (f"{1e3 * t_q:.3f} | {t_q / t_r:.2f} |" if t_q else "— | (not bracketed) |"))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", action="store_true", help="the method study on the walker")
    parser.add_argument("--models", default=",".join(MODELS))
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    names = [m.strip() for m in args.models.split(",") if m.strip()]
    unknown = sorted(set(names) - set(MODELS))
    if unknown:
        parser.error(f"unknown model(s) {', '.join(unknown)}; choose from {', '.join(MODELS)}")
    info = machine_info()
    print(f"date {info['date']}; {info['nproc']} cores, {info['cpu']}; load average "
          f"{info['load']}; python {info['python']}, numpy {info['numpy']}")
    if args.study:
        study()
    else:
        work_precision(names, args.repeats)
    print(f"\nload average at the end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
