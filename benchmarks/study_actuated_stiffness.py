"""Study: the energy the stiffness actuator spends per step (REPRODUCTION.md, Table 3.1).

For each variable-stiffness case of the thesis's Table 3.1 (K1 -> K2, α, φ_max as in
REPRODUCTION.md), the gait of

* ``variable_stiffness_walker`` — the thesis's rule switched instantaneously (the modulation power
  ½ K̇ z² booked as supplied energy, and the jump of H at lift-off), and
* ``actuated_stiffness_walker`` — the same rule as the reference of a servo (time constant τ_K)
  driving each leg's stiffness through a stiffness actuator, whose work is booked per actuator,

and per step: speed, the energy supplied (J; for the actuated walker the two actuators' work) and
the dissipated energy, each from a walk of ``--steps`` steps from the fixed point (one ledger).

Run::

    python benchmarks/study_actuated_stiffness.py               # the three cases (~5 min)
    python benchmarks/study_actuated_stiffness.py --tau 0.002 --steps 4
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

CASES = [  # (K1, K2, alpha, phi_max): REPRODUCTION.md, Table 3.1 (rolling contact)
    (6000.0, 8000.0, 0.2, 0.43789),
    (6000.0, 12000.0, 0.3, 0.36173),
    (8000.0, 12000.0, 0.2, 0.44126),
]


def per_step(name: str, values: dict, steps: int, start: dict | None = None) -> dict:
    """Gait and ledger per step of walker ``name`` with parameter ``values``; ``start``: a
    fixed point (by name) of the switched walker to start the actuated walker's search from
    (its stiffness states from the rule there)."""
    from walker_library import analyze_gait, load_walker

    walker = load_walker(name, values)
    guess = None
    if start is not None:
        K1, K2, phi_max = values["K1"], values["K2"], values["phi_max"]
        start = {**start, "spring1.K": K1,
                 "spring2.K": K1 + (K2 - K1) * abs(start["phi"]) / phi_max}
        guess = [start[k] for k in walker.section]
    result = analyze_gait(walker, guess=guess)
    if result.status != "periodic":
        return {"status": result.status}
    z = np.array([result.fixed_point[k] for k in walker.section])
    strides = walker.walk(z, steps, record=True)
    ledger = strides[-1].info["trajectory"].ledger()
    actuators = ledger.get("actuators", {})
    return {"status": f"period {result.period_steps}, {'stable' if result.stable else 'unstable'}",
            "fixed_point": result.fixed_point, "speed": result.metrics.speed,
            "supplied": ledger["supplied"] / steps,
            "actuators": sum(actuators.values()) / steps if actuators else None,
            "dissipated": ledger["dissipated"] / steps,
            "residual": ledger["relative_residual"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tau", type=float, default=0.005, help="servo time constant τ_K (s)")
    parser.add_argument("--steps", type=int, default=3, help="steps walked per ledger")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f}; tau_K = {args.tau} s, {args.steps} steps")
    print(f"{'case':24s} {'walker':12s} {'speed m/s':>10s} {'supplied J/step':>16s} "
          f"{'actuators J/step':>17s} {'dissipated J/step':>18s}  status")
    for K1, K2, alpha, phi_max in CASES:
        values = {"K1": K1, "K2": K2, "alpha": alpha, "phi_max": phi_max}
        seed = None
        for label, name, extra in (("switched", "variable_stiffness_walker", {}),
                                   ("actuated", "actuated_stiffness_walker", {"tau_K": args.tau})):
            start = time.perf_counter()
            r = per_step(name, {**values, **extra}, args.steps, seed)
            seed = r.get("fixed_point")
            case = f"{K1:.0f} -> {K2:.0f}, a = {alpha}"
            if "speed" not in r:
                print(f"{case:24s} {label:12s} {r['status']}")
                continue
            act = "-" if r["actuators"] is None else f"{r['actuators']:.5f}"
            print(f"{case:24s} {label:12s} {r['speed']:10.4f} {r['supplied']:16.5f} {act:>17s} "
                  f"{r['dissipated']:18.5f}  {r['status']}, residual {r['residual']:.1e}, "
                  f"{time.perf_counter() - start:.0f} s", flush=True)


if __name__ == "__main__":
    main()
