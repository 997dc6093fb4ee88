"""Notebook interfaces: units of compiled models, Trajectory.to_dataframe, quick-look plots,
the HTML summaries (_repr_html_) of Trajectory, CompiledModel, Sweep and GaitResult, and the
notebook-style example docs/notebook.py, run as a script.

Units are checked against their definitions: a C storage's state is the time integral of its
port's flow (m for translation), an I storage's the integral of its effort (N·s); a multibody
joint's coordinate is rad (revolute) or m, its momentum N·m·s or N·s; energies are J."""
from __future__ import annotations

import html
import re
import runpy
from pathlib import Path

import numpy as np
import pytest

from porthamiltonian import C, I, Model, OneJunction, R, Se, compile_model, io
from porthamiltonian.batch import Sweep, grid
from porthamiltonian.interfaces.sweeps import simulate_case
from porthamiltonian.simulation.display import MAX_ROWS, records_html

DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.fixture(scope="module")
def msd():
    m = Model("msd")
    m.parameter("k", 4.0, "N/m")
    m.parameter("c", 0.4, "N*s/m")
    m.add("force", Se(effort="sin(t)"))
    m.add("j", OneJunction())
    m.add("mass", I(inertance=1.0))
    m.add("spring", C(stiffness="k", q0=0.1))
    m.add("damper", R(resistance="c"))
    m.connect("force.p", "j")
    for element in ("mass", "spring", "damper"):
        m.connect("j", f"{element}.p")
    return compile_model(m, backend="python")


@pytest.fixture(scope="module")
def simplest():
    from walker_library import analyze_gait, load_walker
    walker = load_walker("simplest_walker")
    return walker, analyze_gait(walker)


def test_units_of_states_ports_and_outputs(msd):
    assert msd.units["spring.q"] == "m" and msd.units["mass.p"] == "N*s"
    assert msd.units["spring.p.e"] == "N" and msd.units["spring.p.f"] == "m/s"
    pendulum = compile_model(io.load("pendulum"), backend="python")
    u = pendulum.units
    assert u["pendulum.q.pivot"] == "rad" and u["pendulum.p.pivot"] == "N*m*s"
    assert u["pendulum.pivot.e"] == "N*m" and u["pendulum.pivot.f"] == "rad/s"
    assert u["pendulum.tip.x"] == "m" and u["pendulum.T"] == u["pendulum.V"] == "J"


def test_to_dataframe_has_time_index_columns_and_units(msd):
    traj = msd.simulate(3.0, params={"k": 9.0}, max_step=0.1)
    df = traj.to_dataframe()
    assert df.index.name == "t" and np.array_equal(df.index.to_numpy(), traj.t)
    for name in ("spring.q", "mass.p"):
        assert np.array_equal(df[name].to_numpy(), traj[name])
    assert np.array_equal(df["residual"].to_numpy(), traj.residual)
    assert set(msd.output_names) <= set(df.columns)
    units = df.attrs["units"]
    assert units["t"] == "s" and units["spring.q"] == "m" and units["mass.p"] == "N*s"
    assert units["H"] == units["E_diss"] == units["residual"] == "J"
    assert df.attrs["model"] == "msd" and df.attrs["status"] == traj.status
    only = traj.to_dataframe(outputs=["spring.p.e"])
    assert list(only.columns) == [*msd.state_names, "H", "E_diss", "E_in", "residual", "spring.p.e"]
    assert list(traj.to_dataframe(outputs=False).columns)[-1] == "residual"


def test_resets_keep_their_repeated_times(simplest):
    walker, gait = simplest
    z = np.array([gait.fixed_point[k] for k in walker.section])
    traj = walker.walk(z, 2, record=True)[-1].info["trajectory"]
    df = traj.to_dataframe(outputs=False)
    assert df.index.is_monotonic_increasing and not df.index.is_unique
    assert len(df.attrs["events"]) == len(traj.events) > 0
    assert df.attrs["units"]["walker.q.stance"] == "rad"


def test_plot_breaks_at_resets_and_labels_units(msd, simplest):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    walker, gait = simplest
    z = np.array([gait.fixed_point[k] for k in walker.section])
    traj = walker.walk(z, 2, record=True)[-1].info["trajectory"]
    ax = traj.plot("walker.q.stance")
    labels = [ln.get_label() for ln in ax.get_lines() if not ln.get_label().startswith("_")]
    assert labels[0] == "walker.q.stance (rad)" and "events" in labels
    pieces = [ln for ln in ax.get_lines() if ln.get_color() == "C0"]
    assert len(pieces) >= 3                     # one line per continuous piece: 2 heel strikes
    assert ax.get_xlabel() == "t (s)" and ax.get_ylabel() == "(rad)"
    ax = msd.simulate(1.0).plot("H", "E_diss")
    assert ax.get_ylabel() == "(J)"
    plt.close("all")


def test_html_summaries_are_compact(msd, tmp_path):
    traj = msd.simulate(2.0)
    page = traj._repr_html_()
    assert "Trajectory of msd" in page and "<td style=\"text-align:left;padding:2px 8px\">N*s</td>" in page
    assert "None" not in html.unescape(re.sub(r"<[^>]+>", " ", page))
    model_page = msd._repr_html_()
    assert "CompiledModel msd" in model_page and "N/m" in model_page
    rows = [{"case_id": i, "k": float(i), "status": "ok"} for i in range(40)]
    table = records_html(rows)
    assert table.count("<tr>") == 1 + MAX_ROWS + 1 and f"… and {40 - MAX_ROWS} more" in table
    sweep = Sweep(simulate_case, grid(k=[1.0, 4.0]), tmp_path / "s.jsonl",
                  fixed={"model": "mass_spring_damper", "t_end": 1.0, "backend": "python"})
    assert "0 of 2 cases" in sweep._repr_html_()
    sweep.run(serial=True, progress="none")
    assert "2 of 2 cases" in sweep._repr_html_() and "finished 2" in sweep._repr_html_()


def test_gait_result_summary_and_quick_plot(simplest):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    walker, gait = simplest
    page = gait._repr_html_()
    assert "stable period-1 gait" in page and "nondimensional model" in page
    assert 'title="theta_dot">θ̇ stance-leg rate</span>' in page and "&lt; " in page
    axes = gait.plot(walker, steps=1)
    assert axes[0].get_xlabel() == r"$\theta$ (rad)" and axes[1].get_xlabel() == "Re λ"
    assert any(ln.get_linestyle() == "--" for ln in axes[0].get_lines())   # the reset, dashed
    plt.close("all")


def test_the_notebook_example_runs(tmp_path, monkeypatch, capsys):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    monkeypatch.chdir(tmp_path)
    names = runpy.run_path(str(DOCS / "notebook.py"), run_name="__main__")
    plt.close("all")
    out = capsys.readouterr().out
    assert "units: {'spring.q': 'm', 'mass.p': 'N*s', 'spring.p.e': 'N', 'H': 'J'}" in out
    results = names["results"]
    # 2 % settling of a lightly damped oscillator: (2 m / c) ln 50 within a period
    for c, settle in zip(results["c"], results["settling_time"]):
        assert settle == pytest.approx(2 / c * np.log(50), abs=2 * np.pi / np.sqrt(4.0))
