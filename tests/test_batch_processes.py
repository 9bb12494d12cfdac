"""The local backend: one fresh process per task, a worker that dies fails only its task, and closing the
runner (what Ctrl-C does) ends the workers still running."""

import multiprocessing
import os
import signal
import time

from flowvo.batch.processes import WorkerLost, run_in_processes


def pid_or_die(task: int) -> int:
    """Task 2 is killed as the kernel kills a process out of memory; task 3 exits without a word."""
    if task == 2:
        os.kill(os.getpid(), signal.SIGKILL)
    if task == 3:
        os._exit(7)
    return os.getpid()


def sleep_unless_first(task: int) -> int:
    if task:
        time.sleep(60)
    return task


def test_a_killed_worker_fails_only_its_task_and_each_task_has_its_own_process():
    outcomes = dict(run_in_processes([1, 2, 3, 4, 5], pid_or_die, workers=2))
    assert outcomes[2] == WorkerLost("worker died: killed by SIGKILL (out of memory?)")
    assert outcomes[3] == WorkerLost("worker died: exit code 7 without a result")
    pids = [outcomes[task] for task in (1, 4, 5)]
    assert all(isinstance(pid, int) for pid in pids) and len(set(pids)) == 3 and os.getpid() not in pids


def test_closing_the_runner_ends_the_running_workers_at_once():
    start = time.monotonic()
    runner = run_in_processes([0, 1, 2], sleep_unless_first, workers=3)
    assert next(runner) == (0, 0)
    runner.close()
    assert time.monotonic() - start < 20 and not multiprocessing.active_children()
