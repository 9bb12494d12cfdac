"""Local backend: each task in a fresh worker process, at most ``workers`` at a time.

A fresh process per task isolates faults (a task that crashes native code, runs out of memory or is
killed takes only itself down) and makes its peak memory its own. Processes come from a fork server
that has imported the heavy modules once (``preload``), so a task starts in milliseconds, not seconds.
Workers ignore Ctrl-C: the parent ends them (SIGTERM) when it is interrupted or closed.
"""

from __future__ import annotations

import multiprocessing
import signal
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any, TypeVar

T = TypeVar("T")
R = TypeVar("R")

_JOIN_TIMEOUT_S = 5.0
_NO_RESULT = object()


@dataclass(frozen=True)
class WorkerLost:
    """A task whose worker ended without a result; ``reason`` says how (a signal, an exit code, a lost node)."""

    reason: str


def run_in_processes(tasks: Iterable[T], function: Callable[[T], R], workers: int,
                     preload: Sequence[str] = ()) -> Iterator[tuple[T, R | WorkerLost]]:
    """Yield ``(task, function(task))`` as tasks finish, or ``(task, WorkerLost)`` for a worker that died.

    ``function`` and the tasks must pickle (a module-level function). Closing the iterator (or an
    exception in its consumer, such as KeyboardInterrupt) ends the running workers.
    """
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    method = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
    context = multiprocessing.get_context(method)
    if method == "forkserver":
        context.set_forkserver_preload(list(preload))
    pending = deque(tasks)
    running: dict[Connection, tuple[Any, T]] = {}  # result pipe -> (process, task)
    try:
        while pending or running:
            while pending and len(running) < workers:
                task = pending.popleft()
                reader, writer = context.Pipe(duplex=False)
                process = context.Process(target=_work, args=(function, task, writer), daemon=True)
                process.start()
                writer.close()  # the worker holds the only writer: its death reads as end of file
                running[reader] = (process, task)
            for reader in wait(list(running)):
                process, task = running.pop(reader)
                yield task, _outcome(reader, process)
    finally:
        for reader, (process, _) in running.items():
            process.terminate()
            reader.close()
        for process, _ in running.values():
            process.join(_JOIN_TIMEOUT_S)
            if process.is_alive():
                process.kill()
                process.join()


def _work(function: Callable[[Any], Any], task: Any, writer: Connection) -> None:
    """In the worker: run the task and send its result back."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides what an interruption ends
    signal.signal(signal.SIGTERM, _exit)  # unwind (finally blocks, semaphores released) rather than vanish
    writer.send(function(task))
    writer.close()


def _exit(signum: int, frame: Any) -> None:
    raise SystemExit(128 + signum)


def _outcome(reader: Connection, process: Any) -> Any:
    """The result a worker sent, or how it died."""
    try:
        result = reader.recv()
    except (EOFError, OSError):
        result = _NO_RESULT
    finally:
        reader.close()
    process.join(_JOIN_TIMEOUT_S)
    if process.is_alive():
        process.kill()
        process.join()
    if result is not _NO_RESULT:
        return result
    code = process.exitcode
    if code == 128 + signal.SIGTERM:
        code = -signal.SIGTERM
    if code is not None and code < 0:
        return WorkerLost(f"worker died: killed by {signal.Signals(-code).name}"
                          + (" (out of memory?)" if -code == signal.SIGKILL else ""))
    return WorkerLost(f"worker died: exit code {code} without a result")
