"""Work that would cost a user their memory or their time is estimated before it starts, and
refused, bounded or shown (issue 21; porthamiltonian/compiler/estimate.py, batch/grids.py, the
gait search's and the continuation's time limits, simulate's progress).

Before: a 1000-link chain grew to 24 GB and was killed by the kernel after 8 minutes of silence
(a 60-link one took 5 minutes without a word); ``walker sweep`` with a 10⁹-case grid allocated
until MemoryError; ``walker gait compass_walker --set K=1e15`` printed nothing for over 10
minutes (the homotopy from K = 1e6 to 1e15 had no bound); ``t_end = 1e12`` ran silently.

The size cases run in subprocesses capped at 1 GB of address space (RLIMIT_AS) and must refuse
within 5 s of processor time (plus the interpreter's start); the time cases must answer with
their own message.
"""
from __future__ import annotations

import json
import math
import subprocess
import sys
import time

import numpy as np
import pytest
from bounds import capped

from porthamiltonian import io
from porthamiltonian.batch import grid, parse_grid
from porthamiltonian.compiler import estimate, symbolic
from porthamiltonian.compiler.codegen import program
from porthamiltonian.compiler.printers import c_source
from porthamiltonian.errors import CostError
from porthamiltonian.interfaces.cli import RunProgress
from walker_library.analyses.continuation import continue_gait
from walker_library.analyses.poincare import find_fixed_point
from walker_library.core.files import load_walker

GIGABYTE = 1 << 30
#: processor seconds of a refusal in a fresh interpreter: 5 s and the interpreter's start
SUBPROCESS_CPU = 12.0


def chain_text(n: int, formulation: str = "auto") -> str:
    """An n-link planar pendulum chain as a model file (uniform rods on revolute joints; the
    multibody's ``formulation``: auto takes the kernel beyond 9 links)."""
    lines = ["[model]", f'name = "chain{n}"', "[parameters]", "m = 1.0", "l = 0.1", "g = 9.81",
             "[components.arm]", 'type = "Multibody"', 'plane = "xz"', 'gravity = [0, 0, "-g"]',
             f'formulation = "{formulation}"']
    for i in range(n):
        lines += [f"[components.arm.bodies.b{i}]", 'mass = "m"', 'com = [0, 0, "-l/2"]',
                  'inertia = ["m*l**2/12", "m*l**2/12", "m*l**2/12"]']
    for i in range(n):
        lines += [f"[components.arm.joints.j{i}]", 'type = "revolute"',
                  f'parent = "{"world" if i == 0 else f"b{i - 1}"}"', f'child = "b{i}"',
                  'axis = "y"', "q0 = 0.1"] + ([] if i == 0 else ['origin = [0, 0, "-l"]'])
    return "\n".join([*lines, "[simulation]", "t_end = 0.1"]) + "\n"


def _cpu_of(proc_run) -> tuple[subprocess.CompletedProcess, float]:
    import resource
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = proc_run()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return proc, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


# --- the size of a model's code ---------------------------------------------------------------------
@pytest.mark.parametrize("n, formulation", [(6, "auto"), (12, "auto"), (8, "symbolic")])
def test_the_estimate_matches_the_generated_code(n, formulation):
    """The estimate of a chain's C code against the code generated (within 30 %; measured 3-7 %
    by benchmarks/bench_estimate.py), so that a refusal is about the real cost; with the
    formulation the build picks (auto: written out up to 9 links, the kernel beyond)."""
    description = io.loads(chain_text(n, formulation)).freeze()
    cost = estimate.estimate(description)
    sym = symbolic(description)
    size = len(c_source(program(sym)).encode())
    assert cost.kernel == bool(sym.calls) == (formulation == "auto" and n > 9)
    assert cost.bodies == n and cost.terms == n * (n + 1) // 2 and cost.links == cost.kernel * n
    assert 0.7 < cost.code_bytes / size < 1.3, (cost.code_bytes, size)


