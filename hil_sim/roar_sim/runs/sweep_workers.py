"""Where a sweep's runs go: one after another here, on processes forked from this one (a process
per core, each taking run after run), or as Ray tasks (a cluster, or a local Ray started for the
sweep). Each yields the result rows as the runs finish; Ctrl-C ends every process it started."""

from __future__ import annotations

import atexit
import logging
import os
import signal
import socket
import subprocess
import threading
import time
from collections.abc import Callable, Sequence
from contextlib import contextmanager, suppress

from roar_sim import SweepError
from roar_sim.runs.processes import cores, fork_context
from roar_sim.runs.sweep_table import Run, attempt, failed_row

DIED = "the worker running it died (its process ended)"
RAY_STOP_S = 0.1  # [s] for the local Ray's processes to end after SIGTERM, before SIGKILL


RAY_GOODBYE_S = 0.3  # [s] for the driver's goodbye to the local Ray after Ctrl-C, before it is killed


WAIT_SLICE_S = 0.1  # [s] longest wait for Ray results without looking for Ctrl-C


CONNECT_TIMEOUT_S = 5.0  # [s] for a Ray cluster's address to answer


def rows_here(todo: Sequence[Run], fn: Callable[[Run], dict]):
    for run in todo:
        yield attempt(fn, run)


def rows_on_processes(todo: Sequence[Run], fn: Callable[[Run], dict], workers: int | None):
    """Rows as runs finish on `workers` processes forked from this one, each taking run after run.
    A process that dies breaks the pool (every run it held fails with it): those runs are then
    run again each in a process of its own, so only the one that kills its process fails."""
    import concurrent.futures as futures

    from roar_sim.runs import race  # noqa: F401 -- imported once here, inherited by every fork

    context = fork_context()
    count = max(1, min(workers or len(cores()), len(todo)))
    suspects: list[Run] = []
    with _sigint_kept_from_children():  # (Ctrl-C is ours: we end the processes)
        pool = futures.ProcessPoolExecutor(count, mp_context=context)
        pending = {pool.submit(attempt, fn, run): run for run in todo}
    try:
        for done in futures.as_completed(pending):
            try:
                yield done.result()
            except futures.process.BrokenProcessPool:
                suspects.append(pending[done])
        for run in suspects:
            with _sigint_kept_from_children():
                alone = futures.ProcessPoolExecutor(1, mp_context=context)
            try:
                yield alone.submit(attempt, fn, run).result()
            except futures.process.BrokenProcessPool:
                yield failed_row(run, f"BrokenProcessPool: {DIED}")
            finally:
                alone.shutdown()
    finally:
        _end_pool(pool)


