"""One right-hand side of the compiled multibody against Pinocchio's ABA, both in C, no Python.

The model: the N-link chain about random 3D axes (generic_chain_model of
tests/validation/multibody_cases.py, N = 20 by default), compiled by the C back end (``auto``
formulation: the recursive kernel). Pinocchio (``pip install pin``: its wheels ship the C++
headers and libraries; Eigen's headers from the system, e.g. Debian's libeigen3-dev) builds the
same chain (revolute joints about the same unaligned axes, the same placements, masses, centres
of mass and inertias) in benchmarks/native/pinocchio_aba.cpp, compiled here with g++ -O3 against
the wheel's libpinocchio_default (its precompiled double-precision algorithms).

Checked first, through Pinocchio's Python bindings: its mass matrix (crba) equals the model's
``chain.M`` and its gravity torques (rnea at zero velocity and acceleration) equal −ṗ of the model
at zero momentum, to 1e-9 relative; and the model's q̇ at (q, p = M v) is v.

Timed (thread CPU time per call, the minimum over 30 rounds of many calls, in a C / C++ program
each, no Python in the loop; the two programs alternate over ``--rounds`` rounds, medians):

* **model rhs**: ``ph_rhs`` of the model's shared library (benchmarks/native/model_rhs.c,
  dlopen): q̇ = v = M(q)⁻¹ p and ṗ (the kernel's state call) plus the ledger's two rates, at
  (q, p = M v);
* **Pinocchio aba**: ``pinocchio::aba(model, data, q, v, tau = 0)``, the forward dynamics q̈.

Both compute the forward dynamics of the same state; ours works in momenta (v from p, then ṗ),
Pinocchio's in accelerations. Skipped (with a message) when Pinocchio, Eigen or g++ is missing:
benchmarks are not tests.

Run::

    python benchmarks/bench_pinocchio.py                 # N = 20, 5 rounds
    python benchmarks/bench_pinocchio.py --links 10,20,40 --rounds 7
"""
from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import statistics
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "validation"))
NATIVE = Path(__file__).resolve().parent / "native"
_WORK = Path(tempfile.gettempdir()) / "porthamiltonian-bench-pinocchio"
_DEFINES = ["-DBOOST_MPL_LIMIT_LIST_SIZE=30", "-DBOOST_MPL_LIMIT_VECTOR_SIZE=30",
            "-DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS", "-DBOOST_FUSION_INVOKE_MAX_ARITY=12",
            "-DPINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION"]


def pinocchio_prefix() -> Path | None:
    """The cmeel prefix of the installed Pinocchio wheel (include/, lib/), or None."""
    prefix = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix"
    return prefix if (prefix / "include" / "pinocchio" / "algorithm" / "aba.hpp").is_file() else None


def eigen_include() -> Path | None:
    for path in (Path("/usr/include/eigen3"), Path("/usr/local/include/eigen3")):
        if (path / "Eigen" / "Core").is_file():
            return path
    return None


def compiled(source: Path, command: list[str], suffix: str) -> Path:
    """``source`` compiled by ``command`` (the output path appended), kept by hash."""
    digest = hashlib.sha256(source.read_bytes() + " ".join(command).encode()).hexdigest()[:16]
    _WORK.mkdir(exist_ok=True)
    out = _WORK / f"{source.stem}_{digest}{suffix}"
    if not out.is_file():
        subprocess.run([*command, "-o", str(out)], check=True)
    return out


def chain_table(model, n: int) -> str:
    """The chain's table for pinocchio_aba.cpp (see its header)."""
    mb = model.freeze().components["chain"]
    bodies, joints = mb.value("bodies"), mb.value("joints")
    lines = [f"{n} 9.81"]
    for i in range(n):
        j, b = joints[f"q{i}"], bodies[f"link{i}"]
        I = np.array(b["inertia"], dtype=float)
        lines.append(" ".join(repr(float(v)) for v in [
            -1 if i == 0 else i - 1, *j["axis"], *j["origin"], b["mass"], *b["com"],
            I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]))
    return "\n".join(lines) + "\n"


