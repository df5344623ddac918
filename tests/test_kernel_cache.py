"""A damaged kernel cache heals: files cut short, filled with garbage or unreadable are
compiled again and replaced, with at most one line on standard error, and the numbers stay
the same; a process killed while writing the cache leaves nothing unreadable."""

import json
import os
import random
import shutil
import subprocess
import sys

import pytest

PROBE = '''
def _sum_of_squares(values):
    total = 0.0
    for value in values:
        total += value * value
    return total
'''

RUN = '''
import json, os, sys
import numpy as np
if os.environ.get("KILL_AT"):  # die as a killed process would, just before a rename
    real_replace = os.replace
    def replace(source, target):
        if str(target).endswith(os.environ["KILL_AT"]):
            os._exit(9)
        real_replace(source, target)
    os.replace = replace
from lwrl import kernels
import lwrl_cache_probe
probe = kernels.kernel("cache_probe", lwrl_cache_probe._sum_of_squares)
value = probe(np.arange(1000.0) / 7)
stats = probe.dispatcher.stats
print(json.dumps({"value": value, "hits": sum(stats.cache_hits.values()),
                  "misses": sum(stats.cache_misses.values())}))
'''

KIND = {"index": "__pycache__/*.nbi", "data": "__pycache__/*.nbc", "module": "cache_probe.py"}


def can_be_unreadable() -> list | None:
    """The command prefix under which a file of mode 000 cannot be read: none for a user;
    for root, which reads it anyway, `setpriv` dropping the capabilities that let it. None
    where neither can be had."""
    if os.geteuid() != 0:
        return []
    if shutil.which("setpriv"):
        drop = "-dac_override,-dac_read_search"
        return ["setpriv", "--bounding-set", drop, "--inh-caps", drop]
    return None


def run_probe(tmp_path, cache, prefix=(), **environment) -> tuple:
    """`(result, stderr lines)` of a process calling the probe kernel cached in `cache`."""
    probe = tmp_path / "lwrl_cache_probe.py"
    if not probe.exists():
        probe.write_text(PROBE)
    result = subprocess.run([*prefix, sys.executable, "-c", RUN], capture_output=True, text=True,
                            timeout=300, env={**os.environ, "LWRL_CACHE_DIR": str(cache),
                                              "PYTHONPATH": str(tmp_path), **environment})
    if environment.get("KILL_AT"):
        assert result.returncode == 9, result.stderr[-3000:]
        return None, result.stderr.splitlines()
    assert result.returncode == 0, result.stderr[-3000:]
    return json.loads(result.stdout.splitlines()[-1]), result.stderr.splitlines()


@pytest.fixture(scope="module")
def fresh(tmp_path_factory):
    """A cache holding the compiled probe, and the probe's value."""
    where = tmp_path_factory.mktemp("probe")
    result, err = run_probe(where, where / "cache")
    assert result["misses"] == 1 and err == []
    return where, result["value"]


def damage(path, how: str) -> None:
    if how == "cut short":
        with open(path, "r+b") as file:
            file.truncate(os.path.getsize(path) // 2)
    elif how == "garbage":
        path.write_bytes(random.Random(0).randbytes(max(os.path.getsize(path), 64)))
    else:
        path.chmod(0)


@pytest.mark.parametrize("how", ["cut short", "garbage", "unreadable"])
@pytest.mark.parametrize("kind", list(KIND))
def test_a_damaged_cache_file_is_compiled_again_and_replaced(fresh, tmp_path, kind, how):
    where, value = fresh
    prefix = can_be_unreadable() if how == "unreadable" else []
    if prefix is None:
        pytest.skip("this process reads files of mode 000 and cannot drop the capability "
                    "(setpriv, of util-linux, is missing)")
    shutil.copytree(where / "cache", tmp_path / "cache")
    path, = (tmp_path / "cache").glob(f"*/{KIND[kind]}")
    damage(path, how)
    result, err = run_probe(where, tmp_path / "cache", prefix)
    assert result["value"] == value
    # the module is written again; numba's files, stamped with a digest of its text, still
    # hold its compiled code (numba before 0.61 stamped the file's time: compiled again)
    assert result["misses"] == 1 if kind != "module" else result["hits"] + result["misses"] == 1
    # numba itself compiles again, silently, a data file it cannot open
    expected = 0 if (kind, how) == ("data", "unreadable") else 1
    assert len(err) == expected and all(line.startswith("lwrl: the cached kernel cache_probe ")
                                        for line in err), err
    result, err = run_probe(where, tmp_path / "cache", prefix)  # healed: replaced, read
    assert (result["value"], result["hits"], result["misses"], err) == (value, 1, 0, [])


def test_a_process_killed_while_writing_the_cache_leaves_nothing_unreadable(fresh, tmp_path):
    """Killed before numba's index is in place, then between the index and the data: the
    next process compiles again without a word, and the one after reads the cache."""
    where, value = fresh
    cache = tmp_path / "cache"
    for last_file in (".nbi", ".nbc"):
        run_probe(where, cache, KILL_AT=last_file)
    leftovers = sorted(path.name.split(".")[-3] for path in cache.glob("*/__pycache__/*.tmp.*"))
    assert leftovers == ["nbc", "nbi"]  # each killed process's temporary file, nothing else
    result, err = run_probe(where, cache)
    assert (result["value"], result["misses"], err) == (value, 1, [])
    result, err = run_probe(where, cache)
    assert (result["value"], result["hits"], err) == (value, 1, [])


def test_training_heals_the_cache_of_the_issue(tmp_path):
    """`lwrl train` after its loop's index was cut short (`UnpicklingError: pickle data was
    truncated` until now): one line, then the same table."""
    cache, argv = tmp_path / "cache", [sys.executable, "-m", "lwrl.cli", "train",
                                       "mountain_car.cost_to_go", "--agents", "2", "--episodes", "4"]

    def train():
        result = subprocess.run(argv, capture_output=True, text=True, timeout=600,
                                env={**os.environ, "LWRL_CACHE_DIR": str(cache)})
        assert result.returncode == 0, result.stderr[-3000:]
        return result.stdout.splitlines()[:-1], result.stderr.splitlines()  # less "done in ..."

    table, err = train()
    assert err == []
    index, = cache.glob("*/__pycache__/loop_*.nbi")
    damage(index, "cut short")
    healed, err = train()
    assert healed == table
    assert len(err) == 1 and err[0].startswith("lwrl: the cached kernel loop_analytic_") \
        and "UnpicklingError" in err[0] and err[0].endswith("compiling it again"), err
