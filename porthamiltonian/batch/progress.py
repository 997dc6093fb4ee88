"""Progress of long runs: work ticks from inside analyses, sweep and activity displays.

Work ticks
    An analysis reports units of work as it does them — ``tick("stride")`` after each stride of
    a walker, for instance — whether or not anyone is watching: :func:`tick` costs a context
    variable lookup when no display is active. A display installs a *sink* with
    :func:`counting`. Worker processes of a sweep's own process pool send their ticks to the
    sweep's display through a pipe (:class:`TickChannel`), so a sweep of two 50-second cases
    shows strides moving instead of "0/2" for 50 seconds.

Displays (on stderr; stdout stays clean for JSON)
    :class:`SweepProgress` — cases done of the total, failures, the ticks of the cases in
    flight, rate and ETA: a tqdm bar on a terminal, else a text line every ``interval`` seconds
    and at the end. :func:`activity` — one analysis in this process (``walker gait``): a tqdm
    counter of its ticks on a terminal, nothing otherwise.
"""
from __future__ import annotations

import contextlib
import math
import sys
import time
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from contextvars import ContextVar
from typing import IO, Any

from .errors import SweepError

__all__ = ["SweepProgress", "TickChannel", "activity", "counting", "install_worker_sink", "tick"]

Sink = Callable[[str, int], None]
_SINK: ContextVar[Sink | None] = ContextVar("porthamiltonian_batch_progress_sink", default=None)


def tick(what: str, n: int = 1) -> None:
    """Count ``n`` units of work named ``what`` (singular, e.g. ``"stride"``) towards the active
    progress display, if any."""
    sink = _SINK.get()
    if sink is not None:
        sink(what, n)


@contextlib.contextmanager
def counting(sink: Sink) -> Iterator[None]:
    """Send the :func:`tick` calls made inside the block to ``sink(what, n)``."""
    token = _SINK.set(sink)
    try:
        yield
    finally:
        _SINK.reset(token)


def _plural(what: str, n: int) -> str:
    return f"{n} {what}{'' if n == 1 else 's'}"


def work_text(counts: Counter) -> str:
    """``Counter({"stride": 214})`` -> ``"214 strides"``."""
    return ", ".join(_plural(w, n) for w, n in sorted(counts.items()) if n)


class TickChannel:
    """Ticks from worker processes to the sweep's display: a one-way pipe whose writing end the
    workers receive (pool initializer). Each message is one short ``write`` (well below the
    pipe's atomic size), so workers share the pipe without a lock — a worker killed while
    writing cannot leave the pipe locked or a message half-written. Workers batch their ticks
    and send at most every ``interval`` seconds (:func:`install_worker_sink`)."""

    interval = 0.2

    def __init__(self, mp_context: Any):
        self.reader, self.writer = mp_context.Pipe(duplex=False)

    def drain(self) -> Counter:
        """The ticks received since the last call."""
        got: Counter = Counter()
        try:
            while self.reader.poll():
                for line in self.reader.recv_bytes().decode().splitlines():
                    what, _, n = line.rpartition("\t")
                    got[what] += int(n)
        except (EOFError, OSError, ValueError):  # pragma: no cover - a worker died mid-run
            pass
        return got

    def close(self) -> None:
        """Close both ends of the pipe."""
        self.reader.close()
        self.writer.close()


class _WorkerSink:
    def __init__(self, writer: Any, interval: float):
        self.writer, self.interval = writer, interval
        self.pending: Counter = Counter()
        self.last = time.monotonic()

    def __call__(self, what: str, n: int) -> None:
        self.pending[what] += n
        if time.monotonic() - self.last >= self.interval:
            self.flush()

    def flush(self) -> None:
        if self.pending:
            text = "\n".join(f"{w[:60]}\t{n}" for w, n in self.pending.items())
            self.pending.clear()
            try:
                self.writer.send_bytes(text.encode())
            except OSError:  # pragma: no cover - the sweep is gone
                pass
        self.last = time.monotonic()


def install_worker_sink(writer: Any) -> _WorkerSink:
    """In a worker process: send this process's ticks through ``writer`` (the writing end of a
    :class:`TickChannel`) for the rest of its life. The sink's ``flush()`` sends what is
    pending (the runner calls it after each case)."""
    sink = _WorkerSink(writer, TickChannel.interval)
    _SINK.set(sink)
    return sink


def _duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    seconds = round(seconds)
    h, rest = divmod(seconds, 3600)
    m, s = divmod(rest, 60)
    return f"{h}h{m:02d}m{s:02d}s" if h else (f"{m}m{s:02d}s" if m else f"{s}s")


def _tqdm() -> Any:
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm


MODES = ("auto", "bar", "text", "none")


