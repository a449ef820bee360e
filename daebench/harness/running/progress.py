"""Nothing silent for more than ~2 s: progress of a run, of a reference, of a sweep.

A background thread wakes every ``POLL_S`` and writes what the caller is waiting on, to
stderr (stdout stays for results and ``--json``):

* a single run (:class:`RunProgress`): a bar on simulated time once the driver reports
  it (``progress(t)``, every 0.25 s of wall time). If no report has come ``NOTICE_AFTER``
  seconds after the start, one line says why — the JIT compiles the kernels on first use
  (once; they are cached afterwards) when the compiler's own events say it is compiling
  (:func:`daebench.harness.running.compile_events.compiling`), else that the first step is slow — then,
  until the first report, the elapsed time: on a terminal in the bar's one updating line,
  in a pipe a line every ``TICK_S``. (This file must not name the compiler's decorator:
  the kernel cache is stamped with every source that does.)
* a sweep (:class:`SweepProgress`): finished/total, elapsed, and the runs in flight.

On a terminal these are rich bars; otherwise (a pipe, a log file) plain lines, at most
one every ``TICK_S`` seconds, never wrapped.
"""

from __future__ import annotations

import sys
import threading
import time
from typing import Any, Callable, TextIO

from daebench.harness.running.compile_events import compiling

POLL_S = 0.25
NOTICE_AFTER = 1.0
TICK_S = 1.5
COMPILE_NOTICE = ("no step yet after {s:.1f} s — the numerical kernels are being compiled for their first use "
                  "(about 1–2 min on a first run, once; they are cached for later runs)")
SLOW_NOTICE = ("no step yet after {s:.1f} s (loading the modules and cached kernels, or a slow first step; "
               "nothing is being compiled)")


def _is_terminal(stream: TextIO) -> bool:
    return bool(getattr(stream, "isatty", lambda: False)())


class _Ticker:
    """A daemon thread calling ``beat()`` every POLL_S until stopped."""

    def __init__(self) -> None:
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)
        self.t0 = time.monotonic()

    def _loop(self) -> None:
        while not self._stop.wait(self.poll):
            self.beat()

    poll = POLL_S

    def beat(self) -> None:  # pragma: no cover - overridden
        pass

    def start(self) -> None:
        self.t0 = time.monotonic()
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()
        bar = getattr(self, "_bar", None)  # a subclass's rich bar on a terminal
        if bar is not None:
            bar.stop()

    def __enter__(self) -> Any:
        self.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        self.stop()


class RunProgress(_Ticker):
    """Progress of one run on simulated time; use as a context manager and pass the
    object itself as the driver's ``progress`` callback.

    ``write`` receives plain lines (default: stderr); on a terminal a rich bar is drawn
    instead of time lines. ``notice_after``/``tick`` are for tests."""

    def __init__(self, label: str, t_end: float | None, write: Callable[[str], None] | None = None,
                 terminal: bool | None = None, notice_after: float | None = None, tick: float | None = None) -> None:
        super().__init__()
        self.label, self.t_end = label, (float(t_end) if t_end else None)
        self.notice_after = NOTICE_AFTER if notice_after is None else notice_after
        self.tick = TICK_S if tick is None else tick
        self.poll = min(POLL_S, self.tick / 2)
        self.t: float | None = None
        self.noticed = False
        self._last_line = 0.0
        self._write = write or (lambda s: print(s, file=sys.stderr, flush=True))
        self.terminal = _is_terminal(sys.stderr) if terminal is None and write is None else bool(terminal)
        self._bar = None

    def __call__(self, t: float) -> None:
        self.t = float(t)

    def retarget(self, label: str, t_end: float) -> None:
        """Name the run and its end time once they are known (the reporter may start
        earlier, so that loading and compiling are not silent)."""
        self.label, self.t_end = label, float(t_end)
        if self._bar is not None:
            self._bar.update(self._task, description=label, total=self.t_end)

    def start(self) -> None:
        self._last_line = time.monotonic()
        if self.terminal:
            from rich.console import Console  # lazy: rich, only when a terminal shows the bar
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn  # lazy: as above

            self._bar = Progress(TextColumn("{task.description}"), BarColumn(),
                                 TextColumn("t = {task.completed:.4g} / {task.total:.4g} s"), TimeElapsedColumn(),
                                 console=Console(stderr=True), transient=True)
            self._task = self._bar.add_task(self.label, total=self.t_end or 1.0)
            self._bar.start()
        super().start()

    def line(self, text: str) -> None:
        self._last_line = time.monotonic()
        if self._bar is not None:
            self._bar.console.print(text, soft_wrap=True, highlight=False, markup=False)
        else:
            self._write(text)

    def beat(self) -> None:
        now = time.monotonic()
        elapsed = now - self.t0
        if self.t is None:
            compiling_now = compiling()
            if not self.noticed and elapsed >= self.notice_after:
                self.noticed = True
                self.line(f"{self.label}: " + (COMPILE_NOTICE if compiling_now else SLOW_NOTICE).format(s=elapsed))
            elif self.noticed:
                what = "compiling" if compiling_now else "no step yet"
                if self._bar is not None:  # a terminal: one line that updates, not a line per tick
                    self._bar.update(self._task, description=f"{self.label}: {what}, {elapsed:.0f} s")
                elif now - self._last_line >= self.tick:
                    self.line(f"{self.label}: {what}, {elapsed:.0f} s elapsed")
            return
        if self.noticed and self._bar is not None and self._bar.tasks[0].description != self.label:
            self._bar.update(self._task, description=self.label)
        end = self.t_end or float("nan")
        if self._bar is not None:
            self._bar.update(self._task, completed=min(self.t, end))
        elif now - self._last_line >= self.tick:
            self.line(f"{self.label}: t = {self.t:.4g} of {end:.4g} s ({100.0 * self.t / end:.0f} %), "
                      f"{elapsed:.0f} s elapsed")


