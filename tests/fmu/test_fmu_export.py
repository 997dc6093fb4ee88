"""FMU export (porthamiltonian.fmu): the FMUs of shipped models imported back with FMPy.

Checked against independent things: FMPy's validation of the modelDescription (schema, variable
names, model structure, units); FMPy's own solver (CVODE) integrating the model-exchange FMU,
compared with our runs by scipy's DOP853 or Radau at rtol 1e-12 (other integrators at a tight
tolerance); the
co-simulation FMU at its communication points against the same references; the bouncing ball's
event times; the directional derivatives against the compiled Jacobian. One FMU per model and FMI
version (model exchange and co-simulation in one), built once per module; and the heavy top with
its tree evaluated by the multibody kernel (whose C the FMU's sources must hold).
"""
from __future__ import annotations

import ctypes
import stat
import zipfile

import fmpy  # the test extra installs it
import numpy as np
import pytest
from fmpy.validation import validate_fmu

from porthamiltonian import Event, compile_model, io
from porthamiltonian.errors import CompilerError, ExportError, OptionError
from porthamiltonian.fmu import EventProgram, EventRule, RuleChange, RuleCondition
from porthamiltonian.fmu.units import base_unit
from porthamiltonian.interfaces.cli import main

MODELS = {"mass_spring_damper": 20.0, "bouncing_ball": 1.5, "heavy_top": 2.0}
VERSIONS = (2, 3)


@pytest.fixture(scope="module")
def compiled(isolated_cache):
    return {name: compile_model(io.load(name), backend="c") for name in MODELS}


@pytest.fixture(scope="module")
def fmus(compiled, tmp_path_factory):
    """(model, FMI version) -> path of its FMU (model exchange and co-simulation)."""
    folder = tmp_path_factory.mktemp("fmus")
    out = {}
    for name, t_end in MODELS.items():
        for fmi in VERSIONS:
            out[name, fmi] = compiled[name].export_fmu(
                folder / f"{name}_{fmi}.fmu", fmi=fmi, rtol=1e-10, atol=1e-12, stop_time=t_end)
    return out


@pytest.fixture(scope="module")
def references(compiled):
    """Our runs with scipy's integrators at rtol 1e-12, atol 1e-14, on FMPy's output grid (every
    0.01 s): DOP853 (explicit, order 8; Radau at this tolerance takes 10x longer), Radau for the
    stiff contact of the ball (at 1e-13 it moves by 2.5e-11)."""
    out = {}
    for name, t_end in MODELS.items():
        grid = np.round(np.arange(round(t_end / 0.01) + 1) * 0.01, 12)
        method = "Radau" if name == "bouncing_ball" else "DOP853"
        out[name] = compiled[name].simulate(t_end, method=method, rtol=1e-12, atol=1e-14,
                                            t_eval=grid)
    return out


def _max_error(result, reference, names) -> float:
    assert np.allclose(result["time"], reference.t, rtol=0, atol=1e-12)
    return max(float(np.max(np.abs(result[n] - reference[n]))) for n in names)


@pytest.mark.parametrize("fmi", VERSIONS)
@pytest.mark.parametrize("name", MODELS)
def test_fmpy_validation_reports_no_problem(fmus, name, fmi):
    assert validate_fmu(str(fmus[name, fmi])) == []


@pytest.mark.parametrize("fmi", VERSIONS)
def test_fmu_holds_sources_documentation_and_the_binary(fmus, fmi):
    with zipfile.ZipFile(fmus["bouncing_ball", fmi]) as zf:
        names = set(zf.namelist())
        description = zf.read("modelDescription.xml").decode()
        page = zf.read("documentation/index.html").decode()
    folder = "linux64" if fmi == 2 else "x86_64-linux"
    assert f"binaries/{folder}/bouncing_ball.so" in names
    assert {"sources/fmu.c", "sources/model.c", "sources/runtime.c", f"sources/fmi{fmi}.c",
            "sources/ph_fmu.h"} <= names
    assert ("sources/buildDescription.xml" in names) == (fmi == 3)
    # units with their SI base units, parameters with their file's descriptions
    assert '<Unit name="N*s/m^2">' in description and 'kg="1" s="-1"' in description
    assert "ball mass" in description and 'name="ledger.residual"' in description
    assert "touchdown" in page and "Rebuilding" in page


