"""Agents in parallel: the ranges of a batch cover every agent once, in the order that keeps
threads' ranges apart."""

import concurrent.futures
import threading

import pytest

from lwrl.agent import threads


@pytest.mark.parametrize("batch", [1, 2, 7, 9, 15, 16, 17, 30, 31, 300])
@pytest.mark.parametrize("workers", [1, 2, 3])
def test_the_ranges_cover_every_agent_once(batch, workers, monkeypatch):
    monkeypatch.setattr(threads, "_WORKERS", workers)
    ranges, lock = [], threading.Lock()

    def kernel(start, stop):
        with lock:
            ranges.append((start, stop))

    threads.run_in_chunks(kernel, batch, min_chunk=1, chunks_per_worker=8, cancel=[False])
    agents = [b for start, stop in ranges for b in range(start, stop)]
    assert sorted(agents) == list(range(batch)) and all(start < stop for start, stop in ranges)
    if batch >= threads.ALIGN * workers:  # no two threads' agents share a cache line
        assert all(start % threads.ALIGN == 0 for start, _ in ranges)


class RecordingPool:
    """A pool that runs each range at once, in the order submitted."""

    def __init__(self):
        self.submitted = []

    def submit(self, kernel, start, stop):
        self.submitted.append(start)
        future = concurrent.futures.Future()
        future.set_result(kernel(start, stop))
        return future


def test_ranges_started_together_are_far_apart(monkeypatch):
    pool = RecordingPool()
    monkeypatch.setattr(threads, "_WORKERS", 2)
    monkeypatch.setattr(threads, "_POOL", pool)
    monkeypatch.setattr(threads, "_POOL_SIZE", 2)
    threads.run_in_chunks(lambda start, stop: None, 300, min_chunk=1, chunks_per_worker=8,
                          cancel=[False])
    first, second = pool.submitted[0::2], pool.submitted[1::2]
    assert len(pool.submitted) == 16 and max(first) < 150 <= min(second)
