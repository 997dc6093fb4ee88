"""FMUs of open models (porthamiltonian.fmu): inputs as FMI inputs, declared outputs as outputs,
discrete-time controller blocks sampled inside the FMU.

Checked against our own runs with the same input samples (Rodas5P at rtol 1e-12): FMPy's input
table (a zero-order hold: every step change is a repeated time in the table) driving the
co-simulation FMU, to 1e-8 at the communication points, and the model-exchange FMU under FMPy's
CVODE (rtol 1e-11), to 1e-6; FMI 2.0's input derivatives (linear extrapolation over a
communication step) against our linear interpolation of the same samples; a discrete PID inside
the FMU (time events in model exchange, sampled in doStep in co-simulation) against our run;
FMPy's validation of every FMU. One FMU per model and FMI version (ME and CS in one).
"""
from __future__ import annotations

import ctypes

import fmpy  # the test extra installs it
import numpy as np
import pytest
from fmpy.validation import validate_fmu

from porthamiltonian import C, I, Model, OneJunction, R, compile_model, io
from porthamiltonian.errors import OptionError
from porthamiltonian.library import Actuator, DiscretePID
from porthamiltonian.simulation.inputs import Samples

VERSIONS = (2, 3)
#: model -> (end time s, sample period of the force s, seed of its values)
CASES = {"msd": (4.0, 0.1, 2), "cart_pole": (2.0, 0.05, 1)}


def _msd(name: str = "msd", drive: str = "F") -> Model:
    """Mass 1.5 kg, spring k = 4 N/m, damper 0.4 N s/m on a 1-junction, pushed by an actuator
    whose force is ``drive`` (the input F unless a controller drives it); output: the position."""
    m = Model(name)
    m.parameter("k", 4.0, "N/m", "spring stiffness")
    if drive == "F":
        m.input("F", "N", "force on the mass")
    m.add("push", Actuator(effort=drive))
    m.add("j", OneJunction())
    m.add("mass", I(inertance=1.5))
    m.add("spring", C(stiffness="k"))
    m.add("damper", R(resistance=0.4))
    m.connect("push.p", "j")
    for e in ("mass", "spring", "damper"):
        m.connect("j", f"{e}.p")
    m.output("position", "spring.q")
    return m


@pytest.fixture(scope="module")
def models(isolated_cache):
    return {"msd": compile_model(_msd(), backend="c"),
            "cart_pole": compile_model(io.load("cart_pole"), backend="c")}


@pytest.fixture(scope="module")
def fmus(models, tmp_path_factory):
    folder = tmp_path_factory.mktemp("fmus_in")
    return {(name, fmi): models[name].export_fmu(folder / f"{name}_{fmi}.fmu", fmi=fmi,
                                                  rtol=1e-10, atol=1e-12,
                                                  stop_time=CASES[name][0])
            for name in CASES for fmi in VERSIONS}


def _force(name: str) -> tuple[np.ndarray, np.ndarray]:
    t_end, period, seed = CASES[name]
    t = np.round(np.arange(0.0, t_end - period / 2, period), 12)
    return t, np.random.default_rng(seed).uniform(-2.0, 2.0, len(t))


def _table(name: str, t: np.ndarray, u: np.ndarray, t_end: float) -> np.ndarray:
    """FMPy's input table of the held samples: each change is a repeated time."""
    rows = [(t[0], u[0])]
    for k in range(1, len(t)):
        rows += [(t[k], u[k - 1]), (t[k], u[k])]
    rows.append((t_end, u[-1]))
    return np.array(rows, dtype=[("time", float), (name, float)])


@pytest.fixture(scope="module")
def references(models):
    """Our runs with the held samples (Rodas5P, rtol 1e-12, atol 1e-14): they stop on every
    sample time, so the trajectory holds the points the FMUs are compared at."""
    out = {}
    for name, model in models.items():
        t, u = _force(name)
        out[name] = model.simulate(CASES[name][0], inputs={"F": Samples(t, u, "zoh")},
                                   method="Rodas5P", rtol=1e-12, atol=1e-14)
    return out


