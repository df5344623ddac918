"""Outputs claimed for the whole run: a second command aimed at an output that another is
writing stops at once, naming it; a claim whose process is gone is taken over; a run's
directory is put in place whole, so that no reader sees one run's files beside another's."""

import os
import pathlib
import signal
import socket
import subprocess
import sys
import threading

import pytest

from lwrl import outputs

from conftest import run_cli

HOLD = ("import sys, time\n"
        "from lwrl import outputs\n"
        "outputs.claim_output(sys.argv[1], 'the output')\n"
        "print('claimed', flush=True)\n"
        "time.sleep(120)\n")


@pytest.fixture
def holder():
    """`hold(path)`: another process that claims the output `path` and keeps it; killed at
    the end."""
    processes = []

    def hold(path):
        process = subprocess.Popen([sys.executable, "-c", HOLD, str(path)], stdout=subprocess.PIPE,
                                   text=True)
        processes.append(process)
        assert process.stdout.readline().strip() == "claimed"
        return process

    yield hold
    for process in processes:
        process.kill()
        process.wait()


def test_a_claim_held_by_a_live_process_is_refused_and_taken_over_once_it_is_gone(tmp_path, holder):
    output = tmp_path / "run"
    other = holder(output)
    assert outputs.claim(outputs.claim_path(output)) is None
    with pytest.raises(ValueError) as refused:
        outputs.claim_output(output, "--out")
    assert str(refused.value) == (f"--out: {output} is being written by process {other.pid} on "
                                  f"{socket.gethostname()}; wait for it to finish or choose another")
    other.send_signal(signal.SIGKILL)  # gone without releasing: its claim file stays
    other.wait()
    assert outputs.claim_path(output).exists()
    claim = outputs.claim_output(output, "--out")  # taken over
    assert claim.path.read_text() == f"{socket.gethostname()} {os.getpid()}\n"
    claim.release()
    assert not claim.path.exists() and not output.exists()


def test_a_refused_command_leaves_nothing_behind(tmp_path, capsys):
    """The directories made for a claim go with it when the command is refused."""
    (tmp_path / "agents.npz").write_text("an earlier run's")
    status, _, err = run_cli(["train", "mountain_car.cost_to_go", "--out",
                              str(tmp_path / "a" / "b" / "run"), "--save",
                              str(tmp_path / "agents.npz")], capsys)
    assert status == 2 and len(err) == 1 and "agents.npz exists" in err[0]
    assert [path.name for path in tmp_path.iterdir()] == ["agents.npz"]


def test_one_process_holds_a_claim_once(tmp_path):
    claim = outputs.claim(tmp_path / "a.claim")
    assert claim is not None and outputs.claim(tmp_path / "a.claim") is None
    claim.release()
    again = outputs.claim(tmp_path / "a.claim")
    assert again is not None
    outputs.release_claims()
    assert not (tmp_path / "a.claim").exists()


def commands(tmp_path):
    """`(argv, the flag of its output, the output)` for each command that writes one."""
    agents = tmp_path / "agents.npz"
    train = ["train", "mountain_car.cost_to_go", "--agents", "1", "--episodes", "1"]
    compare = ["compare", "pendulum.swingup", "--quick"]
    return [(train, "--out", tmp_path / "run"), (train, "--save", agents),
            (train, "--rrd", tmp_path / "run.rrd"), (compare, "--out", tmp_path / "cmp"),
            (compare + ["--out", str(tmp_path / "cmp")], "--rrd", tmp_path / "c.rrd"),
            (["export", str(agents)], "--c", tmp_path / "c"),
            (["reproduce", "fig3", "--quick"], "--out", tmp_path / "repro")]


@pytest.mark.parametrize("index", range(7))
def test_a_command_aimed_at_a_claimed_output_stops_at_once(tmp_path, holder, capsys, index):
    argv, flag, claimed = commands(tmp_path)[index]
    other = holder(claimed)
    status, out, err = run_cli(argv + [flag, str(claimed)], capsys)
    assert status == 2 and out == "", out
    assert err == [f"lwrl {argv[0]}: error: {flag}: {claimed} is being written by process "
                   f"{other.pid} on {socket.gethostname()}; wait for it to finish or choose another"]
    assert sorted(path.name for path in tmp_path.iterdir()) == [f".{claimed.name}.claim"]