def test_the_binary_links_the_loops_compiled_once_and_exports_fmi_alone(compiled, tmp_path,
                                                                        monkeypatch):
    """An FMU's binary is its model's unit linked with the integration loops' object, compiled
    with hidden entry points once per compiler and cached (as the C back end's loops are),
    not compiled again into every FMU: two FMUs of two models, one compile of the loops and
    one of each FMU's unit; each
    binary exports the FMI functions and nothing of the loops or the model (two FMUs in one
    process never call each other's), where the C back end's library exports its loops. (The
    run of the binary against the run of sources/ built alone as one unit: the rebuild tests
    above.)"""
    from porthamiltonian.backends import native
    from porthamiltonian.compiler import cache

    ball = compiled["bouncing_ball"]
    c_library = cache.verified_path(ball.key, native.library_name(ball.key,
                                                                   native.compiler_identity()))
    assert c_library is not None and hasattr(ctypes.CDLL(str(c_library)), "ph_integrate_rodas5p")
    calls = tmp_path / "calls"
    wrapper = tmp_path / "cc-logged"
    wrapper.write_text(f'#!/bin/sh\necho "$@" >> {calls}\nexec cc "$@"\n')
    wrapper.chmod(wrapper.stat().st_mode | stat.S_IEXEC)
    monkeypatch.setenv("CC", str(wrapper))
    monkeypatch.setenv("PORTHAMILTONIAN_CACHE", str(tmp_path / "cache"))
    paths = [compiled[name].export_fmu(tmp_path / f"{name}.fmu", fmi=fmi)
             for name, fmi in (("mass_spring_damper", 2), ("bouncing_ball", 3))]
    sources = [line.split()[-1] for line in calls.read_text().splitlines()
               if " -c " in f" {line} "]
    assert sorted(s.rsplit("/", 1)[-1] for s in sources) == ["fmu.c", "fmu.c", "loops.c"], sources
    for path, folder in zip(paths, ("linux64", "x86_64-linux")):
        with zipfile.ZipFile(path) as zf:
            zf.extract(f"binaries/{folder}/{path.stem}.so", tmp_path / path.stem)
        lib = ctypes.CDLL(str(tmp_path / path.stem / "binaries" / folder / f"{path.stem}.so"))
        prefix = "fmi2" if folder == "linux64" else "fmi3"
        assert hasattr(lib, f"{prefix}DoStep") and hasattr(lib, f"{prefix}FreeInstance")
        for name in ("ph_integrate_rodas5p", "ph_integrate_rodas4", "ph_many", "rhs", "jac",
                     "ph_n", "ph_rhs", "ph_selftest"):
            assert not hasattr(lib, name), name


def test_fmi3_build_description_follows_its_schema(fmus):
    from lxml import etree  # FMPy's own dependency
    schema_file = (fmpy.__file__.rsplit("/", 1)[0] + "/schema/fmi3/fmi3BuildDescription.xsd")
    schema = etree.XMLSchema(etree.parse(schema_file))
    with zipfile.ZipFile(fmus["bouncing_ball", 3]) as zf:
        doc = etree.fromstring(zf.read("sources/buildDescription.xml"))
    assert schema.validate(doc), schema.error_log


def test_the_sources_rebuild_with_another_build_system(fmus, tmp_path):
    """FMPy's CMake build of sources/ (FMI 3.0: from buildDescription.xml), in place of our
    binary, gives the same co-simulation."""
    from fmpy.build import build_platform_binary
    folder = tmp_path / "rebuilt"
    with zipfile.ZipFile(fmus["bouncing_ball", 3]) as zf:
        zf.extractall(folder, [n for n in zf.namelist() if not n.startswith("binaries/")])
    (tmp_path / "build").mkdir()
    build_platform_binary(folder, build_dir=tmp_path / "build")
    runs = [fmpy.simulate_fmu(str(path), fmi_type="CoSimulation", stop_time=1.5,
                              output_interval=0.01, output=["ball.q.drop.z"])
            for path in (folder, fmus["bouncing_ball", 3])]
    assert np.max(np.abs(runs[0]["ball.q.drop.z"] - runs[1]["ball.q.drop.z"])) < 1e-12


