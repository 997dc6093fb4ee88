"""Benchmark of the walkers: wall time per simulated step and time to find the fixed point, the
framework's default path against hand-written numpy + scipy versions of the same models, in the
same run.

Run::

    python benchmarks/bench_walkers.py                 # all walkers, 3 interleaved rounds (~15 min)
    python benchmarks/bench_walkers.py --quick         # 1 round, 3 steps, no fixed points/compile
    python benchmarks/bench_walkers.py --walkers simplest,compass --rounds 5
    python benchmarks/bench_walkers.py --no-compile    # skip the cold/cached compile subprocesses

Walkers (framework: ``walker_library`` builders with their defaults; hand-written:
``tests/validation/handwritten_walkers.py``, see its docstring for the equations):

* ``simplest``: ``simplest_walker()`` (Garcia et al. 1998; python back end + scipy DOP853, rtol
  1e-12, atol 1e-24, max_step 0.25 — the walker's defaults) vs Garcia's equations of motion and
  heel-strike map under ``solve_ivp`` DOP853 at the same rtol/atol/max_step. Extra line: the same
  framework walker on the numba back end.
* ``compass``: ``compass_walker()`` (the thesis's nominal walker; its file's settings: the
  default back end — C when a compiler works — and the compiled Rodas5P loop at rtol 1e-9,
  atol 1e-11, max_step 0.01) vs the hand-written 4-DOF floating-base model under ``solve_ivp``
  Radau (jac=None: scipy's finite differences; and jac="fd": a hand-written forward-difference
  Jacobian) at rtol 1e-8, atol 1e-10 and the same max_step, mode switches by terminal events;
  LSODA for information (the fastest hand-written stiff solver in the contact benchmark).
* ``legs``: ``compliant_leg_walker()`` (thesis §3.1; the same settings) vs the hand-written 6-DOF
  point-mass model, the same variants. Skipped with a note if
  ``walker_library.compliant_leg_walker`` is not there.

Measured:

* per step: median over ``--rounds`` interleaved rounds of the wall time of one ``walk`` of
  ``--steps`` steps from the framework's fixed point (one simulation for the framework; the
  hand-written restarts solve_ivp at every mode switch), divided by the number of steps;
  ratio = hand / framework (> 1: the framework is faster);
* fixed point from the walker's initial guess: framework ``find_fixed_point`` (Newton, forward
  differences 1e-6 — ``jacobian="fd"``, like for like with the hand-written one —, tol: the walker's ``gait_tolerance`` or 1e-10) vs the same Newton by hand
  (``handwritten_walkers.newton_fixed_point``) on the hand-written stride map; medians of
  ``--fp-rounds``;
* validation: the hand-written fixed point vs the framework's, and the next section state of
  one stride from the same state (framework fixed point), max abs difference;
* compile (``--no-compile`` skips): a fresh subprocess with an empty $PORTHAMILTONIAN_CACHE
  (cold: symbolic compile + code generation + numba JIT at the first stride) and a second one on
  that warm cache (cached); builder time and first-stride time reported separately;
* where the framework's time goes: share of the compiled loop (C or numba walkers) or of the
  generated RHS (python back end), RHS / Jacobian evaluations and accepted steps per step;
* by back end (issue 11): the same walk on the C, numba and python back ends with the walker
  file's method (python: one step per round, it is slow), the configuration before issue 11
  (numba, Rodas4 at rtol 1e-8), Rodas4 at rtol 1e-8 on C, QBDF (the compiled BDF that reuses its
  Jacobian, issue 26) on C at rtol 1e-10, 1e-11, 1e-12 (atol = rtol/100), and — for the compass
  and the compliant-leg walkers — the limit baseline: the model written by hand in C
  (right-hand side and exact Jacobian) under SUNDIALS CVODE with root finding
  (benchmarks/cvode_compass_walker.c, benchmarks/cvode_compliant_leg_walker.c, built here when
  SUNDIALS is installed: ``apt-get install -y libsundials-dev`` on Debian/Ubuntu; without it
  the script says so and leaves those lines out; ``--cvode-rtols``, default 1e-8 … 1e-12, atol =
  rtol/100). For each C variant, CVODE's time at that variant's error is interpolated on
  CVODE's work-precision line, log-log between the two runs whose errors bracket it: the ratio
  at equal accuracy. Every variant's error is measured against a reference walk (Rodas5P at
  rtol 1e-12 on C; the simplest walker: DOP853 at 1e-13), so that the times are compared at
  known accuracy.

``--walkers`` takes the names above (simplest, compass, legs); any other name is refused.
"""
from __future__ import annotations

import argparse
import hashlib
import itertools
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # same LAPACK threading for framework and hand-written code

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "tests" / "validation"))

import handwritten_walkers as hw
import numpy as np
from machine import machine_info
from timing import fresh_walk

