"""Outputs that appear whole or not at all, checked before the work that fills them.

- `atomic_path(path)` / `atomic_write(path)`: write to a temporary name beside `path`, then
  rename it over `path` (`os.replace`): a reader sees the old file or the new one whole,
  never half of one; on an error the temporary file is removed, and one that a killed
  process left behind is removed by `remove_abandoned` (a study that resumes calls it).
- `check_file(path, what)` and `check_directory(path, what)`: a one-line ValueError before
  any work when an output cannot be written there (a missing or read-only parent, a
  directory where a file is meant, or the reverse), or would replace a file without `force`.
- `atomic_directory(path)`: a directory's files written into a new directory beside
  it and put in place in one step, so that a reader never sees one run's files beside
  another's.
- `claim(path)` / `claim_output(path, what)`: an output claimed by this process for as long
  as it works on it (a lock on a claim file naming the host and process); a second process
  aimed at it is refused, and a claim whose process is gone is taken over.
- `available_memory()` and `check_memory(needed, what)`: refuse a batch that would not fit.
- `BackgroundWriter`: outputs written on a thread of their own while the work goes on, every
  one on disk, or its error raised, before the writer is done.
- `write_table(table, path)`: a table written whole as CSV (gzip'd for `.gz`), the same
  bytes each time it is written; `read_table(path)` reads one back, every number as written.

Every room may use it; it imports no other part of lwrl.
"""

import atexit
import concurrent.futures
import contextlib
import ctypes
import errno
import fcntl
import os
import pathlib
import secrets
import shutil
import socket
import tempfile
import time


def _parent(path: pathlib.Path) -> pathlib.Path:
    return path.parent if str(path.parent) else pathlib.Path(".")


@contextlib.contextmanager
def atomic_path(path):
    """A temporary path beside `path` to write to (by any library); renamed to `path` when
    the block ends without an error, removed otherwise. The temporary file is locked while
    it is written (`flock`), so that one a killed process left behind is told from one being
    written (`remove_abandoned`)."""
    path = pathlib.Path(path)
    _parent(path).mkdir(parents=True, exist_ok=True)
    while True:  # the mode a plain open gives (the umask's), not mkstemp's private 0600
        temporary = str(_parent(path) / f".{path.name}.{secrets.token_hex(6)}.partial")
        try:
            descriptor = os.open(temporary, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666)
        except FileExistsError:
            continue
        fcntl.flock(descriptor, fcntl.LOCK_EX)
        if _locked_at(descriptor, temporary):
            break
        os.close(descriptor)  # removed as abandoned between its making and its lock
    try:
        yield temporary
        os.replace(temporary, path)
    finally:
        try:
            if os.path.exists(temporary):
                os.unlink(temporary)
        finally:
            os.close(descriptor)


def remove_abandoned(directory) -> None:
    """Remove the temporary files of `atomic_path` in `directory` that no process is writing
    (left by one killed mid-write: its lock went with it)."""
    for temporary in pathlib.Path(directory).glob(".*.partial"):
        try:
            descriptor = os.open(temporary, os.O_RDONLY)
        except OSError:  # gone, or a directory of `atomic_directory`
            continue
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
            if _locked_at(descriptor, temporary):
                os.unlink(temporary)
        except BlockingIOError:  # being written
            pass
        finally:
            os.close(descriptor)


def _locked_at(descriptor: int, path) -> bool:
    """Whether the file open as `descriptor` is still the one at `path`."""
    try:
        return os.path.samestat(os.fstat(descriptor), os.stat(path))
    except FileNotFoundError:
        return False


@contextlib.contextmanager
def atomic_write(path, mode: str = "w", **options):
    """An open file for `path`, written under a temporary name (`atomic_path`)."""
    with atomic_path(path) as temporary, open(temporary, mode, **options) as file:
        yield file


