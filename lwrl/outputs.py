"""Outputs that appear whole or not at all, checked before the work that fills them.

- `atomic_path(path)` / `atomic_write(path)`: write to a temporary name beside `path`, then
  rename it over `path` (`os.replace`): a reader sees the old file or the new one whole,
  never half of one; on an error the temporary file is removed.
- `check_file(path, what)` and `check_directory(path, what)`: a one-line ValueError before
  any work when an output cannot be written there (a missing or read-only parent, a
  directory where a file is meant, or the reverse), or would replace a file without `force`.
- `available_memory()` and `check_memory(needed, what)`: refuse a batch that would not fit.

Every room may use it; it imports no other part of lwrl.
"""

import contextlib
import errno
import os
import pathlib
import tempfile


def _parent(path: pathlib.Path) -> pathlib.Path:
    return path.parent if str(path.parent) else pathlib.Path(".")


@contextlib.contextmanager
def atomic_path(path):
    """A temporary path beside `path` to write to (by any library); renamed to `path` when
    the block ends without an error, removed otherwise."""
    path = pathlib.Path(path)
    descriptor, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial",
                                             dir=_parent(path))
    os.close(descriptor)
    try:
        yield temporary
        os.replace(temporary, path)
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)


@contextlib.contextmanager
def atomic_write(path, mode: str = "w", **options):
    """An open file for `path`, written under a temporary name (`atomic_path`)."""
    with atomic_path(path) as temporary, open(temporary, mode, **options) as file:
        yield file


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