WALKERS = ("simplest", "compass", "legs")
#: the hand-written C + CVODE drivers, by walker
CVODE_SOURCES = {"compass": ROOT / "benchmarks" / "cvode_compass_walker.c",
                 "legs": ROOT / "benchmarks" / "cvode_compliant_leg_walker.c"}
#: the compiled methods' work-precision lines beside the file's method (QBDF: Jacobian reuse)
QBDF_RTOLS = (1e-10, 1e-11, 1e-12)
CVODE_LIBS = ("-lsundials_cvode", "-lsundials_nvecserial", "-lsundials_sunmatrixdense",
              "-lsundials_sunlinsoldense", "-lsundials_generic", "-lm")


# ------------------------------------------------------------------------------------------------
# framework side
# ------------------------------------------------------------------------------------------------
def legs_available() -> bool:
    try:
        from walker_library import compliant_leg_walker  # noqa: F401
    except ImportError:
        return False
    return True


def build_framework(name: str, backend: str | None = None):
    if name == "simplest":
        from walker_library import simplest_walker
        return simplest_walker(**({"backend": backend} if backend else {}))
    if name == "compass":
        from walker_library import compass_walker
        return compass_walker(**({"backend": backend} if backend else {}))
    from walker_library import compliant_leg_walker
    return compliant_leg_walker(**({"backend": backend} if backend else {}))


def build_hand(name: str, variant: str = "default"):
    if name == "simplest":
        return hw.SimplestWalkerHand()
    cls = hw.CompassWalkerHand if name == "compass" else hw.CompliantLegWalkerHand
    kw = {"Radau": {}, "Radau+fdjac": {"jac": "fd"}, "LSODA": {"method": "LSODA"},
          "default": {}}[variant]
    return cls(**kw)


def hand_variants(name: str) -> list[str]:
    return ["DOP853"] if name == "simplest" else ["Radau", "Radau+fdjac", "LSODA"]


def hand_guess(name: str, fw) -> np.ndarray:
    """The walker's initial guess in the hand-written section coordinates."""
    if name == "simplest":
        P = fw.parameters
        return np.array([P["theta0"], P["theta_dot0"], P["phi_dot0"]])
    return np.asarray(fw.initial_guess(), dtype=float)


def to_hand(name: str, fw, z) -> np.ndarray:
    """Framework section state -> hand-written section state."""
    if name == "simplest":
        th_dot, phi, phi_dot = fw.to_thesis(np.asarray(z, dtype=float))
        return np.array([phi / 2.0, th_dot, phi_dot])
    return np.asarray(z, dtype=float)


def fw_tol(fw) -> float:
    return float(getattr(fw, "gait_tolerance", 1e-10))


class FrameworkSection:
    """The framework walker's own section maps around a hand-written model, for a walker whose
    section definition is the framework's business (the compliant-leg walker: its section
    coordinates were being changed while this benchmark was written). ``to_y`` lifts a section
    state with the framework's ``lift`` and converts (q, p) to the hand-written (q, q̇);
    ``to_z`` converts back and applies the framework's ``project``. Kinematics only: the
    dynamics stay hand-written."""

    def __init__(self, fw, joints):
        self.fw = fw
        names = list(fw.model.state_names)
        coords = [n[len("walker.q."):] for n in names if n.startswith("walker.q.")]
        self._v_order = [coords.index(j) for j in joints]     # joints' rates among M⁻¹p
        self.iq = np.array([names.index(f"walker.q.{j}") for j in joints])
        self._ip_all = np.array([names.index(f"walker.p.{c}") for c in coords])
        self.p = fw.start_params()                      # both feet's contacts on, foot 1 leading
        self.i_lead = fw.model.param_names.index("lead")

    def to_y(self, z):
        fw = self.fw
        x = fw.lift(z, self.p)
        v = np.linalg.solve(fw.model.matrix("walker.M", 0.0, x, self.p), x[self._ip_all])
        return np.concatenate([x[self.iq], v[self._v_order]])

    def to_z(self, y, lead):
        fw = self.fw
        m = len(self.iq)
        x = np.zeros(fw.model.n_states)
        x[self.iq] = y[:m]
        for k in (1, 2):                                # the springs' lengths follow the joints
            x[fw.model.state_index(f"spring{k}.q")] = x[fw.model.state_index(f"walker.q.ankle{k}")]
        v = np.empty(m)
        v[self._v_order] = y[m:]
        x[self._ip_all] = fw.model.matrix("walker.M", 0.0, x, self.p) @ v
        p = self.p.copy()
        p[self.i_lead] = lead + 1
        return fw.project(x, p)


_ADAPTERS: dict[int, FrameworkSection] = {}


def adapter(name: str, fw):
    if name != "legs":
        return None
    if id(fw) not in _ADAPTERS:
        _ADAPTERS[id(fw)] = FrameworkSection(
            fw, ("hip_joint.x", "hip_joint.z", "leg1", "leg2", "ankle1", "ankle2"))
    return _ADAPTERS[id(fw)]


