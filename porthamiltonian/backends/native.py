"""The ``c`` back end: one C99 translation unit per model, a shared library, called by ctypes.

The translation unit holds the generated functions (:func:`porthamiltonian.compiler.printers.
c_source`) and the integration loops (``porthamiltonian/integrators/rosenbrock_loop.c`` and each
method's tables), so that a whole segment between two events runs in C without returning to
Python. It is built by the machine's C compiler — ``$CC`` (which may carry flags, e.g.
``CC="gcc -m64"``), else the first of ``cc``, ``gcc``, ``clang`` on ``PATH``, else
``python -m ziglang cc`` (``pip install 'porthamiltonian[c]'``) — with :data:`FLAGS`. The caller
(:func:`porthamiltonian.compiler.compile_model`) keeps the library in the compiled-model cache and
verifies its sha256 before it is loaded.

Every exported function is called through ctypes on contiguous float64 numpy buffers whose sizes
are checked first (the C code trusts them); ctypes releases the GIL during the call.
"""
from __future__ import annotations

import atexit
import ctypes
import functools
import hashlib
import importlib.util
import json
import math
import os
import platform
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import CompilerError, OptionError
from ..integrators import LOOPS, c_loops
from ..userfiles import no_room
from . import Functions

#: Optimisation and code-generation flags, chosen by measurement on the walkers
#: (benchmarks/bench_build.py --opt-levels; benchmarks/RESULTS.md): the generated functions —
#: long straight-line code, where -O2 costs build time and gains little — at -O1, the
#: integration loop (LU, stages, event location: small loops over the state) at -O2 under GCC
#: (:data:`LOOP_PRAGMA`), which makes the compliant-leg walker's steps ~1.4x faster; the two loop
#: nests of the generated functions (the Jacobian's row operations, the small solves) at -O3 by a
#: pragma in the generated prelude (compiler/printers.py: -18 % per compass-walker step, no
#: measurable build time); the functions called once per analysis, not at every step (jac_u:
#: compiler/printers.py, COLD_FUNCTIONS) at -O0 by a pragma (the Whipple bicycle's unit: 5.3 ->
#: 3.3 s of CPU).
#: -fno-math-errno lets sqrt() compile to one instruction; -fno-tree-dse skips GCC's dead-store
#: elimination, superlinear on the long runs of stores of generated code (the 40-link chain's
#: unit: 4.4 -> 2.6 s of CPU) and of no use there; nothing changes results (no -ffast-math),
#: and nothing is machine-specific (a cache folder may be shared by machines).
FLAGS = ("-O1", "-fno-math-errno", "-fno-tree-dse", "-std=c99", "-shared", "-fPIC")
#: Put before the loop template: GCC optimises the functions that follow at -O2.
LOOP_PRAGMA = ('#if defined(__GNUC__) && !defined(__clang__)\n#pragma GCC optimize ("O2")\n'
               '#endif\n')
_SUFFIX = ".dll" if sys.platform == "win32" else ".so"
_NAMES = ("rhs", "jac", "energy", "outputs", "guards")
_SIZES = ("states", "parameters", "guards", "outputs", "matrices")


def library_prefix(key: str) -> str:
    """The start of the cache file names of a model's libraries on this kind of machine (a
    cache folder may be shared by machines of different kinds)."""
    machine = platform.machine().lower() or "unknown"
    return f"m{key}_c_{sys.platform}_{machine}_"


def library_name(key: str, identity: str | None = None) -> str:
    """The cache file name of a model's library built by the compiler ``identity``
    (:func:`compiler_identity`; default: the current one, ``none`` without a compiler): a
    library is never reused by another compiler, another version or other flags."""
    if identity is None:
        identity = compiler_identity() or "none"
    return f"{library_prefix(key)}{identity}{_SUFFIX}"


#: the generated functions the integration loops call: external (hidden, not exported), since
#: the loops are compiled as a unit of their own (:func:`loop_source`)
LOOP_FUNCTIONS = ("rhs", "jac", "guards", "jac_p")

#: The loops' forcing of parameter sensitivities calls ``jac_p``; a model compiled without it
#: has this stub (the loops call it with no parameter columns, so it is never reached)
JAC_P_STUB = ("/* no parameter Jacobian generated (compile_model(..., jac_p=[...])) */\n"
              "PH_HIDDEN void jac_p(double t, const double *x, const double *p, double *out)\n"
              "{\n    (void)t; (void)x; (void)p; (void)out;\n}\n")


#: appended to every translation unit: the library's self-check and its model key
_SELF_CHECK = r"""
#include <fenv.h>

/* The library's self-check (porthamiltonian.backends.native.load): the IEEE arithmetic the
   integrator relies on (NaN unequal to itself, overflow to infinity, no reassociation); flags
   such as -ffast-math break it. */
PH_EXPORT int ph_selftest(double nan_in, double one)
{
    int ok = 1;
    volatile double x = nan_in, a = 1e16 * one, big = 1e308 * one;
    double y = x, b = a, c = big;
    if (y == y || !isnan(y)) ok = 0;
    if ((b + one) - b != 0.0) ok = 0;
    if (!isinf(c * 10.0)) ok = 0;
    return ok;
}

/* The default floating-point environment again (a library linked with -ffast-math turns off
   subnormal numbers in the whole process when it is loaded). */
PH_EXPORT void ph_fp_default(void) { fesetenv(FE_DFL_ENV); }

PH_EXPORT const char *ph_model_key(void) { return "%s"; }
"""