class SweepProgress:
    """Progress of a sweep on ``stream`` (stderr): ``mode`` "auto" (a tqdm bar when tqdm is
    installed and the stream is a terminal, else text lines), "bar", "text" (a line every
    ``interval`` seconds and at the end) or "none". ``initial``: statuses of the cases done
    before this run; statuses in ``ok_statuses`` are not counted as failures."""

    def __init__(self, mode: str | bool | None, total: int, initial: Counter, desc: str,
                 ok_statuses: Sequence[str], interval: float, stream: IO[str] | None = None):
        self.total, self.desc, self.ok = total, desc, set(ok_statuses)
        self.counts = Counter(initial)
        self.work: Counter = Counter()
        self.initial = sum(initial.values())
        self.stream = stream or sys.stderr
        self.interval = interval
        self.t0 = time.monotonic()
        self.last = self.t0
        self.bar = None
        if mode is True:
            mode = "auto"
        if mode in (None, False, "none"):
            self.mode = "none"
            return
        if mode not in MODES:
            raise SweepError(f"progress must be 'auto', 'bar', 'text' or 'none', got {mode!r}")
        tqdm = _tqdm() if mode in ("auto", "bar") else None
        tty = getattr(self.stream, "isatty", lambda: False)()
        if tqdm is not None and (mode == "bar" or tty):
            self.bar = tqdm(total=total, initial=self.initial, desc=desc, unit="case",
                            file=self.stream, dynamic_ncols=True)
            self.mode = "bar"
            self._postfix()
            return
        self.mode = "text"
        self._line()

    @property
    def failures(self) -> Counter:
        """The counts of the statuses that are not successes."""
        return Counter({k: v for k, v in self.counts.items() if k not in self.ok})

    def _failure_text(self) -> str:
        fails = self.failures
        n = sum(fails.values())
        detail = ", ".join(f"{k} {v}" for k, v in sorted(fails.items()))
        return f"{n} failed" + (f" ({detail})" if n else "")

    def _postfix(self) -> None:
        if self.bar is not None:
            work = work_text(self.work)
            self.bar.set_postfix_str(self._failure_text() + (f", {work}" if work else ""),
                                     refresh=False)

    def _line(self, final: bool = False) -> None:
        done = sum(self.counts.values())
        elapsed = time.monotonic() - self.t0
        ran = done - self.initial
        rate = ran / elapsed if elapsed > 0 and ran else math.nan
        eta = (self.total - done) / rate if ran else math.inf
        text = f"{self.desc}: {done}/{self.total} cases, {self._failure_text()}"
        work = work_text(self.work)
        if work:
            text += f", {work}"
        if ran:
            per_min = rate * 60
            text += f", {per_min:.0f} cases/min" if per_min >= 100 else f", {per_min:.3g} cases/min"
        text += f", elapsed {_duration(elapsed)}" + ("" if final else f", ETA {_duration(eta)}")
        print(text, file=self.stream, flush=True)
        self.last = time.monotonic()

    def update(self, status: str) -> None:
        """A case finished with ``status``."""
        self.counts[status] += 1
        if self.bar is not None:
            self._postfix()
            self.bar.update(1)
        elif self.mode == "text" and time.monotonic() - self.last >= self.interval:
            self._line()

    def add_work(self, what: str, n: int = 1) -> None:
        """Work ticks of the cases (a :func:`counting` sink)."""
        self.work[what] += n

    def refresh(self) -> None:
        """Called while waiting: redraw the bar (its clock runs), or print the text line when
        ``interval`` has passed."""
        if self.bar is not None:
            self._postfix()
            self.bar.refresh()
        elif self.mode == "text" and time.monotonic() - self.last >= self.interval:
            self._line()

    def close(self) -> None:
        """End the display (the bar's last state, or a last text line)."""
        if self.bar is not None:
            self._postfix()
            self.bar.close()
            self.bar = None
        elif self.mode == "text":
            self._line(final=True)
            self.mode = "none"


class _Activity:
    """What :func:`activity` yields: ``write(message)`` prints a line without breaking the bar."""

    def __init__(self, bar: Any, stream: IO[str]):
        self.bar, self.stream = bar, stream

    def write(self, message: str) -> None:
        if self.bar is not None:
            self.bar.write(message, file=self.stream)
        else:
            print(message, file=self.stream, flush=True)


@contextlib.contextmanager
def activity(desc: str, *, enabled: bool = True, stream: IO[str] | None = None
             ) -> Iterator[_Activity]:
    """Show the :func:`tick` counts of the block as a tqdm counter on ``stream`` (stderr) when
    ``enabled``, tqdm is installed and the stream is a terminal, e.g. ``gait compass_walker, 57
    strides [00:12]``; otherwise show nothing (:meth:`_Activity.write` lines excepted)."""
    stream = stream or sys.stderr
    shown = enabled and getattr(stream, "isatty", lambda: False)()
    tqdm = _tqdm() if shown else None           # (tqdm imported only for a terminal)
    if tqdm is None:
        yield _Activity(None, stream)
        return
    bar = tqdm(desc=desc, unit="", file=stream, dynamic_ncols=True,
               bar_format="{desc}{postfix} [{elapsed}]")
    work: Counter = Counter()

    def sink(what: str, n: int) -> None:
        work[what] += n
        bar.set_postfix_str(work_text(work), refresh=False)
        bar.update(n)

    try:
        with counting(sink):
            yield _Activity(bar, stream)
    finally:
        bar.close()
