"""The generated code of an N-link chain grows at most as about N² (the symbolic recursive
multibody) and as N (the kernel formulation, whose code holds a table entry per link).

For the planar pendulum chains of multibody_cases.chain_model (N = 10, 20), the whole
generated module (rhs, Jacobian, energy, outputs, guards, initial state, mass matrix) is measured
by its operations — the arithmetic, unary and call nodes and augmented assignments of its syntax
tree, after common-subexpression elimination — and by its bytes. The growth exponent
log(size(20)/size(10))/log 2 must be ≤ 2.2 for the symbolic formulation (the formulation that
differentiated the mass matrix's entries grew as N^4.5–5) and ≤ 1.0 for the kernel's (the
kernel's own Python, the same for every tree, counted in both). Deterministic: sizes, not times.
benchmarks/bench_multibody_build.py measures N = 2 … 40 and the build times.
"""
from __future__ import annotations

import ast
import math

import pytest
from multibody_cases import chain_model, with_formulation

from porthamiltonian.compiler import symbolic
from porthamiltonian.compiler.codegen import program
from porthamiltonian.compiler.printers import python_source


def operations(source: str) -> int:
    """Arithmetic, unary, call and augmented-assignment nodes of a Python module."""
    kinds = (ast.BinOp, ast.UnaryOp, ast.Call, ast.AugAssign)
    return sum(isinstance(node, kinds) for node in ast.walk(ast.parse(source)))


def measured(formulation: str) -> dict[int, tuple[int, int]]:
    out = {}
    for n in (10, 20):
        source = python_source(program(symbolic(with_formulation(chain_model(n), formulation))))
        out[n] = (operations(source), len(source.encode()))
    return out


@pytest.fixture(scope="module")
def sizes() -> dict[int, tuple[int, int]]:
    return measured("symbolic")


def test_generated_size_grows_at_most_as_n_squared(sizes):
    (ops, size), (ops2, size2) = sizes[10], sizes[20]
    assert math.log2(ops2 / ops) <= 2.2, (ops, ops2)
    assert math.log2(size2 / size) <= 2.2, (size, size2)


def test_a_ten_link_chain_is_small(sizes):
    """Regression pin: the 10-link chain's module has fewer than 8000 operations and 150 kB
    (the entrywise formulation: 302 kB)."""
    ops, size = sizes[10]
    assert ops < 8000 and size < 150_000, (ops, size)


def test_kernel_code_grows_linearly():
    (ops, size), (ops2, size2) = measured("kernel").values()
    assert math.log2(ops2 / ops) <= 1.0, (ops, ops2)
    assert math.log2(size2 / size) <= 1.0, (size, size2)