#: appended to every translation unit: the model's sizes, which the loops' object reads
#: (:func:`loop_source`)
_SIZES_EXPORT = ("/* the sizes the integration loops' object reads (states with the ledger, "
                 "guard slots) */\nPH_HIDDEN const int ph_n = PH_N, ph_ng = PH_NG;\n")


#: the line before each generated function of a C body (followed by its exported wrapper), and
#: after the last (:func:`porthamiltonian.compiler.printers.c_source`): :func:`model_units`
#: shares the functions out between two units
FUNCTION_MARK = "/* ph: function {} */"
FUNCTIONS_END = "/* ph: end of the functions */"
#: a model's body longer than this (characters) compiles as two units, one compiler for each,
#: when a core is free (:func:`split_units`): the build waits for them (compass_walker's 57 kB
#: unit: 0.27–0.39 s for one compile, 0.25 s for two halves at once, but 0.39 s of CPU against
#: 0.30 s: on a busy machine the second compiler only costs)
SPLIT_SIZE = 24_000
_MARK = re.compile(r"^/\* ph: function \w+ \*/$", re.MULTILINE)


def split_units() -> bool:
    """Whether a build compiles a long model body as two units at once (:func:`model_units`):
    ``$PORTHAMILTONIAN_CC_JOBS`` (the compilers a build may run at once: 1 where other processes
    keep every core busy, e.g. parallel test workers; 2 or more: two units), else when a core is
    free (:func:`core_free`). A value that is not a number is ignored."""
    jobs = os.environ.get("PORTHAMILTONIAN_CC_JOBS", "").strip()
    return int(jobs) > 1 if jobs.isdigit() else core_free()


def core_free() -> bool:
    """Whether a processor core is idle, so that a second compiler speeds a build up instead of
    taking the core from other work: the 1-minute load average below the core count less one
    half (a machine without a load average: more than one core)."""
    cores = os.cpu_count() or 1
    if not hasattr(os, "getloadavg"):
        return cores > 1
    return os.getloadavg()[0] < cores - 0.5


def model_units(body: str, key: str = "", split: bool = True) -> list[str]:
    """The model's own code as the translation units the C back end compiles at once: the one
    unit of :func:`model_unit`, or, with ``split`` (:func:`split_units`, for a build) and for a
    body longer than :data:`SPLIT_SIZE`, two of about equal size. Each has the body's prelude
    (includes, static helpers, sizes); the generated functions, each with its wrapper, are
    shared out by size (the largest first, each to the shorter unit) and keep their order
    within a unit; the first unit has the rest (``ph_layout``, :func:`model_unit`'s additions).
    The functions the loops call are external (``PH_HIDDEN``: rhs, jac, guards, jac_p), the
    others static in their unit beside their wrapper."""
    end = body.find(FUNCTIONS_END)
    marks = [m.start() for m in _MARK.finditer(body, 0, end if end >= 0 else len(body))]
    if not split or len(body) <= SPLIT_SIZE or end < 0 or len(marks) < 2:
        return [model_unit(body, key)]
    body = _with_jac_p(body)                # (a stub, after the functions: in the first unit)
    prelude, tail = body[:marks[0]], body[end:]
    functions = [body[a:b] for a, b in zip(marks, [*marks[1:], end])]
    groups: list[list[int]] = [[], []]
    sizes = [0, 0]
    for i in sorted(range(len(functions)), key=lambda i: -len(functions[i])):
        k = sizes.index(min(sizes))
        groups[k].append(i)
        sizes[k] += len(functions[i])
    first, second = ("".join(functions[i] for i in sorted(group)) for group in groups)
    return [prelude + first + tail + "\n" + _unit_end(key), prelude + second]


def model_unit(body: str, key: str = "") -> str:
    """A model's own translation unit for the C back end: the generated body (and
    :data:`JAC_P_STUB` when it has no ``jac_p``), the model's sizes ``ph_n`` and ``ph_ng``,
    the self-check and ``ph_model_key`` returning ``key`` (the model's cache key: letters and
    digits); the integration loops are an object of their own (:func:`loop_source`) linked
    with it."""
    return _with_jac_p(body) + "\n" + _unit_end(key)


def _unit_end(key: str) -> str:
    """What :func:`model_unit` adds after the body: the sizes, the self-check, the key."""
    return _SIZES_EXPORT + "\n" + _self_check(key)


def _self_check(key: str) -> str:
    """The self-check and ``ph_model_key`` returning ``key`` (letters, digits and ``_``)."""
    if key and not key.replace("_", "").isalnum():
        raise CompilerError(f"model key {key!r}: letters, digits and '_' only")
    return _SELF_CHECK.replace("%s", key)


