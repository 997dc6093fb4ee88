"""Closed kinematic loops (issue 23's targets): Andrews' squeezer, the four-bar's drift, a ladder.

1. Andrews' squeezer to 1e-6 at t = 0.03 s: the cold build (C back end, empty cache, fresh
   interpreter) and the run (Rodas5P, rtol 1e-8, compiled loop) against scipy's Radau on the
   hand-written index-reduced equations of Hairer & Wanner (sec. VII.7; the IVP test set's
   formulation: M(q) w = f(q, q̇) − Gᵀλ, G w = −(∂(G q̇)/∂q) q̇, an ODE in (q, q̇) with the
   multipliers solved at every evaluation; numpy, analytic G), each to its error at t_end
   against the test set's reference (Radau at rtol 1e-7: its error 8e-8, under the 1e-6 bar).
   Medians of interleaved repeats.
2. The four-bar (models/four_bar.toml) over 100 s at rtol 1e-8 (Rodas5P): max |φ| and |G v| for
   constraint_gain 0, 1, 10 (the default), 100 (target |φ| ≤ 10 rtol = 1e-7 m).
3. A 10-loop ladder: two planar chains of ten links each, rung k hanging on the left chain's k-th
   joint and closed onto the right chain's by a loop revolute (30 tree joints, 20 constraint
   rows, 10 degrees of freedom), against the equivalent tree (the same model without the loops):
   build time (symbolic + code + C, fresh interpreter) and time per step and per right-hand
   side (with its Jacobian) over 2 s under gravity (target: build ≤ 10 s, speed ≥ 1/3 of the
   tree's per step), the ladder in both formulations (``ladder_symbolic``, ``ladder_kernel``:
   ``"auto"`` builds the kernel, a closed tree of more than KERNEL_LINKS links; the tree: the
   kernel, as ``"auto"`` builds it).

Run::

    python benchmarks/bench_closed_loops.py [--repeats 3] [--only andrews,drift,ladder]

Build times are given as wall time and as CPU time (this process's and its children's: the C
compiler), the latter the figure to compare on a shared machine; builds of compared models are
interleaved. The load average is printed before and after: the machine is shared.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from machine import machine_info

ROOT = Path(__file__).resolve().parent.parent

#: the IVP test set's reference positions at t = 0.03 s (andrews.f)
ANDREWS_REF = np.array([0.1581077119629904e+02, -0.1575637105984298e+02, 0.4082224013073101e-01,
                        -0.5347301163226948e+00, 0.5244099658805304e+00,
                        0.5347301163226948e+00, 0.1048080741042263e+01])
#: the model's outputs in the test set's order (beta, Theta, gamma, Phi, delta, Omega, epsilon)
ANDREWS_OUT = ["beta", "theta", "gamma", "phi", "delta", "omega", "epsilon"]
ANDREWS_Y0 = np.array([-0.0617138900142764496358948458001, 0.0,
                       0.455279819163070380255912382449, 0.222668390165885884674473185609,
                       0.487364979543842550225598953530, -0.222668390165885884674473185609,
                       1.23054744454982119249735015568])


#: the cold build of a model in a fresh interpreter (its text on stdin, or a shipped model's name
#: as argv[1]): prints the wall time and the CPU time (self + children: the C compiler), s
BUILD = ("import resource, sys, time, porthamiltonian as ph; from porthamiltonian import io; "
         "m = io.load(sys.argv[1]) if len(sys.argv) > 1 else io.loads(sys.stdin.read(), 'l.toml'); "
         "c = resource.getrusage(resource.RUSAGE_CHILDREN); c0 = c.ru_utime + c.ru_stime; "
         "t, w = time.process_time(), time.perf_counter(); ph.compile_model(m, backend='c'); "
         "c = resource.getrusage(resource.RUSAGE_CHILDREN); "
         "print(time.perf_counter() - w, time.process_time() - t + c.ru_utime + c.ru_stime - c0)")


def cold_build(text: str | None = None, name: str | None = None) -> tuple[float, float]:
    """(wall, CPU) seconds of one cold build (empty cache, fresh interpreter) of a model given by
    its ``text`` or a shipped model's ``name``."""
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "PORTHAMILTONIAN_CACHE": cache, "PORTHAMILTONIAN_QUIET": "1"}
        done = subprocess.run([sys.executable, "-c", BUILD, *([name] if name else [])],
                              input=text or "", env=env, capture_output=True, text=True,
                              check=True, cwd=ROOT)
    wall, cpu = (float(x) for x in done.stdout.split()[-2:])
    return wall, cpu