def tree_text(joints: list[tuple[str, str, str]]) -> str:
    """A 3D multibody of rods hung by ``(type, parent, child)`` joints (a model file)."""
    lines = ["[components.arm]", 'type = "Multibody"']
    for _, _, child in joints:
        lines += [f"[components.arm.bodies.{child}]", "mass = 1.0", "com = [0, 0, -0.1]",
                  "inertia = [0.01, 0.01, 0.01]"]
    for kind, parent, child in joints:
        axis = ['axis = "y"'] if kind == "revolute" else []
        lines += [f"[components.arm.joints.to_{child}]", f'type = "{kind}"',
                  f'parent = "{parent}"', f'child = "{child}"', *axis]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("joints, terms", [
    ([("revolute", "world", "a"), ("revolute", "world", "b"), ("revolute", "world", "c")], 3),
    ([("revolute", "world", "a"), ("revolute", "a", "b"), ("revolute", "a", "c")], 5),
    ([("spherical", "world", "a"), ("revolute", "a", "b")], 3 + 4),
    ([("revolute", "world", "a"), ("weld", "a", "b")], 2),
])
def test_the_estimate_counts_the_recursion_terms(joints, terms):
    """Σ over bodies of the joint coordinates between the body and the world: a star of N
    bodies costs N, a chain N(N+1)/2, a spherical joint 3, a weld 0."""
    cost = estimate.estimate(io.loads(tree_text(joints)).freeze())
    assert (cost.bodies, cost.terms) == (len(joints), terms)


def test_a_walker_and_a_top_are_small():
    for name, bodies in (("compass_walker_3d", 6), ("heavy_top", 1), ("mass_spring_damper", 0)):
        cost = estimate.estimate(io.load(name).freeze())
        assert cost.bodies == bodies and cost.code_bytes < 100e3, (name, cost)


def test_no_shipped_model_is_refused_or_announced(monkeypatch):
    """Every model of models/ passes the check without a line (written out symbolically, as
    they build: a few seconds each)."""
    from pathlib import Path
    monkeypatch.delenv(estimate.LIMIT_VARIABLE, raising=False)
    lines: list[str] = []
    names = sorted(p.stem for p in (Path(__file__).parents[2] / "models").glob("*.toml"))
    assert len(names) > 20
    for name in names:
        cost = estimate.check(io.load(name).freeze(), lines.append)
        assert not cost.kernel and cost.seconds < 5, (name, cost)
    assert lines == []


@pytest.mark.parametrize("n, argv", [
    (1000, ["-m", "porthamiltonian", "simulate"]),
    (1000, ["-m", "porthamiltonian", "show", "--code"]),
    (300, ["-m", "porthamiltonian", "simulate"]),
])
def test_a_huge_chain_is_refused_before_any_work(n, argv, tmp_path):
    """Under a 1 GB cap: refused with the estimate and the override, in seconds (before: 24 GB
    and the kernel's kill after 8 minutes). Evaluated by the multibody kernel, the chain's code
    is small (2.8 MB for 1000 links) but the C compiler's memory grows with the square of the
    links (about 1.6 GB for 300, measured 0.76 GB for 200): the memory refuses it."""
    path = tmp_path / f"chain{n}.toml"
    path.write_text(chain_text(n))
    proc, cpu = _cpu_of(lambda: capped([*argv, str(path)], GIGABYTE))
    assert proc.returncode == 2, proc.stderr[-2000:]
    err = proc.stderr
    assert err.startswith("error: ") and f"{n} bodies" in err and "refused before any work" in err
    assert "PORTHAMILTONIAN_MAX_CODE_MB" in err and "MemoryError" not in err
    assert "the memory available" in err and "GB of memory" in err
    assert cpu < SUBPROCESS_CPU, cpu


def test_the_memory_available_bounds_the_build(tmp_path):
    """A 60-link chain written out symbolically (2.4 MB of C: under the 8 MB limit, but about
    1.1 GB for the C compiler) in a process capped at 1 GB: refused, naming the memory
    available."""
    path = tmp_path / "chain60.toml"
    path.write_text(chain_text(60, "symbolic"))
    proc = capped(["-m", "porthamiltonian", "show", "--code", str(path)], GIGABYTE)
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert "60 bodies" in proc.stderr and "the memory available (1.1 GB)" in proc.stderr


