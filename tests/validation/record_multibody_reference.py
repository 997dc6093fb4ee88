"""Record reference numbers of the multibody models for test_multibody_regression.py.

The file data/multibody_reference.json holds, for every shipped model with a Multibody and the
models of multibody_cases.python_cases(), at three random states (multibody_cases.random_states,
seed 11) and the default parameters: the state derivative (rhs), its Jacobian (jac), [H, P_diss,
P_in] (energy), every named output and every named matrix, as computed by the python back end of
whatever porthamiltonian is on the path.

It was written with the formulation that differentiated the mass matrix's entries (commit
340043a, before the recursive multibody), so that the test checks the recursive formulation
against it::

    mkdir /tmp/old && git archive 340043a | tar -x -C /tmp/old
    PYTHONPATH=/tmp/old python tests/validation/record_multibody_reference.py 340043a

(run from the repository root; the script imports multibody_cases.py beside it).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
OUT = HERE / "data" / "multibody_reference.json"
SEED, COUNT = 11, 3


def record(compiled) -> dict:
    from multibody_cases import random_states

    p = compiled.param_defaults
    pn = compiled.native_params(p)
    entries = []
    for x in random_states(compiled, SEED, COUNT):
        y = compiled.augment(x)
        f = compiled.functions
        entries.append({
            "x": x.tolist(),
            "rhs": np.asarray(f.rhs(0.0, y, pn), dtype=float).tolist(),
            "jac": np.asarray(f.jac(0.0, y, pn), dtype=float).tolist(),
            "energy": np.asarray(f.energy(0.0, y, pn), dtype=float).tolist(),
            "outputs": dict(zip(compiled.output_names,
                                np.asarray(f.outputs(0.0, y, pn), dtype=float).tolist())),
            "matrices": {name: compiled.matrix(name, 0.0, x, p).tolist()
                         for name in compiled.matrix_names},
        })
    return {"state_names": compiled.state_names, "param_names": compiled.param_names,
            "initial": compiled.initial_state().tolist(), "states": entries}


def main(commit: str) -> None:
    sys.path.insert(0, str(HERE))
    from multibody_cases import python_cases, shipped_multibody_models

    import porthamiltonian.mechanics  # noqa: F401
    from porthamiltonian import compile_model, io

    data = {"commit": commit, "seed": SEED, "models": {}}
    models = {name: io.load(name) for name in shipped_multibody_models()}
    models.update(python_cases())
    for name, model in models.items():
        print("recording", name, flush=True)
        data["models"][name] = record(compile_model(model, backend="python", use_cache=False))
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(json.dumps(data, indent=0) + "\n")
    print(f"wrote {OUT} ({OUT.stat().st_size / 1e3:.0f} kB)")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "unknown")
