"""Nothing lost, nothing unclear: outputs checked before the work, written whole, kept apart
from each other's failures; Ctrl-C stops the work, never the writing."""

import os
import pathlib
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from lwrl import outputs
from lwrl.agent import io as agent_io
from lwrl.cli import output

from conftest import run_cli


def test_a_file_appears_whole_or_not_at_all(tmp_path):
    target = tmp_path / "table.csv"
    with outputs.atomic_write(target) as file:
        file.write("a,b\n")
        assert not target.exists()
    assert target.read_text() == "a,b\n"
    with pytest.raises(RuntimeError), outputs.atomic_write(target) as file:
        file.write("half")
        raise RuntimeError("the disk is full")
    assert target.read_text() == "a,b\n" and sorted(os.listdir(tmp_path)) == ["table.csv"]


def test_outputs_are_checked_for_their_kind_and_place(tmp_path):
    (tmp_path / "file").write_text("")
    (tmp_path / "dir").mkdir()
    with pytest.raises(ValueError, match="--out: .*file is a file, not a directory"):
        outputs.check_directory(tmp_path / "file", "--out")
    with pytest.raises(ValueError, match="--save: .*dir is a directory; give a file name"):
        outputs.check_file(tmp_path / "dir", "--save")
    with pytest.raises(ValueError, match="--save: .*file exists; use --force to replace it"):
        outputs.check_file(tmp_path / "file", "--save")
    outputs.check_file(tmp_path / "file", "--save", force=True)
    with pytest.raises(ValueError, match="--out: cannot write in /proc"):
        outputs.check_directory("/proc/lwrl-nowhere", "--out")
    with pytest.raises(ValueError, match="--rrd: .*file is a file, not a directory"):
        outputs.check_file(tmp_path / "file" / "x.rrd", "--rrd")
    with pytest.raises(ValueError, match="needs about 1024.0 GiB of memory"):
        outputs.check_memory(2 ** 40, "the batch")


def test_train_refuses_an_output_it_cannot_write_before_training(tmp_path, capsys):
    """The example of the issue: --out under /proc refused at once; --save not written either."""
    save = tmp_path / "good.npz"
    status, out, err = run_cli(["train", "mountain_car.cost_to_go", "--episodes", "2", "--agents",
                                "2", "--out", "/proc/x", "--save", str(save)], capsys)
    assert status == 2 and len(err) == 1 and "--out: cannot write in /proc" in err[0]
    assert out == "" and not save.exists()


def test_existing_outputs_are_replaced_only_with_force(tmp_path, capsys):
    argv = ["train", "mountain_car.cost_to_go", "--episodes", "1", "--agents", "1",
            "--out", str(tmp_path / "run"), "--save", str(tmp_path / "agents.npz")]
    assert run_cli(argv, capsys)[0] == 0
    status, _, err = run_cli(argv, capsys)
    assert status == 2 and "already holds config.json, episodes.csv; use --force" in err[0]
    status, _, err = run_cli(argv[:6] + ["--save", str(tmp_path / "agents.npz")], capsys)
    assert status == 2 and "agents.npz exists; use --force" in err[0]
    assert run_cli(argv + ["--force"], capsys)[0] == 0