def _end_pool(pool) -> None:
    """The pool's processes ended at once (after Ctrl-C, or a generator closed early)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.kill()
    for process in processes:
        process.join(timeout=5)


def rows_on_ray(todo: Sequence[Run], fn: Callable[[Run], dict], address: str | None, workers: int | None):
    ray = import_ray()
    ours = not ray.is_initialized()  # else: the caller's Ray session, left running
    if ours:
        start_ray(address, workers)
    interrupted = False
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(attempt)
        pending = {task.remote(fn, run): run for run in todo}
        while pending:
            # a short timeout: Ray's wait blocks in C++, where Ctrl-C waits until it returns
            ready, _ = ray.wait(list(pending), num_returns=1, timeout=WAIT_SLICE_S)
            for ref in ready:
                run = pending.pop(ref)
                try:
                    yield ray.get(ref)
                except ray.exceptions.RayError as e:  # the worker died: no row from it
                    yield failed_row(run, f"{type(e).__name__}: {DIED}")
    except KeyboardInterrupt:
        interrupted = True
        raise
    finally:
        if ours:
            if address is None:
                _without_grace(ray)
            if address is None and interrupted:
                shutdown_at_once(ray)
            else:
                ray.shutdown()


def shutdown_at_once(ray) -> None:
    """ray.shutdown() after Ctrl-C, ended within about 2 x RAY_GOODBYE_S however busy the machine:
    the driver's goodbye to its raylet (which stops the workers of the job) takes 0.25 s on an
    idle machine and was seen to take seconds on a busy one. If it has not ended by then, the
    local Ray's processes are killed, which ends it; should it still hang, the process leaves it
    behind (and Ray's own shutdown at exit, which would wait for it again)."""
    goodbye = threading.Thread(target=ray.shutdown, name="ray-shutdown", daemon=True)
    goodbye.start()
    goodbye.join(RAY_GOODBYE_S)
    if goodbye.is_alive():
        _kill_local_ray(ray)
        goodbye.join(RAY_GOODBYE_S)
    if goodbye.is_alive():
        atexit.unregister(ray.shutdown)


def _node(ray):
    """The local Ray's node handle (not public API: None where it is not as expected)."""
    node = getattr(getattr(getattr(ray, "_private", None), "worker", None), "_global_node", None)
    return node if isinstance(getattr(node, "all_processes", None), dict) else None


def _kill_local_ray(ray) -> None:
    """SIGKILL to the local Ray's processes and all they started."""
    node = _node(ray)
    # a snapshot (list() of a dict is one step under the GIL): ray.shutdown, still running in its
    # thread, takes processes out of the table meanwhile
    infos = [info for infos in list(node.all_processes.values()) for info in list(infos)] if node else []
    for info in infos:
        for pid in [*descendants(info.process.pid), info.process.pid]:
            with suppress(OSError):
                os.kill(pid, signal.SIGKILL)


def _without_grace(ray) -> None:
    """Have ray.shutdown() stop the processes of the local Ray this sweep started all together:
    SIGTERM to all (each ends what it started), killed if not gone within RAY_STOP_S. By default
    shutdown gives each a second, one after another -- seconds after a Ctrl-C. (The driver still
    says goodbye to them first. Ray's node handle is not public API: without it, the default.)"""
    node = _node(ray)
    if node is None:
        return
    kill = node.kill_all_processes

    def stop_together(**_) -> None:
        processes = [info.process for infos in node.all_processes.values() for info in infos
                     if info.process.poll() is None]
        for process in processes:
            process.terminate()
        deadline = time.monotonic() + RAY_STOP_S
        for process in processes:
            try:
                process.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:  # it and what it started (the raylet's agents)
                for pid in [*descendants(process.pid), process.pid]:
                    with suppress(OSError):
                        os.kill(pid, signal.SIGKILL)
        kill(check_alive=False, allow_graceful=False, wait=False)  # Ray's bookkeeping

    node.kill_all_processes = stop_together


def descendants(pid: int) -> list[int]:
    """The processes `pid` started, and theirs (Linux's /proc; none elsewhere)."""
    parents = {}
    for entry in os.listdir("/proc") if os.path.isdir("/proc") else ():
        with suppress(OSError, ValueError, IndexError):
            with open(f"/proc/{entry}/stat") as f:
                parents[int(entry)] = int(f.read().rsplit(")", 1)[1].split()[1])
    found, todo = [], [pid]
    while todo:
        of = todo.pop()
        children = [p for p, parent in parents.items() if parent == of]
        found += children
        todo += children
    return found


@contextmanager
def _sigint_kept_from_children():
    """Processes (and threads) started within block SIGINT for good: a terminal's Ctrl-C, sent to
    the whole process group, reaches the sweep alone, which then ends its local Ray at once,
    instead of killing Ray's servers under their clients. A Ctrl-C meanwhile waits, pending,
    until the end of the block, and interrupts there."""
    before = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


def start_ray(address: str | None, workers: int | None):
    """Ray, connected: a new local Ray with `workers` CPUs (default: all), or the cluster at
    `address` ("auto": the one started on this machine with `ray start`). SweepError if not."""
    ray = import_ray()
    if address not in (None, "auto"):
        reachable(address)
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")  # nothing leaves the machine unasked
    try:
        if address is None:
            with _sigint_kept_from_children():
                ray.init(num_cpus=workers or os.cpu_count(), include_dashboard=False, log_to_driver=False,
                         logging_level=logging.ERROR)
        else:
            ray.init(address=address, log_to_driver=False, logging_level=logging.ERROR)
    except (ConnectionError, RuntimeError, ValueError) as e:
        where = f"connect to the Ray cluster at {address}" if address else "start a local Ray"
        hint = (" (a cluster with token authentication, `ray start`'s default, needs RAY_AUTH_MODE=token here "
                "and its token in ~/.ray/auth_token or RAY_AUTH_TOKEN)"
                if address and "RAY_AUTH_MODE" not in os.environ else "")
        raise SweepError(f"cannot {where}: {str(e).strip().splitlines()[0]}{hint}") from None
    return ray


def reachable(address: str) -> None:
    """SweepError at once if nothing listens at HOST:PORT (Ray itself would retry for minutes)."""
    host, _, port = address.removeprefix("ray://").rpartition(":")
    if not host or not port.isdigit():
        raise SweepError(f"--address {address}: give HOST:PORT (or ray://HOST:PORT, or auto)")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as e:
        raise SweepError(f"cannot reach the Ray cluster at {address}: {e.strerror or e}") from None


def import_ray():
    try:
        import ray
    except ImportError:
        raise SweepError("--address and --ray run on Ray: pip install 'roar-platform[sweep]' "
                         "(without either, the sweep runs on this machine's cores)") from None
    return ray

