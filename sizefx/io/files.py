"""Atomic, non-destructive output files.

Every output of sizefx is written to a temporary file in the destination
directory and renamed into place only when complete, so a crash or Ctrl-C
never leaves a half-written file under the final name. An output never
replaces one of the inputs of the same run, and replaces an existing file
only when the caller says ``force=True``.

The SHA-256 of a file that the batch manifest and the importers' provenance record is here too
(:func:`sha256_of`).
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import mmap
import os
import resource
import shutil
import signal
import stat
import tempfile
import threading
from pathlib import Path

from ..errors import ConfigError, Interrupted, OutputError

__all__ = [
    "atomic_output",
    "atomic_folder_output",
    "check_output_folder_replace",
    "regular_file",
    "file_kind",
    "check_output_path",
    "check_outputs",
    "check_output_folder",
    "check_room",
    "interrupt",
    "INTERRUPTED",
    "sha256_of",
    "remove_stale_temporaries",
    "remove_stale_temporaries_below",
]

#: Bytes of a file mapped (or read) and hashed at a time: a multiple of the page size.
HASH_CHUNK_BYTES = 1 << 24


def sha256_of(path, *, mapped: bool = True) -> str:
    """SHA-256 of a file's bytes (hex), in bounded memory whatever its size.

    ``mapped`` (a batch worker's hash): a regular file is mapped a window of :data:`HASH_CHUNK_BYTES`
    at a time and hashed from the page cache in place. A read would first copy each byte into a
    buffer, and in a batch that copy competed with the stage's own reads of the same record
    (``benchmarks/bench_batch.py``: 8 records of the 1.8 h flight on 2 workers, about 0.5 s of 14).
    One window at a time, so that the process's resident memory (the peak a batch reports per
    record) grows by one window, not by the file. A file truncated by another process while it is
    mapped ends the process with SIGBUS: a batch worker that dies so fails that record alone and
    the record is run again in a fresh worker, but a command's own process should not take that
    risk, so it reads (``mapped=False``). Anything but a regular file (a pipe), and a file system
    that cannot map, is read too.
    """
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        info = os.fstat(f.fileno())
        offset = 0
        if mapped and stat.S_ISREG(info.st_mode):
            try:
                while offset < info.st_size:
                    length = min(HASH_CHUNK_BYTES, info.st_size - offset)
                    with mmap.mmap(f.fileno(), length, access=mmap.ACCESS_READ, offset=offset) as window:
                        digest.update(window)
                    offset += length
                return digest.hexdigest()
            except OSError:  # cannot be mapped here: the rest is read
                f.seek(offset)
        while chunk := f.read(HASH_CHUNK_BYTES):
            digest.update(chunk)
    return digest.hexdigest()


_KINDS = {
    stat.S_IFDIR: "a folder",
    stat.S_IFIFO: "a FIFO (named pipe)",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFSOCK: "a socket",
}


def file_kind(mode: int) -> str:
    """What a file of ``st_mode`` ``mode`` is, in words ("a FIFO (named pipe)"): for refusals."""
    return _KINDS.get(stat.S_IFMT(mode), "not a regular file")


def regular_file(path, what: str = "") -> Path:
    """``path``, checked to be a regular file (links followed) that can be read: a FIFO, a device
    or a socket would block a reader or never end, so it is refused in one line before anyone opens
    it. ``what``: the option or argument that named it, for the message."""
    path = Path(path)
    label = f"{what}: " if what else ""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise ConfigError(f"{path}: {label}no such file; check the path") from None
    except OSError as exc:  # a link loop, a name too long, a folder on the way that cannot be searched
        raise ConfigError(f"{path}: {label}cannot be read ({exc.strerror or exc}); check the path") from None
    if not stat.S_ISREG(info.st_mode):
        raise ConfigError(f"{path}: {label}is {file_kind(info.st_mode)}, not a regular file; give a file")
    if not os.access(path, os.R_OK):
        raise ConfigError(f"{path}: {label}cannot be read (permissions); fix them or leave it out")
    return path


def _require_writable_parent(out: Path) -> None:
    """The folder that will hold the new file or folder ``out`` exists and is writable."""
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise OutputError(f"{out}: directory {parent} does not exist; create it first")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"{out}: directory {parent} is not writable; choose another output folder")


def check_output_path(path, *, inputs=(), force: bool = False) -> Path:
    """Refuse an output path that is an input, or that exists without ``force``."""
    out = Path(path)
    for inp in inputs:
        if inp is None:
            continue
        inp = Path(inp)
        same = False
        if out.exists() and inp.exists():
            same = os.path.samefile(out, inp)
        else:
            same = out.resolve() == inp.resolve()
        if same:
            raise OutputError(f"{out}: output would overwrite the input {inp}; choose another output name")
    if out.exists() and not force:
        raise OutputError(f"{out}: output exists; pass --force to replace it, or choose another name")
    if out.exists() and out.is_dir():
        raise OutputError(f"{out}: output is a directory; give a file name")
    _require_writable_parent(out)
    return out


def check_outputs(outputs: dict, *, inputs=(), force: bool = False) -> None:
    """Pre-flight for every output of one command, before any work: ``outputs`` maps each option
    (``"--json"``) to its path or None. Two outputs may not share a path, and each passes
    :func:`check_output_path` (not an input, not existing without ``force``, folder exists)."""
    given = {opt: Path(path) for opt, path in outputs.items() if path}
    seen: dict = {}
    for opt, path in given.items():
        key = path.resolve()
        if key in seen:
            raise OutputError(f"{path}: given to both {seen[key]} and {opt}; each output needs its own file")
        seen[key] = opt
        check_output_path(path, inputs=inputs, force=force)


def check_output_folder(folder, *, option: str, inputs=()) -> Path:
    """Refuse an output folder (``--plots``) that is a file or an input, or cannot be made.

    The folder may exist (its files are then checked one by one, as outputs) or be new, in an
    existing, writable folder, as for an output file.
    """
    out = Path(folder)
    if out.exists():
        if not out.is_dir():
            is_input = any(inp is not None and Path(inp).exists() and os.path.samefile(out, inp) for inp in inputs)
            raise OutputError(
                f"{out}: {option} needs a directory, and this is {'an input' if is_input else 'a'} file; give a folder"
            )
        if not os.access(out, os.W_OK | os.X_OK):
            raise OutputError(f"{out}: {option}: the folder is not writable; choose another folder")
        return out
    _require_writable_parent(out)
    return out


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


#: The signal that interrupted this process, once one has (:func:`interrupt`). Python may swallow the
#: exception a signal handler raises (when it lands in a weakref callback or a ``__del__``, it is
#: printed as "Exception ignored" and the program goes on), so :func:`atomic_output` also looks
#: here before it publishes an output.
INTERRUPTED: dict[str, int | None] = {"signum": None}


#: The threads whose work was given up (a Dask task its batch cancelled, :mod:`sizefx.batch.runner`):
#: an output they finish is discarded instead of published, so that nothing is written after the
#: batch that wanted it has gone.
ABANDONED: set[int] = set()


def interrupt(signum: int, frame=None):
    """A signal handler (the command line installs it for SIGINT and SIGTERM): remember the signal,
    then raise :class:`~sizefx.errors.Interrupted`."""
    INTERRUPTED["signum"] = signum
    raise Interrupted(signum)


#: Bytes every output is assumed to need at least (HDF5 metadata, a JSON report, a plot).
MIN_OUTPUT_BYTES = 1 << 20


def check_room(out: Path, n_bytes: int, *, already: int = 0) -> None:
    """Refuse, before any work, an output of about ``n_bytes`` more (``already`` written) that the
    file-size limit (``ulimit -f``) or the free space of its disk cannot hold. HDF5 cannot recover
    from a write that fails half way (it may crash closing the file), so the check comes first; a
    write that still fails is caught by :func:`atomic_output`."""
    need = max(int(n_bytes), MIN_OUTPUT_BYTES)
    soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    if soft != resource.RLIM_INFINITY and already + need > soft:
        raise OutputError(
            f"{out}: needs about {(already + need) / 2**20:.1f} MiB, but the file-size limit "
            f"(ulimit -f) is {soft / 2**20:.1f} MiB; raise the limit or write a shorter record"
        )
    parent = out.parent if str(out.parent) else Path(".")
    try:
        st = os.statvfs(parent)
    except OSError:
        return  # a file system without statvfs: the write itself reports a full disk
    free = st.f_bavail * st.f_frsize
    if need > free:
        raise OutputError(
            f"{out}: needs about {need / 2**20:.1f} MiB, but {parent} has {free / 2**20:.1f} MiB free; "
            "free some space or write elsewhere"
        )


#: Largest process id Linux hands out (pid_max's ceiling): a longer number in a name is not a pid.
MAX_PID = 4_194_304


def remove_stale_temporaries(out) -> None:
    """Remove temporary files of earlier runs towards ``out`` whose process is gone (killed with
    SIGKILL, or a machine that lost power): the names carry the writer's process id."""
    out = Path(out)
    parent = out.parent if str(out.parent) else Path(".")
    for tmp in parent.glob(f".{out.name}.*.tmp"):
        parts = tmp.name[len(out.name) + 2 :].split(".")
        if not parts or not parts[0].isdigit() or int(parts[0]) > MAX_PID:
            continue  # another program's file, or a name from before the pid was written into it
        pid = int(parts[0])
        if pid == os.getpid():
            continue
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            if tmp.is_dir() and not tmp.is_symlink():  # an output that is a folder (atomic_folder_output)
                shutil.rmtree(tmp, ignore_errors=True)
            with contextlib.suppress(OSError):
                tmp.unlink()
        except OSError:
            pass  # alive, under another user