def test_a_kernel_multibody_exports_whole_and_rebuilds_from_its_sources(references, tmp_path,
                                                                         isolated_cache):
    """The heavy top with ``formulation = "kernel"``: the C back end links the kernel as an
    object of its own, the FMU's one translation unit holds its source. The FMU validates, its
    co-simulation matches the symbolic model's reference run (DOP853, rtol 1e-12) to 1e-8, its
    Jacobian is the compiled one, and FMPy's CMake build of sources/ gives the same run."""
    from fmpy.build import build_platform_binary
    data = io.model_to_dict(io.load("heavy_top"))
    data["components"]["top"]["formulation"] = "kernel"
    model = compile_model(io.model_from_dict(data), backend="c")
    assert model.meta.kernels == ("multibody",)
    path = model.export_fmu(tmp_path / "top.fmu", fmi=3, rtol=1e-10, atol=1e-12,
                            stop_time=MODELS["heavy_top"])
    assert validate_fmu(str(path)) == []
    folder = tmp_path / "rebuilt"
    with zipfile.ZipFile(path) as zf:
        assert "void ph_mb_state(" in zf.read("sources/model.c").decode()
        zf.extractall(folder, [n for n in zf.namelist() if not n.startswith("binaries/")])
    (tmp_path / "build").mkdir()
    build_platform_binary(folder, build_dir=tmp_path / "build")
    runs = [fmpy.simulate_fmu(str(where), fmi_type="CoSimulation", stop_time=MODELS["heavy_top"],
                              output_interval=0.01, relative_tolerance=1e-10,
                              start_values={"solver.atol": 1e-12}, output=model.state_names)
            for where in (path, folder)]
    assert _max_error(runs[0], references["heavy_top"], model.state_names) < 1e-8
    assert max(np.max(np.abs(runs[0][n] - runs[1][n])) for n in model.state_names) < 1e-12
    fmu, md = _instance(path, tmp_path, "ModelExchange")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    states = [*model.state_names, "ledger.E_diss", "ledger.E_in"]
    x = model.augment(model.initial_state())
    J = model.functions.jac(0.0, x, model.params())
    column = fmu.getDirectionalDerivative([vr[f"der({s})"] for s in states],
                                          [vr[s] for s in states], list(np.eye(len(states))[0]))
    assert np.array_equal(np.array(column), J[:, 0])
    fmu.terminate()
    fmu.freeInstance()


@pytest.mark.parametrize("fmi", VERSIONS)
@pytest.mark.parametrize("name, tolerance", [("mass_spring_damper", 1e-6), ("heavy_top", 1e-6)])
def test_model_exchange_with_fmpys_solver_matches_our_simulation(fmus, compiled, references, name,
                                                                  tolerance, fmi):
    """CVODE (FMPy) at rtol 1e-10 on the ME FMU vs our run at 1e-12: measured 1.2e-8 (spring)
    and 1.1e-7 (top, 60 rad/s spin over 2 s)."""
    result = fmpy.simulate_fmu(str(fmus[name, fmi]), fmi_type="ModelExchange",
                               stop_time=MODELS[name], output_interval=0.01,
                               relative_tolerance=1e-10, output=compiled[name].state_names)
    assert _max_error(result, references[name], compiled[name].state_names) < tolerance


@pytest.mark.parametrize("fmi", VERSIONS)
def test_bouncing_ball_event_times_in_model_exchange(fmus, compiled, fmi):
    """The events FMPy locates on the FMU's event indicators (recorded twice, before and after
    the event update) vs ours at rtol 1e-12: measured 7e-11 s (CVODE at rtol 1e-11)."""
    model = compiled["bouncing_ball"]
    ours = model.simulate(1.5, method="Rodas5P", rtol=1e-12, atol=1e-14)
    result = fmpy.simulate_fmu(str(fmus["bouncing_ball", fmi]), fmi_type="ModelExchange",
                               stop_time=1.5, output_interval=0.01, relative_tolerance=1e-11,
                               record_events=True,
                               output=["events.touchdown.count", "events.liftoff.count"])
    t = result["time"]
    event_times = t[np.nonzero(np.diff(t) == 0)[0]]
    expected = [time for time, _ in ours.events]
    assert [name for _, name in ours.events] == ["touchdown", "liftoff"] * 3
    assert len(event_times) == len(expected) == 6
    assert np.max(np.abs(event_times - expected)) < 1e-8
    assert result["events.touchdown.count"][-1] == 3 and result["events.liftoff.count"][-1] == 3


