"""What building a model will cost, estimated before any work: the size of the generated code,
the memory and time the build will take; a refusal or a progress line before the build.

What grows is the multibodies, and how depends on their formulation (decided here as the build
will: :func:`~porthamiltonian.mechanics.multibody.auto_kernel`, the tables read as text without
sympy). Written out symbolically, a tree's code grows with the sum, over its bodies, of the joint
coordinates between the body and the world (the recursion's terms): N(N+1)/2 for an N-link
chain, N for N bodies hung on the world; about 40 kB + 1.3 kB per term of C, the C compiler's
peak memory about 450 times that (at least 90 MB), the build about 38 s per MB of code on one core. Evaluated
by the kernel, a tree's code grows with its links L (about 9 kB + 2.8 kB per link: table entries
and the calls' outputs), the C compiler's memory about 90 MB + 16.5 kB·L² (one long function of
L² matrix entries), the build about 3 s (the kernel's and the loops' objects, once per cache) +
4.5e-4·L² + 4.8e-6·L³ s (the symbolic pass: the mass matrix's L² entries, each an output of the
kernel's call reading its L coordinates) + 24 µs per byte of code. Measured on planar chains of
10-200 links and chains about random axes (symbolic: 6-40 links; benchmarks/bench_estimate.py:
code within 10 %, memory and time within 30 % from 40 links on); models without a multibody are
small.

:func:`check` is what :func:`~porthamiltonian.compiler.compile_model` runs before it builds: a
model whose code would exceed :func:`limit` (:data:`MAX_CODE_MB`, or the override) or whose
build would need more memory than this process may use is refused with a
:class:`~porthamiltonian.errors.CostError` giving the estimate and the override; one that will
take more than 20 s gets a progress line first.
"""
from __future__ import annotations

import functools
import math
import os
import resource
from collections.abc import Callable
from collections.abc import Set as AbstractSet
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..errors import CostError, ExpressionError
from ..modeling.expressions import parse_text
from .literals import printable

if TYPE_CHECKING:
    from ..modeling.model import ModelDescription

__all__ = ["LIMIT_VARIABLE", "MAX_CODE_MB", "BuildEstimate", "check", "duration_text", "estimate",
           "limit"]

#: the largest generated code built without asking (MB): an 80-link chain written out
#: symbolically, minutes to build
MAX_CODE_MB = 8.0
#: the environment variable that raises (or lowers) that limit, in MB
LIMIT_VARIABLE = "PORTHAMILTONIAN_MAX_CODE_MB"
# measured with benchmarks/bench_estimate.py (module docstring): bytes of C, the C compiler's
# peak memory, CPU seconds of the build (process and compiler, one core)
_BASE, _PER_TERM = 40e3, 1.3e3          # symbolic: base, per body-coordinate term
_MEMORY_PER_BYTE = 450                  # symbolic: the compiler's memory per byte of code
_SECONDS_PER_BYTE = 38e-6               # symbolic: build time per byte of code
_K_BASE, _K_PER_LINK = 9.5e3, 1.9e3     # kernel: base, per link (the layout listed once)
_CC_MEMORY = 90e6                       # the compiler's memory at least (the loops' unit)
_K_MEMORY_PER_LINK2 = 16.5e3            # kernel: the compiler's memory, + per link²
_K_SECONDS = 3.0                        # kernel: the one-time objects (kernel, loops)
_K_SECONDS_PER_LINK2, _K_SECONDS_PER_LINK3 = 4.5e-4, 4.8e-6  # kernel: the symbolic pass
_K_SECONDS_PER_BYTE = 35e-6             # kernel: the compiler per byte of code
_NOTICE_SECONDS = 20.0                  # a progress line before builds longer than this


