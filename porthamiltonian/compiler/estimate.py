"""What building a model will cost, estimated before any work: the size of the generated code,
the memory and time the C compiler will take; a refusal or a progress line before the build.

The generated code of a multibody grows with the sum, over its bodies, of the number of joint
coordinates between the body and the world (the recursion's terms): N(N+1)/2 for an N-link chain,
N for N bodies hung on the world. Measured on planar chains (N = 10…40; benchmarks/
bench_multibody_build.py): about 25 kB + 1.3 kB per term of C (and as much Python), the C
compiler's peak memory about 450 times the code's size, its time about 30 s per MB of code on one
core. Generic joint axes give more code (the estimate is then a lower bound); models without a
multibody are small.

:func:`check` is what :func:`~porthamiltonian.compiler.compile_model` runs before it builds: a
model whose code would exceed :func:`limit` (the smaller of :data:`MAX_CODE_MB` and what the
memory available to this process allows) is refused with a :class:`~porthamiltonian.errors.
CostError` giving the estimate and the override; one that will take more than a few seconds gets
a progress line first.
"""
from __future__ import annotations

import math
import os
import resource
from collections.abc import Callable
from dataclasses import dataclass

from ..errors import CostError
from ..mechanics.joints import joint
from ..modeling.model import ModelDescription
from .literals import printable

__all__ = ["LIMIT_VARIABLE", "MAX_CODE_MB", "BuildEstimate", "check", "duration_text", "estimate",
           "limit"]

#: the largest generated code built without asking (MB): an 80-link chain, minutes to build
MAX_CODE_MB = 8.0
#: the environment variable that raises (or lowers) that limit, in MB
LIMIT_VARIABLE = "PORTHAMILTONIAN_MAX_CODE_MB"
_BASE, _PER_TERM = 25e3, 1.3e3          # bytes of C: base, per body-coordinate term
_MEMORY_PER_BYTE = 450                  # the C compiler's peak memory per byte of code
_SECONDS_PER_BYTE = 30e-6               # build time per byte of code (C compiler + codegen)
_NOTICE_SECONDS = 20.0                  # a progress line before builds longer than this


@dataclass(frozen=True)
class BuildEstimate:
    """The estimated cost of building a model (module docstring): ``bodies`` in its
    multibodies, ``terms`` (Σ over bodies of the joint coordinates to the world), generated
    code (bytes), peak memory (bytes) and time (s)."""

    bodies: int
    terms: int
    code_bytes: float
    memory_bytes: float
    seconds: float

    def describe(self) -> str:
        """``"60 bodies, about 2.4 MB of code (about 1.1 GB of memory and 1 min to build)"``."""
        return (f"{self.bodies} bod{'y' if self.bodies == 1 else 'ies'}, about "
                f"{_size(self.code_bytes)} of code (about {_size(self.memory_bytes)} of memory "
                f"and {duration_text(self.seconds)} to build)")


def _size(n: float) -> str:
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.2g} {unit}" if n < 10 * scale else f"{n / scale:.0f} {unit}"
    return f"{n:.0f} B"


def duration_text(seconds: float) -> str:
    """``"5.4 h"``, ``"2 min"``, ``"40 s"``, ``"3.2e+07 years"``: a time span in words."""
    if seconds >= 3.15e7:
        return f"{seconds / 3.156e7:.2g} years"
    for unit, scale in (("days", 86400), ("h", 3600), ("min", 60)):
        if seconds >= scale:
            return f"{seconds / scale:.2g} {unit}"
    return f"{seconds:.0f} s"


def estimate(description: ModelDescription) -> BuildEstimate:
    """The cost of building ``description`` (module docstring); counts the joint coordinates of
    every ``Multibody`` component from its tables, without building anything."""
    bodies = terms = 0
    for component in description.components.values():
        if component.kind != "Multibody":
            continue
        joints = component.value("joints") or {}
        dof = {table.get("child"): len(joint(name, table).velocities)
               for name, table in joints.items()}
        parent = {table.get("child"): table.get("parent") for table in joints.values()}
        depth: dict[str, int] = {}
        for body in component.value("bodies") or {}:
            chain, node = [], body
            while node in parent and node not in depth and len(chain) <= len(parent):
                chain.append(node)
                node = parent[node]
            total = depth.get(node, 0)
            for b in reversed(chain):
                total += dof.get(b, 0)
                depth[b] = total
            bodies += 1
            terms += depth.get(body, 0)
    code = _BASE + _PER_TERM * terms
    return BuildEstimate(bodies, terms, code, _MEMORY_PER_BYTE * code, _SECONDS_PER_BYTE * code)


def _available_memory() -> float:
    """The memory this process may still use (bytes): the smaller of the system's available
    memory (/proc/meminfo) and the process's address-space limit; inf when unknown."""
    out = math.inf
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    out = float(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    for which in (resource.RLIMIT_AS, resource.RLIMIT_DATA):
        soft = resource.getrlimit(which)[0]
        if soft != resource.RLIM_INFINITY:
            out = min(out, float(soft))
    return out


def limit() -> tuple[float, str]:
    """(the largest code built without asking, in bytes; why): ``$PORTHAMILTONIAN_MAX_CODE_MB``
    when set (the override: nothing else counts then), else the smaller of :data:`MAX_CODE_MB`
    and what the memory available to this process allows."""
    text = os.environ.get(LIMIT_VARIABLE, "").strip()
    if text:
        try:
            value = float(text)
        except ValueError:
            raise CostError(f"${LIMIT_VARIABLE} must be a number of MB, got {text!r}") from None
        return (math.inf if value <= 0 else value * 1e6), f"${LIMIT_VARIABLE} = {text}"
    memory = _available_memory() / _MEMORY_PER_BYTE
    if memory < MAX_CODE_MB * 1e6:
        return memory, f"the memory available ({_size(_available_memory())})"
    return MAX_CODE_MB * 1e6, f"the default limit of {MAX_CODE_MB:g} MB"


def check(description: ModelDescription, report: Callable[[str], None]) -> BuildEstimate:
    """Refuse (:class:`~porthamiltonian.errors.CostError`) to build a model whose estimated code
    exceeds :func:`limit`; call ``report`` with a progress line when the build will take more
    than a few seconds. Returns the estimate."""
    cost = estimate(description)
    largest, why = limit()
    if cost.code_bytes > largest:
        raise CostError(
            f"model {printable(description.name)!r}: building it would take {cost.describe()}; that is "
            f"more than {why} allows, so it is refused before any work. Smaller models build "
            f"in seconds; to build it anyway set {LIMIT_VARIABLE} to the MB of code to allow "
            "(0: no limit)")
    if cost.seconds > _NOTICE_SECONDS:
        report(f"building {printable(description.name)}: {cost.describe()} (estimated); the build reports "
               "when it is done")
    return cost