@pytest.mark.parametrize("fmi", VERSIONS)
@pytest.mark.parametrize("name, rtol", [("mass_spring_damper", 1e-10), ("heavy_top", 1e-10),
                                        ("bouncing_ball", 1e-12)])
def test_co_simulation_matches_at_the_communication_points(fmus, compiled, references, name,
                                                           rtol, fmi):
    """The FMU's own Rodas5P (its rtol from FMPy's setupExperiment) vs our runs at 1e-12:
    measured 3.6e-13 (spring), 6.5e-10 (top), 1.6e-9 (ball, whose contacts amplify any error of
    the impact times: at rtol 1e-10 it is 2e-7)."""
    result = fmpy.simulate_fmu(str(fmus[name, fmi]), fmi_type="CoSimulation",
                               stop_time=MODELS[name], output_interval=0.01,
                               relative_tolerance=rtol, start_values={"solver.atol": rtol * 1e-2},
                               output=[*compiled[name].state_names, "ledger.residual"])
    assert _max_error(result, references[name], compiled[name].state_names) < 1e-8
    assert abs(result["ledger.residual"][-1]) < 1e-8


@pytest.mark.parametrize("fmi", VERSIONS)
def test_co_simulation_events_are_those_of_our_run(fmus, compiled, fmi):
    """Same method and settings: the FMU's steps do not depend on the communication points, so
    its event times (events.<name>.time at the communication points) are ours, to round-off
    (measured: equal)."""
    model = compiled["bouncing_ball"]
    ours = model.simulate(1.5, method="Rodas5P", rtol=1e-10, atol=1e-12)
    result = fmpy.simulate_fmu(str(fmus["bouncing_ball", fmi]), fmi_type="CoSimulation",
                               stop_time=1.5, output_interval=0.01,
                               output=["events.touchdown.time", "events.liftoff.time",
                                       "ledger.E_diss"])
    fmu_times = sorted({*result["events.touchdown.time"], *result["events.liftoff.time"]} - {0.0})
    assert np.max(np.abs(np.array(fmu_times) - [t for t, _ in ours.events])) < 1e-12
    assert result["ledger.E_diss"][-1] == pytest.approx(ours.E_diss[-1], rel=1e-9)


@pytest.mark.parametrize("fmi", VERSIONS)
def test_directional_derivatives_are_the_compiled_jacobian(fmus, compiled, fmi, tmp_path):
    """d(der(x))/dx . e_j through fmi*GetDirectionalDerivative = column j of the compiled
    Jacobian (exactly); d(ledger.H)/dx by the FMU's differences = the compiled energy's."""
    model = compiled["heavy_top"]
    fmu, md = _instance(fmus["heavy_top", fmi], tmp_path, "ModelExchange")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    states = [*model.state_names, "ledger.E_diss", "ledger.E_in"]
    x = model.augment(model.initial_state()) + np.linspace(0.01, 0.07, len(states))
    fmu.setContinuousStates((ctypes.c_double * len(x))(*x), len(x))
    known = [vr[s] for s in states]
    unknown = [vr[f"der({s})"] for s in states]
    J = model.functions.jac(0.0, x, model.params())
    for j in range(len(states)):
        column = fmu.getDirectionalDerivative(unknown, known, list(np.eye(len(states))[j]))
        assert np.array_equal(np.array(column), J[:, j])
    seed = np.linspace(1.0, 2.0, len(states))
    dH = fmu.getDirectionalDerivative([vr["ledger.H"]], known, list(seed))[0]
    expected = _energy_gradient(model, x) @ seed
    assert dH == pytest.approx(expected, rel=1e-7)
    fmu.terminate()
    fmu.freeInstance()