def test_the_override_and_the_progress_line(monkeypatch):
    """$PORTHAMILTONIAN_MAX_CODE_MB raises the limit (0: none); a build estimated to take more
    than 20 s is announced before it starts."""
    description = io.loads(chain_text(60, "symbolic")).freeze()
    monkeypatch.delenv(estimate.LIMIT_VARIABLE, raising=False)
    monkeypatch.setattr(estimate, "_available_memory", lambda: 16e9)
    lines: list[str] = []
    cost = estimate.check(description, lines.append)
    assert len(lines) == 1 and lines[0].startswith("building chain60: 60 bodies, about 2.")
    assert "MB of code" in lines[0] and "to build)" in lines[0]
    assert cost.seconds > 20
    # by the kernel: 150 links, 0.3 MB of code but about 40 s (measured 24 s for 120 links)
    kernel = estimate.check(io.loads(chain_text(150)).freeze(), lines.append)
    assert kernel.kernel and 0.2e6 < kernel.code_bytes < 0.45e6 and 30 < kernel.seconds < 60
    assert len(lines) == 2 and lines[1].startswith("building chain150: 150 bodies, about 29")
    assert estimate.check(io.loads(chain_text(60)).freeze(), lines.append).seconds < 20
    assert len(lines) == 2                  # the kernel builds 60 links in about 10 s: no line
    monkeypatch.setenv(estimate.LIMIT_VARIABLE, "1")
    with pytest.raises(CostError, match=r"more than \$PORTHAMILTONIAN_MAX_CODE_MB = 1 allows"):
        estimate.check(description, lines.append)
    monkeypatch.setenv(estimate.LIMIT_VARIABLE, "0")
    assert estimate.limit()[0] == math.inf
    monkeypatch.setenv(estimate.LIMIT_VARIABLE, "lots")
    with pytest.raises(CostError, match="must be a number of MB"):
        estimate.limit()


# --- the cases of a sweep ----------------------------------------------------------------------------
@pytest.mark.parametrize("argv", [
    ["-m", "walker_library", "sweep", "simplest_walker", "--grid", "slope=0.001:0.01:1000",
     "--grid", "gamma=1:2:1000", "--grid", "x=1:2:1000"],
    ["-m", "porthamiltonian", "sweep", "mass_spring_damper", "--grid", "k=1:2:1000000000"],
    ["-m", "porthamiltonian", "sweep", "mass_spring_damper", "--grid", "k=1:2:100000",
     "--grid", "c=0.1,0.2"],
])
def test_a_huge_grid_is_refused_before_any_case_is_made(argv, tmp_path):
    out = tmp_path / "s.jsonl"
    proc, cpu = _cpu_of(lambda: capped([*argv, "--out", str(out)], GIGABYTE))
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert "refused before any case is made" in proc.stderr and "--max-cases" in proc.stderr
    assert not out.exists() and cpu < SUBPROCESS_CPU


def test_grid_limits_in_python_and_the_override():
    with pytest.raises(CostError, match=r"12 cases \(3 \(a\) x 4 \(b\)\)"):
        grid(max_cases=10, a=[1, 2, 3], b=[1, 2, 3, 4])
    assert len(grid(max_cases=12, a=[1, 2, 3], b=[1, 2, 3, 4])) == 12
    assert len(grid(max_cases=None, a=range(300), b=range(400))) == 120_000
    with pytest.raises(CostError, match="1,000,000,000 cases"):
        parse_grid(["k=0:1:1000000000"])
    assert len(parse_grid(["k=0:1:11", "c=1,2"], max_cases=22)) == 22


