"""Agents in parallel: contiguous ranges of a batch on a pool of threads.

The compiled kernels release the GIL (`nogil=True`), so threads run them on every core
without numba's parallel compilation, which more than doubles compile time. Agents are
independent (each has its own random stream), so results do not depend on the split.
"""

import concurrent.futures
import os

ALIGN = 8
"""Ranges start at multiples of this many agents (in batches of at least this many per
thread): 8 of a per-agent float64 or int64 (its `slot`, `action`, TD error) share a 64-byte
cache line, which two threads writing agents of one line pass back and forth at every step.
For the same reason the ranges are started in an order that keeps those running at once
far apart."""
_POOL = None
_POOL_SIZE = 0
_WORKERS = None


def workers() -> int:
    """Threads used: the cores this process may run on, unless `set_workers` said fewer."""
    if _WORKERS is not None:
        return _WORKERS
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def set_workers(count: int) -> None:
    """Use `count` threads from now on."""
    global _WORKERS
    _WORKERS = int(count)


def run_in_chunks(kernel, batch_size: int, *args, min_chunk: int = 16,
                  chunks_per_worker: int = 1, cancel=None) -> None:
    """Call `kernel(start, stop, *args)` over contiguous ranges covering `range(batch_size)`
    on the worker threads (a single call when the batch is small). With
    `chunks_per_worker` > 1 there are more ranges than threads, each thread taking the next
    as it finishes one: long runs whose agents differ in cost stay balanced.

    `cancel`, a boolean array of one element that the kernel also reads: on Ctrl-C it is
    set, so that the kernels stop soon (at their next check), before the interrupt reaches
    the caller."""
    global _POOL, _POOL_SIZE
    threads = workers()
    chunks = max(1, min(threads * chunks_per_worker, batch_size // min_chunk))
    if chunks == 1 and cancel is None:  # else on a thread, so that Ctrl-C reaches us at once
        kernel(0, batch_size, *args)
        return
    if _POOL_SIZE < threads:
        _POOL = concurrent.futures.ThreadPoolExecutor(max_workers=threads, thread_name_prefix="lwrl")
        _POOL_SIZE = threads
    align = ALIGN if batch_size >= ALIGN * threads else 1
    cuts = {align * round(batch_size * c / (chunks * align)) for c in range(1, chunks)}
    bounds = [0, *sorted(cut for cut in cuts if 0 < cut < batch_size), batch_size]
    ranges = list(zip(bounds[:-1], bounds[1:]))
    stride = -(-len(ranges) // threads)  # the ranges running at once are this far apart
    futures = []
    try:
        for i in sorted(range(len(ranges)), key=lambda i: i % stride):
            futures.append(_POOL.submit(kernel, *ranges[i], *args))
        for future in futures:
            future.result()
    except KeyboardInterrupt:
        # Compiled kernels cannot be interrupted, only asked to stop: let the started ones
        # stop and finish writing before the interrupt reaches the caller, which may then
        # save what is complete.
        if cancel is not None:
            cancel[0] = True
        for future in futures:
            future.cancel()
        concurrent.futures.wait(futures)
        raise
