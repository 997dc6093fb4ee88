"""QBDF, the compiled variable-order BDF (``bdf_loop.py``, ``bdf_loop.c``): its name, and its entry
points printed into each model's module like the Rosenbrock methods' (:mod:`.tableaus`).

The loop needs no tables of its own (the BDF coefficients γ_q = Σ_{i≤q} 1/i and the error
constants 1/(q + 1) are computed in it); its sensitivities are carried by the Rosenbrock method
:data:`PHI_METHOD`, whose tables the entry points pass on.
"""
from __future__ import annotations

from .tableaus import _ARGS, TABLEAUS

#: the name ``simulate(method=...)`` takes, and its symbol in generated code
NAME, SYMBOL = "QBDF", "qbdf"
#: the Rosenbrock method that carries Φ over each BDF step (_variational_step)
PHI_METHOD = "Rodas5P"


def python_entry() -> str:
    """The entry points ``integrate_qbdf`` and ``integrate_qbdf_variational`` (after the
    Rosenbrock methods' tables in the module)."""
    tab = TABLEAUS[PHI_METHOD]
    p = f"_{tab.symbol.upper()}"
    phi = f"{p}_A, {p}_C, {p}_NODES, {p}_D, {tab.gamma!r}, {1.0 / tab.error_order!r}"
    return "\n".join([
        "@_jit",
        f"def integrate_{SYMBOL}(fn, {_ARGS}):",
        f'    """{NAME}: the step loop _bdf (its copy without Φ)."""',
        (f"    return _bdf_plain(fn, {phi}, {_ARGS}, np.empty((y0.shape[0], 0)), "
         "np.empty((0, 0)))[:15]"),
        "", "",
        "@_jit",
        f"def integrate_{SYMBOL}_variational(fn, {_ARGS}, phi0, gain):",
        f'    """{NAME} with sensitivities (the variational equations, by {PHI_METHOD}) from phi0."""',
        f"    return _bdf(fn, {phi}, {_ARGS}, phi0, gain)", ""])


def c_entry() -> str:
    """The exported entry points ``ph_integrate_qbdf`` and ``ph_integrate_qbdf_variational``
    (after the Rosenbrock methods' tables in the translation unit)."""
    tab = f"&{TABLEAUS[PHI_METHOD].symbol}_tableau"
    return (f"/* {NAME} (see the loop above) */\n"
            f"PH_EXPORT int ph_integrate_{SYMBOL}(PH_LOOP_PARAMS)\n"
            f"{{\n    return bdf({tab}, PH_LOOP_ARGS, 0, NULL, 0, NULL, NULL, NULL, NULL);\n}}\n"
            f"/* {NAME} with sensitivities */\n"
            f"PH_EXPORT int ph_integrate_{SYMBOL}_variational(PH_LOOP_PARAMS, PH_PHI_PARAMS)\n"
            f"{{\n    return bdf({tab}, PH_LOOP_ARGS, PH_PHI_ARGS);\n}}\n")
