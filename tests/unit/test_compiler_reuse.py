"""The symbolic compiler reuses the solved structure of a model (components built, causality
solved) for a model that differs from it only in events and model outputs, as a walker compiles
its model without them and then with its own outputs (porthamiltonian.compiler._solved). The
reuse must be invisible: the same generated code as a compile from scratch, and no reuse when
anything else differs."""
from __future__ import annotations

import copy

import pytest

from porthamiltonian import compiler, io
from porthamiltonian.compiler import symbolic
from porthamiltonian.compiler.codegen import program
from porthamiltonian.compiler.printers import c_source, python_source
from porthamiltonian.errors import ModelError


def _variant(model, output: str = "2*spring.q", event: str = "spring.q - 0.01"):
    out = copy.deepcopy(model)
    out.output("stretch2", output)
    out.event("far", event, direction=1, terminal=True)
    return out


def _code(model) -> tuple[str, str]:
    prog = program(symbolic(model))
    return python_source(prog), c_source(prog)


@pytest.fixture
def bare():
    compiler._SOLVED.clear()
    yield io.load("mass_spring_damper")
    compiler._SOLVED.clear()


def test_a_variant_with_outputs_and_events_reuses_the_structure_and_the_code_is_the_same(bare):
    symbolic(bare)
    variant = _variant(bare)
    reused = _code(variant)
    assert len(compiler._SOLVED) == 1                   # the variant hit the bare model's entry
    compiler._SOLVED.clear()
    assert reused == _code(variant)                     # from scratch
    sym = symbolic(variant)
    assert "stretch2" in sym.outputs and [ev.name for ev, _ in sym.events] == ["far"]


def test_anything_else_that_differs_is_solved_again(bare):
    symbolic(bare)
    text = io.model_path("mass_spring_damper").read_text()
    assert "k = { value = 4.0," in text
    symbolic(io.loads(text.replace("k = { value = 4.0,", "k = { value = 5.0,")))  # a default
    assert len(compiler._SOLVED) == 2


def test_an_error_in_a_reused_models_output_names_the_output(bare):
    symbolic(bare)
    with pytest.raises(ModelError, match="stretch2"):
        symbolic(_variant(bare, output="2*no_such_thing.q"))