def addon_unit(body: str, key: str) -> str:
    """The translation unit of an add-on of a model's cache entry (e.g. its port-Hamiltonian
    form: :mod:`porthamiltonian.compiler`): the add-on's generated body, the self-check and
    ``ph_model_key`` returning ``key`` (the model's cache key and the add-on's name,
    ``<key>_<add-on>``). It is a library of its own, loaded beside the model's by
    :func:`load_addon`; no integration loop calls its functions."""
    return body + "\n" + _self_check(key)


def _with_jac_p(body: str) -> str:
    """``body``, followed by :data:`JAC_P_STUB` when it defines no ``jac_p``."""
    return body if "void jac_p(" in body else body + "\n" + JAC_P_STUB


def translation_unit(body: str, loop_pragma: bool = True, key: str = "") -> str:
    """The full C source as one unit (an FMU's sources; measuring optimisation levels): the
    generated body (and :data:`JAC_P_STUB` when it has no ``jac_p``) followed by the
    integration loops (after :data:`LOOP_PRAGMA` unless
    ``loop_pragma`` is false), the self-check and ``ph_model_key`` (:func:`model_unit`)."""
    return model_unit(_with_jac_p(body) + "\n" + (LOOP_PRAGMA if loop_pragma else "")
                      + c_loops(), key)


_LOOP_HEADER = """\
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#if defined(__GNUC__)
#define PH_HIDDEN __attribute__((visibility("hidden")))
#else
#define PH_HIDDEN
#endif
"""
#: the loops' entry points exported from the model's library (the C back end calls them)
_EXPORTED = """\
#if defined(_WIN32)
#define PH_EXPORT __declspec(dllexport)
#else
#define PH_EXPORT __attribute__((visibility("default")))
#endif
"""


def loop_source(fmu: bool = False) -> str:
    """The integration loops as a translation unit of their own, calling the model's ``rhs``,
    ``jac``, ``guards`` and ``jac_p`` (hidden external functions of its generated unit) and
    reading its sizes ``ph_n`` (states with the ledger) and ``ph_ng`` (guard slots) from it
    at run time (:func:`model_unit`): one object for every model, compiled once per compiler
    and cached, which starts compiling before the model is read (compiler.prepare). (The
    loops compiled for the model's sizes as constants ran ≈ 3 % faster per stride on the
    compass walker, the same on the compliant-leg walker: benchmarks/RESULTS.md, "Cold build,
    third pass".) ``fmu``: the variant an FMU's binary links: its entry points
    (``ph_integrate_<method>``, ``ph_many``) hidden, where the C back end's are exported (an
    FMU exports the FMI functions alone: two FMUs loaded into one process never call each
    other's loops), and the Rosenbrock methods alone (an FMU's co-simulation runs one; 0.41
    against 0.6 s of GCC)."""
    declarations = "".join(f"PH_HIDDEN void {name}(double t, const double *x, const double *p, "
                           "double *out);\n" for name in LOOP_FUNCTIONS)
    return (_LOOP_HEADER + ("#define PH_EXPORT PH_HIDDEN\n" if fmu else _EXPORTED)
            + "PH_HIDDEN extern const int ph_n, ph_ng;\n#define PH_N ph_n\n"
            "#define PH_NG ph_ng\n" + declarations + LOOP_PRAGMA + c_loops(multistep=not fmu)
            + _MANY)


#: ``ph_many``: a function of the model's library ``fn(t, x, p, out)`` at k points in one call
#: (the points' times t, states x row by row, nx each; their results into out, nout each): a
#: trajectory's outputs or energy, a dense output's rates, without a call from Python per point
_MANY = """
PH_EXPORT void ph_many(void (*fn)(double, const double *, const double *, double *), int64_t k,
                       const double *t, const double *x, int64_t nx, const double *p,
                       double *out, int64_t nout)
{
    for (int64_t i = 0; i < k; ++i)
        fn(t[i], x + i * nx, p, out + i * nout);
}
"""


def write_source(path: Path, data: str | bytes) -> None:
    """Write a file for the C compiler (a source, or an object to link) at ``path``; a write that
    fails (a full disk, a file size limit) raises :class:`~porthamiltonian.errors.CompilerError`
    saying where and what to do, as a problem of the machine, not a bug."""
    try:
        if isinstance(data, bytes):
            path.write_bytes(data)
        else:
            path.write_text(data)
    except OSError as err:
        raise CompilerError(no_room(f"cannot write {path.name} for the C compiler in "
                                    f"{path.parent}", err)) from err


#: what a failed build's message advises (the C back end's; an FMU's build says its own)
ADVICE = "Set CC to a working C compiler, or choose the numba or python back end"