def _error_at_common_times(result, traj, names, first: bool = True) -> tuple[float, int]:
    """max |FMU - ours| over the FMU's times that our trajectory holds, to 1e-12 s (FMPy's grid
    n dt and our sample times k T may differ in their last bit); at a time it holds twice, a
    sampling instant, the point before it when ``first``, else after; and how many."""
    worst, count = 0.0, 0
    for i, t in enumerate(result["time"]):
        at = np.nonzero(np.abs(traj.t - t) <= 1e-12)[0]
        if len(at):
            j = at[0] if first else at[-1]
            worst = max(worst, max(abs(result[n][i] - traj[n][j]) for n in names))
            count += 1
    return worst, count


@pytest.mark.parametrize("fmi", VERSIONS)
@pytest.mark.parametrize("name", CASES)
def test_inputs_and_declared_outputs_in_the_model_description(fmus, models, name, fmi):
    path = fmus[name, fmi]
    assert validate_fmu(str(path)) == []
    md = fmpy.read_model_description(str(path))
    var = {v.name: v for v in md.modelVariables}
    force = var["F"]
    assert (force.causality, force.variability, force.unit) == ("input", "continuous", "N")
    assert float(force.start) == 0.0 and force.description
    declared = models[name].declared_outputs
    outputs = {v.name for v in md.modelVariables if v.causality == "output"}
    assert {n for n in outputs if not n.startswith(("ledger.", "events."))} == set(declared)
    unit = {"msd": {"position": "m"}, "cart_pole": {"x": "m", "theta": "rad"}}[name]
    assert {n: var[n].unit for n in declared} == unit       # the units of what they read
    assert var["push.p.f"].causality == "local"
    if fmi == 2:
        assert md.coSimulation.canInterpolateInputs


@pytest.mark.parametrize("fmi", VERSIONS)
@pytest.mark.parametrize("name", CASES)
def test_co_simulation_driven_by_fmpys_input_table_equals_our_run(fmus, models, references,
                                                                   name, fmi):
    """The force held between its samples (FMPy sets it at each communication point; a change
    restarts the FMU's integration there, as our run stops at each sample time): at the
    communication points, vs ours at rtol 1e-12: measured 4.1e-14 (msd) and 4.5e-10 (cart-pole,
    FMU at rtol 1e-10); the ledger closes with the input's work as supplied energy."""
    model, t_end = models[name], CASES[name][0]
    t, u = _force(name)
    result = fmpy.simulate_fmu(str(fmus[name, fmi]), fmi_type="CoSimulation", stop_time=t_end,
                               output_interval=0.01, relative_tolerance=1e-10,
                               start_values={"solver.atol": 1e-12}, input=_table("F", t, u, t_end),
                               output=[*model.state_names, *model.declared_outputs,
                                       "ledger.residual", "ledger.E_in"])
    error, count = _error_at_common_times(result, references[name],
                                          [*model.state_names, *model.declared_outputs])
    assert count >= len(t) and error < 1e-8
    assert abs(result["ledger.residual"][-1]) < 1e-8
    assert result["ledger.E_in"][-1] == pytest.approx(references[name].E_in[-1], abs=1e-8)


@pytest.mark.parametrize("fmi", VERSIONS)
@pytest.mark.parametrize("name", CASES)
def test_model_exchange_driven_by_fmpys_input_table_matches_our_run(fmus, models, references,
                                                                     name, fmi):
    """FMPy's CVODE (rtol 1e-11) stops at each step of the input (an input event) and sets the
    new value in event mode: measured 1.5e-9 (msd) and 2.6e-8 (cart-pole) from ours; required
    1e-6."""
    model, t_end = models[name], CASES[name][0]
    t, u = _force(name)
    result = fmpy.simulate_fmu(str(fmus[name, fmi]), fmi_type="ModelExchange", stop_time=t_end,
                               output_interval=0.01, relative_tolerance=1e-11,
                               input=_table("F", t, u, t_end), record_events=False,
                               output=model.state_names)
    error, count = _error_at_common_times(result, references[name], model.state_names)
    assert count >= len(t) and error < 1e-6