def andrews_rhs():
    """The hand-written index-reduced right-hand side (q, q̇) -> (q̇, w) of the test set."""
    m1, m2, m3, m4, m5, m6, m7 = .04325, .00365, .02373, .00706, .07050, .00706, .05498
    i1, i2, i3, i4, i5, i6, i7 = 2.194e-6, 4.410e-7, 5.255e-6, 5.667e-7, 1.169e-5, 5.667e-7, 1.912e-5
    xb, yb, xc, yc = -.03635, .03273, .014, .072
    d, da, e, ea, rr, ra = 28e-3, 115e-4, 2e-2, 1421e-5, 7e-3, 92e-5
    ss, sa, sb, sc, sd = 35e-3, 1874e-5, 1043e-5, 18e-3, 2e-2
    ta, tb, u, ua, ub, zf, fa, mom, c0, l0 = (2308e-5, 916e-5, 4e-2, 1228e-5, 449e-5, 2e-2,
                                               1421e-5, 33e-3, 4530.0, 7785e-5)
    zt = 4e-2
    ef = e - ea
    zff = zf - fa

    def rhs(_t, y):
        be, th, _ga, ph, de, om, ep = y[:7]
        bep, thp, gap, php, dep, omp, epp = y[7:]
        sibe, sith, siga, siph, side, siom, siep = np.sin(y[:7])
        cobe, coth, coga, coph, code, coom, coep = np.cos(y[:7])
        sibeth, cobeth = np.sin(be + th), np.cos(be + th)
        siphde, cophde = np.sin(ph + de), np.cos(ph + de)
        siomep, coomep = np.sin(om + ep), np.cos(om + ep)
        M = np.zeros((7, 7))
        M[0, 0] = m1 * ra**2 + m2 * (rr**2 - 2 * da * rr * coth + da**2) + i1 + i2
        M[1, 0] = M[0, 1] = m2 * (da**2 - da * rr * coth) + i2
        M[1, 1] = m2 * da**2 + i2
        M[2, 2] = m3 * (sa**2 + sb**2) + i3
        M[3, 3] = m4 * ef**2 + i4
        M[4, 3] = M[3, 4] = m4 * (ef**2 + zt * ef * siph) + i4
        M[4, 4] = m4 * (zt**2 + 2 * zt * ef * siph + ef**2) + m5 * (ta**2 + tb**2) + i4 + i5
        M[5, 5] = m6 * zff**2 + i6
        M[6, 5] = M[5, 6] = m6 * (zff**2 - u * zff * siom) + i6
        M[6, 6] = m6 * (zff**2 - 2 * u * zff * siom + u**2) + m7 * (ua**2 + ub**2) + i6 + i7
        xd = sd * coga + sc * siga + xb
        yd = sd * siga - sc * coga + yb
        lang = np.hypot(xd - xc, yd - yc)
        force = -c0 * (lang - l0) / lang
        fx, fy = force * (xd - xc), force * (yd - yc)
        f = np.array([mom - m2 * da * rr * thp * (thp + 2 * bep) * sith,
                      m2 * da * rr * bep**2 * sith,
                      fx * (sc * coga - sd * siga) + fy * (sd * coga + sc * siga),
                      m4 * zt * ef * dep**2 * coph,
                      -m4 * zt * ef * php * (php + 2 * dep) * coph,
                      -m6 * u * zff * epp**2 * coom,
                      m6 * u * zff * omp * (omp + 2 * epp) * coom])
        G = np.zeros((6, 7))
        G[0, :2] = [-rr * sibe + d * sibeth, d * sibeth]
        G[0, 2] = -ss * coga
        G[1, :2] = [rr * cobe - d * cobeth, -d * cobeth]
        G[1, 2] = -ss * siga
        G[2, :2] = G[0, :2]
        G[2, 3], G[2, 4] = -e * cophde, -e * cophde + zt * side
        G[3, :2] = G[1, :2]
        G[3, 3], G[3, 4] = -e * siphde, -e * siphde - zt * code
        G[4, :2] = G[0, :2]
        G[4, 5], G[4, 6] = zf * siomep, zf * siomep - u * coep
        G[5, :2] = G[1, :2]
        G[5, 5], G[5, 6] = -zf * coomep, -zf * coomep - u * siep
        # G w = −(d/dt G) q̇: minus the velocity products of the constraints' second
        # derivatives (gx, gy, ...: those products with their signs flipped)
        w1 = bep + thp
        gx = rr * cobe * bep**2 - d * cobeth * w1**2
        gy = rr * sibe * bep**2 - d * sibeth * w1**2
        w2, w3 = php + dep, omp + epp
        gamma = np.array([
            gx - ss * siga * gap**2,
            gy + ss * coga * gap**2,
            gx - e * siphde * w2**2 - zt * code * dep**2,
            gy + e * cophde * w2**2 - zt * side * dep**2,
            gx - zf * coomep * w3**2 - u * siep * epp**2,
            gy - zf * siomep * w3**2 + u * coep * epp**2])
        K = np.block([[M, G.T], [G, np.zeros((6, 6))]])
        w = np.linalg.solve(K, np.concatenate([f, gamma]))[:7]
        return np.concatenate([y[7:], w])

    return rhs


