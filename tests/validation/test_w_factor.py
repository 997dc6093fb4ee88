"""The linear algebra of the compiled loops (porthamiltonian/integrators/rosenbrock_loop.py and
its C twin): W = I/(hγ) − J factored by blocks when the ledger quadratures' columns of J are zero
(the model block by LU, the ledger rows by substitution), all of W otherwise; each checked
against numpy.linalg.solve on random matrices, in Python and in C (the template compiled with a
small driver by the machine's C compiler)."""
import ctypes

import numpy as np
import pytest

from porthamiltonian.backends import module, native
from porthamiltonian.integrators import c_loops

N, N_MODEL, M = 7, 5, 3     # 5 model states, 2 ledger quadratures; 3 right-hand sides
HGAM = 0.013


def _jacobians():
    """A Jacobian of the ledger's shape (ledger columns zero) and one that breaks it."""
    rng = np.random.default_rng(7)
    J = rng.normal(size=(N, N)) * 40.0
    J[:, N_MODEL:] = 0.0
    broken = J.copy()
    broken[1, N_MODEL + 1] = 3.0
    return J, broken


def _expected(J, B):
    return np.linalg.solve(np.eye(N) / HGAM - J, B)


@pytest.fixture(scope="module")
def python_loop():
    """The Python template's functions: the python back end's loop module."""
    return vars(module.python_loop_module())


@pytest.mark.parametrize("which, block", [(0, N_MODEL), (1, N)])
def test_python_w_factor_and_solves(python_loop, which, block):
    J = _jacobians()[which]
    B = np.random.default_rng(3).normal(size=(N, M))
    W, piv = np.empty((N, N)), np.empty(N, dtype=np.int64)
    nb = python_loop["_w_factor"](J, HGAM, N_MODEL, W, piv)
    assert nb == block
    x = B[:, 0].copy()
    python_loop["_lu_solve"](W, piv, nb, x)
    X = B.ravel().copy()
    python_loop["_lu_solve_rows"](W, piv, nb, X, M)
    ref = _expected(J, B)
    assert np.allclose(x, ref[:, 0], rtol=1e-12, atol=1e-14)
    assert np.allclose(X.reshape(N, M), ref, rtol=1e-12, atol=1e-14)


_STUBS = """
static void rhs(double t, const double *x, const double *p, double *out)
{ (void)t; (void)x; (void)p; (void)out; }
static void jac(double t, const double *x, const double *p, double *out)
{ (void)t; (void)x; (void)p; (void)out; }
static void guards(double t, const double *x, const double *p, double *out)
{ (void)t; (void)x; (void)p; (void)out; }
static void jac_p(double t, const double *x, const double *p, double *out)
{ (void)t; (void)x; (void)p; (void)out; }
"""
_DRIVER = """
PH_EXPORT int ph_test_w(const double *J, double hgam, int64_t n_model, double *b, double *B,
                        int64_t m)
{
    double W[PH_N * PH_N];
    int piv[PH_N];
    const int nf = ph_w_factor(J, hgam, n_model, W, piv);
    if (nf) {
        ph_lu_solve(W, piv, nf, b);
        ph_lu_solve_rows(W, piv, nf, B, m);
    }
    return nf;
}
"""


@pytest.fixture(scope="module")
def c_loop(tmp_path_factory):
    """The C template with the driver above, built like a model's library."""
    folder = tmp_path_factory.mktemp("wfactor")
    source = folder / "wfactor.c"
    prelude = ("#include <math.h>\n#include <stdint.h>\n#include <stdlib.h>\n#include <string.h>\n"
               "#define PH_EXPORT __attribute__((visibility(\"default\")))\n"
               f"#define PH_N {N}\n#define PH_NG 1\n")
    source.write_text(prelude + _STUBS + c_loops() + _DRIVER)
    data, _ = native.build(source, folder)
    library = folder / "wfactor.so"
    library.write_bytes(data)
    lib = ctypes.CDLL(str(library))
    lib.ph_test_w.restype = ctypes.c_int
    lib.ph_test_w.argtypes = (ctypes.c_void_p, ctypes.c_double, ctypes.c_int64, ctypes.c_void_p,
                              ctypes.c_void_p, ctypes.c_int64)
    return lib


@pytest.mark.parametrize("which, block", [(0, N_MODEL), (1, N)])
def test_c_w_factor_and_solves(c_loop, which, block):
    J = np.ascontiguousarray(_jacobians()[which])
    B = np.random.default_rng(3).normal(size=(N, M))
    x = B[:, 0].copy()
    X = B.copy()
    nb = c_loop.ph_test_w(J.ctypes.data, HGAM, N_MODEL, x.ctypes.data, X.ctypes.data, M)
    assert nb == block
    ref = _expected(J, B)
    assert np.allclose(x, ref[:, 0], rtol=1e-12, atol=1e-14)
    assert np.allclose(X, ref, rtol=1e-12, atol=1e-14)
