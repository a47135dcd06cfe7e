"""Running independent tasks on all local cores or on an existing Dask cluster.

``run_tasks(fn, argument_tuples, scheduler, workers)`` is the one scale-out path of the
commands that repeat the same work many times (``evaluate``'s seeds, ``monitor``'s fleet of
loops). ``fn`` must be a module-level function and its arguments plain data, so they travel
to any worker; a task's result never depends on where it ran.
"""
from __future__ import annotations

import multiprocessing
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed

__all__ = ["run_tasks"]


def _progress(done: int, total: int, started: float, unit: str) -> None:
    if not sys.stderr.isatty() and done not in (total,) and done % max(1, total // 10):
        return
    width = 30
    filled = int(width * done / total)
    rate = (time.perf_counter() - started) / max(done, 1)
    eta = rate * (total - done)
    print(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} {unit}, ~{eta:.0f} s left",
          end="" if done < total else "\n", file=sys.stderr, flush=True)


def _gather(completed, total: int, started: float, progress: bool, unit: str) -> list:
    """Results of finished futures (local or Dask), in completion order."""
    results = []
    for future in completed:
        results.append(future.result())
        if progress:
            _progress(len(results), total, started, unit)
    return results


def run_tasks(fn, tasks: list, scheduler=None, workers=None, progress: bool = False,
              unit: str = "tasks") -> tuple[list, str]:
    """``fn(*task)`` for every task; returns (results in completion order, where they ran).

    scheduler: None (local processes, ``workers`` of them, default all cores), a Dask
    scheduler address (tcp://host:8786), or a ``dask.distributed.Client``."""
    tasks = [tuple(t) for t in tasks]
    started = time.perf_counter()
    if not tasks:
        return [], "nowhere (no tasks)"
    if scheduler is None:
        n = min(workers or os.cpu_count() or 1, len(tasks))
        if n == 1:  # no pool to start: one process is this one
            results = []
            for t in tasks:
                results.append(fn(*t))
                if progress:
                    _progress(len(results), len(tasks), started, unit)
            return results, "this process"
        # forkserver, not fork: the parent may hold threads (BLAS, a Dask client, the test
        # runner), and a forked child inheriting a held lock deadlocks.
        context = multiprocessing.get_context("forkserver")
        # Workers fork from a server that imported fn's module once, instead of each
        # importing it (numpy, pandas, the core) anew.
        context.set_forkserver_preload([fn.__module__])
        with ProcessPoolExecutor(max_workers=n, mp_context=context) as pool:
            futures = [pool.submit(fn, *t) for t in tasks]
            return _gather(as_completed(futures), len(tasks), started, progress, unit), f"{n} local processes"
    try:
        from dask.distributed import Client, as_completed as dask_completed
    except ImportError:
        raise ValueError("--scheduler: needs Dask (pip install 'mpmpp[cluster]')") from None
    client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    try:
        futures = client.map(fn, *zip(*tasks), pure=False)
        return (_gather(dask_completed(futures), len(tasks), started, progress, unit),
                f"Dask cluster {client.scheduler.address}")
    finally:
        if client is not scheduler:
            client.close()