class Pending:
    """A compile running in the background (:func:`start_object`): :meth:`wait` gives the
    object's path (valid until :meth:`close`), :meth:`result` its bytes; errors as
    :func:`build`."""

    def __init__(self, text: str, name: str):
        self._tmp = tempfile.TemporaryDirectory(prefix="porthamiltonian-cc-")
        folder = Path(self._tmp.name)
        self.source = folder / f"{name}.c"
        try:
            write_source(self.source, text)
        except CompilerError:
            self._tmp.cleanup()
            raise
        self.out = folder / f"{name}.o"
        self.log = folder / f"{name}.log"
        cc = compiler()
        self.command = [*(cc or ["cc"]), *(f for f in FLAGS if f != "-shared"), "-c", "-o",
                        str(self.out), str(self.source)]
        self.start = time.perf_counter()
        self.process = None
        if cc is not None:
            try:
                with open(self.log, "w") as log:
                    self.process = subprocess.Popen(self.command, stdout=log, stderr=log,
                                                    stdin=subprocess.DEVNULL)
            except OSError:
                self.process = None

    def close(self, stop: bool = False) -> None:
        """Wait for the compiler (if running; ``stop``: end it first, its result not wanted)
        and remove the temporary folder."""
        if self.process is not None and self.process.poll() is None:
            if stop:
                self.process.terminate()
            self.process.wait()
        self._tmp.cleanup()

    def wait(self, log_dir: Path | None, log_as: Path | None = None,
             advice: str = ADVICE) -> tuple[Path, float]:
        """Wait for the compile: (the object's path, valid until :meth:`close`, seconds since it
        started); a failure raises CompilerError with its command and log (in ``log_dir``,
        named after ``log_as`` when given, or a kept temporary file), ending with ``advice``."""
        if self.process is None:            # no compiler, or it could not start: say why
            data, _ = build(self.source, log_dir, (), object_only=True, log_as=log_as,
                            advice=advice)
            write_source(self.out, data)
            return self.out, time.perf_counter() - self.start
        status = self.process.wait()
        seconds = time.perf_counter() - self.start
        if status == 0 and self.out.is_file():
            return self.out, seconds
        log = _write_log(log_as or self.source, log_dir, self.command, f"exit status {status}",
                         self.log.read_text(errors="replace"))
        raise CompilerError(f"the C compiler failed (exit status {status}) building "
                            f"{self.source.name}: {shlex.join(self.command)}; its output is in "
                            f"{log}. {advice}")

    def result(self, log_dir: Path | None, log_as: Path | None = None) -> tuple[bytes, float]:
        """Wait for the compile (:meth:`wait`): (the object's bytes, seconds since it started);
        the temporary folder is removed."""
        try:
            path, seconds = self.wait(log_dir, log_as)
            return path.read_bytes(), seconds
        finally:
            self._tmp.cleanup()


def start_object(text: str, name: str) -> Pending:
    """Start compiling the C source ``text`` into an object file in the background."""
    return Pending(text, name)


def compiler() -> list[str] | None:
    """The C compiler command: ``$CC`` split like a shell would, else cc, gcc or clang on PATH,
    else ``python -m ziglang cc`` when the ziglang package is installed; None when none is."""
    cc = os.environ.get("CC", "").strip()
    if cc:
        return shlex.split(cc)
    for name in ("cc", "gcc", "clang"):
        path = shutil.which(name)
        if path:
            return [path]
    if importlib.util.find_spec("ziglang") is not None:
        return [sys.executable, "-m", "ziglang", "cc"]
    return None


def compiler_identity() -> str | None:
    """A short hash of what the C compiler is: the resolved path of its executable (and its
    size and time stamp), its ``--version`` output, the flags in ``$CC`` and :data:`FLAGS`;
    None when there is no compiler. Part of a library's cache name, so that a library is
    rebuilt when the compiler, its version or its flags change."""
    cc = compiler()
    return None if cc is None else _identity(tuple(cc))


@functools.cache
def _identity(cc: tuple[str, ...]) -> str:
    found = shutil.which(cc[0])
    real = os.path.realpath(found) if found else cc[0]
    try:
        info = os.stat(real)
        stamp = f"{info.st_size}:{info.st_mtime_ns}"
    except OSError:
        stamp = "missing"
    try:
        run = subprocess.run([*cc, "--version"], capture_output=True, text=True, errors="replace",
                             stdin=subprocess.DEVNULL, timeout=60, check=False)
        version = f"{run.returncode}\n{run.stdout}{run.stderr}"[:4000]
    except (OSError, subprocess.SubprocessError) as err:
        version = f"unknown ({type(err).__name__})"
    blob = json.dumps([real, stamp, version, list(cc[1:]), list(FLAGS)])
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


_NO_COMPILER = ("no C compiler found: $CC is not set, none of cc, gcc, clang is on PATH and the "
                "ziglang package is not installed. Install a C compiler (e.g. apt-get install gcc, "
                "xcode-select --install), or pip install 'porthamiltonian[c]' (a compiler from the "
                "package index), or choose the numba or python back end")


#: ``(kernels, log_as, advice) -> object files``: the objects a library built outside the C back
#: end links (an FMU's binary: the integration loops with hidden entry points and the kernels'
#: objects, :func:`loop_source`), from the compiled-model cache, which a later stage keeps:
#: :func:`porthamiltonian.compiler.fmu_objects`, set here when :mod:`porthamiltonian.compiler`
#: is imported (a model can be exported only once it has compiled it). None before.
linked_objects: Callable[[Sequence[str], Path, str], tuple[Path, ...]] | None = None