def bench_andrews(repeats: int) -> dict:
    from scipy.integrate import solve_ivp

    import porthamiltonian as ph
    from porthamiltonian import io

    out: dict = {"build_s": [], "build_cpu_s": [], "ours_s": [], "radau_s": []}
    model = ph.compile_model(io.load("andrews_squeezer"), backend="c")
    rhs = andrews_rhs()
    y0 = np.concatenate([ANDREWS_Y0, np.zeros(7)])
    for _ in range(repeats):
        wall, cpu = cold_build(name="andrews_squeezer")
        out["build_s"].append(wall)
        out["build_cpu_s"].append(cpu)
        t = time.process_time()
        traj = model.simulate(0.03, method="Rodas5P", rtol=1e-8, atol=1e-10)
        out["ours_s"].append(time.process_time() - t)
        t = time.process_time()
        sol = solve_ivp(rhs, (0, 0.03), y0, method="Radau", rtol=1e-7, atol=1e-9)
        out["radau_s"].append(time.process_time() - t)
    ours = np.array([traj[k][-1] for k in ANDREWS_OUT])
    out["ours_rel_error"] = float(np.max(np.abs(ours - ANDREWS_REF) / np.abs(ANDREWS_REF)))
    out["radau_rel_error"] = float(np.max(np.abs(sol.y[:7, -1] - ANDREWS_REF)
                                          / np.abs(ANDREWS_REF)))
    out["ours_steps"], out["radau_nfev"] = len(traj.t) - 1, int(sol.nfev)
    for key in ("build_s", "build_cpu_s", "ours_s", "radau_s"):
        out[key] = statistics.median(out[key])
    out["radau_over_ours"] = out["radau_s"] / out["ours_s"]
    return out


def bench_drift() -> list[dict]:
    import porthamiltonian as ph
    from porthamiltonian import io

    text = (ROOT / "models" / "four_bar.toml").read_text()
    text = text.replace('gravity = [0, 0, "-g"]', 'gravity = [0, 0, "-g"]\nconstraint_gain = "kappa"')
    text = text.replace("[parameters]", "[parameters]\nkappa = 10.0")
    model = ph.compile_model(io.loads(text, "four_bar_gain.toml"), backend="c")
    rows = []
    for kappa in (0.0, 1.0, 10.0, 100.0):
        t = time.perf_counter()
        traj = model.simulate(100.0, params={"kappa": kappa}, method="Rodas5P", rtol=1e-8,
                              atol=1e-10)
        elapsed = time.perf_counter() - t
        phi = max(float(np.max(np.abs(traj[o]))) for o in model.output_names if ".phi." in o)
        vel = max(float(np.max(np.abs(traj[o]))) for o in model.output_names
                  if ".velocity." in o)
        rows.append({"gain": kappa, "max_phi_m": phi, "max_Gv_m_s": vel, "steps": len(traj.t) - 1,
                     "relative_energy_residual": traj.relative_residual, "seconds": elapsed})
    return rows