def _energy_gradient(model, x, h=1e-6):
    p = model.params()
    return np.array([(model.energy(0.0, x + h * e, p)[0] - model.energy(0.0, x - h * e, p)[0])
                     / (2 * h) for e in np.eye(len(x))])


def _instance(path, tmp_path, kind, start=None):
    """An FMPy instance of the FMU at ``path`` (FMI 2 or 3), initialized (ME: in continuous-time
    mode; CS: in step mode), with start values ``start`` set before initialization."""
    from fmpy import extract, instantiate_fmu, read_model_description
    md = read_model_description(str(path))
    folder = extract(str(path), unzipdir=str(tmp_path / f"x{kind}{md.fmiVersion}"))
    fmu = instantiate_fmu(folder, md, fmi_type=kind)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    for name, value in (start or {}).items():
        fmu.setReal([vr[name]], [value]) if md.fmiVersion == "2.0" else fmu.setFloat64(
            [vr[name]], [value])
    if md.fmiVersion == "2.0":
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        if kind == "ModelExchange":
            fmu.newDiscreteStates()
            fmu.enterContinuousTimeMode()
    else:
        fmu.enterInitializationMode(startTime=0.0)
        fmu.exitInitializationMode()
        if kind == "ModelExchange":
            fmu.updateDiscreteStates()
            fmu.enterContinuousTimeMode()
    return fmu, md


def test_fmu_state_round_trip_and_tunable_parameters_in_co_simulation(fmus, compiled, tmp_path):
    """An FMU state saved, serialized and restored replays the same steps; a tunable parameter
    set between steps (the force F at t = 5 s) acts from there, as our run restarted there
    does; a parameter that only sets the initial state (x0) is fixed after initialization."""
    model = compiled["mass_spring_damper"]
    fmu, md = _instance(fmus["mass_spring_damper", 2], tmp_path, "CoSimulation",
                        start={"x0": 0.2})
    vr = {v.name: v.valueReference for v in md.modelVariables}
    q = [vr["spring.q"], vr["mass.p"]]
    t = 0.0
    for _ in range(10):
        fmu.doStep(t, 0.5)
        t += 0.5
    at5 = fmu.getReal(q)
    blob = fmu.serializeFMUstate(fmu.getFMUstate())
    fmu.doStep(t, 1.0)
    first = fmu.getReal(q)
    fmu.setFMUstate(fmu.deSerializeFMUstate(blob))
    assert fmu.getReal(q) == at5
    fmu.doStep(t, 1.0)
    assert fmu.getReal(q) == first
    fmu.setFMUstate(fmu.deSerializeFMUstate(blob))
    fmu.setReal([vr["F"]], [2.0])
    fmu.doStep(t, 1.0)
    pushed = fmu.getReal(q)
    from fmpy.fmi1 import FMICallException
    with pytest.raises(FMICallException):
        fmu.setReal([vr["x0"]], [0.3])
    fmu.terminate()
    fmu.freeInstance()
    start = model.simulate(5.0, method="DOP853", rtol=1e-12, atol=1e-14, x0={"spring.q": 0.2})
    assert at5 == pytest.approx([start["spring.q"][-1], start["mass.p"][-1]], abs=1e-8)
    after = model.simulate(6.0, t_start=5.0, x0=start.x_final, params={"F": 2.0},
                           method="DOP853", rtol=1e-12, atol=1e-14)
    assert pushed == pytest.approx([after["spring.q"][-1], after["mass.p"][-1]], abs=1e-8)


def test_initial_state_follows_its_parameters_unless_set(fmus, tmp_path):
    """The ball's height comes from h0 (as in the model), unless the state itself is set."""
    from_h0, md = _instance(fmus["bouncing_ball", 3], tmp_path, "CoSimulation",
                            start={"h0": 2.0})
    vr = {v.name: v.valueReference for v in md.modelVariables}
    assert from_h0.getFloat64([vr["ball.q.drop.z"]]) == [pytest.approx(2.05)]
    set_directly, _ = _instance(fmus["bouncing_ball", 3], tmp_path / "b", "CoSimulation",
                                start={"h0": 2.0, "ball.q.drop.z": 1.0})
    assert set_directly.getFloat64([vr["ball.q.drop.z"]]) == [1.0]