def test_fmi2_input_derivatives_extrapolate_linearly(fmus, models, tmp_path):
    """fmi2SetRealInputDerivatives (order 1) at each communication point: the FMU's force is
    u + du (t - t_c) over the step, our run's linear interpolation of the same samples (the same
    two slots, u = a + b t): equal at the communication points (measured 0.0), where holding the
    samples would be 0.1 away."""
    from fmpy import extract, instantiate_fmu, read_model_description
    model, path = models["msd"], str(fmus["msd", 2])
    t, u = _force("msd")
    t_end = CASES["msd"][0]
    t, u = np.append(t, t_end), np.append(u, 0.5)
    ours = model.simulate(t_end, inputs={"F": Samples(t, u, "linear")}, method="Rodas5P",
                          rtol=1e-10, atol=1e-12)
    md = read_model_description(path)
    fmu = instantiate_fmu(extract(path, unzipdir=str(tmp_path / "x")), md,
                          fmi_type="CoSimulation")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu.setupExperiment(tolerance=1e-10, startTime=0.0, stopTime=t_end)
    fmu.setReal([vr["solver.atol"]], [1e-12])
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    states = [vr[s] for s in model.state_names]
    error = 0.0
    for k in range(len(t) - 1):
        fmu.setReal([vr["F"]], [u[k]])
        fmu.setRealInputDerivatives([vr["F"]], [1], [(u[k + 1] - u[k]) / (t[k + 1] - t[k])])
        fmu.doStep(t[k], t[k + 1] - t[k])
        at = np.nonzero(ours.t == t[k + 1])[0][0]
        error = max(error, float(np.max(np.abs(np.array(fmu.getReal(states)) - ours.x[at]))))
    assert error < 1e-12
    held = model.simulate(t_end, inputs={"F": Samples(t, u, "zoh")}, method="Rodas5P",
                          rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(np.array(fmu.getReal(states)) - held.x_final)) > 1e-2
    fmu.terminate()
    fmu.freeInstance()


@pytest.mark.parametrize("fmi", VERSIONS)
def test_directional_derivatives_by_the_input_are_the_compiled_jacobian(fmus, models, fmi,
                                                                        tmp_path):
    """d(der(x))/dF through fmi*GetDirectionalDerivative = the generated jac_u (exactly)."""
    from fmpy import extract, instantiate_fmu, read_model_description
    model, path = models["cart_pole"], str(fmus["cart_pole", fmi])
    md = read_model_description(path)
    fmu = instantiate_fmu(extract(path, unzipdir=str(tmp_path / "x")), md,
                          fmi_type="ModelExchange")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    states = [*model.state_names, "ledger.E_diss", "ledger.E_in"]
    if fmi == 2:
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.setReal([vr["F"]], [1.5])
        fmu.exitInitializationMode()
        fmu.newDiscreteStates()
    else:
        fmu.enterInitializationMode(startTime=0.0)
        fmu.setFloat64([vr["F"]], [1.5])
        fmu.exitInitializationMode()
        fmu.updateDiscreteStates()
    fmu.enterContinuousTimeMode()
    x = model.augment(model.initial_state()) + np.linspace(0.01, 0.06, len(states))
    fmu.setContinuousStates((ctypes.c_double * len(x))(*x), len(x))
    column = fmu.getDirectionalDerivative([vr[f"der({s})"] for s in states], [vr["F"]], [1.0])
    p = model.params()
    p[len(model.param_names)] = 1.5
    expected = np.asarray(model.functions.extra["jac_u"](0.0, x, p))[:, 0]
    assert np.array_equal(np.array(column), expected)
    fmu.terminate()
    fmu.freeInstance()


