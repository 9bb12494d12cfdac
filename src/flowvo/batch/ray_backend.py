"""Ray backend: the same tasks as Ray tasks (one CPU each, never retried), on a local Ray instance or an
existing cluster. Ray is optional (``pip install 'flowvo[ray]'``) and imported only here, when asked for.

On a cluster every node needs flowvo installed and must see the inputs and the batch output at the same
paths (a shared file system): tasks write each drive's outputs where the driver reads them back.
"""

from __future__ import annotations

import logging
import socket
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from types import ModuleType
from typing import Any, TypeVar

from flowvo.batch.processes import WorkerLost
from flowvo.errors import FlowvoError
from flowvo.optional import import_optional

T = TypeVar("T")
R = TypeVar("R")

CONNECT_TIMEOUT_S = 5.0
_DEFAULT_PORTS = {"ray://": 10001, "": 6379}  # Ray client server, cluster head (GCS)


@contextmanager
def ray_session(address: str) -> Iterator[ModuleType]:
    """Ray, connected for the block. ``address`` "auto": a new Ray instance on this machine, for this batch
    only; otherwise a running cluster's ``HOST:PORT`` or ``ray://HOST:PORT``, found to answer within 5 s
    before connecting. A Ray already initialised by the caller (inside a Ray job) is used as it is and left
    connected; any other connection is closed (a local instance stopped) at the end of the block."""
    ray = import_optional("ray", "--ray", "ray")
    if ray.is_initialized():
        yield ray
        return
    if address != "auto":
        check_reachable(address)
    try:
        ray.init(address="local" if address == "auto" else address, include_dashboard=False, log_to_driver=False,
                 logging_level=logging.ERROR)
    except Exception as error:  # Ray raises ConnectionError, RuntimeError, ValueError, TimeoutError...
        reason = " ".join(str(error).split())[:300]
        raise FlowvoError(f"--ray {address}: cannot connect to Ray: {reason}") from None
    try:
        yield ray
    finally:
        ray.shutdown()


def check_reachable(address: str) -> None:
    """Raise a one-line FlowvoError unless something accepts a TCP connection at ``address`` within 5 s."""
    scheme = "ray://" if address.startswith("ray://") else ""
    host, _, port_text = address[len(scheme):].rpartition(":")
    if not host:
        host, port_text = port_text, str(_DEFAULT_PORTS[scheme])
    try:
        port = int(port_text)
    except ValueError:
        raise FlowvoError(f"--ray {address}: expected auto, HOST:PORT or ray://HOST:PORT") from None
    try:
        socket.create_connection((host.strip("[]"), port), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as error:
        raise FlowvoError(f"--ray {address}: no Ray cluster answers at {host}:{port} "
                          f"({error.strerror or error}); start one with 'ray start --head' or use --ray auto") from None


def run_on_ray(ray: ModuleType, tasks: Iterable[T], function: Callable[[T], R],
               max_in_flight: int | None = None) -> Iterator[tuple[T, R | WorkerLost]]:
    """Yield ``(task, function(task))`` as Ray tasks finish, or ``(task, WorkerLost)`` when a task's worker
    or node died. At most ``max_in_flight`` tasks are submitted at once (default: twice the cluster's CPUs),
    so a million drives never sit in Ray's queue together. Closing the iterator cancels the running tasks."""
    if max_in_flight is None:
        max_in_flight = max(1, 2 * int(ray.cluster_resources().get("CPU", 1)))
    remote = ray.remote(num_cpus=1, max_retries=0)(_call)
    shared_function = ray.put(function)
    pending = deque(tasks)
    running: dict[Any, T] = {}
    try:
        while pending or running:
            while pending and len(running) < max_in_flight:
                task = pending.popleft()
                running[remote.remote(shared_function, task)] = task
            finished, _ = ray.wait(list(running), num_returns=1)
            for ref in finished:
                task = running.pop(ref)
                try:
                    outcome: Any = ray.get(ref)
                except ray.exceptions.RayError as error:
                    outcome = WorkerLost("worker died: " + " ".join(str(error).split())[:300])
                yield task, outcome
    finally:
        for ref in running:
            ray.cancel(ref, force=True)


def _call(function: Callable[[Any], Any], task: Any) -> Any:
    """In a Ray worker: run one task."""
    return function(task)