def hand_walk_records(name: str, h, z, n_steps: int, fw=None):
    """(section states after each step (None: fell), the raw records)."""
    if name == "simplest":
        out = h.walk(z, n_steps)
        return out, out
    ad = adapter(name, fw)
    if ad is None:
        recs = h.walk(z, n_steps)
        return [r.z_next for r in recs], recs
    recs = h.walk_from(ad.to_y(z), n_steps)
    return [None if r.z_next is None else ad.to_z(r.y, r.lead) for r in recs], recs


def hand_walk(name: str, h, z, n_steps: int, fw=None):
    """Section states after each step (list; None entries: fell)."""
    return hand_walk_records(name, h, z, n_steps, fw)[0]


def hand_stride_map(name: str, h, fw):
    if name == "simplest":
        return h.stride
    return lambda z: hand_walk(name, h, z, 1, fw)[0]


# ------------------------------------------------------------------------------------------------
# compile subprocesses
# ------------------------------------------------------------------------------------------------
def child(args) -> int:
    """Fresh process: build the walker, one stride from its initial guess, the same stride again
    (integrated again, not cut from the first: the time of a stride once built and loaded)."""
    t0 = time.perf_counter()
    fw = build_framework(args.child, args.backend or None)
    t_build = time.perf_counter() - t0
    z = fw.initial_guess()
    t0 = time.perf_counter()
    s = fw.stride(z)
    t_first = time.perf_counter() - t0
    t0 = time.perf_counter()
    fresh_walk(fw, z, 1)
    t_second = time.perf_counter() - t0
    print(json.dumps({"build": t_build, "first": t_first, "second": t_second,
                      "status": s.status, "backend": fw.backend}))
    return 0


def run_child(name: str, cache: str, backend: str = "") -> dict:
    env = dict(os.environ, PORTHAMILTONIAN_CACHE=cache, PYTHONPATH=str(ROOT))
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", name]
    if backend:
        cmd += ["--backend", backend]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=3000,
                         check=False)
    if out.returncode != 0:
        return {"error": out.stderr[-2000:]}
    return json.loads(out.stdout.strip().splitlines()[-1])


def compile_times(name: str, backend: str = "") -> dict:
    cache = tempfile.mkdtemp(prefix=f"phbench_walkers_{name}_")
    cold = run_child(name, cache, backend)
    cached = run_child(name, cache, backend)
    return {"cold": cold, "cached": cached}


# ------------------------------------------------------------------------------------------------
# back ends and the C + CVODE limit baseline
# ------------------------------------------------------------------------------------------------
def build_cvode(name: str) -> tuple[str | None, str]:
    """(path of the walker's compiled CVODE driver, or None, and a note saying why not)."""
    from porthamiltonian.backends import native

    cc = native.compiler()
    if cc is None:
        return None, "no C compiler"
    source = CVODE_SOURCES[name]
    out = Path(tempfile.mkdtemp(prefix="phbench_cvode_")) / source.stem
    run = subprocess.run([*cc, "-O2", str(source), "-o", str(out), *CVODE_LIBS],
                         capture_output=True, text=True, check=False)
    if run.returncode != 0:
        return None, ("SUNDIALS CVODE not found (apt-get install -y libsundials-dev): "
                      + (run.stderr.strip().splitlines() or ["?"])[0][:200])
    check = subprocess.run([str(out), "--check"], capture_output=True, text=True, check=True)
    return str(out), check.stdout.strip()


def run_cvode(name: str, fw, driver: str, z, n: int, repeats: int, rtol=1e-8, atol=1e-10,
              max_step=0.01) -> dict:
    """One run of the walker's CVODE driver from the framework's section state z; its section
    state after the walk in the framework's coordinates as ``z``. The compass driver takes and
    gives section states (the same coordinates); the compliant-leg one the hand-written state
    at the touchdown, converted by :class:`FrameworkSection`."""
    ad = adapter(name, fw)
    start = z if ad is None else ad.to_y(z)
    out = subprocess.run([driver, str(n), repr(rtol), repr(atol), repr(max_step), str(repeats),
                          *(repr(float(v)) for v in start)], capture_output=True, text=True,
                         check=True)
    res = json.loads(out.stdout)
    if ad is not None:
        res["z"] = ad.to_z(np.array(res["y"]), res["lead"]).tolist()
    return res


def backend_variants(name: str) -> dict:
    """label -> (walker, steps per timed walk divisor: None = the full walk)."""
    out = {f"{b}, the file's method": build_framework(name, b) for b in ("c", "numba", "python")}
    if name != "simplest":
        out["numba, Rodas4 rtol 1e-8 (before issue 11)"] = build_framework(name, "numba") \
            .with_options(method="Rodas4", rtol=1e-8, atol=1e-10)
        out["c, Rodas4 rtol 1e-8"] = build_framework(name, "c") \
            .with_options(method="Rodas4", rtol=1e-8, atol=1e-10)
        for rtol in QBDF_RTOLS:
            out[f"c, QBDF rtol {rtol:g}"] = build_framework(name, "c") \
                .with_options(method="QBDF", rtol=rtol, atol=rtol * 1e-2)
    return out