def write_table(table, path) -> None:
    """`table` (a pandas DataFrame) written whole (`atomic_write`) as CSV without its index,
    gzip'd where `path` ends in `.gz` with a header that keeps neither the time nor the
    temporary file's name (RFC 1952's MTIME 0, no FNAME): a table written again, by a study
    that resumes, is the same file byte for byte."""
    gzipped = {"method": "gzip", "mtime": 0, "filename": ""} if str(path).endswith(".gz") else None
    with atomic_write(path, "wb") as file:
        table.to_csv(file, index=False, compression=gzipped)


def read_table(path, **options):
    """The CSV table at `path` (gzip'd for `.gz`) as a pandas DataFrame (`pandas.read_csv`
    with `options`), every float the one whose shortest repr was written. pandas 2 parses
    decimals with a converter that can miss by an ulp (0.00017686265734202648 read as
    0.000176862657342) unless asked for `float_precision="round_trip"`; pandas 3.1 deprecates
    that option, every converter of its being exact (pandas-dev/pandas#64666), so it is asked
    for before 3.1 only. Every table lwrl reads is read here."""
    import pandas as pd  # the 'paper' extra: only what reads tables needs it

    if tuple(int(part) for part in pd.__version__.split(".")[:2]) < (3, 1):
        options.setdefault("float_precision", "round_trip")
    return pd.read_csv(path, **options)


def _exchange(first: pathlib.Path, second: pathlib.Path) -> bool:
    """Swap two existing paths in one step (Linux's `renameat2(RENAME_EXCHANGE)`); False
    where the system or the file system cannot."""
    renameat2 = getattr(ctypes.CDLL(None, use_errno=True), "renameat2", None)
    if renameat2 is None:
        return False
    at_fdcwd, rename_exchange = -100, 2  # <fcntl.h>, <linux/fs.h>
    if renameat2(at_fdcwd, os.fsencode(first), at_fdcwd, os.fsencode(second), rename_exchange) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
        return False
    raise OSError(code, os.strerror(code), str(second))


def _holds_working_directory(path: pathlib.Path) -> bool:
    return pathlib.Path.cwd().resolve().is_relative_to(path.resolve())


def _new_directory(parent: pathlib.Path, prefix: str) -> pathlib.Path:
    """A new directory `parent/PREFIX.<random>.partial` with the mode a plain `mkdir` gives
    (the umask's, not `mkdtemp`'s private 0700: it becomes the output), as `atomic_path`'s
    files have the mode of a plain open."""
    while True:
        candidate = parent / f"{prefix}.{secrets.token_hex(6)}.partial"
        try:
            candidate.mkdir()
            return candidate
        except FileExistsError:
            continue


def _staging_directory(path: pathlib.Path) -> tuple[pathlib.Path, bool]:
    """A new, empty directory to write `path`'s files into, and whether it lies beside
    `path` (so that it can take `path`'s place whole, with `path`'s mode) or, where that
    cannot be, inside it."""
    parent = _parent(path)
    if not _holds_working_directory(path):
        with contextlib.suppress(OSError):
            parent.mkdir(parents=True, exist_ok=True)
            staging = _new_directory(parent, f".{path.name}")
            if path.is_dir():
                shutil.copymode(path, staging)
            return staging, True
    path.mkdir(parents=True, exist_ok=True)
    return _new_directory(path, ""), False


def _place_entries(staging: pathlib.Path, path: pathlib.Path) -> None:
    """Rename each entry of `staging` into `path`, each whole (a directory replaces the one
    of its name, which is moved into `staging` to be removed with it)."""
    path.mkdir(parents=True, exist_ok=True)
    for entry in sorted(staging.iterdir()):
        target = path / entry.name
        if target.is_dir() and not target.is_symlink():
            os.rename(target, staging / f".replaced.{entry.name}")
        os.replace(entry, target)