def remove_stale_temporaries_below(folder) -> None:
    """:func:`remove_stale_temporaries` for every output in ``folder`` and the folders below it (a
    chain's folder, a plots folder: the outputs of a record that was stopped while writing there)."""
    folder = Path(folder)
    if not folder.is_dir() or folder.is_symlink():
        return
    for tmp in folder.rglob(".*.tmp"):
        name = tmp.name[1:].split(".")
        # .NAME.PID.RANDOM.tmp: the output's name is what comes before the pid (the random part may be
        # digits too: every split is tried, and only a dead writer's file of that name is removed)
        for k in range(1, len(name) - 1):
            if name[k].isdigit():
                remove_stale_temporaries(tmp.parent / ".".join(name[:k]))


#: The errors of a write that ran out of room.
NO_ROOM = (errno.EFBIG, errno.ENOSPC, errno.EDQUOT)


def _write_failed(out: Path, exc: OSError) -> OutputError:
    hint = ": a file-size limit (ulimit -f), a full disk or a quota" if exc.errno in NO_ROOM else ""
    return OutputError(f"{out}: cannot be written ({exc.strerror or exc}){hint}; nothing was written")


@contextlib.contextmanager
def atomic_output(
    path, *, inputs=(), force: bool = False, suffix: str = ".tmp", expected_bytes: int = 0, interrupted: bool = False
):
    """Yield a temporary path next to ``path``; rename it to ``path`` on success.

    After a signal (SIGINT, SIGTERM) or with the thread's work given up (:data:`ABANDONED`), the
    file is discarded instead of published, unless ``interrupted``: bookkeeping of the work done
    (a batch's manifest) that is wanted most then.

    On any exception the temporary file is removed and ``path`` is untouched. ``expected_bytes``:
    about how large the output will be (:func:`check_room` refuses it first if it cannot fit). An
    ``OSError`` of a write that ran out of room (a full disk, a file-size limit, a quota), or of
    the rename, becomes an :class:`~sizefx.errors.OutputError` naming ``path``, never the
    temporary file; other errors raised in the ``with`` block (an input's) pass unchanged.
    """
    out = check_output_path(path, inputs=inputs, force=force)
    check_room(out, expected_bytes)
    remove_stale_temporaries(out)
    try:
        fd, tmp = tempfile.mkstemp(
            prefix=f".{out.name}.{os.getpid()}.", suffix=suffix, dir=out.parent if str(out.parent) else "."
        )
    except OSError as exc:
        raise _write_failed(out, exc) from None
    os.close(fd)
    tmp_path = Path(tmp)

    def discard():
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()

    yield from _written(out, tmp_path, discard, interrupted)
    try:
        with open(tmp_path, "rb+") as fh:
            os.fsync(fh.fileno())
        # mkstemp creates 0600; an output gets the permissions any new file would (umask applied)
        os.chmod(tmp_path, 0o666 & ~_umask())
        os.replace(tmp_path, out)
    except OSError as exc:
        discard()
        raise _write_failed(out, exc) from None
    except BaseException:
        discard()
        raise