def bench_backends(name: str, z, args, rec: dict, cvode: dict[str, tuple[str | None, str]]
                   ) -> None:
    """Time per step of the same walk on each back end (and the C + CVODE baseline), each
    variant's error against a tight reference walk."""
    n = args.steps
    variants = backend_variants(name)
    base = build_framework(name, "c")
    ref_walker = (base.with_options(rtol=1e-13, atol=1e-24) if name == "simplest" else
                  base.with_options(method="Rodas5P", rtol=1e-12, atol=1e-14))
    ref = ref_walker.walk(z, n)
    z_ref = ref[-1].z_next
    for w in variants.values():           # build, load, JIT before timing
        w.stride(z)
    times: dict[str, list] = {k: [] for k in variants}
    info: dict[str, dict] = {}
    driver, note = cvode.get(name, (None, "not built"))
    cvode_runs: dict[float, list] = {float(r): [] for r in args.cvode_rtols.split(",")}
    for r in range(args.rounds):
        if driver is not None:                          # interleaved with the framework's
            for rtol, runs in cvode_runs.items():
                runs.append(run_cvode(name, base, driver, z, n, 1, rtol=rtol, atol=rtol * 1e-2))
                print(f"  round {r + 1}: hand C + CVODE rtol {rtol:g}"
                      f"{1e3 * runs[-1]['seconds'][0] / n:30.2f} ms/step", flush=True)
        for label, w in variants.items():
            steps = 1 if (label.startswith("python") and name != "simplest") else n
            t0 = time.perf_counter()
            out = w.walk(z, steps, record=True)
            times[label].append((time.perf_counter() - t0) / steps)
            tr = out[-1].info["trajectory"]
            info[label] = {"steps": (len(tr.t) - len(tr.segments)) / steps,
                           "nfev": tr.nfev / steps, "njev": tr.njev / steps, "nlu": tr.nlu / steps,
                           "error": (float(np.max(np.abs(out[-1].z_next - z_ref)))
                                     if steps == n else
                                     float(np.max(np.abs(out[-1].z_next - ref[0].z_next))))}
            print(f"  round {r + 1}: {label:45s} {1e3 * times[label][-1]:9.2f} ms/step",
                  flush=True)
    rows = {k: {"median": statistics.median(v), **info[k]} for k, v in times.items()}
    if name in CVODE_SOURCES and driver is None:
        rows["hand C + CVODE"] = {"note": note}
    for rtol, runs in cvode_runs.items():
        if runs:
            res = runs[-1]
            rows[f"hand C + CVODE, BDF rtol {rtol:g}"] = {
                "median": statistics.median(r["seconds"][0] for r in runs) / n,
                "steps": res["steps"] / n, "error": float(np.max(np.abs(np.array(res["z"]) - z_ref))),
                "nfev": res["nfev"] / n, "njev": res["njev"] / n, "note": note}
    rec["backends"] = rows


def having(report: dict, key: str) -> list[tuple[str, dict]]:
    """The walkers' records in ``report`` that hold ``key``, by name."""
    return [(name, rec) for name, rec in report.items() if key in rec]


def table(title: str | None, *columns: str) -> None:
    """Print the head of a markdown table: its section title (when given), column names, rule."""
    if title:
        print(f"\n## {title}")
    print("\n| " + " | ".join(columns) + " |")
    print("|" + "---|" * len(columns))


def print_backends(report: dict) -> None:
    if not any("backends" in r for r in report.values()):
        return
    table("Time per step by back end (median of the interleaved rounds; python: one step per "
          "round for the compliant walkers)",
          "walker", "variant", "[ms/step]", "accepted steps / rhs / jac / LU per step",
          "error after the walk vs the reference", "time / C (file's method)")
    for name, rec in report.items():
        rows = rec.get("backends", {})
        c = rows.get("c, the file's method", {}).get("median")
        for label, row in rows.items():
            if "median" not in row:
                print(f"| {name} | {label} | — ({row.get('note')}) | | | |")
                continue
            counts = " / ".join(f"{row[k]:.0f}" if k in row else "—"
                                for k in ("steps", "nfev", "njev", "nlu"))
            print(f"| {name} | {label} | {1e3 * row['median']:.2f} | {counts} | "
                  f"{row['error']:.1e} | {row['median'] / c:.2f} |")
        if c is not None and "numba, Rodas4 rtol 1e-8 (before issue 11)" in rows:
            before = rows["numba, Rodas4 rtol 1e-8 (before issue 11)"]["median"]
            print(f"\n{name}: C (file's method) is {before / c:.2f}x faster per step than the "
                  "numba loop before issue 11 (target: >= 2x)")
        cv = sorted((row["error"], row["median"]) for label, row in rows.items()
                    if label.startswith("hand C + CVODE") and "median" in row)
        for label, row in rows.items():
            if not label.startswith("c, ") or "median" not in row:
                continue
            t_eq = time_at_error(cv, row["error"])
            if t_eq is not None:
                print(f"{name}: {label}: at its error {row['error']:.1e}, CVODE (interpolated "
                      f"log-log between its runs bracketing it) takes {1e3 * t_eq:.2f} ms/step: "
                      f"{label} takes {row['median'] / t_eq:.2f}x that (target: <= 1.0x)")
            else:
                print(f"{name}: {label}: its error {row['error']:.1e} is not bracketed by "
                      "CVODE's runs")
        for label, row in rows.items():
            if label.startswith("hand C + CVODE") and "median" in row and c is not None:
                print(f"{name}: C (file's method) takes {c / row['median']:.2f}x the time per step "
                      f"of {label} (information: unequal errors); CVODE's error "
                      f"{row['error']:.1e} vs C's "
                      f"{rows['c, the file' + chr(39) + 's method']['error']:.1e}; "
                      f"{row.get('note', '')}")