@contextlib.contextmanager
def atomic_directory(path):
    """A new directory to write the output directory `path`'s files into; put in place when
    the block ends without an error, removed otherwise.

    The new directory is made beside `path` and takes its place in one step: renamed to it
    where `path` is absent or empty, exchanged with it where it holds files (Linux's
    `renameat2(RENAME_EXCHANGE)`), so that a reader sees the old files or the new ones,
    never some of each. What the old directory holds that the new one does not (a
    recording, a user's own files) is then moved into the new one, and the rest removed.
    Where `path` holds the working directory, its parent cannot be written, or the system
    cannot exchange two directories, the entries are renamed into `path` one by one, each
    whole. A `path` that is a symbolic link is followed: the directory it names is replaced."""
    path = pathlib.Path(path)
    if path.is_symlink():
        path = path.resolve()
    staging, beside = _staging_directory(path)
    try:
        yield staging
        if not beside:
            _place_entries(staging, path)
        elif not path.exists() or (path.is_dir() and not any(path.iterdir())):
            os.replace(staging, path)
        elif _exchange(staging, path):
            written = {entry.name for entry in path.iterdir()}
            for entry in list(staging.iterdir()):  # the old directory, now at `staging`
                if entry.name not in written:
                    os.rename(entry, path / entry.name)
        else:
            _place_entries(staging, path)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _writable_directory(directory: pathlib.Path, what: str) -> None:
    """Raise unless files can be created in `directory` (its nearest existing ancestor, for
    a directory still to be made)."""
    existing = directory
    while not existing.exists():
        if existing.parent == existing:
            break
        existing = existing.parent
    if not existing.is_dir():
        raise ValueError(f"{what}: {existing} is a file, not a directory")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise ValueError(f"{what}: cannot write in {existing} (permission denied)")
    try:  # access() does not know read-only mounts and /proc: try a file
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as error:
        raise ValueError(f"{what}: cannot write in {existing} ({os.strerror(error.errno or errno.EIO)})") from None


def check_file(path, what: str, force: bool = False) -> pathlib.Path:
    """`path` as an output file named `what` (e.g. `--save`): its directory can be written,
    it is not a directory, and it is not there yet unless `force`."""
    path = pathlib.Path(path)
    if path.is_dir():
        raise ValueError(f"{what}: {path} is a directory; give a file name")
    if path.exists() and not force:
        raise ValueError(f"{what}: {path} exists; use --force to replace it")
    _writable_directory(_parent(path), what)
    return path


def check_directory(path, what: str, force: bool = False, names=()) -> pathlib.Path:
    """`path` as an output directory named `what` (e.g. `--out`): it is not a file and it
    can be written; without `force`, it holds none of the files `names` this command writes
    (an empty `names` allows existing contents: commands that resume)."""
    path = pathlib.Path(path)
    if path.exists() and not path.is_dir():
        raise ValueError(f"{what}: {path} is a file, not a directory")
    _writable_directory(path, what)
    present = [name for name in names if (path / name).exists()]
    if present and not force:
        raise ValueError(f"{what}: {path} already holds {', '.join(present)}; use --force to "
                         "replace them, or another directory")
    return path


class Claim:
    """This process's claim on an output: an exclusive lock (`flock`) on the claim file at
    `path`, which names the host and process that hold it. The kernel drops the lock when
    the process ends however it ends, so a claim whose process is gone is free to be taken
    over; `release()` removes the file."""

    def __init__(self, path: pathlib.Path, descriptor: int, made=()):
        self.path, self._made = path, made
        self._descriptor: int | None = descriptor

    def release(self) -> None:
        """Give the claim up (removing the claim file while it is still locked, so that no
        other process locks a file that is no longer at `path`), and the directories made
        for it that are still empty."""
        if self._descriptor is None:
            return
        with contextlib.suppress(FileNotFoundError):
            os.unlink(self.path)
        os.close(self._descriptor)
        self._descriptor = None
        _HELD.discard(self)
        for directory in self._made:  # the deepest first
            with contextlib.suppress(OSError):
                directory.rmdir()


