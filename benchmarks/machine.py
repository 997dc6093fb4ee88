"""The machine and software a benchmark ran on (printed at the top of every benchmark)."""
from __future__ import annotations

import os
import platform
import time


def machine_info() -> dict:
    """Date, cores available to this process, CPU model, platform, load average and the versions
    of Python, numpy, scipy, sympy and numba (None when not installed)."""
    import importlib

    cpu = "unknown"
    try:
        with open("/proc/cpuinfo") as fh:
            cpu = next(ln.split(":", 1)[1].strip() for ln in fh if ln.startswith("model name"))
    except (OSError, StopIteration):
        pass
    try:
        nproc = len(os.sched_getaffinity(0))
    except AttributeError:
        nproc = os.cpu_count()
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    info = {"date": time.strftime("%Y-%m-%d %H:%M %Z"), "nproc": nproc, "cpu": cpu,
            "platform": platform.platform(), "python": platform.python_version(),
            "load": " ".join(f"{x:.2f}" for x in load)}
    for name in ("numpy", "scipy", "sympy", "numba"):
        try:
            info[name] = importlib.import_module(name).__version__
        except ImportError:
            info[name] = None
    return info
