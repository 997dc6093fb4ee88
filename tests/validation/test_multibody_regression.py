"""The recursive multibody against the numbers of the entrywise formulation it replaced.

data/multibody_reference.json (written by record_multibody_reference.py with commit 340043a,
whose Multibody formed M(q) entry by entry and its velocity terms by differentiating those
entries) holds, for every shipped model with a Multibody and for the spatial tree and 5-link
chain of multibody_cases.py, at three random states: ẋ, ∂ẋ/∂x, [H, P_diss, P_in], every output
and every named matrix. The recursive formulation must give the same numbers to round-off:
|new − old| ≤ 1e-12 · max(|old|, 0.1 · scale) entry by entry, where scale is the largest
|entry| of the same vector (of the same row of a matrix), so that entries that cancel to nearly
zero are compared on their vector's scale. The bodies' pose outputs, added later, are checked in
test_multibody_poses.py; the velocity outputs, added later too, against the joints' port flows. The thesis walkers, whose friction has since moved to the rolling contact
point, are compared with the friction put back at the sole point (:func:`sole_friction`; for
compass_walker and compliant_leg_walker the result is their *_sole_friction files' model).
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from multibody_cases import close, python_cases

from porthamiltonian import compile_model, io

HERE = Path(__file__).resolve().parent
REFERENCE = json.loads((HERE / "data" / "multibody_reference.json").read_text())
#: parameter values changed in the files after the reference was recorded (their initial guess
#: re-tuned for the legs' inertia): the reference's values
RECORDED = {"smooth_stiffness_walker": {"theta0": 0.2634, "theta_dot0": -0.9481,
                                        "phi_dot0": 0.0144}}

#: the thesis walkers whose friction moved to the rolling contact point after the reference was
#: recorded (issue 14): the reference is of the friction at the sole point, which
#: :func:`sole_friction` puts back into the file's text (each sole point R below its foot's arc
#: centre, as the files had it)
ROLLING = {"compass_walker", "compliant_leg_walker", "hip_and_leg_spring_walker",
           "variable_stiffness_walker", "smooth_stiffness_walker", "ankle_stiffness_walker"}


def sole_friction(text: str) -> str:
    """A rolling-contact walker file's text with the friction at the sole point instead: the
    foot's world frames c<k>, cf<k> replaced by the point sole<k>, the 3D contact and friction in
    the x-z plane by the planar ones reading the foot point."""
    for k in "12":
        text, n = re.subn(
            rf'points = \{{ foot{k} = \[0, 0, (0|"R - ankle_height")\] \}}\n'
            rf'world_frames = \{{ c{k} = [^\n]*\}}',
            lambda m, k=k: (f'points = {{ foot{k} = [0, 0, {m.group(1)}], sole{k} = [0, 0, '
                            + ('"-R"' if m.group(1) == "0" else '"-ankle_height"') + "] }"),
            text)
        assert n == 1, k
        floor3d = (f'type = "HuntCrossley3D", plane = "xz", x = "walker.c{k}.x", '
                   f'z = "walker.c{k}.z", radius = "R",')
        floor2d = f'type = "HuntCrossley", x = "walker.foot{k}.x", z = "walker.foot{k}.z - R",'
        fric3d = (f'type = "SCVSFriction3D", plane = "xz", normal_force = "floor{k}.Fn", '
                  'radius = "R",')
        fric2d = f'type = "SCVSFriction", normal_force = "floor{k}.Fn",'
        for old, new in ((f'"walker.c{k} -> floor{k}.p"', f'"walker.foot{k} -> floor{k}.p"'),
                         (f'"walker.cf{k} -> fric{k}.p"', f'"walker.sole{k} -> fric{k}.p"'),
                         (floor3d, floor2d), (fric3d, fric2d)):
            assert text.count(old) == 1, old
            text = text.replace(old, new)
    return text


#: a leg's inertia as the thesis walkers' files give it: a uniform rod, m_leg l²/12 about its
#: centre (across the leg in the 3D files)
ROD = re.compile(r'inertia = \[[^\]\n]*"m_leg\*l\*\*2/12"[^\]\n]*\]')


def point_legs(text: str) -> str:
    """A walker file's text with its legs' rod inertia set to 0 (point-mass legs, as the files
    were when the reference was recorded)."""
    return ROD.sub("inertia = 0", text)


@pytest.fixture(scope="module")
def built(isolated_cache):
    cases = python_cases()
    cache = {}

    def get(name):
        if name not in cache:
            if name in cases:
                model = cases[name]
            elif name in ROLLING:
                model = io.loads(point_legs(sole_friction(io.model_path(name).read_text())), name)
            else:
                model = io.loads(point_legs(io.model_path(name).read_text()), name)
            cache[name] = compile_model(model, backend="python")
        return cache[name]

    return get


@pytest.mark.parametrize("name", sorted(REFERENCE["models"]))
def test_same_numbers_as_the_entrywise_formulation(built, name):
    ref = REFERENCE["models"][name]
    model = built(name)
    assert model.state_names == ref["state_names"]
    # the thesis walkers' legs got a rod's inertia later (a parameter I_leg, then the expression
    # m_leg*l**2/12, which point_legs() zeroes): with point-mass legs, the reference's, the
    # numbers must be the reference's
    later = [n for n in model.param_names if n not in ref["param_names"]]
    assert later in ([], ["I_leg"]), later
    assert [n for n in model.param_names if n not in later] == ref["param_names"]
    params = np.array(model.param_defaults, dtype=float)
    for n in later:
        params[model.param_names.index(n)] = 0.0
    for n, value in RECORDED.get(name, {}).items():
        params[model.param_names.index(n)] = value
    close(model.initial_state(params), ref["initial"], f"{name} initial state")
    pn = model.native_params(params)
    f = model.functions
    for k, entry in enumerate(ref["states"]):
        x = np.array(entry["x"])
        y = model.augment(x)
        close(f.rhs(0.0, y, pn), entry["rhs"], f"{name} rhs #{k}")
        close(f.jac(0.0, y, pn), entry["jac"], f"{name} jac #{k}")
        close(f.energy(0.0, y, pn), entry["energy"], f"{name} energy #{k}")
        outputs = dict(zip(model.output_names, np.asarray(f.outputs(0.0, y, pn), float)))
        added = set(outputs) - set(entry["outputs"])        # the bodies' poses came later,
        assert set(entry["outputs"]) <= set(outputs), f"{name}: outputs lost"   # the velocities too
        assert all(re.search(r"\.pose\.(x|y|z|qw|qx|qy|qz)$", n) or ".v." in n for n in added), \
            added
        for n in added:             # a one-coordinate joint's velocity is its port's flow
            mb, _, joint = n.partition(".v.")
            if f"{mb}.{joint}.f" in outputs:
                assert outputs[n] == outputs[f"{mb}.{joint}.f"], n
        outputs = {n: v for n, v in outputs.items() if n in entry["outputs"]}
        names = sorted(outputs)
        close([outputs[n] for n in names], [entry["outputs"][n] for n in names],
              f"{name} outputs #{k}")
        assert set(model.matrix_names) == set(entry["matrices"])
        for mname, value in entry["matrices"].items():
            close(model.matrix(mname, 0.0, x, params), value, f"{name} {mname} #{k}")


@pytest.mark.parametrize("name", ["compass_walker", "compliant_leg_walker"])
def test_sole_friction_text_is_the_kept_variant(name):
    """sole_friction() of compass_walker (compliant_leg_walker) gives the components and bonds of
    compass_walker_sole_friction (compliant_leg_walker_sole_friction), the files kept with the
    friction at the sole point."""
    rebuilt = io.loads(sole_friction(io.model_path(name).read_text()), name)
    kept = io.load(f"{name}_sole_friction")
    a, b = io.model_to_dict(rebuilt), io.model_to_dict(kept)
    assert a["components"] == b["components"]
    assert rebuilt.freeze().bonds == kept.freeze().bonds