def _written(out: Path, tmp: Path, discard, interrupted: bool = False):
    """The body of :func:`atomic_output` and :func:`atomic_folder_output`: yield ``tmp`` to the writer;
    on its exception, ``discard()`` and re-raise (a write that ran out of room as an
    :class:`~sizefx.errors.OutputError` naming ``out``; other errors, an input's, as they are); after a
    signal whose exception was swallowed, or with the thread's work given up by whoever asked for it,
    ``discard()`` and raise :class:`~sizefx.errors.Interrupted`, unless ``interrupted`` (bookkeeping
    that must be published even then)."""
    try:
        yield tmp
    except OSError as exc:
        discard()
        if exc.errno in NO_ROOM:
            raise _write_failed(out, exc) from None
        raise
    except BaseException:
        discard()
        raise
    if INTERRUPTED["signum"] is not None and not interrupted:
        discard()
        raise Interrupted(INTERRUPTED["signum"])
    if threading.get_ident() in ABANDONED and not interrupted:
        discard()
        raise Interrupted(signal.SIGTERM)


def check_output_folder_replace(
    path, *, inputs=(), force: bool = False, replaceable=None, what: str = "folder"
) -> Path:
    """Refuse an output that is a folder written whole (a ROS 2 bag) where it cannot go: over a file
    (an input or not), over an existing folder without ``force``, or with ``force`` over a folder
    that holds one of ``inputs`` or that ``replaceable(folder)`` does not accept as a ``what`` (so
    that ``--force`` never deletes a folder of other files); and its folder must be writable."""
    out = Path(path)
    for inp in inputs:
        if inp is not None and out.exists() and Path(inp).exists() and os.path.samefile(out, inp):
            raise OutputError(f"{out}: output would overwrite the input {inp}; choose another output name")
    if out.exists() or out.is_symlink():
        if not out.is_dir() or out.is_symlink():
            raise OutputError(f"{out}: output exists and is not a folder; a {what} is a folder: choose another name")
        if not force:
            raise OutputError(f"{out}: output exists; pass --force to replace it, or choose another name")
        for inp in inputs:
            if inp is not None and Path(inp).resolve().is_relative_to(out.resolve()):
                raise OutputError(f"{out}: output folder holds the input {inp}; choose another output name")
        if replaceable is not None and not replaceable(out):
            raise OutputError(
                f"{out}: output exists and is not a {what}; --force replaces only a {what}: choose another name"
            )
    _require_writable_parent(out)
    return out


