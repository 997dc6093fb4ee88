"""Coefficients of the compiled Rosenbrock methods: one source for the Python and the C loops.

A stiffly accurate Rosenbrock (Rodas-type) method with ``s`` stages, in the transformed form of
Hairer & Wanner (*Solving Ordinary Differential Equations II*, 2nd ed., §IV.7, eq. (7.25)): with
``W = I/(γh) − J`` (J = ∂f/∂y at the step's start), stage ``i`` solves

    W k_i = f(t + c_i h, u_i) + h d_i ∂f/∂t + (Σ_{j<i} C_ij k_j) / h,   u_i = y + Σ_{j<i} a_ij k_j

(u_1 = y), the step's result is ``y1 = u_s + k_s`` and its error estimate is ``k_s`` (the embedded
solution is u_s). The dense output on θ ∈ [0, 1] is

    y(θ) = (1 − θ) y + θ (y1 + (1 − θ)(e_1 + θ (e_2 + θ (… + θ e_m)))),   e_r = Σ_j H_rj k_j.

The loops (``rosenbrock_loop.py``, ``rosenbrock_loop.c``) read these tables; the code generator
prints them as literals into each model's module (:func:`python_literals`, :func:`c_literals`).
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from ..errors import OptionError

#: the most stages a tableau may have: the C loops' stage buffers (PH_MAX_STAGES of
#: rosenbrock_loop.c)
MAX_STAGES = 16


@dataclass(frozen=True)
class Tableau:
    """A Rodas-type method (see the module docstring).

    name : the method's name in ``simulate(method=...)``; symbol : its loop's name in generated
    code (``integrate_<symbol>`` in Python, ``ph_integrate_<symbol>`` in C); gamma : γ;
    a, c : the strictly lower-triangular s x s tables (row i, columns j < i); nodes : c_i;
    d : d_i; dense : the m x s table H; error_order : q + 1 for an embedded method of order q
    (the step-size rule's exponent is −1/(q + 1)); source : where the coefficients come from.
    """

    name: str
    symbol: str
    gamma: float
    a: tuple[tuple[float, ...], ...]
    c: tuple[tuple[float, ...], ...]
    nodes: tuple[float, ...]
    d: tuple[float, ...]
    dense: tuple[tuple[float, ...], ...]
    order: int
    error_order: int
    source: str

    @property
    def stages(self) -> int:
        """The number of stages (right-hand-side evaluations per step)."""
        return len(self.nodes)

    def check(self) -> None:
        """Shapes and the structure every loop relies on; OptionError naming what is wrong."""
        s = self.stages
        broken = []
        if not (len(self.a) == len(self.c) == len(self.d) == s and all(
                len(row) == s for table in (self.a, self.c, self.dense) for row in table)):
            broken.append("a, c, d and the rows of a, c and dense need one entry per stage")
        elif not all(self.a[i][j] == 0 == self.c[i][j] for i in range(s) for j in range(i, s)):
            broken.append("a and c must be strictly lower triangular")
        if not (self.nodes[0] == 0.0 and self.d and self.d[0] == self.gamma):
            broken.append("the first node must be 0 and d[0] gamma")
        if s > MAX_STAGES:
            broken.append(f"{s} stages, more than the loops' {MAX_STAGES} (PH_MAX_STAGES)")
        if broken:
            raise OptionError(f"tableau {self.name!r} is malformed: {'; '.join(broken)}")


def _lower(rows: list[list[float]], s: int) -> tuple[tuple[float, ...], ...]:
    """Rows i = 1..s-1 of a strictly lower-triangular table, given without their zeros."""
    out = [tuple(0.0 for _ in range(s))]
    for i, row in enumerate(rows, start=1):
        out.append(tuple(row) + tuple(0.0 for _ in range(s - i)))
    return tuple(out)


_R4_A5 = [1.221224509226641, 6.019134481288629, 12.53708332932087, -0.687886036105895]

#: Rodas4: 6 stages, order 4, embedded order 3, L-stable, stiffly accurate, order-3 dense output.
RODAS4 = Tableau(
    name="Rodas4", symbol="rodas4", gamma=0.25,
    a=_lower([[1.544],
              [0.9466785280815826, 0.2557011698983284],
              [3.314825187068521, 2.896124015972201, 0.9986419139977817],
              _R4_A5,
              [*_R4_A5, 1.0]], 6),
    c=_lower([[-5.6688],
              [-2.430093356833875, -0.2063599157091915],
              [-0.1073529058151375, -9.594562251023355, -20.47028614809616],
              [7.496443313967647, -10.24680431464352, -33.99990352819905, 11.7089089320616],
              [8.083246795921522, -7.981132988064893, -31.52159432874371, 16.31930543123136,
               -6.058818238834054]], 6),
    nodes=(0.0, 0.386, 0.21, 0.63, 1.0, 1.0),
    d=(0.25, -0.1043, 0.1035, -0.0362, 0.0, 0.0),
    dense=((10.12623508344586, -7.487995877610167, -34.80091861555747, -7.992771707568823,
            1.025137723295662, 0.0),
           (-0.6762803392801253, 6.087714651680015, 16.43084320892478, 24.76722511418386,
            -6.594389125716872, 0.0)),
    order=4, error_order=4,
    source="Hairer & Wanner, Solving ODEs II (2nd ed., 1996), §IV.7, and their code RODAS "
           "(coefficient set 1, 'Rodas4')")

_R5_A6 = [-7.502846399306121, 2.561846144803919, -11.627539656261098, -0.18268767659942256,
          0.030198172008377946]

#: Rodas5P: 8 stages, order 5, embedded order 4, L-stable, stiffly accurate, order-4 dense
#: output; designed for stiff problems with an improved (order-4) error estimate and dense output.
RODAS5P = Tableau(
    name="Rodas5P", symbol="rodas5p", gamma=0.21193756319429014,
    a=_lower([[3.0],
              [2.849394379747939, 0.45842242204463923],
              [-6.954028509809101, 2.489845061869568, -10.358996098473584],
              [2.8029986275628964, 0.5072464736228206, -0.3988312541770524, -0.04721187230404641],
              _R5_A6,
              [*_R5_A6, 1.0],
              [*_R5_A6, 1.0, 1.0]], 8),
    c=_lower([[-14.155112264123755],
              [-17.97296035885952, -2.859693295451294],
              [147.12150275711716, -1.41221402718213, 71.68940251302358],
              [165.43517024871676, -0.4592823456491126, 42.90938336958603, -5.961986721573306],
              [24.854864614690072, -3.0009227002832186, 47.4931110020768, 5.5814197821558125,
               -0.6610691825249471],
              [30.91273214028599, -3.1208243349937974, 77.79954646070892, 34.28646028294783,
               -19.097331116725623, -28.087943162872662],
              [37.80277123390563, -3.2571969029072276, 112.26918849496327, 66.9347231244047,
               -40.06618937091002, -54.66780262877968, -9.48861652309627]], 8),
    nodes=(0.0, 0.6358126895828704, 0.4095798393397535, 0.9769306725060716, 0.4288403609558664,
           1.0, 1.0, 1.0),
    d=(0.21193756319429014, -0.42387512638858027, -0.3384627126235924, 1.8046452872882734,
       2.325825639765069, 0.0, 0.0, 0.0),
    dense=((25.948786856663858, -2.5579724845846235, 10.433815404888879, -2.3679251022685204,
            0.524948541321073, 1.1241088310450404, 0.4272876194431874, -0.17202221070155493),
           (-9.91568850695171, -0.9689944594115154, 3.0438037242978453, -24.495224566215796,
            20.176138334709044, 15.98066361424651, -6.789040303419874, -6.710236069923372),
           (11.419903575922262, 2.8879645146136994, 72.92137995996029, 80.12511834622643,
            -52.072871366152654, -59.78993625266729, -0.15582684282751913, 4.883087185713722)),
    order=5, error_order=5,
    source="G. Steinebach, Construction of Rosenbrock-Wanner method Rodas5P and numerical "
           "benchmarks within the Julia Differential Equations package, BIT Numerical "
           "Mathematics 63, 27 (2023) (its coefficients in the transformed form above)")

#: The compiled methods, by the name ``simulate(method=...)`` takes.
TABLEAUS: dict[str, Tableau] = {t.name: t for t in (RODAS4, RODAS5P)}
for _t in TABLEAUS.values():
    _t.check()


def _flat(table: Iterable[Iterable[float]]) -> list[float]:
    return [float(v) for row in table for v in row]


_ARGS = ("t0, y0, t_end, p, rtol, atol, h0, hmax, directions, terminal, mask_index, mask_sign, "
         "n_model, bound, max_steps, store_cap, tgrad_step")


def python_entry(tab: Tableau) -> str:
    """The tables of ``tab`` as module constants and its entry points ``integrate_<symbol>``
    and ``integrate_<symbol>_variational`` (the Python loop template's ``_rosenbrock`` with
    them), each taking the model's functions ``fn`` first (see :mod:`porthamiltonian.
    integrators`)."""
    s, p = tab.stages, f"_{tab.symbol.upper()}"
    return "\n".join([
        f"{p}_A = np.array({_flat(tab.a)!r}).reshape({s}, {s})",
        f"{p}_C = np.array({_flat(tab.c)!r}).reshape({s}, {s})",
        f"{p}_NODES = np.array({list(tab.nodes)!r})",
        f"{p}_D = np.array({list(tab.d)!r})",
        f"{p}_H = np.array({_flat(tab.dense)!r}).reshape({len(tab.dense)}, {s})",
        "", "",
        "@_jit",
        f"def integrate_{tab.symbol}(fn, {_ARGS}):",
        f'    """{tab.name}: the step loop _rosenbrock (its copy without Φ) with its tables."""',
        (f"    return _rosenbrock_plain(fn, {p}_A, {p}_C, {p}_NODES, {p}_D, {p}_H, {tab.gamma!r}, "
         f"{1.0 / tab.error_order!r}, {_ARGS}, np.empty((y0.shape[0], 0)), "
         "np.empty((0, 0)))[:15]"),
        "", "",
        "@_jit",
        f"def integrate_{tab.symbol}_variational(fn, {_ARGS}, phi0, gain):",
        f'    """{tab.name} with sensitivities (the variational equations) from phi0."""',
        (f"    return _rosenbrock(fn, {p}_A, {p}_C, {p}_NODES, {p}_D, {p}_H, {tab.gamma!r}, "
         f"{1.0 / tab.error_order!r}, {_ARGS}, phi0, gain)"), ""])


def c_entry(tab: Tableau) -> str:
    """The tables of ``tab`` as a ``static const ph_tableau`` and its exported entry point
    ``ph_integrate_<symbol>`` (the C loop template's ``rosenbrock`` with them)."""
    def arr(values: Iterable[float]) -> str:
        return "{" + ", ".join(repr(float(v)) for v in values) + "}"

    p = tab.symbol
    return (f"static const double {p}_a[] = {arr(_flat(tab.a))};\n"
            f"static const double {p}_c[] = {arr(_flat(tab.c))};\n"
            f"static const double {p}_nodes[] = {arr(tab.nodes)};\n"
            f"static const double {p}_d[] = {arr(tab.d)};\n"
            f"static const double {p}_h[] = {arr(_flat(tab.dense))};\n"
            f"static const ph_tableau {p}_tableau = {{{tab.stages}, {len(tab.dense)}, "
            f"{tab.gamma!r}, {1.0 / tab.error_order!r}, {p}_a, {p}_c, {p}_nodes, {p}_d, {p}_h}};\n"
            f"/* {tab.name} (see the loop above) */\n"
            f"PH_EXPORT int ph_integrate_{p}(PH_LOOP_PARAMS)\n"
            f"{{\n    return rosenbrock(&{p}_tableau, PH_LOOP_ARGS, 0, NULL, 0, NULL, NULL, NULL, NULL);\n}}\n"
            f"/* {tab.name} with sensitivities */\n"
            f"PH_EXPORT int ph_integrate_{p}_variational(PH_LOOP_PARAMS, PH_PHI_PARAMS)\n"
            f"{{\n    return rosenbrock(&{p}_tableau, PH_LOOP_ARGS, PH_PHI_ARGS);\n}}\n")