def check_same_mechanism(compiled_model, table: str, q: np.ndarray, v: np.ndarray) -> None:
    """Pinocchio's crba and rnea against the compiled model's M and ṗ (see the docstring)."""
    import pinocchio as pin

    rows = [line.split() for line in table.strip().splitlines()]
    n = int(rows[0][0])
    model = pin.Model()
    model.gravity.linear = np.array([0.0, 0.0, -float(rows[0][1])])
    parent = 0
    for row in rows[1:]:
        a, o, m, c, I = (np.array(row[1:4], float), np.array(row[4:7], float), float(row[7]),
                         np.array(row[8:11], float), np.array(row[11:17], float))
        parent = model.addJoint(parent, pin.JointModelRevoluteUnaligned(*a),
                                pin.SE3(np.eye(3), o), f"j{len(model.names)}")
        Ic = np.array([[I[0], I[3], I[4]], [I[3], I[1], I[5]], [I[4], I[5], I[2]]])
        model.appendBodyToJoint(parent, pin.Inertia(m, c, Ic), pin.SE3.Identity())
    data = model.createData()
    params = compiled_model.param_defaults
    x = np.concatenate([q, np.zeros(n)])
    M_pin = pin.crba(model, data, q)
    M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
    M = compiled_model.matrix("chain.M", 0.0, x, params)
    assert np.max(np.abs(M - M_pin)) < 1e-9 * np.max(np.abs(M)), "mass matrices differ"
    gravity = pin.rnea(model, data, q, np.zeros(n), np.zeros(n))
    pdot = compiled_model.functions.rhs(0.0, compiled_model.augment(x),
                                        compiled_model.native_params(params))[n:2 * n]
    assert np.max(np.abs(pdot + gravity)) < 1e-9 * np.max(np.abs(gravity)), "gravity differs"
    print(f"same mechanism: |M - M_pin| {np.max(np.abs(M - M_pin)):.1e}, |pdot + g| "
          f"{np.max(np.abs(pdot + gravity)):.1e} (max |M| {np.max(np.abs(M)):.2f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--links", default="20")
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    prefix, eigen, gxx = pinocchio_prefix(), eigen_include(), shutil.which("g++")
    if prefix is None or eigen is None or gxx is None:
        print("skipped: needs Pinocchio's wheel (pip install pin), Eigen's headers "
              "(apt-get install libeigen3-dev) and g++; found "
              f"pinocchio {prefix}, eigen {eigen}, g++ {gxx}")
        return
    from multibody_cases import generic_chain_model

    from porthamiltonian import compile_model
    from porthamiltonian.backends import native
    pin_aba = compiled(NATIVE / "pinocchio_aba.cpp",
                       [gxx, "-O3", "-DNDEBUG", "-std=c++17", *_DEFINES, f"-I{prefix / 'include'}",
                        f"-I{eigen}", str(NATIVE / "pinocchio_aba.cpp"),
                        f"-L{prefix / 'lib'}", "-lpinocchio_default",
                        f"-Wl,-rpath,{prefix / 'lib'}"], "")
    model_rhs = compiled(NATIVE / "model_rhs.c",
                         [*(native.compiler() or ["cc"]), "-O2", "-std=c99",
                          str(NATIVE / "model_rhs.c"), "-ldl"], "")
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}; compiler flags of the "
          f"model: {' '.join(native.FLAGS)}")
    for n in (int(v) for v in args.links.split(",")):
        chain = generic_chain_model(n)
        with tempfile.TemporaryDirectory() as cache:
            os.environ["PORTHAMILTONIAN_CACHE"] = cache
            model = compile_model(chain, backend="c")
            library = next(Path(cache).rglob("m*_c_*.so"))
            rng = np.random.default_rng(2)
            q = rng.uniform(-1, 1, n)
            v = rng.uniform(-1, 1, n)
            x = np.concatenate([q, np.zeros(n)])
            x[n:] = model.matrix("chain.M", 0.0, x, model.param_defaults) @ v
            table = chain_table(chain, n)
            check_same_mechanism(model, table, q, v)
            work = Path(cache)
            (work / "table.txt").write_text(table)
            (work / "state.txt").write_text(" ".join(repr(float(a)) for a in [*q, *v]) + "\n")
            y = model.augment(x)
            pn = model.native_params(model.param_defaults)
            (work / "model.txt").write_text(
                f"{len(y)}\n" + "\n".join(repr(float(a)) for a in y) + f"\n{len(pn)}\n"
                + "\n".join(repr(float(a)) for a in np.asarray(pn, float)) + "\n")
            ours, theirs = [], []
            for _ in range(args.rounds):
                out = subprocess.run([str(model_rhs), str(library), str(work / "model.txt"),
                                      "2000"], capture_output=True, text=True, check=True)
                ours.append(float(out.stdout.split()[0]))
                out = subprocess.run([str(pin_aba), str(work / "table.txt"),
                                      str(work / "state.txt"), "2000"],
                                     capture_output=True, text=True, check=True)
                theirs.append(float(out.stdout.split()[0]))
            ddq = np.array(out.stdout.split()[1:], float)
            qdot = model.functions.rhs(0.0, y, pn)[:n]
            assert np.max(np.abs(qdot - v)) < 1e-9 * np.max(np.abs(v)), "v = M^-1 p"
            a, b = statistics.median(ours), statistics.median(theirs)
            print(f"N = {n}: model rhs {a * 1e6:.2f} us (min {min(ours) * 1e6:.2f}), Pinocchio "
                  f"aba {b * 1e6:.2f} us (min {min(theirs) * 1e6:.2f}); rhs / aba = {a / b:.2f} "
                  f"(medians of {args.rounds} interleaved rounds; |ddq| max {np.max(np.abs(ddq)):.2f})")
    print(f"load average at the end {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