def object_key(text: str) -> str:
    """The cache key of an object compiled from ``text`` (by :func:`compile_object`): a hash of
    the text, the compiler's identity (:func:`compiler_identity`: its executable, version and
    flags) and the platform, so that an object is never linked by another compiler."""
    blob = "\0".join([compiler_identity() or "none", sys.platform, platform.machine(), text])
    return hashlib.sha256(blob.encode()).hexdigest()[:32]


def compile_object(text: str, name: str, log_dir: Path | None = None,
                   log_as: Path | None = None, advice: str = ADVICE) -> tuple[bytes, float]:
    """Compile the C source ``text`` (e.g. a kernel, sources.c_object_source) into a
    position-independent object file; (its bytes, seconds). Errors as :func:`build` (the log
    named after ``log_as``, e.g. the model's unit that needs the object, when given)."""
    with tempfile.TemporaryDirectory(prefix="porthamiltonian-cc-") as tmp:
        source = Path(tmp) / f"{name}.c"
        write_source(source, text)
        return build(source, log_dir, (), object_only=True, log_as=log_as, advice=advice)


def build(source: Path, log_dir: Path | None, objects: tuple[Path, ...] = (),
          object_only: bool = False, log_as: Path | None = None,
          advice: str = ADVICE) -> tuple[bytes, float]:
    """Compile the translation unit ``source`` into a shared library linked with ``objects``
    (or, ``object_only``, into an object file); (its bytes, seconds).

    The library is written in a private temporary folder (the caller stores it). On failure a
    :class:`~porthamiltonian.errors.CompilerError` shows the command and the file holding the
    compiler's output: ``log_dir/<source>.log`` (the cache entry; ``<log_as>.log`` when given),
    or a kept temporary file when ``log_dir`` is None; then ``advice``."""
    flags = [f for f in FLAGS if f != "-shared"] + ["-c"] if object_only else list(FLAGS)
    return _run(flags, (source,), () if object_only else (*objects,),
                f"{source.stem}{'.o' if object_only else _SUFFIX}", source.name,
                log_as or source, log_dir, advice)


def link(objects: tuple[Path, ...], name: str, log_dir: Path | None, log_as: Path,
         advice: str = ADVICE) -> tuple[bytes, float]:
    """Link the object files ``objects`` (a model's unit compiled by :func:`start_object`, the
    loops', the kernels') into the shared library ``name`` (its file name without the suffix);
    (its bytes, seconds). Errors as :func:`build`, the log named after ``log_as`` (the model's
    unit)."""
    return _run(list(FLAGS), (), objects, f"{name}{_SUFFIX}", f"{name}{_SUFFIX}", log_as,
                log_dir, advice)


def _run(flags: list[str], sources: tuple[Path, ...], objects: tuple[Path, ...], out_name: str,
         what_built: str, log_as: Path, log_dir: Path | None, advice: str) -> tuple[bytes, float]:
    """Run the C compiler with ``flags`` on ``sources`` (and, for a library, ``objects`` and
    the math library) into ``out_name`` in a private temporary folder: (its bytes, seconds);
    a failure raises CompilerError naming ``what_built``, its output logged (:func:`build`)."""
    cc = compiler()
    if cc is None:
        raise CompilerError(_NO_COMPILER)
    with tempfile.TemporaryDirectory(prefix="porthamiltonian-cc-") as tmp:
        out = Path(tmp) / out_name
        command = [*cc, *flags, "-o", str(out), *map(str, sources),
                   *((*map(str, objects), "-lm") if "-shared" in flags else ())]
        start = time.perf_counter()
        try:
            run = subprocess.run(command, capture_output=True, text=True, errors="replace",
                                 stdin=subprocess.DEVNULL, check=False)
            failure = None if run.returncode == 0 and out.is_file() else (
                f"exit status {run.returncode}", run.stdout + run.stderr)
        except OSError as err:
            failure = ("could not be started", f"{err}\n")
        seconds = time.perf_counter() - start
        if failure is None:
            return out.read_bytes(), seconds
    what, output = failure
    log = _write_log(log_as, log_dir, command, what, output)
    raise CompilerError(f"the C compiler failed ({what}) building {what_built}: "
                        f"{shlex.join(command)}; its output is in {log}. {advice}")


def _write_log(source: Path, log_dir: Path | None, command: list[str], what: str,
               output: str) -> Path | str:
    """The file holding the compiler's ``output`` (in ``log_dir`` when given and writable, else
    a kept temporary file); when no file can be written, the output itself, cut to its end."""
    text = f"command: {shlex.join(command)}\n{what}\n\n{output or '(no output)'}\n"
    if log_dir is not None:
        path = log_dir / f"{source.stem}.log"
        try:
            tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
            tmp.write_text(text)
            os.replace(tmp, path)
            return path
        except OSError:
            pass
    try:
        fd, name = tempfile.mkstemp(prefix=f"porthamiltonian-{source.stem}-", suffix=".log")
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
    except OSError as err:           # nowhere to write (a full disk): the output in the message
        return f"(no file: {err.strerror or err}) {output.strip()[-2000:] or '(no output)'}"
    return Path(name)


# --- loading ----------------------------------------------------------------------------------------
def _pointer(array: np.ndarray) -> int:
    return array.ctypes.data