_HELD: set[Claim] = set()
"""The claims this process holds (`release_claims` gives them up, as does its exit)."""


def claim(path) -> Claim | None:
    """Claim the claim file `path` for this process, taking over one whose process is gone;
    None while another process (or another claim of this one) holds it."""
    path = pathlib.Path(path)
    made = [directory for directory in [path.parent, *path.parent.parents]
            if not directory.exists()]
    path.parent.mkdir(parents=True, exist_ok=True)
    while True:
        descriptor = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(descriptor)
            return None
        try:  # the file locked may have been released, and removed, since it was opened
            if os.path.samestat(os.fstat(descriptor), os.stat(path)):
                break
        except FileNotFoundError:
            pass
        os.close(descriptor)
    os.ftruncate(descriptor, 0)
    os.write(descriptor, f"{socket.gethostname()} {os.getpid()}\n".encode())
    held = Claim(path, descriptor, made)
    _HELD.add(held)
    return held


def holder(path) -> str:
    """Who holds the claim file `path`: `process PID on HOST`."""
    for _ in range(20):  # a claim is written just after it is locked
        with contextlib.suppress(OSError, ValueError):
            host, pid = pathlib.Path(path).read_text().split()[:2]
            return f"process {int(pid)} on {host}"
        time.sleep(0.01)
    return "another process"


def claim_path(path) -> pathlib.Path:
    """The claim file of the output `path` (a file or a directory): `.NAME.claim` beside it."""
    path = pathlib.Path(path).resolve()
    return path.parent / f".{path.name}.claim"


def claim_output(path, what: str) -> Claim:
    """Claim the output `path` (named `what`, e.g. `--out`) for this process until it is
    released (`release_claims`, or the process's end); a one-line ValueError naming the
    process that holds it otherwise."""
    where = claim_path(path)
    _writable_directory(where.parent, what)
    held = claim(where)
    if held is None:
        raise ValueError(f"{what}: {path} is being written by {holder(where)}; wait for it to "
                         "finish or choose another")
    return held


def release_claims() -> None:
    """Give up every claim this process holds."""
    for held in list(_HELD):
        held.release()


atexit.register(release_claims)


def available_memory() -> int | None:
    """Bytes of memory this machine can give a new allocation without swapping
    (`MemAvailable`), or None where it cannot be read."""
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def check_memory(needed: int, what: str) -> None:
    """Refuse, in one line, work whose arrays need more memory than the machine has."""
    available = available_memory()
    if available is not None and needed > available:
        raise ValueError(f"{what} needs about {needed / 2**30:.1f} GiB of memory; this machine "
                         f"has {available / 2**30:.1f} GiB available")


class BackgroundWriter:
    """Writes outputs on one thread of its own, in the order given, while the caller goes
    on computing (formatting and compressing a table is work of one core that the
    learners' threads would otherwise wait for). `submit(write, *args)` hands one over,
    first raising the error of one that failed, if any is known; `wait` returns once
    everything handed over is written, and raises the first error a write met; as a
    context manager it waits, then ends its thread, however the block is left."""

    def __init__(self, name: str):
        self.pending: list[concurrent.futures.Future] = []
        """The writes handed over and not yet waited for."""
        self.pool = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix=name)
        """The one thread that writes, named `name`."""

    def submit(self, write, *args) -> None:
        """Hand `write(*args)` over to the writing thread, first raising the error of an
        earlier write that failed, if one is known."""
        if any(future.done() and future.exception() is not None for future in self.pending):
            self.wait()
        self.pending.append(self.pool.submit(write, *args))

    def wait(self) -> None:
        """Return once everything handed over is written; raise the first error a write met."""
        pending, self.pending = self.pending, []
        concurrent.futures.wait(pending)
        for future in pending:
            future.result()

    def __enter__(self) -> "BackgroundWriter":
        return self

    def __exit__(self, *exception) -> None:
        try:
            self.wait()
        finally:
            self.pool.shutdown()
