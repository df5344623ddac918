"""A process's memory mappings, and when JAX's compiled programs must be let go of them.

Each program XLA loads maps memory of its own (about 3.6 mappings per program, measured on
jax 0.10.2), and Linux ends a process's right to map more at `vm.max_map_count` (65 530 by
default). A process that compiles hundreds of programs, a study that runs many learners,
tasks and shapes of batch one after the other, or a test worker that compiles every JAX
learner on every task, reaches it, and XLA's next compilation dies with a segmentation fault:
no exception, the process is gone (seen twice in the full test suite, at
`test_acting_greedily_touches_nothing[stream_q-acrobot.swingup]`). `crowded` says when a
process holds more than half its limit, where the population runner (`runners.population`)
and the tests release the compiled programs (`jax.clear_caches`) before compiling more:
a program needed again is compiled again, and no number changes.

Not every mapping is JAX's to give back (numba's compiled kernels, MuJoCo's, PyTorch's stay),
so a process can stay past half its limit after a release. The next release is then due
only once it holds `MARGIN` of its limit more than it did right after the last (`released`):
releasing after every test of such a process, as the tests first did, cost each test
seconds of garbage collection and every later test its compiled programs.
"""

import os

DEFAULT_LIMIT = 65_530
"""Linux's default `vm.max_map_count`, taken where the limit cannot be read."""
SHARE = 0.5
"""The share of the limit past which a process is crowded."""
MARGIN = 0.125
"""The share of the limit a process must gain after a release before the next is due."""

_after_release = 0
"""The mappings this process held right after its last release (`released`)."""


def count() -> int:
    """The memory mappings this process holds (0 where `/proc` cannot say)."""
    try:
        with open(f"/proc/{os.getpid()}/maps", "rb") as maps:
            return sum(1 for _ in maps)
    except OSError:
        return 0


def limit() -> int:
    """The mappings a process may hold (`/proc/sys/vm/max_map_count`, else `DEFAULT_LIMIT`)."""
    try:
        with open("/proc/sys/vm/max_map_count") as value:
            return int(value.read())
    except (OSError, ValueError):
        return DEFAULT_LIMIT


def crowded() -> bool:
    """Whether this process holds more than `SHARE` of its mappings' limit, and `MARGIN` of
    it more than right after its last release."""
    held, most = count(), limit()
    return held > max(SHARE * most, _after_release + MARGIN * most)


def released() -> None:
    """Note what this process holds right after a release (see the module)."""
    global _after_release
    _after_release = count()