def _vector(value: Any, size: int, what: str) -> np.ndarray:
    """``value`` as a contiguous float64 vector of at least ``size`` entries (the C functions
    read that many)."""
    array = np.ascontiguousarray(value, dtype=np.float64)
    if array.ndim != 1 or array.shape[0] < size:
        raise OptionError(f"{what} must be a vector of {size} floats, got shape {array.shape}")
    return array


def _subnormals() -> bool:
    """True while the process computes with subnormal numbers (no flush-to-zero)."""
    return sys.float_info.min / 2 > 0.0


#: the libraries this process loaded: path -> (device, inode) of the file then
_LOADED: dict[str, tuple[int, int]] = {}


def _fresh_path(path: Path) -> Path:
    """``path``, or, when this process loaded another file by that path before (a library
    replaced since: rebuilt after failing its check), a private copy under a new name: the
    dynamic loader would otherwise hand back the library it loaded first."""
    info = path.stat()
    ident = (info.st_dev, info.st_ino)
    before = _LOADED.setdefault(str(path), ident)
    if before == ident:
        return path
    folder = Path(tempfile.mkdtemp(prefix="porthamiltonian-lib-"))
    atexit.register(shutil.rmtree, folder, True)
    copy = folder / path.name
    shutil.copyfile(path, copy)
    return copy


def _check(lib: ctypes.CDLL, path: Path, key: str | None, subnormals: bool) -> None:
    """The self-check of a loaded library (see :func:`load`); CompilerError on failure, after
    restoring the floating-point environment when loading it changed it."""
    try:
        selftest, reset, model_key = lib.ph_selftest, lib.ph_fp_default, lib.ph_model_key
    except AttributeError as err:
        raise CompilerError(f"{path}: not a library of this project's C back end (it lacks "
                            f"{str(err).split(':')[-1].strip()})") from None
    selftest.restype, selftest.argtypes = ctypes.c_int, (ctypes.c_double, ctypes.c_double)
    reset.restype, reset.argtypes = None, ()
    model_key.restype, model_key.argtypes = ctypes.c_char_p, ()
    flushed = subnormals and not _subnormals()
    if flushed:
        reset()
    if flushed or selftest(math.nan, 1.0) != 1:
        what = ("it turned off subnormal numbers in the whole process when loaded; " if flushed
                else "")
        raise CompilerError(f"{path}: built with floating-point flags that break IEEE arithmetic "
                            f"({what}NaN, overflow or rounding behave otherwise: -ffast-math or "
                            "similar); remove such flags from CC")
    if key is not None and model_key() != key.encode():
        raise CompilerError(f"{path}: the library is that of another model "
                            f"({model_key().decode(errors='replace')!r}, not {key!r})")


def load(path: Path, shapes: dict[str, tuple[int, ...]], n_params: int,
         key: str | None = None) -> Functions:
    """Load the library at ``path`` (verified by the caller) and wrap its functions.
    ``shapes``: the result shape of each function (``rhs``, ``jac``, ..., ``matrix_<k>``).

    The library checks itself first; a :class:`~porthamiltonian.errors.CompilerError` says why
    it cannot be used: not a loadable library, not one of this back end, built with flags that
    break IEEE arithmetic (``ph_selftest``; and a library whose loading turned off subnormal
    numbers for the whole process, as ``-ffast-math`` does, gets the default floating-point
    environment restored), the library of another model (``key``: the model's cache key), or a
    layout that is not the model's."""
    n = shapes["rhs"][0]
    expected = (n, n_params, shapes["guards"][0], shapes["outputs"][0],
                sum(1 for name in shapes if name.startswith("matrix_")))
    lib = _opened(path, key, expected, len(expected))

    many = _many(lib)

    def function(name: str) -> Callable:
        return _function(getattr(lib, f"ph_{name}"), name, shapes[name], n, n_params, many)

    initial_fn = lib.ph_initial
    initial_fn.restype = None
    initial_fn.argtypes = (ctypes.c_void_p, ctypes.c_void_p)

    def initial(p: Any) -> np.ndarray:
        p = _vector(p, n_params, "p")
        out = np.empty(shapes["initial"])
        initial_fn(_pointer(p), _pointer(out))
        return out

    n_guards = shapes["guards"][0]
    loops = {name: _loop(getattr(lib, f"ph_integrate_{symbol}"), n, n_params, n_guards)
             for name, symbol in LOOPS.items()}
    n_gain = shapes["jac_p"][1] if "jac_p" in shapes else 0
    variational = {name: _loop(getattr(lib, f"ph_integrate_{symbol}_variational"), n,
                               n_params, n_guards, variational=True, n_gain=n_gain)
                   for name, symbol in LOOPS.items()}
    matrices = tuple(function(f"matrix_{k}") for k in range(expected[4]))
    extra = {name: function(name) for name in shapes
             if name not in (*_NAMES, "initial") and not name.startswith("matrix_")}
    # (ctypes never unloads a library: the functions stay valid)
    rhs, jac, energy, outputs, guards = (function(name) for name in _NAMES)
    return Functions("c", rhs, jac, energy, outputs, guards, initial, matrices, loops,
                     variational, extra)