# --- refusals and errors ------------------------------------------------------------------------
def test_python_level_events_and_actions_are_refused_with_the_reason(compiled, tmp_path):
    model = compiled["bouncing_ball"]
    with pytest.raises(ExportError, match="Python-level event.*'apex'.*Python callables"):
        model.export_fmu(tmp_path / "b.fmu", events=[Event("apex", lambda t, x, p: x[3])])
    with pytest.raises(ExportError, match="action.*'touchdown'.*Python callables.*EventProgram"):
        model.export_fmu(tmp_path / "b.fmu", actions={"touchdown": lambda t, x, p: None})
    assert not (tmp_path / "b.fmu").exists()


def test_an_event_program_that_does_not_fit_the_model_is_refused(compiled, tmp_path):
    model = compiled["bouncing_ball"]
    program = EventProgram((EventRule(7, (RuleCondition(999, "<"),), (RuleChange(0, 1.0, 2),),
                                      counter="steps"),))
    with pytest.raises(ExportError) as err:
        model.export_fmu(tmp_path / "b.fmu", program=program)
    text = str(err.value)
    assert "event index 7" in text and "output 999" in text and "not both" in text
    assert "counter 'steps' is not declared" in text


def test_bad_options_are_refused_before_any_build(compiled, tmp_path):
    model = compiled["mass_spring_damper"]
    with pytest.raises(OptionError, match="fmi must be 2 or 3"):
        model.export_fmu(tmp_path / "m.fmu", fmi=4)
    with pytest.raises(OptionError, match="kind must be"):
        model.export_fmu(tmp_path / "m.fmu", kind="se")
    with pytest.raises(OptionError, match="no output.*nope"):
        model.export_fmu(tmp_path / "m.fmu", outputs=["nope"])
    with pytest.raises(ExportError, match="does not exist"):
        model.export_fmu(tmp_path / "missing" / "m.fmu")


def test_a_compiler_failure_gives_the_compilers_log(compiled, tmp_path, monkeypatch):
    script = tmp_path / "broken-cc"
    script.write_text("#!/bin/sh\necho 'fmu.c:1: error: the compiler says no' >&2\nexit 1\n")
    script.chmod(script.stat().st_mode | stat.S_IEXEC)
    monkeypatch.setenv("CC", str(script))
    with pytest.raises(CompilerError) as err:
        compiled["mass_spring_damper"].export_fmu(tmp_path / "m.fmu")
    message = str(err.value)
    log = message.split("its output is in ")[1].split(". ")[0]
    with open(log) as fh:
        assert "the compiler says no" in fh.read()
    assert "Set CC to a working C compiler" in message and not (tmp_path / "m.fmu").exists()
    assert "whatever back end" in message and "numba" not in message


def test_command_line_export(tmp_path, capsys):
    out = tmp_path / "msd.fmu"
    assert main(["export-fmu", "mass_spring_damper", "--out", str(out), "--fmi", "3",
                 "--kind", "cs"]) == 0
    assert "wrote" in capsys.readouterr().out
    md = fmpy.read_model_description(str(out))
    assert md.fmiVersion == "3.0" and md.coSimulation and not md.modelExchange
    assert validate_fmu(str(out)) == []
    assert main(["export-fmu", "mass_spring_damper", "--out", str(tmp_path / "no" / "x.fmu")]) == 2
    assert "error: cannot write" in capsys.readouterr().err


def test_units_as_si_base_units():
    assert base_unit("N*s/m^2") == (1.0, {"kg": 1, "m": -1, "s": -1})
    assert base_unit("kg*m^2") == (1.0, {"kg": 1, "m": 2})
    assert base_unit("1") == (1.0, {})
    factor, exps = base_unit("deg/s")
    assert factor == pytest.approx(np.pi / 180) and exps == {"rad": 1, "s": -1}
    assert base_unit("furlong") is None and base_unit("kg/(m*s)") is None