# --- a discrete-time controller inside the FMU ----------------------------------------------------
@pytest.fixture(scope="module")
def servo(isolated_cache, tmp_path_factory):
    """The mass–spring–damper driven by a DiscretePID (T = 0.1 s) on the error r - q, the
    reference r an input: the compiled model, its FMUs (FMI 2.0, 3.0) and our run with r
    stepping at 1.05 s (between samples) and 2.0 s (on one)."""
    m = _msd("servo", drive="ctrl.y")
    m.input("r", "m", "reference position")
    m.add("ctrl", DiscretePID(input="r - spring.q", period=0.1, kp=8.0, ki=4.0, kd=0.5))
    model = compile_model(m, backend="c")
    folder = tmp_path_factory.mktemp("fmus_servo")
    fmus = {fmi: model.export_fmu(folder / f"servo_{fmi}.fmu", fmi=fmi, rtol=1e-10, atol=1e-12,
                                  stop_time=3.0) for fmi in VERSIONS}
    r = Samples([0.0, 1.05, 2.0], [0.0, 1.0, 0.5], "zoh")
    ours = model.simulate(3.0, inputs={"r": r}, method="Rodas5P", rtol=1e-12, atol=1e-14)
    return model, fmus, ours


@pytest.mark.parametrize("fmi", VERSIONS)
def test_discrete_controller_samples_inside_the_fmu(servo, fmi):
    """Model exchange: the sampling instants t_k = k T are time events (nextEventTime), sampled
    in the event update after FMPy set the inputs of t_k; co-simulation: the FMU's integration
    stops on each t_k and samples when it goes on (with the inputs set for that step), so at a
    communication point on t_k it gives the values before the sample. Against our run: CS at
    rtol 1e-10 measured 1e-12, ME (CVODE rtol 1e-11) 6e-9; required 1e-8 and 1e-6."""
    model, fmus, ours = servo
    table = np.array([(0.0, 0.0), (1.05, 0.0), (1.05, 1.0), (2.0, 1.0), (2.0, 0.5), (3.0, 0.5)],
                     dtype=[("time", float), ("r", float)])
    names = [*model.state_names, "position"]
    md = fmpy.read_model_description(str(fmus[fmi]))
    assert validate_fmu(str(fmus[fmi])) == [] and float(md.defaultExperiment.stepSize) == 0.1
    for kind, tolerance, first in (("CoSimulation", 1e-8, True), ("ModelExchange", 1e-6, False)):
        options = {"record_events": False} if kind == "ModelExchange" else {}
        result = fmpy.simulate_fmu(str(fmus[fmi]), fmi_type=kind, stop_time=3.0,
                                   output_interval=0.05, input=table, output=names,
                                   relative_tolerance=1e-10 if first else 1e-11, **options)
        error, count = _error_at_common_times(result, ours, names, first=first)
        assert count == 32 and error < tolerance, kind       # t = k T, 1.05 s
    jumps = ours.t[1:][np.diff(ours["ctrl.y"]) != 0]
    assert np.array_equal(jumps, np.round(jumps / 0.1) * 0.1)    # our samples: exactly k T


def test_bad_input_start_values_are_refused(models, tmp_path):
    with pytest.raises(OptionError, match="no input.*G.*inputs: F"):
        models["msd"].export_fmu(tmp_path / "m.fmu", inputs={"G": 1.0})
    with pytest.raises(OptionError, match="input 'F' must be a finite number"):
        models["msd"].export_fmu(tmp_path / "m.fmu", inputs={"F": float("nan")})
    assert not (tmp_path / "m.fmu").exists()


def test_command_line_export_of_a_model_file_with_inputs(tmp_path, capsys):
    """cart_pole.toml's [inputs] F and [outputs] x, theta; its [simulation] inputs (F = 0) are
    the input's start value."""
    from porthamiltonian.interfaces.cli import main
    out = tmp_path / "cart_pole.fmu"
    assert main(["export-fmu", "cart_pole", "--out", str(out), "--fmi", "3", "--kind", "cs"]) == 0
    assert "1 input(s)" in capsys.readouterr().out
    assert validate_fmu(str(out)) == []
    var = {v.name: v for v in fmpy.read_model_description(str(out)).modelVariables}
    assert var["F"].causality == "input" and float(var["F"].start) == 0.0
    assert var["x"].causality == var["theta"].causality == "output"