def test_a_huge_basin_grid_is_refused_before_the_gait_search(tmp_path):
    """`walker basin --n 100000` made its 10^10-entry tables before walking a point (it hung,
    then ran out of memory): refused by the option's rule, before the walker is even loaded,
    with the largest n and where a larger grid belongs; 316 x 316 (the most) is accepted."""
    proc, cpu = _cpu_of(lambda: capped(["-m", "walker_library", "basin", "rimless_wheel", "--n",
                                        "100000"], GIGABYTE))
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert proc.stderr == ("error: basin: --n = 100000 makes a grid of 10,000,000,000 points, "
                           "more than 100,000 (each point is a walk, and the grid's tables are "
                           "made before the first); give --n <= 316, or run a larger grid as a "
                           "resumable sweep (walker sweep MODEL --analysis basin --grid ... "
                           "--max-cases N)\n")
    assert cpu < SUBPROCESS_CPU
    from walker_library.analyses.robustness import check_basin_size

    check_basin_size(316)
    with pytest.raises(CostError, match=r"n = 317 makes a grid of 100,489 points"):
        check_basin_size(317)


@pytest.mark.parametrize("resolution, h_max, error, message", [
    ("0.1", "0.01", "ParameterValueError",
     ("step_down: resolution (0.1 m) is larger than h_max (0.01 m), so the scan would walk no "
      "height; give a resolution of at most h_max")),
    ("1e-300", "0.1", "ParameterValueError",
     ("step_down: resolution (1e-300 m) is below 1e-12 m, to which the heights are rounded; give "
      "a resolution of at least 1e-12 m")),
    ("1e-9", "0.1", "CostError",
     ("step_down: h_max / resolution = 0.1 m / 1e-09 m makes up to 1e+08 heights, more than "
      "100,000 (each a walk); give a coarser resolution or a lower h_max")),
])
def test_a_step_down_grid_without_heights_or_with_too_many_is_refused(resolution, h_max, error,
                                                                       message, monkeypatch,
                                                                       capsys):
    """A resolution above h_max walked no height and reported "no drop survived" (status 0); one
    below the heights' rounding walked h = 0 again and again (without a time limit, forever);
    1e8 heights ran to the time limit. Each is refused before the gait search (exit 2; the
    rimless wheel's default h_max is 0.1 of its 1 m leg)."""
    from porthamiltonian import errors
    from walker_library.analyses import robustness
    from walker_library.cli import main

    def no_search(*args, **kwargs):
        raise AssertionError("the gait search started")

    monkeypatch.setattr(robustness, "_gait_or_raise", no_search)
    assert main(["step-down", "rimless_wheel", "--resolution", resolution, "--h-max", h_max,
                 "--quiet"]) == 2
    assert capsys.readouterr().err == f"error: {message}\n"
    with pytest.raises(getattr(errors, error)) as info:
        robustness.step_down(load_walker("rimless_wheel"), resolution=float(resolution),
                             h_max=float(h_max))
    assert str(info.value) == message


# --- time: the gait search and the continuation -------------------------------------------------------
def test_a_gait_search_that_would_run_for_hours_stops_at_its_time_limit(capsys, within):
    """K = 1e15 (a contact 1e9 times stiffer than the file's): Newton from the guess stops at
    half the limit (it would use any time given), the search continues the file's nominal gait
    towards K, shows its progress, and stops at --time-limit with its own message (before: over
    10 minutes without a word; then: Newton from the guess used the whole limit, 4.8 s of it
    here before the continuation could start)."""
    from walker_library.cli import main

    with within(cpu=120):
        status = main(["gait", "compass_walker", "--set", "K=1e15", "--time-limit", "4"])
    out, err = capsys.readouterr()
    assert status == 0, err
    assert "the search from the guess stopped at 50% of the time limit" in out
    assert ("the search stopped at its time limit (4 s; --time-limit) while continuing the "
            "model file's nominal gait (K 1e+06 -> 1e+15)") in out
    assert "continuing the model file's nominal gait: K 1e+06 -> 1e+15" in err  # progress
    assert "branch 0 (period 1): homotopy = " in err