def test_two_trainings_aimed_at_one_directory(tmp_path):
    """The issue's case: the same command twice at once, with another seed. The second stops
    at once naming the first, which writes its run; nothing else is left behind."""
    out = tmp_path / "run"
    argv = [sys.executable, "-m", "lwrl.cli", "train", "cartpole.balance", "--plant", "analytic",
            "--agents", "4", "--episodes", "300", "--out", str(out)]
    first = subprocess.Popen(argv + ["--seed", "0"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True)
    try:
        assert "episodes" in first.stdout.readline()  # its header: the first is training
        second = subprocess.run(argv + ["--seed", "1"], capture_output=True, text=True, timeout=120)
        assert first.poll() is None  # the first was still at work
    finally:
        stdout, stderr = first.communicate(timeout=300)
    assert second.returncode == 2 and second.stdout == ""
    assert second.stderr.splitlines() == [
        f"lwrl train: error: --out: {out} is being written by process {first.pid} on "
        f"{socket.gethostname()}; wait for it to finish or choose another"]
    assert first.returncode == 0, stderr
    assert '"seed": 0' in (out / "config.json").read_text()
    assert sorted(os.listdir(tmp_path)) == ["run"] and sorted(os.listdir(out)) == [
        "config.json", "episodes.csv"]


def read_both(directory: pathlib.Path):
    """The two files of `directory` as one reader sees them: through one open directory,
    so that both come from the same directory (None if it was replaced meanwhile)."""
    try:
        descriptor = os.open(directory, os.O_RDONLY | os.O_DIRECTORY)
    except FileNotFoundError:
        return None
    try:
        def opener(name, flags):
            return os.open(name, flags, dir_fd=descriptor)
        with open("config.json", opener=opener) as config, open("episodes.csv", opener=opener) as episodes:
            return config.read(), episodes.read()
    except FileNotFoundError:
        return None
    finally:
        os.close(descriptor)


def write_generations(out: pathlib.Path, count: int) -> None:
    for generation in range(count):
        with outputs.atomic_directory(out) as staging:
            (staging / "config.json").write_text(f"run {generation}")
            (staging / "episodes.csv").write_text(f"run {generation}")


@pytest.mark.parametrize("exchange", [True, False], ids=["exchanged", "renamed one by one"])
def test_a_reader_never_sees_one_runs_file_beside_anothers(tmp_path, monkeypatch, exchange):
    """A run's directory replaced 300 times while a reader reads it: each read holds two
    files of one run where the directory is exchanged whole. Where it cannot be, the files
    are renamed one by one, and the reader does see mixed runs (so the check can fail)."""
    if not exchange:
        monkeypatch.setattr(outputs, "_exchange", lambda first, second: False)
    out = tmp_path / "run"
    write_generations(out, 1)
    (out / "notes.txt").write_text("the user's own")
    mixed, reads, done = [], [0], threading.Event()

    def reader():
        while not done.is_set():
            seen = read_both(out)
            if seen is not None:
                reads[0] += 1
                if seen[0] != seen[1]:
                    mixed.append(seen)

    thread = threading.Thread(target=reader)
    thread.start()
    try:
        write_generations(out, 300)
    finally:
        done.set()
        thread.join()
    assert reads[0] > 100
    assert bool(mixed) != exchange, mixed[:3]
    assert sorted(os.listdir(out)) == ["config.json", "episodes.csv", "notes.txt"]
    assert (out / "config.json").read_text() == "run 299" and sorted(os.listdir(tmp_path)) == ["run"]


def test_a_directory_is_new_until_its_block_ends_and_gone_on_an_error(tmp_path):
    out = tmp_path / "a" / "run"
    with outputs.atomic_directory(out) as staging:
        (staging / "config.json").write_text("new")
        assert not out.exists()
    assert (out / "config.json").read_text() == "new"
    with pytest.raises(RuntimeError), outputs.atomic_directory(out) as staging:
        (staging / "config.json").write_text("half")
        raise RuntimeError("the disk is full")
    assert (out / "config.json").read_text() == "new"
    assert sorted(os.listdir(out.parent)) == ["run"]


def test_the_working_directory_is_written_into_not_replaced(tmp_path, monkeypatch):
    """`--out .`: the directory cannot be swapped under the shell that stands in it; each
    file is renamed into it whole."""
    (tmp_path / "config.json").write_text("old")
    monkeypatch.chdir(tmp_path)
    inode = os.stat(".").st_ino
    with outputs.atomic_directory(".") as staging:
        (staging / "config.json").write_text("new")
        (staging / "figures").mkdir()
    assert os.stat(".").st_ino == inode and (tmp_path / "config.json").read_text() == "new"
    assert sorted(os.listdir(tmp_path)) == ["config.json", "figures"]


def test_a_link_to_a_run_directory_stays_a_link(tmp_path):
    real, link = tmp_path / "real", tmp_path / "link"
    write_generations(real, 1)
    link.symlink_to(real)
    with outputs.atomic_directory(link) as staging:
        (staging / "config.json").write_text("new")
        (staging / "episodes.csv").write_text("new")
    assert link.is_symlink() and (real / "config.json").read_text() == "new"
    assert sorted(os.listdir(tmp_path)) == ["link", "real"]


def test_outputs_keep_the_mode_a_plain_mkdir_or_open_gives(tmp_path):
    """Not the private 0700 and 0600 of temporary directories and files: the umask's for a
    new directory and a file, the old one's for a directory replaced."""
    umask = os.umask(0o022)
    try:
        write_generations(tmp_path / "new", 1)
        (tmp_path / "old").mkdir(mode=0o750)
        (tmp_path / "old" / "notes.txt").write_text("kept")
        write_generations(tmp_path / "old", 1)
        with outputs.atomic_write(tmp_path / "table.csv") as file:
            file.write("a,b\n")
    finally:
        os.umask(umask)
    assert (tmp_path / "new").stat().st_mode & 0o777 == 0o755
    assert (tmp_path / "old").stat().st_mode & 0o777 == 0o750
    assert (tmp_path / "table.csv").stat().st_mode & 0o777 == 0o644


def test_a_recording_that_fails_loses_no_report(tmp_path, capsys, monkeypatch):
    """`lwrl compare --rrd` writes the recording once the report is in place."""
    import types

    from lwrl.studies.compare import comparison

    def compared(task, out_dir, **options):  # the comparison's report, without its work
        (pathlib.Path(out_dir) / "report.md").write_text("the report")
        return types.SimpleNamespace(report_path=str(pathlib.Path(out_dir) / "report.md"),
                                     timings={}, closed_loop=types.SimpleNamespace(replay=None))

    def broken(*args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(comparison, "compare", compared)
    monkeypatch.setattr(comparison, "record", broken)
    status, _, err = run_cli(["compare", "pendulum.swingup", "--quick", "--seeds", "2", "--out",
                              str(tmp_path / "cmp"), "--rrd", str(tmp_path / "plants.rrd")], capsys)
    assert status == 1 and "No space left on device" in err[-1]
    assert (tmp_path / "cmp" / "report.md").exists() and not (tmp_path / "plants.rrd").exists()