def time_at_error(runs: list[tuple[float, float]], error: float) -> float | None:
    """The time at ``error`` on a work-precision line, log-log between the two runs (error,
    time) that bracket it; None when none do."""
    runs = sorted(runs)
    pair = next(((a, b) for a, b in itertools.pairwise(runs) if a[0] <= error <= b[0]), None)
    if pair is None or not pair[0][0] > 0 or pair[1][0] == pair[0][0]:
        return None
    (e0, t0), (e1, t1) = pair
    return math.exp(math.log(t0) + (math.log(t1) - math.log(t0))
                    * (math.log(error) - math.log(e0)) / (math.log(e1) - math.log(e0)))


# ------------------------------------------------------------------------------------------------
# measurements
# ------------------------------------------------------------------------------------------------
def source_hash() -> str:
    h = hashlib.sha1()
    for d in ("porthamiltonian", "walker_library"):
        for p in sorted((ROOT / d).rglob("*.py")):
            h.update(p.read_bytes())
    return h.hexdigest()[:12]


def framework_breakdown(fw, z, n_steps: int) -> dict:
    """Accepted steps, RHS / Jacobian evaluations per step, and the share of the wall time in
    the compiled loop (C, numba) or in the generated RHS (python back end)."""
    f = fw.model.functions
    method = getattr(fw.options, "method", "")
    name = "loop" if fw.backend != "python" and method in f.loops else "rhs"
    orig = f.loops[method] if name == "loop" else f.rhs
    acc = [0.0, 0]

    def wrapped(*a):
        t0 = time.perf_counter()
        r = orig(*a)
        acc[0] += time.perf_counter() - t0
        acc[1] += 1
        return r

    if name == "loop":
        f.loops[method] = wrapped
    else:
        object.__setattr__(f, "rhs", wrapped)
    try:
        t0 = time.perf_counter()
        strides = fw.walk(z, n_steps, record=True)
        total = time.perf_counter() - t0
    finally:
        if name == "loop":
            f.loops[method] = orig
        else:
            object.__setattr__(f, "rhs", orig)
    tr = strides[-1].info.get("trajectory")
    steps = len(tr.t) - len(tr.segments)
    return {"part": name, "share": acc[0] / total, "calls": acc[1], "total": total,
            "nfev": tr.nfev / n_steps, "njev": tr.njev / n_steps, "steps": steps / n_steps,
            "events": len(tr.events) / n_steps, "segments": len(tr.segments) / n_steps,
            "ledger_residual": float(tr.relative_residual)}