def test_one_output_that_fails_after_the_work_keeps_the_others(tmp_path, capsys, monkeypatch):
    def broken(*args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(output, "write_run", broken)
    save = tmp_path / "agents.npz"
    status, out, err = run_cli(["train", "mountain_car.cost_to_go", "--episodes", "2", "--agents",
                                "2", "--out", str(tmp_path / "run"), "--save", str(save)], capsys)
    assert status == 1
    assert err == [f"lwrl train: error: could not write --out {tmp_path / 'run'} "
                   "([Errno 28] No space left on device)"]
    assert f"wrote the agents to {save}" in out and agent_io.load(save)[0].batch_size == 2


def test_agent_files_are_checked_on_load(tmp_path, capsys):
    trained = tmp_path / "cartpole.npz"
    assert run_cli(["train", "cartpole.balance", "--plant", "analytic", "--episodes", "1",
                    "--agents", "2", "--save", str(trained)], capsys)[0] == 0
    agent, metadata = agent_io.load(trained)
    agent.weights[:] = np.nan
    agent_io.save(tmp_path / "nan.npz", agent, metadata)
    status, out, _ = run_cli(["eval", str(tmp_path / "nan.npz"), "--episodes", "1"], capsys)
    assert status == 0 and "2 of 2 agents had diverged in training" in out
    metadata["config"]["task"] = "mountain_car.cost_to_go"
    metadata["config"]["plant"] = "analytic"
    agent_io.save(tmp_path / "other.npz", agent_io.load(trained)[0], metadata)
    status, _, err = run_cli(["eval", str(tmp_path / "other.npz")], capsys)
    assert status == 2 and len(err) == 1
    assert "its agents observe 4 variables and choose among 2 actions, so they were not " \
           "trained on mountain_car.cost_to_go (2 variables: position, velocity; 3 actions)" in err[0]
    for name, content in (("empty.npz", b""), ("array.npy", None), ("text.npz", b"weights")):
        path = tmp_path / name
        if content is None:
            np.save(path, np.zeros(3))
        else:
            path.write_bytes(content)
        status, _, err = run_cli(["eval", str(path)], capsys)
        assert status == 2 and len(err) == 1 and "is not an lwrl agent file" in err[0], err


@pytest.mark.parametrize("stop, presses", [(signal.SIGINT, 1), (signal.SIGINT, 2),
                                           (signal.SIGTERM, 1)])
def test_ctrl_c_stops_the_work_and_writes_what_finished(tmp_path, stop, presses):
    """The first Ctrl-C (or SIGTERM, as `kill` sends) says at once that the run stops, and it
    stops; a second is ignored while what finished is written; the episodes and the agents
    are written whole; the status is 128 + the signal's number."""
    out, save = tmp_path / "run", tmp_path / "agents.npz"
    process = subprocess.Popen(
        [sys.executable, "-m", "lwrl.cli", "train", "cartpole.balance", "--plant", "analytic",
         "--agents", "40", "--episodes", "2000", "--out", str(out), "--save", str(save)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert "episodes" in process.stdout.readline()  # the run's header: training starts
    time.sleep(3.0)
    for _ in range(presses):
        process.send_signal(stop)
        time.sleep(0.3)
    stdout, stderr = process.communicate(timeout=120)
    assert process.returncode == 128 + stop, stderr
    assert "lwrl train: stopping" in stderr
    assert "Traceback" not in stderr
    episodes = (out / "episodes.csv").read_text().splitlines()
    steps = [line.split(",")[3] for line in episodes[1:]]
    assert len(steps) == 40 * 2000 and not all(steps)  # whole, and not every episode ran
    agent, _ = agent_io.load(save)
    assert agent.batch_size == 40
    assert np.any(agent.weights != 0) == any(steps)  # the weights as the finished episodes left them
    assert f"the agents to {save}" in stdout
    assert not [name for name in os.listdir(tmp_path) if name.endswith(".partial")]
    assert not [name for name in os.listdir(out) if name.endswith(".partial")]


def test_what_hid_its_cause_now_names_it(tmp_path, capsys):
    """A negative seed names `seed`; a file that is not a recording is said to be none."""
    from lwrl import tasks

    with pytest.raises(ValueError, match="seed must be a non-negative integer; got -1"):
        tasks.load("pendulum", "swingup", seed=-1)
    not_a_recording = tmp_path / "notes.rrd"
    not_a_recording.write_text("hello")
    for flags in ([], ["--web"]):
        status, _, err = run_cli(["view", str(not_a_recording), *flags], capsys)
        assert status == 2 and err == [f"lwrl view: error: {not_a_recording} is not a Rerun "
                                       "recording (an .rrd file of lwrl train --rrd)"]
    status, _, err = run_cli(["compare", "pendulum.swingup", "--seeds", "100000000", "--out",
                              str(tmp_path / "compare")], capsys)
    assert status == 2 and "needs about" in err[0] and not (tmp_path / "compare").exists()


EXTRAS_ONLY = ("pandas", "jax", "jaxlib", "torch", "stable_baselines3", "ray", "gymnasium",
               "matplotlib", "serial")
"""Packages that only the extras install (the core's dependencies do not pull them)."""


def test_the_first_command_runs_on_the_core_install(tmp_path):
    """The README's first command, `lwrl train mountain_car.cost_to_go` after `pip install
    -e .`: in a process where none of the extras' packages import, a short run of it
    trains and exits 0."""
    code = ("import sys, importlib.abc\n"
            "class Extras(importlib.abc.MetaPathFinder):\n"
            "    def find_spec(self, name, path=None, target=None):\n"
            f"        if name.split('.')[0] in {EXTRAS_ONLY!r}:\n"
            "            raise ImportError(f'No module named {name!r}', name=name)\n"
            "sys.meta_path.insert(0, Extras())\n"
            "from lwrl.cli.main import main\n"
            "sys.exit(main(['train', 'mountain_car.cost_to_go', '--episodes', '2',\n"
            "               '--agents', '2']))\n")
    result = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]


def test_a_missing_extra_is_named(monkeypatch, capsys):
    """Without pandas (the 'paper' extra) the studies' commands say what to install."""
    import builtins

    real_import = builtins.__import__

    def without_pandas(name, *args, **kwargs):
        if name == "pandas" or name.startswith("pandas."):
            raise ImportError("No module named 'pandas'", name="pandas")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", without_pandas)
    for module in [name for name in sys.modules if name.startswith(("lwrl.studies", "lwrl.analysis"))]:
        monkeypatch.delitem(sys.modules, module)
    status, _, err = run_cli(["reproduce", "fig3", "--quick"], capsys)
    assert status == 2 and err == ["lwrl reproduce: error: lwrl reproduce needs the 'paper' extra "
                                   "(pandas is missing): pip install -e '.[paper]'"]


def test_a_table_written_again_is_the_same_file(tmp_path, monkeypatch):
    """gzip keeps the time of writing and the file's name in its header unless told not to
    (`outputs.write_table`, which writes through a temporary name): a committed run's table
    written again by a resumed study leaves the file as it was."""
    import gzip

    import pandas as pd

    table = pd.DataFrame({"seed": [0, 1], "steps": [120, 95]})
    written = []
    for now in (1_000_000_000.0, 1_700_000_000.0):
        monkeypatch.setattr(gzip.time, "time", lambda now=now: now)
        path = tmp_path / f"{int(now)}.csv.gz"
        outputs.write_table(table, path)
        written.append(path.read_bytes())
    assert written[0] == written[1]
    assert pd.read_csv(tmp_path / "1000000000.csv.gz").equals(table)
    table.to_csv(tmp_path / "by-pandas.csv.gz", index=False, compression="gzip")
    assert (tmp_path / "by-pandas.csv.gz").read_bytes() != written[0]  # the check can fail
    outputs.write_table(table, tmp_path / "plain.csv")
    assert (tmp_path / "plain.csv").read_text() == "seed,steps\n0,120\n1,95\n"


def test_a_table_read_back_has_every_float_as_written(tmp_path):
    """A float written with its 17 significant digits (`write_table`, the shortest repr that
    reads back to it) is the same float when `read_table` reads it, plain or gzip'd, on
    pandas 2 (whose default parser can miss by an ulp: 0.00017686265734202648 was read as
    0.000176862657342) as on pandas 3."""
    import pandas as pd

    rng = np.random.default_rng(0)
    numbers = np.concatenate([[0.00017686265734202648, 0.1 + 0.2, -2.2250738585072014e-308],
                              rng.random(2000) * 10.0 ** rng.integers(-12, 12, 2000)])
    assert len(repr(0.1 + 0.2)) - 2 == 17  # 0.30000000000000004: 17 significant digits
    table = pd.DataFrame({"seed": np.arange(numbers.size), "return": numbers})
    for name in ("plain.csv", "gzipped.csv.gz"):
        outputs.write_table(table, tmp_path / name)
        read = outputs.read_table(tmp_path / name)
        assert read["return"].to_numpy().tobytes() == numbers.tobytes()
        assert read.equals(table)


def test_every_table_lwrl_reads_is_read_by_read_table():
    """No module of the package calls pandas' CSV reader but `outputs.read_table`, so that no
    table is read with pandas 2's inexact default."""
    package = pathlib.Path(outputs.__file__).parent
    modules = [pathlib.Path(folder, name) for folder, _, names in os.walk(package, followlinks=True)
               for name in names if name.endswith(".py")]
    assert len(modules) > 100  # the rooms behind lwrl/'s links are walked
    callers = [str(path.relative_to(package)) for path in modules
               if re.search(r"\b(pd|pandas)\.read_csv\(", path.read_text())]
    assert callers == ["outputs.py"]


def test_a_file_left_half_written_is_removed_and_one_being_written_is_not(tmp_path):
    """A process killed mid-write leaves its temporary file unlocked: `remove_abandoned`
    removes it, and leaves alone the one another writer holds."""
    abandoned = tmp_path / ".table.csv.0123456789ab.partial"
    abandoned.write_text("half")
    with outputs.atomic_write(tmp_path / "other.csv") as file:
        file.write("being written")
        outputs.remove_abandoned(tmp_path)
        assert [path.name for path in tmp_path.iterdir()] == [pathlib.Path(file.name).name]
    assert [path.name for path in tmp_path.iterdir()] == ["other.csv"]
