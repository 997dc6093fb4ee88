"""Integration loops compiled together with a model's generated functions.

``rodas_loop.py`` is a source template: the code generator appends it to every generated model
module, where it calls that module's ``rhs``, ``jac`` and ``guards`` directly, so that under the
numba back end the whole step loop (stages, LU, error control, event location) is machine code,
and under the python back end the same algorithm runs as a reference.
"""
from pathlib import Path

#: Text of the Rodas4 step-loop template (see rodas_loop.py).
RODAS_SOURCE = (Path(__file__).parent / "rodas_loop.py").read_text()