@pytest.mark.parametrize("study", ["step-down", "basin", "gsn"])
def test_the_studies_stop_their_gait_search_at_their_time_limit(study, capsys):
    """step-down, basin and gsn start from the gait search, which with K = 1e15 runs to its
    default limit (600 s) before the study starts: --time-limit bounds it as for `walker gait`,
    and the study says that it has no gait and why."""
    from walker_library.cli import main

    status = main([study, "compass_walker", "--set", "K=1e15", "--time-limit", "0.2", "--json",
                   "--quiet"])
    result = json.loads(capsys.readouterr().out)
    assert status == 0 and result["status"] == "no_gait"
    assert "the search stopped at its time limit (0.2 s; --time-limit)" in result["message"]


@pytest.mark.parametrize("study", ["basin", "gsn"])
def test_a_study_without_a_gait_shows_no_nan(study, capsys):
    """Without a gait (the search stopped at once) basin printed "radius nan" and gsn "error
    estimate nan" after the message that there is no gait: the message alone now."""
    from walker_library.cli import main

    assert main([study, "compass_walker", "--set", "K=1e15", "--time-limit", "0.2",
                 "--quiet"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("compass_walker: no periodic gait: ") and out.count("\n") == 1, out
    assert "nan" not in out, out


class _Clock:
    """A clock for ``time.perf_counter()`` that a test moves (one second per case below)."""

    def __init__(self) -> None:
        self.now = 0.0

    def perf_counter(self) -> float:
        return self.now


@pytest.fixture(scope="module")
def compass_gait():
    from walker_library.analyses.gait import analyze_gait

    walker = load_walker("compass_walker")
    return walker, analyze_gait(walker)


def test_the_step_down_scan_starts_no_height_after_its_deadline(compass_gait, monkeypatch):
    """Each height takes a second of a fake clock: with the deadline at 2.5 s the scan walks 3
    heights, the grid's first three (the same walks as those heights given explicitly), and its
    result says it stopped; a deadline passed already walks none."""
    from walker_library.analyses import robustness

    walker, gait = compass_gait
    grid = [round(k * 2e-4 * walker.leg_length, 12) for k in (1, 2, 3)]  # the default grid's
    given = robustness.step_down(walker, gait, heights=grid, boundary_tol=0)
    assert given.stopped == "" and [c["kind"] for c in given.cases] == ["given"] * 3
    clock = _Clock()
    monkeypatch.setattr(robustness, "time", clock)

    def tick(case: dict) -> None:
        clock.now += 1.0

    part = robustness.step_down(walker, gait, progress=tick, deadline=2.5)
    assert part.stopped == "stopped at the time limit after 3 heights"
    assert part.cases == [{**c, "kind": "grid"} for c in given.cases] and part.status == "ok"
    assert part.message.startswith("stopped at the time limit after 3 heights: largest drop "
                                   f"survived {part.max_step_down * 1e3:.3f} mm")
    none = robustness.step_down(walker, gait, deadline=-1.0)
    assert none.cases == [] and none.max_step_down == 0.0
    assert none.message == "stopped at the time limit before the first height: no drop measured"


def test_the_basin_grid_starts_no_point_after_its_deadline(compass_gait, monkeypatch):
    """A 3 x 3 grid with the deadline after 5 points (a second each): those 5 as in the whole
    grid, the other 4 "not_run" (counted as not converged by the radius), the fraction over the
    points walked."""
    from walker_library.analyses import robustness

    walker, gait = compass_gait
    whole = robustness.basin(walker, gait, n=3)
    ref = [o for row in whole.outcome for o in row]
    assert whole.stopped == "" and "not_run" not in ref
    clock = _Clock()
    monkeypatch.setattr(robustness, "time", clock)

    def tick(point: dict) -> None:
        clock.now += 1.0

    part = robustness.basin(walker, gait, n=3, progress=tick, deadline=4.5)
    flat = [o for row in part.outcome for o in row]
    assert flat[:5] == ref[:5] and flat[5:] == ["not_run"] * 4
    assert part.stopped == "stopped at the time limit after 5 of 9 points"
    converged = ref[:5].count("converged")
    assert part.fraction == converged / 5
    assert part.message == (f"{converged} of 5 grid states converge to the gait (stopped at the "
                            "time limit after 5 of 9 points)")
    assert part.radius <= min(whole.radius, math.hypot(0.1, 0.0))   # (1, 2) not run: r = 0.1


@pytest.mark.parametrize("study", ["step-down", "basin"])
def test_the_studies_scans_end_at_their_time_limit(study, monkeypatch, capsys):
    """`walker step-down` and `walker basin` hand the study a deadline --time-limit seconds
    after the command started (the gait search's time included)."""
    from walker_library.analyses import robustness
    from walker_library.cli import main

    name = study.replace("-", "_")
    real, seen = getattr(robustness, name), []

    def recording(*args, **kwargs):
        seen.append(kwargs["deadline"])
        return real(*args, **{**kwargs, "deadline": -1.0})   # stop at once: the wiring only

    monkeypatch.setattr(robustness, name, recording)
    start = time.perf_counter()
    assert main([study, "compass_walker", "--time-limit", "30", "--json", "--quiet"]) == 0
    assert start < seen[0] - 30.0 < time.perf_counter()
    assert json.loads(capsys.readouterr().out)["stopped"].startswith("stopped at the time limit")


def test_newton_starts_no_iteration_after_its_time_limit():
    """A deadline already passed: Newton takes the one stride from the guess and starts no
    iteration (no Jacobian run); the gait search says so and where it stopped."""
    from walker_library.analyses.gait import analyze_gait

    walker = load_walker("simplest_walker")
    fp = find_fixed_point(walker, deadline=time.perf_counter())
    assert (fp.converged, fp.iterations, fp.message) == (False, 0, "stopped at the time limit")
    assert len(fp.history) == 1 and fp.residual > 1e-10
    free = find_fixed_point(walker)
    assert free.converged and free.iterations >= 2
    result = analyze_gait(walker, time_limit=1e-9)
    assert "Newton (period 1) from the guess: stopped at the time limit" in result.search
    assert ("the search stopped at its time limit (1e-09 s; --time-limit) after Newton from "
            "the guess") in result.message


def test_the_run_of_the_newton_matrix_stops_at_the_deadline():
    """The run with sensitivities (a stiff contact makes it take seconds: compass_walker at
    K = 1e15, ≈ 4 s on a quiet machine) stops at its first progress call after the deadline:
    ``stopped``, no Jacobian; and Newton, whose deadline passes during that run, says "stopped at
    the time limit" after the one stride from the guess. Without a deadline the same run gives
    the Jacobian (compass_walker at its file's K)."""
    walker = load_walker("compass_walker")
    z = walker.initial_guess()
    stopped = walker.stride_sensitivity(z, deadline=time.perf_counter())
    assert stopped.stopped and stopped.jacobian is None and not stopped.fell
    whole = walker.stride_sensitivity(z)
    assert not whole.stopped and whole.jacobian is not None
    stiff = walker.with_parameters(K=1e15)
    seen: list[tuple[float, bool]] = []
    sensitivity = stiff.stride_sensitivity

    def recorded(*args, **kwargs):
        run = sensitivity(*args, **kwargs)
        seen.append((kwargs["deadline"], run.stopped))
        return run
    stiff.stride_sensitivity = recorded
    stiff.stride(z)                 # Newton's first stride is then this walk again (reused)
    deadline = time.perf_counter() + 0.2
    fp = find_fixed_point(stiff, z, deadline=deadline)
    assert (fp.converged, fp.iterations, fp.message) == (False, 0, "stopped at the time limit")
    assert seen == [(deadline, True)] and len(fp.history) == 1


def test_a_continuation_stops_at_its_time_limit_and_says_where():
    """The simplest walker's branch over the slope (about 0.45 s for its 18 points on the
    project machine, then the period-2 branch from the flip): a limit of 0.05 s stops the first
    branch (it used to be 0.5 s; on the compiled loop the first branch can end within it)."""
    walker = load_walker("simplest_walker")
    t0 = time.perf_counter()
    result = continue_gait(walker, "slope", 0.004, 0.0185, time_limit=0.05, max_points=400)
    assert time.perf_counter() - t0 < 60
    assert result.stopped.startswith("stopped at the time limit (0.05 s) at slope = ")
    assert result.branches[0].end == result.stopped and result.stopped in result.message
    assert result.to_dict()["stopped"] == result.stopped
    with pytest.raises(Exception, match="time_limit must be a number of seconds > 0"):
        continue_gait(walker, "slope", 0.004, 0.0185, time_limit=0.0)


@pytest.mark.parametrize("argv, words", [
    (["gait", "simplest_walker", "--time-limit", "-1"], "--time-limit must be a finite number >= 0"),
    (["continue", "simplest_walker", "--param", "slope=0.01:0.02", "--time-limit", "nan"],
     "--time-limit must be a finite number >= 0"),
])
def test_bad_time_limits_are_refused(argv, words, capsys):
    from walker_library.cli import main

    assert main(argv) == 2
    assert words in capsys.readouterr().err


# --- time: long runs -------------------------------------------------------------------------------
def test_the_progress_of_a_run_estimates_what_is_left(monkeypatch, capsys):
    clock = iter([0.0, 6.0, 7.0, 40.0])
    monkeypatch.delenv("PORTHAMILTONIAN_QUIET", raising=False)
    progress = RunProgress("pendulum", 1e12, max_steps=10_000_000, clock=lambda: next(clock))
    progress(600.0, 6000)                        # 6 s: a line (1e13 steps needed)
    progress(700.0, 7000)                        # 7 s: not yet (every 30 s)
    progress(4000.0, 40_000)
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 2, lines
    assert lines[0].startswith("pendulum: t = 600 s of 1e+12 s") and "6000 steps" in lines[0]
    assert "will stop at the limit of 10000000 steps near t = 1e+06 s" in lines[0]
    clock2 = iter([0.0, 10.0])
    RunProgress("pendulum", 100.0, clock=lambda: next(clock2))(50.0, 100)
    assert "about 10 s to go at this pace" in capsys.readouterr().err
    # --progress-interval 0.5: the first line after 0.5 s, the next 3 s later
    clock3 = iter([0.0, 0.4, 0.6, 3.5, 3.7])
    progress = RunProgress("pendulum", 100.0, clock=lambda: next(clock3), interval=0.5)
    for t in (1.0, 2.0, 3.0, 4.0):
        progress(t, 10)
    lines = capsys.readouterr().err.splitlines()
    assert [line.split(" of ")[0] for line in lines] == ["pendulum: t = 2 s", "pendulum: t = 4 s"]


def test_simulate_reports_its_progress(compile_named):
    seen: list[tuple[float, int]] = []
    compile_named("pendulum").simulate(50.0, method="Radau", progress=lambda t, n: seen.append((t, n)))
    assert seen and np.all(np.diff([t for t, _ in seen]) > 0) and seen[-1][1] >= 1000
    with pytest.raises(Exception, match="progress must be a function"):
        compile_named("pendulum").simulate(1.0, progress=3)


def test_t_end_1e12_is_not_silent(isolated_cache):
    """``simulate pendulum --t-end 1e12``: a line says where the run is and that max_steps will
    end it (the run is then stopped). By default the first line comes after 5 s (the clock of
    test_the_progress_of_a_run_estimates_what_is_left); here after ``--progress-interval``
    0.5 s, the same line."""
    import os

    from porthamiltonian.interfaces.cli import build_parser
    for command in ("simulate", "view"):
        assert build_parser().parse_args([command, "pendulum"]).progress_interval == 5.0
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    env.pop("PORTHAMILTONIAN_QUIET", None)
    proc = subprocess.Popen([sys.executable, "-m", "porthamiltonian", "simulate", "pendulum",
                             "--t-end", "1e12", "--progress-interval", "0.5"],
                            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, env=env)
    try:
        deadline = time.monotonic() + 240
        line = ""
        while time.monotonic() < deadline:
            line = proc.stderr.readline()
            if line.startswith("pendulum: t = "):
                break
    finally:
        proc.kill()
        proc.wait()
    assert "of 1e+12 s" in line and "will stop at the limit of 10000000 steps" in line, line
    assert line.rstrip().endswith("(Ctrl-C stops the run)")