@contextlib.contextmanager
def atomic_folder_output(
    path, *, inputs=(), force: bool = False, replaceable=None, what: str = "folder", expected_bytes: int = 0
):
    """Yield a path for a new folder (not created yet: the writer makes it) beside ``path``; rename
    it to ``path`` on success. :func:`atomic_output` for an output that is a folder of files.

    Pre-flight by :func:`check_output_folder_replace`. With ``force`` and an existing ``path``, the old
    folder is moved aside, the new one renamed into place, and the old one removed, so that ``path``
    never holds a half-written folder. On any exception, after a signal, or with the thread's work
    given up, the temporary folder is removed and ``path`` is untouched.
    """
    out = check_output_folder_replace(path, inputs=inputs, force=force, replaceable=replaceable, what=what)
    check_room(out, expected_bytes)
    remove_stale_temporaries(out)
    parent = out.parent if str(out.parent) else Path(".")
    try:
        holder = Path(tempfile.mkdtemp(prefix=f".{out.name}.{os.getpid()}.", suffix=".tmp", dir=parent))
    except OSError as exc:
        raise _write_failed(out, exc) from None
    new = holder / out.name  # the folder's own name inside: a writer may name its files after it

    def discard():
        shutil.rmtree(holder, ignore_errors=True)

    yield from _written(out, new, discard)
    try:
        if not new.is_dir():
            raise OSError(errno.ENOENT, "the writer made no folder")
        for f in new.rglob("*"):
            if f.is_file():
                with open(f, "rb+") as fh:
                    os.fsync(fh.fileno())
        os.chmod(new, 0o777 & ~_umask())
        old = holder / ".replaced"
        if out.exists():
            os.rename(out, old)
        try:
            os.rename(new, out)
        except OSError:
            if old.exists():
                os.rename(old, out)
            raise
    except OSError as exc:
        discard()
        raise _write_failed(out, exc) from None
    except BaseException:
        discard()
        raise
    discard()