def run_progress_factory(enabled: bool = True) -> Callable[[str, float], Any] | None:
    """``factory(label, t_end)`` → a :class:`RunProgress` context, or None when disabled."""
    return (lambda label, t_end: RunProgress(label, t_end)) if enabled else None


class SweepProgress(_Ticker):
    """Finished/total of a sweep and what it waits on. ``update(row)`` after each row,
    ``running(specs)`` with the runs in flight."""

    def __init__(self, title: str, total: int, write: Callable[[str], None] | None = None,
                 terminal: bool | None = None, tick: float = TICK_S) -> None:
        super().__init__()
        self.title, self.total, self.tick = title, int(total), tick
        self.done = 0
        self.waiting: list[str] = []
        self._last_line = 0.0
        self._write = write or (lambda s: print(s, file=sys.stderr, flush=True))
        self.terminal = _is_terminal(sys.stderr) if terminal is None and write is None else bool(terminal)
        self._bar = None

    def start(self) -> None:
        self._last_line = time.monotonic()
        if self.terminal:
            from rich.console import Console  # lazy: rich, only when a terminal shows the bar
            from rich.progress import (BarColumn, MofNCompleteColumn, Progress,  # lazy: as above
                                       TextColumn, TimeElapsedColumn)

            self._bar = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                                 TimeElapsedColumn(), TextColumn("{task.fields[waiting]}"),
                                 console=Console(stderr=True), transient=False)
            self._task = self._bar.add_task(self.title, total=self.total, waiting="")
            self._bar.start()
        super().start()

    def running(self, specs: list[Any]) -> None:
        self.waiting = [getattr(s, "label", str(s)) + _step(s) for s in specs]

    def update(self, row: dict[str, Any]) -> None:
        self.done += 1
        text = f"[{self.done}/{self.total}] {row.get('label', '')}{_step_row(row)}: {row.get('status')}"
        if self._bar is not None:
            self._bar.update(self._task, advance=1)
        else:
            self._last_line = time.monotonic()
            self._write(text)

    def beat(self) -> None:
        wait = "waiting on " + "; ".join(self.waiting) if self.waiting else ""
        if self._bar is not None:
            self._bar.update(self._task, waiting=wait)
        elif wait and time.monotonic() - self._last_line >= 5 * self.tick:
            self._last_line = time.monotonic()
            self._write(f"[{self.done}/{self.total}] {time.monotonic() - self.t0:.0f} s elapsed, {wait}")


def _step(spec: Any) -> str:
    v = getattr(spec, "varied", {}) or {}
    return "".join(f" {k}={v[k]:g}" for k in ("h", "tol") if k in v)


def _step_row(row: dict[str, Any]) -> str:
    return "".join(f" {k}={row[k]:g}" for k in ("h", "tol") if isinstance(row.get(k), float) and row[k] == row[k])
