"""Timing for the benches: the least of a few runs, the one least disturbed by other jobs on a
shared machine."""
import time


def best_of(fn, repeat: int = 3, clock=time.perf_counter):
    """(least time of ``repeat`` calls of ``fn``, the last call's result). ``clock``:
    ``time.perf_counter`` for wall time, ``time.process_time`` for this process's CPU time."""
    times, result = [], None
    for _ in range(max(repeat, 1)):
        start = clock()
        result = fn()
        times.append(clock() - start)
    return min(times), result
