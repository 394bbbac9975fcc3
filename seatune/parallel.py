"""Independent tasks of one stage spread over the machine's cores: worker processes forked from the stage, so they
inherit its inputs (a vessel's hydro database, a window's samples) and only the tasks' results are pickled back.

Serial where forking is unavailable or unwise: one CPU, no `fork` start method, inside a daemonic process (a local
Dask cluster's workers, which already run one seatune run per core), or with SEATUNE_WORKERS=1. Results are the
same either way: each task is computed alone, in the order given.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import threading
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor

WORKERS_ENV = "SEATUNE_WORKERS"  # worker processes per stage (default: the CPUs this process may use)

_TASK: tuple[Callable, list] | None = None  # (function, items) the forked workers inherit
_LOCK = threading.Lock()  # one map at a time per process: another thread's map runs serially


def workers() -> int:
    """Worker processes a stage may use: SEATUNE_WORKERS, else the CPUs available; 1 where forking is not done."""
    value = os.environ.get(WORKERS_ENV, "").strip()
    if value:
        try:
            n = int(value)
        except ValueError:
            n = 1
    else:
        n = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    if mp.current_process().daemon or "fork" not in mp.get_all_start_methods():
        return 1
    return max(1, n)


def _call(index: int):
    from threadpoolctl import threadpool_limits

    fn, items = _TASK
    with threadpool_limits(limits=1, user_api="blas"):  # the processes share the cores; BLAS threads would not
        return fn(items[index])


def map_tasks(fn: Callable, items: Iterable, cost: Callable | None = None) -> list:
    """[fn(item) for item in items], the items shared out to forked workers one at a time (the slowest task does not
    hold up a batch). `fn` and the items are inherited, not pickled, so a closure over large arrays costs nothing;
    each result must pickle. An exception in a task is raised here, as the serial loop would raise it. `cost(item)`:
    a rough relative cost; the dearest tasks are handed out first (the last task to start is then a cheap one)."""
    global _TASK
    items = list(items)
    n = min(workers(), len(items))
    if n <= 1:
        return [fn(item) for item in items]
    if _TASK is not None or not _LOCK.acquire(blocking=False):  # inside a worker, or another thread's map
        return [fn(item) for item in items]
    order = sorted(range(len(items)), key=lambda k: -cost(items[k])) if cost else list(range(len(items)))
    _TASK = (fn, items)
    try:
        with ProcessPoolExecutor(n, mp_context=mp.get_context("fork")) as pool:
            done = dict(zip(order, pool.map(_call, order), strict=True))
    finally:
        _TASK = None
        _LOCK.release()
    return [done[k] for k in range(len(items))]