def load_addon(path: Path, shapes: dict[str, tuple[int, ...]], n: int, n_params: int,
               key: str) -> dict[str, Callable]:
    """Load the library of an add-on (:func:`addon_unit`; verified by the caller) and wrap its
    functions, by name: ``shapes``, their result shapes; ``n``, ``n_params``: the model's
    state and parameter-vector lengths, which its layout must have. The checks of :func:`load`
    (the self-check, the key ``<model key>_<add-on>``, the layout's first two sizes) raise a
    CompilerError saying why it cannot be used."""
    lib = _opened(path, key, (n, n_params), 2)
    return {name: _function(getattr(lib, f"ph_{name}"), name, shape, n, n_params)
            for name, shape in shapes.items()}


def _opened(path: Path, key: str | None, expected: tuple[int, ...], compared: int) -> ctypes.CDLL:
    """The library at ``path`` loaded, its self-check passed (:func:`_check`) and the first
    ``compared`` sizes of its ``ph_layout`` equal to ``expected``; CompilerError otherwise."""
    subnormals = _subnormals()
    try:
        lib = ctypes.CDLL(str(_fresh_path(Path(path))))
    except OSError as err:
        raise CompilerError(f"{path}: not a loadable shared library ({err})") from None
    _check(lib, path, key, subnormals)
    layout = (ctypes.c_int64 * 5)()
    lib.ph_layout(layout)
    if tuple(layout)[:compared] != expected:
        raise CompilerError(f"{path}: the library's layout ({dict(zip(_SIZES, layout))}) is not the "
                            f"model's ({dict(zip(_SIZES, expected))})")
    return lib


def _many(lib: ctypes.CDLL) -> Any:
    """The library's ``ph_many`` (the loops' object's, :data:`_MANY`), or None for a library
    linked before it was there."""
    try:
        many = lib.ph_many
    except AttributeError:
        return None
    many.restype = None
    many.argtypes = (ctypes.c_void_p, ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p,
                     ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int64)
    return many


def _function(fn: Any, name: str, shape: tuple[int, ...], n: int, n_params: int,
              many: Any = None) -> Callable:
    """The Python face of a generated function ``fn(t, x, p, out)``: ``call(t, x, p)`` returns
    a new array of ``shape``; with the library's ``ph_many`` (:func:`_many`), also
    ``call.many(t, X, p)``: the function at the times ``t`` and the states ``X`` (one row each,
    exactly n values) in one call, an array (len(t), *shape).

    A call's cost is mostly Python's (8 µs per right-hand side of a 2-state model when every
    call asked numpy for its arrays' addresses and ctypes released the GIL around a function
    that runs for nanoseconds). The fast path: ``x`` and ``p`` that are float64 vectors of
    exactly the lengths the function reads are copied into buffers whose addresses were taken
    once (a memoryview copy, which refuses any other format or shape), the function is called
    through a prototype that keeps the GIL (it returns within microseconds), and a copy of the
    output buffer is returned. Anything else (lists, longer vectors, other dtypes), and a call
    while another thread holds the buffers, takes the general path, which converts and checks
    (OptionError for what is not a vector of at least that many floats)."""
    fn.restype = None
    fn.argtypes = (ctypes.c_double, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)
    address = ctypes.cast(fn, ctypes.c_void_p).value
    if address is None:
        raise CompilerError(f"the library's function {name!r} is a null pointer")
    fast = ctypes.PYFUNCTYPE(None, ctypes.c_double, ctypes.c_void_p, ctypes.c_void_p,
                             ctypes.c_void_p)(address)
    bx, bp, out = np.zeros(n), np.zeros(n_params), np.zeros(shape)
    mx, mp = bx.data, bp.data                   # memoryviews of the buffers
    px, pp, po = (ctypes.c_void_p(a.ctypes.data) for a in (bx, bp, out))
    lock = threading.Lock()

    def call(t: float, x: Any, p: Any) -> np.ndarray:
        if lock.acquire(False):
            try:
                mx[:] = x
                mp[:] = p
            except (TypeError, ValueError):
                pass                            # not such vectors: the general path
            else:
                fast(t, px, pp, po)
                return out.copy()
            finally:
                lock.release()
        x = _vector(x, n, "x")
        p = _vector(p, n_params, "p")
        result = np.empty(shape)
        fn(t, _pointer(x), _pointer(p), _pointer(result))
        return result

    call.__name__ = name
    if many is not None:
        size = int(np.prod(shape))

        def batch(t: Any, xs: Any, p: Any) -> np.ndarray:
            ts = np.ascontiguousarray(t, dtype=float)
            rows = np.ascontiguousarray(xs, dtype=float)
            if ts.ndim != 1 or rows.shape != (len(ts), n):
                raise OptionError(f"{name}.many: {len(ts)} times and a ({len(ts)}, {n}) array "
                                  f"of states, got shapes {ts.shape} and {rows.shape}")
            pv = _vector(p, n_params, "p")
            result = np.empty((len(ts), *shape))
            many(address, len(ts), _pointer(ts), _pointer(rows), n, _pointer(pv),
                 _pointer(result), size)
            return result

        call.many = batch               # type: ignore[attr-defined]
    return call


