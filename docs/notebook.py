# %% [markdown]
# # porthamiltonian in a notebook
#
# A mass–spring–damper built in Python, simulated, looked at, turned into a data frame, then
# swept over its stiffness. Open this file in Jupyter (with jupytext), VS Code or Spyder: each
# `# %%` starts a cell. As a script, `python docs/notebook.py` runs it top to bottom (the test
# suite does, in a few seconds). Needs the `plots` and `frames` extras (`pip install -e ".[all]"`).

# %%
import tempfile
from pathlib import Path

from porthamiltonian import C, I, Model, OneJunction, R, Se, compile_model
from porthamiltonian.batch import Sweep, grid, read_dataframe
from porthamiltonian.interfaces.sweeps import simulate_case

m = Model("msd")
m.parameter("k", 4.0, "N/m")
m.parameter("c", 0.4, "N*s/m")
m.add("force", Se(effort="sin(t)"))           # a sinusoidal force, N
m.add("j", OneJunction())                      # one velocity shared by all
m.add("mass", I(inertance=1.0))                # 1 kg
m.add("spring", C(stiffness="k", q0=0.1))      # stretched 0.1 m at t = 0
m.add("damper", R(resistance="c"))
m.connect("force.p", "j")
for element in ("mass", "spring", "damper"):
    m.connect("j", f"{element}.p")

# the python back end starts at once; leave it out ("auto") for compiled speed on long runs
model = compile_model(m, backend="python")
model  # noqa: B018  (in Jupyter: states, parameters, units)

# %% [markdown]
# ## Simulate, and look
# Parameters are bound at run time: no recompilation for k = 9 N/m.

# %%
traj = model.simulate(20.0, params={"k": 9.0}, max_step=0.05)
traj  # noqa: B018  (in Jupyter: status, energy ledger, final states)

# %%
ax = traj.plot("spring.q", "mass.p")           # states over t, units in the legend
ax_energy = traj.plot("H", "E_diss", "E_in")   # the energy ledger

# %% [markdown]
# ## As a data frame
# One row per stored point, indexed by t; units in `df.attrs["units"]`.

# %%
df = traj.to_dataframe(outputs=["spring.p.e"])
print(df[["spring.q", "mass.p", "spring.p.e", "residual"]].describe().loc[["min", "max"]])
print("units:", {c: df.attrs["units"][c] for c in ("spring.q", "mass.p", "spring.p.e", "H")})
print("ledger residual, largest:", abs(df["residual"]).max(), df.attrs["units"]["residual"])

# %% [markdown]
# ## A sweep over the damping
# The generic case function simulates the model file `mass_spring_damper` (the same system,
# released from x0 = 0.1 m without a force) once per case and records the 2 % settling time of
# X for this light damping, so halving as c doubles.
# The results file resumes if interrupted; one call loads it as a data frame.

# %%
out = Path(tempfile.mkdtemp()) / "msd.jsonl"
sweep = Sweep(simulate_case, grid(c=[0.4, 0.8, 1.6]), out,
              fixed={"model": "mass_spring_damper", "t_end": 30.0, "settle": "spring.q",
                     "backend": "python"})
sweep.run(serial=True, progress="none")
sweep  # noqa: B018  (in Jupyter: cases by status, the first rows)

# %%
results = read_dataframe(out)
print(results[["c", "status", "settling_time", "energy.dissipated"]])
ax_sweep = results.plot(x="c", y="settling_time", marker="o", logx=True, logy=True,
                        ylabel="2 % settling time (s)", xlabel="c (N·s/m)", legend=False)