def ladder_text(loops: bool, n: int = 10, formulation: str = "auto") -> str:
    """Two chains of n links (1 m apart, links 0.3 m) and n rungs, closed by n loop revolutes."""
    link = '{mass = 1.0, com = [0, 0, -0.15], inertia = [0.0075, 0.0075, 0.0075]}'
    rung = '{mass = 0.5, com = [0.5, 0, 0], inertia = [0.04, 0.04, 0.04]}'
    body = []
    for k in range(1, n + 1):
        for side in "LR":
            body += [f"mb.bodies.{side}{k} = {link}"]
        body += [f"mb.bodies.K{k} = {rung}"]
    joints = []
    for k in range(1, n + 1):
        for side, x in (("L", 0.0), ("R", 1.0)):
            parent = "world" if k == 1 else f"{side}{k - 1}"
            origin = f"[{x}, 0, 0]" if k == 1 else "[0, 0, -0.3]"
            q0 = "0.1" if k == 1 else "0"
            joints.append(f'mb.joints.{side}{k} = {{type = "revolute", parent = "{parent}", '
                          f'child = "{side}{k}", axis = "y", origin = {origin}, q0 = {q0}}}')
        joints.append(f'mb.joints.K{k} = {{type = "revolute", parent = "L{k}", child = "K{k}", '
                      f'axis = "y", origin = [0, 0, -0.3], q0 = -0.1}}')
    closures = [f'mb.loops.C{k} = {{type = "revolute", parent = "K{k}", child = "R{k}", '
                f'axis = "y", origin = [1, 0, 0], child_origin = [0, 0, -0.3]}}'
                for k in range(1, n + 1)] if loops else []
    name = f'ladder{n}{"" if loops else "_tree"}{"" if formulation == "auto" else "_" + formulation}'
    return "\n".join([f'[model]\nname = "{name}"\n',
                      "[components]", 'mb.type = "Multibody"', 'mb.plane = "xz"',
                      f'mb.formulation = "{formulation}"', *body,
                      *joints, *closures]) + "\n"


def bench_ladder(repeats: int) -> dict:
    import porthamiltonian as ph
    from porthamiltonian import io

    texts = {"ladder_symbolic": ladder_text(True, formulation="symbolic"),
             "ladder_kernel": ladder_text(True, formulation="kernel"), "tree": ladder_text(False)}
    builds: dict = {f"{name}_{kind}": [] for name in texts for kind in ("build_s", "build_cpu_s")}
    for _ in range(repeats):                        # interleaved: ladder, tree, ladder, ...
        for name, text in texts.items():
            wall, cpu = cold_build(text)
            builds[f"{name}_build_s"].append(wall)
            builds[f"{name}_build_cpu_s"].append(cpu)
    out: dict = {key: statistics.median(values) for key, values in builds.items()}
    models = {name: ph.compile_model(io.loads(text, f"{name}.toml"), backend="c")
              for name, text in texts.items()}
    per_step: dict = {name: [] for name in texts}
    per_f: dict = {name: [] for name in texts}
    for _ in range(repeats):
        for name, model in models.items():
            t = time.process_time()
            traj = model.simulate(2.0, method="Rodas5P", rtol=1e-8, atol=1e-10)
            elapsed = time.process_time() - t
            per_step[name].append(elapsed / (len(traj.t) - 1))
            per_f[name].append(elapsed / (traj.nfev + traj.njev))
            out[f"{name}_steps"] = len(traj.t) - 1
            out[f"{name}_relative_energy_residual"] = traj.relative_residual
    for name in models:
        out[f"{name}_us_per_step"] = 1e6 * statistics.median(per_step[name])
        out[f"{name}_us_per_evaluation"] = 1e6 * statistics.median(per_f[name])
    for name in ("ladder_symbolic", "ladder_kernel"):
        tag = name[len("ladder"):]
        out[f"speed_ratio_per_step{tag}"] = out["tree_us_per_step"] / out[f"{name}_us_per_step"]
        out[f"speed_ratio_per_evaluation{tag}"] = (out["tree_us_per_evaluation"]
                                                   / out[f"{name}_us_per_evaluation"])
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--only", default="andrews,drift,ladder")
    args = parser.parse_args()
    parts = args.only.split(",")
    print(json.dumps(machine_info()))
    results: dict = {}
    if "andrews" in parts:
        results["andrews"] = bench_andrews(args.repeats)
        print(json.dumps({"andrews": results["andrews"]}, indent=1), flush=True)
    if "drift" in parts:
        results["drift"] = bench_drift()
        print(json.dumps({"drift": results["drift"]}, indent=1), flush=True)
    if "ladder" in parts:
        results["ladder"] = bench_ladder(args.repeats)
        print(json.dumps({"ladder": results["ladder"]}, indent=1), flush=True)
    print("load after:", " ".join(f"{x:.2f}" for x in os.getloadavg()))


if __name__ == "__main__":
    main()