def bench_walker(name: str, args, report: dict) -> None:
    from walker_library import find_fixed_point

    print(f"\n=== {name} ===", flush=True)
    rec = report.setdefault(name, {})
    t0 = time.perf_counter()
    fw = build_framework(name)
    rec["build_in_process"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    fw.stride(fw.initial_guess())          # numba: loads (or JIT-compiles) the compiled functions
    rec["first_stride_in_process"] = time.perf_counter() - t0
    print(f"framework {fw.name}: backend {fw.backend}, options {fw.options}; build "
          f"{rec['build_in_process']:.2f} s, first stride {rec['first_stride_in_process']:.2f} s",
          flush=True)
    tol = fw_tol(fw)

    # fixed points (framework first: its fixed point is the start of the per-step runs)
    fp_times, fp = [], None
    for _ in range(args.fp_rounds):
        t0 = time.perf_counter()
        fp = find_fixed_point(fw, tol=tol, jacobian="fd")
        fp_times.append(time.perf_counter() - t0)
    n = args.steps
    if fp.converged:
        z_fw = fp.z
        rec["fp_framework"] = {"times": fp_times, "iterations": fp.iterations,
                               "residual": fp.residual, "z": z_fw.tolist()}
        print(f"framework fixed point: {statistics.median(fp_times):.3f} s (median of "
              f"{len(fp_times)}), {fp.iterations} Newton iterations, residual {fp.residual:.1e}",
              flush=True)
    else:
        # no gait (a model under construction): time one attempted stride from the initial
        # guess on both sides (it may end in a fall) and compare how it ends
        z_fw = np.asarray(fw.initial_guess(), dtype=float)
        n = 1
        rec["no_fixed_point"] = fp.message
        print(f"framework: NO fixed point ({fp.message}); timing one attempted stride from the "
              f"initial guess instead", flush=True)
    z_h0 = to_hand(name, fw, z_fw)
    variants = hand_variants(name)
    fp_variants = variants[:1] + (["LSODA"] if "LSODA" in variants and args.fp_lsoda else [])
    rec["fp_hand"] = {}
    for var in fp_variants if (args.fixed_points and fp.converged) else []:
        times = []
        for r in range(args.fp_rounds if var == variants[0] else 1):
            h = build_hand(name, var)
            t0 = time.perf_counter()
            res = hw.newton_fixed_point(hand_stride_map(name, h, fw), hand_guess(name, fw),
                                        tol=tol)
            times.append(time.perf_counter() - t0)
        rec["fp_hand"][var] = {"times": times, "iterations": res.iterations, "strides":
                               res.strides, "converged": res.converged, "residual": res.residual,
                               "z": res.z.tolist(), "diff": float(np.max(np.abs(res.z - z_h0)))}
        print(f"hand {var} fixed point: {statistics.median(times):.3f} s ({len(times)} run(s)), "
              f"{res.iterations} iterations, {res.strides} strides, residual {res.residual:.1e}, "
              f"max |z_hand - z_framework| = {rec['fp_hand'][var]['diff']:.1e}", flush=True)

    # validation: one stride from the framework's fixed point
    s_fw = fw.stride(z_fw)
    rec["stride_diff"] = {}
    rec["stride_end"] = {"framework": [s_fw.status, s_fw.reason, float(s_fw.duration)]}
    for var in variants:
        h = build_hand(name, var)
        if name == "simplest":
            zh, t_h, why = h.stride(z_h0), float("nan"), ""
        else:
            zs, recs = hand_walk_records(name, h, z_h0, 1, fw)
            zh, t_h, why = zs[0], float(recs[0].t), recs[0].reason
        rec["stride_end"][var] = ["step" if zh is not None else "fell", why, t_h]
        if zh is not None and s_fw.z_next is not None:
            d = float(np.max(np.abs(zh - to_hand(name, fw, s_fw.z_next))))
        else:
            d = float("nan")
        rec["stride_diff"][var] = d
        print(f"one stride from {'the framework fixed point' if fp.converged else 'the guess'}, "
              f"hand {var} vs framework: max abs diff of the next state {d:.1e}; ends: hand "
              f"{rec['stride_end'][var]}, framework {rec['stride_end']['framework']}", flush=True)

    # per-step timing, interleaved
    keys = ["framework"] + [f"hand {v}" for v in variants]
    extra_fw = None
    if name == "simplest" and not args.quick:
        extra_fw = build_framework(name, "numba")
        t0 = time.perf_counter()
        extra_fw.stride(z_fw)
        rec["numba_first_stride"] = time.perf_counter() - t0
        keys.insert(1, "framework numba")
    elif name != "simplest" and not args.quick:     # diagnostic: the same model under scipy Radau
        extra_fw = fw.with_options(method="Radau")
        keys.insert(1, "framework Radau")
    times = {k: [] for k in keys}
    stats: dict[str, dict] = {}
    for r in range(args.rounds):
        order = keys[r % len(keys):] + keys[: r % len(keys)]
        for k in order:
            if k.startswith("framework"):
                w = fw if k == "framework" else extra_fw
                t0 = time.perf_counter()
                out = (fresh_walk(w, z_fw, n) if k == "framework" else
                       w.walk(z_fw, n, record=True))
                el = time.perf_counter() - t0
                assert fp.converged is False or (len(out) == n and not out[-1].fell), out[-1].reason
                stats[k] = {"z_end": out[-1].z_next}
                if k != "framework":
                    tr = out[-1].info["trajectory"]
                    stats[k].update(nfev=tr.nfev / n, njev=tr.njev / n,
                                    steps=(len(tr.t) - len(tr.segments)) / n)
            else:
                h = build_hand(name, k.split(" ", 1)[1])
                t0 = time.perf_counter()
                out = hand_walk(name, h, z_h0, n, fw)
                el = time.perf_counter() - t0
                assert fp.converged is False or (len(out) == n and out[-1] is not None)
                st = h.stats if hasattr(h, "stats") else {"nfev": h.nfev, "steps": h.nsteps}
                stats[k] = {**{a: float(b) / n for a, b in st.items()}, "z_end": out[-1]}
            times[k].append(el / n)
            print(f"  round {r + 1}: {k:20s} {1e3 * el / n:9.2f} ms/step", flush=True)
    rec["per_step"] = {k: {"times": v, "median": statistics.median(v)} for k, v in times.items()}
    rec["per_step_stats"] = {k: {a: (b.tolist() if isinstance(b, np.ndarray) else b)
                                 for a, b in v.items()} for k, v in stats.items()}
    z_end = stats["framework"]["z_end"]
    z_end_fw = None if z_end is None else to_hand(name, fw, z_end)
    rec["walk_diff"] = {k: (float(np.max(np.abs(np.asarray(v["z_end"]) - z_end_fw)))
                            if v["z_end"] is not None and z_end_fw is not None else float("nan"))
                        for k, v in stats.items() if k.startswith("hand")}
    rec["steps_timed"] = n
    rec["breakdown"] = framework_breakdown(fw, z_fw, n)
    print(f"framework breakdown: {rec['breakdown']}", flush=True)
    if args.backends and fp.converged:
        print("by back end:", flush=True)
        bench_backends(name, z_fw, args, rec, args.cvode)


def print_tables(report: dict, info: dict, args) -> None:
    print(f"\n## Per step (median of {args.rounds} interleaved rounds of a {args.steps}-step walk "
          "from the fixed point)")
    for name, rec in report.items():
        if rec.get("no_fixed_point"):
            print(f"\n{name}: no fixed point ({rec['no_fixed_point']}): the times are per "
                  f"attempted stride from the initial guess; how it ended: {rec['stride_end']}")
    table(None, "walker", "framework default [ms/step]", "hand-written variant", "hand [ms/step]",
          "ratio hand/framework", "3x target", "hand steps / nfev / njev per step",
          "framework steps / nfev / njev per step", "next-state diff 1 stride",
          "diff after the walk")
    for name, rec in having(report, "per_step"):
        ps, st, br = rec["per_step"], rec["per_step_stats"], rec["breakdown"]
        f_ms = 1e3 * ps["framework"]["median"]
        for k in ps:
            if not k.startswith("hand"):
                continue
            var = k.split(" ", 1)[1]
            h_ms = 1e3 * ps[k]["median"]
            s = st[k]
            ratio = h_ms / f_ms
            print(f"| {name} | {f_ms:.2f} | {var} | {h_ms:.2f} | {ratio:.2f} | "
                  f"{'MET' if ratio >= 3 else 'MISSED'} | {s.get('steps', 0):.0f} / "
                  f"{s.get('nfev', 0):.0f} / {s.get('njev', 0):.0f} | {br['steps']:.0f} / "
                  f"{br['nfev']:.0f} / {br['njev']:.0f} | {rec['stride_diff'].get(var, float('nan')):.1e} | "
                  f"{rec['walk_diff'].get(k, float('nan')):.1e} |")
        if "framework Radau" in ps:
            s = st["framework Radau"]
            print(f"| {name} | (framework numba functions, scipy Radau: "
                  f"{1e3 * ps['framework Radau']['median']:.2f}) | Radau | "
                  f"{1e3 * ps['hand Radau']['median']:.2f} | "
                  f"{ps['hand Radau']['median'] / ps['framework Radau']['median']:.2f} | info | "
                  f"| {s['steps']:.0f} / {s['nfev']:.0f} / {s['njev']:.0f} | | |")
        if "framework numba" in ps:
            print(f"| {name} | (numba back end, DOP853: "
                  f"{1e3 * ps['framework numba']['median']:.2f}) | DOP853 | "
                  f"{1e3 * ps['hand DOP853']['median']:.2f} | "
                  f"{ps['hand DOP853']['median'] / ps['framework numba']['median']:.2f} | info | | | | |")
    table("Fixed point from the walker's initial guess (median wall time)",
          "walker", "tol", "framework [s] (Newton its)",
          "hand-written [s] (variant, Newton its, strides)", "ratio hand/framework",
          "max abs diff of the fixed points")
    for name, rec in having(report, "fp_framework"):
        f = rec["fp_framework"]
        ft = statistics.median(f["times"])
        for var, hrec in rec.get("fp_hand", {}).items():
            ht = statistics.median(hrec["times"])
            print(f"| {name} | {rec.get('tol', '')} | {ft:.3f} ({f['iterations']}) | {ht:.3f} "
                  f"({var}, {hrec['iterations']}, {hrec['strides']}) | {ht / ft:.1f} | "
                  f"{hrec['diff']:.1e} |")
    table("Where the framework's time goes (one walk, instrumented)",
          "walker", "backend / method", "wall [ms/step]", "share in", "share",
          "events / segments per step", "ledger rel. residual")
    for name, rec in having(report, "breakdown"):
        b = rec["breakdown"]
        print(f"| {name} | {rec.get('backend', '')} | {1e3 * b['total'] / args.steps:.2f} | "
              f"{'compiled loop' if b['part'] == 'loop' else 'generated RHS'} "
              f"({b['calls']} calls) | {100 * b['share']:.0f} % | {b['events']:.1f} / "
              f"{b['segments']:.1f} | {b['ledger_residual']:.1e} |")
    if any("compile" in r for r in report.values()):
        table("Compile (fresh subprocesses; cold = empty cache, cached = the same cache again)",
              "walker", "backend", "cold: build [s]", "cold: first stride [s]", "cached: build [s]",
              "cached: first stride [s]", "second stride [s]")
        for name, rec in report.items():
            for label, c in rec.get("compile", {}).items():
                cold, cached = c["cold"], c["cached"]
                if "error" in cold or "error" in cached:
                    print(f"| {name} | {label} | error: {(cold.get('error') or cached.get('error'))[-200:]!r} |")
                    continue
                print(f"| {name} | {label} | {cold['build']:.2f} | {cold['first']:.2f} | "
                      f"{cached['build']:.2f} | {cached['first']:.2f} | {cached['second']:.3f} |")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--walkers", default=",".join(WALKERS))
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--fp-rounds", type=int, default=3)
    parser.add_argument("--steps", type=int, default=10)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--no-compile", action="store_true")
    parser.add_argument("--no-fixed-points", dest="fixed_points", action="store_false")
    parser.add_argument("--no-fp-lsoda", dest="fp_lsoda", action="store_false",
                        help="skip the hand-written LSODA fixed-point search")
    parser.add_argument("--compile-only", action="store_true",
                        help="only the cold/cached compile subprocesses")
    parser.add_argument("--no-backends", dest="backends", action="store_false",
                        help="skip the per-back-end table (and the C + CVODE baseline)")
    parser.add_argument("--cvode-rtols", default="1e-8,1e-10,1e-11,1e-12",
                        help="tolerances of the C + CVODE baseline (atol = rtol/100)")
    parser.add_argument("--json", help="write the raw numbers to this file")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    parser.add_argument("--backend", default="", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        return child(args)
    if args.quick:
        args.rounds, args.steps, args.fp_rounds = 1, 3, 1
        args.no_compile, args.fixed_points = True, False
    names = [w.strip() for w in args.walkers.split(",") if w.strip()]
    unknown = [w for w in names if w not in WALKERS]
    if unknown or not names:
        parser.error(f"unknown walker name(s) {', '.join(map(repr, unknown)) or '(none given)'} "
                     f"in --walkers; choose from {', '.join(WALKERS)} (simplest = "
                     "simplest_walker, compass = compass_walker, legs = compliant_leg_walker)")
    args.cvode = {name: build_cvode(name) for name in names
                  if args.backends and name in CVODE_SOURCES}

    info = machine_info()
    src0 = source_hash()
    print(f"date {info['date']}; {info['nproc']} cores, {info['cpu']}; {info['platform']}; "
          f"load average {info['load']}")
    print(f"python {info['python']}, numpy {info['numpy']}, scipy {info['scipy']}, "
          f"sympy {info['sympy']}, numba {info['numba']}; BLAS threads "
          f"{os.environ.get('OPENBLAS_NUM_THREADS')}; source hash {src0}")
    print("tolerances: simplest walker rtol 1e-12, atol 1e-24, max_step 0.25 (DOP853, both sides);"
          " compliant walkers: framework the walker files' (Rodas5P, rtol 1e-9, atol 1e-11, "
          "max_step 0.01), hand Radau/LSODA rtol 1e-8, atol 1e-10, max_step 0.01; Newton tol = "
          "the walker's gait_tolerance (1e-10 simplest, 1e-8 compliant), fd step 1e-6; "
          f"{args.rounds} round(s) of {args.steps} steps", flush=True)

    report: dict = {}
    for name in names:
        if name == "legs" and not legs_available():
            print("\n=== legs === walker_library.compliant_leg_walker is not available: skipped")
            report["legs"] = {"skipped": True}
            continue
        if args.compile_only:
            report[name] = {}
            continue
        bench_walker(name, args, report)
        fw = build_framework(name)
        report[name]["backend"] = f"{fw.backend} / {fw.options.method}"
        report[name]["tol"] = f"{fw_tol(fw):g}"
    if not args.no_compile:
        for name in names:
            if report.get(name, {}).get("skipped"):
                continue
            print(f"\ncompile subprocesses: {name} ...", flush=True)
            report[name]["compile"] = {"default": compile_times(name)}
            if name == "simplest":
                report[name]["compile"]["numba"] = compile_times(name, "numba")
    print_tables(report, info, args)
    print_backends(report)
    for name, (_, note) in args.cvode.items():
        print(f"\nC + CVODE baseline, {name}: {note}")
    src1 = source_hash()
    print(f"\nload average at the end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}; source "
          f"hash {src1}{'' if src1 == src0 else ' (CHANGED during the run: other sessions edited the library)'}")
    if args.json:
        Path(args.json).write_text(json.dumps({"info": info, "report": report}, indent=1,
                                              default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