@dataclass(frozen=True)
class BuildEstimate:
    """The estimated cost of building a model (module docstring): ``bodies`` in its
    multibodies, ``terms`` (Σ over bodies of the joint coordinates to the world), generated
    code (bytes), peak memory (bytes), time (s, CPU of one core), ``links`` of the trees the
    kernel evaluates, ``kernel``: whether one does."""

    bodies: int
    terms: int
    code_bytes: float
    memory_bytes: float
    seconds: float
    links: int = 0
    kernel: bool = False

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
    """The cost of building ``description`` (module docstring); counts the links and joint
    coordinates of every ``Multibody`` component from its tables and decides its formulation as
    the build will, without building anything."""
    from ..mechanics.joints import joint  # (imported here: the mechanics import sympy)
    from ..mechanics.multibody import auto_kernel

    bodies = terms = 0
    symbolic_code = kernel_code = kernel_links = 0.0
    kernel = False
    for component in description.components.values():
        if component.kind != "Multibody":
            continue
        joints = component.value("joints") or {}
        specs = {name: joint(name, table) for name, table in joints.items()}
        dof = {table.get("child"): len(specs[name].velocities) for name, table in joints.items()}
        parent = {table.get("child"): table.get("parent") for table in joints.values()}
        depth: dict[str, int] = {}
        own_terms = 0
        for body in component.value("bodies") or {}:
            chain: list[str] = []
            node = body
            while node in parent and node not in depth and len(chain) <= len(parent):
                chain.append(node)
                node = parent[node]
            total = depth.get(node, 0)
            for b in reversed(chain):
                total += dof.get(b, 0)
                depth[b] = total
            bodies += 1
            own_terms += depth.get(body, 0)
        terms += own_terms
        axes = [axis for spec in specs.values() for _, axis, _ in spec.links]
        formulation = component.value("formulation") or "auto"
        closed = bool(component.value("loops") or component.value("constraints"))
        if formulation == "kernel" or (formulation == "auto" and auto_kernel(
                axes, _parametric(component, set(description.parameters)), closed)):
            kernel = True
            kernel_links += len(axes)
            kernel_code += _K_PER_LINK * len(axes)
        else:
            symbolic_code += _PER_TERM * own_terms
    if kernel:
        kernel_code += _K_BASE
    else:
        symbolic_code += _BASE
    L = kernel_links
    memory = max(_CC_MEMORY, _MEMORY_PER_BYTE * symbolic_code,
                 _CC_MEMORY + _K_MEMORY_PER_LINK2 * L ** 2 if kernel else 0.0)
    seconds = _SECONDS_PER_BYTE * symbolic_code + (
        _K_SECONDS + _K_SECONDS_PER_LINK2 * L ** 2 + _K_SECONDS_PER_LINK3 * L ** 3
        + _K_SECONDS_PER_BYTE * kernel_code if kernel else 0.0)
    return BuildEstimate(bodies, terms, symbolic_code + kernel_code, memory, seconds,
                         int(L), kernel)


def _parametric(component: Any, parameters: set[str]) -> bool:
    """Whether a multibody's tables (gravity, bodies' masses, centres, inertias, points and
    frames, joints' origins) name model parameters only (the kernel's condition), read from the
    expressions' text without sympy; an expression that does not parse counts as not."""
    values = [component.value("gravity"), component.value("bodies"),
              [table.get("origin") for table in (component.value("joints") or {}).values()]]
    return all(_names(v) <= parameters for v in values)


def _names(value: Any) -> AbstractSet[str]:
    if isinstance(value, dict):
        return set().union(*map(_names, value.values())) if value else set()
    if isinstance(value, (list, tuple)):
        return set().union(*map(_names, value)) if value else set()
    if isinstance(value, str):
        try:
            return _text_names(value)
        except ExpressionError:
            return {value}
    free = getattr(value, "free_symbols", None)     # a sympy expression (sympy not imported here)
    if free is not None:
        return {str(s) for s in free}
    return set()


@functools.lru_cache(maxsize=4096)
def _text_names(text: str) -> frozenset[str]:
    return frozenset(parse_text(text).names)


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
    when set (the override: the memory available is then not checked either), else
    :data:`MAX_CODE_MB`."""
    text = os.environ.get(LIMIT_VARIABLE, "").strip()
    if text:
        try:
            value = float(text)
        except ValueError:
            raise CostError(f"${LIMIT_VARIABLE} must be a number of MB, got {text!r}") from None
        return (math.inf if value <= 0 else value * 1e6), f"${LIMIT_VARIABLE} = {text}"
    return MAX_CODE_MB * 1e6, f"the default limit of {MAX_CODE_MB:g} MB"


def check(description: ModelDescription, report: Callable[[str], None]) -> BuildEstimate:
    """Refuse (:class:`~porthamiltonian.errors.CostError`) to build a model whose estimated code
    exceeds :func:`limit` or whose build would need more memory than this process may use (the
    system's available memory, the address-space limit; not checked under the override); call
    ``report`` with a progress line when the build will take more than a few seconds. Returns
    the estimate."""
    cost = estimate(description)
    largest, why = limit()
    refused = cost.code_bytes > largest
    if not refused and not os.environ.get(LIMIT_VARIABLE, "").strip():
        available = _available_memory()
        if cost.memory_bytes > available:
            refused, why = True, f"the memory available ({_size(available)})"
    if refused:
        raise CostError(
            f"model {printable(description.name)!r}: building it would take {cost.describe()}; that is "
            f"more than {why} allows, so it is refused before any work. Smaller models build "
            f"in seconds; to build it anyway set {LIMIT_VARIABLE} to the MB of code to allow "
            "(0: no limit)")
    if cost.seconds > _NOTICE_SECONDS:
        report(f"building {printable(description.name)}: {cost.describe()} (estimated); the build reports "
               "when it is done")
    return cost