def _loop(entry: Any, n: int, n_params: int, n_guards: int, variational: bool = False,
          n_gain: int = 0) -> Callable:
    """The Python face of a compiled loop: the calling convention of
    porthamiltonian/integrators/rosenbrock_loop.py (same arguments, same 15-tuple; with
    ``variational`` the arguments phi0 and gain (its rows: none, or one per column of the
    library's ``jac_p``, ``n_gain``) and the 18-tuple). The stored points (times, states,
    events, Φ) come in buffers of the thread's, reused by its next call of this loop (a segment
    between two events is short: a fresh 4096-point buffer per call cost more than the
    segment's Python work); the caller copies what it keeps."""
    c_int64, c_double, c_void_p = ctypes.c_int64, ctypes.c_double, ctypes.c_void_p
    local = threading.local()
    entry.restype = ctypes.c_int
    entry.argtypes = (c_double, c_void_p, c_double, c_void_p, c_double, c_void_p, c_double,
                      c_double, c_void_p, c_void_p, c_int64, c_int64, c_double, c_int64, c_double,
                      c_int64, c_int64, c_double, c_void_p, c_void_p, c_void_p, c_void_p, c_void_p,
                      c_void_p, c_void_p) + ((c_int64, c_void_p, c_int64, c_void_p, c_void_p,
                                              c_void_p, c_void_p) if variational else ())

    def integrate(t0: float, y0: Any, t_end: float, p: Any, rtol: float, atol: Any, h0: float,
                  hmax: float, directions: Any, terminal: Any, mask_index: int, mask_sign: float,
                  n_model: int, bound: float, max_steps: int, store_cap: int, tgrad_step: float,
                  phi0: Any = None, gain: Any = None) -> tuple[Any, ...]:
        y0 = _vector(y0, n, "y0")
        p = _vector(p, n_params, "p")
        atol = _vector(atol, n, "atol")
        directions = np.ascontiguousarray(directions, dtype=np.int64)
        terminal = np.ascontiguousarray(terminal, dtype=np.uint8)
        g = directions.shape[0]
        store_cap = int(store_cap)
        if g > n_guards or terminal.shape != (g,) or not -1 <= int(mask_index) < max(g, 1):
            raise OptionError(f"{g} event directions for {n_guards} guards (terminal flags "
                             f"{terminal.shape}, mask index {mask_index})")
        if store_cap < 2 or not 0 < int(n_model) <= n:
            raise OptionError(f"store_cap {store_cap} (at least 2), n_model {n_model} (1..{n})")
        m = 0
        if variational:
            phi0 = np.ascontiguousarray(phi0, dtype=np.float64)
            if phi0.ndim != 2 or phi0.shape[0] != n:
                raise OptionError(f"phi0 must have shape ({n}, m), got {phi0.shape}")
            m = phi0.shape[1]
            gain = np.ascontiguousarray(np.zeros((0, m)) if gain is None else gain,
                                        dtype=np.float64)
            if gain.ndim != 2 or gain.shape[1] != m or gain.shape[0] not in (0, n_gain):
                raise OptionError(f"gain must have shape (0 or {n_gain}, {m}), got {gain.shape}")
        buffers = getattr(local, "buffers", None)
        if buffers is None or buffers[0] != (store_cap, m):
            buffers = ((store_cap, m), np.empty(store_cap), np.empty((store_cap, n)),
                       np.empty(store_cap), np.empty(store_cap, dtype=np.int64),
                       np.empty((store_cap, n, m)))
            local.buffers = buffers
        _, ts, ys, ev_t, ev_k, phis = buffers
        th = np.empty(2)
        y = np.empty(n)
        counts = np.empty(7, dtype=np.int64)
        extra: tuple[Any, ...] = ()
        if variational:
            phi = np.empty((n, m))
            phi_error = np.zeros(1)
            extra = (m, _pointer(phi0), gain.shape[0], _pointer(gain), _pointer(phis),
                     _pointer(phi), _pointer(phi_error))
        status = entry(t0, _pointer(y0), t_end, _pointer(p), rtol, _pointer(atol), h0, hmax,
                       _pointer(directions), _pointer(terminal), g, int(mask_index), mask_sign,
                       int(n_model), bound, int(max_steps), store_cap, tgrad_step, _pointer(ts),
                       _pointer(ys), _pointer(ev_t), _pointer(ev_k), _pointer(th), _pointer(y),
                       _pointer(counts), *extra)
        c = [int(v) for v in counts]
        out = (status, float(th[0]), y, ts, ys, c[0], c[1], c[2], c[3], c[4], ev_t, ev_k, c[5],
               float(th[1]), c[6])
        return out + (phi, phis, float(phi_error[0])) if variational else out

    return integrate


__all__ = ["FLAGS", "Pending", "addon_unit", "build", "compile_object", "compiler",
           "compiler_identity", "library_name", "library_prefix", "link", "load", "load_addon",
           "loop_source", "model_unit", "object_key", "start_object", "translation_unit"]
