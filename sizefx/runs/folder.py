"""A campaign's folder, as a batch (:mod:`sizefx.batch`) and a chain (:mod:`sizefx.chain`) both keep
it: the records its inputs name (files, folders and globs expanded and checked: :func:`expand_inputs`),
the files its options name, each read once by its own reader before any record or stage runs
(:func:`check_option_files`), the output folder checked against what is read and made
(:func:`check_out_dir`, :func:`make_out_dir`), and its lock, held while one writes there
(:func:`folder_lock`).

Everything here is refused in one line (:class:`~sizefx.errors.ConfigError`) before anything is
written. What a batch alone checks (the paths each record writes, the records' output names, the
partners paired with them) is :mod:`sizefx.batch.inputs`'s.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import fnmatch
import os
import stat
from pathlib import Path

from ..errors import ConfigError
from ..io.files import file_kind, regular_file

__all__ = [
    "RECORD_SUFFIXES",
    "GLOB_MAX_ENTRIES",
    "expand_inputs",
    "check_option_files",
    "resolve_path",
    "check_out_dir",
    "make_out_dir",
    "LOCK_NAME",
    "folder_lock",
]

#: What a folder given as an input contributes: its telemetry files (not recursively: a campaign's
#: folder of records; give a glob such as ``runs/**/*.h5`` for a tree).
RECORD_SUFFIXES = (".h5", ".hdf5")
#: Glob characters: an input with one of them is a pattern, not a path.
_GLOB = set("*?[")


#: Directory entries a glob may visit before it is refused: a tree this large is not a campaign's
#: folder, and a walk of it would run for minutes before anything is checked.
GLOB_MAX_ENTRIES = 1_000_000


def _glob(pattern: str) -> list[Path]:
    """The regular files ``pattern`` matches: ``*``, ``?`` and ``[...]`` within a name, ``**`` for any
    number of folders. As the shell's globs, names that begin with a dot match only a pattern that
    does, and folders that cannot be read are passed over.

    Unlike :func:`glob.glob`, a ``**`` never descends into a link to a folder: a link back to a parent
    would make the walk endless, and a link elsewhere would take it out of the tree the pattern names.
    (A link named by a pattern's own component, ``runs/*/imu.h5``, is followed: each component goes
    one level down.) A walk of more than :data:`GLOB_MAX_ENTRIES` entries is refused."""
    parts = Path(pattern).parts
    first = next((k for k, part in enumerate(parts) if _GLOB & set(part)), len(parts))
    root = Path(*parts[:first]) if first else Path(".")
    rest = parts[first:]
    if rest and rest[-1] == "**":  # ``runs/**``: every file below, as ``runs/**/*``
        rest = (*rest, "*")
    found: list[Path] = []
    seen: set[tuple[int, int, int]] = set()
    visited = 0
    stack = [(root, 0)]
    while stack:
        folder, k = stack.pop()
        try:
            info = os.stat(folder)
        except OSError:
            continue
        key = (info.st_dev, info.st_ino, k)
        if key in seen:  # reached twice (``**/**``, a bind mount): walked once
            continue
        seen.add(key)
        part, last = rest[k], k == len(rest) - 1
        if part == "**":
            stack.append((folder, k + 1))  # ``**`` matches no folder at all, too
        try:
            with os.scandir(folder) as entries:
                for entry in entries:
                    visited += 1
                    if visited > GLOB_MAX_ENTRIES:
                        raise ConfigError(
                            f"{pattern}: the pattern walks more than {GLOB_MAX_ENTRIES:,} files and folders; "
                            "narrow it to the campaign's folder"
                        )
                    name = entry.name
                    if part == "**":
                        if not name.startswith(".") and entry.is_dir(follow_symlinks=False):
                            stack.append((Path(entry.path), k))
                        continue
                    if name.startswith(".") and not part.startswith("."):
                        continue
                    if not fnmatch.fnmatchcase(name, part):
                        continue
                    if last:
                        if entry.is_file():  # a regular file, links followed: FIFOs and devices are left out
                            found.append(Path(entry.path))
                    elif entry.is_dir():
                        stack.append((Path(entry.path), k + 1))
        except OSError:  # a folder that cannot be read: passed over, as the shell does
            continue
    return sorted(found)


def expand_inputs(inputs) -> list[Path]:
    """The records the inputs name, resolved, in a stable order (sorted by path): each file as
    given; each folder's ``*.h5``/``*.hdf5`` files; each glob's matches (:func:`_glob`; ``**``
    recursive, without following links to folders).

    Refused in one line (:class:`~sizefx.errors.ConfigError`): no inputs, or an empty one; a path
    that does not exist; anything but a regular file or a folder (a FIFO, a device: it would never
    end); a folder that cannot be read or holds no record; a glob that matches nothing; the same
    record twice (also through another spelling or a link)."""
    if not inputs:
        raise ConfigError("no inputs: give record files, folders of them, or globs (e.g. 'runs/*.h5')")
    records: dict[Path, str] = {}
    for given in inputs:
        text = str(given)
        if not text.strip():
            raise ConfigError("an empty input (''): give record files, folders of them, or globs")
        if _GLOB & set(text):
            matches = _glob(text)
            if not matches:
                raise ConfigError(
                    f"{text}: the pattern matches no file; check it (quote it so the shell does not expand it first)"
                )
        else:
            path = Path(text)
            if not path.exists():
                raise ConfigError(f"{path}: no such file or folder; check the path")
            if path.is_dir():
                if not os.access(path, os.R_OK | os.X_OK):
                    raise ConfigError(f"{path}: the folder cannot be read (permissions); fix them or leave it out")
                matches = sorted(p for p in path.iterdir() if p.suffix.lower() in RECORD_SUFFIXES and p.is_file())
                if not matches:
                    raise ConfigError(
                        f"{path}: the folder holds no record ({', '.join(RECORD_SUFFIXES)}); give the files or a glob"
                    )
            else:
                matches = [regular_file(path)]
        for match in matches:
            regular_file(match)  # a glob's or a folder's match may have changed since it was listed
            resolved = match.resolve()
            if resolved in records:
                raise ConfigError(f"{match}: given twice (also as {records[resolved]}); each record once")
            records[resolved] = str(match)
    return sorted(records)


def _option_readers() -> dict:
    """Option -> the reader that owns its file, imported when an option names a file (the readers load
    NumPy, the schemas and, for a model, Numba)."""

    def load_model(path):
        from ..correct import load_model

        return load_model(path)

    def levers(name):
        def read(path):
            from .. import levers

            return getattr(levers, name)(path)

        return read

    return {"--levers": levers("read_levers"), "--nominal": levers("nominal_levers"), "--model": load_model}


def check_option_files(option_files: dict) -> None:
    """The files the options name (``{"--levers": path, ...}``, or a chain's ``{"navigate --levers":
    path, ...}``), each read once by its own reader before any record runs: a missing, unreadable or
    invalid one is the whole run's fault, refused in the reader's one line (ConfigError, exit 2)
    instead of once per record. Other files (records, ``--against``, ``--reference``) are only
    pre-flighted here; their contents are judged with their records."""
    from ..stage import preflight

    preflight(inputs=option_files, outputs={})
    readers = _option_readers()
    for option, path in option_files.items():
        reader = readers.get(str(option).split()[-1]) if option else None
        if reader is not None and path:
            reader(path)


def resolve_path(path, what: str) -> Path:
    """``path`` made absolute with every link followed (a new path's existing part), or a one-line
    refusal naming ``what`` (a link loop)."""
    try:
        return Path(path).resolve()
    except (OSError, RuntimeError) as exc:  # RuntimeError: Python 3.11's "Symlink loop"
        raise ConfigError(f"{path}: {what} cannot be resolved ({_one_line(exc)}); check its links") from None


def check_out_dir(out_dir, inputs, records) -> Path:
    """The output folder (resolved), refused in one line when it cannot hold a batch's (or a chain's)
    outputs: empty, a file, a link loop, in a folder that does not exist or cannot be written; an
    input folder or inside one (a re-run would take its outputs for records); or a folder holding one
    of the ``records`` (the files the batch reads), however they were named (a glob the shell
    expanded included). What each record of a batch will write is checked later, path by path
    (``sizefx.batch.inputs.check_writes``)."""
    text = "" if out_dir is None else str(out_dir)
    if not text.strip():
        raise ConfigError("--out '': give the folder for the outputs (it is made if new)")
    out = resolve_path(text, "--out")
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{out_dir}: --out exists and is not a folder; give a folder (it is made if new)")
    folder = out if out.exists() else out.parent
    if not folder.is_dir():
        raise ConfigError(f"{out_dir}: --out's parent folder does not exist; make it first")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ConfigError(f"{out_dir}: --out cannot be written in {folder} (permissions); give another folder")
    for given in inputs:
        text = str(given)
        folder = Path(text.split("*")[0].split("?")[0].split("[")[0] or ".") if _GLOB & set(text) else Path(text)
        if folder.is_dir():
            folder = folder.resolve()
            if out == folder or folder in out.parents:
                raise ConfigError(
                    f"{out_dir}: --out is inside the input folder {given}; a re-run would read the "
                    "outputs as records: put it elsewhere"
                )
    for record in records:
        record = Path(record).resolve()
        if record == out:
            raise ConfigError(f"{out_dir}: --out is one of the inputs; give a new folder")
        if out in record.parents:
            raise ConfigError(
                f"{out_dir}: --out holds the input {record}; outputs and records would mix (a later glob "
                "would take outputs for records): give the outputs a folder of their own"
            )
    return out


def make_out_dir(out: Path) -> Path:
    """Make the output folder ``out`` (checked by :func:`check_out_dir`) if it is new, or refuse in one
    line when it cannot be made (a file system that refuses it: ``/proc``, a read-only mount)."""
    try:
        out.mkdir(exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"{out}: --out cannot be made ({exc.strerror or exc}); give another folder") from None
    if not out.is_dir():
        raise ConfigError(f"{out}: --out is not a folder; give a folder")
    return out


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


#: The lock file in a batch's or a chain's folder, held while it writes there.
LOCK_NAME = ".sizefx.lock"


@contextlib.contextmanager
def folder_lock(out_dir):
    """Hold ``out_dir``'s lock (an advisory ``flock`` on :data:`LOCK_NAME`) while a batch or a chain
    writes there: a second one given the same folder is refused in one line instead of interleaving
    its outputs and manifest with the first's. Released when the process ends, however it ends.
    (``flock`` binds processes on one machine and on most local file systems; not across NFS clients.)

    The lock file is opened without following a link (``O_NOFOLLOW``) and must be a regular file:
    a link planted there (to a record, say) is refused, never written through; so are a folder, a
    FIFO or a device of that name."""
    path = Path(out_dir) / LOCK_NAME
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC, 0o666)
    except OSError as exc:
        what = "a link" if exc.errno == errno.ELOOP else (exc.strerror or str(exc))
        raise ConfigError(
            f"{path}: the batch's lock file cannot be opened ({what}); remove it (sizefx makes its own)"
        ) from None
    info = os.fstat(fd)
    if not stat.S_ISREG(info.st_mode):
        os.close(fd)
        raise ConfigError(
            f"{path}: the batch's lock file is {file_kind(info.st_mode)}; remove it (sizefx makes its own)"
        )
    handle = os.fdopen(fd, "r+")
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = handle.read(200).strip() or "another process"
            raise ConfigError(
                f"{out_dir}: another sizefx batch or run is writing into this folder ({holder}); "
                "wait for it to finish or give another --out"
            ) from None
        handle.seek(0)
        handle.truncate()
        handle.write(f"pid {os.getpid()}")
        handle.flush()
        yield
    finally:
        handle.close()
