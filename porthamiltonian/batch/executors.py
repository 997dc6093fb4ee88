"""Executors for sweeps: a dask.distributed cluster behind the ``--scheduler`` option, and the
width (parallel workers) of any executor.

:func:`open_executor` is the one place a dask client is made: ``scheduler=None`` yields None (the
sweep makes its own process pool), ``"local"`` starts a local cluster of ``workers``
single-threaded worker processes, any other value is a scheduler address (``tcp://host:8786``).
The client (and a local cluster) is closed when the block ends.
"""
from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from concurrent.futures import Executor

from .errors import SweepError

__all__ = ["executor_width", "open_executor"]


@contextlib.contextmanager
def open_executor(scheduler: str | None, workers: int | None = None) -> Iterator[Executor | None]:
    """The executor of a dask.distributed scheduler (see the module docstring), or None."""
    if not scheduler:
        yield None
        return
    if workers is not None and workers < 1:
        raise SweepError(f"--workers must be at least 1, got {workers}")
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise SweepError("--scheduler needs dask.distributed: pip install "
                         "'porthamiltonian[distributed]'") from None
    with contextlib.ExitStack() as stack:
        if scheduler == "local":
            cluster = stack.enter_context(LocalCluster(
                n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                dashboard_address=None))
            client = stack.enter_context(Client(cluster))
        else:
            problem = _address_problem(scheduler)
            if problem is not None:
                raise _malformed(scheduler, problem)
            try:
                client = stack.enter_context(Client(scheduler, timeout=30))
            except OSError as err:
                raise SweepError(f"cannot reach the dask scheduler {scheduler!r}: {err}") from None
            except (ValueError, TypeError) as err:   # dask's words for a malformed address
                raise _malformed(scheduler, str(err)) from None
        yield client.get_executor()


def _malformed(scheduler: str, reason: str) -> SweepError:
    """The error of a scheduler address dask cannot use, with dask's ``reason``."""
    return SweepError(f"--scheduler {scheduler!r} is not a dask scheduler address ({reason}); "
                      "give tcp://host:port, or 'local' for a local cluster")


def _address_problem(scheduler: str) -> str | None:
    """What is wrong with the scheduler address ``scheduler`` in dask's own words (its parsers
    of addresses: an unknown scheme, a TCP/TLS location without a port number or with one that
    is no integer), or None: checked before a client is made, since a client made for a
    malformed address can fail inside dask's event loop (an AssertionError of its loop runner,
    seen after other clients in the process) and leave that loop's thread behind."""
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import get_backend
    try:
        scheme, location = parse_address(scheduler)
        get_backend(scheme)
        if scheme in ("tcp", "tls"):
            parse_host_port(location)
    except (ValueError, TypeError) as err:
        return str(err)
    return None


def executor_width(executor: Executor) -> int:
    """How many cases ``executor`` runs at once: a pool's workers, a dask cluster's threads,
    else the CPU count."""
    width = getattr(executor, "_max_workers", None)
    if isinstance(width, int) and width > 0:
        return width
    client = getattr(executor, "_client", None)      # dask.distributed's ClientExecutor
    if client is not None:
        try:
            return max(1, sum(client.nthreads().values()))
        except Exception:  # noqa: BLE001, S110 - a client that cannot tell: use the CPU count
            pass
    return os.cpu_count() or 1
